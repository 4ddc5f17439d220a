//! Reading the CLI's input files: the kind is chosen by extension.

use std::path::{Path, PathBuf};

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
}

/// The input kind of a path, by extension.
pub fn kind_of(path: &Path) -> Result<InputKind, CliError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "json" => Ok(InputKind::Json),
        _ => Err(CliError::invalid(format!(
            "{}: cannot tell the input kind from the extension `{ext}` (expected .json)",
            path.display()
        ))),
    }
}

/// Reads and validates a scene from `path`.
pub fn load(path: &Path) -> Result<Input, CliError> {
    match kind_of(path)? {
        InputKind::Json => {
            let scene = schema::load_scene_file(path).map_err(CliError::from_load)?;
            Ok(Input { scene, base_dir: schema::base_dir_of(path), warnings: Vec::new() })
        }
    }
}
