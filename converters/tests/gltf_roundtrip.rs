//! Round trips: scene → glTF → scene and glTF → scene → glTF → scene are exact, and every
//! exported file passes the Khronos glTF validator.

mod common;

use std::path::{Path, PathBuf};

use lumo_converters::gltf::{export, import, ImportOptions};
use lumo_schema::{load_scene_file, validate, Scene};

fn roundtrip_scene(scene: &Scene, scene_dir: &Path, out: &Path) -> Scene {
    let warnings =
        export(scene, scene_dir, out).unwrap_or_else(|e| panic!("export {}: {e}", out.display()));
    assert!(warnings.is_empty(), "{warnings:?}");
    let imp = import(
        out,
        &ImportOptions {
            camera: None,
            scene_dir: Some(scene_dir.to_path_buf()),
        },
    )
    .unwrap_or_else(|e| panic!("import {}: {e}", out.display()));
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    imp.scene
}

/// Exported files, for the validator test.
fn exported_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gltf-exports");
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn scene_to_gltf_to_scene_is_exact_for_every_scene_file() {
    let files = common::scene_files();
    assert!(
        files.iter().any(|f| f.ends_with("gltf_shapes.json")),
        "test scenes not found: {files:?}"
    );
    let out_dir = exported_dir();
    for f in &files {
        let scene = load_scene_file(f)
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()))
            .into_inner();
        let dir = f.parent().unwrap();
        let stem = f.file_stem().unwrap().to_string_lossy();
        for ext in ["gltf", "glb"] {
            let out = out_dir.join(format!("scene-{stem}.{ext}"));
            let back = roundtrip_scene(&scene, dir, &out);
            assert_eq!(back, scene, "{} via .{ext} is not a fixpoint", f.display());
        }
    }
}

#[test]
fn gltf_to_scene_to_gltf_to_scene_is_exact_for_every_sample() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let out_dir = exported_dir();
    let work = tempfile::tempdir().unwrap();
    for (i, f) in common::sample_files(&shared).iter().enumerate() {
        let opts = ImportOptions {
            camera: None,
            scene_dir: Some(work.path().to_path_buf()),
        };
        let s1 = import(f, &opts).unwrap().scene;
        let stem = f.file_stem().unwrap().to_string_lossy();
        for ext in ["gltf", "glb"] {
            let out = out_dir.join(format!("sample{i}-{stem}.{ext}"));
            let s2 = roundtrip_scene(&s1, work.path(), &out);
            assert_eq!(s2, s1, "{} via .{ext} is not a fixpoint", f.display());
            assert!(validate(&s2, Some(work.path())).is_empty());
        }
    }
}

#[test]
fn textures_round_trip_through_embedded_images() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("tex")).unwrap();
    std::fs::copy(
        shared.join("gltf/TextureTransformTest/glTF/UV.png"),
        dir.path().join("tex/uv.png"),
    )
    .unwrap();
    let text = r#"{"format_version": 2, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40},
      "textures": {"uv": {"file": "tex/uv.png", "wrap_s": "mirror", "wrap_t": "clamp"}, "rough": {"file": "tex/uv.png", "color_space": "linear", "wrap_s": "clamp", "wrap_t": "clamp"},
                   "duck": {"file": "duck.glb", "gltf_image": 0}},
      "materials": {"m": {"base_color_texture": {"texture": "uv", "offset": [0.25, 0.5], "rotation_deg": 30, "scale": [2, 3]},
                          "alpha": 0.5, "alpha_mode": "mask", "alpha_cutoff": 0.3,
                          "normal_texture": {"texture": "rough", "tex_coord": 1}, "normal_scale": 0.5,
                          "metallic_roughness_texture": {"texture": "rough"}, "metallic": 0.5, "roughness": 0.4,
                          "specular": 0.7, "specular_texture": {"texture": "rough"}, "specular_color": [1, 0.5, 0.25],
                          "specular_color_texture": {"texture": "uv"}, "transmission": 0.5, "transmission_texture": {"texture": "rough"},
                          "emission": [2, 1, 0], "emission_texture": {"texture": "duck", "scale": [1, -1]}}},
      "objects": [{"sphere": {"material": "m", "radius": 1}}]}"#;
    std::fs::copy(
        shared.join("gltf/Duck/glTF-Binary/Duck.glb"),
        dir.path().join("duck.glb"),
    )
    .unwrap();
    let scene = lumo_schema::load_scene_str(text, &dir.path().join("t.json"), Some(dir.path()))
        .unwrap()
        .into_inner();
    for ext in ["gltf", "glb"] {
        let out = exported_dir().join(format!("textures.{ext}"));
        let back = roundtrip_scene(&scene, dir.path(), &out);
        assert_eq!(back, scene);
        // Without lumo's extras the glTF values alone give the same texture transform up to
        // rounding (the top-left ↔ bottom-left conversion is right).
        let stripped = strip_extras(&out, dir.path());
        let m = &stripped.materials["m"];
        let r = m.base_color_texture.as_ref().unwrap();
        assert!(
            (r.offset[0] - 0.25).abs() < 1e-5
                && (r.offset[1] - 0.5).abs() < 1e-5
                && (r.rotation_deg - 30.0).abs() < 1e-4,
            "{r:?}"
        );
        assert_eq!(r.scale, [2.0, 3.0]);
        assert!((m.metallic - 0.5).abs() < 1e-6 && (m.emission[0] - 2.0).abs() < 1e-6);
        assert!((m.specular - 0.7).abs() < 1e-6 && m.specular_color == [1.0, 0.5, 0.25]);
        assert!(m.specular_texture.is_some() && m.specular_color_texture.is_some());
        assert!(m.transmission == 0.5 && m.transmission_texture.is_some());
        assert_eq!(
            (m.alpha, m.alpha_mode, m.alpha_cutoff),
            (0.5, lumo_schema::AlphaMode::Mask, 0.3)
        );
        assert_eq!(
            (
                m.normal_texture.as_ref().map(|t| t.tex_coord),
                m.normal_scale
            ),
            (Some(1), 0.5)
        );
        let uv = &stripped.textures["uv"];
        assert_eq!(
            (uv.wrap_s, uv.wrap_t),
            (lumo_schema::Wrap::Mirror, lumo_schema::Wrap::Clamp)
        );
    }
}

/// Imports a .gltf export with every `extras` removed (what lumo reads from a file another tool
/// rewrote), so the glTF values themselves are tested.
fn strip_extras(out: &Path, scene_dir: &Path) -> Scene {
    let stripped = out.with_file_name(format!(
        "stripped-{}",
        out.file_name().unwrap().to_string_lossy()
    ));
    let bytes = std::fs::read(out).unwrap();
    let (json_text, bin) = if bytes.starts_with(b"glTF") {
        let (json, rest) = common::split_glb(&bytes);
        (json, Some(rest))
    } else {
        (&bytes[..], None)
    };
    let mut v: serde_json::Value = serde_json::from_slice(json_text).unwrap();
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.remove("extras");
                m.values_mut().for_each(strip);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut v);
    let text = serde_json::to_string(&v).unwrap();
    let data = match bin {
        Some(rest) => common::join_glb(&text, rest),
        None => text.into_bytes(),
    };
    std::fs::write(&stripped, data).unwrap();
    import(
        &stripped,
        &ImportOptions {
            camera: None,
            scene_dir: Some(scene_dir.to_path_buf()),
        },
    )
    .unwrap()
    .scene
}

#[test]
fn without_extras_the_gltf_values_approximate_the_scene() {
    let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes/gltf_shapes.json");
    let scene = load_scene_file(&f).unwrap().into_inner();
    let out = exported_dir().join("approx.glb");
    export(&scene, f.parent().unwrap(), &out).unwrap();
    let s = strip_extras(&out, f.parent().unwrap());
    // Every object becomes a mesh; lights and camera come back to f32 rounding.
    assert_eq!(s.objects.len(), scene.objects.len());
    assert_eq!(s.lights.len(), scene.lights.len());
    let c = (s.camera, scene.camera);
    for k in 0..3 {
        assert!((c.0.position[k] - c.1.position[k]).abs() < 1e-5);
    }
    let d0 = [0, 1, 2].map(|k| c.0.look_at[k] - c.0.position[k]);
    let d1 = [0, 1, 2].map(|k| c.1.look_at[k] - c.1.position[k]);
    let l1 = d1.iter().map(|x| x * x).sum::<f32>().sqrt();
    for k in 0..3 {
        assert!((d0[k] - d1[k] / l1).abs() < 1e-5, "{d0:?} {d1:?}");
    }
    assert!((c.0.fov_y_deg - c.1.fov_y_deg).abs() < 1e-4);
    for (a, b) in s.lights.iter().zip(&scene.lights) {
        let (a, b) = (
            serde_json::to_value(a).unwrap(),
            serde_json::to_value(b).unwrap(),
        );
        assert_eq!(
            a.as_object().unwrap().keys().collect::<Vec<_>>(),
            b.as_object().unwrap().keys().collect::<Vec<_>>()
        );
    }
    let lamp = &s.materials["lamp"];
    assert!((lamp.emission[0] - 12.5).abs() < 1e-4 && lamp.two_sided_emission);
    let glass = &s.materials["glass"];
    assert!((glass.transmission - 0.95).abs() < 1e-6 && glass.ior == 1.33);
}

/// Runs the Khronos validator (converters/tests/validator, installed with npm) on files.
/// `None` when it is not installed.
fn khronos_validate(files: &[PathBuf]) -> Option<Vec<serde_json::Value>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/validator");
    if !dir.join("node_modules/gltf-validator").is_dir() {
        if std::env::var("LUMO_REQUIRE_SHARED").as_deref() == Ok("1") {
            panic!("the Khronos glTF validator is not installed: run `npm ci --prefix converters/tests/validator` (or npm install)");
        }
        eprintln!("SKIPPED: Khronos glTF validator not installed; run `npm install --prefix converters/tests/validator`");
        return None;
    }
    let out = std::process::Command::new("node")
        .arg(dir.join("validate.js"))
        .args(files)
        .output()
        .expect("node runs");
    assert!(
        out.status.success(),
        "validator failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(
        String::from_utf8(out.stdout)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect(),
    )
}

#[test]
fn exports_pass_the_khronos_validator() {
    // Export everything this test suite round-trips, into a folder of its own.
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gltf-validate");
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for f in common::scene_files() {
        let scene = load_scene_file(&f).unwrap().into_inner();
        for ext in ["gltf", "glb"] {
            let out = dir.join(format!(
                "{}.{ext}",
                f.file_stem().unwrap().to_string_lossy()
            ));
            export(&scene, f.parent().unwrap(), &out).unwrap();
            files.push(out);
        }
    }
    if let Some(shared) = common::shared_dir() {
        for (i, f) in common::sample_files(&shared).iter().enumerate() {
            let s = import(
                f,
                &ImportOptions {
                    camera: None,
                    scene_dir: Some(dir.clone()),
                },
            )
            .unwrap()
            .scene;
            let out = dir.join(format!("sample{i}.glb"));
            export(&s, &dir, &out).unwrap();
            files.push(out);
        }
    }
    let Some(reports) = khronos_validate(&files) else {
        return;
    };
    assert_eq!(reports.len(), files.len());
    let bad: Vec<&serde_json::Value> = reports.iter().filter(|r| r["errors"] != 0).collect();
    assert!(bad.is_empty(), "validator errors: {bad:#?}");
    eprintln!(
        "{} exported files validated with zero errors",
        reports.len()
    );
}

/// The environment (image, strength, rotation, visibility) survives scene → glTF → scene in
/// lumo's extras, its image path rebased to the glTF file's folder and back.
#[test]
fn environment_round_trips_through_extras() {
    let dir = tempfile::tempdir().unwrap();
    // Conversion never decodes the image: any file of the name will do.
    std::fs::write(dir.path().join("sky.hdr"), b"#?RADIANCE\n").unwrap();
    let text = r#"{"format_version": 2, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40},
      "background": {"image": "sky.hdr", "strength": 2.5, "rotation_deg": 30, "visible": false},
      "materials": {"m": {}}, "objects": [{"sphere": {"material": "m", "radius": 1}}]}"#;
    let scene = lumo_schema::load_scene_str(text, &dir.path().join("s.json"), Some(dir.path()))
        .unwrap()
        .into_inner();
    let out_dir = dir.path().join("exported");
    std::fs::create_dir_all(&out_dir).unwrap();
    for ext in ["glb", "gltf"] {
        let back = roundtrip_scene(&scene, dir.path(), &out_dir.join(format!("s.{ext}")));
        assert_eq!(back.background, scene.background, "{ext}");
    }
}
