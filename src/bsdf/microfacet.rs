//! The GGX / Trowbridge–Reitz microfacet distribution (isotropic): the normal distribution D,
//! Smith's Λ, the masking G1 and the height-correlated masking-shadowing G2, and sampling of the
//! distribution of visible normals with its density.
//!
//! All functions work in the local shading frame (z = macro-surface normal); `alpha` is the GGX
//! width α (glTF: α = roughness²). References: pbrt-v4 §9.6; Heitz, "Understanding
//! the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 3(2), 2014 (G2); Heitz,
//! "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018 (sampling).

use std::f32::consts::PI;

use crate::math::{Vec2, Vec3};
use crate::sampling::concentric_disk;

/// GGX / Trowbridge–Reitz normal distribution D(ωm) (pbrt-v4 eq. 9.16); zero for microfacet
/// normals at or below the horizon.
pub fn ggx_d(wm: Vec3, alpha: f32) -> f32 {
    let cos2 = wm.z * wm.z;
    if cos2 <= 0.0 {
        return 0.0;
    }
    let tan2 = (1.0 - cos2).max(0.0) / cos2;
    let a2 = alpha * alpha;
    let e = 1.0 + tan2 / a2;
    1.0 / (PI * a2 * cos2 * cos2 * e * e)
}

/// Smith Λ for GGX (pbrt-v4 eq. 9.20); symmetric in the sign of `w.z`.
pub fn ggx_lambda(w: Vec3, alpha: f32) -> f32 {
    let cos2 = w.z * w.z;
    if cos2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = (1.0 - cos2).max(0.0) / cos2;
    ((1.0 + alpha * alpha * tan2).sqrt() - 1.0) * 0.5
}

/// Smith masking G1(ω) = 1 / (1 + Λ(ω)) (pbrt-v4 §9.6).
pub fn ggx_g1(w: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(w, alpha))
}

/// Height-correlated masking-shadowing G2 = 1 / (1 + Λ(ωo) + Λ(ωi)) (the height-correlated
/// Smith form of Heitz 2014; pbrt-v4 §9.6).
pub fn ggx_g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))
}

/// Samples a visible normal of GGX seen from `wo` (upper hemisphere, `wo.z > 0`): Heitz 2018,
/// listing 1. The result is a microfacet normal in the upper hemisphere distributed with density
/// [`ggx_visible_pdf`].
pub fn ggx_sample_visible(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let wh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let t1 = if wh.z < 0.99999 {
        Vec3::Z.cross(wh).normalize()
    } else {
        Vec3::X
    };
    let t2 = wh.cross(t1);
    let p = concentric_disk(u);
    let h = (1.0 - p.x * p.x).max(0.0).sqrt();
    let py = (1.0 + wh.z) * 0.5 * p.y + (1.0 - (1.0 + wh.z) * 0.5) * h;
    let pz = (1.0 - p.x * p.x - py * py).max(0.0).sqrt();
    let nh = t1 * p.x + t2 * py + wh * pz;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-6)).normalize()
}

/// Density of visible normals D_ω(ωm) = G1(ω) max(0, ω·ωm) D(ωm) / |cos θ| (Heitz 2018;
/// pbrt-v4 §9.6), the solid-angle pdf of [`ggx_sample_visible`] over ωm. `w` must be in the
/// upper hemisphere (flip it first otherwise).
pub fn ggx_visible_pdf(w: Vec3, wm: Vec3, alpha: f32) -> f32 {
    if w.z == 0.0 {
        return 0.0;
    }
    ggx_g1(w, alpha) * w.dot(wm).max(0.0) * ggx_d(wm, alpha) / w.z.abs()
}

/// Pdf of the reflected direction 2(wo·ωm)ωm − wo when ωm is drawn by [`ggx_sample_visible`]:
/// D_wo(ωm) / (4 |wo·ωm|) (pbrt-v4 §9.6, with the reflection Jacobian
/// dωm/dωi = 1/(4 |wo·ωm|)).
pub fn ggx_reflect_pdf(wo: Vec3, wm: Vec3, alpha: f32) -> f32 {
    let d_wo = ggx_g1(wo, alpha) * wo.dot(wm).max(0.0) * ggx_d(wm, alpha) / wo.z.abs();
    d_wo / (4.0 * wo.dot(wm).abs())
}
