"""Render passes and denoising from Python: the CLI's bytes, arrays with the documented shapes
and values, films that keep their passes, and Open Image Denoise through the library."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import lumo
from conftest import CORNELL, ROOT, small

W, H = 32, 24
PASSES = "albedo,normal,depth,position,uv,object_id,material_id,std_error"


def cornell_materials():
    with open(CORNELL) as f:
        scene = json.load(f)
    return scene["materials"], scene["objects"]


@pytest.fixture(scope="module")
def with_passes():
    return lumo.render(lumo.load(CORNELL, small(W, H)), spp=4, seed=5, aov=PASSES)


def test_same_bytes_as_the_cli(tmp_path, run_cli, with_passes):
    size = ["--width", str(W), "--height", str(H)]
    for ext in ("exr", "png"):
        with_passes.write(tmp_path / f"py.{ext}")
        run_cli(
            "render", CORNELL, *size, "--spp", "4", "--seed", "5", "--aov", PASSES,
            "-o", tmp_path / f"cli.{ext}", "-q",
        )
        assert (tmp_path / f"py.{ext}").read_bytes() == (tmp_path / f"cli.{ext}").read_bytes()
    # PNG outputs get each pass as a file beside the image.
    for name in PASSES.split(","):
        py, cli = tmp_path / f"py.{name}.png", tmp_path / f"cli.{name}.png"
        assert py.read_bytes() == cli.read_bytes(), name


def test_shapes_types_and_read_only(with_passes):
    p = with_passes.passes
    assert list(p) == PASSES.split(",")
    shapes = {
        "albedo": (H, W, 3),
        "normal": (H, W, 3),
        "depth": (H, W),
        "position": (H, W, 3),
        "uv": (H, W, 2),
        "object_id": (H, W),
        "material_id": (H, W),
        "std_error": (H, W, 3),
    }
    for name, shape in shapes.items():
        assert p[name].shape == shape, name
        assert p[name].dtype == (np.uint32 if name.endswith("_id") else np.float32), name
        assert not p[name].flags.writeable, name
    # The same arrays on every call, so that reading them twice costs nothing.
    assert with_passes.passes["depth"] is p["depth"]
    np.testing.assert_array_equal(p["std_error"], with_passes.std_error)


def test_values_follow_the_scene(with_passes):
    p = with_passes.passes
    materials, objects = cornell_materials()
    wall = 1 + next(i for i, o in enumerate(objects) if next(iter(o.values())).get("name") == "left wall")
    on_wall = p["object_id"] == wall
    assert on_wall.sum() > 20, "the left wall is in view"
    # A Lambertian wall's albedo is its base colour (the pixels wholly on it).
    inner = on_wall & np.roll(on_wall, 1, 0) & np.roll(on_wall, -1, 0)
    inner &= np.roll(on_wall, 1, 1) & np.roll(on_wall, -1, 1)
    red = np.array(materials["red"]["base_color"], np.float32)
    np.testing.assert_allclose(p["albedo"][inner], np.broadcast_to(red, (inner.sum(), 3)), atol=1e-5)
    # One material id for the whole wall, and unit normals.
    assert len(np.unique(p["material_id"][on_wall])) == 1
    n = np.linalg.norm(p["normal"][inner], axis=-1)
    np.testing.assert_allclose(n, 1.0, atol=1e-4)
    assert (p["depth"][on_wall] > 0).all()


def test_aov_as_a_list_or_string_and_bad_names():
    scene = lumo.load(CORNELL, small(8, 6))
    a = lumo.render(scene, spp=1, aov=["albedo", "depth"]).passes
    b = lumo.render(scene, spp=1, aov="albedo, depth").passes
    assert list(a) == list(b) == ["albedo", "depth"]
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert lumo.render(scene, spp=1).passes == {}
    with pytest.raises(ValueError, match="unknown render pass `albedoo`.*albedo, normal"):
        lumo.render(scene, spp=1, aov="albedoo")
    with pytest.raises(ValueError, match="not one pass name"):
        lumo.render(scene, spp=1, aov=["albedo,depth"])
    with pytest.raises(TypeError, match="aov= takes pass names"):
        lumo.render(scene, spp=1, aov=3)


def test_the_scenes_passes_are_added(tmp_path):
    scene = lumo.load(CORNELL, {**small(8, 6), "render.aov": ["normal"]})
    assert list(lumo.render(scene, spp=1, aov="depth").passes) == ["normal", "depth"]


def test_films_keep_their_passes(tmp_path, with_passes):
    with_passes.film.write(tmp_path / "f.npz")
    film = lumo.Film.read(tmp_path / "f.npz")
    from_film = film.passes()
    assert list(from_film) == list(with_passes.passes)
    for k, v in with_passes.passes.items():
        np.testing.assert_array_equal(from_film[k], v, err_msg=k)


def oidn_dir():
    """OIDN for the test: LUMO_OIDN, else the pyoidn of tests/oidn/.venv (as tests/denoise.rs)."""
    if os.environ.get("LUMO_OIDN"):
        return os.environ["LUMO_OIDN"]
    for p in sorted((ROOT / "tests" / "oidn" / ".venv" / "lib").glob("python*/site-packages/pyoidn")):
        return str(p)
    if os.environ.get("LUMO_REQUIRE_OIDN") == "1":
        pytest.fail("Open Image Denoise not found and LUMO_REQUIRE_OIDN=1")
    pytest.skip("Open Image Denoise not found (tests/oidn/.venv)")


def test_denoised(monkeypatch, tmp_path):
    monkeypatch.setenv("LUMO_OIDN", oidn_dir())
    scene = lumo.load(CORNELL, small(64, 64))
    noisy = lumo.render(scene, spp=8, seed=5, aov="albedo,normal")
    d = noisy.denoised()
    c = noisy.color
    assert d.shape == c.shape and d.dtype == np.float32
    assert np.isfinite(d).all()
    # Much closer to a 64-spp render than the 8-spp image it came from (measured: relMSE
    # 0.028 → 0.007 against a 256-spp one); the lamp, whose edge the filter softens, left out.
    reference = lumo.render(scene, spp=64, seed=99).color
    keep = reference.max(axis=-1) < 2.0

    def rel_mse(x):
        return float(np.mean(((x - reference) ** 2 / (reference**2 + 1e-2))[keep]))

    assert rel_mse(d) < 0.5 * rel_mse(c), (rel_mse(d), rel_mse(c))
    # What lumo render --denoise writes: the denoised beauty, the noisy one as the pass `noisy`.
    noisy.write(tmp_path / "d.exr", denoise=True)
    assert (tmp_path / "d.exr").stat().st_size > 0


def test_denoised_without_the_library_says_how_to_install_it(monkeypatch, tmp_path, with_passes):
    monkeypatch.setenv("LUMO_OIDN", str(tmp_path))
    with pytest.raises(OSError, match="pyoidn"):
        with_passes.denoised()
    with pytest.raises(OSError, match="pyoidn"):
        with_passes.write(tmp_path / "d.exr", denoise=True)
    assert not (tmp_path / "d.exr").exists()
