"""Speed against error on real glTF assets: lumo and Blender Cycles side by side, under an HDR
environment, each renderer's error measured against its own high-spp render (the two renderers
differ slightly by design, `docs/gltf.md`, so a common reference would measure that difference,
not convergence).

    .venv/bin/python gltf_bench.py [--models DamagedHelmet,GlassVaseFlowers] [--size 160]
        [--ladder 4,16,64,256] [--ref-spp 4096] [--env ../shared/hdri/studio.exr]
        [--lumo target/release/lumo] [--seeds 4] [--light-tree off,on] [--reuse-references]

Scene and settings: exactly those of the glTF comparison (`cycles_gltf.py --env`): lumo's camera
for the file (its first camera or lumo's framing), Blender's bundled importer, the environment as
an Environment Texture at strength 1 with Blender's default mapping (lumo: `--env`, rotation 0),
Cycles on the CPU with both threads, no denoising, no adaptive sampling, no clamping, Box filter
1 px, max bounces 6 against lumo's `--max-depth 8` (the same paths), Blender's default sampling
pattern; lumo with its defaults (Owen-scrambled Sobol, NEE + MIS).

For each model and renderer: a reference of --ref-spp samples (Cycles: passes of 256 spp with
seeds 1000 + k, averaged; lumo: one render with seed 1000000), then the ladder, each rung
rendered with --seeds seeds (spp + 1000 k), the renderers taking turns rung by rung (Cycles,
light tree off then on, then lumo) so that the shared machine's changing load reaches all of
them alike: its RMSE is the root of the mean over seeds of the
squared error (these scenes have fireflies, so one image's RMSE moves by 10-20 % between seeds)
and its time the median over seeds. Cycles runs with its light tree off (as in the glTF
comparison) and on (Blender's default); the faster of the two to the target error is the peer. Times are the renderers' own
render times (Cycles: render_pre to render_post handlers, with Persistent Data on and one
untimed 1-spp render first, so that scene sync, BVH build and texture upload are not counted;
lumo: the time it prints), scene import and loading excluded. RMSE over all pixels and channels against the renderer's own reference.

Output: ``out/gltf/<model>/{cycles,lumo}_{ref,<spp>spp}.exr`` (the first seed's image) and
``out/gltf/results.csv`` (model, peer, spp, seconds, samples_per_second, rmse, rmse_min, rmse_max,
load1); the equal-spp and equal-error tables (target: the 64-spp error of Cycles with its light
tree off, the setting of the glTF comparison) are printed as Markdown.
"""

from __future__ import annotations

import argparse
import csv
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import common
import cycles_gltf as cg
from compare import Rung, time_to_error
from cycles_cornell import Timer

OUT = common.HERE / "out" / "gltf"
MODELS = ("DamagedHelmet", "GlassVaseFlowers")
REF_PASS_SPP = 256
CYCLES_REF_SEED = 1000
LUMO_REF_SEED = 1_000_000
LUMO_MAX_DEPTH = 8  # = Cycles' 6 bounces (tests/gltf_cycles.rs)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)))


def lumo_render(lumo: str, model: Path, env: Path, size: int, spp: int, seed: int,
                out: Path) -> float:
    """Renders with lumo; returns the render time it prints."""
    cmd = [lumo, "render", str(model), "--env", str(env), "--width", str(size), "--height",
           str(size), "--spp", str(spp), "--seed", str(seed), "--max-depth",
           str(LUMO_MAX_DEPTH), "-q", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr}")
    m = re.search(r"spp in ([0-9.]+) s", proc.stderr)
    if not m:
        raise SystemExit(f"no render time in lumo's output:\n{proc.stderr}")
    return float(m.group(1))


def rung_row(model: str, peer: str, spp: int, times: list[float], images: list[np.ndarray],
             ref: np.ndarray, size: int) -> dict:
    """One rung: median time, RMS error over the seeds' images and its range."""
    errors = [rmse(img, ref) for img in images]
    secs = float(np.median(times))
    row = {"model": model, "peer": peer, "spp": spp, "seconds": round(secs, 4),
           "samples_per_second": round(size ** 2 * spp / secs, 1),
           "rmse": round(float(np.sqrt(np.mean(np.square(errors)))), 6),
           "rmse_min": round(min(errors), 6), "rmse_max": round(max(errors), 6),
           "load1": round(common.load1(), 2)}
    print(f"{model}: {peer:24s} {spp:5d} spp {secs:8.3f} s RMSE {row['rmse']:.5f} "
          f"({row['rmse_min']:.5f}-{row['rmse_max']:.5f}, load {row['load1']})", flush=True)
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--size", type=int, default=160)
    ap.add_argument("--ladder", default="4,8,16,32,64,128,256")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--env", type=Path, default=common.REPO_ROOT.parent / "shared" / "hdri" / "studio.exr")
    ap.add_argument("--lumo", default=str(common.REPO_ROOT / "target" / "release" / "lumo"))
    ap.add_argument("--seeds", type=int, default=4,
                    help="renders per rung (seeds spp + 1000 k); RMSE over all, median time")
    ap.add_argument("--light-tree", default="off,on",
                    help="Cycles' light tree settings to run (off,on)")
    ap.add_argument("--reuse-references", action="store_true",
                    help="keep references already in out/gltf (same size and spp)")
    args = ap.parse_args()
    ladder = common.parse_ladder(args.ladder)
    light_trees = [t.strip() for t in args.light_tree.split(",") if t.strip()]
    if not light_trees or any(t not in ("off", "on") for t in light_trees):
        raise SystemExit("--light-tree takes off, on or off,on")

    def seeds(spp: int) -> list[int]:
        return [spp + 1000 * k for k in range(args.seeds)]
    if args.ref_spp % REF_PASS_SPP:
        raise SystemExit(f"--ref-spp must be a multiple of {REF_PASS_SPP}")
    env = args.env.resolve()
    import bpy

    cg.WIDTH = cg.HEIGHT = args.size  # render_passes checks the image size against these
    managed_ext = cg.importer_extensions()
    ns = SimpleNamespace(gltf_root=cg.DEFAULT_GLTF_ROOT.resolve(), prefer="glb", lumo=args.lumo,
                         env=env)
    rows = []
    print(f"== {time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())} load {common.load1():.2f}")
    for model in [m.strip() for m in args.models.split(",") if m.strip()]:
        folder = OUT / model
        folder.mkdir(parents=True, exist_ok=True)
        model_file = cg.find_model_file(ns.gltf_root, model, prefer_binary=True)

        # Cycles, with its light tree off and on.
        ctx = cg.prepare_job(bpy, model, ns, managed_ext, args.size, args.size)
        scene = ctx["scene"]
        # Persistent Data: the scene (BVH, textures) is synced by the first render and kept, so
        # that a timed render measures sampling, as lumo's printed time does (without it, every
        # render of DamagedHelmet re-uploads its textures: 0.6 s at any spp).
        scene.render.use_persistent_data = True
        scene.cycles.use_light_tree = False
        cg.render_passes(bpy, scene, Timer(bpy), 1, [999_983], "gltf_bench_warmup_")
        timer = Timer(bpy)
        ref_path = folder / "cycles_ref.exr"
        if not (args.reuse_references and ref_path.is_file()):
            passes = args.ref_spp // REF_PASS_SPP
            stack, secs, _, _ = cg.render_passes(
                bpy, scene, timer, REF_PASS_SPP,
                [CYCLES_REF_SEED + k for k in range(passes)], "gltf_bench_")
            common.write_exr(ref_path, stack.mean(axis=0))
            print(f"{model}: cycles reference {args.ref_spp} spp in {secs:.1f} s")
        cycles_ref = common.read_exr(ref_path)
        ref_path = folder / "lumo_ref.exr"
        if not (args.reuse_references and ref_path.is_file()):
            secs = lumo_render(args.lumo, model_file, env, args.size, args.ref_spp, LUMO_REF_SEED,
                               ref_path)
            print(f"{model}: lumo reference {args.ref_spp} spp in {secs:.1f} s")
        lumo_ref = common.read_exr(ref_path)
        with tempfile.TemporaryDirectory() as tmp:
            lumo_render(args.lumo, model_file, env, args.size, 1, 999_983, Path(tmp) / "w.exr")

        # The ladder, the renderers taking turns rung by rung, so that a change in the machine's
        # load (it is shared) reaches them alike instead of whichever ran last.
        for spp in ladder:
            for tree in light_trees:
                peer = f"cycles, light tree {tree}"
                scene.cycles.use_light_tree = tree == "on"
                cg.render_passes(bpy, scene, Timer(bpy), 1, [999_979], "gltf_bench_warmup_")
                images, times = [], []
                for seed in seeds(spp):
                    timer = Timer(bpy)
                    stack, secs, _, _ = cg.render_passes(bpy, scene, timer, spp, [seed],
                                                         "gltf_bench_")
                    images.append(stack[0])
                    times.append(secs)
                common.write_exr(folder / f"cycles_{'tree_' if tree == 'on' else ''}{spp}spp.exr",
                                 images[0])
                rows.append(rung_row(model, peer, spp, times, images, cycles_ref, args.size))
            images, times = [], []
            for k, seed in enumerate(seeds(spp)):
                path = folder / (f"lumo_{spp}spp.exr" if k == 0 else f"lumo_{spp}spp_{k}.exr")
                times.append(lumo_render(args.lumo, model_file, env, args.size, spp, seed, path))
                images.append(common.read_exr(path))
                if k:
                    path.unlink()
            rows.append(rung_row(model, "lumo", spp, times, images, lumo_ref, args.size))

    with open(OUT / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"\nwrote {OUT / 'results.csv'}; {time.strftime('%H:%M:%SZ', time.gmtime())} "
          f"load {common.load1():.2f}\n")

    peers = list(dict.fromkeys(r["peer"] for r in rows))
    cycles_peers = [p for p in peers if p.startswith("cycles")]
    for model in dict.fromkeys(r["model"] for r in rows):
        mine = [r for r in rows if r["model"] == model]
        print(f"**{model}**, {args.size}², equal spp (seconds / RMSE against the renderer's own "
              f"{args.ref_spp}-spp render; median time and RMS error over {args.seeds} seeds, "
              f"range of the seeds' RMSE in brackets):\n")
        print("| renderer | " + " | ".join(f"{s} spp" for s in ladder) + " |")
        print("|---|" + "---:|" * len(ladder))
        for peer in peers:
            cells = [f"{r['seconds']:.3g} / {r['rmse']:.4f} ({r['rmse_min']:.4f}–{r['rmse_max']:.4f})"
                     for s in ladder for r in mine if r["peer"] == peer and r["spp"] == s]
            print(f"| {peer} | " + " | ".join(cells) + " |")
        target_peer = "cycles, light tree off" if "cycles, light tree off" in peers else cycles_peers[0]
        target_spp = 64 if 64 in ladder else ladder[-1]
        target = next(r["rmse"] for r in mine if r["peer"] == target_peer and r["spp"] == target_spp)
        times = {}
        for peer in peers:
            times[peer] = time_to_error(
                [Rung(peer, r["spp"], r["seconds"], r["samples_per_second"], str(r["load1"]),
                      Path(), rmse=r["rmse"]) for r in mine if r["peer"] == peer], target)
        best = min(cycles_peers, key=lambda p: times[p][0])
        listed = ", ".join(f"{p} {times[p][0]:.3g} s{'*' if times[p][1] else ''}" for p in peers)
        print(f"\nEqual error ({target_peer}'s {target_spp}-spp RMSE {target:.5f}): {listed}; "
              f"lumo's time ÷ the faster Cycles ({best}) = "
              f"{times['lumo'][0] / times[best][0]:.2f}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
