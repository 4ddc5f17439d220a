"""The reference Cornell box of ``shared/cornell.md``, written out explicitly as triangles.

Both peer scripts use this module: ``cycles_cornell.py`` builds its Blender meshes from it, and
``mitsuba_cornell.py`` checks Mitsuba's built-in ``mi.cornell_box()`` against it (and can render
from it directly with ``--scene explicit``).

Coordinates are the spec's: y up, right-handed, camera at (0, 0, 3.9) looking at the origin.
Every quad is given as four corners ordered so that ``(c1 - c0) x (c2 - c0)`` points to the side
the quad is *seen* from (into the box for walls, out of the boxes, downwards for the light).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# --- Camera and image (cornell.md "Camera and image") -------------------------------------
CAMERA_ORIGIN = (0.0, 0.0, 3.9)
CAMERA_TARGET = (0.0, 0.0, 0.0)
CAMERA_UP = (0.0, 1.0, 0.0)
FOV_DEGREES = 39.3077  # vertical = horizontal, square image
WIDTH = HEIGHT = 256
MAX_DEPTH_MITSUBA = 8  # Mitsuba counting: 1 = emitters only, 2 = direct light, ...

# --- Materials (linear RGB Lambertian reflectance) ----------------------------------------
MATERIALS = {
    "white": (0.885809, 0.698859, 0.666422),
    "red": (0.570068, 0.0430135, 0.0443706),
    "green": (0.105421, 0.37798, 0.076425),
}
LIGHT_RADIANCE = (18.387, 13.9873, 6.75357)


@dataclass(frozen=True)
class Part:
    """One object of the scene: a list of quads (each 4x3 corners), a material, an emission."""

    name: str
    material: str
    quads: np.ndarray  # (n_quads, 4, 3) float64
    emission: tuple[float, float, float] | None = None

    def triangles(self) -> np.ndarray:
        """(2 * n_quads, 3, 3) triangles, fan-split (c0, c1, c2), (c0, c2, c3): same winding."""
        q = self.quads
        return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=0)

    def normals(self) -> np.ndarray:
        """Unit front-side normal of every quad."""
        q = self.quads
        n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
        return n / np.linalg.norm(n, axis=1, keepdims=True)


def _quad(center, u, v) -> np.ndarray:
    """Quad center +- u +- v; its front normal is u x v (see module docstring)."""
    c, u, v = (np.asarray(a, dtype=np.float64) for a in (center, u, v))
    return np.stack([c - u - v, c + u - v, c + u + v, c - u + v])


def _rot_y(degrees: float) -> np.ndarray:
    """Right-handed rotation about +y: maps (1, 0, 0) to (cos t, 0, -sin t) as the spec says."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _box(scale, rot_y_degrees, translate) -> np.ndarray:
    """The cube [-1, 1]^3 with outward-facing quads, transformed p_world = T * R * S * p."""
    x, y, z = np.eye(3)
    faces = []
    for axis, (a, b) in ((x, (y, z)), (y, (z, x)), (z, (x, y))):
        # a x b == axis, so _quad(+axis, a, b) faces +axis and _quad(-axis, b, a) faces -axis.
        faces.append(_quad(axis, a, b))
        faces.append(_quad(-axis, b, a))
    quads = np.stack(faces)  # (6, 4, 3)
    m = _rot_y(rot_y_degrees) @ np.diag(scale)
    return quads @ m.T + np.asarray(translate, dtype=np.float64)


def parts() -> list[Part]:
    """All objects of the reference scene, exactly as tabulated in cornell.md."""
    X, Y, Z = np.eye(3)
    return [
        Part("floor", "white", _quad((0, -1, 0), Z, X)[None]),  # faces +y
        Part("ceiling", "white", _quad((0, 1, 0), X, Z)[None]),  # faces -y
        Part("back", "white", _quad((0, 0, -1), X, Y)[None]),  # faces +z
        Part("left-red", "red", _quad((-1, 0, 0), Y, Z)[None]),  # faces +x
        Part("right-green", "green", _quad((1, 0, 0), Z, Y)[None]),  # faces -x
        Part("small-box", "white", _box((0.3, 0.3, 0.3), -17.0, (0.335, -0.7, 0.38))),
        Part("large-box", "white", _box((0.3, 0.61, 0.3), 18.25, (-0.33, -0.4, -0.28))),
        # x in [-0.23, 0.23], z in [-0.18, 0.20] at y = 0.99, facing -y.
        Part("light", "white", _quad((0, 0.99, 0.01), 0.23 * X, 0.19 * Z)[None], LIGHT_RADIANCE),
    ]


def write_obj(part: Part, path: str) -> None:
    """Writes one part as a Wavefront OBJ (positions and triangles only, 1-based indices)."""
    quads = part.quads
    with open(path, "w", encoding="ascii") as f:
        f.write(f"# {part.name}: generated from shared/cornell.md by cornell_scene.py\n")
        for corner in quads.reshape(-1, 3):
            f.write("v {:.9g} {:.9g} {:.9g}\n".format(*corner))
        for qi in range(len(quads)):
            b = 4 * qi + 1
            f.write(f"f {b} {b + 1} {b + 2}\nf {b} {b + 2} {b + 3}\n")
