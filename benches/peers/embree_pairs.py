"""Rays against Embree in paired rounds: the ratio that survives a shared, noisy machine.

    cargo build --release --example embree_rays_count
    .venv/bin/python embree_pairs.py [--rounds 10] [--threads 1,2] [--sets icosphere:incoherent,...]

``embree_rays.py`` times Embree, then ``cargo bench`` times lumo a minute later; on this project's
shared 2-core machine the speed of a memory-bound ray set moves by x1.5 from one minute to the
next (other guests' use of the shared cache), so a ratio of two such figures can be off by as
much. Here each round times both back to back on the same rays, the order alternating between
rounds: Embree (``embree_rays.trace`` or ``trace_threads``, as in ``embree_rays.py``, best of 2)
and lumo (``examples/embree_rays_count.rs``: closest hit, best of 2 timed passes after one
untimed pass; with THREADS > 1 the rays in 4,096-ray chunks on a rayon pool). The per-round
ratios lumo / Embree are summarised by their median and range; M rays/s ranges are given too.

Needs the ray sets and Embree's hits of ``embree_rays.py`` in ``rays/`` (run it first). Prints a
Markdown table; the 1-minute load average of each set's rounds is in the last column.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import embree_rays as er

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts")
    ap.add_argument("--sets", default="bunny:coherent,bunny:incoherent,icosphere:coherent,"
                    "icosphere:incoherent", help="comma-separated MESH:KIND")
    ap.add_argument("--lumo", type=Path,
                    default=ROOT / "target" / "release" / "examples" / "embree_rays_count")
    args = ap.parse_args()
    if not args.lumo.exists():
        sys.exit(f"{args.lumo} is missing: cargo build --release --example embree_rays_count")
    env = dict(os.environ, LUMO_RAYS_DIR=str(er.RAYS_DIR))
    print("| mesh, rays | threads | Embree M rays/s | lumo M rays/s | lumo / Embree, median "
          "[range] of rounds | load |")
    print("|---|---:|---:|---:|---:|---:|")
    for spec in args.sets.split(","):
        mesh, kind = spec.split(":")
        files = {name: er.RAYS_DIR / f"{mesh}_{name}.npy"
                 for name in ("vertices", "indices", f"{kind}_origins", f"{kind}_dirs")}
        missing = [str(p) for p in files.values() if not p.exists()]
        if missing:
            sys.exit(f"missing {', '.join(missing)}: run embree_rays.py first")
        v, f = np.load(files["vertices"]), np.load(files["indices"])
        o, d = np.load(files[f"{kind}_origins"]), np.load(files[f"{kind}_dirs"])
        scene = er.make_scene(v, f)
        er.trace(scene, v[:1] * 0, np.array([[0, 0, 1]], dtype=np.float32))  # the BVH build
        for threads in (int(t) for t in args.threads.split(",")):
            def embree() -> float:
                best = 0.0
                for _ in range(2):
                    t0 = time.perf_counter()
                    if threads == 1:
                        er.trace(scene, o, d)
                    else:
                        er.trace_threads(scene, o, d, threads)
                    best = max(best, len(o) / (time.perf_counter() - t0) / 1e6)
                return best

            def lumo() -> float:
                out = subprocess.run([str(args.lumo), mesh, kind, str(len(o)), "2", str(threads)],
                                     capture_output=True, text=True, env=env, check=True).stdout
                passes = out.strip().splitlines()[-1].split(":", 1)[1].split()
                return max(float(p.split("/")[0]) for p in passes)

            e_all, l_all, ratios, loads = [], [], [], []
            for r in range(args.rounds):
                if r % 2:
                    lr = lumo()
                    er_ = embree()
                else:
                    er_ = embree()
                    lr = lumo()
                e_all.append(er_)
                l_all.append(lr)
                ratios.append(lr / er_)
                loads.append(os.getloadavg()[0])
            print(f"| {mesh}, {kind} | {threads} | {min(e_all):.2f}–{max(e_all):.2f} | "
                  f"{min(l_all):.2f}–{max(l_all):.2f} | **{statistics.median(ratios):.2f}** "
                  f"[{min(ratios):.2f}–{max(ratios):.2f}] | {min(loads):.1f}–{max(loads):.1f} |",
                  flush=True)


if __name__ == "__main__":
    main()
