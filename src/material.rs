//! Materials of the scene graph: glTF's metallic-roughness parameters, optionally textured,
//! turned into a [`Bsdf`] at each hit.

use crate::bsdf::layered::{Clearcoat, Layered, Sheen};
use crate::bsdf::{Bsdf, Lobes, MetallicRoughness};
use crate::geometry::{OpacityInputs, SurfaceHit};
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::texture::{Texture, TextureRef};

/// How a material's alpha makes it transparent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlphaMode {
    /// Always opaque.
    Opaque,
    /// Cut away where alpha is below this cutoff.
    Mask(f32),
    /// Transparent with probability 1 − alpha.
    Blend,
}

/// A surface material (see the scene format's `Material` for the meaning of each field).
#[derive(Debug, Clone)]
pub struct Material {
    /// Diffuse albedo, metal F0 and transmission tint.
    pub base_color: Rgb,
    /// Multiplies `base_color` (and its alpha `alpha`).
    pub base_color_texture: Option<TextureRef>,
    /// Coverage.
    pub alpha: f32,
    /// How `alpha` is used.
    pub alpha_mode: AlphaMode,
    /// Tangent-space normal map.
    pub normal_texture: Option<TextureRef>,
    /// Scales the normal map's x and y.
    pub normal_scale: f32,
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
    /// Clear-coat strength.
    pub clearcoat: f32,
    /// Red scales `clearcoat`.
    pub clearcoat_texture: Option<TextureRef>,
    /// Clear-coat roughness.
    pub clearcoat_roughness: f32,
    /// Green scales `clearcoat_roughness`.
    pub clearcoat_roughness_texture: Option<TextureRef>,
    /// The clear coat's normal map.
    pub clearcoat_normal_texture: Option<TextureRef>,
    /// Scales the clear-coat normal map's x and y.
    pub clearcoat_normal_scale: f32,
    /// Sheen colour (black: no sheen).
    pub sheen_color: Rgb,
    /// Multiplies `sheen_color`.
    pub sheen_color_texture: Option<TextureRef>,
    /// Sheen roughness.
    pub sheen_roughness: f32,
    /// Alpha scales `sheen_roughness`.
    pub sheen_roughness_texture: Option<TextureRef>,
    /// Shows the base colour without shading.
    pub unlit: bool,
    /// Emitted radiance.
    pub emission: Rgb,
    /// Multiplies `emission`.
    pub emission_texture: Option<TextureRef>,
    /// Emits from both faces.
    pub two_sided_emission: bool,
}

fn lookup(textures: &[Texture], r: &Option<TextureRef>, uv: Vec2, uv1: Vec2) -> Option<Rgb> {
    r.as_ref()
        .map(|r| textures[r.texture as usize].lookup(r.coords(uv, uv1)))
}

impl Material {
    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Radiance leaving the surface towards `wo` (unit, pointing away from the surface) at a
    /// point with geometric normal `ng` and texture coordinate sets `uv`, `uv1`.
    pub fn emitted(&self, textures: &[Texture], ng: Vec3, uv: Vec2, uv1: Vec2, wo: Vec3) -> Rgb {
        if !self.is_emissive() || (!self.two_sided_emission && ng.dot(wo) <= 0.0) {
            return Vec3::ZERO;
        }
        match lookup(textures, &self.emission_texture, uv, uv1) {
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
            && self.clearcoat == 0.0
            && self.sheen_color == Vec3::ZERO
    }

    /// For an unlit material, the colour a ray that reaches `hit` sees: base colour × texture
    /// × vertex colour. `None` for lit materials.
    pub fn unlit_radiance(&self, textures: &[Texture], hit: &SurfaceHit) -> Option<Rgb> {
        if !self.unlit {
            return None;
        }
        let mut c = self.base_color * hit.color.truncate();
        if let Some(t) = lookup(textures, &self.base_color_texture, hit.uv, hit.uv1) {
            c *= t;
        }
        Some(c)
    }

    /// A tangent-space normal map applied to the unit normal `n` (on the front side), or `n`
    /// where the hit has no tangent frame.
    fn mapped_normal(
        textures: &[Texture],
        map: &TextureRef,
        scale: f32,
        hit: &SurfaceHit,
        n: Vec3,
    ) -> Vec3 {
        if hit.tangent.w == 0.0 {
            return n;
        }
        let c = textures[map.texture as usize].lookup(map.coords(hit.uv, hit.uv1));
        let m = Vec3::new(
            (2.0 * c.x - 1.0) * scale,
            (2.0 * c.y - 1.0) * scale,
            2.0 * c.z - 1.0,
        );
        // Gram–Schmidt: the tangent perpendicular to the interpolated normal.
        let t = (hit.tangent.truncate() - n * n.dot(hit.tangent.truncate())).normalize_or_zero();
        if t == Vec3::ZERO {
            return n;
        }
        let b = n.cross(t) * hit.tangent.w;
        let mapped = (t * m.x + b * m.y + n * m.z).normalize_or_zero();
        if mapped == Vec3::ZERO {
            n
        } else {
            mapped
        }
    }

    /// The clear coat and sheen at a hit, if the material has them.
    fn layers(
        &self,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3,
        front_normal: Vec3,
    ) -> (Option<Clearcoat>, Option<Sheen>) {
        let (uv, uv1) = (hit.uv, hit.uv1);
        let clearcoat = (self.clearcoat > 0.0).then(|| {
            let mut weight = self.clearcoat;
            if let Some(t) = lookup(textures, &self.clearcoat_texture, uv, uv1) {
                weight *= t.x.clamp(0.0, 1.0);
            }
            let mut roughness = self.clearcoat_roughness;
            if let Some(t) = lookup(textures, &self.clearcoat_roughness_texture, uv, uv1) {
                roughness *= t.y.clamp(0.0, 1.0);
            }
            let n = match &self.clearcoat_normal_texture {
                Some(map) => Self::mapped_normal(
                    textures,
                    map,
                    self.clearcoat_normal_scale,
                    hit,
                    front_normal,
                ),
                None => front_normal,
            };
            Clearcoat {
                weight,
                alpha: roughness * roughness,
                frame: Frame::from_normal(valid_reflection_normal(n, hit.ng, wo)),
            }
        });
        let sheen = (self.sheen_color != Vec3::ZERO).then(|| {
            let mut color = self.sheen_color;
            if let Some(t) = lookup(textures, &self.sheen_color_texture, uv, uv1) {
                color *= t;
            }
            let mut roughness = self.sheen_roughness;
            if let Some(t) = &self.sheen_roughness_texture {
                roughness *= textures[t.texture as usize]
                    .lookup_alpha(t.coords(uv, uv1))
                    .clamp(0.0, 1.0);
            }
            Sheen {
                color,
                alpha: roughness * roughness,
            }
        });
        (clearcoat, sheen)
    }

    /// Whether the material is ever transparent.
    pub fn has_alpha(&self) -> bool {
        self.alpha_mode != AlphaMode::Opaque
    }

    /// The probability in [0, 1] that a ray meeting the surface at `hit` stops there (1 for
    /// opaque materials): alpha × texture alpha × vertex alpha, thresholded for `Mask`.
    pub fn opacity(&self, textures: &[Texture], at: &OpacityInputs) -> f32 {
        if self.alpha_mode == AlphaMode::Opaque {
            return 1.0;
        }
        let mut alpha = self.alpha * at.color_alpha;
        if let Some(r) = &self.base_color_texture {
            alpha *= textures[r.texture as usize].lookup_alpha(r.coords(at.uv, at.uv1));
        }
        match self.alpha_mode {
            AlphaMode::Mask(cutoff) => {
                if alpha >= cutoff {
                    1.0
                } else {
                    0.0
                }
            }
            _ => alpha.clamp(0.0, 1.0),
        }
    }

    /// The shading normal at a hit, on the geometric normal's side: the interpolated normal,
    /// perturbed by the normal map (glTF: n = normalize(T·x + B·y + N·z) with (x, y) scaled,
    /// B = cross(N, T)·w).
    ///
    /// Where the mirror reflection of `wo` about it dips under the surface, specular lobes would
    /// be black (the black fringes of strong normal maps); Cycles bends the normal of its glossy
    /// closures towards the geometric one until the reflection clears the surface
    /// ([`valid_reflection_normal`]) but leaves its diffuse closures with the unbent normal, so
    /// normal-mapped bevels darken where the tilted diffuse lobe reaches under the surface.
    /// lumo's BSDF has one shading frame, so the bent and unbent normals are blended by
    /// `specular_share`, the fraction of the surface without a diffuse base (metallic, plus the
    /// transmissive part of the rest): a diffuse surface keeps the unbent normal (unless it faces
    /// away from the viewer), a metal gets the bent one. Measured on NormalTangentTest's bevels:
    /// 0.256 against Cycles' 0.252 (0.283 with the bent normal everywhere, black on its smooth
    /// metal with the unbent one).
    fn shading_normal(
        &self,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3,
        specular_share: f32,
    ) -> Vec3 {
        let mut n = front_shading_normal(hit);
        if let Some(map) = &self.normal_texture {
            n = Self::mapped_normal(textures, map, self.normal_scale, hit, n);
        } else if n == hit.ng {
            // Flat shading: the geometric normal reflects every view above the surface.
            return n;
        }
        let bent = valid_reflection_normal(n, hit.ng, wo);
        if bent == n {
            return n;
        }
        // The view side of the surface: a normal facing away from the viewer is always bent.
        let side = if wo.dot(hit.ng) < 0.0 { -1.0 } else { 1.0 };
        if n.dot(wo) * side <= 0.0 {
            return bent;
        }
        let s = specular_share.clamp(0.0, 1.0);
        (n * (1.0 - s) + bent * s).normalize_or(bent)
    }

    /// The scattering function at a hit seen from direction `wo` (unit, away from the surface).
    #[inline]
    pub fn bsdf(&self, textures: &[Texture], hit: &SurfaceHit, wo: Vec3) -> Bsdf {
        if let Some((albedo, frame)) = self.lambert(textures, hit, wo) {
            // The common case stays small enough to inline into the integrators.
            return Bsdf {
                frame,
                ng: hit.ng,
                lobes: Lobes::Lambert(albedo),
            };
        }
        self.glossy_bsdf(textures, hit, wo, self.base_color_at(textures, hit))
    }

    /// For a Lambertian material ([`is_plain_lambertian`](Self::is_plain_lambertian) or
    /// not), the albedo and shading frame of its [`bsdf`](Self::bsdf) at `hit` seen from `wo`,
    /// without the rest of a [`Bsdf`]; `None` for every other material.
    #[inline]
    pub fn lambert(
        &self,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3,
    ) -> Option<(Rgb, Frame)> {
        if !self.is_lambertian() {
            return None;
        }
        let albedo = self.base_color_at(textures, hit);
        let frame = Frame::from_normal(self.shading_normal(textures, hit, wo, 0.0));
        Some((albedo, frame))
    }

    /// For a Lambertian material seen at `hit`, whether its shading normal is the surface's
    /// geometric one: no normal map, and the interpolated normal, turned to the geometric
    /// normal's side, equals it (flat shading). There [`lambert`](Self::lambert)'s frame is
    /// [`Frame::from_normal`] of that normal, whatever the view.
    #[inline]
    pub fn shades_flat(&self, hit: &SurfaceHit) -> bool {
        self.normal_texture.is_none() && front_shading_normal(hit) == hit.ng
    }

    /// The albedo of a Lambertian material at `hit` (the first half of
    /// [`lambert`](Self::lambert)).
    #[inline]
    pub fn lambert_albedo(&self, textures: &[Texture], hit: &SurfaceHit) -> Rgb {
        self.base_color_at(textures, hit)
    }

    /// Whether the material is Lambertian, lit and does not emit: a surface where a path only
    /// scatters diffusely and finds no light of its own (the common vertex of interiors, which
    /// the path tracer runs in SIMD lanes).
    #[inline]
    pub fn is_plain_lambertian(&self) -> bool {
        self.is_lambertian() && !self.unlit && !self.is_emissive()
    }

    /// The albedo of every hit on a surface without vertex colours where the material is
    /// plain Lambertian ([`is_plain_lambertian`](Self::is_plain_lambertian)) with neither a
    /// base-colour texture nor a normal map: its base colour (as
    /// [`lambert_albedo`](Self::lambert_albedo) gives it, a white vertex colour changing no
    /// bit). `None` for other materials.
    pub fn route_albedo(&self) -> Option<Rgb> {
        (self.is_plain_lambertian()
            && self.base_color_texture.is_none()
            && self.normal_texture.is_none())
        .then_some(self.base_color)
    }

    /// The base colour at `hit`: factor × texture × vertex colour.
    #[inline]
    fn base_color_at(&self, textures: &[Texture], hit: &SurfaceHit) -> Rgb {
        let mut base = self.base_color * hit.color.truncate();
        if let Some(t) = lookup(textures, &self.base_color_texture, hit.uv, hit.uv1) {
            base *= t;
        }
        base
    }

    /// [`Material::bsdf`] for every material that is not purely Lambertian.
    #[inline(never)]
    fn glossy_bsdf(&self, textures: &[Texture], hit: &SurfaceHit, wo: Vec3, base: Rgb) -> Bsdf {
        let (uv, uv1) = (hit.uv, hit.uv1);
        let (mut metallic, mut roughness) = (self.metallic, self.roughness);
        if let Some(t) = lookup(textures, &self.metallic_roughness_texture, uv, uv1) {
            roughness *= t.y.clamp(0.0, 1.0);
            metallic *= t.z.clamp(0.0, 1.0);
        }
        let mut specular = self.specular;
        if let Some(t) = self.specular_texture.as_ref() {
            specular *= textures[t.texture as usize]
                .lookup_alpha(t.coords(uv, uv1))
                .clamp(0.0, 1.0);
        }
        let mut specular_color = self.specular_color;
        if let Some(t) = lookup(textures, &self.specular_color_texture, uv, uv1) {
            specular_color *= t;
        }
        let mut transmission = self.transmission;
        if let Some(t) = lookup(textures, &self.transmission_texture, uv, uv1) {
            transmission *= t.x.clamp(0.0, 1.0);
        }
        let frame = Frame::from_normal(self.shading_normal(
            textures,
            hit,
            wo,
            metallic + (1.0 - metallic) * transmission,
        ));
        let base = MetallicRoughness {
            base_color: base,
            metallic,
            roughness,
            ior: self.ior,
            specular_factor: specular,
            specular_color,
            transmission,
            thin_walled: self.absorption.is_none(),
            energy_compensation: true,
        };
        let front = if hit.ns.dot(hit.ng) < 0.0 {
            -hit.ns
        } else {
            hit.ns
        };
        let lobes = match self.layers(textures, hit, wo, front) {
            (None, None) => {
                let outgoing = base.outgoing_for(&frame, wo);
                Lobes::MetallicRoughness(base, outgoing)
            }
            (clearcoat, sheen) => Lobes::Layered(Box::new(Layered {
                base,
                clearcoat,
                sheen,
            })),
        };
        Bsdf {
            frame,
            ng: hit.ng,
            lobes,
        }
    }
}

/// `n` (unit, on `ng`'s side of the surface), or if the mirror reflection of `wo` about it
/// dips below a small elevation above the geometric surface, the normal closest to `n` in the
/// plane of `n` and `ng` whose reflection reaches that elevation. The elevation is that of
/// Cycles' `ensure_valid_reflection`: min(0.9·(wo·ng), 0.01).
///
/// In closed form, as Cycles solves it: with m = cos θ·ng + sin θ·x (x the unit direction of
/// n's tangential part) and wo = (i_x, ·, i_z) in (x, ·, ng), the reflection's elevation is
/// 2(m·wo)(m·ng) − i_z = i_x sin 2θ + i_z cos 2θ = r cos(2θ − φ₀) with r = |(i_x, i_z)| and
/// φ₀ = atan2(i_x, i_z). It is i_z (valid) at θ = 0 and falls through the threshold t at
/// 2θ = φ₀ + acos(t/r), whose cosine is (i_z t − i_x √(r² − t²)) / r²; cos θ and sin θ follow
/// from the half angle, without trigonometric calls (a bisection with sin and cos took 3 % of a
/// glass scene's time).
fn valid_reflection_normal(n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    // Seen from the back, the surface is mirrored: work on wo's side.
    let (ng, n, flip) = if wo.dot(ng) < 0.0 {
        (-ng, -n, true)
    } else {
        (ng, n, false)
    };
    let threshold = (0.9 * wo.dot(ng)).min(0.01);
    if (2.0 * n.dot(wo) * n - wo).dot(ng) >= threshold {
        return if flip { -n } else { n };
    }
    let x = (n - ng * n.dot(ng)).normalize_or_zero();
    let (ix, iz) = (wo.dot(x), wo.dot(ng));
    let r2 = ix * ix + iz * iz;
    let m = if r2 <= 0.0 {
        ng
    } else {
        let cos_2theta = ((iz * threshold - ix * (r2 - threshold * threshold).max(0.0).sqrt())
            / r2)
            .clamp(-1.0, 1.0);
        let cos_theta = (0.5 * (1.0 + cos_2theta)).sqrt();
        let sin_theta = (0.5 * (1.0 - cos_2theta)).sqrt();
        (ng * cos_theta + x * sin_theta).normalize()
    };
    if flip {
        -m
    } else {
        m
    }
}

/// The hit's interpolated normal turned to the side of its geometric normal.
#[inline]
fn front_shading_normal(hit: &SurfaceHit) -> Vec3 {
    if hit.ns.dot(hit.ng) < 0.0 {
        -hit.ns
    } else {
        hit.ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bent_normals_reflect_the_view_above_the_surface() {
        let ng = Vec3::Z;
        for (n, wo) in [
            (Vec3::new(0.8, 0.0, 0.6), Vec3::new(-0.9, 0.0, 0.1)),
            (Vec3::new(0.0, 0.7, 0.3), Vec3::new(0.0, -0.99, 0.02)),
            (Vec3::new(0.5, 0.5, 0.2), Vec3::new(-0.6, -0.6, -0.2)),
        ] {
            let (n, wo) = (n.normalize(), wo.normalize());
            let m = valid_reflection_normal(n, ng, wo);
            let side = wo.dot(ng).signum();
            let r = 2.0 * m.dot(wo) * m - wo;
            assert!((m.length() - 1.0).abs() < 1e-5);
            assert!(
                r.dot(ng) * side >= (0.9 * wo.dot(ng).abs()).min(0.01) - 1e-4,
                "{m:?}"
            );
            // Still in the plane of n and ng, and not bent further than needed.
            assert!(m.dot(ng.cross(n)).abs() < 1e-4);
        }
        // A valid normal is kept exactly.
        let n = Vec3::new(0.1, 0.0, 1.0).normalize();
        assert_eq!(valid_reflection_normal(n, ng, Vec3::Z), n);
        // Bent no further than needed: the largest valid angle from ng, as a fine scan finds it.
        let mut rng = crate::sampler::Pcg32::new(5, 2);
        let mut bent = 0;
        for _ in 0..2_000 {
            let mut dir = || {
                let z = 2.0 * rng.next_f32() - 1.0;
                let phi = std::f32::consts::TAU * rng.next_f32();
                let s = (1.0 - z * z).max(0.0).sqrt();
                Vec3::new(s * phi.cos(), s * phi.sin(), z)
            };
            let (mut n, wo) = (dir(), dir());
            if n.z < 0.0 {
                n = -n;
            }
            let m = valid_reflection_normal(n, ng, wo);
            if m == n {
                continue;
            }
            bent += 1;
            let (ng, n, m) = if wo.z < 0.0 {
                (-ng, -n, -m)
            } else {
                (ng, n, m)
            };
            let t = (0.9 * wo.dot(ng)).min(0.01);
            let height = |m: Vec3| (2.0 * m.dot(wo) * m - wo).dot(ng);
            let x = (n - ng * n.dot(ng)).normalize();
            let theta_n = n.dot(ng).clamp(-1.0, 1.0).acos();
            let largest = (0..=20_000)
                .map(|k| theta_n * k as f32 / 20_000.0)
                .take_while(|&th| height(ng * th.cos() + x * th.sin()) >= t)
                .last()
                .unwrap_or(0.0);
            let theta_m = m.dot(ng).clamp(-1.0, 1.0).acos();
            assert!(
                (theta_m - largest).abs() <= 2e-3 * theta_n.max(1e-3),
                "n {n} wo {wo}: θ {theta_m} against {largest}"
            );
            assert!((height(m) - t).abs() < 1e-3, "{} against {t}", height(m));
        }
        assert!(bent > 100, "only {bent} normals bent");
    }
}
