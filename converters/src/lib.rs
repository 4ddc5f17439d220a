//! Converters between lumo's scene description ([`lumo_schema::Scene`]) and other formats.
//!
//! - [`gltf`]: glTF 2.0 (`.gltf`, `.glb`) import and export.

pub mod gltf;
