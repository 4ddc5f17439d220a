"""Renders the reference Cornell box (shared/cornell.md) with Blender Cycles (PyPI ``bpy``).

    .venv/bin/python cycles_cornell.py [--spp 1,4,16,64,256]

The scene is built from ``cornell_scene.py``'s explicit triangles (Blender is z-up, so the spec's
(x, y, z) becomes Blender's (x, -z, y), a proper rotation). Settings, as issue 7 asks:

- CPU device, all threads; no denoising; no adaptive sampling; no light/intensity clamping
  (Blender's default clamps indirect light at 10, which is biased); glossy filter off.
- Pixel filter: Box, width 1 px (each sample uniform in its pixel, equal weights).
- Max bounces 6 (Cycles counts 0 = direct light only, so 6 = Mitsuba's max_depth 8); diffuse
  bounces 6 as well.
- View transform Standard, look None, exposure 0, gamma 1; the EXR holds the scene-linear
  (Linear Rec.709, same primaries as Mitsuba's linear sRGB) render result, which Blender writes
  without any view transform.
- Materials: Diffuse BSDF (roughness 0 = Lambertian). The light: an Emission shader with colour =
  the spec's radiance and strength 1 (so a pixel seeing it reads exactly that radiance; checked
  below), multiplied by (1 - Backfacing) so it emits only from its front (downward) face, and
  ``emission_sampling = FRONT`` so light sampling agrees. Its back face is black, as in Mitsuba,
  whose diffuse BSDF is one-sided.
- Sampling pattern and light tree: Blender's defaults (recorded in the output).

Timing: one warm-up render at 1 spp first (kernel load, scene sync); each rung is then timed from
Blender's ``render_pre`` to ``render_post`` handlers, i.e. scene sync (24 quads: negligible) plus
path tracing, without writing the EXR. Each rung renders --seeds images (default 3) with seeds
spp, spp + 1000, spp + 2000 (every renderer's), each timed --repeats times (default 1); the
fastest time is kept, since the machine is shared.

Output: ``out/cycles/cycles_<spp>spp.exr`` (linear float32 RGB) and ``timings.csv`` (wall and
CPU seconds of all threads between the handlers).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import common
import cornell_scene as cs

PEER = "cycles"
#: Cycles counts bounces after the camera ray: 0 = direct light only. Mitsuba's max_depth 8
#: (1 = emitter seen directly, 2 = direct light) therefore corresponds to 6.
MAX_BOUNCES = cs.MAX_DEPTH_MITSUBA - 2


def to_blender(p: np.ndarray) -> np.ndarray:
    """Spec coordinates (y up) -> Blender (z up): (x, y, z) -> (x, -z, y), a rotation."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


def _new_material(bpy, name: str):
    mat = bpy.data.materials.new(name)
    if hasattr(mat, "use_nodes") and not mat.use_nodes:
        try:
            mat.use_nodes = True
        except Exception:  # Blender 5 always uses nodes; the property may be read-only
            pass
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    return mat, nt


def diffuse_material(bpy, name: str, rgb):
    mat, nt = _new_material(bpy, name)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat


def light_material(bpy, reflectance, radiance):
    """Front face: white diffuse + emission of ``radiance``; back face: black (no emission)."""
    mat, nt = _new_material(bpy, "light")
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    front = nt.nodes.new("ShaderNodeMath")
    front.operation = "SUBTRACT"
    front.inputs[0].default_value = 1.0
    nt.links.new(geo.outputs["Backfacing"], front.inputs[1])
    emit = nt.nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (*radiance, 1.0)
    nt.links.new(front.outputs["Value"], emit.inputs["Strength"])
    white = nt.nodes.new("ShaderNodeBsdfDiffuse")
    white.inputs["Color"].default_value = (*reflectance, 1.0)
    white.inputs["Roughness"].default_value = 0.0
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(white.outputs["BSDF"], add.inputs[0])
    nt.links.new(emit.outputs["Emission"], add.inputs[1])
    black = nt.nodes.new("ShaderNodeBsdfDiffuse")
    black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
    nt.links.new(add.outputs["Shader"], mix.inputs[1])
    nt.links.new(black.outputs["BSDF"], mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    mat.cycles.emission_sampling = "FRONT"
    return mat


def build_scene(bpy):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene

    mats = {name: diffuse_material(bpy, name, rgb) for name, rgb in cs.MATERIALS.items()}
    for part in cs.parts():
        verts = to_blender(part.quads.reshape(-1, 3))
        faces = [tuple(range(4 * i, 4 * i + 4)) for i in range(len(part.quads))]
        mesh = bpy.data.meshes.new(part.name)
        mesh.from_pydata([tuple(v) for v in verts], [], faces)
        mesh.validate()
        if part.emission is not None:
            mesh.materials.append(light_material(bpy, cs.MATERIALS[part.material], part.emission))
        else:
            mesh.materials.append(mats[part.material])
        obj = bpy.data.objects.new(part.name, mesh)
        scene.collection.objects.link(obj)
        # Blender quads are planar here; Cycles splits them into two triangles.
        for poly in mesh.polygons:
            poly.use_smooth = False

    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "PERSP"
    cam_data.lens_unit = "FOV"
    cam_data.sensor_fit = "AUTO"  # square image: the angle applies to both axes
    cam_data.angle = math.radians(cs.FOV_DEGREES)
    cam_data.clip_start = 0.001
    cam_data.clip_end = 100.0
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = tuple(to_blender(np.array(cs.CAMERA_ORIGIN)))
    # A Blender camera looks down its local -z with +y up; rotating 90 deg about x makes it look
    # along Blender +y (= spec -z, towards the box) with Blender +z (= spec +y) up.
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("black")
    world.color = (0.0, 0.0, 0.0)
    try:
        world.use_nodes = True
        bg = world.node_tree.nodes.get("Background")
        if bg is not None:
            bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
            bg.inputs["Strength"].default_value = 0.0
    except Exception:
        pass
    scene.world = world

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = cs.WIDTH, cs.HEIGHT, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.threads_mode = "AUTO"
    r.use_persistent_data = False
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
    c.transparent_max_bounces = MAX_BOUNCES
    c.volume_bounces = 0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.use_animated_seed = False
    c.film_exposure = 1.0
    if hasattr(c, "use_auto_tile"):
        c.use_auto_tile = False

    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    vs.use_curve_mapping = False
    return scene


class Timer:
    """Times render_pre -> render_post (excludes the EXR write and Python overhead)."""

    def __init__(self, bpy):
        self.t0 = self.t1 = self.c0 = self.c1 = None
        bpy.app.handlers.render_pre.append(self._pre)
        bpy.app.handlers.render_post.append(self._post)

    def _pre(self, *_):
        self.c0, self.t0 = time.process_time(), time.perf_counter()

    def _post(self, *_):
        self.c1, self.t1 = time.process_time(), time.perf_counter()

    def seconds(self) -> tuple[float, float]:
        """(wall, CPU of all threads) between the two handlers."""
        return self.t1 - self.t0, self.c1 - self.c0


def render(bpy, scene, timer: Timer, spp: int, seed: int, path: Path) -> tuple[float, float]:
    scene.cycles.samples = spp
    scene.cycles.seed = seed
    scene.render.filepath = str(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    wall = time.perf_counter() - wall0
    dt, cpu = timer.seconds()
    if not (0 < dt <= wall):
        raise RuntimeError(f"render handlers gave {dt} s for a {wall} s call")
    return dt, cpu


def check_light_pixels(img: np.ndarray) -> None:
    """Pixels that see the light's front must read its radiance: the EXR is linear radiance.

    The light covers image rows 32..40, columns 106..149 (located in Mitsuba's render). Its
    surface also reflects (white diffuse), which adds about 0.5-1.2 % (measured in Mitsuba), so
    the mean of the interior pixels divided by the emitted radiance must lie in [1.0, 1.03].
    """
    ratio = img[33:40, 108:148].reshape(-1, 3).mean(axis=0) / np.array(cs.LIGHT_RADIANCE)
    if not np.all((ratio > 0.995) & (ratio < 1.03)):
        raise SystemExit(f"cycles: light pixels / emitted radiance = {ratio}, want ~1.005-1.012: "
                         "the EXR is not linear scene radiance (check view transform, exposure, "
                         "emission strength, image orientation)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--spp", default=",".join(map(str, common.DEFAULT_LADDER)),
                    help="spp ladder, comma-separated (default 1,4,16,64,256)")
    ap.add_argument("--seeds", type=int, default=common.DEFAULT_SEEDS,
                    help="images per rung, with seeds spp + 1000 k (time: the fastest)")
    ap.add_argument("--repeats", type=int, default=1,
                    help="time each image this many times (same seed) and keep the fastest")
    ap.add_argument("--out", type=Path, default=common.HERE / "out")
    args = ap.parse_args()
    ladder = common.parse_ladder(args.spp)

    import bpy

    scene = build_scene(bpy)
    timer = Timer(bpy)
    folder = args.out / PEER
    c = scene.cycles
    print(f"blender {bpy.app.version_string}, cycles CPU, threads {scene.render.threads}, "
          f"sampling pattern {c.sampling_pattern}, light tree {getattr(c, 'use_light_tree', '?')}, "
          f"max bounces {c.max_bounces}")

    warm = folder / "warmup.exr"
    dt, _ = render(bpy, scene, timer, 1, 999_983, warm)
    check_light_pixels(common.read_exr(warm))
    warm.unlink()
    print(f"warm-up render (1 spp, not counted): {dt:.2f} s; light pixels read the spec radiance")

    rows = []
    for spp in ladder:
        names, dt, cpu = [], math.inf, math.inf
        for k, seed in enumerate(common.rung_seeds(spp, args.seeds)):
            names.append(common.seeded_exr(PEER, spp, k))
            # Each run writes the EXR itself; only the times are kept.
            _, dt1, cpu1 = common.best_of(
                args.repeats,
                lambda: (None, *render(bpy, scene, timer, spp, seed, folder / names[-1])))
            dt, cpu = min(dt, dt1), min(cpu, cpu1)
        rows.append(common.timing_row(PEER, spp, dt, ";".join(names), cpu))
        common.print_rung(PEER, spp, dt, cpu)
    common.write_timings(folder / "timings.csv", rows)
    print(f"wrote {folder / 'timings.csv'}")


if __name__ == "__main__":
    sys.exit(main())
