//! Energy compensation for multiple scattering between GGX microfacets, after Kulla & Conty,
//! "Revisiting Physically Based Shading at Imageworks", SIGGRAPH 2017 course *Physically Based
//! Shading in Theory and Practice*, section on energy compensation.
//!
//! A single-scattering microfacet BRDF with a perfect reflector (F = 1) has directional albedo
//! E(μ, α) < 1 at high roughness: light that bounces more than once between microfacets is lost.
//! Kulla & Conty add the lobe
//!
//!   f_ms(μo, μi) = F_ms · (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg)),
//!
//! with E_avg(α) = 2 ∫₀¹ E(μ, α) μ dμ, whose albedo is exactly the missing 1 − E(μo) (so a white
//! rough metal is white again, and the lobe is reciprocal), tinted for a coloured Fresnel by
//! F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)), F_avg = 2 ∫ F(μ) μ dμ, which for
//! Schlick with F90 = 1 is F0 + (1 − F0)/21.
//!
//! E and E_avg are tabulated by numerical integration over the microfacet normals (see
//! `integrate`) on 32 × 32 nodes in (μ, √α), bilinearly interpolated; E_avg by the midpoint rule
//! on the μ nodes. The tables are computed once, when the code changes, and embedded
//! (`src/bsdf/tables.rs`, checked against `compute` bit for bit by a test), so that no render
//! waits for them (computing them took ≈ 80 M instructions at the first glossy hit). A
//! second table E5 = ∫ (1 − |ωo·ωm|)⁵ f cos dωi makes the albedo of a Schlick-Fresnel lobe exact
//! from the tables: E_F(μ) = F0·E(μ) + (1 − F0)·E5(μ) (Schlick is linear in F0), which the
//! glTF layering of a diffuse base under the specular layer uses ([`specular_albedo`]).

use std::f32::consts::FRAC_1_PI;

use crate::math::{Rgb, Vec3};

/// Nodes in μ = cos θ, at the midpoints (i + ½)/N of [0, 1].
const N_MU: usize = 32;
/// Nodes in roughness r = √α, at j/(N − 1) over [0, 1].
const N_ROUGH: usize = 32;
/// Integration nodes per table entry in the warped GGX CDF coordinate.
#[cfg(test)]
const N_S: usize = 64;
/// Integration nodes per table entry in φ ∈ [0, π].
#[cfg(test)]
const N_PHI: usize = 32;
/// Smallest α integrated (the GGX formulas degenerate at α = 0, where E = 1 anyway).
#[cfg(test)]
const MIN_ALPHA: f32 = 1e-4;

/// The tabulated single-scattering albedos of GGX.
pub(super) struct Tables {
    /// E(μ, r): `e[r][μ]`.
    pub(super) e: [[f32; N_MU]; N_ROUGH],
    /// E5(μ, r): `e5[r][μ]`.
    pub(super) e5: [[f32; N_MU]; N_ROUGH],
    /// E_avg(r).
    pub(super) e_avg: [f32; N_ROUGH],
    /// 2 ∫ E5(μ) μ dμ.
    pub(super) e5_avg: [f32; N_ROUGH],
}

#[cfg(test)]
fn mu_node(i: usize) -> f32 {
    (i as f32 + 0.5) / N_MU as f32
}

/// Directional albedos (E, E5) of the GGX reflection lobe with F = 1 at cos θo = `mu`:
/// E = ∫ D(ωm) G2(ωo, ωi) (ωo·ωm)⁺ / μo dωm over the microfacets whose mirror direction ωi is
/// above the horizon (the reflection lobe's albedo written over the half vector). The integral
/// is taken in the GGX CDF coordinate ξ = tan²θm / (α² + tan²θm), in which D cos θm dωm =
/// dξ dφ/(2π), warped by ξ = 1 − (1 − s)² to resolve GGX's long tail (the microfacets that
/// reflect below the horizon, ≈ 1 % of the albedo even at α = 0.09), midpoint rule in (s, φ).
#[cfg(test)]
fn integrate(mu: f32, alpha: f32, phis: &[(f64, f64); N_PHI]) -> (f64, f64) {
    let mu = mu as f64;
    let a2 = (alpha as f64) * (alpha as f64);
    let wo = glam::DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let lambda = |z: f64| {
        let tan2 = (1.0 - z * z).max(0.0) / (z * z);
        ((1.0 + a2 * tan2).sqrt() - 1.0) * 0.5
    };
    let lambda_o = lambda(mu);
    let (mut e, mut e5) = (0.0f64, 0.0f64);
    for a in 0..N_S {
        let s = (a as f64 + 0.5) / N_S as f64;
        let xi = 1.0 - (1.0 - s) * (1.0 - s);
        let dxi = 2.0 * (1.0 - s) / N_S as f64;
        let tan2 = a2 * xi / (1.0 - xi);
        let cos_m = 1.0 / (1.0 + tan2).sqrt();
        let sin_m = (1.0 - cos_m * cos_m).max(0.0).sqrt();
        // The integrand is even in φ: average over [0, π].
        for &(cos_phi, sin_phi) in phis {
            let wm = glam::DVec3::new(sin_m * cos_phi, sin_m * sin_phi, cos_m);
            let om = wo.dot(wm);
            if om <= 0.0 {
                continue;
            }
            let wi_z = 2.0 * om * cos_m - mu;
            if wi_z <= 0.0 {
                continue;
            }
            let g = om / (mu * cos_m) / (1.0 + lambda_o + lambda(wi_z));
            let w = g * dxi / N_PHI as f64;
            e += w;
            e5 += w * (1.0 - om).clamp(0.0, 1.0).powi(5);
        }
    }
    (e, e5)
}

/// Computes the tables (embedded as `super::tables::GGX_*`).
#[cfg(test)]
pub(super) fn compute() -> Tables {
    let mut t = Tables {
        e: [[0.0; N_MU]; N_ROUGH],
        e5: [[0.0; N_MU]; N_ROUGH],
        e_avg: [0.0; N_ROUGH],
        e5_avg: [0.0; N_ROUGH],
    };
    // The azimuths' (cos φ, sin φ), the same for every node: computed once, not per node.
    let phis: [(f64, f64); N_PHI] = std::array::from_fn(|b| {
        let phi = std::f64::consts::PI * (b as f64 + 0.5) / N_PHI as f64;
        (phi.cos(), phi.sin())
    });
    for r in 0..N_ROUGH {
        let rough = r as f32 / (N_ROUGH - 1) as f32;
        let alpha = (rough * rough).max(MIN_ALPHA);
        let (mut avg, mut avg5) = (0.0f64, 0.0f64);
        for m in 0..N_MU {
            let (e, e5) = integrate(mu_node(m), alpha, &phis);
            t.e[r][m] = e as f32;
            t.e5[r][m] = e5 as f32;
            // Midpoint rule for 2 ∫ E μ dμ on the same nodes.
            avg += 2.0 * e * mu_node(m) as f64 / N_MU as f64;
            avg5 += 2.0 * e5 * mu_node(m) as f64 / N_MU as f64;
        }
        t.e_avg[r] = avg as f32;
        t.e5_avg[r] = avg5 as f32;
    }
    t
}

fn tables() -> &'static Tables {
    static TABLES: Tables = Tables {
        e: super::tables::GGX_E,
        e5: super::tables::GGX_E5,
        e_avg: super::tables::GGX_E_AVG,
        e5_avg: super::tables::GGX_E5_AVG,
    };
    &TABLES
}

/// Linear interpolation position in the roughness axis for α: (index, fraction).
fn rough_pos(alpha: f32) -> (usize, f32) {
    let x = alpha.max(0.0).sqrt().min(1.0) * (N_ROUGH - 1) as f32;
    let i = (x as usize).min(N_ROUGH - 2);
    (i, x - i as f32)
}

/// Linear interpolation position in the μ axis: (index, fraction).
#[inline(always)]
fn mu_pos(mu: f32) -> (usize, f32) {
    let x = (mu.abs().min(1.0) * N_MU as f32 - 0.5).clamp(0.0, (N_MU - 1) as f32);
    let m = (x as usize).min(N_MU - 2);
    (m, x - m as f32)
}

/// Bilinear interpolation of `table` at the positions of [`mu_pos`] and [`rough_pos`].
#[inline(always)]
fn interpolate(
    table: &[[f32; N_MU]; N_ROUGH],
    (m, fm): (usize, f32),
    (r, fr): (usize, f32),
) -> f32 {
    let row = |r: usize| table[r][m] * (1.0 - fm) + table[r][m + 1] * fm;
    row(r) * (1.0 - fr) + row(r + 1) * fr
}

fn lookup(table: &[[f32; N_MU]; N_ROUGH], mu: f32, alpha: f32) -> f32 {
    interpolate(table, mu_pos(mu), rough_pos(alpha))
}

/// The tables at one roughness α, for the many lookups a BSDF makes at its α: the same values,
/// bit for bit, as [`albedo`], [`average_albedo`] and the functions built on them, without
/// finding α's place in the tables (a square root) for each.
#[derive(Debug, Clone, Copy)]
pub struct AtRoughness {
    rough: (usize, f32),
    /// E_avg(α) ([`average_albedo`]).
    pub e_avg: f32,
    /// The cosine-weighted average of E5(μ, α).
    pub e5_avg: f32,
}

impl AtRoughness {
    /// The tables at roughness `alpha`.
    pub fn new(alpha: f32) -> AtRoughness {
        let (r, fr) = rough_pos(alpha);
        let t = tables();
        AtRoughness {
            rough: (r, fr),
            e_avg: t.e_avg[r] * (1.0 - fr) + t.e_avg[r + 1] * fr,
            e5_avg: t.e5_avg[r] * (1.0 - fr) + t.e5_avg[r + 1] * fr,
        }
    }

    /// A stand-in for BSDFs that look up no table (smooth glass that transmits everything):
    /// NaN, so that a lookup through it would show in the image instead of passing unseen.
    pub fn unused() -> AtRoughness {
        AtRoughness {
            rough: (0, f32::NAN),
            e_avg: f32::NAN,
            e5_avg: f32::NAN,
        }
    }

    /// E(μ, α) and E5(μ, α): the albedo of the lobe with F = 1 ([`albedo`]) and with the
    /// (1 − μ)⁵ weight of Schlick's Fresnel.
    #[inline]
    pub fn e_e5(&self, mu: f32) -> (f32, f32) {
        let at = mu_pos(mu);
        let t = tables();
        (
            interpolate(&t.e, at, self.rough),
            interpolate(&t.e5, at, self.rough),
        )
    }

    /// The colour F_ms of the multiple-scattering lobe for Schlick's F0 = `f0`, as in
    /// [`compensation_from`] and [`compensation_albedo`]; `None` where they are zero (no lobe:
    /// 1 − E_avg < 10⁻⁶, a smooth surface).
    pub fn f_ms(&self, f0: Rgb) -> Option<Rgb> {
        if 1.0 - self.e_avg < 1e-6 {
            return None;
        }
        let f_avg = schlick_average(f0);
        Some(f_avg * f_avg * self.e_avg / (Vec3::ONE - f_avg * (1.0 - self.e_avg)))
    }
}

/// Directional albedo E(μ, α) of the single-scattering GGX reflection lobe with F = 1.
pub fn albedo(mu: f32, alpha: f32) -> f32 {
    lookup(&tables().e, mu, alpha)
}

/// Cosine-weighted average E_avg(α) = 2 ∫₀¹ E(μ, α) μ dμ.
pub fn average_albedo(alpha: f32) -> f32 {
    let (r, fr) = rough_pos(alpha);
    let t = tables();
    t.e_avg[r] * (1.0 - fr) + t.e_avg[r + 1] * fr
}

/// Cosine-weighted hemispherical average of Schlick's Fresnel with F90 = 1:
/// F_avg = F0 + (1 − F0)/21.
pub fn schlick_average(f0: Rgb) -> Rgb {
    f0 + (Vec3::ONE - f0) / 21.0
}

/// The multiple-scattering lobe f_ms(μo, μi) (no cosine) for a Schlick Fresnel of normal
/// reflectance `f0` (F90 = 1); zero for smooth surfaces.
pub fn compensation(mu_o: f32, mu_i: f32, alpha: f32, f0: Rgb) -> Rgb {
    compensation_from(compensation_factor(mu_o, alpha), mu_i, alpha, f0)
}

/// The factor 1 − E(μ) of the multiple-scattering lobe for one direction (clamped at 0).
pub fn compensation_factor(mu: f32, alpha: f32) -> f32 {
    (1.0 - albedo(mu, alpha)).max(0.0)
}

/// [`compensation`] given μo's [`compensation_factor`] (the same bits), for a BSDF evaluated
/// many times for one outgoing direction.
pub fn compensation_from(factor_o: f32, mu_i: f32, alpha: f32, f0: Rgb) -> Rgb {
    let e_avg = average_albedo(alpha);
    if 1.0 - e_avg < 1e-6 {
        return Vec3::ZERO;
    }
    let f_avg = schlick_average(f0);
    let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
    let s = factor_o * compensation_factor(mu_i, alpha);
    f_ms * (s * FRAC_1_PI / (1.0 - e_avg))
}

/// Directional albedo ∫ f_ms cos θi dωi = F_ms (1 − E(μo)) of [`compensation`].
pub fn compensation_albedo(mu_o: f32, alpha: f32, f0: Rgb) -> Rgb {
    let e_avg = average_albedo(alpha);
    if 1.0 - e_avg < 1e-6 {
        return Vec3::ZERO;
    }
    let f_avg = schlick_average(f0);
    let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
    f_ms * (1.0 - albedo(mu_o, alpha)).max(0.0)
}

/// Directional albedo of the GGX reflection lobe with Schlick Fresnel (F0 = `f0`, F90 = 1),
/// plus that of its compensation lobe when `compensate`: F0·E + (1 − F0)·E5 [+ F_ms (1 − E)].
pub fn specular_albedo(mu: f32, alpha: f32, f0: Rgb, compensate: bool) -> Rgb {
    let e = albedo(mu, alpha);
    let e5 = lookup(&tables().e5, mu, alpha);
    let single = f0 * e + (Vec3::ONE - f0) * e5;
    if compensate {
        single + compensation_albedo(mu, alpha, f0)
    } else {
        single
    }
}

/// Cosine-weighted average 2 ∫ [`specular_albedo`] μ dμ.
pub fn specular_average_albedo(alpha: f32, f0: Rgb, compensate: bool) -> Rgb {
    let (r, fr) = rough_pos(alpha);
    let t = tables();
    let e_avg = t.e_avg[r] * (1.0 - fr) + t.e_avg[r + 1] * fr;
    let e5_avg = t.e5_avg[r] * (1.0 - fr) + t.e5_avg[r + 1] * fr;
    let single = f0 * e_avg + (Vec3::ONE - f0) * e5_avg;
    if compensate && 1.0 - e_avg >= 1e-6 {
        let f_avg = schlick_average(f0);
        let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
        single + f_ms * (1.0 - e_avg)
    } else {
        single
    }
}

#[cfg(test)]
mod tests {
    use super::super::microfacet::ggx_g2;
    use super::*;
    use crate::math::Vec2;
    use crate::sampler::Pcg32;
    use crate::sampling::cosine_hemisphere;

    #[test]
    fn tables_are_sane() {
        // Smooth: no loss. Rough: loss grows with roughness and towards grazing angles.
        assert!((albedo(0.7, 0.0) - 1.0).abs() < 1e-4);
        assert!((average_albedo(0.0) - 1.0).abs() < 1e-3);
        let mut last = 1.0;
        for r in [0.2f32, 0.4, 0.6, 0.8, 1.0] {
            let e = albedo(0.5, r * r);
            assert!(e < last && e > 0.3, "E(0.5, r={r}) = {e}");
            last = e;
            let avg = average_albedo(r * r);
            assert!(avg < 1.0 && avg > 0.3, "E_avg(r={r}) = {avg}");
        }
    }

    #[test]
    fn tabulated_albedo_matches_independent_integration() {
        use super::super::microfacet::ggx_d;
        use super::super::testing::hemisphere_integral;
        // Midpoint quadrature of the evaluated BRDF D G2 / (4 μo μi) · μi over (μi, φi): no
        // sampling routine involved.
        for (mu, alpha) in [(0.3f32, 0.25f32), (0.8, 0.6), (0.55, 1.0), (0.9, 0.09)] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let e = hemisphere_integral(600, |wi| {
                let wm = (wo + wi).normalize();
                (ggx_d(wm, alpha) * ggx_g2(wo, wi, alpha) / (4.0 * wo.z)) as f64
            }) as f32;
            assert!(
                (e - albedo(mu, alpha)).abs() < 0.003,
                "μ {mu} α {alpha}: {e} vs table {}",
                albedo(mu, alpha)
            );
        }
    }

    #[test]
    fn compensation_lobe_restores_the_missing_energy() {
        // ∫ f_ms cos dωi = 1 − E(μo) for F = 1, by cosine sampling of the lobe.
        let mut rng = Pcg32::new(4, 4);
        for alpha in [0.25f32, 0.64, 1.0] {
            for mu in [0.2f32, 0.6, 0.95] {
                let n = 20_000;
                let mut sum = 0.0f64;
                for _ in 0..n {
                    let wi = cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                    sum +=
                        (compensation(mu, wi.z, alpha, Vec3::ONE).x * std::f32::consts::PI) as f64;
                }
                let got = (sum / n as f64) as f32;
                let want = 1.0 - albedo(mu, alpha);
                assert!(
                    (got - want).abs() < 0.003,
                    "α {alpha} μ {mu}: {got} vs {want}"
                );
            }
        }
    }
}
