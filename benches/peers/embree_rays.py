"""Ray-throughput baseline: Embree (PyPI ``embreex``) on fixed, saved ray sets.

    .venv/bin/python embree_rays.py [--rays 1000000] [--repeats 3]

Meshes
  icosphere  unit sphere at the origin: an icosahedron subdivided 7 times (each triangle split
             into 4 at its edge midpoints, new vertices pushed onto the sphere):
             20 * 4^7 = 327,680 triangles, 163,842 vertices, outward (counter-clockwise) winding.
  bunny      shared/meshes/bunny_small.obj (4,968 triangles), as stored.
Both are also saved (see below), so another renderer can load exactly these triangles.

Rays (per mesh; N = --rays, default 1,000,000). Let C be the centre of the mesh's axis-aligned
bounding box, R the largest distance of a vertex from C (bounding sphere about C).
  coherent    a pinhole camera at C + (0, 0, 3R) looking down -z (up +y), square image of
              side sqrt(N) (1000 x 1000), through pixel centres, row-major from the top-left;
              vertical = horizontal field of view 2 * asin(1/3) (the bounding sphere just fits).
              No random numbers.
  incoherent  rng = numpy.random.Generator(numpy.random.PCG64(SEED)), SEED = 20261123 for the
              icosphere and 20261124 for the bunny; then, in this order:
                g = rng.standard_normal((N, 3)); origin = C + 2R * g / |g|  (uniform on a sphere)
                u = rng.random((N, 3));          target = bbox_min + u * (bbox_max - bbox_min)
              direction = normalize(target - origin).
  All rays: tnear = 0, tfar = +inf, float32; directions are unit length (computed in float64,
  then rounded to float32; the float32 values in the files are the canonical rays).

Files written to ``rays/`` (gitignored; regenerate with this script, it is deterministic):
  <mesh>_vertices.npy            float32 (V, 3)
  <mesh>_indices.npy             int32   (F, 3), zero-based
  <mesh>_<kind>_origins.npy      float32 (N, 3), C order
  <mesh>_<kind>_dirs.npy         float32 (N, 3)
  <mesh>_<kind>_embree_t.npy     float32 (N,): Embree's closest hit distance, +inf on a miss
  <mesh>_<kind>_embree_prim.npy  int32   (N,): the triangle index hit, -1 on a miss
  (standard NumPy .npy v1.0 files: a text header with dtype/shape, then raw little-endian data)

Measurement: closest-hit queries (``EmbreeScene.run(..., output=1)``: t, u, v, Ng, primID per
ray), BVH build excluded. "1 thread" = one call on all N rays. "all cores" = the rays split into
4 contiguous chunks per core, traced by a pool of one Python thread per core on one shared scene.
This scales because embreex 4.4's compiled ``run`` loop does not hold the GIL (measured: the
incoherent sets run ~2x faster on 2 threads; the script warns if a set gains < 1.3x). Results
of the threaded run are checked to equal the single-threaded ones ray by ray. Reported: the best
of --repeats runs (the machine is shared).
Results: ``embree_results.csv`` (mesh, kind, rays, hits, threads, seconds, mrays_per_s, load1,
cpu_seconds, mrays_per_cpu_s); the CPU-time figures (user + system of all threads) are far less
inflated than wall time when other jobs share the cores.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

import common

RAYS_DIR = common.HERE / "rays"
SEEDS = {"icosphere": 20261123, "bunny": 20261124}


def shared_dir() -> Path:
    """$LUMO_SHARED, else <repo>/../shared, else /work/shared."""
    env = os.environ.get("LUMO_SHARED")
    for cand in ([Path(env)] if env else []) + [common.REPO_ROOT.parent / "shared",
                                                Path("/work/shared")]:
        if cand.is_dir():
            return cand
    raise SystemExit("shared data folder not found: set LUMO_SHARED to the shared/ folder")


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere; every step splits each triangle into four at its edge midpoints."""
    p = (1.0 + math.sqrt(5.0)) / 2.0
    v = np.array([[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0],
                  [0, -1, p], [0, 1, p], [0, -1, -p], [0, 1, -p],
                  [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]], dtype=np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                  [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                  [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        edges = np.stack([np.stack([a, b], 1), np.stack([b, c], 1), np.stack([c, a], 1)], 1)
        key = np.sort(edges.reshape(-1, 2), axis=1)
        uniq, inverse = np.unique(key, axis=0, return_inverse=True)
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = (len(v) + inverse.reshape(-1, 3))  # midpoint vertex of edges ab, bc, ca
        ab, bc, ca = m[:, 0], m[:, 1], m[:, 2]
        v = np.concatenate([v, mid])
        f = np.concatenate([np.stack([a, ab, ca], 1), np.stack([b, bc, ab], 1),
                            np.stack([c, ca, bc], 1), np.stack([ab, bc, ca], 1)])
    return v.astype(np.float32), f.astype(np.int32)


def load_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Positions and triangles of an OBJ (polygons fan-triangulated; v/vt/vn refs accepted)."""
    verts, faces = [], []
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, 1):
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                verts.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                idx = []
                for tok in parts[1:]:
                    i = int(tok.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                if len(idx) < 3:
                    raise SystemExit(f"{path}:{lineno}: face with fewer than 3 vertices")
                faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.array(verts, dtype=np.float32), np.array(faces, dtype=np.int32)


def bounds(v: np.ndarray):
    lo, hi = v.min(0).astype(np.float64), v.max(0).astype(np.float64)
    c = (lo + hi) / 2
    return lo, hi, c, float(np.linalg.norm(v.astype(np.float64) - c, axis=1).max())


def coherent_rays(v: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    side = math.isqrt(n)
    if side * side != n:
        raise SystemExit(f"--rays {n}: the coherent grid needs a square number (e.g. 1000000)")
    lo, hi, c, r = bounds(v)
    eye = c + np.array([0.0, 0.0, 3.0 * r])
    half = math.tan(math.asin(1.0 / 3.0))
    s = (np.arange(side) + 0.5) / side * 2.0 - 1.0  # pixel centres in [-1, 1]
    yy, xx = np.meshgrid(-s, s, indexing="ij")      # row 0 is the top of the image
    d = np.stack([xx * half, yy * half, -np.ones_like(xx)], axis=-1).reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(eye, d.shape)
    return np.ascontiguousarray(o, dtype=np.float32), np.ascontiguousarray(d, dtype=np.float32)


def incoherent_rays(v: np.ndarray, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    lo, hi, c, r = bounds(v)
    rng = np.random.Generator(np.random.PCG64(seed))
    g = rng.standard_normal((n, 3))
    o = c + 2.0 * r * g / np.linalg.norm(g, axis=1, keepdims=True)
    u = rng.random((n, 3))
    d = lo + u * (hi - lo) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(o, dtype=np.float32), np.ascontiguousarray(d, dtype=np.float32)


def make_scene(v: np.ndarray, f: np.ndarray):
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, v, f)
    return scene


def trace(scene, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    res = scene.run(o, d, output=1)
    prim = np.asarray(res["primID"], dtype=np.int32)
    t = np.where(prim >= 0, np.asarray(res["tfar"], dtype=np.float32), np.float32(np.inf))
    return t, prim


def trace_threads(scene, o, d, threads: int):
    chunks = np.array_split(np.arange(len(o)), 4 * threads)
    with ThreadPoolExecutor(threads) as pool:
        parts = list(pool.map(lambda ix: trace(scene, o[ix[0]:ix[-1] + 1], d[ix[0]:ix[-1] + 1]),
                              chunks))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--results", type=Path, default=common.HERE / "embree_results.csv")
    args = ap.parse_args()
    import embreex

    cores = os.cpu_count() or 1
    RAYS_DIR.mkdir(exist_ok=True)
    meshes = {"icosphere": icosphere(7), "bunny": load_obj(shared_dir() / "meshes" /
                                                           "bunny_small.obj")}
    rows = []
    print(f"embreex {getattr(embreex, '__version__', '?')}, {cores} cores, "
          f"{args.rays:,} rays per set, best of {args.repeats}")
    for name, (v, f) in meshes.items():
        np.save(RAYS_DIR / f"{name}_vertices.npy", v)
        np.save(RAYS_DIR / f"{name}_indices.npy", f)
        t0 = time.perf_counter()
        scene = make_scene(v, f)
        trace(scene, v[:1] * 0, np.array([[0, 0, 1]], dtype=np.float32))  # commit = BVH build
        print(f"{name}: {len(f):,} triangles, BVH build + first ray {time.perf_counter() - t0:.3f} s")
        for kind in ("coherent", "incoherent"):
            o, d = (coherent_rays(v, args.rays) if kind == "coherent"
                    else incoherent_rays(v, args.rays, SEEDS[name]))
            np.save(RAYS_DIR / f"{name}_{kind}_origins.npy", o)
            np.save(RAYS_DIR / f"{name}_{kind}_dirs.npy", d)
            t_ref, p_ref = trace(scene, o, d)
            np.save(RAYS_DIR / f"{name}_{kind}_embree_t.npy", t_ref)
            np.save(RAYS_DIR / f"{name}_{kind}_embree_prim.npy", p_ref)
            hits = int(np.count_nonzero(p_ref >= 0))
            speed = {}
            for threads in sorted({1, cores}):
                best = best_cpu = math.inf
                for _ in range(args.repeats):
                    c0, t0 = time.process_time(), time.perf_counter()
                    t_hit, p_hit = (trace(scene, o, d) if threads == 1
                                    else trace_threads(scene, o, d, threads))
                    best = min(best, time.perf_counter() - t0)
                    best_cpu = min(best_cpu, time.process_time() - c0)
                    if not np.array_equal(p_hit, p_ref):
                        raise SystemExit(f"{name}/{kind}: {threads}-thread results differ")
                mrays = len(o) / best / 1e6
                speed[threads] = mrays
                load = common.load1()
                rows.append({"mesh": name, "kind": kind, "rays": len(o), "hits": hits,
                             "threads": threads, "seconds": f"{best:.4f}",
                             "mrays_per_s": f"{mrays:.3f}", "load1": f"{load:.2f}",
                             "cpu_seconds": f"{best_cpu:.4f}",
                             "mrays_per_cpu_s": f"{len(o) / best_cpu / 1e6:.3f}"})
                print(f"  {kind:10s} {threads} thread(s): {mrays:6.2f} Mrays/s  "
                      f"({best:.3f} s, {len(o) / best_cpu / 1e6:6.2f} Mrays per CPU-second, "
                      f"{hits:,} hits, load {load:.2f})", flush=True)
            if cores > 1 and speed[cores] < 1.3 * speed[1]:
                print(f"  WARNING: {cores} threads gain only {speed[cores] / speed[1]:.2f}x "
                      "(GIL held, machine busy, or too few rays to amortise the threads)")
    with open(args.results, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {args.results}; rays and Embree's hits in {RAYS_DIR}")


if __name__ == "__main__":
    main()
