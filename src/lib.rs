//! lumo: a physically based renderer.
//!
//! Data flows one way, and so do the modules' imports: any input (scene JSON, legacy text,
//! glTF) is read and validated by [`load()`], with every mesh and image it references
//! ([`assets::Assets`], plain data); [`Loaded::build`] turns it into a [`scene::Scene`] graph
//! ([`scene::build()`], no I/O), which is rendered ([`render::render`]) and written
//! ([`output::write_image`]). The renderer itself only ever sees the scene graph. A
//! [`job::RenderJob`] is one render of a loaded scene with its settings (samples, window,
//! budgets, checkpoints), whose samples make a partial film ([`partial_film`]) that merges with
//! the other parts of the same render; the CLI and the Python package render through it.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let loaded = lumo::load("scenes/cornell.json", &lumo::LoadOptions::default())?;
//! let (scene, _warnings) = loaded.build()?;
//! let (image, _stats) = lumo::render::render(&scene, &Default::default());
//! lumo::output::write_image(&image, "cornell.png".as_ref(), lumo::output::ToneMap::Clamp)?;
//! # Ok(())
//! # }
//! ```

#![warn(missing_docs)]

pub mod alloc;
pub mod aov;
pub mod assets;
pub mod bsdf;
pub mod bvh;
pub mod camera;
pub mod denoise;
pub mod environment;
pub mod geometry;
pub mod hash;
pub mod image;
pub mod integrator;
pub mod job;
pub mod lanes;
pub mod lathe;
pub mod load;

pub use load::{load, LoadOptions, Loaded};
pub mod light;
pub mod light_sampler;
pub mod light_tree;
pub mod lsp;
pub mod material;
pub mod math;
pub mod multilayer;
pub mod output;
pub mod partial_film;
pub mod phases;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;
