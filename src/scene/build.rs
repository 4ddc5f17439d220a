//! Turning a validated scene description and its assets into a scene graph: resolve names to
//! indices, compose transforms, make meshes and textures, collect lights. No I/O happens here.

use std::collections::HashMap;
use std::sync::Arc;

use glam::Affine2;
use lumo_schema as schema;
use lumo_schema::Validated;

use super::{IntegratorKind, Scene, Settings};
use crate::assets::{Assets, MeshData, TextureImage};
use crate::camera::Camera;
use crate::environment::Environment;
use crate::geometry::shadow_casters::LightPoints;
use crate::geometry::{Geometry, Instance, Mesh, Plane, Shape, Sphere};
use crate::light::Light;
use crate::light_sampler::{LightSampler, LightSamplerKind};
use crate::material::{AlphaMode, Material};
use crate::math::{srgb8_table, srgb8_to_linear, unorm8_table, Affine3A, Vec2, Vec3};
use crate::texture::{Texels, Texture, TextureRef, Wrap};
use rayon::prelude::*;

/// Most triangles a scene may hold (about 6 GiB with BVHs); larger scenes are refused.
pub const MAX_TRIANGLES: usize = 64 << 20;

/// Why a scene graph could not be built from a validated scene and its assets.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The scene references a mesh or image that is not among the assets (the scene was
    /// changed after its assets were read).
    #[error("{json_path}: `{file}` was not read with the scene's assets")]
    MissingAsset {
        /// JSON path of the reference in the scene.
        json_path: String,
        /// The file as the scene names it.
        file: String,
    },
    /// An object names a material the scene does not define.
    #[error("{json_path}.material: unknown material `{name}`")]
    UnknownMaterial {
        /// JSON path of the object.
        json_path: String,
        /// The name.
        name: String,
    },
    /// The scene holds more triangles than [`MAX_TRIANGLES`].
    #[error("{json_path}: the scene exceeds the limit of {MAX_TRIANGLES} triangles (about 6 GiB of memory)")]
    TooManyTriangles {
        /// JSON path of the object that crossed the limit.
        json_path: String,
    },
    /// A lathe's profile cannot be turned into the renderer's curve.
    #[error("{json_path}.profile: {message}")]
    Profile {
        /// JSON path of the lathe.
        json_path: String,
        /// What is wrong with it.
        message: String,
    },
}

/// The object → world map of a list of transform steps (the first step acts first), in the
/// renderer's f32 ([`lumo_schema::geometry::transform::compose`]).
pub fn compose_transform(ops: &[schema::TransformOp]) -> Affine3A {
    lumo_schema::geometry::transform::compose(ops)
}

/// Builds the scene graph from a validated scene and the assets read for it (see
/// [`crate::load()`]); reads no file. Returns the scene and warnings about what was dropped.
pub fn build(
    desc: &Validated<schema::Scene>,
    assets: &Assets,
) -> Result<(Scene, Vec<String>), BuildError> {
    let mut warnings = Vec::new();
    let textures = textures(desc, assets)?;
    let materials = materials(desc, &textures);
    let mut instances = instances(desc, assets, &materials, &mut warnings)?;
    crate::phases::mark("build: meshes");
    let mut lights = area_lights(
        &mut instances,
        &materials.items,
        &textures.items,
        &mut warnings,
    );
    crate::phases::mark("build: area lights");
    let mut geometry = Geometry::new(instances);
    crate::phases::mark("build: geometry (BVHs)");

    // The lights' order is their index: emissive shapes, the scene's lights, the environment.
    let scene_radius = scene_radius(&geometry);
    lights.extend(desc.lights.iter().map(|l| punctual_light(l, scene_radius)));
    let environment = environment(&desc.background, assets)?;
    let environment_light = environment.as_ref().map(|env| {
        lights.push(Light::Environment {
            env: env.clone(),
            scene_radius,
        });
        lights.len() - 1
    });
    let light_sampler = LightSampler::new(&lights, LightSamplerKind::Auto);
    geometry.limit_shadow_casters(light_points(&lights).as_ref());

    let camera = camera(desc);
    let settings = settings(desc);
    let has_alpha = materials.items.iter().any(Material::has_alpha);
    let scene = Scene {
        camera,
        environment,
        environment_light,
        geometry,
        materials: materials.items,
        textures: textures.items,
        lights,
        light_sampler,
        settings,
        has_alpha,
    };
    Ok((scene, warnings))
}

/// Where the lights' samples lie, for the shadow rays' tests; `None` when some light is at
/// infinity.
fn light_points(lights: &[Light]) -> Option<LightPoints> {
    let mut hull = Vec::new();
    for light in lights {
        hull.extend(light.hull()?);
    }
    Some(LightPoints {
        hull,
        all_surfaces: lights.iter().all(|l| l.surface_instance().is_some()),
    })
}

/// Items made from one of the scene's name-keyed tables (textures, materials), in the table's
/// order, with the index each name resolves to.
struct Named<'a, T> {
    items: Vec<T>,
    index: HashMap<&'a str, u32>,
}

impl<'a, T> FromIterator<(&'a str, T)> for Named<'a, T> {
    fn from_iter<I: IntoIterator<Item = (&'a str, T)>>(named_items: I) -> Self {
        let mut named = Named {
            items: Vec::new(),
            index: HashMap::new(),
        };
        for (name, item) in named_items {
            named.index.insert(name, named.items.len() as u32);
            named.items.push(item);
        }
        named
    }
}

/// Texture descriptions and their images → the renderer's textures, by name.
fn textures<'a>(
    desc: &'a schema::Scene,
    assets: &Assets,
) -> Result<Named<'a, Texture>, BuildError> {
    desc.textures
        .iter()
        .map(|(name, t)| {
            let image = assets.texture(t).ok_or_else(|| BuildError::MissingAsset {
                json_path: format!("textures.{name}"),
                file: t.file.clone(),
            })?;
            Ok((name.as_str(), texture(t, image)))
        })
        .collect()
}

/// A texture description and its image → a texture whose lookups return linear values.
fn texture(t: &schema::Texture, image: &TextureImage) -> Texture {
    let srgb = t.color_space == schema::ColorSpace::Srgb && !image.is_float;
    let texels = match &image.texels {
        // The bytes are shared; only the decoding differs with the colour space.
        Texels::Rgba8 {
            rgba, has_alpha, ..
        } => Texels::Rgba8 {
            rgba: rgba.clone(),
            has_alpha: *has_alpha,
            decode: if srgb { srgb8_table() } else { unorm8_table() },
        },
        // Other images (16-bit) arrive as floats still encoded; sRGB ones are decoded once, here.
        Texels::Float { rgb, alpha } => Texels::Float {
            rgb: if srgb {
                let table = srgb8_table();
                rgb.par_iter()
                    .map(|c| c.map(|v| srgb8_to_linear(v, table)))
                    .collect()
            } else {
                rgb.to_vec()
            },
            alpha: alpha.clone(),
        },
    };
    Texture {
        width: image.width,
        height: image.height,
        texels,
        wrap_s: wrap(t.wrap_s),
        wrap_t: wrap(t.wrap_t),
    }
}

fn wrap(w: schema::Wrap) -> Wrap {
    match w {
        schema::Wrap::Repeat => Wrap::Repeat,
        schema::Wrap::Mirror => Wrap::Mirror,
        schema::Wrap::Clamp => Wrap::Clamp,
    }
}

/// Material descriptions → materials, by name, their texture names resolved to indices.
fn materials<'a>(desc: &'a schema::Scene, textures: &Named<Texture>) -> Named<'a, Material> {
    desc.materials
        .iter()
        .map(|(name, m)| (name.as_str(), material(m, textures)))
        .collect()
}

fn material(m: &schema::Material, textures: &Named<Texture>) -> Material {
    let tex_ref = |r: &Option<schema::TextureRef>| texture_ref(r, textures);
    Material {
        base_color: Vec3::from(m.base_color),
        base_color_texture: tex_ref(&m.base_color_texture),
        alpha: m.alpha,
        alpha_mode: match m.alpha_mode {
            schema::AlphaMode::Opaque => AlphaMode::Opaque,
            schema::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff),
            schema::AlphaMode::Blend => AlphaMode::Blend,
        },
        normal_texture: tex_ref(&m.normal_texture),
        normal_scale: m.normal_scale,
        metallic: m.metallic,
        roughness: m.roughness,
        metallic_roughness_texture: tex_ref(&m.metallic_roughness_texture),
        ior: m.ior,
        specular: m.specular,
        specular_texture: tex_ref(&m.specular_texture),
        specular_color: Vec3::from(m.specular_color),
        specular_color_texture: tex_ref(&m.specular_color_texture),
        transmission: m.transmission,
        transmission_texture: tex_ref(&m.transmission_texture),
        absorption: m.volume.as_ref().map(|v| Vec3::from(v.absorption())),
        clearcoat: m.clearcoat,
        clearcoat_texture: tex_ref(&m.clearcoat_texture),
        clearcoat_roughness: m.clearcoat_roughness,
        clearcoat_roughness_texture: tex_ref(&m.clearcoat_roughness_texture),
        clearcoat_normal_texture: tex_ref(&m.clearcoat_normal_texture),
        clearcoat_normal_scale: m.clearcoat_normal_scale,
        sheen_color: Vec3::from(m.sheen_color),
        sheen_color_texture: tex_ref(&m.sheen_color_texture),
        sheen_roughness: m.sheen_roughness,
        sheen_roughness_texture: tex_ref(&m.sheen_roughness_texture),
        unlit: m.unlit,
        emission: Vec3::from(m.emission),
        emission_texture: tex_ref(&m.emission_texture),
        two_sided_emission: m.two_sided_emission,
    }
}

/// A material's texture slot → the texture's index and the map from the coordinate set it
/// names to the texture's coordinates: translation · rotation · scale, so the scale acts first.
fn texture_ref(r: &Option<schema::TextureRef>, textures: &Named<Texture>) -> Option<TextureRef> {
    r.as_ref().and_then(|r| {
        textures
            .index
            .get(r.texture.as_str())
            .map(|&texture| TextureRef {
                texture,
                transform: Affine2::from_translation(Vec2::from(r.offset))
                    * {
                        let (sin, cos) = crate::lanes::math::sin_cos(r.rotation_deg.to_radians());
                        Affine2::from_cols(Vec2::new(cos, sin), Vec2::new(-sin, cos), Vec2::ZERO)
                    }
                    * Affine2::from_scale(Vec2::from(r.scale)),
                tex_coord: r.tex_coord.min(1) as u8,
            })
    })
}

/// Objects → instances (shape, object → world map, material index), one per object in order.
/// Warns about the degenerate triangles dropped.
fn instances(
    desc: &schema::Scene,
    assets: &Assets,
    materials: &Named<Material>,
    warnings: &mut Vec<String>,
) -> Result<Vec<Instance>, BuildError> {
    let mut meshes = Meshes::default();
    let mut instances = Vec::new();
    for (i, obj) in desc.objects.iter().enumerate() {
        let json_path = format!("objects[{i}].{}", obj.kind());
        let Some(&material) = materials.index.get(obj.material()) else {
            return Err(BuildError::UnknownMaterial {
                json_path,
                name: obj.material().to_string(),
            });
        };
        let to_world = compose_transform(obj.transform());
        let shape = meshes.shape(obj, assets, &json_path)?;
        instances.push(Instance::new(shape, to_world, material));
    }
    let degenerate = meshes.degenerate;
    if degenerate > 0 {
        warnings.push(format!(
            "dropped {degenerate} degenerate (zero-area) triangles"
        ));
    }
    Ok(instances)
}

/// The meshes made so far, shared between objects with the same source and smoothing, and the
/// triangles counted against [`MAX_TRIANGLES`].
#[derive(Default)]
struct Meshes {
    /// By source and smoothing.
    shared: HashMap<String, Arc<Mesh>>,
    /// Triangles made (a shared mesh counts once).
    triangles: usize,
    /// Zero-area triangles dropped.
    degenerate: usize,
}

impl Meshes {
    /// An object → its shape in object space (`json_path` names the object in errors).
    fn shape(
        &mut self,
        obj: &schema::Object,
        assets: &Assets,
        json_path: &str,
    ) -> Result<Shape, BuildError> {
        Ok(match obj {
            schema::Object::Sphere(s) => Shape::Sphere(Sphere {
                center: Vec3::from(s.center),
                radius: s.radius,
            }),
            schema::Object::Plane(p) => {
                let n = Vec3::from(p.normal);
                let len = n.length();
                Shape::Plane(Plane {
                    normal: n / len,
                    offset: p.offset,
                })
            }
            schema::Object::Triangle(t) => {
                let (mesh, dropped) = Mesh::from_triangles(
                    t.vertices.iter().map(|v| Vec3::from(*v)).collect(),
                    vec![[0, 1, 2]],
                );
                self.degenerate += dropped;
                self.triangles += 1;
                Shape::Mesh(Arc::new(mesh))
            }
            schema::Object::Mesh(m) => Shape::Mesh(self.mesh(m, assets, json_path)?),
            schema::Object::Lathe(l) => Shape::Lathe(Arc::new(build_lathe(&l.profile, json_path)?)),
        })
    }

    /// A mesh object → its mesh, made at its source's first use and shared after; smooth meshes
    /// keep their normals or get angle-weighted ones, flat meshes drop them.
    fn mesh(
        &mut self,
        m: &schema::Mesh,
        assets: &Assets,
        json_path: &str,
    ) -> Result<Arc<Mesh>, BuildError> {
        let key = format!("{:?}|{}", m.source, m.smooth);
        if let Some(mesh) = self.shared.get(&key) {
            return Ok(mesh.clone());
        }
        let mut data = mesh_data(&m.source, assets, json_path)?;
        self.triangles += data.triangles.len();
        if self.triangles > MAX_TRIANGLES {
            return Err(BuildError::TooManyTriangles {
                json_path: json_path.to_string(),
            });
        }
        data.normals = if m.smooth {
            Some(data.normals.clone().unwrap_or_else(|| {
                Arc::new(Mesh::angle_weighted_normals(
                    &data.positions,
                    &data.triangles,
                ))
            }))
        } else {
            None
        };
        let (mesh, dropped) = Mesh::new(data);
        self.degenerate += dropped;
        let mesh = Arc::new(mesh);
        self.shared.insert(key, mesh.clone());
        Ok(mesh)
    }
}

/// Emissive instances → area lights, in instance order: one per triangle of a mesh, one per
/// sphere; each such instance records its first light's index (`light_base`). Warns about the
/// emitters no light can sample.
fn area_lights(
    instances: &mut [Instance],
    materials: &[Material],
    textures: &[Texture],
    warnings: &mut Vec<String>,
) -> Vec<Light> {
    let mut lights = Vec::new();
    let mut unsampled = 0;
    for (k, inst) in instances.iter_mut().enumerate() {
        let m = &materials[inst.material as usize];
        if !m.is_emissive() {
            continue;
        }
        match &inst.shape {
            Shape::Mesh(mesh) => {
                inst.light_base = Some(lights.len() as u32);
                lights.extend(triangle_lights(k as u32, inst, mesh, m, textures));
            }
            Shape::Sphere(s) => match similarity_scale(&inst.to_world) {
                Some(scale) => {
                    inst.light_base = Some(lights.len() as u32);
                    lights.push(Light::Sphere {
                        instance: k as u32,
                        center: inst.to_world.transform_point3(s.center),
                        radius: s.radius * scale,
                        emission: m.emission,
                    });
                }
                None => unsampled += 1,
            },
            Shape::Plane(_) | Shape::Lathe(_) => unsampled += 1,
        }
    }
    if unsampled > 0 {
        warnings.push(format!(
            "{unsampled} emissive object(s) (planes, lathes or non-uniformly scaled spheres) are lit only by rays that hit them, which converges slowly"
        ));
    }
    lights
}

/// An emissive mesh instance → one light per triangle, in world space, each with the
/// material's emission times its emission texture's mean over the triangle.
fn triangle_lights<'a>(
    instance_index: u32,
    inst: &'a Instance,
    mesh: &'a Mesh,
    m: &'a Material,
    textures: &'a [Texture],
) -> impl Iterator<Item = Light> + 'a {
    // The corners' coordinates in the set the emission texture samples (hits without
    // coordinates use the barycentrics, or zero for set 1).
    let set1 = m.emission_texture.is_some_and(|t| t.tex_coord == 1);
    (0..mesh.data.triangles.len() as u32).map(move |prim| {
        let v = mesh
            .corners(prim)
            .map(|p| inst.to_world.transform_point3(p));
        let tri = mesh.data.triangles[prim as usize];
        let uv = match (set1, &mesh.data.uvs, &mesh.data.uvs1) {
            (false, Some(uvs), _) | (true, _, Some(uvs)) => tri.map(|i| uvs[i as usize]),
            (false, None, _) => [Vec2::ZERO, Vec2::X, Vec2::Y],
            (true, _, None) => [Vec2::ZERO; 3],
        };
        let emission = match &m.emission_texture {
            Some(r) => m.emission * mean_over_triangle(&textures[r.texture as usize], r, uv),
            None => m.emission,
        };
        Light::triangle(instance_index, prim, v, uv, emission, m.two_sided_emission)
    })
}

/// The geometry's bounds → half their diagonal (1 when nothing is bounded): the size against
/// which the power of directional and environment lights is weighed when choosing lights.
fn scene_radius(geometry: &Geometry) -> f32 {
    let bounds = geometry.bounds();
    if bounds.is_empty() {
        1.0
    } else {
        (bounds.max - bounds.min).length() * 0.5
    }
}

/// A point, directional or spot light description → a light, directions normalised and cone
/// angles as cosines.
fn punctual_light(l: &schema::Light, scene_radius: f32) -> Light {
    match l {
        schema::Light::Point(p) => Light::Point {
            position: Vec3::from(p.position),
            intensity: Vec3::from(p.intensity),
        },
        schema::Light::Directional(d) => Light::Directional {
            to_light: -Vec3::from(d.direction).normalize(),
            irradiance: Vec3::from(d.irradiance),
            scene_radius,
        },
        schema::Light::Spot(s) => Light::Spot {
            position: Vec3::from(s.position),
            axis: Vec3::from(s.direction).normalize(),
            intensity: Vec3::from(s.intensity),
            cos_inner: crate::lanes::math::cos(s.inner_angle_deg.to_radians()),
            cos_outer: crate::lanes::math::cos(s.outer_angle_deg.to_radians()),
        },
    }
}

/// The background → the environment: an image (repeating in longitude, clamped at the poles) or
/// a constant colour; `None` when it is black, so that it is neither looked up nor sampled.
fn environment(
    bg: &schema::Background,
    assets: &Assets,
) -> Result<Option<Arc<Environment>>, BuildError> {
    let environment = match &bg.image {
        Some(file) => {
            let image = assets
                .environment(bg)
                .ok_or_else(|| BuildError::MissingAsset {
                    json_path: "background.image".into(),
                    file: file.clone(),
                })?;
            let texture = Texture {
                width: image.width,
                height: image.height,
                texels: image.texels.clone(),
                wrap_s: Wrap::Repeat,
                wrap_t: Wrap::Clamp,
            };
            Environment::image(
                texture,
                bg.strength,
                bg.rotation_deg.to_radians(),
                bg.visible,
            )
        }
        None => Environment::constant(Vec3::from(bg.color), bg.strength, bg.visible),
    };
    Ok(Some(environment).filter(|e| !e.is_black()).map(Arc::new))
}

/// The camera description → the camera, its aspect ratio the image's.
fn camera(desc: &schema::Scene) -> Camera {
    let c = &desc.camera;
    let aspect = desc.image.width as f32 / desc.image.height as f32;
    Camera::look_at(
        Vec3::from(c.position),
        Vec3::from(c.look_at),
        Vec3::from(c.up),
        c.fov_y_deg,
        aspect,
        c.aperture_radius,
        c.focus_distance,
    )
}

/// The image size and render settings → the renderer's settings.
fn settings(desc: &schema::Scene) -> Settings {
    let r = &desc.render;
    Settings {
        width: desc.image.width,
        height: desc.image.height,
        spp: r.spp,
        max_depth: r.max_depth,
        seed: r.seed,
        integrator: match r.integrator {
            schema::Integrator::Path => IntegratorKind::Path,
            schema::Integrator::Raycast => IntegratorKind::Raycast,
        },
        sampler: match r.sampler {
            schema::SamplerKind::Sobol => crate::sampler::SamplerKind::Sobol,
            schema::SamplerKind::Independent => crate::sampler::SamplerKind::Independent,
        },
        time_budget_s: r.time_budget_s,
    }
}

/// The scale factor of a similarity transform (rotation × uniform scale + translation), or
/// `None` when the map shears or scales non-uniformly.
fn similarity_scale(m: &Affine3A) -> Option<f32> {
    let cols = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
    let s = cols[0].length();
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * s.max(1e-30);
    let ok = cols.iter().all(|c| close(c.length(), s))
        && close(cols[0].dot(cols[1]) / s, 0.0)
        && close(cols[1].dot(cols[2]) / s, 0.0)
        && close(cols[0].dot(cols[2]) / s, 0.0);
    ok.then_some(s)
}

/// The renderer's lathe from the schema's profile (f32 data widened to f64).
fn build_lathe(
    profile: &schema::Profile,
    json_path: &str,
) -> Result<crate::lathe::Lathe, BuildError> {
    use crate::lathe::{Lathe, Profile};
    let pts = |v: &[[f32; 2]]| {
        v.iter()
            .map(|p| [p[0] as f64, p[1] as f64])
            .collect::<Vec<_>>()
    };
    let built = match profile {
        schema::Profile::Bezier(b) => Profile::bezier(&pts(&b.points)),
        schema::Profile::Bspline(b) => {
            let knots: Vec<f64> = b.knots_or_default().iter().map(|&k| k as f64).collect();
            Profile::bspline(b.degree as usize, &pts(&b.points), Some(&knots))
        }
    };
    built.map(Lathe::new).map_err(|e| BuildError::Profile {
        json_path: json_path.to_string(),
        message: e.to_string(),
    })
}

/// The mesh arrays of a source: inline data from the scene, files from the assets.
fn mesh_data(
    source: &schema::MeshSource,
    assets: &Assets,
    json_path: &str,
) -> Result<MeshData, BuildError> {
    if let schema::MeshSource::Inline(m) = source {
        return Ok(MeshData {
            positions: Arc::new(m.positions.iter().map(|p| Vec3::from(*p)).collect()),
            triangles: Arc::new(m.indices.clone()),
            normals: m.normals.as_ref().map(|n| {
                Arc::new(
                    n.iter()
                        .map(|v| Vec3::from(*v).normalize_or_zero())
                        .collect(),
                )
            }),
            uvs: m
                .uvs
                .as_ref()
                .map(|t| Arc::new(t.iter().map(|v| Vec2::from(*v)).collect())),
            ..MeshData::default()
        });
    }
    match assets.mesh(source) {
        // The arrays are shared, not copied.
        Some(data) => Ok(MeshData::clone(data)),
        None => Err(BuildError::MissingAsset {
            json_path: format!("{json_path}.source"),
            file: match source {
                schema::MeshSource::Obj(f) => f.clone(),
                schema::MeshSource::Gltf(g) => g.file.clone(),
                schema::MeshSource::Inline(_) => String::new(),
            },
        }),
    }
}

/// The mean of a texture over a triangle with these texture coordinates (the set `r` samples):
/// bilinear lookups at the points of a barycentric lattice whose spacing follows the triangle's
/// size in texels (order 2 to 16: 6 to 153 points).
///
/// It only weighs the choice of lights for next-event estimation (an emissive texture that is
/// black over most of a mesh, as DamagedHelmet's, would otherwise spend most light samples on
/// black triangles). The estimate never changes what a triangle emits, and a triangle whose
/// estimate is zero is still found by BSDF sampling with full MIS weight, so the image stays
/// unbiased whatever the estimate.
fn mean_over_triangle(texture: &Texture, r: &crate::texture::TextureRef, uv: [Vec2; 3]) -> Vec3 {
    let (a, b) = (
        r.coords(uv[1], uv[1]) - r.coords(uv[0], uv[0]),
        r.coords(uv[2], uv[2]) - r.coords(uv[0], uv[0]),
    );
    let texels = 0.5 * a.perp_dot(b).abs() * texture.width as f32 * texture.height as f32;
    let order = (texels.sqrt().ceil() as u32).clamp(2, 16);
    let mut sum = Vec3::ZERO;
    let mut count = 0u32;
    for i in 0..=order {
        for j in 0..=order - i {
            let (wb, wc) = (i as f32 / order as f32, j as f32 / order as f32);
            let p = uv[0] * (1.0 - wb - wc) + uv[1] * wb + uv[2] * wc;
            sum += texture.lookup(r.coords(p, p));
            count += 1;
        }
    }
    sum / count as f32
}

#[cfg(test)]
mod tests {

    /// The light-choice weight of a textured emitter follows its texture: a 64 × 1 texture black
    /// on its left half and white on its right half.
    #[test]
    fn emission_texture_means_weigh_triangles_by_what_they_emit() {
        use crate::texture::{Texture, TextureRef, Wrap};
        let texels: Vec<Vec3> = (0..64)
            .map(|i| if i < 32 { Vec3::ZERO } else { Vec3::ONE })
            .collect();
        let t = Texture::from_rgb(64, 1, texels, Wrap::Clamp, Wrap::Clamp);
        let r = TextureRef {
            texture: 0,
            transform: glam::Affine2::IDENTITY,
            tex_coord: 0,
        };
        let tri = |u0: f32, u1: f32| [Vec2::new(u0, 0.0), Vec2::new(u1, 0.0), Vec2::new(u0, 1.0)];
        assert!(mean_over_triangle(&t, &r, tri(0.0, 0.4)).x < 0.01);
        assert!(mean_over_triangle(&t, &r, tri(0.6, 1.0)).x > 0.99);
        let straddling = mean_over_triangle(&t, &r, tri(0.0, 1.0)).x;
        assert!((0.1..0.5).contains(&straddling), "{straddling}");
    }
    use super::*;

    #[test]
    fn transform_steps_apply_in_listed_order() {
        use schema::{Rotation, Scale, TransformOp};
        // Scale by 2, then rotate +90° about y, then translate by (1, 0, 0).
        let ops = vec![
            TransformOp::Scale(Scale::Uniform(2.0)),
            TransformOp::Rotate(Rotation {
                axis: [0.0, 1.0, 0.0],
                degrees: 90.0,
            }),
            TransformOp::Translate([1.0, 0.0, 0.0]),
        ];
        let m = compose_transform(&ops);
        // (1,0,0) → (2,0,0) → rotated +90° about y: (cos, 0, −sin)·2 = (0,0,−2) → (1,0,−2).
        assert!((m.transform_point3(Vec3::X) - Vec3::new(1.0, 0.0, -2.0)).length() < 1e-5);
        // A row-major matrix op equal to a translation.
        let t = compose_transform(&[TransformOp::Matrix([
            [1.0, 0.0, 0.0, 5.0],
            [0.0, 1.0, 0.0, 6.0],
            [0.0, 0.0, 1.0, 7.0],
            [0.0, 0.0, 0.0, 1.0],
        ])]);
        assert!((t.transform_point3(Vec3::ZERO) - Vec3::new(5.0, 6.0, 7.0)).length() < 1e-6);
    }
}
