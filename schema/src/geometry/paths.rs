//! Relative paths between a file and a folder, as a scene file or a glTF URI stores them.
//!
//! One pair, one argument order: [`relative`]`(target, base)` is `target` seen from the folder
//! `base`. Edge cases:
//! - Both sides are made [`absolute`] first, with symbolic links resolved on the part that
//!   exists, so a link or a `..` through a link does not produce a wrong path.
//! - The same folder gives `"."`.
//! - No common root (different drives or UNC shares on Windows) gives `target`'s absolute
//!   path, since no relative path exists.
//! - Components after the existing part are kept as written (a `..` there is not collapsed,
//!   because what it means depends on links that do not exist yet).

use std::path::{Component, Path, PathBuf};

/// A path's extension in lower case (`""` when it has none or it is not UTF-8): how every
/// input and output format is told apart.
pub fn lowercase_extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// The absolute path with symbolic links resolved. For a path that does not exist yet (an
/// output folder about to be created), its nearest existing ancestor is resolved and the rest
/// appended, so that both sides of [`relative`] are comparable.
pub fn absolute(p: &Path) -> PathBuf {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut existing = abs.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(real) = existing.canonicalize() {
            let mut out = real;
            for part in rest.iter().rev() {
                out.push(part);
            }
            return out;
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                existing = parent;
            }
            _ => return abs,
        }
    }
}

/// `target` relative to the folder `base` (both made [`absolute`] first), with `/`
/// separators: the string a scene file or a glTF URI stores. See the module docs for the edge
/// cases.
pub fn relative(target: &Path, base: &Path) -> String {
    let (t, b) = (absolute(target), absolute(base));
    let tc: Vec<Component> = t.components().collect();
    let bc: Vec<Component> = b.components().collect();
    let common = tc.iter().zip(&bc).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return t.display().to_string();
    }
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

/// How many folders above the output's folder a path a scene file stores may climb (with
/// `..`) before [`portable`] writes it absolute.
pub const MAX_CLIMB: usize = 2;

/// `target` as a scene file in the folder `base` stores it, so that the file reads it wherever
/// it is used: relative (as [`relative`]) when `target` lies under `base` or under a near
/// ancestor (at most [`MAX_CLIMB`] `..`), so that the folder moves together with its assets;
/// otherwise `target`'s absolute path, never a relative one that climbs to the filesystem's
/// root (`../../work/…` from `/tmp/out`, which breaks as soon as either side moves).
pub fn portable(target: &Path, base: &Path) -> String {
    let (t, b) = (absolute(target), absolute(base));
    let tc: Vec<Component> = t.components().collect();
    let bc: Vec<Component> = b.components().collect();
    let common = tc.iter().zip(&bc).take_while(|(x, y)| x == y).count();
    // The root itself (`/`, or `C:` and `\\`) is no ancestor to share.
    let roots = bc
        .iter()
        .take_while(|c| matches!(c, Component::Prefix(_) | Component::RootDir))
        .count();
    if common <= roots || bc.len() - common > MAX_CLIMB {
        return t.display().to_string();
    }
    relative(&t, &b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_and_their_edge_cases() {
        let dir = std::env::temp_dir().join(format!("lumo-paths-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("a/b")).unwrap();
        let file = dir.join("a/b/m.obj");
        assert_eq!(relative(&file, &dir), "a/b/m.obj");
        assert_eq!(
            relative(&dir.join("x.bin"), &dir.join("a/b")),
            "../../x.bin"
        );
        assert_eq!(relative(&dir, &dir), ".");
        // Folders that do not exist yet still compare with existing ones.
        assert_eq!(relative(&file, &dir.join("new/out")), "../../a/b/m.obj");
        // Through `..` the existing part is resolved.
        assert_eq!(relative(&dir.join("a/../a/b/m.obj"), &dir), "a/b/m.obj");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn portable_paths_are_relative_nearby_and_absolute_far_away() {
        let dir =
            absolute(&std::env::temp_dir().join(format!("lumo-portable-{}", std::process::id())));
        std::fs::create_dir_all(dir.join("a/b/c")).unwrap();
        let asset = dir.join("assets/t.png");
        // Under the output's folder, or up to two folders above it: relative.
        assert_eq!(portable(&asset, &dir), "assets/t.png");
        assert_eq!(portable(&asset, &dir.join("a")), "../assets/t.png");
        assert_eq!(portable(&asset, &dir.join("a/b")), "../../assets/t.png");
        // Further: absolute.
        assert_eq!(
            portable(&asset, &dir.join("a/b/c")),
            asset.display().to_string()
        );
        // Sharing only the filesystem's root: absolute, never `../../…` up to it.
        let far = Path::new("/lumo-nowhere/assets/t.png");
        assert_eq!(portable(far, &dir), far.display().to_string());
        assert!(!portable(far, Path::new("/lumo-x")).starts_with(".."));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
