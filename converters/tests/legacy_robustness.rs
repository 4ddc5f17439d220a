//! Arbitrary and mutated input never panics the importer: random bytes, and real scenes with
//! tokens deleted, duplicated, swapped for keywords, numbers or junk, or cut short. Whatever
//! imports must export, and whatever exports must import again. (The cargo-fuzz targets in
//! `converters/fuzz/` do the same with coverage guidance.)

mod common;

use std::path::Path;

use lumo_converters::legacy::{self, ImportOptions};
use proptest::prelude::*;

const VOCAB: &[&str] = &[
    "{",
    "}",
    "[",
    "]",
    "Group",
    "numObjects",
    "MaterialIndex",
    "Transform",
    "Matrix4f",
    "Rotate",
    "XRotate",
    "Scale",
    "UniformScale",
    "Translate",
    "Sphere",
    "Plane",
    "Triangle",
    "TriangleMesh",
    "RevSurface",
    "profile",
    "BezierCurve",
    "BsplineCurve",
    "controls",
    "Materials",
    "numMaterials",
    "Material",
    "type",
    "refr",
    "emission",
    "texture",
    "glossy",
    "Lights",
    "numLights",
    "PointLight",
    "DirectionalLight",
    "PerspectiveCamera",
    "DepthCamera",
    "0",
    "1",
    "-1",
    "0.5",
    "1e30",
    "-1e-30",
    "3",
    "4",
    "1000001",
    "nan",
    "#",
    "obj_file",
    "x.obj",
    "",
];

fn scenes() -> Vec<String> {
    let mut files = common::own_legacy_scenes();
    if let Some(dir) = common::shared_dir() {
        files.extend(common::txt_files(&dir.join("legacy-scenes")));
    }
    files
        .iter()
        .map(|f| std::fs::read_to_string(f).expect("scene text"))
        .collect()
}

/// Runs the whole pipeline; panics only on a real bug.
fn exercise(text: &str, base: &Path) {
    let path = base.join("mutant.txt");
    match legacy::import_str(text, &path, &ImportOptions::default()) {
        Ok(imported) => {
            if let Ok(out) = legacy::export(&imported.scene, base) {
                let again = legacy::import_str(&out, &path, &ImportOptions::default());
                assert!(
                    again.is_ok(),
                    "export of an imported mutant does not import: {}\n{out}",
                    again.unwrap_err()
                );
            }
        }
        Err(e) => {
            let report = e.to_string();
            assert!(report.contains("error"), "{report}");
        }
    }
}

#[derive(Debug, Clone)]
enum Edit {
    Delete(usize),
    Duplicate(usize),
    Replace(usize, usize),
    Truncate(usize),
    Junk(usize, String),
}

fn apply(text: &str, edits: &[Edit]) -> String {
    let mut toks: Vec<String> = text.split_whitespace().map(str::to_string).collect();
    for e in edits {
        if toks.is_empty() {
            break;
        }
        let n = toks.len();
        match e {
            Edit::Delete(i) => {
                toks.remove(i % n);
            }
            Edit::Duplicate(i) => {
                let t = toks[i % n].clone();
                toks.insert(i % n, t);
            }
            Edit::Replace(i, w) => toks[i % n] = VOCAB[w % VOCAB.len()].to_string(),
            Edit::Truncate(i) => toks.truncate(i % n),
            Edit::Junk(i, s) => toks[i % n] = s.clone(),
        }
    }
    toks.join(" ")
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        any::<usize>().prop_map(Edit::Delete),
        any::<usize>().prop_map(Edit::Duplicate),
        (any::<usize>(), any::<usize>()).prop_map(|(i, w)| Edit::Replace(i, w)),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), "\\PC{1,8}").prop_map(|(i, s)| Edit::Junk(i, s)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let text = String::from_utf8_lossy(&bytes);
        let dir = std::env::temp_dir();
        exercise(&text, &dir);
        let _ = legacy::parse(&text);
    }

    #[test]
    fn random_keyword_soup_never_panics(words in prop::collection::vec(0usize..VOCAB.len(), 0..200)) {
        let text: Vec<&str> = words.iter().map(|w| VOCAB[*w]).collect();
        exercise(&text.join(" "), &std::env::temp_dir());
    }

    #[test]
    fn mutated_scenes_never_panic(which in any::<usize>(), edits in prop::collection::vec(edit(), 1..6)) {
        let all = scenes();
        let text = &all[which % all.len()];
        let dir = common::workspace_root().join("scenes").join("legacy");
        exercise(&apply(text, &edits), &dir);
    }
}
