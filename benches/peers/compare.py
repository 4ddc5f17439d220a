"""Error of every peer's renders against the common reference; equal-spp and equal-error tables.

    .venv/bin/python compare.py [--runs out/mitsuba-llvm out/cycles out/lumo ...]
                                [--reference tests/reference/cornell_mitsuba_4096.exr]

A *run* is a folder holding ``timings.csv`` with at least the columns ``peer,spp,seconds``
(optionally ``samples_per_second,exr,load1,cpu_seconds``) plus the EXRs it names: column ``exr``
relative to the folder (several images of the rung, rendered with different seeds, separated by
``;``), or, when that column is missing or empty, ``<peer>_<spp>spp.exr``. Any renderer can
be added this way (see ``lumo_cornell.py`` for lumo). By default every folder under ``out/``
that has a ``timings.csv`` is a run.

Error metric: RMSE over all pixels and all three channels of linear radiance,
sqrt(mean((img - ref)^2)); also the relative MSE mean((img - ref)^2 / (ref^2 + 0.01)), averaged
over pixels and channels. A rung of several images: the root of their mean squared error (and
the mean of their relative MSEs).

Equal-error table: the target is the RMSE of ``--target-peer`` at ``--target-spp`` (default:
mitsuba-llvm at 64 spp). For each peer, the wall time to reach it is interpolated linearly in
log(time)-log(RMSE) between the two ladder rungs that bracket it (Monte Carlo error falls as
t^-1/2, a straight line in log-log); outside the ladder it is extrapolated from the nearest two
rungs and marked with '*'.

The same table is printed for CPU time (user + system of all threads) when every run has a
``cpu_seconds`` column: on a machine shared with other jobs it is far less inflated than wall
time (the peers' wall times assume they have all cores to themselves).

Equal-time table: the RMSE each peer reaches within the time budgets of --budgets, by the same
log-log interpolation along the ladder.

Writes ``results.csv`` (one row per run and rung) and prints the tables as Markdown.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import common


@dataclass
class Rung:
    peer: str
    spp: int
    seconds: float
    samples_per_second: float
    load1: str
    exr: list[Path]
    cpu_seconds: float = math.nan
    rmse: float = math.nan
    rel_mse: float = math.nan


def load_run(folder: Path) -> list[Rung]:
    path = folder / "timings.csv"
    if not path.is_file():
        raise SystemExit(f"{path}: not found; a run folder needs a timings.csv "
                         "(columns peer,spp,seconds[,samples_per_second,exr,load1])")
    rungs = []
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = {"peer", "spp", "seconds"} - set(reader.fieldnames or [])
        if missing:
            raise SystemExit(f"{path}: missing column(s) {sorted(missing)}; "
                             f"found {reader.fieldnames}")
        for line, row in enumerate(reader, start=2):
            try:
                spp = int(row["spp"])
                seconds = float(row["seconds"])
            except (TypeError, ValueError) as e:
                raise SystemExit(f"{path}:{line}: spp must be an integer and seconds a number "
                                 f"({e})") from e
            if spp <= 0 or not seconds > 0:
                raise SystemExit(f"{path}:{line}: spp and seconds must be positive")
            peer = row["peer"].strip()
            exr = (row.get("exr") or "").strip() or f"{peer}_{spp}spp.exr"
            sps = row.get("samples_per_second") or ""
            cpu = (row.get("cpu_seconds") or "").strip()
            rungs.append(Rung(peer, spp, seconds,
                              float(sps) if sps else common.WIDTH_HEIGHT * spp / seconds,
                              (row.get("load1") or "").strip(),
                              [folder / name.strip() for name in exr.split(";")],
                              float(cpu) if cpu else math.nan))
    if not rungs:
        raise SystemExit(f"{path}: no rows")
    return rungs


def errors(img: np.ndarray, ref: np.ndarray, where: Path) -> tuple[float, float]:
    if img.shape != ref.shape:
        raise SystemExit(f"{where}: image is {img.shape[1]}x{img.shape[0]}, the reference "
                         f"{ref.shape[1]}x{ref.shape[0]}; render at the reference's size")
    if not np.all(np.isfinite(img)):
        raise SystemExit(f"{where}: image has {np.count_nonzero(~np.isfinite(img))} NaN/inf "
                         "values")
    d2 = (img - ref) ** 2
    return float(np.sqrt(d2.mean())), float((d2 / (ref * ref + 0.01)).mean())


def time_to_error(rungs: list[Rung], target: float, cpu: bool = False) -> tuple[float, bool]:
    """Seconds (wall, or CPU if ``cpu``) to reach RMSE ``target`` by log-log interpolation;
    the flag is True if extrapolated."""
    pts = sorted(((r.cpu_seconds if cpu else r.seconds), r.rmse) for r in rungs)
    if len(pts) == 1:  # single rung: assume the Monte Carlo rate, error ~ t^-1/2
        t, e = pts[0]
        return t * (e / target) ** 2, True
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 >= target >= e1:
            return _loglog(t0, e0, t1, e1, target), False
    # Outside the ladder: extrapolate from the two rungs at the relevant end.
    (t0, e0), (t1, e1) = (pts[-2], pts[-1]) if target < pts[-1][1] else (pts[0], pts[1])
    return _loglog(t0, e0, t1, e1, target), True


def error_at_time(rungs: list[Rung], budget: float, cpu: bool = False) -> tuple[float, bool]:
    """RMSE reached after ``budget`` seconds (log-log interpolation); True if extrapolated."""
    pts = sorted(((r.cpu_seconds if cpu else r.seconds), r.rmse) for r in rungs)
    if len(pts) == 1:
        t, e = pts[0]
        return e * math.sqrt(t / budget), True
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if t0 <= budget <= t1:
            return _loglog(e0, t0, e1, t1, budget), False
    (t0, e0), (t1, e1) = (pts[-2], pts[-1]) if budget > pts[-1][0] else (pts[0], pts[1])
    return _loglog(e0, t0, e1, t1, budget), True


def _loglog(t0, e0, t1, e1, target) -> float:
    if e0 == e1:
        return t0
    s = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
    return math.exp(math.log(t0) + s * (math.log(t1) - math.log(t0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--runs", nargs="*", type=Path,
                    help="run folders (default: every folder under out/ with a timings.csv)")
    ap.add_argument("--reference", type=Path, default=common.REFERENCE_EXR)
    ap.add_argument("--target-peer", default="mitsuba-llvm")
    ap.add_argument("--target-spp", type=int, default=64)
    ap.add_argument("--budgets", default="0.5,2,8",
                    help="time budgets in seconds for the equal-time table (default 0.5,2,8)")
    ap.add_argument("--results", type=Path, default=common.HERE / "results.csv")
    args = ap.parse_args()

    try:
        budgets = [float(b) for b in args.budgets.split(",") if b.strip()]
    except ValueError as e:
        raise SystemExit(f"--budgets: expected comma-separated seconds, got {args.budgets!r}") from e
    if not budgets or any(b <= 0 for b in budgets):
        raise SystemExit(f"--budgets: every budget must be positive, got {args.budgets!r}")
    runs = args.runs
    if not runs:
        out = common.HERE / "out"
        runs = sorted(p for p in out.iterdir() if (p / "timings.csv").is_file()) \
            if out.is_dir() else []
    if not runs:
        raise SystemExit("no runs: render with mitsuba_cornell.py / cycles_cornell.py first, "
                         "or pass --runs FOLDER ...")
    ref = common.read_exr(args.reference)

    peers: dict[str, list[Rung]] = {}
    for folder in runs:
        for r in load_run(folder):
            each = [errors(common.read_exr(path), ref, path) for path in r.exr]
            r.rmse = math.sqrt(sum(rmse * rmse for rmse, _ in each) / len(each))
            r.rel_mse = sum(rel for _, rel in each) / len(each)
            peers.setdefault(r.peer, []).append(r)

    with open(args.results, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["peer", "spp", "seconds", "samples_per_second", "rmse", "rel_mse", "load1",
                    "cpu_seconds"])
        for peer, rungs in peers.items():
            for r in sorted(rungs, key=lambda r: r.spp):
                w.writerow([peer, r.spp, f"{r.seconds:.4f}", f"{r.samples_per_second:.1f}",
                            f"{r.rmse:.6f}", f"{r.rel_mse:.6f}", r.load1,
                            "" if math.isnan(r.cpu_seconds) else f"{r.cpu_seconds:.4f}"])

    print(f"reference: {args.reference}\n")
    print("Equal spp (RMSE of linear radiance vs the reference)\n")
    print("| peer | spp | seconds | M samples/s | RMSE | relMSE | CPU s | load |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for peer, rungs in peers.items():
        for r in sorted(rungs, key=lambda r: r.spp):
            print(f"| {peer} | {r.spp} | {r.seconds:.3f} | {r.samples_per_second / 1e6:.2f} | "
                  f"{r.rmse:.5f} | {r.rel_mse:.6f} | {r.cpu_seconds:.3f} | {r.load1} |")

    clocks = [("wall", False)]
    if all(not math.isnan(r.cpu_seconds) for rungs in peers.values() for r in rungs):
        clocks.append(("CPU (all threads)", True))
    for clock, cpu in clocks:
        print(f"\nEqual time, {clock}: RMSE reached within each budget; * = extrapolated\n")
        print("| peer | " + " | ".join(f"RMSE at {b:g} s" for b in budgets) + " |")
        print("|---|" + "---:|" * len(budgets))
        for peer, rungs in peers.items():
            cells = []
            for b in budgets:
                e, extra = error_at_time(rungs, b, cpu)
                cells.append(f"{e:.5f}{'*' if extra else ''}")
            print(f"| {peer} | " + " | ".join(cells) + " |")

    target_rungs = [r for r in peers.get(args.target_peer, []) if r.spp == args.target_spp]
    if not target_rungs:
        print(f"\n(no {args.target_peer} run at {args.target_spp} spp: no equal-error table)")
        return
    target = target_rungs[0].rmse
    names = list(peers)
    for clock, cpu in clocks:
        times = {peer: time_to_error(rungs, target, cpu) for peer, rungs in peers.items()}
        print(f"\nEqual error, {clock} time: seconds to reach RMSE {target:.5f} "
              f"({args.target_peer} at {args.target_spp} spp); * = extrapolated beyond the "
              "ladder\n")
        print("| peer | seconds | " + " | ".join(f"time ratio vs {n}" for n in names) + " |")
        print("|---|---:|" + "---:|" * len(names))
        for peer in names:
            t, extra = times[peer]
            ratios = " | ".join(f"{t / times[n][0]:.2f}" for n in names)
            print(f"| {peer} | {t:.3f}{'*' if extra else ''} | {ratios} |")
    print(f"\nwrote {args.results}")


if __name__ == "__main__":
    sys.exit(main())
