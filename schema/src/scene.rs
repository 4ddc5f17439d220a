//! The scene description: plain serde data, one type per concept.
//!
//! Conventions used by every type here:
//! - Right-handed coordinates, y up. Lengths are in scene units (arbitrary but consistent).
//! - Colours are linear RGB triples. Reflectances and weights are unitless fractions in [0, 1];
//!   radiance is in W·sr⁻¹·m⁻² per channel.
//! - Angles are in degrees.
//! - File paths are resolved relative to the folder of the scene file.
//! - Every struct rejects unknown keys, so a typo is an error instead of a silently ignored key.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A three-component vector (x, y, z) in scene units.
pub type Vec3 = [f32; 3];
/// A two-component vector.
pub type Vec2 = [f32; 2];
/// A linear RGB colour.
pub type Rgb = [f32; 3];

/// The format version this crate reads and writes.
pub const FORMAT_VERSION: u32 = 2;

/// A complete lumo scene: what to render and how.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Path or URL of the JSON Schema this file follows, for editors
    /// (`"../schema/scene.schema.json"` in lumo's examples). Not used by the renderer.
    #[serde(rename = "$schema", default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<String>,
    /// Version of the scene format: 2. Files of version 1 (lobe-weight materials) are still
    /// read, migrated on load with a warning; `lumo convert old.json -o new.json` upgrades them.
    #[schemars(range(min = 1, max = 2))]
    pub format_version: u32,
    /// Output image size.
    #[serde(default)]
    pub image: Image,
    /// How the image is computed.
    #[serde(default)]
    pub render: RenderSettings,
    /// The viewpoint.
    pub camera: Camera,
    /// The environment: what a ray that leaves the scene sees, and a light. Default: black.
    #[serde(default)]
    pub background: Background,
    /// Image textures by name, referenced by materials.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub textures: BTreeMap<String, Texture>,
    /// Materials by name, referenced by objects.
    pub materials: BTreeMap<String, Material>,
    /// The geometry.
    pub objects: Vec<Object>,
    /// Punctual lights. Emissive materials are lights too (area lights).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<Light>,
}

/// Output image size in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Image {
    /// Width in pixels. Default 512.
    #[serde(default = "default_image_side")]
    #[schemars(range(min = 1, max = 16384))]
    pub width: u32,
    /// Height in pixels. Default 512.
    #[serde(default = "default_image_side")]
    #[schemars(range(min = 1, max = 16384))]
    pub height: u32,
}

fn default_image_side() -> u32 {
    512
}

impl Default for Image {
    fn default() -> Self {
        Image {
            width: default_image_side(),
            height: default_image_side(),
        }
    }
}

/// The light-transport algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// Unidirectional path tracing with next-event estimation and multiple importance sampling.
    #[default]
    Path,
    /// Fast preview: primary rays, direct light from punctual lights and emitters,
    /// mirror and refraction up to `max_depth`.
    Raycast,
}

/// The sequence of sample points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SamplerKind {
    /// Owen-scrambled Sobol points: lower error at equal sample counts.
    #[default]
    Sobol,
    /// Independent uniform random numbers (for comparison).
    Independent,
}

/// A render pass written besides the beauty (docs/passes.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RenderPass {
    /// Albedo at the first non-delta hit (`albedo.R/G/B`).
    Albedo,
    /// World-space shading normal at the first non-delta hit (`normal.X/Y/Z`).
    Normal,
    /// Distance along the camera ray to its first hit (`depth.Z`).
    Depth,
    /// World-space position of the camera ray's first hit (`position.X/Y/Z`).
    Position,
    /// Texture coordinates there (`uv.U/V`).
    Uv,
    /// Index + 1 of the object the pixel's first sample hit (`object_id.I`).
    ObjectId,
    /// Index + 1 of its material, materials sorted by name (`material_id.I`).
    MaterialId,
    /// Standard error of the beauty (`std_error.R/G/B`).
    StdError,
}

impl RenderPass {
    /// Its name in scene files and on the command line (`object_id`).
    pub fn name(self) -> &'static str {
        match self {
            RenderPass::Albedo => "albedo",
            RenderPass::Normal => "normal",
            RenderPass::Depth => "depth",
            RenderPass::Position => "position",
            RenderPass::Uv => "uv",
            RenderPass::ObjectId => "object_id",
            RenderPass::MaterialId => "material_id",
            RenderPass::StdError => "std_error",
        }
    }
}

/// How the image is computed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderSettings {
    /// The light-transport algorithm. Default `path`.
    #[serde(default)]
    pub integrator: Integrator,
    /// The sequence of sample points. Default `sobol`.
    #[serde(default, skip_serializing_if = "is_default_sampler")]
    pub sampler: SamplerKind,
    /// Samples per pixel. Default 64.
    #[serde(default = "default_spp")]
    #[schemars(range(min = 1))]
    pub spp: u32,
    /// Maximum path depth, counted as Mitsuba does: 1 = only emitters seen directly,
    /// 2 = direct illumination, n = up to n − 1 bounces after the camera ray. Default 8.
    #[serde(default = "default_max_depth")]
    #[schemars(range(min = 1, max = 1024))]
    pub max_depth: u32,
    /// Seed of the random sequences. The same scene and seed give the same image,
    /// whatever the thread count. Default 0.
    #[serde(default)]
    pub seed: u64,
    /// Optional wall-clock budget in seconds: samples are taken in progressive passes of
    /// doubling size until the budget is spent or `spp` samples are reached, whichever comes
    /// first (the pass that crosses the budget is finished).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub time_budget_s: Option<f32>,
    /// Render passes to write besides the beauty: channels of the EXR's one part, or PNGs
    /// beside a PNG (`lumo render --aov` adds to them). Default none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aov: Vec<RenderPass>,
}

fn is_default_sampler(s: &SamplerKind) -> bool {
    *s == SamplerKind::Sobol
}

fn default_spp() -> u32 {
    64
}
fn default_max_depth() -> u32 {
    8
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            integrator: Integrator::default(),
            sampler: SamplerKind::default(),
            spp: default_spp(),
            max_depth: default_max_depth(),
            seed: 0,
            time_budget_s: None,
            aov: Vec::new(),
        }
    }
}

/// A perspective camera: a pinhole, or a thin lens when `aperture_radius` > 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Position of the eye (the lens centre).
    pub position: Vec3,
    /// A point the camera looks at; the view direction is `look_at − position`.
    pub look_at: Vec3,
    /// Approximate up direction; it is re-orthogonalised against the view direction.
    /// Default (0, 1, 0).
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Full vertical field of view in degrees, in (0, 180).
    #[schemars(extend("exclusiveMinimum" = 0, "exclusiveMaximum" = 180))]
    pub fov_y_deg: f32,
    /// Radius of the thin lens in scene units. 0 (the default) is a pinhole: everything sharp.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(min = 0))]
    pub aperture_radius: f32,
    /// Distance from the lens along the view direction to the plane in perfect focus, in scene
    /// units. Default: the distance to `look_at`. Only meaningful with `aperture_radius` > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub focus_distance: Option<f32>,
}

fn default_up() -> Vec3 {
    [0.0, 1.0, 0.0]
}

fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

/// The environment: what rays that leave the scene see, and a light (importance-sampled, by
/// the image's luminance or uniformly, and combined with BSDF sampling by MIS).
///
/// Radiance from direction d is `strength` × (the image at d, or `color`). The image is
/// equirectangular, oriented as Blender's Environment Texture with the default mapping: in
/// lumo's y-up coordinates its centre column faces +x, u = 0.25 faces −z, u = 0.75 faces +z,
/// and its top row is straight up.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Background {
    /// Constant radiance in every direction (linear RGB, W·sr⁻¹·m⁻²), when there is no
    /// `image`. Default black.
    #[serde(default)]
    pub color: Rgb,
    /// An equirectangular HDR image of the radiance (`.exr` or `.hdr`, linear RGB in
    /// W·sr⁻¹·m⁻²), relative to the scene file. Negative texels (compression noise) count as 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    /// Multiplies the radiance (≥ 0). Default 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub strength: f32,
    /// Rotation of the image about +y, in degrees, counter-clockwise seen from above. Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rotation_deg: f32,
    /// Whether camera rays see it; it lights the scene either way. Default true.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub visible: bool,
}

impl Default for Background {
    fn default() -> Self {
        Background {
            color: [0.0; 3],
            image: None,
            strength: 1.0,
            rotation_deg: 0.0,
            visible: true,
        }
    }
}

fn yes() -> bool {
    true
}
fn is_true(b: &bool) -> bool {
    *b
}

/// Colour space of a texture's stored values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ColorSpace {
    /// sRGB-encoded (colour images: base colour, emission). Decoded to linear on load.
    #[default]
    Srgb,
    /// Linear values (data images: roughness, metallic).
    Linear,
}

/// What a texture lookup does outside [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Wrap {
    /// Tile the image.
    #[default]
    Repeat,
    /// Tile, mirroring every other copy.
    Mirror,
    /// Repeat the edge texels.
    Clamp,
}

/// An image texture, sampled bilinearly. Texture coordinate (0, 0) is the bottom-left corner of
/// the image, (1, 1) the top-right (OpenGL convention; glTF's top-left origin is converted).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Texture {
    /// Image file (PNG, JPEG, BMP, HDR, EXR), or a glTF/GLB file when `gltf_image` is given.
    pub file: String,
    /// Index of the image inside the glTF/GLB `file` (its `images` array).
    /// Only for glTF files; must be absent for plain image files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf_image: Option<u32>,
    /// How the stored values are encoded. Default `srgb`.
    #[serde(default)]
    pub color_space: ColorSpace,
    /// Behaviour outside [0, 1] along u (glTF `wrapS`). Default `repeat`.
    #[serde(default, skip_serializing_if = "is_repeat")]
    pub wrap_s: Wrap,
    /// Behaviour outside [0, 1] along v (glTF `wrapT`). Default `repeat`.
    #[serde(default, skip_serializing_if = "is_repeat")]
    pub wrap_t: Wrap,
}

fn is_repeat(w: &Wrap) -> bool {
    *w == Wrap::Repeat
}

/// A use of a named texture, with an optional affine map of the texture coordinates
/// (KHR_texture_transform): uv' = translate(offset) · rotate(rotation_deg) · scale(scale) · uv.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TextureRef {
    /// Name of a texture in `textures`.
    pub texture: String,
    /// Added to the texture coordinates after scaling and rotation. Default (0, 0).
    #[serde(default, skip_serializing_if = "is_zero2")]
    pub offset: Vec2,
    /// Counter-clockwise rotation of the texture coordinates, in degrees. Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rotation_deg: f32,
    /// Multiplies the texture coordinates first. Default (1, 1).
    #[serde(default = "one2", skip_serializing_if = "is_one2")]
    pub scale: Vec2,
    /// Which texture coordinate set of the mesh to use: 0 or 1 (glTF `texCoord`: TEXCOORD_0
    /// or TEXCOORD_1). Default 0. Shapes other than glTF meshes have one set.
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    #[schemars(range(min = 0, max = 1))]
    pub tex_coord: u32,
}

fn is_zero_u32(x: &u32) -> bool {
    *x == 0
}

fn is_zero2(v: &Vec2) -> bool {
    *v == [0.0, 0.0]
}
fn one2() -> Vec2 {
    [1.0, 1.0]
}
fn is_one2(v: &Vec2) -> bool {
    *v == [1.0, 1.0]
}

/// A surface's appearance: glTF 2.0's metallic-roughness material (glTF 2.0 specification,
/// Appendix B) with the parameters of its ratified material extensions, plus emission.
///
/// ```text
/// metal      = GGX reflection with Schlick Fresnel, F0 = base_color
/// dielectric = GGX reflection, F0 from ior × specular_color, weighted by specular,
///              over mix(Lambert(base_color), transmission tinted by base_color, transmission)
/// material   = mix(dielectric, metal, metallic)                  α = roughness²
/// ```
///
/// Every factor is multiplied by its texture where one is given. The defaults are those of
/// Blender's Principled BSDF (a grey, slightly glossy plastic); `specular: 0` removes the
/// reflection over the diffuse base (a pure Lambertian surface, as the legacy format's diffuse
/// materials are), while transmission keeps the exact Fresnel reflection of its `ior`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Diffuse reflectance, metal F0 and transmission tint (linear RGB, each in [0, 1]).
    /// Default (0.8, 0.8, 0.8). glTF `baseColorFactor` (RGB).
    #[serde(default = "default_base_color")]
    pub base_color: Rgb,
    /// Multiplies `base_color` by this texture (its RGB channels; its alpha channel multiplies
    /// `alpha`). glTF `baseColorTexture`. A mesh's vertex colours (glTF `COLOR_0`) multiply
    /// both as well.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_color_texture: Option<TextureRef>,
    /// Coverage in [0, 1], used as `alpha_mode` says. Default 1. glTF `baseColorFactor` (A).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    #[schemars(range(min = 0, max = 1))]
    pub alpha: f32,
    /// How `alpha` (× texture alpha × vertex alpha) makes the surface transparent: `opaque`
    /// ignores it, `mask` cuts away where it is below `alpha_cutoff`, `blend` lets a fraction
    /// 1 − alpha of the light through unchanged (stochastic transparency, for camera and shadow
    /// rays alike). Default `opaque`. glTF `alphaMode`.
    #[serde(default, skip_serializing_if = "is_opaque")]
    pub alpha_mode: AlphaMode,
    /// The `mask` threshold in [0, 1]: alpha below it is cut away. Default 0.5. glTF
    /// `alphaCutoff`.
    #[serde(default = "half", skip_serializing_if = "is_half")]
    #[schemars(range(min = 0, max = 1))]
    pub alpha_cutoff: f32,
    /// A tangent-space normal map (linear RGB = (x, y, z) · 0.5 + 0.5, +y towards +v),
    /// perturbing the shading normal with the mesh's tangents (glTF `TANGENT`, or MikkTSpace
    /// tangents when the file has none). glTF `normalTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal_texture: Option<TextureRef>,
    /// Scales the normal map's x and y (glTF `normalTexture.scale`). Default 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub normal_scale: f32,
    /// Metalness in [0, 1]: 0 is a dielectric, 1 a metal whose F0 is `base_color`. Default 0.
    /// glTF `metallicFactor`.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(min = 0, max = 1))]
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] of the metal, the specular reflection and the
    /// transmission: GGX microfacets with α = roughness², a perfect mirror (and smooth glass)
    /// below α = 10⁻³. Default 0.5. glTF `roughnessFactor`.
    #[serde(
        default = "default_roughness",
        skip_serializing_if = "is_default_roughness"
    )]
    #[schemars(range(min = 0, max = 1))]
    pub roughness: f32,
    /// Per-texel factors in glTF's layout: green multiplies `roughness`, blue multiplies
    /// `metallic`. Linear data. glTF `metallicRoughnessTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Index of refraction of the dielectric (inside over outside, > 0): sets the specular F0 =
    /// ((ior − 1)/(ior + 1))² and the refraction of transmission. Default 1.5.
    /// `KHR_materials_ior`.
    #[serde(default = "default_ior", skip_serializing_if = "is_default_ior")]
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub ior: f32,
    /// Strength of the dielectric's specular reflection over its diffuse base, in [0, 1]: 0
    /// leaves a pure Lambertian base. Default 1. `KHR_materials_specular` `specularFactor`.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    #[schemars(range(min = 0, max = 1))]
    pub specular: f32,
    /// Multiplies `specular` by this texture's alpha channel. Linear data.
    /// `KHR_materials_specular` `specularTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular_texture: Option<TextureRef>,
    /// Tints the dielectric's F0 at normal incidence (linear RGB, each ≥ 0; F0 is capped at 1).
    /// Default white. `KHR_materials_specular` `specularColorFactor`.
    #[serde(default = "white", skip_serializing_if = "is_white")]
    pub specular_color: Rgb,
    /// Multiplies `specular_color` by this texture (its RGB channels).
    /// `KHR_materials_specular` `specularColorTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular_color_texture: Option<TextureRef>,
    /// Fraction of the dielectric base that is transmitted instead of diffusely reflected, in
    /// [0, 1]: a rough dielectric interface (Walter et al. 2007) with the specular roughness,
    /// tinted by `base_color`. Default 0. `KHR_materials_transmission` `transmissionFactor`.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(min = 0, max = 1))]
    pub transmission: f32,
    /// Multiplies `transmission` by this texture's red channel. Linear data.
    /// `KHR_materials_transmission` `transmissionTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmission_texture: Option<TextureRef>,
    /// The object is a solid whose surface bounds a medium: transmitted light refracts into it
    /// and is absorbed along its path inside (`KHR_materials_volume`). Absent: the surface is
    /// thin-walled (a soap bubble, a window pane), and light passes through without bending.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<Volume>,
    /// Strength in [0, 1] of a clear coat over everything else: a GGX layer of ior 1.5 with its
    /// own roughness and normal. Default 0 (none). `KHR_materials_clearcoat` `clearcoatFactor`.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(min = 0, max = 1))]
    pub clearcoat: f32,
    /// Multiplies `clearcoat` by this texture's red channel. Linear data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearcoat_texture: Option<TextureRef>,
    /// Perceptual roughness in [0, 1] of the clear coat (α = roughness²). Default 0.
    /// `clearcoatRoughnessFactor`.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(min = 0, max = 1))]
    pub clearcoat_roughness: f32,
    /// Multiplies `clearcoat_roughness` by this texture's green channel. Linear data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearcoat_roughness_texture: Option<TextureRef>,
    /// The clear coat's own tangent-space normal map (as `normal_texture`); without it the coat
    /// follows the unperturbed surface normal. `clearcoatNormalTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearcoat_normal_texture: Option<TextureRef>,
    /// Scales the clear-coat normal map's x and y. Default 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub clearcoat_normal_scale: f32,
    /// Colour of a sheen layer (cloth, velvet, dust: retro-reflection at grazing angles), linear
    /// RGB in [0, 1]. Default black (none). `KHR_materials_sheen` `sheenColorFactor`.
    #[serde(default, skip_serializing_if = "is_black")]
    pub sheen_color: Rgb,
    /// Multiplies `sheen_color` by this texture (its RGB channels). `sheenColorTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sheen_color_texture: Option<TextureRef>,
    /// Perceptual roughness in [0, 1] of the sheen ("Charlie" distribution, α = roughness²).
    /// Default 0. `sheenRoughnessFactor`.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(min = 0, max = 1))]
    pub sheen_roughness: f32,
    /// Multiplies `sheen_roughness` by this texture's alpha channel. Linear data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sheen_roughness_texture: Option<TextureRef>,
    /// Unlit: the surface shows its base colour (× texture × vertex colour) as is, unaffected
    /// by light, and reflects nothing (`KHR_materials_unlit`). Rays that reach it see that
    /// colour as emitted radiance; it is not sampled as a light.
    #[serde(default, skip_serializing_if = "is_false")]
    pub unlit: bool,
    /// Emitted radiance (linear RGB, W·sr⁻¹·m⁻², each ≥ 0): a surface with emission is an area
    /// light. Default black. glTF `emissiveFactor` × `KHR_materials_emissive_strength`.
    #[serde(default, skip_serializing_if = "is_black")]
    pub emission: Rgb,
    /// Multiplies `emission` by this texture (its RGB channels). glTF `emissiveTexture`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emission_texture: Option<TextureRef>,
    /// Emit from both faces. By default a surface emits only from its front face (the side its
    /// geometric normal points to: outside of spheres and lathes, counter-clockwise side of
    /// triangles, the normal's side of planes).
    #[serde(default, skip_serializing_if = "is_false")]
    pub two_sided_emission: bool,
}

/// The medium inside a closed transmissive object (`KHR_materials_volume`): Beer–Lambert
/// absorption, so that light travelling a distance d inside keeps
/// `attenuation_color^(d / attenuation_distance)` of its radiance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Volume {
    /// Colour that white light becomes after travelling `attenuation_distance` inside (linear
    /// RGB, each in (0, 1]). Default white (no absorption). `attenuationColor`.
    #[serde(default = "white", skip_serializing_if = "is_white")]
    pub attenuation_color: Rgb,
    /// Distance in scene units over which light takes `attenuation_color` (> 0). Absent: no
    /// absorption (glTF's +∞). `attenuationDistance`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub attenuation_distance: Option<f32>,
}

impl Default for Volume {
    /// A clear medium (no absorption).
    fn default() -> Self {
        Volume {
            attenuation_color: white(),
            attenuation_distance: None,
        }
    }
}

impl Volume {
    /// The absorption coefficient σa per scene unit, per channel: −ln(colour) / distance
    /// (zero without a distance).
    pub fn absorption(&self) -> Rgb {
        match self.attenuation_distance {
            Some(d) if d > 0.0 => self.attenuation_color.map(|c| -c.max(1e-30).ln() / d),
            _ => [0.0; 3],
        }
    }
}

fn default_base_color() -> Rgb {
    [0.8, 0.8, 0.8]
}
fn default_roughness() -> f32 {
    0.5
}
fn is_default_roughness(x: &f32) -> bool {
    *x == 0.5
}
fn default_ior() -> f32 {
    1.5
}
fn is_default_ior(x: &f32) -> bool {
    *x == 1.5
}
fn one() -> f32 {
    1.0
}
fn half() -> f32 {
    0.5
}
fn is_half(x: &f32) -> bool {
    *x == 0.5
}
fn is_opaque(m: &AlphaMode) -> bool {
    *m == AlphaMode::Opaque
}

/// How a material's alpha makes it transparent (glTF `alphaMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is opaque.
    #[default]
    Opaque,
    /// Alpha below `alpha_cutoff` cuts the surface away; above it the surface is opaque.
    Mask,
    /// A fraction 1 − alpha of the light passes through the surface unchanged.
    Blend,
}
fn is_one(x: &f32) -> bool {
    *x == 1.0
}
fn white() -> Rgb {
    [1.0; 3]
}
fn is_white(c: &Rgb) -> bool {
    *c == [1.0; 3]
}
fn is_black(c: &Rgb) -> bool {
    *c == [0.0, 0.0, 0.0]
}
fn is_false(b: &bool) -> bool {
    !*b
}

impl Default for Material {
    fn default() -> Self {
        Material {
            base_color: default_base_color(),
            base_color_texture: None,
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            normal_texture: None,
            normal_scale: 1.0,
            metallic: 0.0,
            roughness: default_roughness(),
            metallic_roughness_texture: None,
            ior: default_ior(),
            specular: 1.0,
            specular_texture: None,
            specular_color: white(),
            specular_color_texture: None,
            transmission: 0.0,
            transmission_texture: None,
            volume: None,
            clearcoat: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness: 0.0,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            sheen_color: [0.0; 3],
            sheen_color_texture: None,
            sheen_roughness: 0.0,
            sheen_roughness_texture: None,
            unlit: false,
            emission: [0.0; 3],
            emission_texture: None,
            two_sided_emission: false,
        }
    }
}

impl Material {
    /// A Lambertian (pure diffuse) material of reflectance `color`: no specular reflection.
    pub fn lambert(color: Rgb) -> Material {
        Material {
            base_color: color,
            specular: 0.0,
            ..Material::default()
        }
    }

    /// The texture uses of this material with their JSON keys, in declaration order.
    pub fn texture_refs(&self) -> [(&'static str, Option<&TextureRef>); 12] {
        [
            ("base_color_texture", self.base_color_texture.as_ref()),
            ("normal_texture", self.normal_texture.as_ref()),
            (
                "metallic_roughness_texture",
                self.metallic_roughness_texture.as_ref(),
            ),
            ("specular_texture", self.specular_texture.as_ref()),
            (
                "specular_color_texture",
                self.specular_color_texture.as_ref(),
            ),
            ("transmission_texture", self.transmission_texture.as_ref()),
            ("clearcoat_texture", self.clearcoat_texture.as_ref()),
            (
                "clearcoat_roughness_texture",
                self.clearcoat_roughness_texture.as_ref(),
            ),
            (
                "clearcoat_normal_texture",
                self.clearcoat_normal_texture.as_ref(),
            ),
            ("sheen_color_texture", self.sheen_color_texture.as_ref()),
            (
                "sheen_roughness_texture",
                self.sheen_roughness_texture.as_ref(),
            ),
            ("emission_texture", self.emission_texture.as_ref()),
        ]
    }
}

/// One step of an object's placement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TransformOp {
    /// Move by this offset.
    Translate(Vec3),
    /// Rotate right-handedly (counter-clockwise looking down the axis towards the origin).
    Rotate(Rotation),
    /// Scale about the origin, uniformly (one number) or per axis (three numbers).
    Scale(Scale),
    /// A general affine 4×4 matrix, row by row; the last row must be (0, 0, 0, 1).
    /// Points map as p' = M · (x, y, z, 1).
    Matrix([[f32; 4]; 4]),
}

/// A rotation about an axis through the origin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    /// Axis direction (need not be unit length, must not be zero).
    pub axis: Vec3,
    /// Angle in degrees, right-handed about `axis`.
    pub degrees: f32,
}

/// Uniform or per-axis scale factors (non-zero).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Scale {
    /// The same factor on every axis.
    Uniform(f32),
    /// One factor per axis.
    PerAxis(Vec3),
}

/// Placement of an object: a list of steps applied to the object **in the order listed**
/// (the first step acts first): p_world = Opₙ ⋯ Op₂ · Op₁ · p_object.
/// Example: `[{"scale": 2}, {"rotate": {"axis": [0,1,0], "degrees": 30}}, {"translate": [1,0,0]}]`
/// scales, then rotates, then moves. Normals transform with the inverse transpose.
pub type Transform = Vec<TransformOp>;

/// A piece of geometry with its material and placement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Object {
    /// A sphere.
    Sphere(Sphere),
    /// An infinite plane.
    Plane(Plane),
    /// A single triangle.
    Triangle(Triangle),
    /// A triangle mesh from an OBJ file, a glTF/GLB file, or inline arrays.
    Mesh(Mesh),
    /// A surface of revolution about the y axis.
    Lathe(Lathe),
}

/// A sphere. Texture coordinates: u = azimuth φ / 2π about +y measured from +x towards −z,
/// v = polar angle from −y to +y / π (v = 1 at the north pole, +y).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Sphere {
    /// Optional name, for messages and exporters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Name of a material in `materials`.
    pub material: String,
    /// Placement of the sphere (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub transform: Transform,
    /// Centre in object space. Default (0, 0, 0).
    #[serde(default)]
    pub center: Vec3,
    /// Radius in scene units, > 0.
    #[schemars(extend("exclusiveMinimum" = 0))]
    pub radius: f32,
}

/// The infinite plane of points p with dot(normal, p) = offset. Its front is the side `normal`
/// points to. Texture coordinates are the point's coordinates along two tangent axes, in scene
/// units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Plane {
    /// Optional name, for messages and exporters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Name of a material in `materials`.
    pub material: String,
    /// Placement of the plane (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub transform: Transform,
    /// Normal direction (non-zero; normalised on load, `offset` is measured along the unit normal).
    pub normal: Vec3,
    /// Signed distance of the plane from the origin along the unit normal. Default 0.
    #[serde(default)]
    pub offset: f32,
}

/// A single triangle; its front face is the counter-clockwise side (normal (v1−v0)×(v2−v0)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Triangle {
    /// Optional name, for messages and exporters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Name of a material in `materials`.
    pub material: String,
    /// Placement of the triangle (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub transform: Transform,
    /// The three corners in object space.
    pub vertices: [Vec3; 3],
}

/// A triangle mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Mesh {
    /// Optional name, for messages and exporters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Name of a material in `materials`.
    pub material: String,
    /// Placement of the mesh (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub transform: Transform,
    /// Where the triangles come from.
    pub source: MeshSource,
    /// Interpolate vertex normals across faces: the file's normals when it has them, otherwise
    /// angle-weighted averages of the face normals. When false, faces are flat. Default false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub smooth: bool,
}

/// Where a mesh's triangles come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MeshSource {
    /// A Wavefront OBJ file (all its objects and groups; polygons are fan-triangulated).
    Obj(String),
    /// One primitive of one mesh inside a glTF (.gltf) or binary glTF (.glb) file.
    Gltf(GltfMeshRef),
    /// Arrays written in the scene file.
    Inline(InlineMesh),
}

/// A mesh primitive inside a glTF file, by index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GltfMeshRef {
    /// The .gltf or .glb file.
    pub file: String,
    /// Index into the file's `meshes` array.
    pub mesh: u32,
    /// Index into that mesh's `primitives` array. Default 0.
    #[serde(default)]
    pub primitive: u32,
}

/// Mesh data written out in full.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InlineMesh {
    /// Vertex positions in object space.
    pub positions: Vec<Vec3>,
    /// Triangles as triples of 0-based indices into `positions`, counter-clockwise front.
    pub indices: Vec<[u32; 3]>,
    /// Optional per-vertex normals (one per position); used when `smooth` is true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normals: Option<Vec<Vec3>>,
    /// Optional per-vertex texture coordinates (one per position).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uvs: Option<Vec<Vec2>>,
}

/// A surface of revolution: the profile curve, drawn in the xy-plane, revolved about the y axis:
/// S(t, θ) = (x(t) cos θ, y(t), −x(t) sin θ). |x| is the radius, so profiles at negative x
/// work: a profile and its mirror image (−x, y) describe the same surface, oriented the same way.
/// Orientation: the front (outside) normal is n = ∂S/∂θ × ∂S/∂t, which at θ = 0 is
/// x · (y′, −x′, 0): **a profile traversed upwards (increasing y) faces away from the axis**,
/// one traversed downwards faces the axis. At poles (x = 0) the normal is the limit along the
/// axis.
/// Texture coordinates: u = θ / 2π, v = the curve parameter normalised to [0, 1] over the
/// whole profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Lathe {
    /// Optional name, for messages and exporters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Name of a material in `materials`.
    pub material: String,
    /// Placement of the lathe (default: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub transform: Transform,
    /// The profile curve in the xy-plane.
    pub profile: Profile,
}

/// A planar profile curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// One Bézier curve of degree `points.len() − 1` (at least 2 points), parameter in [0, 1].
    Bezier(BezierProfile),
    /// A B-spline.
    Bspline(BsplineProfile),
}

/// A Bézier profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BezierProfile {
    /// Control points (x, y); the degree is one less than their number.
    pub points: Vec<Vec2>,
}

/// A B-spline profile of the given degree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BsplineProfile {
    /// Polynomial degree, ≥ 1. Default 3 (cubic).
    #[serde(default = "default_degree")]
    #[schemars(range(min = 1, max = 16))]
    pub degree: u32,
    /// Control points (x, y); at least `degree + 1` of them.
    pub points: Vec<Vec2>,
    /// Knot vector: `points.len() + degree + 1` non-decreasing values. The curve is traced over
    /// [knots[degree], knots[points.len()]]. Default: clamped uniform on [0, 1] (the curve starts
    /// and ends at the first and last control points).
    // The doc is also the JSON Schema's description, so its math stays unescaped.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub knots: Option<Vec<f32>>,
}

fn default_degree() -> u32 {
    3
}

impl BsplineProfile {
    /// The knot vector with its default applied: clamped uniform on [0, 1].
    pub fn knots_or_default(&self) -> Vec<f32> {
        if let Some(k) = &self.knots {
            return k.clone();
        }
        let p = self.degree as usize;
        let n = self.points.len();
        let spans = n.saturating_sub(p).max(1);
        let mut knots = Vec::with_capacity(n + p + 1);
        knots.extend(std::iter::repeat_n(0.0, p + 1));
        for i in 1..spans {
            knots.push(i as f32 / spans as f32);
        }
        knots.extend(std::iter::repeat_n(1.0, p + 1));
        knots
    }
}

/// A punctual light. Emissive materials are area lights and need no entry here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Light {
    /// Light from one point, equally in all directions, falling off with the squared distance.
    Point(PointLight),
    /// Light from infinitely far away along one direction (the sun).
    Directional(DirectionalLight),
    /// A point light restricted to a cone, with a smooth falloff between the inner and outer
    /// angle.
    Spot(SpotLight),
}

/// A point light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PointLight {
    /// Position in world space.
    pub position: Vec3,
    /// Radiant intensity (linear RGB, W·sr⁻¹, each ≥ 0).
    pub intensity: Rgb,
}

/// A directional light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLight {
    /// The direction the light travels (from the light towards the scene), non-zero.
    pub direction: Vec3,
    /// Irradiance on a surface facing the light (linear RGB, W·m⁻², each ≥ 0).
    pub irradiance: Rgb,
}

/// A spot light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpotLight {
    /// Position in world space.
    pub position: Vec3,
    /// The cone's axis: the direction the light shines, non-zero.
    pub direction: Vec3,
    /// Radiant intensity on the axis (linear RGB, W·sr⁻¹, each ≥ 0).
    pub intensity: Rgb,
    /// Half-angle in degrees inside which the intensity is full. Default 0.
    #[serde(default)]
    #[schemars(range(min = 0, max = 90))]
    pub inner_angle_deg: f32,
    /// Half-angle in degrees outside which there is no light; ≥ `inner_angle_deg`, in (0, 90].
    /// Default 45.
    #[serde(default = "default_outer_angle")]
    #[schemars(extend("exclusiveMinimum" = 0), range(max = 90))]
    pub outer_angle_deg: f32,
}

fn default_outer_angle() -> f32 {
    45.0
}

impl Object {
    /// The material name of the object.
    pub fn material(&self) -> &str {
        match self {
            Object::Sphere(o) => &o.material,
            Object::Plane(o) => &o.material,
            Object::Triangle(o) => &o.material,
            Object::Mesh(o) => &o.material,
            Object::Lathe(o) => &o.material,
        }
    }

    /// The placement of the object.
    pub fn transform(&self) -> &Transform {
        match self {
            Object::Sphere(o) => &o.transform,
            Object::Plane(o) => &o.transform,
            Object::Triangle(o) => &o.transform,
            Object::Mesh(o) => &o.transform,
            Object::Lathe(o) => &o.transform,
        }
    }

    /// The optional name of the object.
    pub fn name(&self) -> Option<&str> {
        match self {
            Object::Sphere(o) => o.name.as_deref(),
            Object::Plane(o) => o.name.as_deref(),
            Object::Triangle(o) => o.name.as_deref(),
            Object::Mesh(o) => o.name.as_deref(),
            Object::Lathe(o) => o.name.as_deref(),
        }
    }

    /// The key of this object's kind in JSON (`sphere`, `plane`, …).
    pub fn kind(&self) -> &'static str {
        match self {
            Object::Sphere(_) => "sphere",
            Object::Plane(_) => "plane",
            Object::Triangle(_) => "triangle",
            Object::Mesh(_) => "mesh",
            Object::Lathe(_) => "lathe",
        }
    }
}
