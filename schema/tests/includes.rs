//! Scenes that include fragments: merging, paths relative to the fragment, and every problem
//! placed in the file that wrote it, with the includes that brought that file in.

use std::path::{Path, PathBuf};

use lumo_schema::{load_scene_file, load_scene_file_with_fragments, LoadError, Object, Report};

/// A fresh folder under the target directory with the given files.
fn folder(name: &str, files: &[(&str, &str)]) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("includes_{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    for (file, text) in files {
        let path = dir.join(file);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    dir
}

const SCENE_HEAD: &str = r#"{
  "format_version": 2,
  "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y_deg": 40},
  "include": ["lib/materials.json", "rig.json"],
"#;

/// The report `lumo validate` prints for the scene at `path`.
fn report(path: &Path) -> String {
    match load_scene_file(path) {
        Err(LoadError::Invalid { file, diagnostics }) => Report { file, diagnostics }.to_string(),
        other => panic!("expected problems, got {other:?}"),
    }
}

#[test]
fn the_example_scene_composes_its_fragments() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let (scene, _, fragments) =
        load_scene_file_with_fragments(&scenes.join("studio.json")).unwrap();
    assert_eq!(
        fragments,
        [
            scenes.join("common/materials.json"),
            scenes.join("common/light_rig.json")
        ]
    );
    // The including file wins: its copper `gold` replaces the fragment's.
    assert_eq!(scene.materials["gold"].base_color, [0.95, 0.64, 0.54]);
    assert!(scene.materials.contains_key("softbox") && scene.materials.contains_key("glass"));
    // Paths in a fragment are relative to the fragment (`../textures/…` from `common/`),
    // written relative to the scene's folder.
    assert_eq!(scene.textures["glaze"].file, "textures/vase_glaze.png");
    // Included objects come first, in include order, then the scene's own.
    let names: Vec<_> = scene.objects.iter().map(Object::name).collect();
    assert_eq!(
        names,
        [
            Some("key softbox"),
            Some("floor"),
            Some("glazed ball"),
            Some("copper ball"),
            Some("glass ball")
        ]
    );
    assert_eq!(scene.lights.len(), 2);
}

#[test]
fn problems_in_fragments_are_placed_there_with_the_includes() {
    let dir = folder(
        "placed",
        &[
            (
                "scene.json",
                &format!("{SCENE_HEAD}  \"materials\": {{}},\n  \"objects\": [{{\"sphere\": {{\"center\": [0, 0, 0], \"radius\": 1, \"material\": \"red\"}}}}]\n}}\n"),
            ),
            (
                "lib/materials.json",
                "{\n  \"include\": [\"more.json\"],\n  \"materials\": {\"red\": {\"base_color\": [0.8, 0.1, 0.1], \"roughness\": \"low\"}}\n}\n",
            ),
            (
                "lib/more.json",
                "{\n  \"textures\": {\"wood\": {\"file\": \"wood.png\"}}\n}\n",
            ),
            (
                "rig.json",
                "{\n  \"lights\": [{\"point\": {\"position\": [0, 2, 0], \"intensity\": [-1, 1, 1]}}]\n}\n",
            ),
        ],
    );
    let text = report(&dir.join("scene.json"));
    let lib = dir.join("lib/materials.json");
    let scene = dir.join("scene.json");
    // A wrong type in a fragment, included from scene.json line 4 column 15.
    assert!(
        text.contains(&format!(
            "  {}:3:69: materials.red.roughness: expected a number, found a string \"low\"\n    included from {}:4:15\n",
            lib.display(),
            scene.display()
        )),
        "{text}"
    );
    // Two levels down: a missing texture in lib/more.json, its path relative to lib/.
    assert!(
        text.contains(&format!(
            "{}:2:33: textures.wood.file:",
            dir.join("lib/more.json").display()
        )) && text.contains(&format!(
            "    included from {}:2:15\n    included from {}:4:15\n",
            lib.display(),
            scene.display()
        )),
        "{text}"
    );
    // A value out of range in a list item of another fragment: its index in that file.
    assert!(
        text.contains(&format!(
            "{}:2:61: lights[0].point.intensity",
            dir.join("rig.json").display()
        )),
        "{text}"
    );
}

#[test]
fn keys_defined_twice_cycles_and_missing_files_are_refused() {
    let fragment = |color: &str| {
        format!("{{\"materials\": {{\"red\": {{\"base_color\": {color}}}}}, \"render\": {{\"spp\": 4}}}}")
    };
    let objects = "\"objects\": [{\"sphere\": {\"center\": [0, 0, 0], \"radius\": 1, \"material\": \"red\"}}]";
    let a = fragment("[1, 0, 0]");
    let b = fragment("[0.9, 0, 0]");
    let twice = folder(
        "twice",
        &[
            (
                "scene.json",
                &format!("{SCENE_HEAD}  \"materials\": {{}},\n  {objects}\n}}"),
            ),
            ("lib/materials.json", &a),
            ("rig.json", &b),
        ],
    );
    let text = report(&twice.join("scene.json"));
    assert!(
        text.contains("materials.red: `materials.red` is also defined in")
            && text.contains("render: `render` is also defined in")
            && text.contains("define it in one included file only, or in the including file"),
        "{text}"
    );
    // The including file defines both: it wins, and the scene is valid.
    let resolved = folder(
        "resolved",
        &[
            (
                "scene.json",
                &format!("{SCENE_HEAD}  \"render\": {{\"spp\": 2}},\n  \"materials\": {{\"red\": {{\"base_color\": [0.5, 0, 0]}}}},\n  {objects}\n}}"),
            ),
            ("lib/materials.json", &a),
            ("rig.json", &b),
        ],
    );
    let scene = load_scene_file(&resolved.join("scene.json")).unwrap();
    assert_eq!(scene.render.spp, 2);
    assert_eq!(scene.materials["red"].base_color, [0.5, 0.0, 0.0]);

    let cycle = folder(
        "cycle",
        &[
            (
                "scene.json",
                &format!("{SCENE_HEAD}  \"materials\": {{}},\n  \"objects\": []\n}}"),
            ),
            ("lib/materials.json", "{\"include\": [\"../rig.json\"]}"),
            ("rig.json", "{\"include\": [\"lib/materials.json\"]}"),
        ],
    );
    let text = report(&cycle.join("scene.json"));
    assert!(
        text.contains("include[0]: this include makes a cycle:") && text.contains("rig.json"),
        "{text}"
    );

    let missing = folder(
        "missing",
        &[(
            "scene.json",
            &format!("{SCENE_HEAD}  \"materials\": {{}},\n  \"objects\": []\n}}"),
        )],
    );
    let text = report(&missing.join("scene.json"));
    let scene = missing.join("scene.json");
    assert!(
        text.contains(&format!(
            "{}:4:15: include[0]: cannot read the included file",
            scene.display()
        )) && text.contains(&format!("{}:4:37: include[1]:", scene.display())),
        "{text}"
    );
}
