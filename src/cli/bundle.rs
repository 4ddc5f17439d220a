//! `lumo bundle`: a scene with every file it reads, in one zip, for machines that share no
//! filesystem (the Dask driver ships it to its workers), and `lumo version`.

use std::io::Write;
use std::path::{Path, PathBuf};

use lumo_schema as schema;

use super::{load_overridden, CliError, SceneOverrides};

/// The scene file at the root of every bundle.
pub const BUNDLE_SCENE: &str = "scene.json";
/// The folder of a bundle that holds the scene's files.
pub const BUNDLE_FILES: &str = "files";

/// `lumo version`: one line of JSON with the version and the build id (the SHA-256 of this
/// executable), which drivers compare across machines before merging their films.
pub fn version_cmd() -> Result<(), CliError> {
    println!(
        "{}",
        serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "build_id": lumo::partial_film::build_id(),
            "lanes": lumo::lanes::default_width(),
            "native_lanes": lumo::lanes::native_width(),
        })
    );
    Ok(())
}

/// The deepest folder holding every path (all absolute).
fn common_root(paths: &[PathBuf]) -> PathBuf {
    let mut root: Option<PathBuf> = None;
    for p in paths {
        let dir = p.parent().unwrap_or(Path::new("/")).to_path_buf();
        root = Some(match root {
            None => dir,
            Some(r) => {
                let mut common = PathBuf::new();
                for (a, b) in r.components().zip(dir.components()) {
                    if a != b {
                        break;
                    }
                    common.push(a.as_os_str());
                }
                common
            }
        });
    }
    root.unwrap_or_else(|| PathBuf::from("/"))
}

/// `lumo bundle`: writes `output` (a zip: `scene.json` with the overrides baked in and its file
/// references rewritten to `files/…`, and the files) and prints one line of JSON: the scene's
/// content hash (the `scene_hash` of every film rendered from the bundle or from the original),
/// its resolution, the number of files and their bytes.
pub fn bundle_cmd(
    scene_path: &Path,
    overrides: &SceneOverrides,
    output: &Path,
) -> Result<(), CliError> {
    if lumo_schema::geometry::paths::lowercase_extension(output) != "zip" {
        return Err(CliError::invalid(format!(
            "{}: a bundle is a zip file; name it *.zip",
            output.display()
        )));
    }
    super::split::check_writable(output, "bundle")?;
    let loaded = load_overridden(scene_path, overrides)?;
    let scene_hash = loaded
        .content_hash()
        .map_err(|e| CliError::failure(e.to_string()))?;
    let base = &loaded.description.base_dir;
    let absolute = |p: &Path| {
        std::path::absolute(base.join(p))
            .map_err(|e| CliError::failure(format!("{}: {e}", p.display())))
    };
    let mut files: Vec<PathBuf> = Vec::new();
    for f in loaded.assets.files() {
        // Already resolved against the scene's folder (relative to the working directory).
        let a = std::path::absolute(f)
            .map_err(|e| CliError::failure(format!("{}: {e}", f.display())))?;
        if !files.contains(&a) {
            files.push(a);
        }
    }
    let mut scene: schema::Scene = (*loaded.description.scene).clone();
    let mut references: Vec<&mut String> = Vec::new();
    for t in scene.textures.values_mut() {
        references.push(&mut t.file);
    }
    for o in &mut scene.objects {
        if let schema::Object::Mesh(m) = o {
            match &mut m.source {
                schema::MeshSource::Obj(f) => references.push(f),
                schema::MeshSource::Gltf(g) => references.push(&mut g.file),
                schema::MeshSource::Inline(_) => {}
            }
        }
    }
    if let Some(image) = &mut scene.background.image {
        references.push(image);
    }
    let mut resolved = Vec::new();
    for r in &references {
        let a = absolute(Path::new(r.as_str()))?;
        if !files.contains(&a) {
            files.push(a.clone());
        }
        resolved.push(a);
    }
    let root = common_root(&files);
    let inside = |a: &Path| -> String {
        let rel = a.strip_prefix(&root).unwrap_or(a);
        let parts: Vec<String> = rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        format!("{BUNDLE_FILES}/{}", parts.join("/"))
    };
    for (r, a) in references.into_iter().zip(&resolved) {
        *r = inside(a);
    }
    let fail = |e: &dyn std::fmt::Display| CliError::failure(format!("{}: {e}", output.display()));
    let dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = lumo::output::temp_file_in(dir).map_err(|e| fail(&e))?;
    let mut zip = zip::ZipWriter::new(std::io::BufWriter::new(tmp));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .compression_level(Some(1))
        .large_file(true);
    zip.start_file(BUNDLE_SCENE, options)
        .map_err(|e| fail(&e))?;
    zip.write_all(schema::to_json(&scene).as_bytes())
        .map_err(|e| fail(&e))?;
    let mut bytes = 0u64;
    for f in &files {
        let data =
            std::fs::read(f).map_err(|e| CliError::failure(format!("{}: {e}", f.display())))?;
        bytes += data.len() as u64;
        zip.start_file(inside(f), options).map_err(|e| fail(&e))?;
        zip.write_all(&data).map_err(|e| fail(&e))?;
    }
    let buffered = zip.finish().map_err(|e| fail(&e))?;
    let tmp = buffered.into_inner().map_err(|e| fail(&e.error()))?;
    tmp.persist(output).map_err(|e| fail(&e.error))?;
    let s = &loaded.description.scene;
    println!(
        "{}",
        serde_json::json!({
            "scene_hash": scene_hash,
            "width": s.image.width,
            "height": s.image.height,
            "files": files.len(),
            "bytes": bytes,
        })
    );
    Ok(())
}
