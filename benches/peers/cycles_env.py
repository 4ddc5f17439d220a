"""Blender Cycles reference renders of lumo's HDR environment light (an equirectangular image as
``background.image``), for checking its orientation, rotation and brightness against Blender's
Environment Texture: per scene a mean image and the per-pixel variance of that mean.

    .venv/bin/python cycles_env.py [--scenes A,B] [--passes 8] [--spp 256] [--out DIR]
                                   [--export-glb --lumo PATH] [--lumo-check --lumo PATH]

The scenes are lumo scene files ``<out>/<name>.json`` (format_version 2: three spheres and an HDR
background; see ``tests/data/cycles_env/README.md``). For every scene:

1. Geometry and materials: ``<out>/spheres.glb``, written by ``lumo convert spheres_sunrise.json
   -o spheres.glb`` (``--export-glb`` rewrites it). All scenes share the same spheres, so one GLB
   serves them all: before importing, the script checks that the GLB's ``extras.lumo`` (the
   spheres' centres and radii, the materials) equal the scene file's ``objects`` and
   ``materials``. Imported with Blender's bundled glTF importer into an empty factory-settings
   scene (``cycles_gltf.import_model``, which turns glTF's y-up into Blender's z-up as
   (x, y, z) -> (x, -z, y)); the GLB's camera is deleted.
2. Camera: from the scene file (``position``, ``look_at``, ``up``, ``fov_y_deg``) with
   ``cycles_gltf.add_camera`` (the same frame change, vertical field of view, checked by
   projection).
3. World: Environment Texture (equirectangular, interpolation Linear) of ``background.image`` ->
   Background (Strength = ``background.strength``) -> World Output; visible to the camera, world
   importance sampling "Auto" (Blender's default). Rotation 0: the texture's Vector input is left
   unlinked (Blender's default mapping, the world direction), which is lumo's convention for an
   unrotated image. ``rotation_deg`` = phi != 0: Texture Coordinate (Generated) -> Mapping (type
   Point, Rotation Z = -phi) -> Vector. The sign: a Point mapping computes R_z(theta) * d and the
   texture is looked up there, so the image turns by -theta about Blender's +z (= lumo's +y); lumo
   turns it by +phi (counter-clockwise seen from above), hence theta = -phi. (Equivalently:
   Mapping type Texture with Rotation Z = +phi.) The image as Blender loaded it is compared with
   the file read by OpenEXR (they must agree).
4. Cycles settings: ``cycles_gltf.configure_cycles`` (CPU; Box 1 px; no denoising, adaptive
   sampling or clamping; light tree off; Filter Glossy 0; max bounces 6 = lumo's max_depth 8;
   view transform Standard; 128 x 128; the EXR holds the scene-linear result).
5. K passes (``--passes``) of ``--spp`` samples, seeds 1..K. ``<name>.exr`` = mean,
   ``<name>.var.exr`` = sample variance of the passes / K (the variance of the mean), float32 RGB,
   ZIP; ``<name>.png`` = sRGB preview (clamped; kept if under 30 KB).
6. Check, independent of lumo (``Geometry.orientation_check``): numpy predicts two sets of
   pixels from the documented convention (lumo y-up: turn the direction by -phi about +y, then
   u = 0.5 + atan2(z, x) / 2pi, v = 0.5 + asin(y) / pi from the bottom row; bilinear lookup;
   times strength), with 8 x 8 sub-pixel rays per pixel and analytic spheres: the background
   (pixels all of whose rays miss every sphere, one pixel of margin) and the mirror sphere's
   reflection (pixels all of whose reflected rays escape to the environment). The same is
   predicted for wrong alternatives (rotation sign flipped, mirrored, turned +-90 / 180 degrees,
   upside down). The render must fit the documented one best, with a median relative error
   (luminance) under 3 %, or the script stops.

``--lumo-check`` also renders every scene with lumo (``lumo render X.json -o ... --spp N
--error-image ...``, into ``--lumo-out`` or a temporary folder; in the repo only the summary in
``renders.json``) and prints the RMSE against the Cycles mean, the image means, the mean, median
and mean z^2 of each region (background, each sphere), the same orientation check for lumo's
image, the brightest pixel of the mirror sphere (lumo, Cycles, numpy prediction) and the
brightness centroid of the diffuse sphere in both images.

Records go to ``<out>/renders.json``. Run it with ``nice -n 10`` on a shared machine.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import common
import cycles_gltf as cg
from cycles_cornell import Timer

SCENES = ("spheres_sunrise", "spheres_sunrise_rot90", "spheres_city_strength")
GLB_NAME = "spheres.glb"
GLB_SOURCE_SCENE = "spheres_sunrise"
DEFAULT_OUT = common.REPO_ROOT / "tests" / "data" / "cycles_env"
FIRST_SEED = 1
SUBPIXELS = 8           # sub-pixel rays per axis for the numpy checks
ORIENTATION_TOLERANCE = 0.03
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


# --- scene files -----------------------------------------------------------------------------------

def load_scene(path: Path) -> dict:
    scene = json.loads(path.read_text())
    if scene.get("format_version") != 2:
        raise RuntimeError(f"{path}: format_version {scene.get('format_version')}, want 2")
    bg = scene.get("background") or {}
    if not bg.get("image"):
        raise RuntimeError(f"{path}: background.image missing")
    img = Path(bg["image"])
    if not img.is_absolute():
        img = (path.parent / img).resolve()
    if not img.is_file():
        raise FileNotFoundError(f"{path}: background image {img} not found")
    size = scene.get("image", {})
    if (size.get("width"), size.get("height")) != (cg.WIDTH, cg.HEIGHT):
        raise RuntimeError(f"{path}: image {size}, this script renders {cg.WIDTH} x {cg.HEIGHT}")
    for obj in scene["objects"]:
        if set(obj) != {"sphere"}:
            raise RuntimeError(f"{path}: only spheres are supported, got {sorted(obj)}")
    return {
        "path": path,
        "json": scene,
        "camera": {k: scene["camera"][k] for k in ("position", "look_at", "up", "fov_y_deg")},
        "image": img,
        "strength": float(bg.get("strength", 1.0)),
        "rotation_deg": float(bg.get("rotation_deg", 0.0)),
        "visible": bool(bg.get("visible", True)),
        "spheres": [(np.array(o["sphere"]["center"], float), float(o["sphere"]["radius"]),
                     o["sphere"]["material"]) for o in scene["objects"]],
    }


def _close(a, b) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return set(a) == set(b) and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(a - b) <= 1e-6 * max(1.0, abs(a), abs(b))
    return a == b


def check_glb(glb: Path, sc: dict) -> None:
    """The GLB holds exactly the scene's spheres and materials (from its ``extras.lumo``)."""
    g = cg.read_gltf_json(glb)
    mats = g.get("materials", [])
    found = []
    for node in g.get("nodes", []):
        sphere = node.get("extras", {}).get("lumo", {}).get("sphere")
        if sphere is None:
            continue
        prims = g["meshes"][node["mesh"]]["primitives"]
        mat = mats[prims[0]["material"]]
        found.append((sphere["center"], sphere["radius"], mat["name"],
                      mat.get("extras", {}).get("lumo", {}).get("material")))
    want = [(list(c), r, m, sc["json"]["materials"][m]) for c, r, m in sc["spheres"]]
    if len(found) != len(want) or not all(_close(list(f), list(w)) for f, w in zip(found, want)):
        raise RuntimeError(f"{glb} does not hold the spheres/materials of {sc['path'].name}:\n"
                           f"  glb:   {found}\n  scene: {want}\n"
                           "re-export it (--export-glb --lumo PATH)")


def export_glb(lumo: str, scene_json: Path, glb: Path) -> None:
    proc = subprocess.run([lumo, "convert", str(scene_json), "-o", str(glb)],
                          capture_output=True, text=True)
    if proc.returncode != 0 or not glb.is_file():
        raise RuntimeError(f"`{lumo} convert {scene_json} -o {glb}` failed: "
                           f"{proc.stderr.strip() or proc.stdout.strip()}")


# --- Blender scene ----------------------------------------------------------------------------------

def set_env_world(bpy, scene, sc: dict) -> dict:
    """Environment Texture world (see the module docstring); returns what was built."""
    world = bpy.data.worlds.new("env")
    scene.world = world  # before setting world.cycles.* (their update callbacks read it)
    if world.node_tree is None:
        world.use_nodes = True
    nt = world.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    image = bpy.data.images.load(str(sc["image"]), check_existing=False)
    image.colorspace_settings.name = "Linear Rec.709"
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = image
    tex.projection = "EQUIRECTANGULAR"
    tex.interpolation = "Linear"
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = sc["strength"]
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    mapping_z = None
    if sc["rotation_deg"] != 0.0:
        coord = nt.nodes.new("ShaderNodeTexCoord")
        mapping = nt.nodes.new("ShaderNodeMapping")
        mapping.vector_type = "POINT"
        mapping_z = -sc["rotation_deg"]
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(mapping_z))
        nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    world.cycles.sampling_method = "AUTOMATIC"
    world.cycles_visibility.camera = sc["visible"]

    # The image as Blender decoded it must equal the file as OpenEXR decodes it.
    w, h = image.size
    px = np.array(image.pixels[:], dtype=np.float64).reshape(h, w, image.channels)[::-1, :, :3]
    ref = common.read_exr(sc["image"])
    if px.shape != ref.shape:
        raise RuntimeError(f"{sc['image']}: Blender reads {px.shape}, OpenEXR {ref.shape}")
    rel = float(np.max(np.abs(px - ref) / np.maximum(np.abs(ref), 1e-3)))
    if rel > 1e-4:
        raise RuntimeError(f"{sc['image']}: Blender's pixels differ from OpenEXR's by up to {rel:.3g} "
                           "(relative)")
    return {
        "image": str(sc["image"]),
        "image_size": [w, h],
        "colorspace": image.colorspace_settings.name,
        "blender_vs_openexr_max_rel_diff": rel,
        "projection": tex.projection,
        "interpolation": tex.interpolation,
        "strength": bg.inputs["Strength"].default_value,
        "vector": ("unlinked (default mapping)" if mapping_z is None
                   else f"Texture Coordinate Generated -> Mapping POINT rotation Z = {mapping_z:g} deg"),
        "mapping_rotation_z_deg": mapping_z,
        "sampling_method": world.cycles.sampling_method,
        "sample_map_resolution": world.cycles.sample_map_resolution,
        "camera_visible": world.cycles_visibility.camera,
    }


def imported_materials(bpy) -> dict:
    """The Principled BSDF inputs the importer set, per material (for the record)."""
    out = {}
    for mat in bpy.data.materials:
        if mat.node_tree is None:
            continue
        for node in mat.node_tree.nodes:
            if node.type == "BSDF_PRINCIPLED":
                vals = {}
                vals["distribution"] = node.distribution
                for name in ("Base Color", "Metallic", "Roughness", "IOR", "Specular IOR Level",
                             "Specular Tint", "Diffuse Roughness", "Coat Weight", "Sheen Weight",
                             "Transmission Weight", "Emission Strength"):
                    sock = node.inputs.get(name)
                    if sock is None:
                        continue
                    v = sock.default_value
                    v = [round(float(x), 6) for x in v][:3] if hasattr(v, "__len__") else round(float(v), 6)
                    vals[name] = v if not sock.is_linked else f"linked ({v})"
                out[mat.name] = vals
    return out


# --- numpy checks ----------------------------------------------------------------------------------

def camera_rays(cam: dict, w: int, h: int, n: int = SUBPIXELS) -> np.ndarray:
    """(h, w, n*n, 3) unit directions of n x n stratified (cell-centre) rays per pixel, pinhole
    camera as lumo's and Blender's (row 0 = top)."""
    pos, at, up = (np.array(cam[k], float) for k in ("position", "look_at", "up"))
    f = at - pos
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    t = math.tan(math.radians(cam["fov_y_deg"]) / 2)
    sub = (np.arange(n) + 0.5) / n
    xs = ((np.arange(w)[:, None] + sub[None, :]).ravel() * 2 / w - 1) * t * w / h   # (w*n,)
    ys = (1 - (np.arange(h)[:, None] + sub[None, :]).ravel() * 2 / h) * t           # (h*n,)
    d = f + xs[None, :, None] * r + ys[:, None, None] * u                            # (h*n, w*n, 3)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d.reshape(h, n, w, n, 3).transpose(0, 2, 1, 3, 4).reshape(h, w, n * n, 3)


def first_hit(origins: np.ndarray, dirs: np.ndarray, spheres, skip: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """(index of the first sphere each ray hits or -1, its distance or inf); ``origins``
    broadcasts against ``dirs`` (unit); sphere ``skip`` is ignored."""
    shape = np.broadcast_shapes(np.shape(origins)[:-1], dirs.shape[:-1])
    best = np.full(shape, np.inf)
    ids = np.full(shape, -1)
    for k, (c, rad, _) in enumerate(spheres):
        if k == skip:
            continue
        oc = origins - c
        b = np.sum(dirs * oc, axis=-1)
        disc = b * b - (np.sum(oc * oc, axis=-1) - rad * rad)
        sq = np.sqrt(np.maximum(disc, 0))
        t = np.where(-b - sq > 1e-6, -b - sq, -b + sq)
        hit = (disc > 0) & (t > 1e-6) & (t < best)
        best[hit] = t[hit]
        ids[hit] = k
    return ids, best


def erode(mask: np.ndarray) -> np.ndarray:
    """Pixels of ``mask`` whose 8 neighbours are in it too."""
    m = np.pad(mask, 1, constant_values=False)
    out = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out &= m[1 + dy:1 + dy + mask.shape[0], 1 + dx:1 + dx + mask.shape[1]]
    return out


def env_lookup(env: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Bilinear lookup (texel centres at (i + 0.5) / size, u periodic, v clamped) of an
    equirectangular image (row 0 = top) in lumo's documented orientation, unrotated."""
    h, w, _ = env.shape
    u = 0.5 + np.arctan2(d[..., 2], d[..., 0]) / (2 * math.pi)
    v = 0.5 - np.arcsin(np.clip(d[..., 1], -1, 1)) / math.pi          # from the top row
    x = u * w - 0.5
    y = np.clip(v * h - 0.5, 0, h - 1)
    x0 = np.floor(x).astype(int)
    y0 = np.minimum(np.floor(y).astype(int), h - 2)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    x0 %= w
    x1 = (x0 + 1) % w
    return ((env[y0, x0] * (1 - fx) + env[y0, x1] * fx) * (1 - fy)
            + (env[y0 + 1, x0] * (1 - fx) + env[y0 + 1, x1] * fx) * fy)


def rot_y(d: np.ndarray, deg: float) -> np.ndarray:
    """Rotates directions by ``deg`` about +y (right-handed: x -> -z for +90)."""
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([c * x + s * z, y, -s * x + c * z], axis=-1)


#: name -> direction transform applied before the unrotated lookup (phi = rotation_deg).
HYPOTHESES = {
    "documented": lambda d, phi: rot_y(d, -phi),
    "rotation sign flipped": lambda d, phi: rot_y(d, phi),
    "mirrored (u -> 1 - u)": lambda d, phi: rot_y(d, -phi) * np.array([1, 1, -1]),
    "turned 180 deg (u + 0.5)": lambda d, phi: rot_y(d, -phi - 180),
    "turned +90 deg": lambda d, phi: rot_y(d, -phi - 90),
    "turned -90 deg": lambda d, phi: rot_y(d, -phi + 90),
    "upside down (v -> 1 - v)": lambda d, phi: rot_y(d, -phi) * np.array([1, -1, 1]),
}


def is_mirror(material: dict) -> bool:
    """lumo's perfect mirror (metallic 1, roughness 0, white base colour): reflectance 1 at every
    angle in lumo and in Blender's Principled BSDF (F82 tint model with F0 = tint = 1)."""
    return (material.get("metallic", 0) == 1 and material.get("roughness", 0.5) == 0
            and list(material.get("base_color", [0.8] * 3)) == [1, 1, 1])


class Geometry:
    """Per-scene pixel masks and the numpy predictions (computed once):

    - ``background``: pixels all of whose sub-pixel rays miss every sphere, eroded by a pixel.
    - ``sphere_masks``: pixels all of whose sub-pixel rays hit that sphere, eroded by a pixel.
    - ``mirror``: pixels of a mirror sphere all of whose reflected sub-pixel rays escape (none
      hits another sphere).
    Predictions: the environment seen along the (reflected) rays under each of ``HYPOTHESES``.
    """

    def __init__(self, sc: dict):
        self.sc = sc
        o = np.array(sc["camera"]["position"], float)
        dirs = camera_rays(sc["camera"], cg.WIDTH, cg.HEIGHT)
        ids, t = first_hit(o, dirs, sc["spheres"])
        self.background = erode(np.all(ids == -1, axis=-1))
        self.sphere_masks = {m: erode(np.all(ids == k, axis=-1))
                             for k, (_, _, m) in enumerate(sc["spheres"])}
        self.sphere_centres_px = {}
        for k, (_, _, m) in enumerate(sc["spheres"]):
            rows, cols = np.nonzero(np.any(ids == k, axis=-1))
            self.sphere_centres_px[m] = (float(rows.mean()), float(cols.mean()))
        self.env = np.maximum(common.read_exr(sc["image"]), 0.0)  # negative DWAB noise -> 0 (lumo)
        self.regions = {"background": (self.background, dirs[self.background])}
        self.mirror_name = None
        for k, (c, rad, m) in enumerate(sc["spheres"]):
            if not is_mirror(sc["json"]["materials"][m]) or self.mirror_name is not None:
                continue
            mask = self.sphere_masks[m]
            d = dirs[mask]                                            # (N, n*n, 3)
            p = o + t[mask][..., None] * d
            nrm = (p - c) / rad
            refl = d - 2 * np.sum(d * nrm, axis=-1, keepdims=True) * nrm
            hit, _ = first_hit(p, refl, sc["spheres"], skip=k)
            escapes = np.all(hit == -1, axis=-1)
            full = np.zeros_like(mask)
            full[mask] = escapes
            self.mirror_name = m
            self.mirror = full
            self.regions[f"{m} reflection"] = (full, refl[escapes])
        self.predictions = {}
        for region, (_, rays) in self.regions.items():
            self.predictions[region] = {
                name: sc["strength"] * env_lookup(self.env, f(rays, sc["rotation_deg"])).mean(axis=1)
                for name, f in HYPOTHESES.items()
                if not (name == "rotation sign flipped" and sc["rotation_deg"] == 0)}

    def predicted_image(self, hypothesis: str = "documented") -> np.ndarray:
        """The predicted pixels (NaN where there is no prediction)."""
        img = np.full((cg.HEIGHT, cg.WIDTH, 3), np.nan)
        for region, (mask, _) in self.regions.items():
            img[mask] = self.predictions[region][hypothesis]
        return img

    def orientation_check(self, img: np.ndarray) -> dict:
        """Per region (background; the mirror sphere's reflection): the median over pixels of
        |image - prediction| / prediction (luminance) for every hypothesis, the best one, and the
        ratio of the region's mean to the documented prediction's (RGB)."""
        out = {}
        for region, (mask, _) in self.regions.items():
            px = img[mask]
            y = px @ LUMINANCE
            errs = {}
            for name, pred in self.predictions[region].items():
                py = pred @ LUMINANCE
                errs[name] = round(float(np.median(np.abs(y - py) / np.maximum(py, 1e-6))), 5)
            doc = self.predictions[region]["documented"]
            out[region] = {
                "pixels": int(mask.sum()),
                "median_rel_err": dict(sorted(errs.items(), key=lambda kv: kv[1])),
                "best": min(errs, key=errs.get),
                "mean_ratio_rgb_vs_documented": (px.mean(axis=0) / doc.mean(axis=0)).round(5).tolist(),
            }
        return out


def assert_documented(check: dict, who: str) -> None:
    for region, c in check.items():
        if c["best"] != "documented" or c["median_rel_err"]["documented"] > ORIENTATION_TOLERANCE:
            raise RuntimeError(f"{who}: {region} pixels fit '{c['best']}' best (median relative "
                               f"errors {c['median_rel_err']}); the documented orientation must fit "
                               f"best and within {ORIENTATION_TOLERANCE:.0%}")


def fmt_check(check: dict) -> str:
    parts = []
    for region, c in check.items():
        errs = ", ".join(f"{k} {v:.4f}" for k, v in c["median_rel_err"].items())
        parts.append(f"{region} ({c['pixels']} px): best {c['best']}; median rel. err. {errs}; "
                     f"mean / documented {c['mean_ratio_rgb_vs_documented']}")
    return "\n      ".join(parts)


# --- lumo check --------------------------------------------------------------------------------------

def lumo_check(lumo: str, sc: dict, geo: Geometry, cyc_mean: np.ndarray, cyc_var: np.ndarray,
               spp: int, out_dir: Path) -> dict:
    """Renders the scene with lumo and compares it with the Cycles mean (printed and returned)."""
    name = sc["path"].stem
    img_path = out_dir / f"{name}_lumo.exr"
    err_path = out_dir / f"{name}_lumo.stderr.exr"
    t0 = time.perf_counter()
    proc = subprocess.run([lumo, "render", str(sc["path"]), "-o", str(img_path), "--spp", str(spp),
                           "--error-image", str(err_path), "-q"], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"lumo render {sc['path']} failed: {proc.stderr.strip()}")
    lum = common.read_exr(img_path)
    se = common.read_exr(err_path) if err_path.is_file() else None
    diff = lum - cyc_mean
    res = {
        "lumo_spp": spp,
        "lumo_seconds": round(seconds, 2),
        "rmse": float(np.sqrt(np.mean(diff ** 2))),
        "mean_lumo": lum.reshape(-1, 3).mean(axis=0).round(5).tolist(),
        "mean_cycles": cyc_mean.reshape(-1, 3).mean(axis=0).round(5).tolist(),
        "orientation_check_lumo": geo.orientation_check(lum),
    }
    # RMSE without the few brightest pixels (sun reflections dominate the plain RMSE).
    lum_y = cyc_mean @ LUMINANCE
    keep = lum_y < np.quantile(lum_y, 0.99)
    res["rmse_without_brightest_1pct"] = float(np.sqrt(np.mean(diff[keep] ** 2)))
    if se is not None:
        z2 = diff ** 2 / (cyc_var + se ** 2 + 1e-12)
        res["mean_z2"] = float(np.mean(z2))  # ~1 if the two agree up to noise
    regions = {"background": geo.background, **geo.sphere_masks}
    res["region_means"] = {}
    for rname, mask in regions.items():
        a, b = lum[mask].mean(axis=0), cyc_mean[mask].mean(axis=0)
        ma, mb = np.median(lum[mask] @ LUMINANCE), np.median(cyc_mean[mask] @ LUMINANCE)
        res["region_means"][rname] = {"lumo": a.round(5).tolist(), "cycles": b.round(5).tolist(),
                                      "ratio": (a / b).round(4).tolist(),
                                      "median_luminance_ratio": round(float(ma / mb), 4)}
        if se is not None:
            res["region_means"][rname]["mean_z2"] = round(float(np.mean(z2[mask])), 3)
    # Orientation markers: the brightest pixel of the mirror sphere (in lumo, Cycles and the
    # numpy prediction of its reflection); the luminance-weighted centroid of the diffuse sphere
    # relative to its centre (luminance clipped at 3 x the region's median, against fireflies).
    for m, mask in geo.sphere_masks.items():
        mat = sc["json"]["materials"][m]
        if m == geo.mirror_name:
            pred = geo.predicted_image()

            def brightest(img, region=mask):
                y = np.where(region & np.all(np.isfinite(img), axis=-1), img @ LUMINANCE, -np.inf)
                r, c = np.unravel_index(np.argmax(y), y.shape)
                return {"px": [int(r), int(c)], "luminance": round(float(y[r, c]), 3)}
            res[f"brightest_px_{m}"] = {"lumo": brightest(lum), "cycles": brightest(cyc_mean),
                                        "predicted": brightest(pred, geo.mirror),
                                        "sphere_centre_px": [round(v, 1) for v in geo.sphere_centres_px[m]]}
        if mat.get("specular", None) == 0 and mat.get("metallic", 0) == 0:
            rr, cc = np.nonzero(mask)

            def centroid(img):
                y = (img @ LUMINANCE)[mask]
                y = np.minimum(y, 3 * np.median(y))
                return [round(float((rr * y).sum() / y.sum() - rr.mean()), 2),
                        round(float((cc * y).sum() / y.sum() - cc.mean()), 2)]
            res[f"brightness_centroid_offset_px_{m}"] = {"lumo": centroid(lum), "cycles": centroid(cyc_mean)}
    return res


def print_lumo(res: dict) -> None:
    print(f"  lumo {res['lumo_spp']} spp ({res['lumo_seconds']:.1f} s): RMSE vs Cycles {res['rmse']:.5f} "
          f"(without the brightest 1 %: {res['rmse_without_brightest_1pct']:.5f}); "
          f"mean z^2 {res.get('mean_z2', float('nan')):.3f}")
    print(f"    image mean lumo {res['mean_lumo']}  cycles {res['mean_cycles']}")
    for rname, v in res["region_means"].items():
        print(f"    {rname:10s} mean lumo {v['lumo']}  cycles {v['cycles']}  ratio {v['ratio']}; "
              f"median luminance ratio {v['median_luminance_ratio']}; mean z^2 {v.get('mean_z2')}")
    print(f"    lumo orientation: {fmt_check(res['orientation_check_lumo'])}")
    for k, v in res.items():
        if k.startswith(("brightest_px_", "brightness_centroid")):
            print(f"    {k}: {v}")


# --- main ----------------------------------------------------------------------------------------------

def render_scene(bpy, sc: dict, glb: Path, args) -> tuple[dict, dict, np.ndarray, np.ndarray, Geometry]:
    name = sc["path"].stem
    t_job = time.perf_counter()
    check_glb(glb, sc)
    cg.reset_blender(bpy)
    scene = bpy.context.scene
    _, notable = cg.import_model(bpy, glb)
    for ln in notable:
        print(f"  importer: {ln}")
    lights, cams = cg.remove_lights_and_cameras(bpy)
    materials = imported_materials(bpy)
    world = set_env_world(bpy, scene, sc)
    settings = cg.configure_cycles(scene)
    settings["world"] = "Environment Texture (see each scene's 'world')"
    cg.add_camera(bpy, scene, sc["camera"])
    timer = Timer(bpy)
    print(f"  world: {world['vector']}, strength {world['strength']:g}; materials {materials}",
          flush=True)

    seeds = [FIRST_SEED + k for k in range(args.passes)]
    stack, render_s, cpu_s, loads = cg.render_passes(bpy, scene, timer, args.spp, seeds, "cycles_env_")
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / args.passes

    geo = Geometry(sc)
    check = geo.orientation_check(mean)
    print(f"  cycles orientation: {fmt_check(check)}", flush=True)
    assert_documented(check, f"{name} (Cycles)")

    args.out.mkdir(parents=True, exist_ok=True)
    common.write_exr(args.out / f"{name}.exr", mean.astype(np.float32))
    common.write_exr(args.out / f"{name}.var.exr", var_of_mean.astype(np.float32))
    png_bytes = cg.write_png_preview(args.out / f"{name}.png", mean)
    total_s = time.perf_counter() - t_job
    entry = {
        "scene": sc["path"].name,
        "glb": glb.name,
        "camera": sc["camera"],
        "world": world,
        "materials_imported": materials,
        "lights_removed": lights,
        "cameras_removed": cams,
        "importer_warnings": notable,
        "passes": args.passes,
        "spp_per_pass": args.spp,
        "spp": args.passes * args.spp,
        "seeds": seeds,
        "render_seconds": round(render_s, 2),
        "render_cpu_seconds": round(cpu_s, 2),
        "total_seconds": round(total_s, 2),
        "load1_max": round(max(loads), 2),
        "blender": bpy.app.version_string,
        "image_mean": [round(float(v), 6) for v in mean.reshape(-1, 3).mean(axis=0)],
        "orientation_check": check,
        "png_preview_bytes": png_bytes,
    }
    print(f"  -> {name}: {args.passes} x {args.spp} spp, render {render_s:.1f} s (cpu {cpu_s:.1f} s), "
          f"total {total_s:.1f} s; image mean {entry['image_mean']}; png "
          f"{'%d B' % png_bytes if png_bytes else 'skipped (>= 30 KB)'}", flush=True)
    return entry, settings, mean, var_of_mean, geo


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated scene names")
    ap.add_argument("--passes", type=int, default=8, help="independent passes K (default 8)")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel per pass (default 256)")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT,
                    help=f"folder of the scene files and outputs (default {DEFAULT_OUT})")
    ap.add_argument("--lumo", default=cg.default_lumo(), help="lumo binary (for --export-glb, --lumo-check)")
    ap.add_argument("--export-glb", action="store_true",
                    help=f"rewrite {GLB_NAME} with `lumo convert {GLB_SOURCE_SCENE}.json -o {GLB_NAME}`")
    ap.add_argument("--lumo-check", action="store_true",
                    help="also render each scene with lumo and compare (printed, and in renders.json)")
    ap.add_argument("--lumo-spp", type=int, default=256, help="lumo's spp for --lumo-check")
    ap.add_argument("--lumo-out", type=Path, default=None,
                    help="keep lumo's renders here (default: a temporary folder)")
    ap.add_argument("--no-render", action="store_true",
                    help="use the stored Cycles images (only the checks and --lumo-check)")
    args = ap.parse_args()
    if args.passes < 2 or args.spp < 1:
        raise SystemExit("need --passes >= 2 and --spp >= 1")
    args.out = args.out.resolve()
    names = [s.strip() for s in args.scenes.split(",") if s.strip()]
    glb = args.out / GLB_NAME
    if args.export_glb:
        export_glb(args.lumo, args.out / f"{GLB_SOURCE_SCENE}.json", glb)
        print(f"wrote {glb}")

    record_path = args.out / "renders.json"
    record = json.loads(record_path.read_text()) if record_path.is_file() else {}
    record.setdefault("scenes", {})
    failed = []
    lumo_dir_ctx = (contextlib.nullcontext(args.lumo_out) if args.lumo_out
                    else tempfile.TemporaryDirectory(prefix="cycles_env_lumo_"))
    bpy = None
    with lumo_dir_ctx as lumo_dir:
        lumo_dir = Path(lumo_dir)
        lumo_dir.mkdir(parents=True, exist_ok=True)
        for name in names:
            print(f"== {name}", flush=True)
            try:
                sc = load_scene(args.out / f"{name}.json")
                if args.no_render:
                    mean = common.read_exr(args.out / f"{name}.exr")
                    var = common.read_exr(args.out / f"{name}.var.exr")
                    geo = Geometry(sc)
                    check = geo.orientation_check(mean)
                    print(f"  cycles orientation: {fmt_check(check)}", flush=True)
                    assert_documented(check, f"{name} (Cycles)")
                    entry = record["scenes"].get(name, {})
                    entry["orientation_check"] = check
                else:
                    if bpy is None:
                        import bpy as _bpy
                        bpy = _bpy
                        record["generator"] = "benches/peers/cycles_env.py"
                        record["blender"] = bpy.app.version_string
                    entry, settings, mean, var, geo = render_scene(bpy, sc, glb, args)
                    record["settings"] = settings
                    record["command"] = " ".join(shlex.quote(a) for a in (
                        ["nice", "-n", "10", "benches/peers/.venv/bin/python", "benches/peers/cycles_env.py"]
                        + (["--passes", str(args.passes)] if args.passes != 8 else [])
                        + (["--spp", str(args.spp)] if args.spp != 256 else [])))
                if args.lumo_check:
                    res = lumo_check(args.lumo, sc, geo, mean, var, args.lumo_spp, lumo_dir)
                    res["lumo_version"] = cg.lumo_version(args.lumo)
                    print_lumo(res)
                    entry["lumo_check"] = res
                record["scenes"][name] = entry
                head = ("generator", "blender", "command", "settings")
                record = {**{k: record[k] for k in head if k in record},
                          **{k: v for k, v in record.items() if k not in head}}
                record_path.write_text(cg.to_json(record) + "\n")
            except Exception as e:
                print(f"ERROR: {name}: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
                import traceback
                traceback.print_exc()
                failed.append(name)
    print("\nper-scene timings:")
    for name in names:
        e = record["scenes"].get(name, {})
        if "render_seconds" in e:
            print(f"  {name:26s} {e['spp']:5d} spp  render {e['render_seconds']:8.1f} s  "
                  f"total {e['total_seconds']:8.1f} s")
    if failed:
        print(f"FAILED: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
