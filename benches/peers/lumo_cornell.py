"""Runs lumo over the spp ladder and writes a run folder that compare.py reads like any peer's.

    .venv/bin/python lumo_cornell.py [--lumo target/release/lumo] [--scene scenes/cornell.json]
        [--spp 1,4,16,64,256] [--time-regex 'spp in ([0-9.]+) s']

For each rung it runs ``<lumo> render <scene> -o out/lumo/lumo_<spp>spp.exr --spp <spp>`` (the
command can be changed with --command, a template with {lumo}, {scene}, {out}, {spp}, {seed}),
after one untimed warm-up run at 1 spp; each rung renders --seeds images (default 3) with seeds
spp, spp + 1000, spp + 2000 (every renderer's), each run --repeats times (default 1), and the
fastest time is kept (compare.py takes the root of the images' mean squared error as the
rung's RMSE). The time recorded is

- with --time-regex: the number captured by the regex's first group in lumo's stdout+stderr
  (use this when lumo prints its pure render time, comparable to the peers' render-only times;
  lumo's summary line reads "rendered 256x256 at N spp in T s: ...", so
  ``--time-regex 'spp in ([0-9.]+) s'``);
- otherwise the wall time of the whole process, which also counts process start-up and scene
  loading, i.e. slightly favours the peers. The CSV does not record which of the two was used:
  say so when quoting the numbers.

The CPU time recorded (``cpu_seconds``) is always that of the whole lumo process.

Output: ``out/lumo/timings.csv`` (peer,spp,seconds,samples_per_second,exr,load1,cpu_seconds) +
the EXRs.
"""

from __future__ import annotations

import argparse
import re
import resource
import shlex
import subprocess
import sys
import time
from pathlib import Path

import common


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run(cmd: list[str]) -> tuple[float, float, str]:
    """Runs lumo; returns (wall seconds, CPU seconds of the child, its stdout+stderr)."""
    c0, t0 = _children_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - c0
    out = proc.stdout + proc.stderr
    if proc.returncode != 0:
        raise SystemExit(f"`{shlex.join(cmd)}` failed with exit code {proc.returncode}:\n{out}")
    return wall, cpu, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--lumo", default=str(common.REPO_ROOT / "target" / "release" / "lumo"))
    ap.add_argument("--scene", default=str(common.REPO_ROOT / "scenes" / "cornell.json"))
    ap.add_argument("--command",
                    default="{lumo} render {scene} -o {out} --spp {spp} --seed {seed}")
    ap.add_argument("--spp", default=",".join(map(str, common.DEFAULT_LADDER)))
    ap.add_argument("--time-regex", help="regex whose group 1 is lumo's render time in seconds")
    ap.add_argument("--seeds", type=int, default=common.DEFAULT_SEEDS,
                    help="images per rung, with seeds spp + 1000 k (time: the fastest)")
    ap.add_argument("--repeats", type=int, default=1,
                    help="run each image this many times (same seed) and keep the fastest")
    ap.add_argument("--peer", default="lumo")
    ap.add_argument("--out", type=Path, default=common.HERE / "out")
    args = ap.parse_args()
    ladder = common.parse_ladder(args.spp)
    folder = args.out / args.peer
    folder.mkdir(parents=True, exist_ok=True)
    pattern = re.compile(args.time_regex) if args.time_regex else None

    def command(spp: int, out: Path, seed: int) -> list[str]:
        return shlex.split(args.command.format(lumo=shlex.quote(args.lumo),
                                               scene=shlex.quote(args.scene),
                                               out=shlex.quote(str(out)), spp=spp, seed=seed))

    warm = folder / "warmup.exr"
    wall, _, _ = run(command(1, warm, 999_983))
    warm.unlink(missing_ok=True)
    print(f"warm-up (1 spp, not counted): {wall:.2f} s wall")

    rows = []
    for spp in ladder:
        names = []
        seconds = cpu = float("inf")
        for k, seed in enumerate(common.rung_seeds(spp, args.seeds)):
            names.append(common.seeded_exr(args.peer, spp, k))
            for _ in range(args.repeats):
                wall, cpu1, text = run(command(spp, folder / names[-1], seed))
                if pattern:
                    m = pattern.search(text)
                    if not m:
                        raise SystemExit(f"--time-regex {args.time_regex!r} matched nothing in "
                                         f"lumo's output:\n{text}")
                    wall = float(m.group(1))
                seconds, cpu = min(seconds, wall), min(cpu, cpu1)
        rows.append(common.timing_row(args.peer, spp, seconds, ";".join(names), cpu))
        print(f"{args.peer}: {spp:5d} spp  {seconds:8.3f} s "
              f"({'reported' if pattern else 'wall'}; load {common.load1():.2f})", flush=True)
    common.write_timings(folder / "timings.csv", rows)
    print(f"wrote {folder / 'timings.csv'}; now run compare.py")


if __name__ == "__main__":
    sys.exit(main())
