"""Start time and peak memory on big meshes: lumo's whole start (load a .glb, build, render one
sample) against Embree's BVH build (``rtcCommitScene``) over the same indexed triangles, side by
side in one run.

    .venv/bin/python start_bench.py [--lumo target/release/lumo] [--baseline OLD_LUMO]
        [--repeats 3] [--levels 3,4,5,6,7,8] [--instanced 8] [--plot ../../docs/start.svg]

Meshes: the unit icosphere of ``embree_rays.icosphere(n)`` (20 * 4^n triangles, the same
vertices and triangles as ``lumo::geometry::mesh::icosphere``), written as a minimal binary glTF
(``out/start/ico<n>.glb``): one buffer with POSITION (float32), NORMAL (float32, = position on
the unit sphere) and uint32 indices, one mesh, one node, no camera (lumo frames the scene), no
light (lumo adds its default environment), glTF's default material. Level 8 is the issue's
1,310,720-triangle sphere (31 MB). The largest case (``ico8x<K>.glb``) instances the level-8 mesh
K times (K nodes referencing the one mesh, translated 2.5 apart along x): K * 1.31M triangles
rendered, 1.31M stored.

lumo: ``lumo render X.glb -o out.png --spp 1 --width 64 --height 64 -q`` under
``/usr/bin/time -v``: wall time of the whole process (start to exit: read, parse, import,
validate, content hash, scene build, BVH build, one sample per pixel, PNG written), its user and
system CPU time and its peak resident set size ("Maximum resident set size").

Embree: ``rtcCommitScene`` alone, the BVH build, wall and CPU time, called through ctypes on
the Embree 4 library that embreex ships (embreex has no commit call of its own). The scene is
made as embreex makes it (default device, scene flags and build quality; one triangle geometry,
float3 vertices with a 16-byte stride, uint3 indices) from the same float32 vertices and int32
indices that the .glb holds, its buffers filled before the clock starts; a warm-up commit starts
Embree's worker threads first. For context, embreex's whole Python path is timed too, part by
part: ``EmbreeScene()``, ``TriangleMesh(scene, V, F)`` (a copy into Embree's buffers one element
at a time through Python indexing: about as long as the build itself on 1.31M triangles) and the
first ray (``run`` commits the scene, then traces). Before 2026-12-02 this script reported that
whole path as "Embree's build". Instanced case: the one level-8 mesh (what an instancing
renderer builds; embreex has no instance API).

``--baseline OLD_LUMO`` also times another lumo binary (an earlier build) the same way, right
before the current one, for before/after ratios measured side by side.

Each repeat runs every size, lumo then Embree, so both see the same machine state; reported are
min-max ranges over --repeats and the 1-minute load average (2 cores: above ~2 means another job
competes); CPU times (lumo: user + system; Embree: this process's CPU time over the commit)
are far less inflated by other jobs than wall times. Output: ``out/start/results.csv`` and a
log-log plot of lumo's start time, Embree's commit and embreex's whole path, and lumo's peak
bytes per triangle against triangle count.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import common
from embree_rays import icosphere

OUT = common.HERE / "out" / "start"


def write_glb(path: Path, v: np.ndarray, f: np.ndarray, instances: int = 1) -> None:
    """A minimal glTF 2.0 binary: one mesh (positions, normals, uint32 indices), `instances`
    nodes referencing it, translated 2.5 apart along x."""
    pos = np.ascontiguousarray(v, dtype="<f4")
    nrm = pos / np.linalg.norm(pos, axis=1, keepdims=True).astype("<f4")
    idx = np.ascontiguousarray(f, dtype="<u4")
    blobs = [pos.tobytes(), np.ascontiguousarray(nrm, dtype="<f4").tobytes(), idx.tobytes()]
    offsets, off = [], 0
    for b in blobs:
        offsets.append(off)
        off += len(b)
    doc = {
        "asset": {"version": "2.0", "generator": "lumo benches/peers/start_bench.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(instances))}],
        "nodes": [{"mesh": 0, **({"translation": [2.5 * i, 0.0, 0.0]} if instances > 1 else {})}
                  for i in range(instances)],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "buffers": [{"byteLength": off}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": offsets[0], "byteLength": len(blobs[0]), "target": 34962},
            {"buffer": 0, "byteOffset": offsets[1], "byteLength": len(blobs[1]), "target": 34962},
            {"buffer": 0, "byteOffset": offsets[2], "byteLength": len(blobs[2]), "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3",
             "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
            {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": idx.size, "type": "SCALAR"},
        ],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    binary = b"".join(blobs)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    tmp = path.with_suffix(".tmp")
    with open(tmp, "wb") as fh:
        fh.write(struct.pack("<4sII", b"glTF", 2, total))
        fh.write(struct.pack("<I4s", len(js), b"JSON") + js)
        fh.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)
    tmp.replace(path)


def run_lumo(lumo: str, glb: Path) -> dict:
    """One start of lumo under /usr/bin/time -v: wall, user, sys seconds and peak RSS bytes."""
    out = glb.with_suffix(".png")
    cmd = ["/usr/bin/time", "-v", lumo, "render", str(glb), "-o", str(out), "--spp", "1",
           "--width", "64", "--height", "64", "-q"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")

    def field(name: str) -> str:
        m = re.search(rf"^\s*{re.escape(name)}: (.+)$", proc.stderr, re.M)
        if not m:
            raise SystemExit(f"no '{name}' in /usr/bin/time's output:\n{proc.stderr}")
        return m.group(1).strip()

    wall = 0.0
    for part in field("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":"):
        wall = wall * 60 + float(part)
    return {"wall": wall, "user": float(field("User time (seconds)")),
            "sys": float(field("System time (seconds)")),
            "rss": int(field("Maximum resident set size (kbytes)")) * 1024}


def _embree_lib():
    """The Embree 4 library that embreex ships (``embreex.libs/libembree4-*.so.4``), loaded with
    ctypes: embreex has no commit call (its ``EmbreeScene.run`` commits on the first query), so
    the commit alone is timed through Embree's C API on the same library."""
    import ctypes
    import glob

    import embreex

    libs = sorted(glob.glob(str(Path(embreex.__file__).parent.parent / "embreex.libs"
                                / "libembree4*.so*")))
    if not libs:
        raise SystemExit("no libembree4 next to embreex (embreex.libs/)")
    lib = ctypes.CDLL(libs[0])
    vp, u32, sz = ctypes.c_void_p, ctypes.c_uint, ctypes.c_size_t
    lib.rtcNewDevice.restype = vp
    lib.rtcNewDevice.argtypes = [ctypes.c_char_p]
    lib.rtcNewScene.restype = vp
    lib.rtcNewScene.argtypes = [vp]
    lib.rtcNewGeometry.restype = vp
    lib.rtcNewGeometry.argtypes = [vp, ctypes.c_int]
    lib.rtcSetNewGeometryBuffer.restype = vp
    lib.rtcSetNewGeometryBuffer.argtypes = [vp, ctypes.c_int, u32, ctypes.c_int, sz, sz]
    for name in ("rtcCommitGeometry", "rtcReleaseGeometry", "rtcCommitScene",
                 "rtcReleaseScene", "rtcReleaseDevice"):
        getattr(lib, name).restype = None
        getattr(lib, name).argtypes = [vp]
    lib.rtcAttachGeometry.restype = u32
    lib.rtcAttachGeometry.argtypes = [vp, vp]
    lib.rtcGetDeviceError.restype = ctypes.c_int
    lib.rtcGetDeviceError.argtypes = [vp]
    return lib


def embree_commit(lib, device, v: np.ndarray, f: np.ndarray) -> tuple[float, float]:
    """Wall and CPU seconds (all threads of this process) of ``rtcCommitScene`` alone: the BVH
    build. The scene is made as embreex makes it (default flags and build quality, one triangle
    geometry, float3 vertices with a 16-byte stride, uint3 indices), with the buffers filled by a
    memory copy before the clock starts."""
    import ctypes

    RTC_GEOMETRY_TYPE_TRIANGLE, RTC_BUFFER_TYPE_INDEX, RTC_BUFFER_TYPE_VERTEX = 0, 0, 1
    RTC_FORMAT_UINT3, RTC_FORMAT_FLOAT3 = 0x5003, 0x9003
    scene = lib.rtcNewScene(device)
    geom = lib.rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE)
    vb = lib.rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 16,
                                     len(v))
    ib = lib.rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, len(f))
    v4 = np.zeros((len(v), 4), dtype=np.float32)
    v4[:, :3] = v
    ctypes.memmove(vb, v4.ctypes.data, v4.nbytes)
    idx = np.ascontiguousarray(f, dtype=np.uint32)
    ctypes.memmove(ib, idx.ctypes.data, idx.nbytes)
    lib.rtcCommitGeometry(geom)
    lib.rtcAttachGeometry(scene, geom)
    lib.rtcReleaseGeometry(geom)
    c0, t0 = time.process_time(), time.perf_counter()
    lib.rtcCommitScene(scene)
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    err = lib.rtcGetDeviceError(device)
    lib.rtcReleaseScene(scene)
    if err:
        raise SystemExit(f"Embree error {err} in rtcCommitScene")
    return dt, cpu


def embreex_full(v: np.ndarray, f: np.ndarray) -> dict:
    """embreex's whole path, each part timed (wall seconds): ``EmbreeScene()`` (a new device and
    scene), ``TriangleMesh(scene, V, F)`` (copies the arrays into Embree's buffers one element
    at a time through Python indexing) and the first ray (``run`` commits the scene, i.e.
    ``rtcCommitScene``, then traces one ray)."""
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    o = np.zeros((1, 3), dtype=np.float32)
    d = np.array([[0, 0, 1]], dtype=np.float32)
    t0 = time.perf_counter()
    scene = rtcs.EmbreeScene()
    t1 = time.perf_counter()
    TriangleMesh(scene, v, f)
    t2 = time.perf_counter()
    scene.run(o, d, output=1)
    t3 = time.perf_counter()
    del scene
    return {"scene": t1 - t0, "mesh": t2 - t1, "first_ray": t3 - t2, "full": t3 - t0}


def rng(xs: list[float], fmt: str = "{:.3f}") -> str:
    lo, hi = min(xs), max(xs)
    return fmt.format(lo) if lo == hi else f"{fmt.format(lo)}–{fmt.format(hi)}"


def plot(rows: list[dict], path: Path) -> None:
    """Log-log: start/build time and peak memory against rendered triangles (best of repeats);
    memory per *stored* triangle (the instanced case stores one mesh)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_case: dict[str, list[dict]] = {}
    for r in rows:
        by_case.setdefault(r["case"], []).append(r)
    cases = sorted(by_case.values(), key=lambda rs: rs[0]["triangles"])
    n = np.array([rs[0]["triangles"] for rs in cases], dtype=float)
    stored = np.array([rs[0]["stored_triangles"] for rs in cases], dtype=float)
    best = lambda key: np.array([min(r[key] for r in rs) for rs in cases], dtype=float)
    has_base = all(r["baseline_s"] != "" for r in rows)
    inst = np.array([rs[0]["instances"] > 1 for rs in cases])
    load = f"load {min(r['load1'] for r in rows):.1f}–{max(r['load1'] for r in rows):.1f}"
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    a.loglog(n, best("lumo_s"), "o-", label="lumo start (load + build + 1 spp)")
    if has_base:
        a.loglog(n, best("baseline_s"), "o:", color="gray", label="lumo start, before")
    a.loglog(n, best("embree_commit_s"), "s--", label="Embree BVH build: rtcCommitScene")
    a.loglog(n, best("embreex_full_s"), "s:", color="tab:orange", alpha=0.6,
             label="embreex EmbreeScene + TriangleMesh + first ray")
    if inst.any():
        a.loglog(n[inst], best("lumo_s")[inst], "o", mfc="none", ms=13, color="k",
                 label="8 instances of 1.31 M")
    a.set_xlabel("triangles rendered")
    a.set_ylabel("seconds (best of repeats)")
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    b.loglog(n, best("rss_bytes") / 2**20, "o-", label="lumo peak RSS, MiB")
    b.loglog(n, best("rss_bytes") / stored, "^-", label="lumo peak bytes / stored triangle")
    if has_base:
        b.loglog(n, best("baseline_rss_bytes") / stored, "^:", color="gray",
                 label="bytes / stored triangle, before")
    b.axhline(80, color="tab:red", ls=":", lw=1, label="80 B / triangle (target)")
    if inst.any():
        b.loglog(n[inst], (best("rss_bytes") / stored)[inst], "o", mfc="none", ms=13,
                 color="k", label="8 instances of 1.31 M")
    b.set_xlabel("triangles rendered")
    b.grid(True, which="both", alpha=0.3)
    b.legend(fontsize=8)
    fig.suptitle(f"lumo start vs Embree commit, icosphere .glb, {os.cpu_count()} cores, {load}")
    fig.tight_layout()
    fig.savefig(path)
    print(f"wrote {path}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--lumo", default=str(common.REPO_ROOT / "target" / "release" / "lumo"))
    ap.add_argument("--baseline", default=None,
                    help="an earlier lumo binary, timed the same way in the same run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--levels", default="3,4,5,6,7,8")
    ap.add_argument("--instanced", type=int, default=8,
                    help="instances of the level-8 mesh in the largest case (0: none)")
    ap.add_argument("--plot", type=Path, default=None)
    ap.add_argument("--results", type=Path, default=OUT / "results.csv")
    args = ap.parse_args()
    if not Path(args.lumo).is_file():
        raise SystemExit(f"{args.lumo}: not found (cargo build --release)")
    OUT.mkdir(parents=True, exist_ok=True)
    cases = []  # (name, glb, V, F, instances)
    levels = [int(s) for s in args.levels.split(",") if s.strip()]
    meshes = {}
    for n in sorted(set(levels + ([8] if args.instanced else []))):
        meshes[n] = icosphere(n)
    for n in levels:
        v, f = meshes[n]
        glb = OUT / f"ico{n}.glb"
        write_glb(glb, v, f)
        cases.append((f"ico{n}", glb, v, f, 1))
    if args.instanced:
        v, f = meshes[8]
        glb = OUT / f"ico8x{args.instanced}.glb"
        write_glb(glb, v, f, args.instanced)
        cases.append((f"ico8x{args.instanced}", glb, v, f, args.instanced))
    import embreex

    lib = _embree_lib()
    device = lib.rtcNewDevice(None)
    embree_commit(lib, device, *icosphere(3))  # start Embree's worker threads before timing
    print(f"lumo {args.lumo}; embreex {getattr(embreex, '__version__', '?')}; "
          f"{os.cpu_count()} cores; {args.repeats} repeats", flush=True)
    rows = []
    for rep in range(args.repeats):
        for name, glb, v, f, k in cases:
            base = run_lumo(args.baseline, glb) if args.baseline else None
            lumo = run_lumo(args.lumo, glb)
            commit, commit_cpu = embree_commit(lib, device, v, f)
            full = embreex_full(v, f)
            tris = len(f) * k
            row = {"case": name, "repeat": rep, "triangles": tris, "stored_triangles": len(f),
                   "instances": k, "glb_bytes": glb.stat().st_size, "lumo_s": lumo["wall"],
                   "lumo_user_s": lumo["user"], "lumo_sys_s": lumo["sys"],
                   "rss_bytes": lumo["rss"], "embree_commit_s": commit,
                   "embree_commit_cpu_s": commit_cpu, "embreex_scene_s": full["scene"],
                   "embreex_mesh_s": full["mesh"], "embreex_first_ray_s": full["first_ray"],
                   "embreex_full_s": full["full"], "load1": common.load1(),
                   "baseline_s": base["wall"] if base else "",
                   "baseline_rss_bytes": base["rss"] if base else ""}
            rows.append(row)
            print(f"[{rep}] {name:8s} {tris:>10,} tris  lumo {lumo['wall']:.3f} s "
                  f"(user {lumo['user']:.2f} sys {lumo['sys']:.2f})  peak "
                  f"{lumo['rss'] / 2**20:7.1f} MiB = {lumo['rss'] / len(f):6.1f} B/stored tri  "
                  f"embree commit {commit:.3f} s (cpu {commit_cpu:.2f})  "
                  f"ratio {lumo['wall'] / commit:5.2f}  embreex mesh {full['mesh']:.3f} s "
                  f"first ray {full['first_ray']:.3f} s full {full['full']:.3f} s  "
                  + (f"baseline {base['wall']:.3f} s {base['rss'] / len(f):6.1f} B/tri  "
                     if base else "")
                  + f"load {row['load1']:.2f}", flush=True)
    lib.rtcReleaseDevice(device)
    with open(args.results, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"\nwrote {args.results}\n")
    print("| case | triangles | lumo start s | Embree commit s | lumo / commit | lumo CPU s | "
          "commit CPU s | embreex TriangleMesh s | embreex first ray (commit) s | "
          "embreex full s | lumo / full | peak MiB | peak B/stored triangle | load |"
          + (" baseline start s | baseline B/stored triangle |" if args.baseline else ""))
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
          + ("---:|---:|" if args.baseline else ""))
    for name, _, v, f, k in cases:
        rs = [r for r in rows if r["case"] == name]
        print(f"| {name} | {len(f) * k:,} | {rng([r['lumo_s'] for r in rs])} | "
              f"{rng([r['embree_commit_s'] for r in rs])} | "
              f"{rng([r['lumo_s'] / r['embree_commit_s'] for r in rs], '{:.2f}')} | "
              f"{rng([r['lumo_user_s'] + r['lumo_sys_s'] for r in rs], '{:.2f}')} | "
              f"{rng([r['embree_commit_cpu_s'] for r in rs], '{:.2f}')} | "
              f"{rng([r['embreex_mesh_s'] for r in rs])} | "
              f"{rng([r['embreex_first_ray_s'] for r in rs])} | "
              f"{rng([r['embreex_full_s'] for r in rs])} | "
              f"{rng([r['lumo_s'] / r['embreex_full_s'] for r in rs], '{:.2f}')} | "
              f"{rng([r['rss_bytes'] / 2**20 for r in rs], '{:.0f}')} | "
              f"{rng([r['rss_bytes'] / len(f) for r in rs], '{:.0f}')} | "
              f"{rng([r['load1'] for r in rs], '{:.2f}')} |"
              + (f" {rng([r['baseline_s'] for r in rs])} | "
                 f"{rng([r['baseline_rss_bytes'] / len(f) for r in rs], '{:.0f}')} |"
                 if args.baseline else ""))
    if args.plot:
        plot(rows, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
