"""Reference renders of Khronos glTF sample models with Blender Cycles (PyPI ``bpy``), for lumo's
glTF material tests: per model a mean image and the per-pixel variance of that mean.

    .venv/bin/python cycles_gltf.py [--models A,B|all] [--passes 8] [--spp 256] [--lumo PATH]
                                    [--gltf-root DIR] [--out DIR] [--env FILE.exr]
                                    [--still PNG --size 384]

For every model (``<Name>``, ``<Name>_nonormal`` or ``<Name>_flat``):

1. The camera comes from lumo: ``lumo convert MODEL -o x.json`` writes lumo's scene for the glTF
   file, whose ``camera`` (``position``, ``look_at``, ``up``, ``fov_y_deg``, glTF's y-up frame) is
   the file's first camera or lumo's automatic framing. It is turned into Blender's z-up frame the
   way Blender's glTF importer turns the model, (x, y, z) -> (x, -z, y), with a vertical field of
   view (``sensor_fit = VERTICAL``), and checked by projecting points with Blender's own camera
   maths. The values are recorded in ``cameras.json``.
2. A fresh Blender scene (factory settings, empty) imports the model with the bundled glTF
   importer (``io_scene_gltf2``, default options). Its console log is captured; warnings, errors
   and extensions the file uses but the importer does not handle are printed and recorded.
   Lights and cameras the file brings are deleted. The only light is a world of constant grey 0.5,
   strength 1. ``_nonormal``: every Normal Map node is unlinked from the Principled BSDF's Normal
   input (the normal maps are then ignored). ``_flat``: every mesh loses its custom (the file's)
   normals and is shaded flat, so that shading normals are the geometric ones (lumo's
   ``smooth: false``).
3. Cycles settings (the issue's list): CPU, all threads; Box pixel filter 1 px; no denoising; no
   adaptive sampling; no clamping; light tree off; Filter Glossy 0; caustics reflective and
   refractive on (Blender's defaults); max bounces 6 (diffuse, glossy, transmission and volume 6
   too); transparent max bounces 64; sampling pattern Blender's default; view transform Standard,
   look None, exposure 0, gamma 1; 128 x 128. The EXR Blender writes holds the scene-linear render
   result (no view transform), as in ``cycles_cornell.py``.
4. K passes (``--passes``) of ``--spp`` samples with seeds 1, 2, ..., K. Output in ``--out``:
   ``<Name>.exr`` = mean of the passes, ``<Name>.var.exr`` = sample variance of the passes / K
   (the variance of the mean), both float32 RGB, ZIP (``common.write_exr``); ``<Name>.png`` = an
   sRGB preview (clamped), kept only when under 30 KB. ``cameras.json`` (cameras plus render
   metadata, merged with what is already there so that ``--models`` re-renders only some) and
   ``README.md`` (generated from ``cameras.json``) are rewritten after every model.

A model that fails (lumo convert, import, render) prints an error and the others go on; the exit
status is 1 if any failed. Per-model timings are printed. Run it with ``nice -n 10`` on a shared
machine.

``--env FILE.exr`` (environment mode): the world is that equirectangular HDR image instead of the
grey constant, built exactly as ``cycles_env.set_env_world`` builds it for rotation 0 (Environment
Texture, Linear Rec.709, interpolation Linear, Vector input unlinked = Blender's default mapping,
which is lumo's orientation of an unrotated ``--env`` image; Background strength 1; visible to the
camera; world importance sampling Auto, Blender's default). Everything else is unchanged
(settings, lumo's camera, K passes, mean / variance EXRs, previews, ``cameras.json``, README).
Defaults that change with ``--env``: ``--out`` = ``tests/data/cycles_gltf_env``, ``--models`` =
``all`` (every folder of ``--gltf-root`` holding a model, no ``_nonormal`` variants, then the
``ENV_VARIANTS``: ``CornellBoxVinc3r_flat``), and
``--prefer glb`` (``glTF-Binary/*.glb`` before ``glTF/*.gltf``). The grey check is replaced by an
environment check: Blender's ``scene.ray_cast`` on the evaluated scene with 4 x 4 rays per pixel
finds the pixels that see no geometry (eroded by one pixel); there the Cycles mean must match a
numpy prediction of the environment (``cycles_env.env_lookup``, lumo's documented orientation,
the same rays) with a median relative luminance error under 3 %, or the model fails. The number
of pixels that see any geometry is recorded (0 = the camera sees nothing). Environment-mode EXRs
are stored more compactly (see ``ENV_MEAN_HALF``, ``ENV_VAR_MANTISSA_BITS``).

``--still PNG --size N`` (one model, with or without ``--env``): one pass of ``--spp`` samples,
seed 1, at N x N, the same scene and settings otherwise, written as an 8-bit sRGB PNG (the linear
result clamped to [0, 1], sRGB transfer curve, no dithering: what the Standard view transform
shows). Its settings are recorded under ``stills`` in ``--out``'s ``cameras.json`` and README.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import os
import shlex
import shutil
import struct
import subprocess
import sys
import tempfile
import textwrap
import time
import traceback
import zlib
from pathlib import Path

import numpy as np

import common
from cycles_cornell import Timer, render as render_pass

#: The models of the issue, in order; ``_nonormal`` variants are rendered after their model.
MODELS = (
    "MetalRoughSpheresNoTextures",
    "NormalTangentMirrorTest",
    "NormalTangentTest",
    "AlphaBlendModeTest",
    "TextureSettingsTest",
    "ClearCoatTest",
    "SpecularTest",
    "TransmissionRoughnessTest",
    "VertexColorTest",
    "DamagedHelmet",
    "GlassVaseFlowers",
)
NONORMAL_SUFFIX = "_nonormal"
FLAT_SUFFIX = "_flat"
#: Environment mode: variants rendered after the folders' models by default. CornellBoxVinc3r's
#: file normals are averaged across the box's corners (up to 55 degrees from the walls' geometric
#: normals); flat, it isolates how each renderer treats light from behind the geometric surface.
ENV_VARIANTS = ("CornellBoxVinc3r" + FLAT_SUFFIX,)
NONORMAL_MODELS = ("NormalTangentMirrorTest", "NormalTangentTest")
#: Passes for models too slow for the default (name -> passes); empty: every model uses --passes.
PASSES_OVERRIDE: dict[str, int] = {}

WIDTH = HEIGHT = 128
WORLD_GREY = 0.5
MAX_BOUNCES = 6
TRANSPARENT_MAX_BOUNCES = 64
FIRST_SEED = 1
PNG_MAX_BYTES = 30_000

DEFAULT_GLTF_ROOT = common.REPO_ROOT.parent / "shared" / "gltf"
DEFAULT_OUT = common.REPO_ROOT / "tests" / "data" / "cycles_gltf"
DEFAULT_ENV_OUT = common.REPO_ROOT / "tests" / "data" / "cycles_gltf_env"
SOURCE_REPO = "KhronosGroup/glTF-Sample-Assets"

# Environment mode (--env) only:
#: Sub-pixel rays per axis for the background mask (Blender ray casts) and the prediction.
ENV_CHECK_SUBPIXELS = 4
#: Largest median relative luminance error allowed between the background pixels and the numpy
#: prediction of the environment.
ENV_CHECK_TOLERANCE = 0.03
#: Storage of the environment-mode EXRs (ZIP either way), to keep 33 models within a few MB: with
#: a textured background every pixel is noisy and float32 compresses poorly (~195 KB per image,
#: ~13 MB for 33 models). The mean is written as half floats (11 significant bits: relative
#: rounding <= 2^-11 = 0.05 %, far below the noise of a 2048-spp mean; range up to 65504): ~55 KB.
#: The variance as float32 (its values, down to 1e-17, go far below half's range) rounded to this
#: many explicit mantissa bits: relative rounding <= 2^-(bits+1) = 1.6 %, against the estimate's
#: own ~53 % scatter with K = 8: ~80 KB. The grey-world references keep full float32.
ENV_MEAN_HALF = True
ENV_VAR_MANTISSA_BITS = 5


def default_jobs() -> list[str]:
    jobs = []
    for m in MODELS:
        jobs.append(m)
        if m in NONORMAL_MODELS:
            jobs.append(m + NONORMAL_SUFFIX)
    return jobs


def split_job(job: str) -> tuple[str, bool, bool]:
    """'NormalTangentTest_nonormal' -> ('NormalTangentTest', True, False);
    'CornellBoxVinc3r_flat' -> ('CornellBoxVinc3r', False, True)."""
    if job.endswith(NONORMAL_SUFFIX):
        return job[: -len(NONORMAL_SUFFIX)], True, False
    if job.endswith(FLAT_SUFFIX):
        return job[: -len(FLAT_SUFFIX)], False, True
    return job, False, False


def find_model_file(root: Path, model: str, prefer_binary: bool = False) -> Path:
    """The model's glTF/*.gltf, else glTF-Binary/*.glb (the variant lumo's tests read); with
    ``prefer_binary`` the other way round. Folders without that layout (CornellBoxVinc3r): the
    first *.gltf / *.glb in the folder itself."""
    order = [("glTF", "*.gltf"), ("glTF-Binary", "*.glb")]
    if prefer_binary:
        order.reverse()
    order += [(".", pattern) for _, pattern in order]
    for sub, pattern in order:
        hits = sorted((root / model / sub).glob(pattern))
        if hits:
            return hits[0]
    raise FileNotFoundError(f"{root / model}: no glTF/*.gltf, glTF-Binary/*.glb or *.gltf/*.glb")


def all_models(root: Path) -> list[str]:
    """Every folder of ``root`` that holds a model (see find_model_file), sorted."""
    names = []
    for d in sorted(p for p in root.iterdir() if p.is_dir()):
        with contextlib.suppress(FileNotFoundError):
            find_model_file(root, d.name)
            names.append(d.name)
    return names


def read_gltf_json(path: Path) -> dict:
    """The JSON of a .gltf, or of a .glb's first (JSON) chunk."""
    data = path.read_bytes()
    if data[:4] == b"glTF":
        length, kind = struct.unpack_from("<II", data, 12)
        if kind != 0x4E4F534A:  # 'JSON'
            raise ValueError(f"{path}: first GLB chunk is not JSON")
        return json.loads(data[20:20 + length])
    return json.loads(data)


def default_lumo() -> str:
    built = common.REPO_ROOT / "target" / "release" / "lumo"
    return str(built) if built.is_file() else "lumo"


def lumo_camera(lumo: str, model_file: Path) -> dict:
    """The camera lumo uses for ``model_file`` (from ``lumo convert``), in glTF's y-up frame."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scene.json"
        proc = subprocess.run([lumo, "convert", str(model_file), "-o", str(out)],
                              capture_output=True, text=True)
        if proc.returncode != 0 or not out.is_file():
            raise RuntimeError(f"`{lumo} convert {model_file}` failed (exit {proc.returncode}): "
                               f"{proc.stderr.strip() or proc.stdout.strip()}")
        cam = json.loads(out.read_text())["camera"]
    missing = [k for k in ("position", "look_at", "up", "fov_y_deg") if k not in cam]
    if missing:
        raise RuntimeError(f"lumo's camera for {model_file} lacks {missing}: {cam}")
    return {"position": [float(v) for v in cam["position"]],
            "look_at": [float(v) for v in cam["look_at"]],
            "up": [float(v) for v in cam["up"]],
            "fov_y_deg": float(cam["fov_y_deg"])}


def lumo_version(lumo: str) -> str:
    with contextlib.suppress(Exception):
        proc = subprocess.run([lumo, "--version"], capture_output=True, text=True, timeout=60)
        return proc.stdout.strip() or proc.stderr.strip()
    return "unknown"


def gltf_to_blender(v) -> tuple[float, float, float]:
    """glTF y-up -> Blender z-up, as the glTF importer converts: (x, y, z) -> (x, -z, y)."""
    x, y, z = v
    return (x, -z, y)


# --- Blender scene ------------------------------------------------------------------------------

def reset_blender(bpy) -> None:
    """Empty factory-settings scene with the glTF importer enabled."""
    import addon_utils

    bpy.ops.wm.read_factory_settings(use_empty=True)
    loaded_default, loaded_state = addon_utils.check("io_scene_gltf2")
    if not loaded_state:
        addon_utils.enable("io_scene_gltf2", default_set=True)
    if not hasattr(bpy.ops.import_scene, "gltf"):
        raise RuntimeError("the io_scene_gltf2 add-on could not be enabled")


@contextlib.contextmanager
def capture_fds():
    """Captures everything written to file descriptors 1 and 2 (Python and C) into a list of
    lines, yielded; the caller reads it after the block."""
    lines: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    saved = (os.dup(1), os.dup(2))
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            yield lines
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            tmp.seek(0)
            lines.extend(tmp.read().decode("utf-8", "replace").splitlines())


def importer_extensions() -> list[str]:
    """The extensions Blender's glTF importer handles (its own list; it ignores others silently)."""
    from io_scene_gltf2.io.imp.gltf2_io_gltf import glTFImporter

    return list(glTFImporter("unused.gltf", {"import_user_extensions": []}).extensions_managed)


def import_model(bpy, path: Path) -> tuple[list[str], list[str]]:
    """Imports ``path``; returns (the importer's full console log, its warning/error lines).
    Raises RuntimeError with the importer's message if it fails."""
    error = None
    with capture_fds() as log:
        try:
            result = bpy.ops.import_scene.gltf(filepath=str(path))
            if "FINISHED" not in result:
                error = f"importer returned {sorted(result)}"
        except Exception as e:  # bpy raises RuntimeError with the operator's ERROR report
            error = f"{type(e).__name__}: {e}"
    # INFO lines only name what is created ("create Mesh node Error Marker" in TextureTransformTest
    # is a mesh's name); the importer reports problems at WARNING / ERROR level.
    notable = [ln.strip() for ln in log
               if any(w in ln.upper() for w in ("WARNING", "ERROR", "UNSUPPORTED", "NOT SUPPORTED"))
               and "| INFO:" not in ln]
    if error:
        raise RuntimeError(f"glTF import of {path} failed: {error}\n  log: " + "\n  log: ".join(log))
    return log, notable


def give_default_material(bpy, gltf_json: dict) -> int:
    """Gives every mesh of a file without materials the glTF default material (base colour 1,
    metallic 1, roughness 1; glTF 2.0 section 3.9.6), times COLOR_0 where the mesh has it.
    Blender's importer does not build that material: without COLOR_0 it leaves the slot empty
    (Cycles then renders its own grey diffuse surface), with COLOR_0 it makes a Principled BSDF
    of the vertex colour with metallic 0 and roughness 0.5. Returns the number of meshes
    changed; raises when a file with materials has a mesh without one (not handled here)."""
    meshes = {o.data for o in bpy.data.objects if o.type == "MESH"}
    if gltf_json.get("materials"):
        bare = sorted(m.name for m in meshes if not any(m.materials))
        if bare:
            raise RuntimeError(f"meshes without a material in a file with materials: {bare}")
        return 0
    default = None
    for mesh in meshes:
        if not any(mesh.materials):
            if default is None:
                # Blender 5 gives a new material a node tree with a Principled BSDF.
                default = bpy.data.materials.new("glTF default")
            mesh.materials.clear()
            mesh.materials.append(default)
        for mat in mesh.materials:
            principled = [n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"]
            if len(principled) != 1:
                raise RuntimeError(f"{mat.name}: expected one Principled BSDF")
            bsdf = principled[0]
            if not bsdf.inputs["Base Color"].is_linked:
                bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
            bsdf.inputs["Metallic"].default_value = 1.0
            bsdf.inputs["Roughness"].default_value = 1.0
            bsdf.inputs["IOR"].default_value = 1.5
    return len(meshes)


def remove_lights_and_cameras(bpy) -> tuple[int, int]:
    lights = cams = 0
    for obj in list(bpy.data.objects):
        if obj.type == "LIGHT":
            lights += 1
        elif obj.type == "CAMERA":
            cams += 1
        else:
            continue
        bpy.data.objects.remove(obj, do_unlink=True)
    return lights, cams


def count_emissive(bpy) -> int:
    """Materials whose Principled BSDF emits (a non-zero Emission Strength with a colour)."""
    n = 0
    for mat in bpy.data.materials:
        nt = mat.node_tree
        if nt is None:
            continue
        for node in nt.nodes:
            if node.type == "BSDF_PRINCIPLED":
                s = node.inputs["Emission Strength"]
                c = node.inputs["Emission Color"]
                if (s.is_linked or s.default_value > 0) and (c.is_linked or any(c.default_value[:3])):
                    n += 1
                    break
    return n


def shade_flat(bpy) -> int:
    """Removes every mesh's custom normals (the file's NORMAL) and shades its faces flat; returns
    the number of meshes."""
    n = 0
    for mesh in {o.data for o in bpy.data.objects if o.type == "MESH"}:
        if "custom_normal" in mesh.attributes:
            mesh.attributes.remove(mesh.attributes["custom_normal"])
        mesh.shade_flat()
        if mesh.has_custom_normals or any(p.use_smooth for p in mesh.polygons):
            raise RuntimeError(f"{mesh.name}: still smooth after shade_flat")
        n += 1
    return n


def unlink_normal_maps(bpy) -> int:
    """Removes every link Normal Map node -> Principled BSDF 'Normal'; returns how many."""
    removed = 0
    for mat in bpy.data.materials:
        nt = mat.node_tree
        if nt is None:
            continue
        for link in list(nt.links):
            if (link.to_node.type == "BSDF_PRINCIPLED" and link.to_socket.identifier == "Normal"
                    and link.from_node.type == "NORMAL_MAP"):
                nt.links.remove(link)
                removed += 1
    return removed


def add_camera(bpy, scene, cam: dict):
    """lumo's camera (glTF frame) as the scene's camera; checked by projecting points."""
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Matrix, Vector

    pos = Vector(gltf_to_blender(cam["position"]))
    target = Vector(gltf_to_blender(cam["look_at"]))
    up = Vector(gltf_to_blender(cam["up"]))
    forward = target - pos
    dist = forward.length
    if dist <= 0:
        raise ValueError(f"camera position equals look_at: {cam}")
    forward.normalize()
    right = forward.cross(up)
    if right.length < 1e-9:
        raise ValueError(f"camera up is parallel to the view direction: {cam}")
    right.normalize()
    true_up = right.cross(forward)
    # A Blender camera looks down its local -z with local +y up and +x right.
    m = Matrix((
        (right.x, true_up.x, -forward.x, pos.x),
        (right.y, true_up.y, -forward.y, pos.y),
        (right.z, true_up.z, -forward.z, pos.z),
        (0.0, 0.0, 0.0, 1.0),
    ))
    data = bpy.data.cameras.new("lumo_camera")
    data.type = "PERSP"
    data.lens_unit = "FOV"
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(cam["fov_y_deg"])
    data.shift_x = data.shift_y = 0.0
    data.clip_start = dist * 1e-5
    data.clip_end = dist * 1e5
    obj = bpy.data.objects.new("lumo_camera", data)
    obj.matrix_world = m
    scene.collection.objects.link(obj)
    scene.camera = obj
    bpy.context.view_layer.update()

    # Checks: look_at projects to the image centre; a point fov/2 above the axis to the top edge,
    # one tan(fov/2)*aspect to the side to the right edge (aspect 1 here).
    half = math.radians(cam["fov_y_deg"]) / 2
    aspect = scene.render.resolution_x / scene.render.resolution_y
    checks = [
        (target, (0.5, 0.5)),
        (pos + dist * (forward + math.tan(half) * true_up), (0.5, 1.0)),
        (pos + dist * (forward + math.tan(half) * aspect * right), (1.0, 0.5)),
    ]
    for point, want in checks:
        got = world_to_camera_view(scene, obj, point)
        if abs(got.x - want[0]) > 1e-4 or abs(got.y - want[1]) > 1e-4:
            raise RuntimeError(f"camera check failed: {tuple(point)} projects to {tuple(got)}, "
                               f"want {want}")
    return obj


def set_world(bpy, scene) -> None:
    """Constant grey background (0.5, strength 1): the only light."""
    world = bpy.data.worlds.new("grey")
    if world.node_tree is None:  # Blender 5 worlds always have nodes ('use_nodes' is deprecated)
        world.use_nodes = True
    world.color = (WORLD_GREY,) * 3
    nt = world.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (WORLD_GREY, WORLD_GREY, WORLD_GREY, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    scene.world = world


def set_env_world(bpy, scene, env: Path) -> dict:
    """The HDR image ``env`` as the world, exactly as ``cycles_env.set_env_world`` builds it for
    rotation 0 and strength 1 (Environment Texture with default mapping, importance sampling
    Auto, visible to the camera; it also checks Blender's pixels against OpenEXR's)."""
    import cycles_env

    return cycles_env.set_env_world(bpy, scene, {"image": env, "strength": 1.0,
                                                 "rotation_deg": 0.0, "visible": True})


def repo_relative(path: Path) -> str:
    """``path`` relative to the repository root (with ``..`` if outside), for the records."""
    return Path(os.path.relpath(Path(path).resolve(), common.REPO_ROOT)).as_posix()


def env_background_check(bpy, scene, cam: dict, env: Path, mean: np.ndarray,
                         n: int = ENV_CHECK_SUBPIXELS) -> dict:
    """Environment mode: finds the pixels that see geometry (Blender ray casts, n x n rays per
    pixel through lumo's camera) and compares the pixels that see none (eroded by one pixel) with
    the numpy prediction of the environment along the same rays. Returns the record."""
    import cycles_env
    from mathutils import Vector

    h, w = mean.shape[:2]
    dirs = cycles_env.camera_rays(cam, w, h, n)              # (h, w, n*n, 3), glTF / lumo frame
    depsgraph = bpy.context.evaluated_depsgraph_get()
    origin = Vector(gltf_to_blender(cam["position"]))
    flat = dirs.reshape(-1, 3)
    hits = np.zeros(len(flat), bool)
    for i, d in enumerate(flat):
        hits[i] = scene.ray_cast(depsgraph, origin, Vector(gltf_to_blender(d)))[0]
    hits = hits.reshape(h, w, n * n)
    sees_geometry = np.any(hits, axis=-1)
    background = cycles_env.erode(~sees_geometry)
    env_img = np.maximum(common.read_exr(env), 0.0)          # as lumo reads it (DWAB noise -> 0)
    out = {"subpixel_rays": n * n,
           "pixels_seeing_geometry": int(sees_geometry.sum()),
           "background_pixels_checked": int(background.sum())}
    if background.any():
        pred = cycles_env.env_lookup(env_img, dirs[background]).mean(axis=1)
        y = mean[background] @ cycles_env.LUMINANCE
        py = pred @ cycles_env.LUMINANCE
        rel = np.abs(y - py) / np.maximum(py, 1e-6)
        out["median_rel_err"] = round(float(np.median(rel)), 5)
        out["p99_rel_err"] = round(float(np.quantile(rel, 0.99)), 5)
        out["mean_ratio_rgb"] = (mean[background].mean(axis=0) / pred.mean(axis=0)).round(5).tolist()
    return out


def quantize_mantissa(a: np.ndarray, bits: int) -> np.ndarray:
    """float32 values rounded (to nearest, ties to even) to ``bits`` explicit mantissa bits."""
    a = np.ascontiguousarray(a, dtype=np.float32)
    drop = 23 - bits
    if drop <= 0:
        return a
    i = a.view(np.uint32).astype(np.uint64)
    i = ((i + (1 << (drop - 1)) - 1 + ((i >> drop) & 1)) >> drop) << drop
    return i.astype(np.uint32).view(np.float32)


def configure_cycles(scene, width: int = WIDTH, height: int = HEIGHT) -> dict:
    """The issue's settings; returns them as read back from Blender (for the record)."""
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.threads_mode = "AUTO"
    r.use_persistent_data = False
    for attr in ("use_compositing", "use_sequencer"):
        if hasattr(r, attr):
            setattr(r, attr, False)
    img = r.image_settings
    img.file_format = "OPEN_EXR"
    img.color_mode = "RGB"
    img.color_depth = "32"
    img.exr_codec = "ZIP"

    c = scene.cycles
    c.device = "CPU"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.max_bounces = MAX_BOUNCES
    c.diffuse_bounces = MAX_BOUNCES
    c.glossy_bounces = MAX_BOUNCES
    c.transmission_bounces = MAX_BOUNCES
    c.volume_bounces = MAX_BOUNCES
    c.transparent_max_bounces = TRANSPARENT_MAX_BOUNCES
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.use_light_tree = False
    c.blur_glossy = 0.0
    c.caustics_reflective = True   # Blender's default
    c.caustics_refractive = True   # Blender's default
    c.use_animated_seed = False
    c.film_exposure = 1.0
    if hasattr(c, "use_auto_tile"):
        c.use_auto_tile = False
    # sampling_pattern: left at Blender's default (recorded below).

    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    vs.use_curve_mapping = False

    return {
        "device": c.device,
        "threads_mode": r.threads_mode,
        "threads": r.threads,
        "pixel_filter": f"{c.pixel_filter_type} {c.filter_width:g} px",
        "denoising": c.use_denoising,
        "adaptive_sampling": c.use_adaptive_sampling,
        "sample_clamp_direct": c.sample_clamp_direct,
        "sample_clamp_indirect": c.sample_clamp_indirect,
        "light_tree": c.use_light_tree,
        "blur_glossy": c.blur_glossy,
        "caustics_reflective": c.caustics_reflective,
        "caustics_refractive": c.caustics_refractive,
        "max_bounces": c.max_bounces,
        "diffuse_bounces": c.diffuse_bounces,
        "glossy_bounces": c.glossy_bounces,
        "transmission_bounces": c.transmission_bounces,
        "volume_bounces": c.volume_bounces,
        "transparent_max_bounces": c.transparent_max_bounces,
        "sampling_pattern": c.sampling_pattern,
        "view_transform": vs.view_transform,
        "look": vs.look,
        "exposure": vs.exposure,
        "gamma": vs.gamma,
        "film_exposure": c.film_exposure,
        "film_transparent": r.film_transparent,
        "world": f"constant grey {WORLD_GREY}, strength 1",
        "resolution": [r.resolution_x, r.resolution_y],
    }


# --- outputs -------------------------------------------------------------------------------------

def write_png_preview(path: Path, rgb: np.ndarray) -> int | None:
    """sRGB 8-bit preview (clamped); written only if under PNG_MAX_BYTES. Returns its size."""
    png = encode_png(rgb)
    if len(png) >= PNG_MAX_BYTES:
        path.unlink(missing_ok=True)
        return None
    path.write_bytes(png)
    return len(png)


def encode_png(rgb: np.ndarray) -> bytes:
    """8-bit sRGB PNG of a linear RGB image: clamped to [0, 1], sRGB transfer curve, rounded."""
    x = np.clip(rgb, 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    px = np.round(srgb * 255).astype(np.uint8)
    h, w, _ = px.shape
    best = None
    for ftype in range(3):  # None, Sub, Up for the whole image; keep the smallest
        rows = []
        prev = np.zeros((w * 3,), np.int16)
        for row in px.reshape(h, w * 3).astype(np.int16):
            if ftype == 0:
                f = row
            elif ftype == 1:
                f = row - np.concatenate([np.zeros(3, np.int16), row[:-3]])
            else:
                f = row - prev
            rows.append(bytes([ftype]) + (f % 256).astype(np.uint8).tobytes())
            prev = row
        data = zlib.compress(b"".join(rows), 9)
        if best is None or len(data) < len(best):
            best = data

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"sRGB", b"\x00") + chunk(b"IDAT", best) + chunk(b"IEND", b""))


def canonical_command(args) -> str:
    """The command that regenerates every model with these sample counts (no --models; --out
    only in environment mode, when it is not the default)."""
    argv = ["nice", "-n", "10", "benches/peers/.venv/bin/python", "benches/peers/cycles_gltf.py"]
    if args.env is not None:
        argv += ["--env", args.env_arg]
        if args.out != DEFAULT_ENV_OUT.resolve():
            argv += ["--out", repo_relative(args.out)]
    if args.passes != 8:
        argv += ["--passes", str(args.passes)]
    if args.spp != 256:
        argv += ["--spp", str(args.spp)]
    argv += ["--lumo", args.lumo_arg]
    return " ".join(shlex.quote(a) for a in argv)


def still_command(args, job: str, png: Path) -> str:
    """The command that regenerates one --still image."""
    argv = ["nice", "-n", "10", "benches/peers/.venv/bin/python", "benches/peers/cycles_gltf.py"]
    if args.env is not None:
        argv += ["--env", args.env_arg]
    argv += ["--models", job, "--still", repo_relative(png), "--size", str(args.size),
             "--spp", str(args.spp)]
    if args.out != (DEFAULT_ENV_OUT if args.env is not None else DEFAULT_OUT).resolve():
        argv += ["--out", repo_relative(args.out)]
    argv += ["--lumo", args.lumo_arg]
    return " ".join(shlex.quote(a) for a in argv)


def to_json(value, indent: int = 0) -> str:
    """JSON with one key per line down to the models' entries, and lists / small dicts inline."""
    pad = " " * (indent + 1)
    if isinstance(value, dict) and (indent < 2 or len(json.dumps(value)) > 100):
        items = [f"{pad}{json.dumps(k)}: {to_json(v, indent + 1)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    return json.dumps(value)


def load_record(out: Path) -> dict:
    p = out / "cameras.json"
    if p.is_file():
        with contextlib.suppress(Exception):
            return json.loads(p.read_text())
    return {}


def save_record(out: Path, record: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "cameras.json").write_text(to_json(record) + "\n")


def model_legal(root: Path, model: str) -> list[dict]:
    p = root / model / "SOURCE-metadata.json"
    try:
        return json.loads(p.read_text()).get("legal", [])
    except Exception:
        return []


def model_title(root: Path, model: str) -> str:
    with contextlib.suppress(Exception):
        return json.loads((root / model / "SOURCE-metadata.json").read_text()).get("name") or model
    return model


# --- main loop -------------------------------------------------------------------------------------

def prepare_job(bpy, job: str, args, managed_ext: list[str], width: int = WIDTH,
                height: int = HEIGHT) -> dict:
    """Steps 1-3 for one job: lumo's camera, the import, world, Cycles settings and camera."""
    model, nonormal, flat = split_job(job)
    model_file = find_model_file(args.gltf_root, model, prefer_binary=args.prefer == "glb")
    cam = lumo_camera(args.lumo, model_file)

    reset_blender(bpy)
    scene = bpy.context.scene
    t0 = time.perf_counter()
    log, notable = import_model(bpy, model_file)
    import_seconds = time.perf_counter() - t0
    for ln in notable:
        print(f"  importer: {ln}")
    used = read_gltf_json(model_file).get("extensionsUsed", []) or []
    unsupported = [e for e in used if e not in managed_ext]
    if unsupported:
        print(f"  importer: extensions used by the file but not handled (ignored silently): "
              f"{', '.join(unsupported)}")
    defaulted = give_default_material(bpy, read_gltf_json(model_file))
    if defaulted:
        print(f"  gave {defaulted} mesh(es) without a material glTF's default material")
    lights, cams = remove_lights_and_cameras(bpy)
    if lights:
        print(f"  note: removed {lights} light(s) the file brought")
    unlinked = None
    if nonormal:
        unlinked = unlink_normal_maps(bpy)
        if unlinked == 0:
            raise RuntimeError("no Normal Map -> Principled BSDF Normal link found to remove")
        print(f"  unlinked {unlinked} Normal Map node(s) from the Principled BSDF")
    if flat:
        print(f"  shaded {shade_flat(bpy)} mesh(es) flat")
    emissive = count_emissive(bpy)
    meshes = sum(1 for o in bpy.data.objects if o.type == "MESH")

    world = None
    if args.env is None:
        set_world(bpy, scene)
    else:
        world = set_env_world(bpy, scene, args.env)
        world["image"] = repo_relative(world["image"])
    settings = configure_cycles(scene, width, height)
    if world is not None:
        settings["world"] = (f"Environment Texture {world['image']} ({world['vector']}), "
                             f"strength {world['strength']:g}")
        settings["world_nodes"] = world
    add_camera(bpy, scene, cam)
    return {
        "model": model, "nonormal": nonormal, "flat": flat, "model_file": model_file, "camera": cam,
        "scene": scene, "import_seconds": import_seconds, "notable": notable, "used": used,
        "unsupported": unsupported, "lights": lights, "cams": cams, "unlinked": unlinked,
        "emissive": emissive, "meshes": meshes, "world": world, "settings": settings,
        "meshes_in_view_layer": sum(1 for o in scene.objects if o.type == "MESH" and o.visible_get()),
    }


def remove_timer(bpy, timer) -> None:
    for h, fn in ((bpy.app.handlers.render_pre, timer._pre), (bpy.app.handlers.render_post, timer._post)):
        with contextlib.suppress(ValueError):
            h.remove(fn)


def render_passes(bpy, scene, timer, spp: int, seeds: list[int], prefix: str):
    """Renders one pass per seed into a temporary folder and returns the stack of images (each
    checked: WIDTH × HEIGHT, finite), the summed render and CPU seconds and the load after each
    pass. The render handlers of `timer` are removed afterwards, whatever happens."""
    images, loads = [], []
    render_s = cpu_s = 0.0
    try:
        with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
            for k, seed in enumerate(seeds):
                path = Path(tmp) / f"pass{k}.exr"
                dt, cpu = render_pass(bpy, scene, timer, spp, seed, path)
                render_s += dt
                cpu_s += cpu
                loads.append(common.load1())
                img = common.read_exr(path)
                if img.shape != (HEIGHT, WIDTH, 3):
                    raise RuntimeError(f"pass {k}: image shape {img.shape}")
                if not np.all(np.isfinite(img)):
                    raise RuntimeError(f"pass {k}: non-finite pixels")
                images.append(img)
                print(f"  pass {k + 1}/{len(seeds)}: {spp} spp, seed {seed}, {dt:7.2f} s "
                      f"(cpu {cpu:7.2f} s, load {loads[-1]:.2f})", flush=True)
    finally:
        remove_timer(bpy, timer)
    return np.stack(images), render_s, cpu_s, loads


def render_job(bpy, job: str, args, managed_ext: list[str]) -> tuple[dict, dict]:
    t_job = time.perf_counter()
    ctx = prepare_job(bpy, job, args, managed_ext)
    model_file, cam, scene = ctx["model_file"], ctx["camera"], ctx["scene"]
    timer = Timer(bpy)

    passes = PASSES_OVERRIDE.get(job, PASSES_OVERRIDE.get(ctx["model"], args.passes))
    seeds = [FIRST_SEED + k for k in range(passes)]
    stack, render_s, cpu_s, loads = render_passes(bpy, scene, timer, args.spp, seeds, "cycles_gltf_")
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / passes if passes > 1 else np.full_like(mean, np.nan)
    env_check = None
    if args.env is None:
        # Linearity check: pixels that see only the world read exactly its radiance in every pass.
        bg = np.all(np.abs(stack - WORLD_GREY) < 1e-6, axis=(0, 3))
        background_pixels = int(bg.sum())
    else:
        t0 = time.perf_counter()
        env_check = env_background_check(bpy, scene, cam, args.env, mean)
        env_check["seconds"] = round(time.perf_counter() - t0, 2)
        print(f"  environment check: {env_check}", flush=True)
        if env_check.get("median_rel_err", 0.0) > ENV_CHECK_TOLERANCE:
            raise RuntimeError(f"the background pixels do not match the environment's prediction "
                               f"(median relative error {env_check['median_rel_err']} > "
                               f"{ENV_CHECK_TOLERANCE}): {env_check}")

    args.out.mkdir(parents=True, exist_ok=True)
    if args.env is None:
        common.write_exr(args.out / f"{job}.exr", mean.astype(np.float32))
        common.write_exr(args.out / f"{job}.var.exr", var_of_mean.astype(np.float32))
    else:
        if ENV_MEAN_HALF and float(np.max(mean)) >= 65504:
            raise RuntimeError(f"mean up to {np.max(mean)}: too large for half floats")
        common.write_exr(args.out / f"{job}.exr", mean, half=ENV_MEAN_HALF)
        common.write_exr(args.out / f"{job}.var.exr",
                         quantize_mantissa(var_of_mean, ENV_VAR_MANTISSA_BITS))
    png_bytes = write_png_preview(args.out / f"{job}.png", mean)

    total_s = time.perf_counter() - t_job
    entry = {
        "gltf": model_file.relative_to(args.gltf_root).as_posix(),
        "camera": cam,
        "normal_maps": not ctx["nonormal"],
        "flat": ctx["flat"],
        "passes": passes,
        "spp_per_pass": args.spp,
        "spp": passes * args.spp,
        "seeds": seeds,
        "render_seconds": round(render_s, 2),
        "render_cpu_seconds": round(cpu_s, 2),
        "total_seconds": round(total_s, 2),
        "import_seconds": round(ctx["import_seconds"], 2),
        "load1_max": round(max(loads), 2),
        "blender": bpy.app.version_string,
        "meshes": ctx["meshes"],
        "emissive_materials": ctx["emissive"],
        "lights_removed": ctx["lights"],
        "cameras_removed": ctx["cams"],
        "normal_map_links_removed": ctx["unlinked"],
        "importer_warnings": ctx["notable"],
        "extensions_used": ctx["used"],
        "extensions_not_handled_by_importer": ctx["unsupported"],
    }
    if args.env is None:
        entry["background_pixels_reading_0.5"] = background_pixels
    else:
        entry["meshes_in_view_layer"] = ctx["meshes_in_view_layer"]
        entry["environment_check"] = env_check
    entry["image_mean"] = [round(float(v), 6) for v in mean.reshape(-1, 3).mean(axis=0)]
    entry["png_preview_bytes"] = png_bytes
    if args.env is None:
        check_txt = f"{background_pixels} background pixels read {WORLD_GREY}"
    else:
        check_txt = (f"{env_check['pixels_seeing_geometry']} pixels see geometry, "
                     f"{env_check['background_pixels_checked']} background pixels checked")
    print(f"  -> {job}: {passes} x {args.spp} spp = {passes * args.spp} spp, render {render_s:.1f} s "
          f"(cpu {cpu_s:.1f} s), total {total_s:.1f} s; {check_txt}; image mean {entry['image_mean']}; png "
          f"{'%d B' % png_bytes if png_bytes else 'skipped (>= 30 KB)'}", flush=True)
    if args.env is None and background_pixels == 0:
        print(f"  warning: no pixel sees only the world; the linearity check could not run")
    if args.env is not None and env_check["pixels_seeing_geometry"] == 0:
        print(f"  warning: the camera sees no geometry")
    return entry, ctx["settings"]


def render_still(bpy, job: str, args, managed_ext: list[str]) -> tuple[dict, dict]:
    """--still: one pass of --spp samples (seed FIRST_SEED) at --size x --size, as an sRGB PNG."""
    t_job = time.perf_counter()
    ctx = prepare_job(bpy, job, args, managed_ext, args.size, args.size)
    timer = Timer(bpy)
    try:
        with tempfile.TemporaryDirectory(prefix="cycles_gltf_") as tmp:
            path = Path(tmp) / "still.exr"
            dt, cpu = render_pass(bpy, ctx["scene"], timer, args.spp, FIRST_SEED, path)
            load = common.load1()
            img = common.read_exr(path)
    finally:
        remove_timer(bpy, timer)
    if img.shape != (args.size, args.size, 3) or not np.all(np.isfinite(img)):
        raise RuntimeError(f"bad image (shape {img.shape})")
    png = encode_png(img)
    args.still.parent.mkdir(parents=True, exist_ok=True)
    args.still.write_bytes(png)
    total_s = time.perf_counter() - t_job
    entry = {
        "model": job,
        "gltf": ctx["model_file"].relative_to(args.gltf_root).as_posix(),
        "camera": ctx["camera"],
        "resolution": [args.size, args.size],
        "passes": 1,
        "spp": args.spp,
        "seed": FIRST_SEED,
        "world": ctx["settings"]["world"],
        "png": "8-bit sRGB: linear result clamped to [0, 1], sRGB transfer curve, rounded "
               "(no dithering); the Standard view transform's encoding",
        "png_bytes": len(png),
        "render_seconds": round(dt, 2),
        "render_cpu_seconds": round(cpu, 2),
        "total_seconds": round(total_s, 2),
        "load1": round(load, 2),
        "blender": bpy.app.version_string,
        "image_mean_linear": [round(float(v), 6) for v in img.reshape(-1, 3).mean(axis=0)],
        "command": still_command(args, job, args.still),
    }
    print(f"  -> {args.still}: {args.size} x {args.size}, {args.spp} spp, render {dt:.1f} s "
          f"(cpu {cpu:.1f} s, load {load:.2f}), {len(png)} B", flush=True)
    return entry, ctx["settings"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--models", default=None,
                    help="comma-separated models (a '_nonormal' suffix unlinks the normal maps), or "
                         "'all' (every model folder of --gltf-root); default: all of the issue's, "
                         "with --env: all")
    ap.add_argument("--passes", type=int, default=8, help="independent passes K (default 8)")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel per pass (default 256)")
    ap.add_argument("--lumo", default=default_lumo(),
                    help="lumo binary used for the cameras (default target/release/lumo, else PATH)")
    ap.add_argument("--gltf-root", type=Path, default=DEFAULT_GLTF_ROOT,
                    help=f"folder of the sample models (default {DEFAULT_GLTF_ROOT})")
    ap.add_argument("--out", type=Path, default=None,
                    help=f"output folder (default {DEFAULT_OUT}, with --env {DEFAULT_ENV_OUT})")
    ap.add_argument("--env", default=None, metavar="FILE.exr",
                    help="light the models with this equirectangular HDR image (Environment "
                         "Texture, default mapping, strength 1) instead of the grey world")
    ap.add_argument("--prefer", choices=("gltf", "glb"), default=None,
                    help="which file of a model folder: glTF/*.gltf or glTF-Binary/*.glb first "
                         "(default gltf, with --env glb)")
    ap.add_argument("--still", type=Path, default=None, metavar="PNG",
                    help="render one model (--models) in one pass of --spp samples at --size x "
                         "--size into this sRGB PNG; recorded in --out's cameras.json and README")
    ap.add_argument("--size", type=int, default=384, help="--still: width = height (default 384)")
    ap.add_argument("--readme-only", action="store_true",
                    help="only rewrite README.md from the existing cameras.json (no rendering)")
    args = ap.parse_args()
    args.env_arg = args.env
    args.env = Path(args.env).resolve() if args.env else None
    if args.out is None:
        args.out = DEFAULT_ENV_OUT if args.env is not None else DEFAULT_OUT
    if args.prefer is None:
        args.prefer = "glb" if args.env is not None else "gltf"
    if args.readme_only:
        record = load_record(args.out)
        if not record.get("models"):
            raise SystemExit(f"{args.out / 'cameras.json'}: no models recorded")
        write_readme(args.out, record, args.gltf_root.resolve())
        print(f"wrote {args.out / 'README.md'}")
        return 0
    if args.env is not None and not args.env.is_file():
        raise SystemExit(f"--env: {args.env} not found")
    if args.passes < 2 and args.still is None:
        raise SystemExit("--passes: need at least 2 passes to estimate a variance")
    if args.spp < 1:
        raise SystemExit("--spp: must be positive")
    if args.still is not None and args.size < 1:
        raise SystemExit("--size: must be positive")
    args.gltf_root = args.gltf_root.resolve()
    if args.models is None:
        jobs = (all_models(args.gltf_root) + list(ENV_VARIANTS) if args.env is not None
                else default_jobs())
    elif args.models.strip() == "all":
        jobs = all_models(args.gltf_root)
    else:
        jobs = [j.strip() for j in args.models.split(",") if j.strip()]
    if not jobs:
        raise SystemExit("--models: empty")
    if args.still is not None and len(jobs) != 1:
        raise SystemExit("--still: give exactly one model with --models")
    if shutil.which(args.lumo) is None and not Path(args.lumo).is_file():
        raise SystemExit(f"--lumo: {args.lumo} not found (build lumo or pass --lumo PATH)")
    args.lumo_arg = args.lumo
    args.out = args.out.resolve()
    if args.still is not None:
        args.still = args.still.resolve()

    import bpy

    reset_blender(bpy)
    managed_ext = importer_extensions()
    print(f"blender {bpy.app.version_string}; glTF importer handles {len(managed_ext)} extensions; "
          f"{len(jobs)} model(s), "
          + (f"still {args.size} x {args.size}, 1 x {args.spp} spp" if args.still is not None
             else f"{args.passes} x {args.spp} spp")
          + f", out {args.out}"
          + (f", env {args.env}" if args.env is not None else ""), flush=True)

    record = load_record(args.out)
    record["generator"] = "benches/peers/cycles_gltf.py"
    record["blender"] = bpy.app.version_string
    record["resolution"] = [WIDTH, HEIGHT]
    if args.env is None:
        record["world_rgb"] = [WORLD_GREY] * 3
    else:
        record["env"] = {"image": repo_relative(args.env), "bytes": args.env.stat().st_size,
                         "sha256": hashlib.sha256(args.env.read_bytes()).hexdigest()}
        record["exr_storage"] = {
            "mean": "half float, ZIP" if ENV_MEAN_HALF else "float32, ZIP",
            "variance": f"float32 rounded to {ENV_VAR_MANTISSA_BITS} mantissa bits, ZIP"}
    record["lumo_version"] = lumo_version(args.lumo)
    record["camera_frame"] = ("glTF / lumo y-up; Blender camera = (x, y, z) -> (x, -z, y), "
                              "fov_y_deg = vertical field of view (sensor_fit VERTICAL)")
    record.setdefault("models", {})

    if args.still is not None:
        job = jobs[0]
        print(f"== {job} (still)", flush=True)
        try:
            entry, settings = render_still(bpy, job, args, managed_ext)
        except Exception as e:
            print(f"ERROR: {job}: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
            traceback.print_exc()
            return 1
        record.setdefault("stills", {})[repo_relative(args.still)] = entry
        save_record(args.out, record)
        if record["models"]:
            write_readme(args.out, record, args.gltf_root)
        return 0

    failed = []
    timings = []
    for job in jobs:
        model, _, _ = split_job(job)
        print(f"== {job}", flush=True)
        try:
            if model not in MODELS and args.env is None:
                print(f"  note: {model} is not one of the issue's models; rendering it anyway")
            entry, settings = render_job(bpy, job, args, managed_ext)
        except Exception as e:
            print(f"ERROR: {job}: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
            if not isinstance(e, (FileNotFoundError, RuntimeError)):
                traceback.print_exc()
            failed.append(job)
            if args.env is not None:
                record.setdefault("failed", {})[job] = f"{type(e).__name__}: {e}"[:2000]
                save_record(args.out, record)
                write_readme(args.out, record, args.gltf_root)
            continue
        record["models"][job] = entry
        record.get("failed", {}).pop(job, None)
        record["settings"] = settings  # the same for every model
        record["command"] = canonical_command(args)
        save_record(args.out, record)
        write_readme(args.out, record, args.gltf_root)
        timings.append((job, entry["spp"], entry["render_seconds"], entry["total_seconds"]))

    print("\nper-model timings (render = sum of the passes' render_pre..render_post):")
    for job, spp, rs, ts in timings:
        print(f"  {job:34s} {spp:5d} spp  render {rs:8.1f} s  total {ts:8.1f} s")
    if failed:
        print(f"FAILED: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


# --- README ----------------------------------------------------------------------------------------

#: Departures from the glTF spec noticed in the importer's code/log and Cycles, per model.
GENERAL_NOTES = """\
- **BRDF.** The importer maps every glTF material onto Blender's Principled BSDF, which is not
  the glTF BRDF: multiple-scattering GGX (energy-conserving, so rough surfaces are brighter than
  single-scattering GGX), its own dielectric layering and Fresnel (F82 tint for metals). Expect
  small systematic differences on rough and metallic surfaces, largest at grazing angles.
- **Single-sided materials.** `doubleSided: false` becomes Blender's "Backface Culling (Camera)",
  an EEVEE/viewport option that Cycles ignores: Cycles renders back faces of single-sided
  materials (the glTF spec culls them).
- **Occlusion textures** are imported into an unconnected "glTF Material Output" group and do not
  affect the render (right for a path tracer: occlusion is an approximation of what it computes).
- **Textures** are sampled by Cycles without mip-mapping: `Linear` (bilinear) for LINEAR samplers,
  `Closest` for NEAREST ones; `minFilter` mip-map modes are ignored. Wrap modes: REPEAT, CLAMP and
  MIRRORED_REPEAT are honoured, with a node setup when S and T differ.
- **Normal maps**: a Normal Map node (tangent space) with tangents Blender computes itself
  (MikkTSpace from the UV map); the importer never reads a file's TANGENT attribute. Cycles'
  "bump map correction" (material setting, on by default) bends normal-mapped normals that
  point away from the viewer, a Blender-specific heuristic.
- **Lights**: the world is the only light (no file brings lights). Emissive materials stay
  emissive (Emission Color x Emission Strength 1; `KHR_materials_emissive_strength` sets the
  strength).
"""

MODEL_NOTES = {
    "AlphaBlendModeTest": "BLEND: Principled Alpha = base-colour alpha (Cycles renders it as "
        "stochastic transparency, i.e. correct 'over' compositing, no sorting issues); MASK: a Math "
        "node makes alpha 1 - (alpha < cutoff), so alpha == cutoff is opaque as in the spec.",
    "ClearCoatTest": "KHR_materials_clearcoat -> Principled Coat (Weight = clearcoatFactor, "
        "Roughness = clearcoatRoughnessFactor, coat IOR 1.5, Coat Normal from "
        "clearcoatNormalTexture). Cycles attenuates the base by the coat's reflectance, close to "
        "but not literally the spec's layering formula. The labels are emissive.",
    "SpecularTest": "KHR_materials_specular -> Principled 'IOR Level' = 0.5 x specularFactor and "
        "'Specular Tint' = specularColorFactor (x textures). Blender's Principled BSDF turns IOR "
        "Level and tint into F0 its own way, which need not equal the spec's formula (dielectric "
        "F0 x specularColor, then x specular), in particular for the HDR specularColorFactor row "
        "(M7, factors up to 25); not checked further.",
    "TransmissionRoughnessTest": "KHR_materials_transmission -> Transmission Weight; "
        "KHR_materials_ior -> IOR; KHR_materials_volume (thicknessFactor 0.005, no attenuation) -> "
        "a Volume Absorption of density 1/attenuationDistance = 0 on the material's volume output. "
        "Cycles refracts at each mesh surface as a closed solid (what the spec's volume extension "
        "means); the thickness factor itself has no effect in Cycles.",
    "GlassVaseFlowers": "Left vase: alphaMode BLEND (stochastic transparency). Right vase: "
        "KHR_materials_transmission + KHR_materials_volume (thicknessFactor 0.075 and a thickness "
        "texture, no attenuation) -> a refracting closed solid with a Volume Absorption of density "
        "0; the thickness (factor and texture) has no effect in Cycles. Flowers: alphaMode MASK.",
    "VertexColorTest": "COLOR_0 is multiplied into the base colour through a Color Attribute node "
        "(as the spec says).",
    "TextureSettingsTest": "Different wrapS/wrapT are emulated with Separate/Combine XYZ and "
        "Math (wrap / ping-pong) nodes on the UVs with the image set to clamp (EXTEND), so bilinear "
        "filtering at a repeat seam blends with the edge texel instead of the opposite edge; the "
        "single-sided quad shows its back face in Cycles "
        "(see 'Single-sided materials').",
    "NormalTangentMirrorTest": "The importer ignores the file's TANGENT attribute (it has no code "
        "for it): Blender computes MikkTSpace tangents from the UVs, which handles the mirrored "
        "UVs, so the supplied tangents (the point of this test) are not what is rendered.",
    "NormalTangentTest": "No TANGENT in the file: Blender computes MikkTSpace tangents.",
    "DamagedHelmet": "Emissive texture; occlusion texture unused (see above).",
}


def write_readme(out: Path, record: dict, gltf_root: Path) -> None:
    if record.get("env"):
        write_env_readme(out, record, gltf_root)
        return
    models = record.get("models", {})
    names = [j for j in default_jobs() if j in models] + sorted(j for j in models if j not in default_jobs())
    lines = []
    add = lines.append
    add("# Cycles reference renders of glTF sample models")
    add("")
    add("Reference images of Khronos glTF sample models rendered with Blender Cycles, for testing")
    add("lumo's glTF materials per pixel. Generated by `benches/peers/cycles_gltf.py` (this file too:")
    add("edit the script, not this README).")
    add("")
    add("## Files")
    add("")
    add("| file | content |")
    add("|---|---|")
    add("| `<Name>.exr` | mean of K independent passes: linear scene radiance, float32 RGB (channels `R`, `G`, `B`), ZIP, 128 x 128 |")
    add("| `<Name>.var.exr` | per-pixel variance of that mean = sample variance of the K passes (ddof 1) / K, float32 RGB, ZIP |")
    add("| `<Name>.png` | sRGB preview of the mean (clamped to [0, 1]), for humans; only where it is under 30 KB |")
    add("| `cameras.json` | per model: `gltf` (path under `shared/gltf/`), `camera` = the lumo camera used (`position`, `look_at`, `up`, `fov_y_deg`, glTF/lumo y-up frame), passes, spp, seeds, seconds, importer warnings; at the top: Blender and lumo versions, the Cycles settings as read back |")
    add("")
    add("`<Name>_nonormal` = the same model and camera with every Normal Map node unlinked from the")
    add("Principled BSDF's Normal input (normal maps ignored), same seeds as `<Name>`.")
    add("`<Name>_flat` = the same model and camera with every mesh's normals removed and its faces")
    add("shaded flat (shading normals = geometric normals; lumo's `smooth: false`).")
    add("")
    ks = sorted({models[j]["passes"] for j in names})
    k = ks[0]
    add(f"With K = {k} passes the variance estimate has {k - 1} degrees of freedom (relative standard")
    add(f"deviation sqrt(2/{k - 1}) = {100 * math.sqrt(2 / (k - 1)):.0f} % per pixel and channel): pool it over "
        "neighbouring pixels")
    add("or a whole image, or allow for it in the threshold, rather than trusting single pixels.")
    add("Pixels that see only the background have variance exactly 0.")
    add("")
    add("## Regenerate")
    add("")
    add("```sh")
    add("bash benches/peers/setup.sh    # benches/peers/.venv with bpy==5.0.1, numpy, OpenEXR")
    add(record.get("command", "nice -n 10 benches/peers/.venv/bin/python benches/peers/cycles_gltf.py"))
    add("```")
    add("")
    add(textwrap.fill(
        f"Cameras came from `{record.get('lumo_version', '?')}`. `--lumo` is any lumo binary whose "
        "`lumo convert MODEL -o x.json` gives the camera (default `target/release/lumo`); "
        "`--models A,B` re-renders only some models and keeps the others' entries; "
        "`--passes K --spp N` change the sample counts; `--readme-only` rewrites this file from "
        "`cameras.json`. Models are read from `../shared/gltf/` (`--gltf-root`). Cycles renders "
        "are deterministic for a given seed: a second run reproduced the images.",
        width=96, break_on_hyphens=False, break_long_words=False))
    add("")
    add("## Renders")
    add("")
    add("Render seconds = sum over the passes of Cycles' `render_pre` .. `render_post` (scene sync and")
    add("path tracing; the first model's first pass also loads the kernels), wall time on the shared")
    add("2-core machine; CPU s = CPU time of all of Blender's threads over the same intervals; load =")
    add("the highest 1-minute load average seen (above 2, other jobs competed for the cores and the")
    add("wall times are inflated).")
    add("")
    total = sum(models[j]["total_seconds"] for j in names)
    add(f"All {len(names)} renders took {total:.0f} s in all (import, render, writing).")
    add("")
    add("| model | passes x spp | spp | render s | CPU s | load | Blender | sampling pattern | importer warnings |")
    add("|---|---|---:|---:|---:|---:|---|---|---|")
    pattern = record.get("settings", {}).get("sampling_pattern", "?")
    for j in names:
        e = models[j]
        warn = "; ".join(e.get("importer_warnings") or []) or "none"
        unsup = e.get("extensions_not_handled_by_importer") or []
        if unsup:
            warn += "; not handled: " + ", ".join(unsup)
        add(f"| {j} | {e['passes']} x {e['spp_per_pass']} | {e['spp']} | {e['render_seconds']:.1f} | "
            f"{e['render_cpu_seconds']:.1f} | {e['load1_max']:.2f} | {e['blender']} | "
            f"{pattern} | {warn} |")
    add("")
    add("## Scene and settings")
    add("")
    add("- Camera: lumo's (`lumo convert MODEL -o x.json`, its `camera`: the file's first camera, or")
    add("  lumo's automatic framing; none of these files has a camera), turned to Blender's z-up frame")
    add("  as the importer turns the model, (x, y, z) -> (x, -z, y); vertical field of view")
    add("  `fov_y_deg` with `sensor_fit = VERTICAL`; checked by projecting look_at to the image centre")
    add("  and points at the half-angles to the image edges. 128 x 128, pixel aspect 1.")
    add("- Import: Blender's bundled glTF importer (`io_scene_gltf2`), default options, into an empty")
    add("  factory-settings scene. Lights and cameras from the file deleted (there are none).")
    add("- Light: world of constant grey 0.5, strength 1, the only light (plus emissive materials).")
    add("- Cycles: CPU device, all threads (threads mode AUTO); pixel filter Box, width 1 px; no")
    add("  denoising; no adaptive sampling; no clamping (`sample_clamp_direct` =")
    add("  `sample_clamp_indirect` = 0); light tree off; Filter Glossy 0; caustics reflective and")
    add("  refractive on (Blender's defaults, set explicitly); max bounces 6, diffuse / glossy /")
    add("  transmission / volume bounces 6; transparent max bounces 64; sampling pattern Blender's")
    add("  default (see the table); seeds 1..K, `use_animated_seed` off; film not transparent.")
    add("- Colour: view transform Standard, look None, exposure 0, gamma 1; the EXR holds the")
    add("  scene-linear render result (Linear Rec.709), written by Blender as float32 EXR and averaged")
    add("  in float64. Check: every pixel that sees only the world reads exactly 0.5 in every pass.")
    add("")
    add("## Where Blender's importer / Cycles depart from the glTF spec")
    add("")
    add("The importer's console log had no warnings or errors for any model unless the table above")
    add("says so, and it handles every extension these files use (it ignores unknown non-required")
    add("extensions without a word, so the script also compares `extensionsUsed` with the importer's")
    add("list). Departures noticed in the importer's code and in Cycles:")
    add("")
    add(GENERAL_NOTES.rstrip())
    add("")
    add("Per model:")
    add("")
    for j in names:
        model, _, _ = split_job(j)
        if j == model and model in MODEL_NOTES:
            add(textwrap.fill(f"- **{model}**: {MODEL_NOTES[model]}", width=96,
                              subsequent_indent="  ", break_on_hyphens=False))
    add("")
    add("## Licenses and attribution")
    add("")
    add("These images are derived works (renders) of the models below, from the Khronos glTF Sample")
    add(f"Assets (`{SOURCE_REPO}`, `Models/<Name>/`; copies in `shared/gltf/<Name>/` with their")
    add("`SOURCE-LICENSE.md` / `SOURCE-metadata.json`). Licenses per `SOURCE-metadata.json`:")
    add("")
    seen = []
    for j in names:
        model, _, _ = split_job(j)
        if model in seen:
            continue
        seen.append(model)
        legal = model_legal(gltf_root, model)
        parts = []
        for lg in legal:
            parts.append(f"© {lg.get('year', '?')} {lg.get('owner', '?')}, artist {lg.get('artist', '?')} "
                         f"({lg.get('what', '?')}), {lg.get('spdx') or lg.get('license', '?')}")
        title = model_title(gltf_root, model)
        add(textwrap.fill(
            f"- `{model}*`: \"{title}\" — " + ("; ".join(parts) if parts else "license unknown")
            + f". Source: https://github.com/{SOURCE_REPO}/tree/main/Models/{model}. Rendered with "
              "Blender Cycles (re-lit, re-framed).", width=96, subsequent_indent="  ",
            break_on_hyphens=False, break_long_words=False))
    add("")
    add("CC-BY-4.0 attribution applies to the renders of the CC-BY models (listed above, with the")
    add("license link https://creativecommons.org/licenses/by/4.0/). DamagedHelmet's metadata also")
    add("names an earlier version of the model under CC-BY-NC-4.0 (theblueturtle_), which the")
    add("current model \"may have been based on\" (its SOURCE-README.md).")
    add("")
    (out / "README.md").write_text("\n".join(lines))


#: Environment-mode notes on the importer for features the issue's models do not have.
ENV_GENERAL_NOTES = """\
- **Primitives without a material** (BoxVertexColors, Cameras, MultipleScenes, SimpleInstancing,
  SimpleMeshes, SimpleSparseAccessor, Triangle, TriangleWithoutIndices): the glTF default
  material is white, metallic 1, roughness 1. The importer does not build it: without COLOR_0 it
  leaves the material slot empty (Cycles would render its own grey diffuse surface); with
  COLOR_0 it creates a Principled BSDF of the vertex colour with metallic 0 and roughness 0.5.
  This script gives such files the spec's default (`give_default_material`): a Principled BSDF
  of base colour 1 (or the importer's COLOR_0 link), metallic 1, roughness 1, IOR 1.5.
- **Missing normals** (NORMAL absent): flat shading (face normals), as the spec says.
- **KHR_materials_unlit** (UnlitTest): an Emission shader of the base colour (strength 1) for
  camera rays, mixed with a Transparent BSDF for every other ray (Blender's "light path trick"):
  the camera sees the base colour; other surfaces see through the unlit object (no shadows, no
  reflections of it).
- **KHR_texture_transform**: a Mapping node on the UVs (offset, rotation, scale; `texCoord`
  override honoured).
- **EXT_mesh_gpu_instancing** (SimpleInstancing): the importer instances the mesh at every
  TRANSLATION / ROTATION / SCALE, as lumo does.
- **Several scenes** (MultipleScenes): the importer imports every scene as a collection and
  excludes all but the default one (`scene`) from the view layer, so the default scene is
  rendered, as lumo does.
- **Cameras in the file** (Cameras, Duck): deleted; lumo's camera is used, which is the file's
  first camera (perspective; lumo does not import orthographic cameras) with its vertical field
  of view.
"""

#: Per-model environment-mode notes (besides MODEL_NOTES), written from the renders.
ENV_MODEL_NOTES: dict[str, str] = {
    "SimpleInstancing": "EXT_mesh_gpu_instancing: Blender and lumo both draw the cube 125 times "
        "(translations 0..10, scales 1..2, rotations about the axes); no material, so glTF's "
        "default material (see above).",
    "BoxInterleaved": "No metallicFactor, so metallic 1 (the spec's default): a red metal, "
        "unlike Box (metallicFactor 0), which is why the two images differ.",
    "BoxVertexColors": "No material, with COLOR_0: the importer's Principled BSDF of base colour "
        "COLOR_0 made metallic 1 and roughness 1 (glTF's default material times COLOR_0).",
    "Cameras": "lumo's camera is the file's first camera (perspective, yfov 0.7 rad = 40.1 deg); "
        "the orthographic one is ignored by lumo and deleted here. No material (glTF's default) "
        "and no normals (flat).",
    "Duck": "lumo's camera is the file's camera (yfov 37.8 deg, up vector not +y): the duck covers "
        "only about 1300 pixels, off centre.",
    "MultipleScenes": "The default scene (`scene`: 1) is rendered, as in lumo; scene 0's "
        "collection is excluded. No material, no normals.",
    "SimpleMeshes": "No material: glTF's default.",
    "SimpleSparseAccessor": "No material (glTF's default), no normals (flat).",
    "Triangle": "No material (glTF's default), no normals (flat).",
    "TriangleWithoutIndices": "No material (glTF's default), no normals (flat); the same "
        "image as Triangle.",
    "GlassBrokenWindow": "The glass is a single quad with KHR_materials_transmission "
        "(transmissionFactor 1, roughness 0.05 x texture) and alphaMode MASK (the broken hole). "
        "Without KHR_materials_volume the spec treats it as thin-walled (no refraction "
        "offset); Cycles refracts at the quad as at the surface of a solid of IOR 1.5 and never "
        "refracts back, so the background seen through the glass is shifted. The frame's "
        "occlusion texture is unused (see above).",
    "TextureTransformTest": "KHR_texture_transform -> Mapping nodes; in the render every arrow "
        "points at its green marker (transforms as the spec wants). The importer's log lines "
        "\"create Mesh node Error Marker / Not Supported Marker\" are INFO lines naming meshes of "
        "the test, not problems.",
    "ClearCoatCarPaint": "KHR_materials_clearcoat and KHR_texture_transform (both required) are "
        "handled: Principled Coat (weight 1, roughness 0; no clearcoat normal, so the coat is "
        "smooth), a Mapping node (scale 3) on the UVs of the base layer's noise normal map "
        "(scale 0.2).",
    "EmissiveStrengthTest": "KHR_materials_emissive_strength -> Principled Emission Strength.",
    "UnlitTest": "KHR_materials_unlit (required): see 'KHR_materials_unlit' above.",
    "CornellBoxVinc3r": "Not a Khronos sample: a Blender 2.80 export with an open front, lit by "
        "the environment and by its emissive ceiling panel (emissiveFactor 1; no "
        "pbrMetallicRoughness, so a white rough metal underneath). TEXCOORD_1 (lightmap UVs) is "
        "not used by any material.",
    "TwoSidedPlane": "doubleSided true: both faces rendered (Cycles renders back faces anyway).",
}

#: Models outside the Khronos sample assets: (source URL, licence line).
OTHER_SOURCES = {
    "CornellBoxVinc3r": (
        "https://github.com/Vinc3r/cornellBox",
        "\"WebGL Cornell box for BabylonJS\" — © 2019 Vincent Lamy (Vinc3r), WTFPL v2 (the "
        "repository's LICENSE; its README: \"feel free to do whatever you want with these "
        "assets\"); file `BJS-2.80-Eevee-gltf/assets/cornellBox-2.80-Eevee-gltf.gltf` at commit "
        "4250737dcec66c88575ede38a37b68cb4d62bf98"),
}


def env_check_summary(models: dict) -> str:
    checked = {j: e["environment_check"] for j, e in models.items()
               if (e.get("environment_check") or {}).get("median_rel_err") is not None}
    unchecked = sorted(j for j in models if j not in checked)
    text = ""
    if checked:
        worst = max(checked, key=lambda j: checked[j]["median_rel_err"])
        p99 = max(c["p99_rel_err"] for c in checked.values())
        text = (f"{len(checked)} models were checked: median error at most "
                f"{100 * checked[worst]['median_rel_err']:.3f} % ({worst}), 99th percentile at most "
                f"{100 * p99:.2f} % (pixels next to geometry and the environment's sharpest edges).")
    if unchecked:
        text += (" No background pixel, so no check: " + ", ".join(unchecked) + ".")
    return text.strip()


def write_env_readme(out: Path, record: dict, gltf_root: Path) -> None:
    """README.md of an environment-mode folder (--env), generated from ``cameras.json``."""
    try:
        out_rel = out.resolve().relative_to(common.REPO_ROOT)
    except ValueError:
        out_rel = out
    models = record.get("models", {})
    failed = record.get("failed", {})
    names = sorted(models)
    env = record["env"]
    settings = record.get("settings", {})
    world = settings.get("world_nodes", {})
    storage = record.get("exr_storage", {})
    lines = []
    add = lines.append

    def para(text: str) -> None:
        add(textwrap.fill(text, width=96, break_on_hyphens=False, break_long_words=False))

    def bullet(text: str) -> None:
        add(textwrap.fill(text, width=96, subsequent_indent="  ", break_on_hyphens=False,
                          break_long_words=False))

    env_name = Path(env["image"]).name
    add(f"# Cycles reference renders of glTF sample models under `{env_name}`")
    add("")
    para("Reference images of glTF sample models rendered with Blender Cycles, lit by an HDR "
         f"environment map (`{env['image']}`) instead of the grey world of `../cycles_gltf/`, for "
         "testing lumo's glTF materials together with its environment light (`--env`). "
         "Generated by `benches/peers/cycles_gltf.py --env` (this file too: edit the script, not "
         "this README).")
    add("")
    add("## Files")
    add("")
    add("| file | content |")
    add("|---|---|")
    add(f"| `<Name>.exr` | mean of K independent passes: linear scene radiance, RGB (channels `R`, `G`, `B`), {storage.get('mean', '?')}, {WIDTH} x {HEIGHT} |")
    add(f"| `<Name>.var.exr` | per-pixel variance of that mean = sample variance of the K passes (ddof 1) / K, RGB, {storage.get('variance', '?')} |")
    add("| `<Name>.png` | sRGB preview of the mean (clamped to [0, 1]), for humans; only where it is under 30 KB |")
    add("| `cameras.json` | per model: `gltf` (path under `shared/gltf/`), `camera` = the lumo camera used (`position`, `look_at`, `up`, `fov_y_deg`, glTF/lumo y-up frame), passes, spp, seeds, seconds, importer warnings, the environment check; at the top: Blender and lumo versions, the environment file (with its SHA-256), the world nodes and the Cycles settings as read back, the still image(s) |")
    add("")
    para("`<Name>` is the model's folder under `shared/gltf/`; `<Name>_flat` is the same model and "
         "camera with every mesh's normals removed and its faces shaded flat (shading normals = "
         "geometric normals, lumo's `smooth: false`). Storage: with a textured background "
         "every pixel is noisy and float32 compresses poorly (about 195 KB per 128 x 128 image, "
         "13 MB for the folder), so the mean is stored as half floats (relative rounding at most "
         "2^-11 = 0.05 %, far below the noise of a 2048-spp mean) and the variance as float32 "
         f"rounded to {ENV_VAR_MANTISSA_BITS} mantissa bits (relative rounding at most "
         f"{100 * 2.0 ** -(ENV_VAR_MANTISSA_BITS + 1):.1f} %, against the estimate's own scatter "
         "below); readers that convert to float (OpenEXR, the `exr`/`image` crates) need nothing "
         "special.")
    add("")
    ks = sorted({models[j]["passes"] for j in names}) or [8]
    k = ks[0]
    para(f"With K = {k} passes the variance estimate has {k - 1} degrees of freedom (relative "
         f"standard deviation sqrt(2/{k - 1}) = {100 * math.sqrt(2 / (k - 1)):.0f} % per pixel and "
         "channel): pool it over neighbouring pixels or a whole image, or allow for it in the "
         "threshold, rather than trusting single pixels. Unlike the grey world's, background "
         "pixels have a small non-zero variance (the environment varies within a pixel).")
    add("")
    add("## Regenerate")
    add("")
    add("```sh")
    add("bash benches/peers/setup.sh    # benches/peers/.venv with bpy==5.0.1, numpy, OpenEXR")
    add(record.get("command", "nice -n 10 benches/peers/.venv/bin/python benches/peers/cycles_gltf.py --env FILE.exr"))
    for still in record.get("stills", {}).values():
        add(still["command"])
    add("```")
    add("")
    para(f"Cameras came from `{record.get('lumo_version', '?')}`. `--lumo` is any lumo binary whose "
         "`lumo convert MODEL -o x.json` gives the camera; `--models A,B` re-renders only some "
         "models and keeps the others' entries; `--passes K --spp N` change the sample counts; "
         f"`--readme-only --out {out_rel}` rewrites this file from `cameras.json`. "
         "Models are read from `../shared/gltf/` (`--gltf-root`), one file per model folder: "
         "`glTF-Binary/*.glb`, else `glTF/*.gltf`, else the folder's own `*.gltf` "
         "(CornellBoxVinc3r). Cycles renders are deterministic for a given seed: a second run "
         "of UnlitTest and Triangle reproduced their EXRs bit for bit.")
    add("")
    para("The matching lumo render (same camera, since lumo made it; lumo's `--env` uses the "
         "orientation that Blender's default mapping gives, see `../cycles_env/`): "
         f"`lumo render MODEL --env {env['image']} --width {WIDTH} --height {HEIGHT} --spp N -o "
         "x.exr` from the repository root. Remember the importer departures below before "
         "reading differences as lumo bugs.")
    add("")
    add("## Renders")
    add("")
    para("Render seconds = sum over the passes of Cycles' `render_pre` .. `render_post` (scene "
         "sync and path tracing; the first model's first pass also loads the kernels), wall time "
         "on the shared 2-core machine; CPU s = CPU time of all of Blender's threads over the "
         "same intervals; load = the highest 1-minute load average seen (above 2, other jobs "
         "competed for the cores and the wall times are inflated). Geometry px = pixels with at "
         "least one of 16 rays hitting geometry (Blender's `ray_cast`; 0 = the camera sees "
         "nothing); env err = median relative luminance error of the pixels that see only the "
         "environment against the numpy prediction (see 'Scene and settings').")
    add("")
    total = sum(models[j]["total_seconds"] for j in names)
    para(f"All {len(names)} renders took {total:.0f} s in all (import, render, checks, writing)"
         + (f"; {len(failed)} model(s) failed (below)." if failed else "; none failed."))
    add("")
    add("| model | file | passes x spp | render s | CPU s | load | total s | geometry px | env err | importer warnings |")
    add("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
    for j in names:
        e = models[j]
        warn = "; ".join(e.get("importer_warnings") or []) or "none"
        unsup = e.get("extensions_not_handled_by_importer") or []
        if unsup:
            warn += "; not handled: " + ", ".join(unsup)
        chk = e.get("environment_check", {})
        err = chk.get("median_rel_err")
        add(f"| {j} | `{Path(e['gltf']).name}` | {e['passes']} x {e['spp_per_pass']} | "
            f"{e['render_seconds']:.1f} | {e['render_cpu_seconds']:.1f} | {e['load1_max']:.2f} | "
            f"{e['total_seconds']:.1f} | {chk.get('pixels_seeing_geometry', '?')} | "
            f"{'-' if err is None else f'{100 * err:.3f} %'} | {warn} |")
    for j in sorted(failed):
        add(f"| {j} | failed: {failed[j].splitlines()[0]} | | | | | | | | |")
    add("")
    add(f"Blender {record.get('blender', '?')}, sampling pattern {settings.get('sampling_pattern', '?')}.")
    add("")
    stills = record.get("stills", {})
    if stills:
        add("## Larger still image")
        add("")
        for path, s in stills.items():
            para(f"`{path}`: {s['model']} (`{s['gltf']}`), {s['resolution'][0]} x "
                 f"{s['resolution'][1]}, {s['passes']} pass of {s['spp']} spp (seed {s['seed']}), "
                 f"the same camera (lumo's, fov_y {s['camera']['fov_y_deg']:g} deg; the image is "
                 "square, so the framing equals the 128 x 128 reference's), world and Cycles "
                 f"settings as above except the resolution. {s['png']}. Blender {s['blender']}; "
                 f"render {s['render_seconds']:.1f} s (CPU {s['render_cpu_seconds']:.1f} s, load "
                 f"{s['load1']:.2f}); {s['png_bytes']} bytes. Regenerate with `{s['command']}`.")
            add("")
    add("## Scene and settings")
    add("")
    bullet("- Camera: lumo's (`lumo convert MODEL -o x.json`, its `camera`: the file's first camera "
           "(Cameras, Duck), or lumo's automatic framing), turned to Blender's z-up frame as the "
           "importer turns the model, (x, y, z) -> (x, -z, y); vertical field of view "
           "`fov_y_deg` with `sensor_fit = VERTICAL`; checked by projecting look_at to the image "
           f"centre and points at the half-angles to the image edges. {WIDTH} x {HEIGHT}, pixel "
           "aspect 1.")
    bullet("- Import: Blender's bundled glTF importer (`io_scene_gltf2`), default options, into an "
           "empty factory-settings scene. Lights and cameras from the file deleted (no file has "
           "lights).")
    bullet(f"- Light: the world only (plus emissive materials): `{env['image']}` ({env['bytes']} "
           f"bytes, SHA-256 `{env['sha256']}`, {world.get('image_size', ['?', '?'])[0]} x "
           f"{world.get('image_size', ['?', '?'])[1]}) as an Environment Texture, projection "
           f"{world.get('projection', '?')}, interpolation {world.get('interpolation', '?')}, "
           f"colour space {world.get('colorspace', '?')}, Vector input "
           f"{world.get('vector', '?')} -> Background, strength {world.get('strength', '?')} -> "
           "World Output. Visible to the camera. World importance sampling "
           f"{world.get('sampling_method', '?')} (Blender's default; map resolution "
           f"{world.get('sample_map_resolution', '?')}), light tree off. Blender decodes the EXR "
           "to the values OpenEXR gives (checked: largest relative difference "
           f"{world.get('blender_vs_openexr_max_rel_diff', '?')}). The default mapping is lumo's "
           "orientation of an unrotated environment (verified in `../cycles_env/`).")
    bullet("- Cycles: CPU device, all threads (threads mode AUTO); pixel filter Box, width 1 px; no "
           "denoising; no adaptive sampling; no clamping (`sample_clamp_direct` = "
           "`sample_clamp_indirect` = 0); light tree off; Filter Glossy 0; caustics reflective and "
           "refractive on (Blender's defaults, set explicitly); max bounces 6, diffuse / glossy / "
           "transmission / volume bounces 6; transparent max bounces 64; sampling pattern "
           "Blender's default; seeds 1..K, `use_animated_seed` off; film not transparent.")
    bullet("- Colour: view transform Standard, look None, exposure 0, gamma 1; the EXR holds the "
           "scene-linear render result (Linear Rec.709), written by Blender as float32 EXR and "
           "averaged in float64 (then stored as above).")
    bullet(f"- Check (replaces the grey world's): Blender's `scene.ray_cast` on the evaluated scene "
           f"with {ENV_CHECK_SUBPIXELS} x {ENV_CHECK_SUBPIXELS} rays per pixel through lumo's "
           "camera finds the pixels that see no geometry (eroded by one pixel; transparent "
           "geometry counts as geometry); there the Cycles mean must match a numpy prediction of "
           "the environment along the same rays (lumo's documented orientation, bilinear lookup, "
           "negative texels as 0) with a median relative luminance error under "
           f"{100 * ENV_CHECK_TOLERANCE:.0f} % (else the model fails). "
           + env_check_summary(models))
    add("")
    add("## Where Blender's importer / Cycles depart from the glTF spec")
    add("")
    para("The importer's console log had no warnings or errors for any model unless the table "
         "above says so, and it handles every extension these files use (it ignores unknown "
         "non-required extensions without a word, so the script also compares `extensionsUsed` "
         "with the importer's list). Departures noticed in the importer's code and in Cycles (the "
         "first six as in `../cycles_gltf/README.md`):")
    add("")
    add(GENERAL_NOTES.rstrip())
    add(ENV_GENERAL_NOTES.rstrip())
    add("")
    add("Per model:")
    add("")
    for j in names:
        note = " ".join(n for n in (MODEL_NOTES.get(j), ENV_MODEL_NOTES.get(j)) if n)
        if note:
            bullet(f"- **{j}**: {note}")
    for j in sorted(failed):
        bullet(f"- **{j}**: failed: {failed[j]}")
    add("")
    add("## Licenses and attribution")
    add("")
    para("These images are derived works (renders) of the models below, copied in "
         "`shared/gltf/<Name>/` with their `SOURCE-LICENSE.md` / `SOURCE-metadata.json`; all but "
         f"one come from the Khronos glTF Sample Assets (`{SOURCE_REPO}`, `Models/<Name>/`). "
         "Licenses per `SOURCE-metadata.json`:")
    add("")
    for j in names + sorted(failed):
        if split_job(j)[0] != j:
            continue  # a variant: attributed with its model
        if j in OTHER_SOURCES:
            url, text = OTHER_SOURCES[j]
            bullet(f"- `{j}`: {text}. Source: {url}. Rendered with Blender Cycles (re-lit, "
                   "re-framed).")
            continue
        legal = model_legal(gltf_root, j)
        parts = [f"© {lg.get('year', '?')} {lg.get('owner', '?')}, artist {lg.get('artist', '?')} "
                 f"({lg.get('what', '?')}), {lg.get('spdx') or lg.get('license', '?')}" for lg in legal]
        bullet(f"- `{j}`: \"{model_title(gltf_root, j)}\" — "
               + ("; ".join(parts) if parts else "license unknown")
               + f". Source: https://github.com/{SOURCE_REPO}/tree/main/Models/{j}. Rendered "
                 "with Blender Cycles (re-lit, re-framed).")
    add("")
    para("CC-BY-4.0 attribution applies to the renders of the CC-BY models (listed above, with the "
         "license link https://creativecommons.org/licenses/by/4.0/). `LicenseRef-CC-BY-TM` "
         "(BoxTextured) is CC-BY 4.0 with trademark limitations (the texture is the Cesium logo). "
         "`SCEA` (Duck) is the SCEA Shared Source License 1.0 (https://spdx.org/licenses/SCEA.html). "
         "DamagedHelmet's metadata also names an earlier version of the model under CC-BY-NC-4.0 "
         "(theblueturtle_), which the current model \"may have been based on\" (its "
         "SOURCE-README.md).")
    add("")
    para(f"Environment: `{env_name}` (`{env['image']}`, copied unmodified from Blender's "
         "studio lights, `datafiles/studiolights/world`, Debian package `blender-data` "
         "3.4.1+dfsg-2; see `shared/hdri/README.md`): CC0, created by Greg Zaal (HDRI Haven, now "
         "Poly Haven, https://polyhaven.com), per `shared/hdri/SOURCE-license.txt`: \"All HDRIs are "
         "licenses as CC0.\"")
    add("")
    (out / "README.md").write_text("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
