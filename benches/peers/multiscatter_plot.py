"""Plots and tabulates ``examples/microsurface_walk.rs``'s output: the Heitz et al. 2016 random
walk on the Smith GGX microsurface (ground truth) against lumo's Kulla-Conty lobe and Cycles'
albedo-scaled lobe.

    cargo run --release --example microsurface_walk target/microsurface_walk
    python3 benches/peers/multiscatter_plot.py [target/microsurface_walk] [docs/multiple-scattering]

Writes ``lobes.png`` (f cos θi in and out of the plane of incidence), ``albedo.png`` (directional
albedo of a gold conductor) into the output folder and prints the tables of
``docs/multiple-scattering.md`` (Markdown) on stdout. Needs numpy and matplotlib only.
"""

from __future__ import annotations

import csv
import math
import sys
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

N_MU = 16
N_PHI = 24


def read(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def lobes(rows: list[dict]) -> dict:
    """(alpha, mu_o) -> {column: array (N_MU, N_PHI)}."""
    out: dict = defaultdict(lambda: defaultdict(lambda: np.zeros((N_MU, N_PHI))))
    for r in rows:
        key = (r["alpha"], round(r["mu_o"], 6))
        for col in ("walk", "walk_ms", "lumo", "lumo_ms", "cycles", "cycles_ms", "single"):
            out[key][col][int(r["mu_bin"]), int(r["phi_bin"])] = r[col]
    return out


def l1(model: np.ndarray, truth: np.ndarray) -> float:
    """Relative L1 distance of two densities on equal-solid-angle bins: sum |m - t| / sum t."""
    return float(np.abs(model - truth).sum() / truth.sum())


def save(fig, path: Path) -> None:
    """Saves a figure as a palette PNG (a line plot needs few colours: a tenth of the bytes)."""
    from PIL import Image  # matplotlib depends on Pillow

    fig.savefig(path, dpi=90)
    plt.close(fig)
    Image.open(path).convert("RGB").quantize(colors=64).save(path, optimize=True)


def mu_centres() -> np.ndarray:
    return (np.arange(N_MU) + 0.5) / N_MU


def plot_lobes(data: dict, out: Path) -> None:
    keys = sorted(data)
    alphas = sorted({k[0] for k in keys})
    mus = sorted({k[1] for k in keys}, reverse=True)
    fig, axes = plt.subplots(len(alphas), len(mus), figsize=(4.0 * len(mus), 3.1 * len(alphas)),
                             squeeze=False)
    theta = np.degrees(np.arccos(mu_centres()))
    for i, a in enumerate(alphas):
        for j, mu in enumerate(mus):
            ax = axes[i][j]
            d = data[(a, mu)]
            # In the plane of incidence: φ bin 0 (the side of ωo, drawn at negative θi) and the
            # last φ bin (the mirror side, positive θi); out of the plane: the bins around 90°.
            side = N_PHI // 2
            x = np.concatenate([-theta, theta[::-1]])

            def plane(col: str) -> np.ndarray:
                return np.concatenate([d[col][:, 0], d[col][::-1, -1]])

            def across(col: str) -> np.ndarray:
                v = 0.5 * (d[col][:, side - 1] + d[col][:, side])
                return np.concatenate([v, v[::-1]])

            ax.plot(x, plane("walk"), "k.", ms=4, label="random walk (total)")
            ax.plot(x, plane("lumo"), "C0-", lw=1.2, label="lumo: GGX + Kulla-Conty")
            ax.plot(x, plane("cycles"), "C3-", lw=1.2, label="Cycles: GGX / E(μo)")
            ax.plot(x, plane("walk_ms"), "kx", ms=3, label="random walk, ≥ 2 bounces")
            ax.plot(x, plane("lumo_ms"), "C0--", lw=1.0, label="lumo's compensation lobe")
            ax.plot(x, plane("cycles_ms"), "C3--", lw=1.0, label="Cycles' added part")
            ax.plot(x, across("walk"), "o", color="0.55", mfc="none", ms=3,
                    label="random walk, |φ| ≈ 90° (mirrored)")
            ax.plot(x, across("lumo"), "C0:", lw=1.0)
            ax.plot(x, across("cycles"), "C3:", lw=1.0)
            ax.set_title(f"α = {a:g}, θo = {math.degrees(math.acos(mu)):.1f}°", fontsize=9)
            ax.axvline(math.degrees(math.acos(mu)), color="0.8", lw=0.6)
            ax.set_xlim(-90, 90)
            ax.tick_params(labelsize=7)
            if i == len(alphas) - 1:
                ax.set_xlabel("θi (°): negative on the side of ωo, positive on the mirror side",
                              fontsize=7)
            if j == 0:
                ax.set_ylabel("f(ωo, ωi) cos θi  (1/sr)", fontsize=8)
    axes[0][0].legend(fontsize=6, loc="upper left")
    fig.suptitle("White rough conductor (F = 1): reflected energy per solid angle, in the plane "
                 "of incidence (dotted: across it)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    save(fig, out / "lobes.png")


def plot_albedo(rows: list[dict], out: Path) -> None:
    alphas = sorted({r["alpha"] for r in rows})
    fig, axes = plt.subplots(1, len(alphas), figsize=(4.0 * len(alphas), 3.2), squeeze=False)
    for j, a in enumerate(alphas):
        ax = axes[0][j]
        rs = sorted((r for r in rows if r["alpha"] == a), key=lambda r: r["mu_o"])
        mu = np.array([r["mu_o"] for r in rs])
        th = np.degrees(np.arccos(mu))
        for c, name in zip("rgb", ("C3", "C2", "C0")):
            ax.plot(th, [r[f"walk_gold_{c}"] for r in rs], ".", color=name, ms=5)
            ax.plot(th, [r[f"lumo_gold_{c}"] for r in rs], "-", color=name, lw=1.0)
            ax.plot(th, [r[f"cycles_gold_{c}"] for r in rs], "--", color=name, lw=1.0)
        ax.plot(th, [r["walk_single"] for r in rs], "k.", ms=4)
        ax.plot(th, [r["table_e"] for r in rs], "k-", lw=0.8)
        ax.set_title(f"α = {a:g}", fontsize=9)
        ax.set_xlabel("θo (°)", fontsize=8)
        ax.set_ylim(0, 1.05)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel("directional albedo", fontsize=8)
    axes[0][0].plot([], [], "k.", label="random walk")
    axes[0][0].plot([], [], "k-", label="lumo (black: single scattering E, F = 1)")
    axes[0][0].plot([], [], "k--", label="Cycles")
    axes[0][0].legend(fontsize=6, loc="lower left")
    fig.suptitle("Gold conductor (Schlick F0 = 1.0, 0.766, 0.336): albedo by channel; black: "
                 "single-scattering albedo of a white one", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    save(fig, out / "albedo.png")


def tables(data: dict, albedo_rows: list[dict]) -> str:
    lines = ["| α | θo | E_ss | walk: share of ≥ 2 bounces | L1 total: lumo | L1 total: Cycles "
             "| L1 multiple: lumo | L1 multiple: Cycles |",
             "|---|---|---|---|---|---|---|---|"]
    for (a, mu) in sorted(data):
        d = data[(a, mu)]
        omega = 2.0 * (1.0 / N_MU) * (math.pi / N_PHI)
        ss = d["single"].sum() * omega
        ms_share = d["walk_ms"].sum() / d["walk"].sum()
        lines.append(
            f"| {a:g} | {math.degrees(math.acos(mu)):.1f}° | {ss:.3f} | {ms_share:.3f} "
            f"| {l1(d['lumo'], d['walk']):.3f} | {l1(d['cycles'], d['walk']):.3f} "
            f"| {l1(d['lumo_ms'], d['walk_ms']):.3f} | {l1(d['cycles_ms'], d['walk_ms']):.3f} |")
    # The walk's single scattering against the analytic lobe: the check of the walk itself.
    lines.append("")
    lines.append("| α | θo | L1 of the walk's single scattering against GGX (height-correlated G2) |")
    lines.append("|---|---|---|")
    for (a, mu) in sorted(data):
        d = data[(a, mu)]
        walk_ss = d["walk"] - d["walk_ms"]
        lines.append(f"| {a:g} | {math.degrees(math.acos(mu)):.1f}° | {l1(d['single'], walk_ss):.4f} |")
    # Reciprocity of the walk: f(ωo → bin of ωi) / μi against f(ωi → bin of ωo) / μo.
    lines.append("")
    lines.append("| α | μa → μb | f(a → b) | f(b → a) | ratio |")
    lines.append("|---|---|---|---|---|")
    mus = sorted({k[1] for k in data})
    for a in sorted({k[0] for k in data}):
        for x in range(len(mus)):
            for y in range(x + 1, len(mus)):
                ma, mb = mus[x], mus[y]
                ia, ib = int(ma * N_MU), int(mb * N_MU)
                fab = data[(a, ma)]["walk"][ib, 0] / mb
                fba = data[(a, mb)]["walk"][ia, 0] / ma
                lines.append(f"| {a:g} | {ma:.3f} → {mb:.3f} | {fab:.4f} | {fba:.4f} | {fab / fba:.3f} |")
    # Albedo of the gold conductor.
    lines.append("")
    lines.append("| α | θo | walk (r, g, b) | lumo | Cycles |")
    lines.append("|---|---|---|---|---|")
    for r in sorted(albedo_rows, key=lambda r: (r["alpha"], -r["mu_o"])):
        if int(round(r["mu_o"] * 20 - 0.5)) not in (19, 14, 9, 4, 1):
            continue
        fmt = lambda p: ", ".join(f"{r[f'{p}_gold_{c}']:.3f}" for c in "rgb")  # noqa: E731
        lines.append(f"| {r['alpha']:g} | {math.degrees(math.acos(r['mu_o'])):.1f}° | {fmt('walk')} "
                     f"| {fmt('lumo')} | {fmt('cycles')} |")
    worst = defaultdict(lambda: [0.0, 0.0])
    for r in albedo_rows:
        for c in "rgb":
            t = r[f"walk_gold_{c}"]
            worst[r["alpha"]][0] = max(worst[r["alpha"]][0], abs(r[f"lumo_gold_{c}"] / t - 1))
            worst[r["alpha"]][1] = max(worst[r["alpha"]][1], abs(r[f"cycles_gold_{c}"] / t - 1))
    lines.append("")
    lines.append("| α | largest relative albedo error, lumo | Cycles | white walk albedo (min) |")
    lines.append("|---|---|---|---|")
    for a in sorted(worst):
        white = min(r["walk_white"] for r in albedo_rows if r["alpha"] == a)
        lines.append(f"| {a:g} | {100 * worst[a][0]:.2f} % | {100 * worst[a][1]:.2f} % | {white:.5f} |")
    return "\n".join(lines)


def main() -> int:
    src = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("target/microsurface_walk")
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("docs/multiple-scattering")
    out.mkdir(parents=True, exist_ok=True)
    data = lobes(read(src / "lobes.csv"))
    albedo_rows = read(src / "albedo.csv")
    plot_lobes(data, out)
    plot_albedo(albedo_rows, out)
    print(tables(data, albedo_rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
