"""Renders the reference Cornell box (shared/cornell.md) with Mitsuba 3 over an spp ladder.

    .venv/bin/python mitsuba_cornell.py [--variant llvm_ad_rgb|scalar_rgb] [--spp 1,4,16,64,256]
                                        [--sampler independent|ldsampler|multijitter|stratified]
    .venv/bin/python mitsuba_cornell.py --reference OUT.exr --ref-spp 4096

Scene: Mitsuba's built-in ``mi.cornell_box()`` with the pixel filter changed to a box and the
sampler set by ``--sampler`` (default ``independent``, the built-in scene's; ``ldsampler`` and
``multijitter`` are Mitsuba's best for this scene: at 64 spp their error is less than half the
independent sampler's); path tracer with max_depth 8 (as in the built-in scene). Before
rendering, the built-in scene is checked against the explicit geometry of ``cornell_scene.py``
(positions, facing, reflectances and emission of every face, by ray casts), so a change of
Mitsuba's built-in would be caught. ``--scene explicit`` renders from that explicit geometry
instead (OBJ meshes), as a cross-check.

Timing: one warm-up render (1 spp, its own seed) runs first, so that Dr.Jit's kernel compilation
and scene upload are excluded; each rung then times ``mi.render`` plus the copy to numpy (which
forces evaluation of the lazy LLVM arrays). Writing the EXR is not timed. Each rung renders
--seeds images (default 3) with seeds spp, spp + 1000, spp + 2000 (the same seeds as every other
renderer's), each timed --repeats times (default 1); the rung's time is the fastest, since the
machine is shared, and compare.py takes the root of the images' mean squared error as its
RMSE. The seeds are distinct from the reference's, so the noise of a rung and of the reference
are independent.

Output: ``out/mitsuba-<variant>/mitsuba-<variant>_<spp>spp.exr`` (linear float32 RGB) and
``timings.csv`` with columns ``peer,spp,seconds,samples_per_second,exr,load1,cpu_seconds``
(CPU time of the process, all threads, over the same interval).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import common
import cornell_scene as cs

# Seeds: the ladder uses seed = spp (1, 4, 16, ...); the warm-up 999_983; reference passes
# 1_000_000 + pass index. All distinct, so no two images share random numbers.
WARMUP_SEED = 999_983
REFERENCE_SEED_BASE = 1_000_000


def set_variant(requested: str):
    import mitsuba as mi

    try:
        mi.set_variant(requested)
        return mi, requested
    except Exception as e:  # libLLVM missing -> Dr.Jit refuses the llvm variants
        if requested == "scalar_rgb":
            raise
        print(f"mitsuba: variant {requested} unavailable ({e}); falling back to scalar_rgb",
              file=sys.stderr)
        mi.set_variant("scalar_rgb")
        return mi, "scalar_rgb"


def builtin_scene_dict(mi, sampler: str = "independent") -> dict:
    """mi.cornell_box() with a box pixel filter and the given sampler."""
    d = mi.cornell_box()
    d["integrator"] = {"type": "path", "max_depth": cs.MAX_DEPTH_MITSUBA}
    sensor = d["sensor"]
    # 4: valid for every sampler (ldsampler wants a square power of two); mi.render(spp=…) sets
    # the count of each render.
    sensor["sampler"] = {"type": sampler, "sample_count": 4}
    sensor["film"]["rfilter"] = {"type": "box"}
    return d


def sensor_dict(mi, sampler: str) -> dict:
    """The spec's camera and film (box filter) with ``sampler``."""
    T = mi.ScalarTransform4f
    return {
        "type": "perspective",
        "fov_axis": "smaller",
        "fov": cs.FOV_DEGREES,
        "near_clip": 0.001,
        "far_clip": 100.0,
        "to_world": T().look_at(origin=cs.CAMERA_ORIGIN, target=cs.CAMERA_TARGET,
                                up=cs.CAMERA_UP),
        "sampler": {"type": sampler, "sample_count": 4},
        "film": {"type": "hdrfilm", "width": cs.WIDTH, "height": cs.HEIGHT,
                 "rfilter": {"type": "box"}, "pixel_format": "rgb",
                 "component_format": "float32"},
    }


def explicit_scene_dict(mi, workdir: Path, sampler: str = "independent") -> dict:
    """The same scene from cornell_scene.py's triangles, via OBJ files in ``workdir``."""
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": cs.MAX_DEPTH_MITSUBA},
        "sensor": sensor_dict(mi, sampler),
    }
    for name, rgb in cs.MATERIALS.items():
        d[name] = {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rgb)}}
    for part in cs.parts():
        path = workdir / f"{part.name}.obj"
        cs.write_obj(part, str(path))
        shape = {"type": "obj", "filename": str(path), "face_normals": True,
                 "bsdf": {"type": "ref", "id": part.material}}
        if part.emission is not None:
            shape["emitter"] = {"type": "area",
                                "radiance": {"type": "rgb", "value": list(part.emission)}}
        d[part.name] = shape
    return d


def verify_against_spec(mi, scene) -> int:
    """Checks every face of cornell_scene.py against the loaded Mitsuba scene by ray casts.

    For each triangle, a ray starts 1e-3 in front of its centroid and points back at it; it must
    hit at t = 1e-3 a surface with the same geometric normal, the spec's reflectance and the
    spec's emission (zero except for the light). Faces looking down (-y) on the boxes are skipped:
    they lie on (small box) or under (large box) the floor, where the floor is hit as well.
    Also compares the scene's bounding box with the spec's. Returns the number of triangles checked.
    """
    origins, dirs, normals, refl, emis, names = [], [], [], [], [], []
    for part in cs.parts():
        for quad, n in zip(part.quads, part.normals()):
            if part.name.endswith("box") and n[1] < -0.999:
                continue
            # Triangle centroids, not the quad centre: that lies on the shared diagonal, where a
            # non-watertight ray test may slip between the two triangles.
            for tri in (quad[[0, 1, 2]], quad[[0, 2, 3]]):
                c = tri.mean(axis=0)
                origins.append(c + 1e-3 * n)
                dirs.append(-n)
                normals.append(n)
                refl.append(cs.MATERIALS[part.material])
                emis.append(part.emission or (0.0, 0.0, 0.0))
                names.append(part.name)
    failures = []
    for i in range(len(origins)):
        ray = mi.Ray3f(mi.Point3f(*map(float, origins[i])), mi.Vector3f(*map(float, dirs[i])))
        si = scene.ray_intersect(ray)
        got_t = float(np.asarray(si.t).ravel()[0])
        got_n = np.asarray(si.n, dtype=np.float64).ravel()[:3]
        bsdf = si.bsdf(ray)
        got_r = np.asarray(bsdf.eval_diffuse_reflectance(si), dtype=np.float64).ravel()[:3]
        emitter = si.emitter(scene)
        if emitter is None:  # scalar variants return None where the llvm ones return a null ptr
            got_e = np.zeros(3)
        else:
            got_e = np.asarray(emitter.eval(si), dtype=np.float64).ravel()[:3]
        problems = []
        if abs(got_t - 1e-3) > 1e-5:
            problems.append(f"t={got_t:.6g} (want 1e-3)")
        if np.dot(got_n, normals[i]) < 0.9999:
            problems.append(f"normal {got_n} (want {normals[i]})")
        if not np.allclose(got_r, refl[i], rtol=1e-5, atol=1e-6):
            problems.append(f"reflectance {got_r} (want {refl[i]})")
        if not np.allclose(got_e, emis[i], rtol=1e-5, atol=1e-6):
            problems.append(f"emission {got_e} (want {emis[i]})")
        if problems:
            failures.append(f"{names[i]} triangle at {origins[i] - 1e-3 * normals[i]}: " +
                            "; ".join(problems))
    allq = np.concatenate([p.quads.reshape(-1, 3) for p in cs.parts()])
    bb = scene.bbox()
    got_lo = np.asarray(bb.min, dtype=np.float64).ravel()[:3]
    got_hi = np.asarray(bb.max, dtype=np.float64).ravel()[:3]
    if not (np.allclose(got_lo, allq.min(0), atol=1e-4) and np.allclose(got_hi, allq.max(0),
                                                                           atol=1e-4)):
        failures.append(f"scene bbox {got_lo}..{got_hi} != spec {allq.min(0)}..{allq.max(0)}")
    if failures:
        raise SystemExit("Mitsuba scene does not match shared/cornell.md:\n  " +
                         "\n  ".join(failures))
    return len(origins)


def render(mi, scene, spp: int, seed: int) -> tuple[np.ndarray, float, float]:
    """Renders and returns (HxWx3 float32 linear RGB, wall seconds, CPU seconds)."""
    c0, t0 = time.process_time(), time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    arr = np.array(img, dtype=np.float32)  # forces evaluation in the LLVM variants
    return arr, time.perf_counter() - t0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", default=",".join(map(str, common.DEFAULT_LADDER)),
                    help="spp ladder, comma-separated (default 1,4,16,64,256)")
    ap.add_argument("--seeds", type=int, default=common.DEFAULT_SEEDS,
                    help="images per rung, with seeds spp + 1000 k (time: the fastest)")
    ap.add_argument("--repeats", type=int, default=1,
                    help="time each image this many times (same seed) and keep the fastest")
    ap.add_argument("--scene", choices=("builtin", "explicit"), default="builtin")
    ap.add_argument("--sampler", default="independent",
                    choices=("independent", "ldsampler", "multijitter", "stratified"),
                    help="Mitsuba's sampler (default independent, the built-in scene's); "
                         "ladder spp must suit it (powers of 4 suit all of them)")
    ap.add_argument("--out", type=Path, default=common.HERE / "out")
    ap.add_argument("--reference", type=Path,
                    help="instead of the ladder, render a high-spp reference to this EXR")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--pass-spp", type=int, default=256,
                    help="reference is the mean of ref-spp/pass-spp passes (bounds memory)")
    args = ap.parse_args()
    ladder = common.parse_ladder(args.spp)

    mi, variant = set_variant(args.variant)
    import drjit as dr

    with tempfile.TemporaryDirectory() as tmp:
        if args.scene == "builtin":
            scene = mi.load_dict(builtin_scene_dict(mi, args.sampler))
        else:
            scene = mi.load_dict(explicit_scene_dict(mi, Path(tmp), args.sampler))
        checked = verify_against_spec(mi, scene)
    print(f"mitsuba {mi.__version__} (drjit {dr.__version__}), variant {variant}, "
          f"sampler {args.sampler}, scene {args.scene}: {checked} triangles match "
          f"shared/cornell.md")

    _, t_warm, _ = render(mi, scene, 1, WARMUP_SEED)
    print(f"warm-up render (1 spp, not counted): {t_warm:.2f} s")

    if args.reference:
        if args.ref_spp % args.pass_spp:
            raise SystemExit("--ref-spp must be a multiple of --pass-spp")
        passes = args.ref_spp // args.pass_spp
        acc = np.zeros((cs.HEIGHT, cs.WIDTH, 3), dtype=np.float64)
        total = 0.0
        for p in range(passes):
            img, dt, _ = render(mi, scene, args.pass_spp, REFERENCE_SEED_BASE + p)
            acc += img
            total += dt
            print(f"  reference pass {p + 1}/{passes}: {dt:.2f} s (load {common.load1():.2f})",
                  flush=True)
        common.write_exr(args.reference, acc / passes)
        print(f"reference: {args.ref_spp} spp in {total:.1f} s render time "
              f"({common.WIDTH_HEIGHT * args.ref_spp / total / 1e6:.2f} M samples/s) "
              f"-> {args.reference}")
        return

    peer = (f"mitsuba-{variant.split('_')[0]}-{args.sampler}"
            + ("" if args.scene == "builtin" else "-explicit"))
    folder = args.out / peer
    rows = []
    for spp in ladder:
        names, dt, cpu = [], math.inf, math.inf
        for k, seed in enumerate(common.rung_seeds(spp, args.seeds)):
            img, dt1, cpu1 = common.best_of(args.repeats,
                                            lambda: render(mi, scene, spp, seed=seed))
            names.append(common.seeded_exr(peer, spp, k))
            common.write_exr(folder / names[-1], img)
            dt, cpu = min(dt, dt1), min(cpu, cpu1)
        rows.append(common.timing_row(peer, spp, dt, ";".join(names), cpu))
        common.print_rung(peer, spp, dt, cpu)
    common.write_timings(folder / "timings.csv", rows)
    print(f"wrote {folder / 'timings.csv'}")


if __name__ == "__main__":
    main()
