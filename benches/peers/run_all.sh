#!/usr/bin/env bash
# Runs every peer benchmark in sequence (one at a time: they all use every core) and the
# comparison. Assumes setup.sh has run. Extra arguments go to the two renderers (e.g. --spp 1,4).
#
#   bash benches/peers/setup.sh && bash benches/peers/run_all.sh
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PY="$HERE/.venv/bin/python"
cd "$HERE"
echo "== $(date -u +%FT%TZ) load: $(cut -d' ' -f1-3 /proc/loadavg)"
"$PY" mitsuba_cornell.py --variant llvm_ad_rgb "$@"
echo "== load: $(cut -d' ' -f1-3 /proc/loadavg)"
"$PY" mitsuba_cornell.py --variant scalar_rgb "$@"
echo "== load: $(cut -d' ' -f1-3 /proc/loadavg)"
"$PY" cycles_cornell.py "$@"
echo "== load: $(cut -d' ' -f1-3 /proc/loadavg)"
"$PY" compare.py
echo "== load: $(cut -d' ' -f1-3 /proc/loadavg)"
"$PY" embree_rays.py
echo "== $(date -u +%FT%TZ) load: $(cut -d' ' -f1-3 /proc/loadavg)"
