//! The glTF front end's error type.

use std::path::PathBuf;

/// Everything that can go wrong reading or writing glTF. Every variant names the file and, where
/// there is one, the glTF element (`meshes[2].primitives[0].indices`).
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The file could not be read or written.
    #[error("{}: {action}: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// What we were doing ("cannot read", "cannot write").
        action: &'static str,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file is not valid glTF: broken JSON or GLB framing, or a structural error.
    #[error("{}: {element}: {message}", file.display())]
    Invalid {
        /// The file.
        file: PathBuf,
        /// The glTF element path (`accessors[3]`), or `GLB header`, or `JSON line 4 column 7`.
        element: String,
        /// What is wrong and how to fix it.
        message: String,
    },
    /// The file needs a glTF extension lumo does not implement (`extensionsRequired`).
    #[error("{}: extensionsRequired[{index}]: the file requires the extension `{extension}`, which lumo does not support; re-export it without that extension", file.display())]
    UnsupportedExtension {
        /// The file.
        file: PathBuf,
        /// Index into `extensionsRequired`.
        index: usize,
        /// The extension's name.
        extension: String,
    },
    /// A requested element does not exist (a mesh, primitive, image or camera by index or name).
    #[error("{}: {element}: {message}", file.display())]
    NotFound {
        /// The file.
        file: PathBuf,
        /// The element that was asked for.
        element: String,
        /// What exists instead.
        message: String,
    },
    /// The scene cannot be exported (a missing OBJ file, an unreadable texture...).
    #[error("{}: {element}: {message}", file.display())]
    Export {
        /// The scene folder or file involved.
        file: PathBuf,
        /// The scene element (JSON path like `objects[3]`).
        element: String,
        /// What is wrong.
        message: String,
    },
}

impl GltfError {
    pub(crate) fn invalid(
        file: &std::path::Path,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        GltfError::Invalid {
            file: file.to_path_buf(),
            element: element.into(),
            message: message.into(),
        }
    }
}
