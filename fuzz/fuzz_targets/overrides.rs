//! Fuzzes scene overrides (`lumo.load(…, overrides)`, `Scene.with_overrides` in Python, and
//! `--set PATH=JSON`) with arbitrary bytes: every line is an assignment `PATH=JSON`, parsed,
//! applied to a small scene as JSON and read back as a scene, which is then validated. None of
//! it may panic, and:
//! - a path that parses prints (as diagnostics print paths) and parses back to itself;
//! - an override that names nothing leaves the document as it was;
//! - a valid scene read back from overrides serialises and reads back to itself.
//!
//! Seed corpus: `corpus/overrides/`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lumo_schema::overrides::{apply, apply_to_scene, parse_assignment, parse_path};

const SCENE: &str = r#"{
  "format_version": 2,
  "image": {"width": 8, "height": 6},
  "render": {"spp": 2, "seed": 1},
  "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y_deg": 40},
  "textures": {},
  "materials": {
    "red": {"base_color": [0.8, 0.1, 0.1]},
    "light": {"base_color": [1, 1, 1], "emission": [4, 4, 4]}
  },
  "objects": [
    {"sphere": {"center": [0, 0, 0], "radius": 1, "material": "red"}},
    {"plane": {"normal": [0, 1, 0], "offset": -1, "material": "light"}}
  ]
}"#;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = lumo_schema::parse_scene(SCENE) else {
        panic!("the fuzz target's own scene does not parse");
    };
    let mut overrides = Vec::new();
    for line in text.lines().take(16) {
        if let Ok(path) = parse_path(line) {
            let printed = path.to_string();
            match parse_path(&printed) {
                Ok(again) => assert_eq!(again, path, "`{line}` prints as `{printed}`"),
                Err(d) => panic!("`{line}` prints as `{printed}`, which does not parse: {d}"),
            }
        }
        let Ok(o) = parse_assignment(line) else {
            continue;
        };
        let mut doc = serde_json::to_value(&scene).unwrap_or_default();
        let before = doc.clone();
        if apply(&mut doc, &o.path, o.value.clone()).is_err() {
            assert_eq!(doc, before, "a failed override changed the document");
        }
        overrides.push(o);
    }
    if let Ok(changed) = apply_to_scene(&scene, &overrides) {
        if !lumo_schema::validate(&changed, None).is_empty() {
            return;
        }
        let text = lumo_schema::to_json(&changed);
        match lumo_schema::parse_scene(&text) {
            Ok(again) => assert_eq!(again, changed, "a scene does not read back to itself"),
            Err(d) => panic!("a scene read from overrides does not read back: {d}\n{text}"),
        }
    }
});
