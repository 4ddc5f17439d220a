//! Fresnel reflectance: the exact dielectric formula, Schlick's approximation with F0 / F90, and
//! the two Fresnel combinators of glTF 2.0 (specification Appendix B, "BRDF Implementation"):
//! `conductor_fresnel` and `fresnel_mix`, the latter with the specular weight and colour of
//! `KHR_materials_specular`.
//!
//! References: pbrt-v4 §9.3 (exact dielectric Fresnel); Schlick, "An Inexpensive
//! BRDF Model for Physically-based Rendering", CGF 13(3), 1994; glTF 2.0 Appendix B.

use crate::math::{Rgb, Vec3};

/// Fresnel reflectance of a smooth dielectric boundary for unpolarised light (exact), given
/// cos θ on the incident side and the relative index η = η_t / η_i. Returns 1 for total internal
/// reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(-1.0, 1.0);
    let (cos_i, eta) = if cos_i < 0.0 {
        (-cos_i, 1.0 / eta)
    } else {
        (cos_i, eta)
    };
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Schlick's approximation for a metal with normal-incidence reflectance `f0` (F90 = 1), as the
/// legacy [`Bsdf`](super::Bsdf) metal lobe uses it.
pub fn fresnel_schlick(f0: Rgb, cos: f32) -> Rgb {
    let m = (1.0 - cos.abs()).clamp(0.0, 1.0);
    let m5 = m * m * m * m * m;
    f0 + (Vec3::ONE - f0) * m5
}

/// Schlick's approximation with explicit reflectance at normal (`f0`) and grazing (`f90`)
/// incidence: F = F0 + (F90 − F0)(1 − |cos θ|)⁵ (glTF 2.0 Appendix B).
pub fn schlick_f0_f90(f0: Rgb, f90: Rgb, cos: f32) -> Rgb {
    let m = (1.0 - cos.abs()).clamp(0.0, 1.0);
    let m5 = m * m * m * m * m;
    f0 + (f90 - f0) * m5
}

/// Normal-incidence reflectance of a dielectric of index `ior` in vacuum: ((ior − 1)/(ior + 1))²
/// (glTF 2.0 Appendix B, `KHR_materials_ior`). An infinite ior, like 0, gives 1 (the value
/// `KHR_materials_specular` uses to convert specular-glossiness materials).
pub fn ior_to_f0(ior: f32) -> f32 {
    if ior.is_infinite() {
        return 1.0;
    }
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// Fresnel term of glTF's metal BRDF, `conductor_fresnel(f0 = baseColor, bsdf)` (Appendix B):
/// Schlick with F0 = base colour and F90 = 1 at |V·H| = `v_dot_h`.
pub fn conductor_fresnel(base_color: Rgb, v_dot_h: f32) -> Rgb {
    schlick_f0_f90(base_color, Vec3::ONE, v_dot_h)
}

/// The dielectric F0 of `KHR_materials_specular`: min(F0(ior) · specular colour, 1), per channel.
pub fn dielectric_f0(ior: f32, specular_color: Rgb) -> Rgb {
    (specular_color * ior_to_f0(ior)).min(Vec3::ONE)
}

/// The weights glTF's `fresnel_mix` gives its two operands at |V·H| = `v_dot_h` (glTF 2.0
/// Appendix B, extended by `KHR_materials_specular`): with F = Schlick(F0 =
/// [`dielectric_f0`], F90 = 1), `fresnel_mix(base, layer) = (1 − w·max(F))·base + w·F·layer`,
/// where w is the specular factor. Returns (base weight, layer weight). Without the extension
/// (w = 1, colour 1) this is the plain `mix(base, layer, F)`.
pub fn fresnel_mix_weights(
    ior: f32,
    specular_factor: f32,
    specular_color: Rgb,
    v_dot_h: f32,
) -> (f32, Rgb) {
    let f = schlick_f0_f90(dielectric_f0(ior, specular_color), Vec3::ONE, v_dot_h);
    (1.0 - specular_factor * f.max_element(), f * specular_factor)
}

/// glTF's `fresnel_mix(ior, base, layer)` applied to evaluated operands (see
/// [`fresnel_mix_weights`]).
pub fn fresnel_mix(
    ior: f32,
    specular_factor: f32,
    specular_color: Rgb,
    v_dot_h: f32,
    base: Rgb,
    layer: Rgb,
) -> Rgb {
    let (wb, wl) = fresnel_mix_weights(ior, specular_factor, specular_color, v_dot_h);
    base * wb + layer * wl
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.2, 1.0 / 1.5), 1.0); // total internal reflection
        assert!((fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6); // from inside, normal incidence
        assert!(fresnel_dielectric(1e-4, 1.5) > 0.99);
    }

    #[test]
    fn schlick_and_gltf_combinators() {
        assert!((ior_to_f0(1.5) - 0.04).abs() < 1e-7);
        assert_eq!((ior_to_f0(0.0), ior_to_f0(f32::INFINITY)), (1.0, 1.0));
        let f0 = Vec3::new(0.9, 0.5, 0.1);
        // F0 at normal incidence, F90 at grazing incidence, monotone in between.
        assert!((conductor_fresnel(f0, 1.0) - f0).abs().max_element() < 1e-7);
        assert!((conductor_fresnel(f0, 0.0) - Vec3::ONE).abs().max_element() < 1e-7);
        let f90 = Vec3::splat(0.7);
        assert!((schlick_f0_f90(f0, f90, 0.0) - f90).abs().max_element() < 1e-7);
        // Schlick stays within 0.04 (absolute) of the exact dielectric Fresnel for glass at all
        // angles (it is an approximation: the largest gap, 0.036, is near grazing incidence).
        for i in 0..=100 {
            let c = i as f32 / 100.0;
            let s = schlick_f0_f90(Vec3::splat(0.04), Vec3::ONE, c).x;
            assert!((s - fresnel_dielectric(c, 1.5)).abs() < 0.04, "cos {c}");
        }
        // fresnel_mix: plain mix(base, layer, F) without KHR_materials_specular...
        let (b, l) = (Vec3::new(0.2, 0.4, 0.6), Vec3::ONE);
        let m = fresnel_mix(1.5, 1.0, Vec3::ONE, 1.0, b, l);
        assert!((m - (b * 0.96 + l * 0.04)).abs().max_element() < 1e-6);
        // ...a zero specular factor leaves the base alone, and F0 is clamped to 1.
        assert_eq!(fresnel_mix(1.5, 0.0, Vec3::ONE, 0.3, b, l), b);
        assert_eq!(dielectric_f0(1.5, Vec3::splat(100.0)), Vec3::ONE);
    }
}
