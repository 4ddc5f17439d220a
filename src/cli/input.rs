//! Reading the CLI's input files: the kind is chosen by extension.

use std::path::{Path, PathBuf};

use lumo_converters::gltf::{self, CameraChoice, ImportOptions};
use lumo_converters::legacy;
use lumo_schema as schema;

use super::CliError;

/// A scene read from any supported input, with the folder its relative paths resolve against.
pub struct Input {
    /// The scene description.
    pub scene: schema::Scene,
    /// Folder relative paths in `scene` resolve against.
    pub base_dir: PathBuf,
    /// Non-fatal problems found while reading.
    pub warnings: Vec<String>,
}

/// The kinds of input lumo reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// lumo scene JSON.
    Json,
    /// The course's legacy text scene format (`.txt`), converted on the fly.
    Legacy,
    /// glTF 2.0 (.gltf or .glb).
    Gltf,
}

/// Options for inputs that need them.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Legacy scenes: keep, drop, or decide per scene whether to use the `Lights` block.
    pub lights: legacy::LightsPolicy,
    /// glTF: which camera to use (`--camera NAME|INDEX`).
    pub camera: Option<CameraChoice>,
    /// glTF: the folder the scene's relative paths should be relative to (where a converted
    /// scene file will be written). Default: the glTF file's folder.
    pub scene_dir: Option<PathBuf>,
}

/// The input kind of a path, by extension.
pub fn kind_of(path: &Path) -> Result<InputKind, CliError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "json" => Ok(InputKind::Json),
        "txt" => Ok(InputKind::Legacy),
        "gltf" | "glb" => Ok(InputKind::Gltf),
        _ => Err(CliError::invalid(format!(
            "{}: cannot tell the input kind from the extension `{ext}` (expected .json, .txt, .gltf or .glb)",
            path.display()
        ))),
    }
}

/// Reads and validates a scene from `path`.
pub fn load(path: &Path) -> Result<Input, CliError> {
    load_with(path, &LoadOptions::default())
}

/// Reads and validates a scene from `path` with input-specific options.
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Input, CliError> {
    match kind_of(path)? {
        InputKind::Gltf => {
            let opts = ImportOptions {
                camera: options.camera.clone(),
                scene_dir: options.scene_dir.clone(),
            };
            let imported = gltf::import(path, &opts).map_err(|e| match e {
                gltf::GltfError::Io { .. } => CliError::failure(e.to_string()),
                _ => CliError::invalid(e.to_string()),
            })?;
            let base_dir = match &options.scene_dir {
                Some(d) => d.clone(),
                None => schema::base_dir_of(path),
            };
            let diags = schema::validate(&imported.scene, Some(&base_dir));
            if let Some(d) = diags.first() {
                return Err(CliError::invalid(format!(
                    "{}: the imported scene is not valid: {d}",
                    path.display()
                )));
            }
            Ok(Input {
                scene: imported.scene,
                base_dir,
                warnings: imported.warnings,
            })
        }
        InputKind::Json => {
            let scene = schema::load_scene_file(path).map_err(CliError::from_load)?;
            Ok(Input {
                scene,
                base_dir: schema::base_dir_of(path),
                warnings: Vec::new(),
            })
        }
        InputKind::Legacy => {
            // Paths in the converted scene stay relative to the legacy file's folder.
            let opts = legacy::ImportOptions {
                lights: options.lights,
                output_dir: None,
            };
            let imported = legacy::import(path, &opts).map_err(|e| match e {
                legacy::LegacyError::Io { .. } => CliError::failure(e.to_string()),
                legacy::LegacyError::Invalid { .. } => CliError::invalid(e.to_string()),
            })?;
            // The importer's warnings read `file:line:col: warning: …`; the CLI adds
            // `warning: file:` itself, so keep only `line:col: …`.
            let prefix = format!("{}:", path.display());
            let warnings = imported
                .warnings
                .iter()
                .map(|w| {
                    w.strip_prefix(&prefix)
                        .unwrap_or(w)
                        .replacen(" warning: ", " ", 1)
                        .trim_start()
                        .to_string()
                })
                .collect();
            Ok(Input {
                scene: imported.scene,
                base_dir: schema::base_dir_of(path),
                warnings,
            })
        }
    }
}
