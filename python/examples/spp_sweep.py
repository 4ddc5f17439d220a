"""Error against samples per pixel, for two sample sequences: a parameter sweep with lumo.

Renders a high-spp reference of a scene, then the scene at a ladder of sample counts with each
sampler (a scene override) and a few seeds, and measures each image's RMSE against the
reference. Writes the table as CSV and, when matplotlib is installed, a log-log plot with the
ideal 1/sqrt(spp) slope.

    python python/examples/spp_sweep.py scenes/cornell.json -o sweep
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

import lumo


def rmse(image: np.ndarray, reference: np.ndarray) -> float:
    return float(np.sqrt(np.mean((image.astype(np.float64) - reference) ** 2)))


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default="scenes/cornell.json")
    ap.add_argument("--size", type=int, default=128, help="image width and height")
    ap.add_argument("--spp", default="1,4,16,64,256", help="the sample-count ladder")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--seeds", type=int, default=3, help="renders per point (their mean)")
    ap.add_argument("-o", "--out", default="spp_sweep", help="folder for the CSV and plot")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    base = lumo.load(args.scene, {"image.width": args.size, "image.height": args.size})
    print(f"reference: {args.reference_spp} spp …", flush=True)
    reference = lumo.render(base, spp=args.reference_spp, seed=1 << 40).color.astype(np.float64)

    rows = []
    for sampler in ("sobol", "independent"):
        scene = base.with_overrides({"render.sampler": sampler})
        for spp in (int(s) for s in args.spp.split(",")):
            results = [lumo.render(scene, spp=spp, seed=seed) for seed in range(args.seeds)]
            row = {
                "sampler": sampler,
                "spp": spp,
                "rmse": float(np.mean([rmse(r.color, reference) for r in results])),
                "seconds": float(np.mean([r.stats.seconds for r in results])),
                "estimated_error": float(np.mean([r.stats.estimated_error for r in results])),
            }
            rows.append(row)
            print(f"{sampler:12} {spp:6} spp  RMSE {row['rmse']:.5f}  {row['seconds']:.3f} s")

    with open(out / "spp_sweep.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {out / 'spp_sweep.csv'}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (the CSV has the numbers)")
        return rows
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for sampler in ("sobol", "independent"):
        pts = [(r["spp"], r["rmse"]) for r in rows if r["sampler"] == sampler]
        ax.loglog(*zip(*pts), "o-", label=sampler)
    spp0, err0 = pts[0]
    ladder = np.array([p[0] for p in pts], dtype=float)
    ax.loglog(ladder, err0 * np.sqrt(spp0 / ladder), "k--", lw=1, label="1/√spp")
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel(f"RMSE against {args.reference_spp} spp")
    ax.set_title(Path(args.scene).name)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "spp_sweep.png", dpi=120)
    print(f"wrote {out / 'spp_sweep.png'}")
    return rows


if __name__ == "__main__":
    main()
