//! The glTF side of a material and a light, as plain values, and the mapping between them and
//! lumo's material and light models. Import and export share this so that the exporter's
//! output, read back, gives exactly the values the exporter computed: that equality is how the
//! importer decides whether lumo's exact description in `extras` is still current.

use lumo_schema::{AlphaMode, Light, Material, TextureRef, Volume};

/// Luminous efficacy used to convert glTF's photometric light units to lumo's radiometric
/// ones: 683 lm/W, the peak of the photopic curve (555 nm) that defines the candela. So
/// W·sr⁻¹ = cd / 683 and W·m⁻² = lx / 683, per channel of `color × intensity`.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// One texture use: `textureInfo` plus KHR_texture_transform.
#[derive(Debug, Clone, PartialEq)]
pub struct TexInfo {
    /// Index into `textures`.
    pub index: usize,
    /// TEXCOORD set (the transform's override when present).
    pub tex_coord: u32,
    /// KHR_texture_transform (offset, rotation in radians, scale) in glTF's top-left UV
    /// convention; `None` for the identity.
    pub transform: Option<([f32; 2], f32, [f32; 2])>,
}

/// KHR_texture_transform's values; read from JSON for the texture uses the gltf crate gives no
/// transform accessor for (`normalTexture`, and the extensions it does not parse).
#[derive(serde::Deserialize)]
pub(super) struct RawTransform {
    #[serde(default)]
    offset: [f32; 2],
    #[serde(default)]
    rotation: f32,
    #[serde(default = "unit_scale")]
    scale: [f32; 2],
    #[serde(rename = "texCoord")]
    tex_coord: Option<u32>,
}

fn unit_scale() -> [f32; 2] {
    [1.0, 1.0]
}

impl TexInfo {
    /// A texture use from its texture index, its own `texCoord` and its KHR_texture_transform
    /// (whose `texCoord`, when given, overrides the use's).
    fn new(index: usize, tex_coord: u32, transform: Option<RawTransform>) -> TexInfo {
        TexInfo {
            index,
            tex_coord: transform
                .as_ref()
                .and_then(|t| t.tex_coord)
                .unwrap_or(tex_coord),
            transform: transform
                .map(|t| (t.offset, t.rotation, t.scale))
                .filter(|t| *t != ([0.0, 0.0], 0.0, [1.0, 1.0])),
        }
    }

    /// A `textureInfo` the gltf crate parsed.
    pub(super) fn of_info(i: &gltf::texture::Info) -> TexInfo {
        let transform = i.texture_transform().map(|t| RawTransform {
            offset: t.offset(),
            rotation: t.rotation(),
            scale: t.scale(),
            tex_coord: t.tex_coord(),
        });
        TexInfo::new(i.texture().index(), i.tex_coord(), transform)
    }

    /// A `normalTexture` (the gltf crate has no transform accessor for it).
    pub(super) fn of_normal(n: &gltf::material::NormalTexture) -> TexInfo {
        let transform = n
            .extension_value("KHR_texture_transform")
            .and_then(|v| serde_json::from_value::<RawTransform>(v.clone()).ok());
        TexInfo::new(n.texture().index(), n.tex_coord(), transform)
    }

    /// A `textureInfo` as JSON, in an extension the gltf crate does not parse; `None` when it
    /// has no valid index.
    pub(super) fn from_json(v: &serde_json::Value) -> Option<TexInfo> {
        let index = usize::try_from(v.get("index")?.as_u64()?).ok()?;
        let own = v
            .get("texCoord")
            .and_then(serde_json::Value::as_u64)
            .unwrap_or(0) as u32;
        let transform = v
            .get("extensions")
            .and_then(|e| e.get("KHR_texture_transform"))
            .and_then(|t| serde_json::from_value::<RawTransform>(t.clone()).ok());
        Some(TexInfo::new(index, own, transform))
    }
}

/// The glTF values of a material that lumo maps.
#[derive(Debug, Clone, PartialEq)]
pub struct Pbr {
    /// baseColorFactor.
    pub base_color: [f32; 4],
    /// baseColorTexture.
    pub base_color_texture: Option<TexInfo>,
    /// alphaMode.
    pub alpha_mode: AlphaMode,
    /// alphaCutoff (0.5 when absent).
    pub alpha_cutoff: f32,
    /// normalTexture and its scale.
    pub normal_texture: Option<(TexInfo, f32)>,
    /// metallicFactor.
    pub metallic: f32,
    /// roughnessFactor.
    pub roughness: f32,
    /// metallicRoughnessTexture.
    pub metallic_roughness_texture: Option<TexInfo>,
    /// emissiveFactor.
    pub emissive: [f32; 3],
    /// emissiveTexture.
    pub emissive_texture: Option<TexInfo>,
    /// KHR_materials_emissive_strength (1 when absent).
    pub emissive_strength: f32,
    /// KHR_materials_ior (1.5 when absent).
    pub ior: f32,
    /// KHR_materials_specular specularFactor (1 when absent).
    pub specular: f32,
    /// KHR_materials_specular specularTexture (alpha channel).
    pub specular_texture: Option<TexInfo>,
    /// KHR_materials_specular specularColorFactor (white when absent).
    pub specular_color: [f32; 3],
    /// KHR_materials_specular specularColorTexture (sRGB).
    pub specular_color_texture: Option<TexInfo>,
    /// KHR_materials_transmission factor (0 when absent).
    pub transmission: f32,
    /// KHR_materials_transmission texture (red channel).
    pub transmission_texture: Option<TexInfo>,
    /// KHR_materials_volume, when present with a non-zero thickness (glTF's thickness 0 means
    /// thin-walled): (attenuationColor, attenuationDistance; `None` for +∞).
    pub volume: Option<([f32; 3], Option<f32>)>,
    /// KHR_materials_clearcoat: factor, texture (R), roughness, roughness texture (G), normal
    /// texture and scale (zero factor when absent).
    pub clearcoat: f32,
    /// clearcoatTexture.
    pub clearcoat_texture: Option<TexInfo>,
    /// clearcoatRoughnessFactor.
    pub clearcoat_roughness: f32,
    /// clearcoatRoughnessTexture.
    pub clearcoat_roughness_texture: Option<TexInfo>,
    /// clearcoatNormalTexture and its scale.
    pub clearcoat_normal_texture: Option<(TexInfo, f32)>,
    /// KHR_materials_sheen sheenColorFactor (black when absent).
    pub sheen_color: [f32; 3],
    /// sheenColorTexture (sRGB).
    pub sheen_color_texture: Option<TexInfo>,
    /// sheenRoughnessFactor.
    pub sheen_roughness: f32,
    /// sheenRoughnessTexture (alpha channel).
    pub sheen_roughness_texture: Option<TexInfo>,
    /// KHR_materials_unlit.
    pub unlit: bool,
    /// doubleSided.
    pub double_sided: bool,
}

/// The thicknessFactor lumo writes with KHR_materials_volume. A path tracer follows the real
/// geometry, so lumo keeps no thickness; glTF only needs it non-zero to mean "not thin-walled"
/// (rasterizers use it to approximate refraction; 1 scene unit is their default scale).
pub const EXPORTED_THICKNESS: f32 = 1.0;

/// lumo → glTF texture transform. lumo maps uv_l' = T(o_l) R(r) S(s) uv_l with bottom-left
/// coordinates and a counter-clockwise rotation; glTF maps uv_g' = T(o_g) R_g(r) S(s) uv_g with
/// top-left coordinates uv_g = F(uv_l) = (u, 1 − v) and R_g = [[cos, sin], [−sin, cos]]. The
/// lumo map must equal F ∘ glTF map ∘ F. Since F = T(0, 1) S(1, −1) and S(1, −1) R_g S(1, −1)
/// is the counter-clockwise rotation, that is T(0, 1) T(o_gx, −o_gy) R(r) S(s) T(0, −1), and
/// moving the last translation to the front (R S (0, −1) = (s_y sin r, −s_y cos r)) gives
///   o_l = (o_gx + s_y sin r, 1 − o_gy − s_y cos r),   rotation and scale unchanged.
pub fn transform_to_gltf(r: &TextureRef) -> Option<([f32; 2], f32, [f32; 2])> {
    if r.offset == [0.0, 0.0] && r.rotation_deg == 0.0 && r.scale == [1.0, 1.0] {
        return None;
    }
    let rot = f64::from(r.rotation_deg).to_radians();
    let sy = f64::from(r.scale[1]);
    let ox = f64::from(r.offset[0]) - sy * rot.sin();
    let oy = 1.0 - f64::from(r.offset[1]) - sy * rot.cos();
    Some(([ox as f32, oy as f32], rot as f32, r.scale))
}

/// glTF → lumo texture transform: the inverse of [`transform_to_gltf`].
pub fn transform_from_gltf(t: Option<([f32; 2], f32, [f32; 2])>) -> ([f32; 2], f32, [f32; 2]) {
    let Some((o, rot, s)) = t else {
        return ([0.0, 0.0], 0.0, [1.0, 1.0]);
    };
    let r = f64::from(rot);
    let sy = f64::from(s[1]);
    let ox = f64::from(o[0]) + sy * r.sin();
    let oy = 1.0 - f64::from(o[1]) - sy * r.cos();
    ([ox as f32, oy as f32], r.to_degrees() as f32, s)
}

/// The glTF values for a lumo material. `index_of` maps a lumo texture name to a glTF texture
/// index (`None`: the texture is not exported, so the use is dropped).
///
/// lumo's material is glTF's, so the mapping is one to one (the inverse of
/// [`material_from_pbr`]), except: emissive = emission / max(1, largest channel) with the
/// largest channel as KHR_materials_emissive_strength when above 1; doubleSided =
/// `two_sided_emission` for emitters, true otherwise (lumo renders both faces of every
/// surface).
pub fn pbr_of_material(m: &Material, index_of: &dyn Fn(&str) -> Option<usize>) -> Pbr {
    let info = |r: &Option<TextureRef>| {
        r.as_ref().and_then(|r| {
            index_of(&r.texture).map(|index| TexInfo {
                index,
                tex_coord: r.tex_coord,
                transform: transform_to_gltf(r),
            })
        })
    };
    let peak = m.emission.iter().copied().fold(0.0f32, f32::max);
    let (emissive, strength) = if peak > 1.0 {
        (m.emission.map(|c| c / peak), peak)
    } else {
        (m.emission, 1.0)
    };
    let emitter = m.emission != [0.0; 3];
    Pbr {
        base_color: [m.base_color[0], m.base_color[1], m.base_color[2], m.alpha],
        base_color_texture: info(&m.base_color_texture),
        alpha_mode: m.alpha_mode,
        alpha_cutoff: m.alpha_cutoff,
        normal_texture: info(&m.normal_texture).map(|t| (t, m.normal_scale)),
        metallic: m.metallic,
        roughness: m.roughness,
        metallic_roughness_texture: info(&m.metallic_roughness_texture),
        emissive,
        emissive_texture: info(&m.emission_texture),
        emissive_strength: strength,
        ior: m.ior,
        specular: m.specular,
        specular_texture: info(&m.specular_texture),
        specular_color: m.specular_color,
        specular_color_texture: info(&m.specular_color_texture),
        transmission: m.transmission,
        transmission_texture: info(&m.transmission_texture),
        volume: m
            .volume
            .as_ref()
            .map(|v| (v.attenuation_color, v.attenuation_distance)),
        clearcoat: m.clearcoat,
        clearcoat_texture: info(&m.clearcoat_texture),
        clearcoat_roughness: m.clearcoat_roughness,
        clearcoat_roughness_texture: info(&m.clearcoat_roughness_texture),
        clearcoat_normal_texture: info(&m.clearcoat_normal_texture)
            .map(|t| (t, m.clearcoat_normal_scale)),
        sheen_color: m.sheen_color,
        sheen_color_texture: info(&m.sheen_color_texture),
        sheen_roughness: m.sheen_roughness,
        sheen_roughness_texture: info(&m.sheen_roughness_texture),
        unlit: m.unlit,
        double_sided: if emitter { m.two_sided_emission } else { true },
    }
}

/// The lumo material for glTF values. `name_of` maps a texture use (and whether it holds
/// colour, sRGB-encoded) to a lumo texture name.
///
/// One to one: each glTF factor and texture becomes the lumo field of the same name
/// (`emissiveFactor` × emissive strength → `emission`, KHR_materials_volume with a non-zero
/// thickness → `volume`); factors are clamped into their ranges; doubleSided → two-sided
/// emission for emitters.
pub fn material_from_pbr(
    p: &Pbr,
    name_of: &mut dyn FnMut(&TexInfo, bool) -> Option<String>,
) -> Material {
    let mut r = |t: &Option<TexInfo>, srgb: bool| {
        t.as_ref().and_then(|t| {
            let name = name_of(t, srgb)?;
            let (offset, rotation_deg, scale) = transform_from_gltf(t.transform);
            Some(TextureRef {
                texture: name,
                offset,
                rotation_deg,
                scale,
                tex_coord: t.tex_coord.min(1),
            })
        })
    };
    let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let mut normal_map = |n: &Option<(TexInfo, f32)>| {
        n.as_ref().and_then(|(t, scale)| {
            let scale = if scale.is_finite() { *scale } else { 1.0 };
            r(&Some(t.clone()), false).map(|t| (t, scale))
        })
    };
    let normal = normal_map(&p.normal_texture);
    let coat_normal = normal_map(&p.clearcoat_normal_texture);
    let emission = p.emissive.map(|c| (c * p.emissive_strength).max(0.0));
    Material {
        base_color: [0, 1, 2].map(|k| unit(p.base_color[k])),
        base_color_texture: r(&p.base_color_texture, true),
        alpha: unit(p.base_color[3]),
        alpha_mode: p.alpha_mode,
        alpha_cutoff: if p.alpha_mode == AlphaMode::Mask {
            unit(p.alpha_cutoff)
        } else {
            0.5
        },
        normal_texture: normal.as_ref().map(|(t, _)| t.clone()),
        normal_scale: normal.map_or(1.0, |(_, s)| s),
        metallic: unit(p.metallic),
        roughness: unit(p.roughness),
        metallic_roughness_texture: r(&p.metallic_roughness_texture, false),
        ior: if p.ior > 0.0 && p.ior.is_finite() {
            p.ior
        } else {
            1.5
        },
        specular: unit(p.specular),
        specular_texture: r(&p.specular_texture, false),
        specular_color: p
            .specular_color
            .map(|c| if c.is_finite() { c.max(0.0) } else { 1.0 }),
        specular_color_texture: r(&p.specular_color_texture, true),
        transmission: unit(p.transmission),
        transmission_texture: r(&p.transmission_texture, false),
        volume: p.volume.map(|(color, distance)| Volume {
            attenuation_color: color.map(|c| if c > 0.0 { c.min(1.0) } else { 1e-6 }),
            attenuation_distance: distance.filter(|d| *d > 0.0 && d.is_finite()),
        }),
        clearcoat: unit(p.clearcoat),
        clearcoat_texture: r(&p.clearcoat_texture, false),
        clearcoat_roughness: unit(p.clearcoat_roughness),
        clearcoat_roughness_texture: r(&p.clearcoat_roughness_texture, false),
        clearcoat_normal_texture: coat_normal.as_ref().map(|(t, _)| t.clone()),
        clearcoat_normal_scale: coat_normal.map_or(1.0, |(_, s)| s),
        sheen_color: p.sheen_color.map(unit),
        sheen_color_texture: r(&p.sheen_color_texture, true),
        sheen_roughness: unit(p.sheen_roughness),
        sheen_roughness_texture: r(&p.sheen_roughness_texture, false),
        unlit: p.unlit,
        emission,
        emission_texture: r(&p.emissive_texture, true),
        two_sided_emission: p.double_sided && emission != [0.0; 3],
    }
}

/// The glTF values of a KHR_lights_punctual light.
#[derive(Debug, Clone, PartialEq)]
pub struct LightValues {
    /// "point", "spot" or "directional".
    pub kind: &'static str,
    /// Linear RGB colour in [0, 1].
    pub color: [f32; 3],
    /// Candela (point, spot) or lux (directional).
    pub intensity: f32,
    /// Spot cone angles in radians (inner, outer).
    pub cone: Option<(f32, f32)>,
}

/// Largest f32 not above π/2 (the validator compares the f32 widened to double): one ulp below
/// `FRAC_PI_2`, which rounds up.
const HALF_PI_F32: f32 = f32::from_bits(std::f32::consts::FRAC_PI_2.to_bits() - 1);

/// lumo light → glTF values: intensity = largest channel × 683, colour = channels / largest.
pub fn light_values(l: &Light) -> LightValues {
    let split = |rgb: [f32; 3]| {
        let peak = rgb.iter().copied().fold(0.0f32, f32::max);
        if peak > 0.0 {
            (rgb.map(|c| c / peak), peak * LUMENS_PER_WATT)
        } else {
            ([1.0; 3], 0.0)
        }
    };
    let (kind, rgb, cone) = match l {
        Light::Point(p) => ("point", p.intensity, None),
        Light::Directional(d) => ("directional", d.irradiance, None),
        Light::Spot(s) => {
            let outer = (f64::from(s.outer_angle_deg).to_radians() as f32).min(HALF_PI_F32);
            // glTF requires inner < outer.
            let inner =
                (f64::from(s.inner_angle_deg).to_radians() as f32).min(outer * (1.0 - 1e-6));
            ("spot", s.intensity, Some((inner, outer)))
        }
    };
    let (color, intensity) = split(rgb);
    LightValues {
        kind,
        color,
        intensity,
        cone,
    }
}

/// Radiometric intensity (W·sr⁻¹ or W·m⁻²) of glTF colour × photometric intensity.
pub fn radiometric(v: &LightValues) -> [f32; 3] {
    v.color
        .map(|c| (c.max(0.0) * v.intensity.max(0.0)) / LUMENS_PER_WATT)
}
