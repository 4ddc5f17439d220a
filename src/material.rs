//! Materials of the scene graph: glTF's metallic-roughness parameters, optionally textured,
//! turned into a [`Bsdf`] at each hit.

use crate::bsdf::{Bsdf, Lobes, MetallicRoughness};
use crate::geometry::SurfaceHit;
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::texture::{Texture, TextureRef};

/// A surface material (see the scene format's `Material` for the meaning of each field).
#[derive(Debug, Clone)]
pub struct Material {
    /// Diffuse albedo, metal F0 and transmission tint.
    pub base_color: Rgb,
    /// Multiplies `base_color`.
    pub base_color_texture: Option<TextureRef>,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (α = roughness²).
    pub roughness: f32,
    /// Green scales roughness, blue scales metallic.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Index of refraction.
    pub ior: f32,
    /// Strength of the dielectric specular reflection.
    pub specular: f32,
    /// Alpha scales `specular`.
    pub specular_texture: Option<TextureRef>,
    /// Tint of the dielectric F0.
    pub specular_color: Rgb,
    /// Multiplies `specular_color`.
    pub specular_color_texture: Option<TextureRef>,
    /// Transmitted fraction of the dielectric base.
    pub transmission: f32,
    /// Red scales `transmission`.
    pub transmission_texture: Option<TextureRef>,
    /// The absorption coefficient σa (per scene unit) of the medium the surface bounds, when
    /// it bounds one (`None`: thin-walled).
    pub absorption: Option<Rgb>,
    /// Emitted radiance.
    pub emission: Rgb,
    /// Multiplies `emission`.
    pub emission_texture: Option<TextureRef>,
    /// Emits from both faces.
    pub two_sided_emission: bool,
}

fn lookup(textures: &[Texture], r: &Option<TextureRef>, uv: Vec2) -> Option<Rgb> {
    r.as_ref()
        .map(|r| textures[r.texture as usize].lookup(r.transform.transform_point2(uv)))
}

impl Material {
    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Radiance leaving the surface towards `wo` (unit, pointing away from the surface) at a
    /// point with geometric normal `ng` and texture coordinates `uv`.
    pub fn emitted(&self, textures: &[Texture], ng: Vec3, uv: Vec2, wo: Vec3) -> Rgb {
        if !self.is_emissive() || (!self.two_sided_emission && ng.dot(wo) <= 0.0) {
            return Vec3::ZERO;
        }
        match lookup(textures, &self.emission_texture, uv) {
            Some(t) => self.emission * t,
            None => self.emission,
        }
    }

    /// Whether the material can only ever reflect diffusely (no texture can change that), so
    /// its BSDF is the plain Lambertian lobe.
    fn is_lambertian(&self) -> bool {
        self.metallic == 0.0
            && self.transmission == 0.0
            && (self.specular == 0.0 || self.specular_color == Vec3::ZERO)
    }

    /// The scattering function at a hit.
    pub fn bsdf(&self, textures: &[Texture], hit: &SurfaceHit) -> Bsdf {
        let mut base = self.base_color;
        if let Some(t) = lookup(textures, &self.base_color_texture, hit.uv) {
            base *= t;
        }
        // The shading normal must lie on the geometric normal's side.
        let ns = if hit.ns.dot(hit.ng) < 0.0 {
            -hit.ns
        } else {
            hit.ns
        };
        let frame = Frame::from_normal(ns);
        if self.is_lambertian() {
            return Bsdf {
                frame,
                ng: hit.ng,
                lobes: Lobes::Lambert(base),
            };
        }
        let (mut metallic, mut roughness) = (self.metallic, self.roughness);
        if let Some(t) = lookup(textures, &self.metallic_roughness_texture, hit.uv) {
            roughness *= t.y.clamp(0.0, 1.0);
            metallic *= t.z.clamp(0.0, 1.0);
        }
        let mut specular = self.specular;
        if let Some(t) = self.specular_texture.as_ref() {
            specular *= textures[t.texture as usize]
                .lookup_alpha(t.transform.transform_point2(hit.uv))
                .clamp(0.0, 1.0);
        }
        let mut specular_color = self.specular_color;
        if let Some(t) = lookup(textures, &self.specular_color_texture, hit.uv) {
            specular_color *= t;
        }
        let mut transmission = self.transmission;
        if let Some(t) = lookup(textures, &self.transmission_texture, hit.uv) {
            transmission *= t.x.clamp(0.0, 1.0);
        }
        Bsdf {
            frame,
            ng: hit.ng,
            lobes: Lobes::MetallicRoughness(MetallicRoughness {
                base_color: base,
                metallic,
                roughness,
                ior: self.ior,
                specular_factor: specular,
                specular_color,
                transmission,
                thin_walled: self.absorption.is_none(),
                energy_compensation: true,
            }),
        }
    }
}
