//! Every example scene validates against the checked-in JSON Schema (with the independent
//! `jsonschema` validator, so serde and the schema cannot drift apart), loads through serde and
//! the semantic checks, and survives parse → serialise → parse unchanged. Every invalid scene in
//! `tests/invalid/` produces exactly the diagnostics listed in its expectations.

use std::path::{Path, PathBuf};

use lumo_schema::{load_scene_file, parse_scene, to_json, LoadError};
use serde_json::Value;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn schema_validator() -> jsonschema::Validator {
    validator_of("schema/scene.schema.json")
}

fn validator_of(file: &str) -> jsonschema::Validator {
    let text = std::fs::read_to_string(workspace().join(file)).unwrap();
    let schema: Value = serde_json::from_str(&text).unwrap();
    jsonschema::validator_for(&schema).expect("the schema itself is valid")
}

fn json_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            json_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "json") {
            out.push(path);
        }
    }
}

#[test]
fn example_scenes_are_valid_and_round_trip() {
    let validator = schema_validator();
    let fragment_validator = validator_of("schema/scene-fragment.schema.json");
    let mut files = Vec::new();
    json_files(&workspace().join("scenes"), &mut files);
    let mut fragments = 0;
    assert!(
        files.iter().any(|f| f.ends_with("cornell.json")),
        "scenes/cornell.json is missing"
    );
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        let value: Value = serde_json::from_str(&text).unwrap();
        if lumo_schema::include::is_fragment(&text) {
            // A part of scenes (scenes/common/): its own schema and checks.
            fragments += 1;
            let errors: Vec<String> = fragment_validator
                .iter_errors(&value)
                .map(|e| format!("{}: {e}", e.instance_path()))
                .collect();
            assert!(errors.is_empty(), "{}: {errors:#?}", file.display());
            assert!(
                validator.iter_errors(&value).next().is_some(),
                "{}: a fragment should not pass as a whole scene",
                file.display()
            );
            lumo_schema::check_fragment_file(&file).unwrap_or_else(|e| panic!("{e}"));
            continue;
        }
        assert_eq!(
            value["$schema"],
            "../schema/scene.schema.json",
            "{}: every example scene must name the schema for editors",
            file.display()
        );
        let errors: Vec<String> = validator
            .iter_errors(&value)
            .map(|e| format!("{}: {e}", e.instance_path()))
            .collect();
        assert!(
            errors.is_empty(),
            "{} violates the JSON Schema: {errors:#?}",
            file.display()
        );
        let scene = load_scene_file(&file)
            .unwrap_or_else(|e| panic!("{e}"))
            .into_inner();
        let again = parse_scene(&to_json(&scene)).unwrap();
        assert_eq!(
            scene,
            again,
            "{}: parse → serialise → parse changed the scene",
            file.display()
        );
    }
    assert!(fragments >= 2, "scenes/common/ holds the example fragments");
}

#[test]
fn invalid_scenes_report_exactly_the_expected_problems() {
    let dir = workspace().join("tests/invalid");
    let expectations: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expectations.json")).unwrap())
            .unwrap();
    let validator = schema_validator();
    let mut files = Vec::new();
    json_files(&dir, &mut files);
    files.retain(|f| !f.ends_with("expectations.json"));
    assert_eq!(
        files.len(),
        expectations.as_object().unwrap().len(),
        "every invalid scene needs an expectation and vice versa"
    );
    for file in files {
        let name = file.file_name().unwrap().to_str().unwrap();
        let expect = &expectations[name];
        assert!(expect.is_object(), "no expectation for {name}");
        let diagnostics = match load_scene_file(&file) {
            Err(LoadError::Invalid { diagnostics, .. }) => diagnostics,
            other => panic!("{name}: expected an invalid scene, got {other:?}"),
        };
        let wanted = expect["errors"].as_array().unwrap();
        assert_eq!(
            diagnostics.len(),
            wanted.len(),
            "{name}: got {diagnostics:#?}"
        );
        for (d, w) in diagnostics.iter().zip(wanted) {
            assert_eq!(
                d.path.to_string(),
                w["path"].as_str().unwrap(),
                "{name}: {d}"
            );
            assert!(
                d.message.contains(w["contains"].as_str().unwrap()),
                "{name}: message `{}` lacks `{}`",
                d.message,
                w["contains"]
            );
            assert_eq!(
                d.location.map(|l| l.line as u64),
                w["line"].as_u64(),
                "{name}: {d}"
            );
            if let Some(help) = w.get("help") {
                assert_eq!(d.help.as_deref(), help.as_str(), "{name}: {d}");
            }
        }
        // Errors the schema can express must be caught by any editor too.
        if let Ok(value) = serde_json::from_str::<Value>(&std::fs::read_to_string(&file).unwrap()) {
            let schema_level = expect["schema_level"].as_bool().unwrap();
            assert_eq!(
                !validator.is_valid(&value),
                schema_level,
                "{name}: schema-level rejection should be {schema_level}"
            );
        }
    }
}
