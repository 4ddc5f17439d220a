//! lumo: a physically based renderer.
//!
//! Data flows one way: a scene description (crate `lumo-schema`) is validated, turned into a
//! [`scene::Scene`] graph ([`scene::build`]), rendered ([`render::render`]) and written
//! ([`output::write_image`]). The renderer itself only ever sees the scene graph.

#![warn(missing_docs)]

pub mod bsdf;
pub mod bvh;
pub mod camera;
pub mod geometry;
pub mod image;
pub mod integrator;
pub mod lathe;
pub mod load;

pub use load::{load, LoadOptions, Loaded};
pub mod light;
pub mod material;
pub mod math;
pub mod output;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;
