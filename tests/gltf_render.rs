//! Every shared glTF sample model imports through the CLI's input path and renders (tiny)
//! without error or NaN, with its meshes and images read through the glTF loader.

mod common;

use std::path::PathBuf;

use lumo::LoadOptions;

fn samples(shared: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![shared.join("gltf")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Import warnings that would mean a feature of glTF's material model was dropped.
const NOT_MAPPED: [&str; 7] = [
    "normal textures",
    "alphaMode",
    "TEXCOORD_1",
    "wrapS",
    "KHR_materials_",
    "KHR_texture_transform",
    "transmission textures",
];

#[test]
fn every_sample_model_renders_without_error_or_nan() {
    let Some(shared) = common::shared() else {
        return;
    };
    let files = samples(&shared);
    assert!(files.len() >= 20, "only {} sample files", files.len());
    for f in &files {
        let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let mut inp = lumo::load(f, &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        for w in &inp.description.warnings {
            assert!(
                !NOT_MAPPED.iter().any(|feature| w.contains(feature)),
                "{name}: {w}"
            );
        }
        inp.edit(|s| {
            s.image.width = 48;
            s.image.height = 48;
            s.render.spp = 4;
        })
        .unwrap();
        let (scene, _warnings) = inp
            .build()
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let (image, stats) = lumo::render::render(&scene, &lumo::render::RenderOptions::default());
        assert_eq!(stats.nan_samples, 0, "{}: NaN samples", f.display());
        assert!(
            image.pixels.iter().all(|p| p.is_finite()),
            "{}: non-finite pixel",
            f.display()
        );
        // Something is visible: not every pixel is the background.
        let bg = inp.description.scene.background.color;
        let differs = image
            .pixels
            .iter()
            .filter(|p| (p.x - bg[0]).abs() + (p.y - bg[1]).abs() + (p.z - bg[2]).abs() > 1e-3)
            .count();
        assert!(
            differs > 20,
            "{}: only {differs} pixels show the model",
            f.display()
        );
    }
}

#[test]
fn convert_writes_gltf_that_renders_like_the_scene() {
    // scenes/cornell.json → .glb → render: same image as the JSON (the export is exact).
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("cornell.glb");
    assert_cmd::Command::cargo_bin("lumo")
        .unwrap()
        .current_dir(common::root())
        .args(["convert", "scenes/cornell.json", "-o"])
        .arg(&glb)
        .assert()
        .success();
    let json = common::root().join("scenes/cornell.json");
    let mut imgs = Vec::new();
    for f in [&json, &glb] {
        let mut inp = lumo::load(f, &LoadOptions::default()).unwrap();
        inp.edit(|s| {
            s.image.width = 24;
            s.image.height = 24;
            s.render.spp = 2;
        })
        .unwrap();
        let (scene, _) = inp.build().unwrap();
        imgs.push(lumo::render::render(&scene, &lumo::render::RenderOptions::default()).0);
    }
    assert_eq!(imgs[0].pixels, imgs[1].pixels);
}

#[test]
fn cli_converts_gltf_to_json_and_reports_camera_errors() {
    let Some(shared) = common::shared() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("duck.json");
    let lumo = || assert_cmd::Command::cargo_bin("lumo").unwrap();
    lumo()
        .arg("convert")
        .arg(shared.join("gltf/Duck/glTF/Duck.gltf"))
        .arg("-o")
        .arg(&json)
        .assert()
        .success();
    // The written scene references the glTF file relative to its own folder and renders.
    let png = dir.path().join("duck.png");
    lumo()
        .args([
            "render", "--spp", "1", "--width", "16", "--height", "16", "-q", "-o",
        ])
        .arg(&png)
        .arg(&json)
        .assert()
        .success();
    assert!(png.is_file());
    let out = lumo()
        .args(["render", "--camera", "1", "-q", "-o"])
        .arg(dir.path().join("x.png"))
        .arg(shared.join("gltf/Cameras/glTF/Cameras.gltf"))
        .assert()
        .code(2);
    let stderr = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        stderr.contains("cameras[1]") && stderr.contains("orthographic"),
        "{stderr}"
    );
}
