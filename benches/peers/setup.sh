#!/usr/bin/env bash
# Installs everything the peer benchmarks need, idempotently, into benches/peers/.venv.
#
#   bash benches/peers/setup.sh
#
# - Debian libllvm19 (for Mitsuba's llvm_ad_rgb variant; Dr.Jit loads libLLVM at run time).
#   Installed with apt-get when available and we are root; otherwise Mitsuba falls back to
#   scalar_rgb (the scripts detect this and say so).
# - PyPI: mitsuba, bpy (Blender as a Python module, 5.0.1 has CPython 3.11 wheels), embreex,
#   numpy, OpenEXR.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV="$HERE/.venv"
PY="${PYTHON:-python3.11}"
command -v "$PY" >/dev/null 2>&1 || PY=python3

# --- Debian: libllvm19 --------------------------------------------------------------------
if ! ldconfig -p 2>/dev/null | grep -q 'libLLVM.so.19\|libLLVM-19'; then
    if command -v apt-get >/dev/null 2>&1; then
        SUDO=""
        if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
        if $SUDO apt-get install -y --no-install-recommends libllvm19 >/dev/null 2>&1 \
           || { $SUDO apt-get update >/dev/null && $SUDO apt-get install -y --no-install-recommends libllvm19; }; then
            echo "setup: installed libllvm19"
        else
            echo "setup: WARNING: could not install libllvm19; Mitsuba will use scalar_rgb" >&2
        fi
    else
        echo "setup: WARNING: no apt-get; Mitsuba llvm_ad_rgb needs libLLVM (set DRJIT_LIBLLVM_PATH)" >&2
    fi
else
    echo "setup: libLLVM 19 already present"
fi

# --- Python venv --------------------------------------------------------------------------
if [ ! -x "$VENV/bin/python" ]; then
    "$PY" -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install --quiet --upgrade pip
# Pinned to versions measured in README.md; bump deliberately.
"$VENV/bin/python" -m pip install --quiet \
    "numpy==1.26.4" \
    "OpenEXR==3.5.3" \
    "mitsuba==3.9.1" \
    "bpy==5.0.1" \
    "embreex==4.4.0.post1" \
    "matplotlib==3.11.2"
"$VENV/bin/python" - <<'PY'
import importlib
for m in ("numpy", "OpenEXR", "mitsuba", "bpy", "embreex", "matplotlib"):
    mod = importlib.import_module(m)
    version = getattr(mod, "__version__", None) or mod.app.version_string  # bpy has no __version__
    print(f"setup: {m} {version}")
PY
echo "setup: done; run scripts with $VENV/bin/python"
