"""The Cornell box with a mesh in place of its two boxes, rendered by lumo and Mitsuba 3 side by side.

    .venv/bin/python mesh_scenes.py [--scenes bunny,ico] [--spp 16,64,256] [--repeats 3]
                                    [--ref-spp 4096] [--check-spp 1024] [--lumo target/release/lumo]

Two scenes, each the reference Cornell box of ``shared/cornell.md`` (``cornell_scene.py``) with
its two boxes replaced by one white Lambertian mesh:

- ``bunny``: the Stanford bunny of ``shared/meshes/bunny_small.obj`` (4,968 triangles), scaled to
  0.9 high and standing on the floor at the centre of the box;
- ``ico``: the 327,680-triangle icosphere of the ray benchmark (``embree_rays.py``: an
  icosahedron subdivided 7 times), radius 0.55, resting on the floor: the traversal-heavy scene.

Every object is written once, in world space, to ``out/mesh/<scene>/*.obj``; both renderers read
those files (flat shading: lumo's default, Mitsuba's ``face_normals``), so they render the same
triangles with the same materials, light, camera, box filter and depth (8, counted as Mitsuba
counts it).

Per scene:

1. a reference: Mitsuba ``multijitter`` at ``--ref-spp`` (passes of 256 spp, seeds 1,000,000 + k);
2. the check that both renderers render the same scene: lumo and Mitsuba (``multijitter``, a
   seed of its own) at ``--check-spp`` against the reference; each one's RMSE must be within
   15 % of the other's, and the image means must agree within 4 standard errors per channel
   (per-pixel differences averaged), or the script stops with exit code 1 before timing
   anything;
3. the ladder: Mitsuba ``ldsampler`` and ``multijitter`` (``llvm_ad_rgb``, both cores) and lumo
   (its default sampler, both cores) at every ``--spp``, each rung rendered ``--repeats`` times
   with seeds spp, spp + 1000, spp + 2000, … (the same seeds for every renderer); a rung's time
   is the fastest repeat's, its RMSE the root of the repeats' mean squared error (one seed's
   RMSE moves by ±4 % on the icosphere at 64 spp, which moves a time to equal error by ±8 %);
   the times are the renderers' own (Mitsuba: ``mi.render`` and reading the image back; lumo:
   "rendered ... in T s", scene loading excluded), with the CPU time of the whole process
   beside them;
4. the tables: RMSE and seconds per rung, samples/s at 64 spp, and the time each renderer needs
   to reach Mitsuba ``ldsampler``'s 64-spp RMSE (log-log interpolation along its ladder, as
   ``compare.py`` does for the Cornell box), with lumo's time over the best Mitsuba's.

Writes ``out/mesh/results.csv`` (scene, renderer, spp, seconds, cpu_seconds, rmse, seeds,
rmse_min, rmse_max — the range of the single seeds' RMSE — and load1) and prints the tables in
the README's form.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import common
import compare
import cornell_scene as cs
import embree_rays
import mitsuba_cornell

BOXES = ("small-box", "large-box")
REFERENCE_SEED_BASE = 1_000_000
CHECK_SEED = 424_242
# A rung's k-th repeat renders with seed spp + SEED_STEP·k.
SEED_STEP = 1000


def bunny() -> tuple[np.ndarray, np.ndarray]:
    """The shared bunny, 0.9 high, centred in x and z, standing on the floor (y = -1)."""
    v, f = embree_rays.load_obj(embree_rays.shared_dir() / "meshes" / "bunny_small.obj")
    v = v.astype(np.float64)
    lo, hi = v.min(0), v.max(0)
    scale = 0.9 / (hi[1] - lo[1])
    centre = np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
    return (v - centre) * scale + np.array([0.0, -1.0, 0.0]), f


def icosphere() -> tuple[np.ndarray, np.ndarray]:
    """The ray benchmark's 327,680-triangle icosphere (``embree_rays.py``), radius 0.55,
    resting on the floor."""
    v, f = embree_rays.icosphere(7)
    return v.astype(np.float64) * 0.55 + np.array([0.0, -0.45, 0.0]), f


MESHES = {"bunny": bunny, "ico": icosphere}


def write_mesh_obj(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    """Writes vertices ``v`` and triangles ``f`` (0-based) as a Wavefront OBJ, flat (no normals)."""
    with open(path, "w", encoding="ascii") as out:
        out.write(f"# {path.stem}: written by benches/peers/mesh_scenes.py\n")
        out.write("".join("v {:.9g} {:.9g} {:.9g}\n".format(*p) for p in v))
        out.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))


def write_scene(name: str, folder: Path) -> tuple[Path, list[tuple[str, str, Path, tuple | None]]]:
    """Writes the scene's OBJ files and lumo's scene file; returns the scene file and the
    objects as (name, material, OBJ path, emission)."""
    folder.mkdir(parents=True, exist_ok=True)
    objects = []
    for part in cs.parts():
        if part.name in BOXES:
            continue
        path = folder / f"{part.name}.obj"
        cs.write_obj(part, str(path))
        objects.append((part.name, part.material, path, part.emission))
    v, f = MESHES[name]()
    path = folder / f"{name}.obj"
    write_mesh_obj(path, v, f)
    objects.append((name, "white", path, None))
    materials = {m: {"base_color": list(rgb), "specular": 0} for m, rgb in cs.MATERIALS.items()}
    materials["light"] = dict(materials["white"], emission=list(cs.LIGHT_RADIANCE))
    scene = {
        "format_version": 2,
        "image": {"width": cs.WIDTH, "height": cs.HEIGHT},
        "render": {"integrator": "path", "spp": 64, "max_depth": cs.MAX_DEPTH_MITSUBA, "seed": 0},
        "camera": {"position": list(cs.CAMERA_ORIGIN), "look_at": list(cs.CAMERA_TARGET),
                   "up": list(cs.CAMERA_UP), "fov_y_deg": cs.FOV_DEGREES},
        "background": {"color": [0, 0, 0]},
        "materials": materials,
        "objects": [{"mesh": {"name": n, "material": "light" if e else m,
                              "source": {"obj": p.name}}} for n, m, p, e in objects],
    }
    scene_path = folder / "scene.json"
    scene_path.write_text(json.dumps(scene, indent=2) + "\n")
    return scene_path, objects


def mitsuba_scene(mi, objects, sampler: str):
    """The scene for Mitsuba from ``objects`` (as ``write_scene`` returns them) with ``sampler``."""
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": cs.MAX_DEPTH_MITSUBA},
        "sensor": mitsuba_cornell.sensor_dict(mi, sampler),
    }
    for m, rgb in cs.MATERIALS.items():
        d[m] = {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rgb)}}
    for name, material, path, emission in objects:
        shape = {"type": "obj", "filename": str(path), "face_normals": True,
                 "bsdf": {"type": "ref", "id": material}}
        if emission is not None:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb",
                                                             "value": list(emission)}}
        d[name] = shape
    return mi.load_dict(d)


def lumo_render(lumo: str, scene: Path, out: Path, spp: int, seed: int) -> tuple[float, float]:
    """Renders with lumo; returns (lumo's render seconds, CPU seconds of the process)."""
    r0 = os.times()
    proc = subprocess.run([lumo, "render", str(scene), "-o", str(out), "--spp", str(spp),
                           "--seed", str(seed)], capture_output=True, text=True)
    r1 = os.times()
    text = proc.stdout + proc.stderr
    if proc.returncode != 0:
        raise SystemExit(f"lumo failed on {scene}:\n{text}")
    m = re.search(r"spp in ([0-9.]+) s", text)
    if not m:
        raise SystemExit(f"lumo's output has no render time:\n{text}")
    return float(m.group(1)), (r1.children_user - r0.children_user) + (
        r1.children_system - r0.children_system)


def mitsuba_render(mi, scene, spp: int, seed: int) -> tuple[np.ndarray, float, float]:
    """Renders with Mitsuba: (the image, wall seconds, CPU seconds), as mitsuba_cornell.py."""
    return mitsuba_cornell.render(mi, scene, spp, seed)


def check_same_scene(ref, lumo_img, mi_img, spp: int) -> str:
    """Whether lumo's and Mitsuba's images at ``spp`` agree with the reference alike."""
    e_lumo = compare.errors(lumo_img, ref, Path("lumo check"))[0]
    e_mi = compare.errors(mi_img, ref, Path("mitsuba check"))[0]
    d = (lumo_img - mi_img).reshape(-1, 3).astype(np.float64)
    z = d.mean(0) / (d.std(0, ddof=1) / math.sqrt(len(d)))
    report = (f"RMSE against the reference at {spp} spp: lumo {e_lumo:.5f}, Mitsuba {e_mi:.5f}; "
              f"mean difference lumo - Mitsuba z = {z[0]:+.2f}, {z[1]:+.2f}, {z[2]:+.2f}")
    if abs(e_lumo / e_mi - 1.0) > 0.15 or np.any(np.abs(z) > 4.0):
        raise SystemExit(f"the renderers disagree: {report}")
    return report


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--scenes", default="bunny,ico")
    ap.add_argument("--spp", default="16,64,256")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--check-spp", type=int, default=1024)
    ap.add_argument("--lumo", default=str(common.REPO_ROOT / "target" / "release" / "lumo"))
    ap.add_argument("--out", type=Path, default=common.HERE / "out" / "mesh")
    args = ap.parse_args()
    ladder = common.parse_ladder(args.spp)
    if 64 not in ladder:
        raise SystemExit("--spp must include 64: the target is Mitsuba ldsampler's 64-spp error")
    mi, variant = mitsuba_cornell.set_variant("llvm_ad_rgb")
    rows = []
    for name in args.scenes.split(","):
        if name not in MESHES:
            raise SystemExit(f"unknown scene {name!r}: use {', '.join(MESHES)}")
        folder = args.out / name
        scene_path, objects = write_scene(name, folder)
        scenes = {s: mitsuba_scene(mi, objects, s) for s in ("ldsampler", "multijitter")}
        n_tris = sum(1 for line in (folder / f"{name}.obj").open() if line.startswith("f "))
        print(f"== {name}: {n_tris} triangles in the mesh; {variant}; load {common.load1():.2f}")

        ref_path = folder / f"reference_{args.ref_spp}.exr"
        if ref_path.is_file():
            ref = common.read_exr(ref_path)
        else:
            passes = max(1, args.ref_spp // 256)
            t0 = time.perf_counter()
            acc = sum(mitsuba_render(mi, scenes["multijitter"], 256, REFERENCE_SEED_BASE + k)[0]
                      .astype(np.float64) for k in range(passes))
            ref = (acc / passes).astype(np.float32)
            common.write_exr(ref_path, ref)
            print(f"reference: Mitsuba multijitter {passes * 256} spp in "
                  f"{time.perf_counter() - t0:.1f} s")

        lumo_check = folder / f"lumo_check_{args.check_spp}.exr"
        lumo_render(args.lumo, scene_path, lumo_check, args.check_spp, 7)
        mi_check, _, _ = mitsuba_render(mi, scenes["multijitter"], args.check_spp, CHECK_SEED)
        print(check_same_scene(ref, common.read_exr(lumo_check), mi_check, args.check_spp))

        # A warm-up of each renderer (Mitsuba compiles its kernels on the first render).
        for s in scenes.values():
            mitsuba_render(mi, s, 4, 999_983)
        lumo_render(args.lumo, scene_path, folder / "warmup.exr", 1, 999_983)
        ladders: dict[str, list[compare.Rung]] = {}
        for spp in ladder:
            for peer in ("mitsuba-ldsampler", "mitsuba-multijitter", "lumo"):
                best = None
                squared_errors = []
                load = common.load1()
                exr = folder / f"{peer}_{spp}spp.exr"
                for repeat in range(args.repeats):
                    seed = spp + SEED_STEP * repeat
                    if peer == "lumo":
                        # The first seed's image is kept, as Mitsuba's below.
                        out = exr if repeat == 0 else folder / "lumo_repeat.exr"
                        seconds, cpu = lumo_render(args.lumo, scene_path, out, spp, seed)
                        img = common.read_exr(out)
                    else:
                        img, seconds, cpu = mitsuba_render(mi, scenes[peer.split("-")[1]], spp,
                                                           seed)
                        if repeat == 0:
                            common.write_exr(exr, img)
                    squared_errors.append(compare.errors(img, ref, exr)[0] ** 2)
                    if best is None or seconds < best[0]:
                        best = (seconds, cpu)
                seconds, cpu = best
                rmse = math.sqrt(sum(squared_errors) / len(squared_errors))
                seed_rmse = [math.sqrt(e) for e in squared_errors]
                rung = compare.Rung(peer, spp, seconds, cs.WIDTH * cs.HEIGHT * spp / seconds,
                                    f"{load:.2f}", exr, cpu, rmse)
                ladders.setdefault(peer, []).append(rung)
                rows.append({"scene": name, "renderer": peer, "spp": spp,
                             "seconds": f"{seconds:.4f}", "cpu_seconds": f"{cpu:.4f}",
                             "rmse": f"{rmse:.6f}", "seeds": len(seed_rmse),
                             "rmse_min": f"{min(seed_rmse):.6f}",
                             "rmse_max": f"{max(seed_rmse):.6f}", "load1": f"{load:.2f}"})
                print(f"{name} {peer:20s} {spp:4d} spp {seconds:8.3f} s  cpu {cpu:7.3f} s  "
                      f"RMSE {rmse:.5f} [{min(seed_rmse):.5f}–{max(seed_rmse):.5f}]  "
                      f"{rung.samples_per_second / 1e6:.2f} M samples/s  (load {load:.2f})")
        target = next(r.rmse for r in ladders["mitsuba-ldsampler"] if r.spp == 64)
        print(f"\n{name}: time to Mitsuba ldsampler's 64-spp RMSE ({target:.5f}):")
        times = {p: compare.time_to_error(r, target) for p, r in ladders.items()}
        best_peer = min(times[p][0] for p in times if p != "lumo")
        for peer, (t, extrapolated) in times.items():
            print(f"  {peer:20s} {t:7.3f} s{' (extrapolated)' if extrapolated else ''}")
        print(f"  lumo / best Mitsuba: {times['lumo'][0] / best_peer:.2f} "
              f"(load now {common.load1():.2f})\n")
    results = args.out / "results.csv"
    with open(results, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {results}")


if __name__ == "__main__":
    sys.exit(main())
