//! Materials of the scene graph: lobe weights and parameters, optionally textured, turned into
//! a [`Bsdf`] at each hit.

use crate::bsdf::Bsdf;
use crate::geometry::SurfaceHit;
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::texture::{Texture, TextureRef};

/// A surface material (see the scene format's `Material` for the meaning of each field).
#[derive(Debug, Clone)]
pub struct Material {
    /// Diffuse reflectance / metal tint.
    pub base_color: Rgb,
    /// Multiplies `base_color`.
    pub base_color_texture: Option<TextureRef>,
    /// Diffuse weight; `None` means the rest after specular and transmission.
    pub diffuse: Option<f32>,
    /// Metal lobe weight.
    pub specular: f32,
    /// Dielectric lobe weight.
    pub transmission: f32,
    /// Metal roughness in [0, 1] (α = roughness²).
    pub roughness: f32,
    /// Green scales roughness, blue scales `specular`.
    pub roughness_specular_texture: Option<TextureRef>,
    /// Index of refraction.
    pub ior: f32,
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

    /// The scattering function at a hit.
    pub fn bsdf(&self, textures: &[Texture], hit: &SurfaceHit) -> Bsdf {
        let mut base = self.base_color;
        if let Some(t) = lookup(textures, &self.base_color_texture, hit.uv) {
            base *= t;
        }
        let (mut specular, mut roughness) = (self.specular, self.roughness);
        if let Some(t) = lookup(textures, &self.roughness_specular_texture, hit.uv) {
            roughness *= t.y.clamp(0.0, 1.0);
            specular *= t.z.clamp(0.0, 1.0);
        }
        let diffuse = self
            .diffuse
            .unwrap_or((1.0 - specular - self.transmission).max(0.0));
        // The shading normal must lie on the geometric normal's side.
        let ns = if hit.ns.dot(hit.ng) < 0.0 {
            -hit.ns
        } else {
            hit.ns
        };
        Bsdf {
            frame: Frame::from_normal(ns),
            ng: hit.ng,
            base,
            w_diffuse: diffuse,
            w_specular: specular,
            w_transmission: self.transmission,
            alpha: roughness * roughness,
            ior: self.ior,
        }
    }
}
