//! Helpers shared by the converters' integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The workspace root (the folder above this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the crate lives in the workspace").to_path_buf()
}

/// The shared test-data folder: `$LUMO_SHARED`, else `<workspace root>/../shared`. `None` (after
/// a loud message) when it is missing, unless `LUMO_REQUIRE_SHARED=1`, which makes it a failure.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("LUMO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => workspace_root().join("../shared"),
    };
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var("LUMO_REQUIRE_SHARED").as_deref() == Ok("1") {
        panic!("shared test data not found at {} and LUMO_REQUIRE_SHARED=1", dir.display());
    }
    eprintln!("SKIPPED: ../shared not found (looked for {}); set LUMO_SHARED", dir.display());
    None
}

/// Every sample model file (.gltf and .glb) under shared/gltf, sorted.
pub fn sample_files(shared: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![shared.join("gltf")];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf") | Some("glb")) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Scene JSON files to round-trip: the workspace's `scenes/` folder (recursively) and this
/// crate's `tests/scenes/`.
pub fn scene_files() -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![workspace_root().join("scenes"), Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes")];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().and_then(|e| e.to_str()) == Some("json") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}
