//! Helpers shared by the converter tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The workspace root (the parent of this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("crate is inside the workspace")
        .to_path_buf()
}

/// The shared test data folder: `$LUMO_SHARED`, else `../shared` beside the workspace root.
/// When it is missing: panics if `LUMO_REQUIRE_SHARED=1`, otherwise prints a loud SKIPPED
/// message and returns `None`.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("LUMO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => workspace_root().join("..").join("shared"),
    };
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var("LUMO_REQUIRE_SHARED").is_ok_and(|v| v == "1") {
        panic!(
            "shared test data not found at {} (LUMO_REQUIRE_SHARED=1)",
            dir.display()
        );
    }
    eprintln!(
        "SKIPPED: ../shared not found (looked at {}); set LUMO_SHARED",
        dir.display()
    );
    None
}

/// The `.txt` files of a folder, sorted.
pub fn txt_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    v.sort();
    v
}

/// The shared legacy scenes (None when shared data is missing and not required).
pub fn shared_legacy_scenes() -> Option<Vec<PathBuf>> {
    let dir = shared_dir()?.join("legacy-scenes");
    let files = txt_files(&dir);
    assert!(
        files.len() >= 16,
        "expected the 16 shared legacy scenes in {}, found {}",
        dir.display(),
        files.len()
    );
    Some(files)
}

/// Our own example legacy scenes in `scenes/legacy/`.
pub fn own_legacy_scenes() -> Vec<PathBuf> {
    txt_files(&workspace_root().join("scenes").join("legacy"))
}

/// Every glTF sample model file (.gltf and .glb) under shared/gltf, sorted: lumo imports all
/// of them (none requires an extension lumo does not implement).
pub fn sample_files(shared: &Path) -> Vec<PathBuf> {
    files_with_ext(vec![shared.join("gltf")], &["gltf", "glb"])
}

/// Scene JSON files to round-trip through glTF: the workspace's `scenes/` folder (recursively)
/// and this crate's `tests/scenes/`.
pub fn scene_files() -> Vec<PathBuf> {
    files_with_ext(
        vec![
            workspace_root().join("scenes"),
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes"),
        ],
        &["json"],
    )
    .into_iter()
    // Fragments (`scenes/common/`) only complete the scenes that include them, which are here.
    .filter(|f| {
        std::fs::read_to_string(f).map_or(true, |text| !lumo_schema::include::is_fragment(&text))
    })
    .collect()
}

/// Files with one of `exts` under the folders, recursively, sorted.
fn files_with_ext(mut stack: Vec<PathBuf>, exts: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| exts.contains(&e))
            {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Splits a binary glTF into its JSON chunk's text and everything after that chunk (the BIN
/// chunk with its header, if any).
pub fn split_glb(glb: &[u8]) -> (&[u8], &[u8]) {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().expect("a GLB header")) as usize;
    (&glb[20..20 + json_len], &glb[20 + json_len..])
}

/// Where accessor `index`'s first element starts in the buffer (its bufferView's offset plus
/// its own), read from the glTF JSON `doc`.
pub fn accessor_start(doc: &serde_json::Value, index: usize) -> usize {
    let acc = &doc["accessors"][index];
    let view = &doc["bufferViews"][acc["bufferView"].as_u64().expect("a bufferView") as usize];
    view["byteOffset"].as_u64().unwrap_or(0) as usize
        + acc["byteOffset"].as_u64().unwrap_or(0) as usize
}

/// A binary glTF with the JSON chunk `json` (padded with spaces to 4 bytes) followed by `rest`
/// as [`split_glb`] returned it.
pub fn join_glb(json: &str, rest: &[u8]) -> Vec<u8> {
    let mut text = json.to_string();
    while !text.len().is_multiple_of(4) {
        text.push(' ');
    }
    let mut glb = Vec::with_capacity(20 + text.len() + rest.len());
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&((20 + text.len() + rest.len()) as u32).to_le_bytes());
    glb.extend_from_slice(&(text.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(text.as_bytes());
    glb.extend_from_slice(rest);
    glb
}
