//! Converters between lumo's scene description ([`lumo_schema::Scene`]) and other formats.
//!
//! - [`legacy`]: the Tsinghua / MIT 6.837 course ray tracer's text scenes (`.txt`) and the
//!   path-tracing dialects students added to them, in both directions.
//! - [`obj`]: the one Wavefront OBJ reader (geometry through tobj) and the checks the legacy
//!   importer runs on the OBJ files a scene references.
//! - [`gltf`]: glTF 2.0 (`.gltf`, `.glb`) import and export, and the mesh/image loading the
//!   renderer uses for glTF references.
//!
//! This crate depends on `lumo-schema` only, never on the renderer.

#![warn(missing_docs)]

pub mod gltf;
pub mod legacy;
pub mod obj;
