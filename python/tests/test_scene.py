"""Loading, dicts, overrides, validation, errors with their locations, convert, schema."""

from __future__ import annotations

import json
import re

import pytest

import lumo
from conftest import CORNELL, ROOT, small

INVALID = ROOT / "tests" / "invalid"


def test_module_identity():
    assert re.fullmatch(r"\d+\.\d+\.\d+.*", lumo.__version__)
    assert re.fullmatch(r"sha256:[0-9a-f]{64}", lumo.build_id)
    # The build id is the extension module's file, not the interpreter's.
    import hashlib

    from lumo import _lumo

    with open(_lumo.__file__, "rb") as f:
        assert lumo.build_id == "sha256:" + hashlib.sha256(f.read()).hexdigest()


def test_loads_every_input_kind():
    scene = lumo.load(CORNELL)
    assert (scene.kind, scene.width, scene.height, scene.spp) == ("json", 256, 256, 256)
    assert scene.files == [str(CORNELL)]
    legacy = lumo.load(ROOT / "scenes" / "legacy" / "cornell_box.txt")
    assert legacy.kind == "legacy"
    glb = ROOT / "tests" / "data" / "cycles_env" / "spheres.glb"
    gltf = lumo.load(glb, camera=0)
    assert gltf.kind == "gltf"
    assert gltf.files[0] == str(glb)
    assert isinstance(gltf.warnings, list)
    # A scene with meshes lists the files it read after the input itself.
    bunny = lumo.load(ROOT / "scenes" / "glass_bunny.json")
    assert len(bunny.files) > 1 and bunny.files[0].endswith("glass_bunny.json")


def test_dicts_round_trip():
    scene = lumo.load(CORNELL)
    d = scene.to_dict()
    assert d["materials"]["red"]["base_color"] == pytest.approx([0.570068, 0.0430135, 0.0443706])
    again = lumo.Scene.from_dict(d, base_dir=scene.base_dir)
    assert again.to_dict() == d
    assert again.to_json() == scene.to_json()
    assert again.file == "<dict>"
    # The same content hash: a dict of the scene renders the same pixels.
    assert again.content_hash() == scene.content_hash()


def test_from_dict_reports_every_problem_by_path():
    d = json.loads(CORNELL.read_text())
    d["materials"]["red"]["specular"] = 2
    d["objects"][0]["mesh"]["material"] = "whte"
    with pytest.raises(lumo.SceneError) as e:
        lumo.Scene.from_dict(d, base_dir=ROOT / "scenes")
    paths = [x.path for x in e.value.diagnostics]
    assert paths == ["materials.red.specular", "objects[0].mesh.material"]
    assert e.value.diagnostics[1].help == "did you mean `white`?"
    # A dict has no lines: no made-up ones.
    assert all(x.line is None and x.file == "<dict>" for x in e.value.diagnostics)
    assert isinstance(e.value, ValueError)


def test_overrides_are_applied_and_revalidated():
    scene = lumo.load(CORNELL)
    red = scene.with_overrides({"materials.red.base_color": [0.8, 0.1, 0.1], "render.spp": 4})
    assert red.to_dict()["materials"]["red"]["base_color"] == pytest.approx([0.8, 0.1, 0.1])
    assert red.spp == 4
    assert scene.spp == 256, "the original scene is unchanged"
    assert red.content_hash() != scene.content_hash()
    same = lumo.load(CORNELL, {"materials.red.base_color": [0.8, 0.1, 0.1], "render.spp": 4})
    assert same.to_json() == red.to_json()
    # An element by index, a field left at its default, a new material.
    more = scene.with_overrides(
        {
            "objects[7].mesh.material": "red",
            "render.time_budget_s": 5,
            "materials.blue": {"base_color": [0.1, 0.1, 0.8]},
        }
    )
    d = more.to_dict()
    assert d["objects"][7]["mesh"]["material"] == "red"
    assert "blue" in d["materials"]


@pytest.mark.parametrize(
    "overrides, path, words",
    [
        ({"materials.red.base_colour": [1, 0, 0]}, "materials.red.base_colour", "unknown field"),
        ({"materials.rde.base_color": [1, 0, 0]}, "materials.rde", "names nothing"),
        ({"objects[99].mesh.material": "red"}, "objects[99]", "has 8 elements"),
        ({"render.spp": "many"}, "render.spp", "expected a non-negative integer"),
        ({"render.spp": 0}, "render.spp", ""),
        ({"materials.red.base_color": [2, -1]}, "materials.red.base_color", ""),
        ({"objects[0].mesh.material": "nothing"}, "objects[0].mesh.material", "unknown material"),
        ({"render..spp": 1}, "render", "at character 8"),
    ],
)
def test_bad_overrides_are_scene_errors_with_the_path(overrides, path, words):
    scene = lumo.load(CORNELL)
    with pytest.raises(lumo.SceneError) as e:
        scene.with_overrides(overrides)
    d = e.value.diagnostics
    assert d, str(e.value)
    assert d[0].path == path, d
    assert words in d[0].message
    assert d[0].file == str(CORNELL)
    assert path in str(e.value)
    with pytest.raises(lumo.SceneError):
        lumo.load(CORNELL, overrides)


def test_override_values_must_be_json():
    with pytest.raises(TypeError, match="cannot be written as JSON"):
        lumo.load(CORNELL, {"render.spp": object()})
    with pytest.raises(TypeError, match="mapping"):
        lumo.load(CORNELL).with_overrides([("render.spp", 4)])


def test_scene_errors_carry_locations_and_the_cli_report(run_cli):
    bad = INVALID / "three_mistakes.json"
    with pytest.raises(lumo.SceneError) as e:
        lumo.load(bad)
    d = e.value.diagnostics
    assert [(x.line, x.path) for x in d] == [
        (3, "camera.up"),
        (5, "materials.mix.specular"),
        (8, "objects[0].sphere.radius"),
    ]
    assert all(x.column and x.file == str(bad) and x.help for x in d)
    assert str(d[0]).startswith(f"{bad}:3:{d[0].column}: camera.up: ")
    assert e.value.file == str(bad)
    # str() is the report `lumo validate` prints.
    cli = run_cli("validate", bad, check=False)
    assert cli.returncode == 2
    assert cli.stderr.strip() == "error: " + str(e.value)


def test_missing_files_are_os_errors():
    with pytest.raises(OSError, match="nowhere.json"):
        lumo.load(ROOT / "nowhere.json")


@pytest.mark.parametrize(
    "path", sorted(p.name for p in INVALID.iterdir() if p.name != "expectations.json")
)
def test_validate_every_invalid_file(path):
    expectations = json.loads((INVALID / "expectations.json").read_text())
    diagnostics = lumo.validate(INVALID / path)
    assert diagnostics, f"{path} is invalid but validate() found nothing"
    assert all(isinstance(d, lumo.Diagnostic) and d.message for d in diagnostics)
    for want in expectations.get(path, {}).get("errors", []):
        found = [d for d in diagnostics if d.path == want["path"] or want["path"] == "(root)"]
        assert found, (want, diagnostics)
        assert any(want["contains"] in d.message for d in found), (want, diagnostics)
        if "line" in want:
            assert any(d.line == want["line"] for d in found), (want, diagnostics)


def test_validate_never_raises_on_bad_input(tmp_path):
    assert lumo.validate(CORNELL) == []
    assert lumo.validate(json.loads(CORNELL.read_text()), base_dir=CORNELL.parent) == []
    missing = lumo.validate(tmp_path / "missing.json")
    assert len(missing) == 1 and "missing.json" in missing[0].file
    assert lumo.validate(tmp_path / "scene.yaml")[0].message
    (tmp_path / "binary.json").write_bytes(b"\xff\xfe\x00")
    assert lumo.validate(tmp_path / "binary.json")
    assert lumo.validate({"format_version": 2})  # missing camera, materials, objects
    assert lumo.validate({"x": float("nan")})


def test_convert_round_trips(tmp_path):
    out = tmp_path / "cornell.glb"
    warnings = lumo.convert(CORNELL, out)
    assert isinstance(warnings, list) and out.stat().st_size > 1000
    back = tmp_path / "back.json"
    lumo.convert(out, back)
    scene = lumo.load(back)
    assert scene.kind == "json" and len(scene.to_dict()["objects"]) == 8
    legacy = tmp_path / "legacy.json"
    lumo.convert(ROOT / "scenes" / "legacy" / "textured_sphere.txt", legacy)
    # Paths in the written scene are relative to its folder: it loads from there.
    lumo.load(legacy)
    with pytest.raises(ValueError, match="cannot tell the output format"):
        lumo.convert(CORNELL, tmp_path / "x.yaml")


def test_schema():
    s = lumo.schema()
    assert s["title"] == "lumo scene"
    assert "materials" in s["properties"]
    assert lumo.schema(as_text=True) == (ROOT / "schema" / "scene.schema.json").read_text()


def test_scene_small_helper_renders_what_it_says():
    scene = lumo.load(CORNELL, small(16, 8))
    assert (scene.width, scene.height) == (16, 8)


def test_stubs_match_the_module():
    """The type stubs name the same functions, methods and parameters as the module."""
    import ast
    import inspect

    from lumo import _lumo

    stub = ast.parse((ROOT / "python" / "lumo" / "_lumo.pyi").read_text())

    def params(node):
        a = node.args
        return [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs if x.arg not in ("self", "cls")]

    def runtime_params(obj):
        return [p for p in inspect.signature(obj).parameters if p not in ("self", "cls")]

    checked = 0
    for node in stub.body:
        if isinstance(node, ast.FunctionDef) and not any(
            isinstance(d, ast.Name) and d.id == "overload" for d in node.decorator_list
        ):
            assert params(node) == runtime_params(getattr(_lumo, node.name)), node.name
            checked += 1
        if isinstance(node, ast.ClassDef):
            cls = getattr(_lumo, node.name)
            for item in node.body:
                if not isinstance(item, ast.FunctionDef):
                    continue
                member = getattr(cls, item.name)
                if any(isinstance(d, ast.Name) and d.id == "property" for d in item.decorator_list):
                    assert isinstance(member, property) or not callable(member), item.name
                else:
                    assert params(item) == runtime_params(member), f"{node.name}.{item.name}"
                checked += 1
    assert checked > 50
    public = {n for n in dir(_lumo) if not n.startswith("_")}
    in_stub = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    in_stub |= {n.target.id for n in stub.body if isinstance(n, ast.AnnAssign)}
    assert public | {"__version__"} == in_stub, public ^ in_stub
    assert (ROOT / "python" / "lumo" / "py.typed").is_file()
