//! The layout of lumo's data inside glTF `extras`.
//!
//! glTF can only carry triangles and PBR metallic-roughness materials. When lumo exports a scene
//! it writes what glTF can express (tessellated meshes, PBR materials, a camera, punctual lights)
//! **and** lumo's exact description of each element in that element's `extras`, always under
//! the single key `"lumo"`, so other tools keep it untouched and lumo reads the scene back
//! exactly:
//!
//! | glTF element        | `extras.lumo` type  | what it holds |
//! |---------------------|---------------------|---------------|
//! | `scenes[i]`         | [`SceneExtras`]     | image size, render settings, background, `$schema` |
//! | `nodes[i]`          | [`NodeExtras`]      | the exact shape (sphere, plane, lathe, triangle), the original mesh source, the transform as a list of steps, the tessellation used |
//! | `materials[i]`      | [`MaterialExtras`]  | the full lumo [`Material`] |
//! | `textures[i]`       | [`TextureExtras`]   | the full lumo [`Texture`] (original file, colour space) |
//! | `cameras[i]`        | [`CameraExtras`]    | the full lumo [`Camera`] |
//! | `KHR_lights_punctual.lights[i]` | [`LightExtras`] | the full lumo [`Light`] |
//!
//! Example of a lathe node, written by hand or by lumo's exporter:
//!
//! ```json
//! { "name": "vase", "mesh": 3,
//!   "extras": { "lumo": {
//!     "lathe": { "bspline": { "degree": 2, "points": [[0.5, 0], [1, 1], [0.3, 2]] } },
//!     "tessellation": { "segments": 64, "rings": 64 } } } }
//! ```
//!
//! A node with a `sphere`, `plane`, `lathe` or `triangle` imports as that exact object and the
//! node's tessellated mesh is ignored. The importer trusts the other exact descriptions (a
//! material, a camera, a light, a transform) only while they still agree with the glTF data they
//! were written with — if another tool edited the glTF values, the glTF values win.
//!
//! File paths inside extras (`source`, a texture's `file`) are relative to the folder of the
//! glTF file that carries them.

use serde::{Deserialize, Serialize};

use lumo_schema::{
    Background, Camera, Image, Light, Material, MeshSource, Profile, RenderSettings, Texture,
    Transform, Vec3,
};

/// The key under which every lumo extras object lives: `extras = {"lumo": {...}}`.
pub const EXTRAS_KEY: &str = "lumo";

/// `extras` of a glTF element written by lumo: `{"lumo": T}`. Other keys are kept by other tools
/// and ignored by lumo.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LumoExtras<T> {
    /// lumo's data.
    pub lumo: T,
}

/// `scenes[i].extras.lumo`: scene-wide settings glTF has no place for.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SceneExtras {
    /// The scene file's `$schema`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<String>,
    /// Output image size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<Image>,
    /// Render settings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render: Option<RenderSettings>,
    /// Background.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub background: Option<Background>,
}

/// The exact description of a sphere: `nodes[i].extras.lumo.sphere`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SphereShape {
    /// Centre in object space.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

/// The exact description of an infinite plane: `nodes[i].extras.lumo.plane`. The node's mesh is
/// a large square of it (see [`NodeExtras::tessellation`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlaneShape {
    /// Normal (not necessarily unit length).
    pub normal: Vec3,
    /// Signed distance from the origin along the unit normal.
    pub offset: f32,
}

/// How a curved object was tessellated into the node's glTF mesh.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tessellation {
    /// Divisions around the axis (spheres, lathes); for a plane, 1.
    pub segments: u32,
    /// Divisions along the profile (lathes) or from pole to pole (spheres); for a plane, 1.
    pub rings: u32,
    /// For planes: half the side of the exported square, in scene units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_size: Option<f32>,
}

/// `nodes[i].extras.lumo`: the exact description of the object a node stands for.
///
/// At most one of `sphere`, `plane`, `lathe`, `triangle` is present; with one of them the node
/// imports as that object and its mesh is ignored. Lathe vertices are written in three.js
/// `LatheGeometry` order (outer loop around the axis, inner loop along the profile).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct NodeExtras {
    /// A sphere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sphere: Option<SphereShape>,
    /// An infinite plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane: Option<PlaneShape>,
    /// A lathe: the profile revolved about the object's y axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lathe: Option<Profile>,
    /// A single triangle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangle: Option<[Vec3; 3]>,
    /// For meshes: where the mesh came from in the original scene (an OBJ file, a glTF
    /// primitive, or inline arrays). File paths are relative to this glTF file's folder. The
    /// importer uses it when the referenced file still exists, otherwise the node's own mesh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<MeshSource>,
    /// The tessellation used for the node's mesh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tessellation: Option<Tessellation>,
    /// The object's placement as lumo steps. Used when it composes to the node's glTF world
    /// transform (or, for transforms glTF cannot express, when the mesh was baked in world space
    /// and the node has none); absent when the node's matrix says the same.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<Transform>,
    /// True when the transform was baked into the mesh's vertices because it is not a
    /// translation · rotation · scale (it shears), which glTF nodes cannot express.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub baked: bool,
}

/// `materials[i].extras.lumo`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialExtras {
    /// The exact lumo material.
    pub material: Material,
}

/// `textures[i].extras.lumo`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextureExtras {
    /// The exact lumo texture; its `file` is relative to the glTF file's folder.
    pub texture: Texture,
}

/// `cameras[i].extras.lumo`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraExtras {
    /// The exact lumo camera (world space).
    pub camera: Camera,
}

/// `extensions.KHR_lights_punctual.lights[i].extras.lumo`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LightExtras {
    /// The exact lumo light (world space).
    pub light: Light,
}
