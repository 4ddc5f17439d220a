"""Small helpers shared by the peer scripts: EXR I/O, the spp ladder, timing CSVs, machine load."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent.parent
DEFAULT_LADDER = (1, 4, 16, 64, 256)
REFERENCE_EXR = REPO_ROOT / "tests" / "reference" / "cornell_mitsuba_4096.exr"

#: Columns of every peer's ``timings.csv``. ``seconds`` is wall time; ``cpu_seconds`` the CPU
#: time (user + system, all threads) of the same render, which a busy machine inflates much less
#: than wall time. ``exr`` is relative to the CSV's folder. ``load1`` is the 1-minute load
#: average when the rung finished (the machine is shared).
TIMING_COLUMNS = ("peer", "spp", "seconds", "samples_per_second", "exr", "load1", "cpu_seconds")


def parse_ladder(text: str) -> list[int]:
    """'1,4,16' -> [1, 4, 16]; rejects non-positive or malformed entries with a clear message."""
    try:
        ladder = [int(s) for s in text.split(",") if s.strip()]
    except ValueError as e:
        raise SystemExit(f"--spp: expected comma-separated integers like 1,4,16, got {text!r}") from e
    if not ladder or any(n <= 0 for n in ladder):
        raise SystemExit(f"--spp: every sample count must be a positive integer, got {text!r}")
    return ladder


def load1() -> float:
    """1-minute load average (2 cores here: above ~2 means someone else is competing)."""
    return os.getloadavg()[0]


def write_exr(path: Path | str, rgb: np.ndarray, half: bool = False) -> None:
    """Writes an (H, W, 3) linear RGB image as a ZIP-compressed scanline EXR (float32 or half)."""
    import OpenEXR

    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] < 3:
        raise ValueError(f"{path}: expected an (H, W, 3) image, got shape {rgb.shape}")
    pixels = np.ascontiguousarray(rgb[:, :, :3].astype(np.float16 if half else np.float32))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with OpenEXR.File(header, {"RGB": pixels}) as f:
        f.write(str(path))


def read_exr(path: Path | str) -> np.ndarray:
    """Reads the RGB channels of an EXR as float64 (H, W, 3).

    Accepts plain R/G/B(/A) files (lumo, Mitsuba, Blender single-layer EXR) and layer-prefixed
    channel names such as ``ViewLayer.Combined.R`` (Blender multilayer), taking the first layer.
    """
    import OpenEXR

    if not Path(path).is_file():
        raise FileNotFoundError(f"{path}: EXR not found")
    with OpenEXR.File(str(path), separate_channels=True) as f:
        channels = {name: ch.pixels for name, ch in f.channels().items()}
    by_suffix: dict[str, np.ndarray] = {}
    for name in sorted(channels):
        suffix = name.rsplit(".", 1)[-1]
        by_suffix.setdefault(suffix, channels[name])
    missing = [c for c in "RGB" if c not in by_suffix]
    if missing:
        raise ValueError(
            f"{path}: no {'/'.join(missing)} channel(s); found {sorted(channels)}. "
            "Write linear RGB channels named R, G, B."
        )
    return np.stack([by_suffix[c].astype(np.float64) for c in "RGB"], axis=-1)


def write_timings(path: Path, rows: list[dict]) -> None:
    """Writes a peer's timings CSV (columns TIMING_COLUMNS)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=TIMING_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in TIMING_COLUMNS})


def timing_row(peer: str, spp: int, seconds: float, exr_name: str,
               cpu_seconds: float | None = None) -> dict:
    """One CSV row; samples/s counts camera samples (pixels x spp), not rays."""
    return {
        "cpu_seconds": "" if cpu_seconds is None else f"{cpu_seconds:.4f}",
        "peer": peer,
        "spp": spp,
        "seconds": f"{seconds:.4f}",
        "samples_per_second": f"{WIDTH_HEIGHT * spp / seconds:.1f}",
        "exr": exr_name,
        "load1": f"{load1():.2f}",
    }


WIDTH_HEIGHT = 256 * 256


SEED_STEP = 1000
"""A rung's k-th image is rendered with seed spp + SEED_STEP·k (every renderer the same seeds)."""

DEFAULT_SEEDS = 3
"""Images per rung: one seed's RMSE moves by a few per cent, which moves a time to equal error
twice as much."""


def rung_seeds(spp: int, count: int) -> list[int]:
    """The seeds of a rung's ``count`` images."""
    return [spp + SEED_STEP * k for k in range(count)]


def seeded_exr(peer: str, spp: int, k: int) -> str:
    """The file name of a rung's k-th image (the first keeps the one-image name)."""
    return f"{peer}_{spp}spp.exr" if k == 0 else f"{peer}_{spp}spp_seed{k}.exr"


def best_of(repeats: int, render):
    """Calls ``render()`` -> (result, wall seconds, CPU seconds) ``repeats`` times (same seed:
    same image, only the time varies); returns the first result with the least wall and CPU
    time seen."""
    result, dt, cpu = render()
    for _ in range(repeats - 1):
        _, dt2, cpu2 = render()
        dt, cpu = min(dt, dt2), min(cpu, cpu2)
    return result, dt, cpu


def print_rung(peer: str, spp: int, seconds: float, cpu: float) -> None:
    """One ladder rung's line: time, throughput, CPU time and the machine's load."""
    print(f"{peer}: {spp:5d} spp  {seconds:8.3f} s  {WIDTH_HEIGHT * spp / seconds / 1e6:6.2f} "
          f"M samples/s  cpu {cpu:8.3f} s  (load {load1():.2f})", flush=True)
