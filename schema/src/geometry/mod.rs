//! Geometry over the scene types, in f64: the one implementation that the converters and the
//! renderer share.
//!
//! - [`profile`]: lathe profile curves (parameter range, point and derivative).
//! - [`transform`]: transform steps as one matrix, Rodrigues' rotation.
//! - [`tessellate`]: triangle meshes of spheres, planes and lathes.
//! - [`bounds`]: true world-space bounds of every object kind.
//! - [`normals`]: angle-weighted vertex normals.
//! - [`paths`]: relative paths between files and folders, as scene files store them.

pub mod bounds;
pub mod normals;
pub mod paths;
pub mod profile;
pub mod tessellate;
pub mod transform;

pub use glam;
