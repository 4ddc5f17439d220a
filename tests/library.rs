//! lumo as a library: one `lumo::load` for every input kind, the files it read, and a build
//! that reads nothing.

mod common;

use std::path::{Path, PathBuf};

use lumo::load::{InputKind, LoadError};
use lumo::LoadOptions;

/// The README's five lines, with the sample count lowered for a test.
#[test]
fn loads_renders_and_writes_a_scene_in_five_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cornell.png");
    let mut loaded = lumo::load(
        common::root().join("scenes/cornell.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    loaded.edit(|s| s.render.spp = 4).unwrap();
    let (scene, _warnings) = loaded.build().unwrap();
    let (image, _stats) = lumo::render::render(&scene, &Default::default());
    lumo::output::write_image(&image, &out, lumo::output::ToneMap::Clamp).unwrap();
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (256, 256));
    assert!(image.mean().length() > 0.05, "the Cornell box is not black");
}

fn names(files: &[PathBuf]) -> Vec<String> {
    files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect()
}

/// Every kind of input reports the files it read: the scene, then its meshes and images.
#[test]
fn every_input_kind_lists_the_files_it_read() {
    let root = common::root();
    let json = lumo::load(
        root.join("scenes/glass_bunny.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(json.description.kind, InputKind::Json);
    assert_eq!(names(&json.files()), ["glass_bunny.json", "glass_blob.obj"]);

    let legacy = root.join("scenes/legacy/transformed_mesh.txt");
    let legacy = lumo::load(&legacy, &LoadOptions::default()).unwrap();
    assert_eq!(legacy.description.kind, InputKind::Legacy);
    // Referenced twice, read once.
    assert_eq!(
        names(&legacy.files()),
        ["transformed_mesh.txt", "pyramid.obj"]
    );

    let Some(shared) = common::shared() else {
        return;
    };
    let gltf = shared.join("gltf/BoxTextured/glTF/BoxTextured.gltf");
    let gltf = lumo::load(&gltf, &LoadOptions::default()).unwrap();
    assert_eq!(gltf.description.kind, InputKind::Gltf);
    let mut files = names(&gltf.files());
    files.sort();
    assert_eq!(
        files,
        ["BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"]
    );
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// Building reads no file: the scene builds (and renders the same) after every file it
/// read is gone.
#[test]
fn building_reads_no_file() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&common::root().join("scenes"), dir.path());
    copy_dir(
        &common::root().join("scenes/assets"),
        &dir.path().join("assets"),
    );
    let mut loaded =
        lumo::load(dir.path().join("glass_bunny.json"), &LoadOptions::default()).unwrap();
    loaded
        .edit(|s| {
            s.image.width = 32;
            s.image.height = 32;
            s.render.spp = 2;
        })
        .unwrap();
    let before = lumo::render::render(&loaded.build().unwrap().0, &Default::default()).0;
    for f in loaded.files() {
        std::fs::remove_file(&f).unwrap();
    }
    let after = lumo::render::render(&loaded.build().unwrap().0, &Default::default()).0;
    assert_eq!(before.pixels, after.pixels);
}

/// Overrides are validated like the file: an invalid one is refused, with the file named, and
/// leaves the scene as it was.
#[test]
fn an_invalid_override_is_refused_and_changes_nothing() {
    let path = common::root().join("scenes/cornell.json");
    let mut loaded = lumo::load(&path, &LoadOptions::default()).unwrap();
    let err = loaded.edit(|s| s.camera.fov_y_deg = 200.0).unwrap_err();
    assert!(matches!(err, LoadError::Invalid(_)));
    assert_eq!(err.exit_code(), 2);
    let msg = err.to_string();
    assert!(
        msg.contains("cornell.json") && msg.contains("camera.fov_y_deg"),
        "{msg}"
    );
    assert!((loaded.description.scene.camera.fov_y_deg - 200.0).abs() > 1.0);
}

/// A missing input is an I/O error (exit code 1), an unknown extension invalid input (2).
#[test]
fn load_errors_map_to_exit_codes() {
    let missing = lumo::load("no/such/scene.json", &LoadOptions::default()).unwrap_err();
    assert_eq!(missing.exit_code(), 1, "{missing}");
    let unknown = lumo::load("scene.yaml", &LoadOptions::default()).unwrap_err();
    assert_eq!(unknown.exit_code(), 2, "{unknown}");
    assert!(unknown.to_string().contains(".json, .txt, .gltf or .glb"));
}
