//! The glTF side of a material and a light, as plain values, and the mapping between them and
//! lumo's material and light models. Import and export share this so that the exporter's
//! output, read back, gives exactly the values the exporter computed: that equality is how the
//! importer decides whether lumo's exact description in `extras` is still current.

use lumo_schema::{Light, Material, TextureRef};

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

/// The glTF values of a material that lumo maps.
#[derive(Debug, Clone, PartialEq)]
pub struct Pbr {
    /// baseColorFactor.
    pub base_color: [f32; 4],
    /// baseColorTexture.
    pub base_color_texture: Option<TexInfo>,
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
    /// KHR_materials_transmission factor (0 when absent).
    pub transmission: f32,
    /// KHR_materials_ior (1.5 when absent).
    pub ior: f32,
    /// doubleSided.
    pub double_sided: bool,
}

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
/// Mapping (the inverse of [`material_from_pbr`]): metallic = specular weight; transmission
/// factor = transmission / (1 − specular) (glTF's transmission applies to the non-metal part);
/// emissive = emission / max(1, largest channel) with the largest channel as
/// KHR_materials_emissive_strength when above 1; doubleSided = `two_sided_emission` for
/// emitters, true otherwise (lumo renders both faces of every surface).
pub fn pbr_of_material(m: &Material, index_of: &dyn Fn(&str) -> Option<usize>) -> Pbr {
    let info = |r: &Option<TextureRef>| {
        r.as_ref().and_then(|r| {
            index_of(&r.texture).map(|index| TexInfo {
                index,
                tex_coord: 0,
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
    let transmission = if m.specular < 1.0 {
        (m.transmission / (1.0 - m.specular)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let emitter = m.emission != [0.0; 3];
    Pbr {
        base_color: [m.base_color[0], m.base_color[1], m.base_color[2], 1.0],
        base_color_texture: info(&m.base_color_texture),
        metallic: m.specular,
        roughness: m.roughness,
        metallic_roughness_texture: info(&m.roughness_specular_texture),
        emissive,
        emissive_texture: info(&m.emission_texture),
        emissive_strength: strength,
        transmission,
        ior: m.ior,
        double_sided: if emitter { m.two_sided_emission } else { true },
    }
}

/// The lumo material for glTF values. `name_of` maps a texture use to a lumo texture name.
///
/// glTF's metal-rough model is a metal layer (weight `metallic`) over a dielectric base; the
/// base is transmissive with weight `transmission`, otherwise diffuse. In lumo's lobe weights:
/// specular = metallic, transmission = (1 − metallic) · transmission, diffuse = the rest
/// (left implicit). The dielectric's own specular coat over the diffuse base (F0 = 0.04) has no
/// lumo lobe and is dropped. roughness = roughnessFactor; the metallicRoughness texture's green
/// (roughness) and blue (metallic) channels scale roughness and specular. emission =
/// emissiveFactor × emissive strength. doubleSided → two-sided emission for emitters.
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
            })
        })
    };
    let t = p.transmission.clamp(0.0, 1.0);
    // With a metallicRoughness texture the metal weight varies per texel (factor × blue), but
    // lumo's transmission weight is one number. Files that combine them (e.g. Khronos'
    // TransmissionRoughnessTest: metallicFactor 1 by default, a texture with blue = 0) mean
    // glass where transmission is set, so then: transmission = t, specular = factor × (1 − t).
    let (metallic, transmission) = if p.metallic_roughness_texture.is_some() && t > 0.0 {
        (p.metallic.clamp(0.0, 1.0) * (1.0 - t), t)
    } else {
        let m = p.metallic.clamp(0.0, 1.0);
        (m, (1.0 - m) * t)
    };
    let emission = p.emissive.map(|c| (c * p.emissive_strength).max(0.0));
    Material {
        base_color: [0, 1, 2].map(|k| p.base_color[k].clamp(0.0, 1.0)),
        base_color_texture: r(&p.base_color_texture, true),
        diffuse: None,
        specular: metallic,
        transmission: transmission.clamp(0.0, 1.0 - metallic),
        roughness: p.roughness.clamp(0.0, 1.0),
        roughness_specular_texture: r(&p.metallic_roughness_texture, false),
        ior: if p.ior > 0.0 && p.ior.is_finite() {
            p.ior
        } else {
            1.5
        },
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
