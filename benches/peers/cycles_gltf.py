"""Reference renders of Khronos glTF sample models with Blender Cycles (PyPI ``bpy``), for lumo's
glTF material tests: per model a mean image and the per-pixel variance of that mean.

    .venv/bin/python cycles_gltf.py [--models A,B] [--passes 8] [--spp 256] [--lumo PATH]
                                    [--gltf-root DIR] [--out DIR]

For every model (``<Name>`` or ``<Name>_nonormal``):

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
   input (the normal maps are then ignored).
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
"""

from __future__ import annotations

import argparse
import contextlib
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
SOURCE_REPO = "KhronosGroup/glTF-Sample-Assets"


def default_jobs() -> list[str]:
    jobs = []
    for m in MODELS:
        jobs.append(m)
        if m in NONORMAL_MODELS:
            jobs.append(m + NONORMAL_SUFFIX)
    return jobs


def split_job(job: str) -> tuple[str, bool]:
    """'NormalTangentTest_nonormal' -> ('NormalTangentTest', True)."""
    if job.endswith(NONORMAL_SUFFIX):
        return job[: -len(NONORMAL_SUFFIX)], True
    return job, False


def find_model_file(root: Path, model: str) -> Path:
    """The model's glTF/*.gltf, else glTF-Binary/*.glb (the variant lumo's tests read)."""
    for sub, pattern in (("glTF", "*.gltf"), ("glTF-Binary", "*.glb")):
        hits = sorted((root / model / sub).glob(pattern))
        if hits:
            return hits[0]
    raise FileNotFoundError(f"{root / model}: no glTF/*.gltf or glTF-Binary/*.glb")


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
    notable = [ln.strip() for ln in log
               if any(w in ln.upper() for w in ("WARNING", "ERROR", "UNSUPPORTED", "NOT SUPPORTED"))]
    if error:
        raise RuntimeError(f"glTF import of {path} failed: {error}\n  log: " + "\n  log: ".join(log))
    return log, notable


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


def configure_cycles(scene) -> dict:
    """The issue's settings; returns them as read back from Blender (for the record)."""
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = WIDTH, HEIGHT, 100
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

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"sRGB", b"\x00") + chunk(b"IDAT", best) + chunk(b"IEND", b""))
    if len(png) >= PNG_MAX_BYTES:
        path.unlink(missing_ok=True)
        return None
    path.write_bytes(png)
    return len(png)


def canonical_command(args) -> str:
    """The command that regenerates every model with these sample counts (no --models/--out)."""
    argv = ["nice", "-n", "10", "benches/peers/.venv/bin/python", "benches/peers/cycles_gltf.py"]
    if args.passes != 8:
        argv += ["--passes", str(args.passes)]
    if args.spp != 256:
        argv += ["--spp", str(args.spp)]
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

def render_job(bpy, job: str, args, managed_ext: list[str]) -> tuple[dict, dict]:
    model, nonormal = split_job(job)
    t_job = time.perf_counter()
    model_file = find_model_file(args.gltf_root, model)
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
    lights, cams = remove_lights_and_cameras(bpy)
    if lights:
        print(f"  note: removed {lights} light(s) the file brought")
    unlinked = None
    if nonormal:
        unlinked = unlink_normal_maps(bpy)
        if unlinked == 0:
            raise RuntimeError("no Normal Map -> Principled BSDF Normal link found to remove")
        print(f"  unlinked {unlinked} Normal Map node(s) from the Principled BSDF")
    emissive = count_emissive(bpy)
    meshes = sum(1 for o in bpy.data.objects if o.type == "MESH")

    set_world(bpy, scene)
    settings = configure_cycles(scene)
    add_camera(bpy, scene, cam)
    timer = Timer(bpy)

    passes = PASSES_OVERRIDE.get(job, PASSES_OVERRIDE.get(model, args.passes))
    seeds = [FIRST_SEED + k for k in range(passes)]
    images = []
    render_s = cpu_s = 0.0
    loads = []
    try:
        with tempfile.TemporaryDirectory(prefix="cycles_gltf_") as tmp:
            for k, seed in enumerate(seeds):
                path = Path(tmp) / f"pass{k}.exr"
                dt, cpu = render_pass(bpy, scene, timer, args.spp, seed, path)
                render_s += dt
                cpu_s += cpu
                loads.append(common.load1())
                img = common.read_exr(path)
                if img.shape != (HEIGHT, WIDTH, 3):
                    raise RuntimeError(f"pass {k}: image shape {img.shape}")
                if not np.all(np.isfinite(img)):
                    raise RuntimeError(f"pass {k}: non-finite pixels")
                images.append(img)
                print(f"  pass {k + 1}/{passes}: {args.spp} spp, seed {seed}, {dt:7.2f} s "
                      f"(cpu {cpu:7.2f} s, load {loads[-1]:.2f})", flush=True)
    finally:
        for h, fn in ((bpy.app.handlers.render_pre, timer._pre), (bpy.app.handlers.render_post, timer._post)):
            with contextlib.suppress(ValueError):
                h.remove(fn)

    stack = np.stack(images)
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / passes if passes > 1 else np.full_like(mean, np.nan)
    # Linearity check: pixels that see only the world read exactly its radiance in every pass.
    bg = np.all(np.abs(stack - WORLD_GREY) < 1e-6, axis=(0, 3))
    background_pixels = int(bg.sum())

    args.out.mkdir(parents=True, exist_ok=True)
    common.write_exr(args.out / f"{job}.exr", mean.astype(np.float32))
    common.write_exr(args.out / f"{job}.var.exr", var_of_mean.astype(np.float32))
    png_bytes = write_png_preview(args.out / f"{job}.png", mean)

    total_s = time.perf_counter() - t_job
    entry = {
        "gltf": model_file.relative_to(args.gltf_root).as_posix(),
        "camera": cam,
        "normal_maps": not nonormal,
        "passes": passes,
        "spp_per_pass": args.spp,
        "spp": passes * args.spp,
        "seeds": seeds,
        "render_seconds": round(render_s, 2),
        "render_cpu_seconds": round(cpu_s, 2),
        "total_seconds": round(total_s, 2),
        "import_seconds": round(import_seconds, 2),
        "load1_max": round(max(loads), 2),
        "blender": bpy.app.version_string,
        "meshes": meshes,
        "emissive_materials": emissive,
        "lights_removed": lights,
        "cameras_removed": cams,
        "normal_map_links_removed": unlinked,
        "importer_warnings": notable,
        "extensions_used": used,
        "extensions_not_handled_by_importer": unsupported,
        "background_pixels_reading_0.5": background_pixels,
        "image_mean": [round(float(v), 6) for v in mean.reshape(-1, 3).mean(axis=0)],
        "png_preview_bytes": png_bytes,
    }
    print(f"  -> {job}: {passes} x {args.spp} spp = {passes * args.spp} spp, render {render_s:.1f} s "
          f"(cpu {cpu_s:.1f} s), total {total_s:.1f} s; {background_pixels} background pixels read "
          f"{WORLD_GREY}; image mean {entry['image_mean']}; png "
          f"{'%d B' % png_bytes if png_bytes else 'skipped (>= 30 KB)'}", flush=True)
    if background_pixels == 0:
        print(f"  warning: no pixel sees only the world; the linearity check could not run")
    return entry, settings


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--models", default=",".join(default_jobs()),
                    help="comma-separated models (a '_nonormal' suffix unlinks the normal maps); "
                         "default: all of the issue's")
    ap.add_argument("--passes", type=int, default=8, help="independent passes K (default 8)")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel per pass (default 256)")
    ap.add_argument("--lumo", default=default_lumo(),
                    help="lumo binary used for the cameras (default target/release/lumo, else PATH)")
    ap.add_argument("--gltf-root", type=Path, default=DEFAULT_GLTF_ROOT,
                    help=f"folder of the sample models (default {DEFAULT_GLTF_ROOT})")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    ap.add_argument("--readme-only", action="store_true",
                    help="only rewrite README.md from the existing cameras.json (no rendering)")
    args = ap.parse_args()
    if args.readme_only:
        record = load_record(args.out)
        if not record.get("models"):
            raise SystemExit(f"{args.out / 'cameras.json'}: no models recorded")
        write_readme(args.out, record, args.gltf_root.resolve())
        print(f"wrote {args.out / 'README.md'}")
        return 0
    if args.passes < 2:
        raise SystemExit("--passes: need at least 2 passes to estimate a variance")
    if args.spp < 1:
        raise SystemExit("--spp: must be positive")
    jobs = [j.strip() for j in args.models.split(",") if j.strip()]
    if not jobs:
        raise SystemExit("--models: empty")
    if shutil.which(args.lumo) is None and not Path(args.lumo).is_file():
        raise SystemExit(f"--lumo: {args.lumo} not found (build lumo or pass --lumo PATH)")
    args.lumo_arg = args.lumo
    args.gltf_root = args.gltf_root.resolve()
    args.out = args.out.resolve()

    import bpy

    reset_blender(bpy)
    managed_ext = importer_extensions()
    print(f"blender {bpy.app.version_string}; glTF importer handles {len(managed_ext)} extensions; "
          f"{len(jobs)} model(s), {args.passes} x {args.spp} spp, out {args.out}", flush=True)

    record = load_record(args.out)
    record["generator"] = "benches/peers/cycles_gltf.py"
    record["blender"] = bpy.app.version_string
    record["resolution"] = [WIDTH, HEIGHT]
    record["world_rgb"] = [WORLD_GREY] * 3
    record["lumo_version"] = lumo_version(args.lumo)
    record["camera_frame"] = ("glTF / lumo y-up; Blender camera = (x, y, z) -> (x, -z, y), "
                              "fov_y_deg = vertical field of view (sensor_fit VERTICAL)")
    record.setdefault("models", {})

    failed = []
    timings = []
    for job in jobs:
        model, _ = split_job(job)
        print(f"== {job}", flush=True)
        try:
            if model not in MODELS:
                print(f"  note: {model} is not one of the issue's models; rendering it anyway")
            entry, settings = render_job(bpy, job, args, managed_ext)
        except Exception as e:
            print(f"ERROR: {job}: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
            if not isinstance(e, (FileNotFoundError, RuntimeError)):
                traceback.print_exc()
            failed.append(job)
            continue
        record["models"][job] = entry
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
        model, _ = split_job(j)
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
        model, _ = split_job(j)
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


if __name__ == "__main__":
    sys.exit(main())
