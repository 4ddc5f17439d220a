//! Broken glTF files give clear errors naming the file and the element, never a panic.
//! The broken files are made here from the good samples.

mod common;

use std::path::{Path, PathBuf};

use lumo_converters::gltf::{import, import_bytes, load_mesh_primitive, ImportOptions};
use proptest::prelude::*;

fn copy_model(shared: &Path, model: &str, to: &Path) -> PathBuf {
    let src = shared.join("gltf").join(model);
    for e in std::fs::read_dir(src.parent().unwrap()).unwrap().flatten() {
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
    to.join(src.file_name().unwrap())
}

fn edit_json(file: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(file).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(file, serde_json::to_vec(&v).unwrap()).unwrap();
}

fn import_err(file: &Path) -> String {
    match import(file, &ImportOptions::default()) {
        Ok(_) => panic!("{} imported without error", file.display()),
        Err(e) => e.to_string(),
    }
}

fn assert_names(msg: &str, file: &Path, element: &str) {
    assert!(
        msg.contains(&file.display().to_string()),
        "message does not name the file: {msg}"
    );
    assert!(
        msg.contains(element),
        "message does not name `{element}`: {msg}"
    );
}

#[test]
fn truncated_glb() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(shared.join("gltf/Box/glTF-Binary/Box.glb")).unwrap();
    for cut in [0, 7, 12, 19, 100, 1000, good.len() - 100, good.len() - 1] {
        let f = dir.path().join(format!("cut{cut}.glb"));
        std::fs::write(&f, &good[..cut]).unwrap();
        let msg = import_err(&f);
        assert!(msg.contains(&f.display().to_string()), "{msg}");
        assert!(
            msg.contains("GLB") || msg.contains("JSON") || msg.contains("buffers[0]"),
            "cut at {cut}: {msg}"
        );
    }
}

#[test]
fn glb_header_declaring_a_length_below_its_own_size() {
    // Found by cargo-fuzz: the gltf crate subtracted the header size from this length unchecked.
    let mut bytes = b"glTF".to_vec();
    bytes.extend_from_slice(&2u32.to_le_bytes());
    bytes.extend_from_slice(&4u32.to_le_bytes());
    bytes.extend_from_slice(&[0u8; 64]);
    let f = Path::new("tiny.glb");
    let msg = import_bytes(f, &bytes, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("tiny.glb") && msg.contains("GLB header"),
        "{msg}"
    );
}

#[test]
fn buffer_shorter_than_accessor() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let f = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
    // The NORMAL accessor claims far more vertices than its buffer view holds.
    edit_json(&f, |v| {
        let acc = v["meshes"][0]["primitives"][0]["attributes"]["NORMAL"]
            .as_u64()
            .unwrap() as usize;
        v["accessors"][acc]["count"] = 5000.into();
    });
    let msg = import_err(&f);
    assert_names(&msg, &f, "meshes[0].primitives[0].attributes.NORMAL");
    assert!(msg.contains("shorter than the accessor"), "{msg}");
    let msg = load_mesh_primitive(&f, 0, 0).unwrap_err().to_string();
    assert_names(&msg, &f, "meshes[0].primitives[0].attributes.NORMAL");

    // The .bin file itself is shorter than the buffer's byteLength.
    let f = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
    let bin = dir.path().join("Box0.bin");
    let data = std::fs::read(&bin).unwrap();
    std::fs::write(&bin, &data[..data.len() / 2]).unwrap();
    let msg = import_err(&f);
    assert_names(&msg, &f, "buffers[0]");
    assert!(msg.contains("truncated"), "{msg}");
}

#[test]
fn index_out_of_range() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // A vertex index in the binary data beyond the vertex count.
    let f = copy_model(&shared, "Triangle/glTF/Triangle.gltf", dir.path());
    let bin = dir.path().join("simpleTriangle.bin");
    let mut data = std::fs::read(&bin).unwrap();
    data[2..4].copy_from_slice(&999u16.to_le_bytes()); // second index of the first triangle
    std::fs::write(&bin, &data).unwrap();
    let msg = import_err(&f);
    assert_names(&msg, &f, "meshes[0].primitives[0].indices");
    assert!(msg.contains("999"), "{msg}");
    // An accessor index in the JSON that does not exist.
    let f = copy_model(&shared, "Triangle/glTF/Triangle.gltf", dir.path());
    edit_json(&f, |v| {
        v["meshes"][0]["primitives"][0]["indices"] = 42.into()
    });
    let msg = import_err(&f);
    assert_names(&msg, &f, "meshes[0].primitives[0].indices");
    // A POSITION attribute naming an accessor that does not exist (found by fuzzing: it
    // panicked inside the gltf crate's validation).
    let f = copy_model(&shared, "Triangle/glTF/Triangle.gltf", dir.path());
    edit_json(&f, |v| {
        v["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 43.into()
    });
    let msg = import_err(&f);
    assert_names(&msg, &f, "meshes[0].primitives[0].attributes.POSITION");
    // A mesh/primitive the scene asks for that is not there.
    let f = copy_model(&shared, "Triangle/glTF/Triangle.gltf", dir.path());
    let msg = load_mesh_primitive(&f, 3, 0).unwrap_err().to_string();
    assert_names(&msg, &f, "meshes[3]");
    let msg = load_mesh_primitive(&f, 0, 5).unwrap_err().to_string();
    assert_names(&msg, &f, "meshes[0].primitives[5]");
}

#[test]
fn missing_texture_and_bin() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let f = copy_model(&shared, "BoxTextured/glTF/BoxTextured.gltf", dir.path());
    std::fs::remove_file(dir.path().join("CesiumLogoFlat.png")).unwrap();
    let msg = import_err(&f);
    assert_names(&msg, &f, "images[0].uri");
    assert!(
        msg.contains("CesiumLogoFlat.png") && msg.contains("not found"),
        "{msg}"
    );
    std::fs::remove_file(dir.path().join("BoxTextured0.bin")).unwrap();
    let msg = import_err(&f);
    assert_names(&msg, &f, "buffers[0].uri");
    assert!(msg.contains("BoxTextured0.bin"), "{msg}");
}

#[test]
fn non_finite_matrix() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let f = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
    // 1e39 does not fit an f32: it reads as infinity.
    let text = std::fs::read_to_string(&f).unwrap();
    let patched = text.replacen(
        "\"matrix\": [\n                1.0,",
        "\"matrix\": [\n                1e39,",
        1,
    );
    let patched = if patched == text {
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["nodes"][0]["matrix"][0] = serde_json::json!(1e39);
        serde_json::to_string(&v).unwrap()
    } else {
        patched
    };
    std::fs::write(&f, patched).unwrap();
    let msg = import_err(&f);
    // serde_json reads 1e39 into an f32 as infinity, or (with some of its features, which other
    // crates of the workspace may enable) rejects it as out of range: either way a located error.
    assert!(msg.contains(&f.display().to_string()), "{msg}");
    assert!(
        msg.contains("nodes[0].matrix[0]")
            || (msg.contains("JSON line") && msg.contains("out of range")),
        "{msg}"
    );
    // Finite matrices whose product overflows f32.
    let g = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
    edit_json(&g, |v| {
        v["nodes"][0]["matrix"][0] = serde_json::json!(3e38);
        v["nodes"][1]["matrix"] =
            serde_json::json!([3e38, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    });
    let msg = import_err(&g);
    assert_names(&msg, &g, "nodes[1]");
    assert!(msg.contains("overflows"), "{msg}");
    // A literal NaN is not JSON: the error gives the line and column.
    let f = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
    edit_json(&f, |v| {
        v["nodes"][0]["matrix"][0] = serde_json::json!(12345.5)
    });
    let text = std::fs::read_to_string(&f)
        .unwrap()
        .replacen("12345.5", "NaN", 1);
    std::fs::write(&f, text).unwrap();
    let msg = import_err(&f);
    assert!(msg.contains("JSON line") && msg.contains("column"), "{msg}");
}

#[test]
fn required_extension_we_cannot_honour() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let f = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
    edit_json(&f, |v| {
        v["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
        v["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    });
    let msg = import_err(&f);
    assert_names(&msg, &f, "extensionsRequired[0]");
    assert!(msg.contains("KHR_draco_mesh_compression"), "{msg}");

    // After a required extension lumo implements, the message names the one it does not
    // (ClearCoatCarPaint.glb requires KHR_texture_transform, then KHR_materials_clearcoat).
    edit_json(&f, |v| {
        let both = serde_json::json!(["KHR_texture_transform", "KHR_draco_mesh_compression"]);
        v["extensionsUsed"] = both.clone();
        v["extensionsRequired"] = both;
    });
    let msg = import_err(&f);
    assert_names(&msg, &f, "extensionsRequired[1]");
    assert!(msg.contains("`KHR_draco_mesh_compression`"), "{msg}");
}

/// A file that requires an extension lumo does not implement is refused, naming it (and its
/// index in `extensionsRequired`), even when the gltf crate itself parses that extension.
#[test]
fn files_requiring_unimplemented_extensions_are_refused_by_name() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    for extension in [
        "KHR_materials_iridescence",
        "KHR_materials_pbrSpecularGlossiness",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let f = copy_model(&shared, "Box/glTF/Box.gltf", dir.path());
        edit_json(&f, |v| {
            v["extensionsUsed"] = serde_json::json!(["KHR_texture_transform", extension]);
            v["extensionsRequired"] = serde_json::json!(["KHR_texture_transform", extension]);
        });
        let msg = import_err(&f);
        assert!(
            msg.contains(&format!(
                "extensionsRequired[1]: the file requires the extension `{extension}`"
            )),
            "{msg}"
        );
    }
}

/// No shared sample is refused: every extension they require is implemented.
#[test]
fn every_shared_sample_imports() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let files = common::sample_files(&shared);
    assert!(files.len() >= 30, "{}", files.len());
    for f in files {
        if let Err(e) = import(&f, &ImportOptions::default()) {
            panic!("{}: {e}", f.display());
        }
    }
}

/// Mutated GLB bytes never panic the importer (cargo-fuzz needs nightly; this runs everywhere).
/// Seeds: the shared .glb samples; mutations: byte overwrites, truncations, insertions.
fn glb_seeds() -> Vec<Vec<u8>> {
    let Some(shared) = common::shared_dir() else {
        return Vec::new();
    };
    common::sample_files(&shared)
        .into_iter()
        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("glb"))
        .filter_map(|p| std::fs::read(p).ok())
        .filter(|b| b.len() < 20_000)
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, rng_algorithm: proptest::test_runner::RngAlgorithm::ChaCha, rng_seed: proptest::test_runner::RngSeed::Fixed(0x6c75_6d6f), ..ProptestConfig::default() })]
    #[test]
    fn mutated_glb_never_panics(seed in 0usize..64, edits in proptest::collection::vec((any::<u32>(), any::<u8>(), 0u8..4), 1..12), cut in proptest::option::of(any::<u32>())) {
        let seeds = glb_seeds();
        if seeds.is_empty() {
            return Ok(());
        }
        let mut bytes = seeds[seed % seeds.len()].clone();
        for (pos, val, kind) in edits {
            if bytes.is_empty() { break; }
            // Bias positions towards the header and JSON chunk, where structure lives.
            let p = if kind == 0 { pos as usize % bytes.len().min(64) } else { pos as usize % bytes.len() };
            match kind {
                0 | 1 => bytes[p] = val,
                2 => bytes.insert(p, val),
                _ => { bytes.remove(p); }
            }
        }
        if let Some(c) = cut {
            let n = c as usize % (bytes.len() + 1);
            bytes.truncate(n);
        }
        let _ = import_bytes(Path::new("fuzz.glb"), &bytes, &ImportOptions::default());
    }
}

/// Every number in a JSON value, as a path of keys/indices.
fn number_paths(
    v: &serde_json::Value,
    path: &mut Vec<serde_json::Value>,
    out: &mut Vec<Vec<serde_json::Value>>,
) {
    match v {
        serde_json::Value::Number(_) => out.push(path.clone()),
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                path.push(i.into());
                number_paths(x, path, out);
                path.pop();
            }
        }
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                path.push(k.clone().into());
                number_paths(x, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn at<'a>(v: &'a mut serde_json::Value, path: &[serde_json::Value]) -> &'a mut serde_json::Value {
    path.iter().fold(v, |v, k| match k {
        serde_json::Value::Number(i) => &mut v[i.as_u64().unwrap() as usize],
        serde_json::Value::String(s) => &mut v[s.as_str()],
        _ => unreachable!(),
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 768, failure_persistence: None, rng_algorithm: proptest::test_runner::RngAlgorithm::ChaCha, rng_seed: proptest::test_runner::RngSeed::Fixed(0x6c75_6d6f), ..ProptestConfig::default() })]
    /// Structure-aware mutation: numbers in the GLB's JSON chunk (indices, counts, offsets,
    /// strides, factors) are replaced by hostile values; the binary chunk is kept.
    #[test]
    fn glb_with_hostile_json_numbers_never_panics(seed in 0usize..64, edits in proptest::collection::vec((any::<u32>(), 0usize..10, any::<i32>()), 1..6)) {
        let seeds = glb_seeds();
        if seeds.is_empty() {
            return Ok(());
        }
        let bytes = &seeds[seed % seeds.len()];
        let (json_chunk, rest) = common::split_glb(bytes);
        let mut json: serde_json::Value = serde_json::from_slice(json_chunk).unwrap();
        let mut paths = Vec::new();
        number_paths(&json, &mut Vec::new(), &mut paths);
        for (pick, kind, val) in edits {
            let p = &paths[pick as usize % paths.len()];
            let hostile: serde_json::Value = match kind {
                0 => 0.into(),
                1 => (-1).into(),
                2 => u32::MAX.into(),
                3 => (i32::MAX as i64 + 7).into(),
                4 => 3.into(),
                5 => 1e39.into(),
                6 => (-1e-45).into(),
                7 => (val % 64).into(),
                8 => val.into(),
                _ => 0.5.into(),
            };
            *at(&mut json, p) = hostile;
        }
        let d = common::join_glb(&serde_json::to_string(&json).unwrap(), rest);
        let _ = import_bytes(Path::new("fuzz.glb"), &d, &ImportOptions::default());
    }
}

/// Broken `EXT_mesh_gpu_instancing` attributes give located errors: an accessor index out of
/// range, attributes of different counts, the wrong accessor type, a zero quaternion.
#[test]
fn broken_gpu_instancing() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let bytes = std::fs::read(
        shared
            .join("gltf")
            .join("SimpleInstancing/glTF-Binary/SimpleInstancing.glb"),
    )
    .unwrap();
    let (json, rest) = common::split_glb(&bytes);
    let doc: serde_json::Value = serde_json::from_slice(json).unwrap();
    let attributes = "nodes[0].extensions.EXT_mesh_gpu_instancing.attributes";
    type Edit = fn(&mut serde_json::Value);
    let cases: [(&str, Edit, &str); 5] = [
        (
            "TRANSLATION",
            |v| v["attributes"]["TRANSLATION"] = 99.into(),
            "not an index",
        ),
        (
            "SCALE",
            |v| v["attributes"]["SCALE"] = 1.into(),
            "same count",
        ),
        (
            "TRANSLATION",
            |v| v["attributes"]["TRANSLATION"] = 4.into(),
            "VEC3",
        ),
        (
            "",
            |v| v["attributes"] = serde_json::json!([3, 4]),
            "must be an object",
        ),
        (
            "ROTATION",
            |v| v["attributes"]["ROTATION"] = 1.into(),
            "VEC4",
        ),
    ];
    for (key, edit, says) in cases {
        let mut d = doc.clone();
        edit(&mut d["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]);
        let glb = common::join_glb(&serde_json::to_string(&d).unwrap(), rest);
        let file = Path::new("instancing.glb");
        let msg = match import_bytes(file, &glb, &ImportOptions::default()) {
            Ok(_) => panic!("{key}: imported without error"),
            Err(e) => e.to_string(),
        };
        let element = if key.is_empty() {
            attributes.to_string()
        } else {
            format!("{attributes}.{key}")
        };
        assert_names(&msg, file, &element);
        assert!(msg.contains(says), "{msg}");
    }
    // A zero quaternion: the ROTATION accessor's first value set to (0, 0, 0, 0) in the binary
    // chunk (after the chunk's 8-byte header).
    let at = 8 + common::accessor_start(&doc, 4);
    let mut zeroed = rest.to_vec();
    zeroed[at..at + 16].fill(0);
    let glb = common::join_glb(std::str::from_utf8(json).unwrap().trim_end(), &zeroed);
    let file = Path::new("instancing.glb");
    let msg = import_bytes(file, &glb, &ImportOptions::default())
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert_names(&msg, file, &format!("{attributes}.ROTATION"));
    assert!(msg.contains("instance 0") && msg.contains("zero"), "{msg}");
}
