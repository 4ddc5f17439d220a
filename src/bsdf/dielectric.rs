//! Dielectric interfaces: the rough dielectric BSDF (GGX reflection + transmission with
//! refraction) and the thin-walled dielectric glTF uses for transmission without a volume.
//!
//! Both work in the local shading frame, the front side (z > 0) being outside: η is the index of
//! refraction inside over outside, so light going from `wo` at z > 0 into the surface sees η and
//! light leaving sees 1/η. `eval` returns f·|cos θi| and the pdf of `sample`; `sample` returns a
//! [`LocalSample`] whose weight is f·|cos θi|/pdf. Values are scalar: the caller tints.
//!
//! Radiance convention (pbrt-v4 §9.5.2): the BTDF carries the 1/η′² factor of radiance
//! transport, η′ = η_i/η_o being the index on `wi`'s side over that on `wo`'s side, so it is not
//! symmetric; it obeys f(ωo, ωi)/η_o² = f(ωi, ωo)/η_i² (Veach 1997 §5.2, with η_x the index
//! on the side of ωx), which the tests check.
//!
//! References: Walter, Marschner, Li & Torrance, "Microfacet Models for Refraction through Rough
//! Surfaces", EGSR 2007, in the form of pbrt-v4's `DielectricBxDF` (§9.7),
//! with visible-normal sampling (Heitz 2018); pbrt-v4's `ThinDielectricBxDF` (§9.5.3) for the
//! inter-reflection inside a thin slab; glTF `KHR_materials_transmission` ("thin-walled":
//! transmission does not bend the ray).

use super::fresnel::fresnel_dielectric;
use super::microfacet::{ggx_d, ggx_g2, ggx_sample_visible, ggx_visible_pdf};
use super::{LocalSample, DELTA_ALPHA};
use crate::math::{Vec2, Vec3};

/// Refracts `wi` (either side) through the surface with normal `n`, given η = η_t/η_i for
/// `wi` on the side `n` points to (pbrt-v4 §9.3). Returns the refracted direction and the
/// relative index η′ actually crossed, or `None` under total internal reflection.
fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let mut cos_i = n.dot(wi);
    let (mut eta, mut n) = (eta, n);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wi / eta + (cos_i / eta - cos_t) * n, eta))
}

/// The upper-hemisphere representative of `w`.
fn upper(w: Vec3) -> Vec3 {
    if w.z < 0.0 {
        -w
    } else {
        w
    }
}

/// A rough (or smooth) dielectric boundary: Walter et al. 2007 with GGX.
#[derive(Debug, Clone, Copy)]
pub struct RoughDielectric {
    /// Index of refraction inside over outside.
    pub eta: f32,
    /// GGX α; below [`DELTA_ALPHA`] (or when η = 1) the interface is smooth and both lobes are
    /// Dirac deltas, as in pbrt-v4.
    pub alpha: f32,
}

/// The generalised half vector of a pair, faced up, with η′ and whether it is a reflection;
/// `None` for degenerate configurations and back-facing microfacets (pbrt-v4
/// `DielectricBxDF::f`).
fn half_vector(wo: Vec3, wi: Vec3, eta: f32) -> Option<(Vec3, f32, bool)> {
    let (cos_o, cos_i) = (wo.z, wi.z);
    let reflect = cos_o * cos_i > 0.0;
    let etap = if reflect {
        1.0
    } else if cos_o > 0.0 {
        eta
    } else {
        1.0 / eta
    };
    let wm = wi * etap + wo;
    if cos_i == 0.0 || cos_o == 0.0 || wm.length_squared() == 0.0 {
        return None;
    }
    let wm = upper(wm.normalize());
    if wm.dot(wi) * cos_i < 0.0 || wm.dot(wo) * cos_o < 0.0 {
        return None;
    }
    Some((wm, etap, reflect))
}

impl RoughDielectric {
    /// Whether both lobes are Dirac deltas.
    pub fn is_delta(&self) -> bool {
        self.eta == 1.0 || self.alpha < DELTA_ALPHA
    }

    /// f·|cos θi| and the pdf of [`sample`](Self::sample) for the pair; zero for delta
    /// interfaces.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if self.is_delta() {
            return (0.0, 0.0);
        }
        let Some((wm, etap, reflect)) = half_vector(wo, wi, self.eta) else {
            return (0.0, 0.0);
        };
        let a = self.alpha;
        let r = fresnel_dielectric(wo.dot(wm), self.eta);
        let t = 1.0 - r;
        let pdf_wm = ggx_visible_pdf(upper(wo), wm, a);
        let d_g = ggx_d(wm, a) * ggx_g2(wo, wi, a);
        if reflect {
            let f = d_g * r / (4.0 * wo.z.abs());
            (f, pdf_wm / (4.0 * wo.dot(wm).abs()) * r)
        } else {
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
            let f = d_g * t * (wi.dot(wm) * wo.dot(wm) / (wo.z * denom)).abs() / (etap * etap);
            let dwm_dwi = wi.dot(wm).abs() / denom;
            (f, pdf_wm * dwm_dwi * t)
        }
    }

    /// Samples reflection or transmission in proportion to the Fresnel reflectance of the
    /// sampled visible microfacet (`uc` chooses, `u` samples the microfacet normal).
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample> {
        if wo.z == 0.0 {
            return None;
        }
        if self.is_delta() {
            return self.sample_smooth(wo, uc);
        }
        let a = self.alpha;
        // Visible normal on wo's side, expressed in the upper hemisphere like pbrt's wm.
        let wm = ggx_sample_visible(upper(wo), a, u);
        let r = fresnel_dielectric(wo.dot(wm), self.eta);
        let pdf_wm = ggx_visible_pdf(upper(wo), wm, a);
        if uc < r {
            let wi = 2.0 * wo.dot(wm) * wm - wo;
            if wo.z * wi.z <= 0.0 {
                return None;
            }
            let pdf = pdf_wm / (4.0 * wo.dot(wm).abs()) * r;
            let f = ggx_d(wm, a) * ggx_g2(wo, wi, a) * r / (4.0 * wo.z.abs());
            if pdf <= 0.0 {
                return None;
            }
            return Some(LocalSample {
                wi,
                weight: Vec3::splat(f / pdf),
                pdf,
                delta: false,
                transmitted: false,
                etap: 1.0,
            });
        }
        let (wi, etap) = refract(wo, wm, self.eta)?;
        let wi = wi.normalize();
        if wo.z * wi.z >= 0.0 {
            return None;
        }
        let t = 1.0 - r;
        let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
        let pdf = pdf_wm * wi.dot(wm).abs() / denom * t;
        let f =
            ggx_d(wm, a) * ggx_g2(wo, wi, a) * t * (wi.dot(wm) * wo.dot(wm) / (wo.z * denom)).abs()
                / (etap * etap);
        if pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(LocalSample {
            wi,
            weight: Vec3::splat(f / pdf),
            pdf,
            delta: false,
            transmitted: true,
            etap,
        })
    }

    fn sample_smooth(&self, wo: Vec3, uc: f32) -> Option<LocalSample> {
        let r = fresnel_dielectric(wo.z, self.eta);
        if uc < r {
            return Some(LocalSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                weight: Vec3::ONE,
                pdf: r,
                delta: true,
                transmitted: false,
                etap: 1.0,
            });
        }
        let (wi, etap) = refract(wo, Vec3::Z, self.eta)?;
        Some(LocalSample {
            wi: wi.normalize(),
            weight: Vec3::splat(1.0 / (etap * etap)),
            pdf: 1.0 - r,
            delta: true,
            transmitted: true,
            etap,
        })
    }
}

/// A thin-walled dielectric slab (glTF transmission without `KHR_materials_volume`): light is
/// reflected by the GGX lobe or transmitted along the same lobe mirrored through the surface
/// (no bending), in the proportions R′ = R + T²R/(1 − R²), T′ = 1 − R′ of a slab whose two faces
/// have the exact Fresnel reflectance R at the microfacet (pbrt-v4 `ThinDielectricBxDF`).
#[derive(Debug, Clone, Copy)]
pub struct ThinDielectric {
    /// Index of refraction of the slab over its surroundings.
    pub eta: f32,
    /// GGX α; below [`DELTA_ALPHA`] both lobes are Dirac deltas.
    pub alpha: f32,
}

impl ThinDielectric {
    /// Whether both lobes are Dirac deltas.
    pub fn is_delta(&self) -> bool {
        self.alpha < DELTA_ALPHA
    }

    /// Slab reflectance R′ for cos θ = `cos` on a microfacet.
    fn slab_reflectance(&self, cos: f32) -> f32 {
        let r = fresnel_dielectric(cos.abs(), self.eta);
        if r < 1.0 {
            r + (1.0 - r) * (1.0 - r) * r / (1.0 - r * r)
        } else {
            1.0
        }
    }

    /// f·|cos θi| and the pdf of [`sample`](Self::sample) for the pair; zero for delta slabs.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if self.is_delta() || wo.z == 0.0 || wi.z == 0.0 {
            return (0.0, 0.0);
        }
        let transmitted = wo.z * wi.z < 0.0;
        // Work on wo's side, upper hemisphere; transmission is reflection mirrored through z.
        let o = upper(wo);
        let i = if wo.z < 0.0 { -wi } else { wi };
        let i = if transmitted {
            Vec3::new(i.x, i.y, -i.z)
        } else {
            i
        };
        let wm = (o + i).normalize_or_zero();
        if wm == Vec3::ZERO || o.dot(wm) <= 0.0 {
            return (0.0, 0.0);
        }
        let rp = self.slab_reflectance(o.dot(wm));
        let frac = if transmitted { 1.0 - rp } else { rp };
        let a = self.alpha;
        let f = ggx_d(wm, a) * ggx_g2(o, i, a) / (4.0 * o.z) * frac;
        let pdf = ggx_visible_pdf(o, wm, a) / (4.0 * o.dot(wm)) * frac;
        (f, pdf)
    }

    /// Samples a visible microfacet, reflects about it, and transmits (mirroring through the
    /// surface) with probability T′.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample> {
        if wo.z == 0.0 {
            return None;
        }
        let side = wo.z.signum();
        let o = upper(wo);
        let (i, delta) = if self.is_delta() {
            (Vec3::new(-o.x, -o.y, o.z), true)
        } else {
            let wm = ggx_sample_visible(o, self.alpha, u);
            let i = 2.0 * o.dot(wm) * wm - o;
            if i.z <= 0.0 {
                return None;
            }
            (i, false)
        };
        let rp = self.slab_reflectance((o + i).normalize().dot(o));
        let transmitted = uc >= rp;
        let i_side = if transmitted {
            Vec3::new(i.x, i.y, -i.z)
        } else {
            i
        };
        let wi = i_side * side;
        if delta {
            let p = if transmitted { 1.0 - rp } else { rp };
            return Some(LocalSample {
                wi,
                weight: Vec3::ONE,
                pdf: p,
                delta: true,
                transmitted,
                etap: 1.0,
            });
        }
        let (f, pdf) = self.eval(wo, wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(LocalSample {
            wi,
            weight: Vec3::splat(f / pdf),
            pdf,
            delta: false,
            transmitted,
            etap: 1.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::chi2;
    use super::super::testing::{dir, random_dir, u3};
    use super::*;
    use crate::sampler::Pcg32;

    #[test]
    fn rough_dielectric_chi2() {
        // (η, α, θo): outside, grazing, from inside (with total internal reflection), dense.
        let cases = [
            (1.5f32, 0.3f32, 30.0f32),
            (1.5, 0.6, 75.0),
            (1.33, 0.4, 150.0),
            (2.4, 0.9, 45.0),
            (1.5, 0.2, 60.0),
            (1.5, 0.3, 10.0),
        ];
        let mut ps = Vec::new();
        for (k, &(eta, alpha, theta)) in cases.iter().enumerate() {
            let b = RoughDielectric { eta, alpha };
            let wo = dir(theta, 0.3);
            let p = chi2::p_value(
                "rough dielectric",
                100_000,
                k as u64,
                |rng| {
                    let (uc, u) = u3(rng);
                    b.sample(wo, uc, u).map(|s| s.wi)
                },
                |wi| b.eval(wo, wi).1,
            );
            ps.push((format!("η {eta} α {alpha} θ {theta}"), p));
        }
        chi2::assert_all_pass(&ps);
    }

    #[test]
    fn thin_dielectric_chi2() {
        let cases = [
            (1.5f32, 0.3f32, 40.0f32),
            (1.5, 0.7, 160.0),
            (2.0, 0.5, 80.0),
        ];
        let mut ps = Vec::new();
        for (k, &(eta, alpha, theta)) in cases.iter().enumerate() {
            let b = ThinDielectric { eta, alpha };
            let wo = dir(theta, 1.0);
            let p = chi2::p_value(
                "thin dielectric",
                100_000,
                100 + k as u64,
                |rng| {
                    let (uc, u) = u3(rng);
                    b.sample(wo, uc, u).map(|s| s.wi)
                },
                |wi| b.eval(wo, wi).1,
            );
            ps.push((format!("thin η {eta} α {alpha} θ {theta}"), p));
        }
        chi2::assert_all_pass(&ps);
    }

    #[test]
    fn samples_agree_with_eval() {
        let mut rng = Pcg32::new(3, 3);
        for (eta, alpha) in [(1.5f32, 0.05f32), (1.5, 0.5), (1.0 / 1.33, 0.3), (2.4, 1.0)] {
            let rough = RoughDielectric { eta, alpha };
            let thin = ThinDielectric { eta, alpha };
            for theta in [5.0f32, 50.0, 85.0, 130.0, 175.0] {
                let wo = dir(theta, 0.7);
                for _ in 0..2000 {
                    let (uc, u) = u3(&mut rng);
                    let pairs = [
                        rough.sample(wo, uc, u).map(|s| (s, rough.eval(wo, s.wi))),
                        thin.sample(wo, uc, u).map(|s| (s, thin.eval(wo, s.wi))),
                    ];
                    for (s, (f, pdf)) in pairs.into_iter().flatten() {
                        assert!(!s.delta && s.pdf > 0.0 && s.weight.x.is_finite());
                        assert_eq!(s.transmitted, s.wi.z * wo.z < 0.0);
                        let tol = 1e-3 * pdf.max(1.0);
                        assert!((s.pdf - pdf).abs() <= tol, "pdf {} vs {pdf}", s.pdf);
                        let fs = s.weight.x * s.pdf;
                        assert!((fs - f).abs() <= 1e-3 * f.max(1.0), "f {fs} vs {f}");
                    }
                }
            }
        }
    }

    #[test]
    fn reciprocity_and_eta_squared_relation() {
        let mut rng = Pcg32::new(8, 1);
        let mut checked = (0, 0);
        for (eta, alpha) in [(1.5f32, 0.3f32), (1.33, 0.7), (2.0, 0.15)] {
            let b = RoughDielectric { eta, alpha };
            let thin = ThinDielectric { eta, alpha };
            for _ in 0..5000 {
                let wo = random_dir(&mut rng);
                let wi = random_dir(&mut rng);
                // f without the cosine, both ways.
                let f = |a: Vec3, c: Vec3| b.eval(a, c).0 / c.z.abs();
                let (f_oi, f_io) = (f(wo, wi), f(wi, wo));
                let ft = |a: Vec3, c: Vec3| thin.eval(a, c).0 / c.z.abs();
                assert!((ft(wo, wi) - ft(wi, wo)).abs() <= 1e-3 * ft(wo, wi).max(1e-3));
                if f_oi < 1e-4 || !f_oi.is_finite() {
                    continue;
                }
                if wo.z * wi.z > 0.0 {
                    assert!((f_oi - f_io).abs() <= 1e-3 * f_oi, "{f_oi} vs {f_io}");
                    checked.0 += 1;
                } else {
                    // f(ωo, ωi)/η_o² = f(ωi, ωo)/η_i², η_x the index on ωx's side (outside 1); the
                    // tolerance covers f32 rounding in the far tails of D (values ~1e-4).
                    let n = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
                    let (l, r) = (f_oi / n(wo).powi(2), f_io / n(wi).powi(2));
                    assert!((l - r).abs() <= 5e-3 * l, "η {eta}: {l} vs {r}");
                    checked.1 += 1;
                }
            }
        }
        assert!(checked.0 > 500 && checked.1 > 500, "{checked:?}");
    }

    /// Mean of weight·η′² over samples: the directional albedo of the interface in terms of
    /// power (radiance scaled back by η′² on transmission).
    fn energy(sample: impl Fn(f32, Vec2) -> Option<LocalSample>, n: usize) -> f32 {
        let mut rng = Pcg32::new(17, 2);
        let mut sum = 0.0f64;
        for _ in 0..n {
            let (uc, u) = u3(&mut rng);
            if let Some(s) = sample(uc, u) {
                sum += (s.weight.x * s.etap * s.etap) as f64;
            }
        }
        (sum / n as f64) as f32
    }

    #[test]
    fn energy_is_conserved() {
        for theta in [0.0f32, 40.0, 80.0, 120.0, 170.0] {
            let wo = dir(theta, 0.2);
            // Index-matched: everything passes straight through (R + T = 1), rough or not.
            for alpha in [0.0f32, 0.3, 1.0] {
                let b = RoughDielectric { eta: 1.0, alpha };
                let e = energy(|uc, u| b.sample(wo, uc, u), 2000);
                assert!((e - 1.0).abs() < 0.01, "η 1 α {alpha} θ {theta}: {e}");
            }
            // Smooth interfaces conserve energy exactly; rough ones lose what single scattering
            // misses (up to ~60 % at α = 1, as GGX reflection does), never gain.
            for eta in [1.33f32, 1.5, 2.4] {
                let smooth = RoughDielectric { eta, alpha: 0.0 };
                let e = energy(|uc, u| smooth.sample(wo, uc, u), 2000);
                assert!((e - 1.0).abs() < 1e-4, "smooth η {eta} θ {theta}: {e}");
                for alpha in [0.1f32, 0.4, 1.0] {
                    let b = RoughDielectric { eta, alpha };
                    let e = energy(|uc, u| b.sample(wo, uc, u), 40_000);
                    assert!(e <= 1.01 && e > 0.25, "η {eta} α {alpha} θ {theta}: {e}");
                    let t = ThinDielectric { eta, alpha };
                    let e = energy(|uc, u| t.sample(wo, uc, u), 40_000);
                    assert!(
                        e <= 1.01 && e > 0.25,
                        "thin η {eta} α {alpha} θ {theta}: {e}"
                    );
                }
            }
        }
    }
}
