"""Shared fixtures of lumo's Python tests.

The tests run from any folder; the repository's scenes are found from this file. Tests that
compare with the `lumo` command need its binary: `LUMO_BIN` (set by tests/python.rs, which runs
this suite under `cargo test`), else `target/release/lumo` or `target/debug/lumo`. Without one
they skip, unless `LUMO_REQUIRE_PYTHON=1`, which turns the skip into a failure.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell.json"


def small(width: int = 32, height: int = 24) -> dict:
    """Overrides that make the Cornell box small enough for a test."""
    return {"image.width": width, "image.height": height}


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def cornell():
    import lumo

    return lumo.load(CORNELL, small())


@pytest.fixture(scope="session")
def lumo_bin() -> Path:
    candidates = [os.environ.get("LUMO_BIN")]
    candidates += [str(ROOT / "target" / p / "lumo") for p in ("release", "debug")]
    candidates.append(shutil.which("lumo"))
    for c in candidates:
        if c and Path(c).is_file() and os.access(c, os.X_OK):
            return Path(c)
    message = "no lumo binary (set LUMO_BIN, or cargo build --bin lumo)"
    if os.environ.get("LUMO_REQUIRE_PYTHON") == "1":
        pytest.fail(message)
    pytest.skip(message)


@pytest.fixture
def run_cli(lumo_bin):
    """Runs `lumo ARGS...` from the repository's root; returns the completed process."""

    def run(*args: str, check: bool = True) -> subprocess.CompletedProcess:
        p = subprocess.run(
            [str(lumo_bin), *map(str, args)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
        if check and p.returncode != 0:
            raise AssertionError(f"lumo {' '.join(map(str, args))} failed:\n{p.stderr}")
        return p

    return run
