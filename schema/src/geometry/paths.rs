//! Relative paths between a file and a folder, as a scene file or a glTF URI stores them.

use std::path::{Component, Path, PathBuf};

/// Absolute, normalised form of a path (symlinks resolved when the path exists).
pub fn absolute(p: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(p) {
        return c;
    }
    // A path that does not exist yet: canonicalise its parent and append the name.
    if let (Some(parent), Some(name)) = (p.parent(), p.file_name()) {
        let parent = if parent.as_os_str().is_empty() {
            Path::new(".")
        } else {
            parent
        };
        if let Ok(c) = std::fs::canonicalize(parent) {
            return c.join(name);
        }
    }
    std::env::current_dir()
        .map(|d| d.join(p))
        .unwrap_or_else(|_| p.to_path_buf())
}

/// `target` relative to the folder `base` (both made absolute first), with `/` separators:
/// the string a scene file or a glTF URI stores.
pub fn relative(target: &Path, base: &Path) -> String {
    let (t, b) = (absolute(target), absolute(base));
    let tc: Vec<Component> = t.components().collect();
    let bc: Vec<Component> = b.components().collect();
    let common = tc.iter().zip(&bc).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = Vec::new();
    for _ in common..bc.len() {
        parts.push("..".into());
    }
    for c in &tc[common..] {
        parts.push(c.as_os_str().to_string_lossy().into_owned());
    }
    if parts.is_empty() {
        ".".into()
    } else {
        parts.join("/")
    }
}
