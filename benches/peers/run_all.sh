#!/usr/bin/env bash
# Runs every peer benchmark in sequence (one at a time: they all use every core) and the
# comparison, with every peer at its best unbiased settings: Mitsuba 3 with its two stratified
# samplers (ldsampler, multijitter; the independent sampler of the built-in scene only as a
# labelled extra row), Cycles with Blender's default sampling pattern, lumo with its default
# (Owen-scrambled Sobol); no clamping anywhere, the same depth. Assumes setup.sh has run and
# target/release/lumo is built. The equal-error target is Mitsuba ldsampler's 64-spp error.
# LUMO_PEERS_REPEATS=N (default 1) times every image of every renderer N times (same seed, same
# image) and keeps the fastest.
#
#   bash benches/peers/setup.sh && cargo build --release && bash benches/peers/run_all.sh
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PY="$HERE/.venv/bin/python"
cd "$HERE"
load() { echo "== $(date -u +%FT%TZ) load: $(cut -d' ' -f1-3 /proc/loadavg)"; }
rm -rf out/mitsuba-* out/cycles out/lumo
REPEATS=(--repeats "${LUMO_PEERS_REPEATS:-1}")
load
# ldsampler needs square powers of two; the same ladder for the other Mitsuba samplers.
"$PY" mitsuba_cornell.py --variant llvm_ad_rgb --sampler ldsampler --spp 4,16,64,256 "${REPEATS[@]}"
load
"$PY" mitsuba_cornell.py --variant llvm_ad_rgb --sampler multijitter --spp 4,16,64,256 "${REPEATS[@]}"
load
"$PY" mitsuba_cornell.py --variant llvm_ad_rgb --sampler independent --spp 4,16,64,256 "${REPEATS[@]}"
load
"$PY" cycles_cornell.py "${REPEATS[@]}"
load
"$PY" lumo_cornell.py --time-regex 'spp in ([0-9.]+) s' "${REPEATS[@]}"
load
"$PY" compare.py --target-peer mitsuba-llvm-ldsampler --target-spp 64
load
# The ray-throughput table against Embree (LUMO_PEERS_EMBREE=0 skips it).
if [ "${LUMO_PEERS_EMBREE:-1}" = 1 ]; then
    "$PY" embree_rays.py
    load
fi
