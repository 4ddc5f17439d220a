//! The glTF 2.0 metallic-roughness BSDF at one shading point (glTF 2.0 specification, Appendix B
//! "BRDF Implementation"), with the parameters of `KHR_materials_ior`, `KHR_materials_specular`
//! and `KHR_materials_transmission`, given as plain numbers (textures already applied):
//!
//! ```text
//! metal      = conductor_fresnel(baseColor, specular_brdf(α))
//! dielectric = fresnel_mix(ior, specular, base = mix(diffuse_brdf(baseColor),
//!                                                    specular_btdf(α) · baseColor, transmission),
//!                          layer = specular_brdf(α))
//! material   = mix(dielectric, metal, metallic)                    α = roughness²
//! ```
//!
//! `specular_brdf` is GGX with height-correlated Smith G2 ([`microfacet`](super::microfacet)),
//! plus, when [`MetallicRoughness::energy_compensation`] is on, the Kulla–Conty
//! multiple-scattering lobe ([`multiple_scattering`](super::multiple_scattering)) with the same
//! Fresnel tint. Two points differ from a literal reading of Appendix B, to keep the BSDF energy
//! conserving and reciprocal (both checked by the tests):
//!
//! - **Diffuse under the specular layer.** Appendix B weighs the diffuse base by
//!   1 − specular·max(F(V·H)), evaluated at the half vector of each pair; at grazing view the
//!   specular layer then reflects almost everything while the diffuse base still receives nearly
//!   all of its weight, and the albedo exceeds 1. We use the albedo-scaling form of the same
//!   layering (Kulla & Conty 2017, slide 21): the base is weighted by
//!   (1 − a(μo))(1 − a(μi)) / (1 − a_avg), where a(μ) is the directional albedo of the specular
//!   layer (its largest channel, times the specular factor) and a_avg its cosine-weighted mean —
//!   exactly the energy the layer did not reflect, reciprocal by construction.
//! - **Transmission.** The transmitted part is the rough dielectric BSDF of
//!   [`dielectric`](super::dielectric) with η = ior and the exact Fresnel equations (Walter et al.
//!   2007), its transmission tinted by the base colour, so that reflection + transmission conserve
//!   energy; the glTF Schlick `fresnel_mix` is its approximation. The specular factor and colour
//!   of `KHR_materials_specular` do not act on this part. Without a volume
//!   ([`MetallicRoughness::thin_walled`]) it is the thin-walled slab instead (no bending).
//!
//! Conventions are those of the legacy [`Bsdf`](super::Bsdf): local shading frame (z = shading
//! normal on the front, outside, side), `wo` towards the viewer, `wi` towards the light; `eval`
//! returns f·|cos θi| and the pdf with which `sample` produces `wi`; the sample weight is
//! f·|cos θi|/pdf; delta lobes carry their discrete probability as pdf. The reflection lobes are
//! two-sided (a back-side `wo` sees the same BRDF mirrored). The caller rejects directions on
//! the wrong side of the geometric normal, as `Bsdf::eval` does.
//!
//! Sampling (pbrt-v4 style, one sample, no MIS between lobes): three strategies — GGX visible
//! normals (metal and dielectric specular layers), cosine-weighted hemisphere (diffuse and
//! multiple-scattering lobes), and the dielectric's own sampler — are chosen in proportion to an
//! estimate of the albedo of the lobes they serve; the pdf is the probability-weighted sum of all
//! strategies' pdfs, so [`MetallicRoughness::eval`] and [`MetallicRoughness::sample`] agree.

use std::f32::consts::FRAC_1_PI;

use super::dielectric::{RoughDielectric, ThinDielectric};
use super::fresnel::{conductor_fresnel, dielectric_f0, fresnel_dielectric, schlick_f0_f90};
use super::microfacet::{ggx_d, ggx_g2, ggx_reflect_pdf, ggx_sample_visible};
use super::multiple_scattering::{
    compensation, compensation_albedo, specular_albedo, specular_average_albedo,
};
use super::{LocalSample, DELTA_ALPHA};
use crate::math::{Rgb, Vec2, Vec3};
use crate::sampling::cosine_hemisphere;

/// The glTF metallic-roughness parameters of one shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetallicRoughness {
    /// Base colour (linear RGB): diffuse albedo, metal F0, transmission tint.
    pub base_color: Rgb,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]; the GGX width is α = roughness².
    pub roughness: f32,
    /// Index of refraction (`KHR_materials_ior`, default 1.5); F0 = ((ior − 1)/(ior + 1))².
    pub ior: f32,
    /// Strength of the dielectric specular layer (`KHR_materials_specular`, default 1).
    pub specular_factor: f32,
    /// Tint of the dielectric F0 (`KHR_materials_specular`, default white).
    pub specular_color: Rgb,
    /// Fraction of the dielectric base that is transmitted (`KHR_materials_transmission`).
    pub transmission: f32,
    /// Thin-walled transmission (no `KHR_materials_volume`): no refraction of the direction.
    pub thin_walled: bool,
    /// Add the Kulla–Conty multiple-scattering lobes to the GGX reflection layers.
    pub energy_compensation: bool,
}

/// Index of the three sampling strategies in the probabilities.
const SPECULAR: usize = 0;
const COSINE: usize = 1;
const TRANSMISSION: usize = 2;

/// The upper-hemisphere representative of a pair on one side (point reflection keeps all dot
/// products, so the isotropic reflection lobes see the same configuration).
fn upper(w: Vec3) -> Vec3 {
    if w.z < 0.0 {
        -w
    } else {
        w
    }
}

fn mean(c: Rgb) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

impl MetallicRoughness {
    /// The core glTF material (no extensions: ior 1.5, specular 1 and white, no transmission),
    /// with energy compensation.
    pub fn new(base_color: Rgb, metallic: f32, roughness: f32) -> MetallicRoughness {
        MetallicRoughness {
            base_color,
            metallic,
            roughness,
            ior: 1.5,
            specular_factor: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            thin_walled: false,
            energy_compensation: true,
        }
    }

    /// GGX width α = roughness².
    pub fn alpha(&self) -> f32 {
        let r = self.roughness.clamp(0.0, 1.0);
        r * r
    }

    fn specular_is_delta(&self) -> bool {
        self.alpha() < DELTA_ALPHA
    }

    /// Weights of the metal, opaque-dielectric and transmissive-dielectric parts.
    fn weights(&self) -> (f32, f32, f32) {
        let m = self.metallic.clamp(0.0, 1.0);
        let t = self.transmission.clamp(0.0, 1.0);
        (m, (1.0 - m) * (1.0 - t), (1.0 - m) * t)
    }

    fn spec_weight(&self) -> f32 {
        self.specular_factor.clamp(0.0, 1.0)
    }

    fn f0(&self) -> Rgb {
        dielectric_f0(self.ior, self.specular_color)
    }

    /// Whether any lobe is non-delta, so light sampling can help.
    pub fn has_smooth_lobe(&self) -> bool {
        let (_, d, t) = self.weights();
        !self.specular_is_delta() || d > 0.0 || (t > 0.0 && !self.transmission_is_delta())
    }

    fn transmission_is_delta(&self) -> bool {
        if self.thin_walled {
            self.thin().is_delta()
        } else {
            self.volume().is_delta()
        }
    }

    fn volume(&self) -> RoughDielectric {
        RoughDielectric {
            eta: self.ior,
            alpha: self.alpha(),
        }
    }

    fn thin(&self) -> ThinDielectric {
        ThinDielectric {
            eta: self.ior,
            alpha: self.alpha(),
        }
    }

    /// Largest-channel directional albedo of the dielectric specular layer, times its weight.
    fn layer_albedo(&self, mu: f32) -> f32 {
        let f0 = Vec3::splat(self.f0().max_element());
        self.spec_weight() * specular_albedo(mu, self.alpha(), f0, self.energy_compensation).x
    }

    /// The albedo-scaling weight of the diffuse base (see the module doc).
    fn diffuse_scale(&self, mu_o: f32, mu_i: f32) -> f32 {
        let f0 = Vec3::splat(self.f0().max_element());
        let avg = self.spec_weight()
            * specular_average_albedo(self.alpha(), f0, self.energy_compensation).x;
        if 1.0 - avg < 1e-6 {
            return 0.0;
        }
        (1.0 - self.layer_albedo(mu_o)).max(0.0) * (1.0 - self.layer_albedo(mu_i)).max(0.0)
            / (1.0 - avg)
    }

    /// Non-delta reflection BRDF (no cosine) for `o`, `i` in the upper hemisphere.
    fn reflection(&self, o: Vec3, i: Vec3) -> Rgb {
        let (m, d, _) = self.weights();
        let w = self.spec_weight();
        let alpha = self.alpha();
        let mut f = Vec3::ZERO;
        if !self.specular_is_delta() {
            let wm = (o + i).normalize_or_zero();
            if wm != Vec3::ZERO {
                let spec = ggx_d(wm, alpha) * ggx_g2(o, i, alpha) / (4.0 * o.z * i.z);
                let c = o.dot(wm);
                f += conductor_fresnel(self.base_color, c) * (m * spec);
                f += schlick_f0_f90(self.f0(), Vec3::ONE, c) * (d * w * spec);
            }
            if self.energy_compensation {
                f += compensation(o.z, i.z, alpha, self.base_color) * m;
                f += compensation(o.z, i.z, alpha, self.f0()) * (d * w);
            }
        }
        if d > 0.0 {
            f += self.base_color * (d * FRAC_1_PI * self.diffuse_scale(o.z, i.z));
        }
        f
    }

    /// Probabilities of the three strategies for `wo`, from albedo estimates of their lobes.
    fn strategy_probs(&self, wo: Vec3) -> [f32; 3] {
        let mu = wo.z.abs();
        let (m, d, t) = self.weights();
        let w = self.spec_weight();
        let alpha = self.alpha();
        let comp = self.energy_compensation;
        // A small floor keeps every lobe that can be non-zero samplable.
        let floor = |albedo: f32, present: bool| {
            if present {
                albedo.max(1e-3)
            } else {
                0.0
            }
        };
        let spec = m * mean(specular_albedo(mu, alpha, self.base_color, false))
            + d * w * mean(specular_albedo(mu, alpha, self.f0(), false));
        let spec = floor(spec, m + d * w > 0.0);
        let mut cosine = d * mean(self.base_color) * (1.0 - self.layer_albedo(mu)).max(0.0);
        if comp && !self.specular_is_delta() {
            cosine += m * mean(compensation_albedo(mu, alpha, self.base_color))
                + d * w * mean(compensation_albedo(mu, alpha, self.f0()));
        }
        let cosine = floor(
            cosine,
            d > 0.0 || (comp && !self.specular_is_delta() && m + d * w > 0.0),
        );
        let trans = if t > 0.0 {
            let r = fresnel_dielectric(mu, self.ior);
            floor(t * (r + (1.0 - r) * mean(self.base_color)), true)
        } else {
            0.0
        };
        let total = spec + cosine + trans;
        if total <= 0.0 {
            return [0.0; 3];
        }
        [spec / total, cosine / total, trans / total]
    }

    /// The transmissive part's f·|cos θi| and pdf (scalar), and its η′ for transmission.
    fn transmission_eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if self.thin_walled {
            self.thin().eval(wo, wi)
        } else {
            self.volume().eval(wo, wi)
        }
    }

    /// f·|cos θi| for the pair (local frame) and the pdf with which [`sample`](Self::sample)
    /// returns `wi`; delta lobes contribute nothing.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z == 0.0 || wi.z == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let probs = self.strategy_probs(wo);
        let (_, _, t) = self.weights();
        let mut f = Vec3::ZERO;
        let mut pdf = 0.0;
        if wo.z * wi.z > 0.0 {
            let (o, i) = (upper(wo), upper(wi));
            f += self.reflection(o, i) * i.z;
            pdf += probs[COSINE] * i.z * FRAC_1_PI;
            if probs[SPECULAR] > 0.0 && !self.specular_is_delta() {
                let wm = (o + i).normalize_or_zero();
                if wm != Vec3::ZERO {
                    pdf += probs[SPECULAR] * ggx_reflect_pdf(o, wm, self.alpha());
                }
            }
        }
        if t > 0.0 {
            let (ft, pt) = self.transmission_eval(wo, wi);
            let tint = if wo.z * wi.z < 0.0 {
                self.base_color
            } else {
                Vec3::ONE
            };
            f += tint * (ft * t);
            pdf += probs[TRANSMISSION] * pt;
        }
        (f, pdf)
    }

    /// The pdf with which [`sample`](Self::sample) returns `wi` (that of [`eval`](Self::eval)).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval(wo, wi).1
    }

    /// Samples an incident direction: `u_lobe` chooses the strategy (and, rescaled, reflection
    /// or transmission inside the dielectric), `u` the direction.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<LocalSample> {
        if wo.z == 0.0 {
            return None;
        }
        let probs = self.strategy_probs(wo);
        let (m, d, t) = self.weights();
        let side = wo.z.signum();
        let o = upper(wo);
        let wi = if u_lobe < probs[SPECULAR] {
            if self.specular_is_delta() {
                let fr = conductor_fresnel(self.base_color, o.z) * m
                    + schlick_f0_f90(self.f0(), Vec3::ONE, o.z) * (d * self.spec_weight());
                let p = probs[SPECULAR];
                return Some(LocalSample {
                    wi: Vec3::new(-wo.x, -wo.y, wo.z),
                    weight: fr / p,
                    pdf: p,
                    delta: true,
                    transmitted: false,
                    etap: 1.0,
                });
            }
            let wm = ggx_sample_visible(o, self.alpha(), u);
            let i = 2.0 * o.dot(wm) * wm - o;
            if i.z <= 0.0 {
                return None;
            }
            i * side
        } else if u_lobe < probs[SPECULAR] + probs[COSINE] {
            let i = cosine_hemisphere(u);
            if i.z <= 0.0 {
                return None;
            }
            i * side
        } else {
            if probs[TRANSMISSION] <= 0.0 {
                return None;
            }
            let uc = ((u_lobe - probs[SPECULAR] - probs[COSINE]) / probs[TRANSMISSION])
                .clamp(0.0, 1.0 - f32::EPSILON);
            let s = if self.thin_walled {
                self.thin().sample(wo, uc, u)?
            } else {
                self.volume().sample(wo, uc, u)?
            };
            if s.delta {
                let tint = if s.transmitted {
                    self.base_color
                } else {
                    Vec3::ONE
                };
                let p = probs[TRANSMISSION];
                return Some(LocalSample {
                    weight: s.weight * tint * (t / p),
                    pdf: s.pdf * p,
                    ..s
                });
            }
            s.wi
        };
        let (f, pdf) = self.eval(wo, wi);
        if pdf <= 0.0 || f == Vec3::ZERO {
            return None;
        }
        let transmitted = wo.z * wi.z < 0.0;
        let etap = if !transmitted || self.thin_walled {
            1.0
        } else if wo.z > 0.0 {
            self.ior
        } else {
            1.0 / self.ior
        };
        Some(LocalSample {
            wi,
            weight: f / pdf,
            pdf,
            delta: false,
            transmitted,
            etap,
        })
    }
}
