#!/usr/bin/env python3
"""Writes scenes/many_lights.json: a floor and a back wall lit by 300 small emissive quads
(600 triangle lights) of eight colours and intensities, hanging face down at various heights
over the floor or set on the wall, for measuring light selection among many emitters (the
light tree, docs/performance.md). Deterministic: the same file every run.

    python3 scenes/many_lights.py > scenes/many_lights.json

An optional argument takes the first N quads only (all hanging when N ≤ 240), for measuring where
the tree starts to pay (docs/performance.md): `python3 scenes/many_lights.py 4`.
"""
import json
import random
import sys

rng = random.Random(2018)

# (name, colour, strength): colours of different hue and brightness, strengths over 30×.
EMITTERS = [
    ("warm", [1.0, 0.62, 0.28], 40.0),
    ("cold", [0.45, 0.65, 1.0], 25.0),
    ("red", [1.0, 0.12, 0.08], 30.0),
    ("green", [0.2, 1.0, 0.25], 18.0),
    ("white", [1.0, 1.0, 1.0], 60.0),
    ("dim", [1.0, 0.85, 0.7], 6.0),
    ("magenta", [0.9, 0.15, 0.9], 22.0),
    ("bright", [1.0, 0.9, 0.75], 200.0),
]


def r3(v):
    return [round(x, 4) for x in v]


def quad(c, half_u, half_v, u, v):
    """Corners of a quad centred at c spanned by unit vectors u, v (front = u × v)."""
    return [
        r3([c[k] - half_u * u[k] - half_v * v[k] for k in range(3)]),
        r3([c[k] + half_u * u[k] - half_v * v[k] for k in range(3)]),
        r3([c[k] + half_u * u[k] + half_v * v[k] for k in range(3)]),
        r3([c[k] - half_u * u[k] + half_v * v[k] for k in range(3)]),
    ]


meshes = {name: [] for name, _, _ in EMITTERS}
weights = [3, 3, 2, 2, 2, 3, 2, 1]
COUNT = int(sys.argv[1]) if len(sys.argv) > 1 else 300
for i in range(COUNT):
    name = rng.choices([e[0] for e in EMITTERS], weights)[0]
    size = rng.uniform(0.06, 0.16)
    if i < 240:
        # Hanging over the floor, facing down: u = x, v = z, front x × z = −y.
        c = [rng.uniform(-5.5, 5.5), rng.uniform(0.3, 3.0), rng.uniform(-5.5, 4.0)]
        meshes[name].append(quad(c, size, size, [1, 0, 0], [0, 0, 1]))
    else:
        # On the back wall (z = −6), facing +z: u = x, v = y.
        c = [rng.uniform(-5.5, 5.5), rng.uniform(0.3, 3.5), -5.99]
        meshes[name].append(quad(c, size, size, [1, 0, 0], [0, 1, 0]))

materials = {
    "floor": {"base_color": [0.7, 0.7, 0.7], "specular": 0},
    "wall": {"base_color": [0.6, 0.55, 0.5], "specular": 0},
    "ball": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.3},
}
for name, colour, strength in EMITTERS:
    materials["lamp " + name] = {
        "base_color": [0.1, 0.1, 0.1],
        "specular": 0,
        "emission": [round(c * strength / 5, 3) for c in colour],
    }

objects = [
    {"plane": {"material": "floor", "normal": [0, 1, 0], "offset": 0}},
    {"plane": {"material": "wall", "normal": [0, 0, 1], "offset": -6}},
]
for k in range(6):
    objects.append(
        {
            "sphere": {
                "material": "ball",
                "center": [-4.5 + 1.8 * k, 0.5, -2.0 + 1.1 * (k % 3)],
                "radius": 0.5,
            }
        }
    )
for name, quads in meshes.items():
    if not quads:
        continue
    positions, indices = [], []
    for q in quads:
        b = len(positions)
        positions.extend(q)
        # Counter-clockwise seen from the front (u × v).
        indices.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]])
    objects.append(
        {
            "mesh": {
                "name": "lamps " + name,
                "material": "lamp " + name,
                "source": {"inline": {"positions": positions, "indices": indices}},
            }
        }
    )

scene = {
    "$schema": "../schema/scene.schema.json",
    "format_version": 2,
    "image": {"width": 256, "height": 192},
    "render": {"integrator": "path", "spp": 64, "max_depth": 6, "seed": 0},
    "camera": {
        "position": [0, 4.5, 9.5],
        "look_at": [0, 0.6, -1.5],
        "up": [0, 1, 0],
        "fov_y_deg": 45,
    },
    "background": {"color": [0, 0, 0]},
    "materials": materials,
    "objects": objects,
}

# One vertex or triangle per line keeps the file readable and diffable.
text = json.dumps(scene, indent=2)
import re

text = re.sub(r"\[\s+(-?[\d.]+),\s+(-?[\d.]+),\s+(-?[\d.]+)\s+\]", r"[\1, \2, \3]", text)
print(text)
