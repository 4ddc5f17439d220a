//! Bad meshes and textures give a clear error naming the file and the element, exit code 2,
//! never a panic.

use assert_cmd::Command;
use std::path::Path;

fn scene_with(dir: &Path, object: &str, textures: &str) -> std::path::PathBuf {
    let text = format!(
        r#"{{
          "format_version": 2,
          "image": {{ "width": 8, "height": 8 }},
          "render": {{ "spp": 1 }},
          "camera": {{ "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40 }},
          "textures": {{ {textures} }},
          "materials": {{ "m": {{ {material} }} }},
          "objects": [ {object} ]
        }}"#,
        material = if textures.is_empty() {
            ""
        } else {
            r#""base_color_texture": { "texture": "t" }"#
        }
    );
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    path
}

fn render(scene: &Path) -> (i32, String) {
    let out = scene.with_file_name("out.png");
    let o = Command::cargo_bin("lumo")
        .unwrap()
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(&out)
        .arg("-q")
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn obj_with_out_of_range_index() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bad.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
    )
    .unwrap();
    let scene = scene_with(
        dir.path(),
        r#"{ "mesh": { "material": "m", "source": { "obj": "bad.obj" } } }"#,
        "",
    );
    let (code, err) = render(&scene);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("bad.obj") && err.contains("objects[0].mesh.source.obj"),
        "{err}"
    );
}

#[test]
fn obj_with_nan_vertex() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("nan.obj"),
        "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let scene = scene_with(
        dir.path(),
        r#"{ "mesh": { "material": "m", "source": { "obj": "nan.obj" } } }"#,
        "",
    );
    let (code, err) = render(&scene);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("nan.obj") && err.contains("vertex 2"), "{err}");
}

#[test]
fn corrupt_and_missing_textures() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("broken.png"),
        b"\x89PNG\r\n\x1a\n this is not a png",
    )
    .unwrap();
    let sphere = r#"{ "sphere": { "material": "m", "radius": 1 } }"#;
    let scene = scene_with(dir.path(), sphere, r#""t": { "file": "broken.png" }"#);
    let (code, err) = render(&scene);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("scene.json: ")
            && err.contains("broken.png")
            && err.contains("cannot decode image")
            && err.contains("textures.t"),
        "{err}"
    );
    let scene = scene_with(dir.path(), sphere, r#""t": { "file": "absent.png" }"#);
    let (code, err) = render(&scene);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("textures.t.file") && err.contains("`absent.png` not found"),
        "{err}"
    );
}

#[test]
fn degenerate_triangles_are_dropped_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("deg.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n",
    )
    .unwrap();
    let scene = scene_with(
        dir.path(),
        r#"{ "mesh": { "material": "m", "source": { "obj": "deg.obj" } } }"#,
        "",
    );
    let (code, err) = render(&scene);
    assert_eq!(code, 0, "{err}");
    assert_eq!(err.matches("degenerate").count(), 1, "{err}");
    assert!(err.contains("dropped 2 degenerate"), "{err}");
}
