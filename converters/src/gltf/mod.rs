//! glTF 2.0 front end: import `.gltf`/`.glb` files as lumo scenes, export lumo scenes as glTF,
//! and read mesh primitives and images for the renderer.
//!
//! - [`import`]: glTF → [`lumo_schema::Scene`]. Meshes are referenced by index
//!   ([`lumo_schema::MeshSource::Gltf`]), not inlined. Nodes whose `extras.lumo` describe an
//!   exact shape (see [`extras`]) import as that shape.
//! - [`export`]: [`lumo_schema::Scene`] → glTF, with lumo's exact description in `extras`, so
//!   scene → glTF → scene is exact.
//! - [`load_mesh_primitive`], [`load_image`]: what the renderer's loader needs.
//!
//! The full mapping is documented in `docs/gltf.md`.

mod document;
mod error;
mod export;
pub mod extras;
mod import;
mod math;
mod mesh;
mod nodes;
mod pbr;
mod tangents;
mod tessellate;

pub use error::GltfError;
pub use export::export;
pub use import::{import, CameraChoice, ImportOptions, Imported, DEFAULT_ENVIRONMENT_WARNING};
pub use lumo_schema::geometry::paths::relative as relative_path;
pub use mesh::{load_image, load_mesh_primitive, GltfFile, MeshData};
pub use pbr::LUMENS_PER_WATT;
pub use tangents::mikktspace as mikktspace_tangents;

/// Imports glTF or GLB bytes held in memory, as if read from `file` (used to resolve relative
/// URIs and in messages). External buffers and images are not read. For fuzzing and tests.
pub fn import_bytes(
    file: &std::path::Path,
    bytes: &[u8],
    options: &ImportOptions,
) -> Result<Imported, GltfError> {
    let loaded = document::Loaded::from_bytes(file, bytes, false)?;
    import::import_loaded(&loaded, options)
}
