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
//!   layering (in the reciprocal form of Kulla & Conty 2017's energy compensation): the base is weighted by
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
use super::multiple_scattering::AtRoughness;
use super::{BsdfSample, LocalSample, DELTA_ALPHA};
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::sampling::cosine_hemisphere;

/// A direction drawn by [`MetallicRoughness::sample_direction_at`].
#[derive(Debug, Clone, Copy)]
pub enum Sampled {
    /// From a delta lobe: the complete sample.
    Delta(LocalSample),
    /// From a smooth lobe: the local direction, to be evaluated.
    Smooth(Vec3),
}

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

/// What a [`MetallicRoughness`] computes for one outgoing direction (local) alone, made by
/// [`MetallicRoughness::outgoing_for`]: evaluations and samples for that direction use it
/// instead of computing it again (with the same results, bit for bit).
#[derive(Debug, Clone, Copy)]
pub struct Outgoing {
    wo: Vec3,
    /// Probabilities of the specular, cosine and transmission strategies.
    probs: [f32; 3],
    /// The sum of the three strategies' albedo estimates (mean over the channels, each lobe
    /// floored at 10⁻³ where present): the BSDF's directional albedo as its sampling sees it
    /// (NaN for smooth glass that transmits everything, whose terms are skipped).
    albedo: f32,
    /// (1 − the dielectric layer's albedo at μo), clamped: the diffuse base's μo factor.
    diffuse_o: f32,
    /// The compensation lobes' μo factor ([`compensation_factor`]).
    compensation_o: f32,
    /// What every pair of directions shares.
    shared: Shared,
}

/// The table terms of a [`MetallicRoughness`] that depend on its roughness and colours alone,
/// found once per shading point for its evaluations: the same values, bit for bit, as the
/// `multiple_scattering` functions give for each pair (which found α's place in the tables,
/// F_ms and the layer's average albedo again in every evaluation).
#[derive(Debug, Clone, Copy)]
struct Shared {
    tables: AtRoughness,
    /// The dielectric F0 ([`MetallicRoughness::f0`]) and its largest channel, the F0 of the
    /// layer albedo that scales the diffuse base.
    f0: Rgb,
    f0_max: f32,
    /// F_ms of the compensation lobes of the metal, the dielectric and the layer albedo; zero
    /// where there are none (smooth, or compensation off).
    f_ms_metal: Rgb,
    f_ms_dielectric: Rgb,
    f_ms_layer: f32,
    /// 1 − the dielectric layer's average albedo (the diffuse base's normalization); ≤ 10⁻⁶
    /// leaves no diffuse base.
    layer_norm: f32,
}

/// The widest specular lobe (GGX α; roughness 0.5) that counts as glossy for
/// [`MetallicRoughness::is_glossy_dominated`]: beyond it light sampling finds the direct light
/// well, and extra BSDF samples for it cost without helping (DamagedHelmet under `studio.exr`,
/// 160², 64 spp, 16 seeds: MSE × spp 0.0191 with and without them on lobes of α ≥ 0.25, for
/// 10 % less time; leaving out α ≥ 0.1 raised it to 0.0199, α ≥ 0.05 to 0.0237).
pub const GLOSSY_MAX_ALPHA: f32 = 0.25;

/// Refractive index standing in for ior 0 or ∞ in the transmissive part (see `eta`).
const DEGENERATE_IOR: f32 = 1e4;

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

    /// Whether nothing is transmitted and the specular lobe is smooth (not a mirror), narrow
    /// (α < [`GLOSSY_MAX_ALPHA`]) and chosen with probability ≥ ½ for the `wo` that `at` was
    /// made for.
    pub fn is_glossy_dominated(&self, at: &Outgoing) -> bool {
        let (_, _, t) = self.weights();
        !self.specular_is_delta()
            && self.alpha() < GLOSSY_MAX_ALPHA
            && t == 0.0
            && at.probs[SPECULAR] >= 0.5
    }

    fn transmission_is_delta(&self) -> bool {
        if self.thin_walled {
            self.thin().is_delta()
        } else {
            self.volume().is_delta()
        }
    }

    /// The index the transmissive part refracts with: `ior`, except that the F0 = 1 values of
    /// `KHR_materials_specular`'s specular-glossiness conversion (ior 0 or ∞), which have no
    /// refraction, become a very dense dielectric (F0 ≈ 0.9996) instead of dividing by zero.
    fn eta(&self) -> f32 {
        if self.ior > 0.0 && self.ior.is_finite() {
            self.ior
        } else {
            DEGENERATE_IOR
        }
    }

    fn volume(&self) -> RoughDielectric {
        RoughDielectric {
            eta: self.eta(),
            alpha: self.alpha(),
            energy_compensation: self.energy_compensation,
        }
    }

    fn thin(&self) -> ThinDielectric {
        ThinDielectric {
            eta: self.eta(),
            alpha: self.alpha(),
            energy_compensation: self.energy_compensation,
        }
    }

    /// The terms shared by all pairs of directions (see [`Shared`]).
    fn shared(&self) -> Shared {
        let tables = AtRoughness::new(self.alpha());
        let f0 = self.f0();
        let f0_max = f0.max_element();
        let comp = self.energy_compensation;
        let f_ms = |c: Rgb| tables.f_ms(c).filter(|_| comp).unwrap_or(Vec3::ZERO);
        let f_ms_layer = f_ms(Vec3::splat(f0_max)).x;
        // 2 ∫ (layer albedo) μ dμ, as `specular_average_albedo` of the splatted F0.
        let single = f0_max * tables.e_avg + (1.0 - f0_max) * tables.e5_avg;
        let avg = if comp && 1.0 - tables.e_avg >= 1e-6 {
            single + f_ms_layer * (1.0 - tables.e_avg)
        } else {
            single
        };
        Shared {
            tables,
            f0,
            f0_max,
            f_ms_metal: f_ms(self.base_color),
            f_ms_dielectric: f_ms(f0),
            f_ms_layer,
            layer_norm: 1.0 - self.spec_weight() * avg,
        }
    }

    /// Largest-channel directional albedo of the dielectric specular layer, times its weight,
    /// given E and E5 at its μ.
    fn layer_albedo(&self, sh: &Shared, (e, e5): (f32, f32)) -> f32 {
        let single = sh.f0_max * e + (1.0 - sh.f0_max) * e5;
        self.spec_weight() * (single + sh.f_ms_layer * (1.0 - e).max(0.0))
    }

    /// The albedo-scaling weight of the diffuse base (see the module doc), given `o`'s
    /// [`Outgoing::diffuse_o`] and E and E5 at μi.
    fn diffuse_scale(&self, sh: &Shared, diffuse_o: f32, e_e5_i: (f32, f32)) -> f32 {
        if sh.layer_norm < 1e-6 {
            return 0.0;
        }
        diffuse_o * (1.0 - self.layer_albedo(sh, e_e5_i)).max(0.0) / sh.layer_norm
    }

    /// Non-delta reflection BRDF (no cosine) for `o`, `i` in the upper hemisphere; `at` was
    /// made for `o` (or its mirror image).
    fn reflection(&self, o: Vec3, i: Vec3, at: &Outgoing) -> Rgb {
        let (m, d, _) = self.weights();
        let w = self.spec_weight();
        let alpha = self.alpha();
        let sh = &at.shared;
        let smooth = !self.specular_is_delta();
        // E and E5 at μi, which the compensation lobes and the diffuse base share.
        let e_e5_i = if (smooth && self.energy_compensation) || d > 0.0 {
            sh.tables.e_e5(i.z)
        } else {
            (0.0, 0.0)
        };
        let mut f = Vec3::ZERO;
        if smooth {
            let wm = (o + i).normalize_or_zero();
            if wm != Vec3::ZERO {
                let spec = ggx_d(wm, alpha) * ggx_g2(o, i, alpha) / (4.0 * o.z * i.z);
                let c = o.dot(wm);
                f += conductor_fresnel(self.base_color, c) * (m * spec);
                f += schlick_f0_f90(sh.f0, Vec3::ONE, c) * (d * w * spec);
            }
            if self.energy_compensation && 1.0 - sh.tables.e_avg >= 1e-6 {
                // `compensation_from` for each lobe, with μi's factor found once.
                let s = at.compensation_o * (1.0 - e_e5_i.0).max(0.0);
                let scale = s * FRAC_1_PI / (1.0 - sh.tables.e_avg);
                f += sh.f_ms_metal * scale * m;
                f += sh.f_ms_dielectric * scale * (d * w);
            }
        }
        if d > 0.0 {
            f += self.base_color * (d * FRAC_1_PI * self.diffuse_scale(sh, at.diffuse_o, e_e5_i));
        }
        f
    }

    /// What depends on `wo` alone (local): the probabilities of the three strategies, from
    /// albedo estimates of their lobes, and the μo factors of the reflection lobes.
    fn outgoing(&self, wo: Vec3) -> Outgoing {
        let mu = wo.z.abs();
        if self.metallic <= 0.0 && self.transmission >= 1.0 && self.specular_is_delta() {
            // Smooth glass that transmits everything (weights 0, 0, 1): the transmissive
            // strategy is the only one (`probs` below would be [0, 0, 1] exactly), and no term
            // of the reflection lobes is ever read (`reflection` reads them only for rough or
            // diffuse parts). A third of the shading cost of GlassVaseFlowers' glass.
            let nan = Vec3::splat(f32::NAN);
            return Outgoing {
                wo,
                probs: [0.0, 0.0, 1.0],
                albedo: f32::NAN,
                diffuse_o: f32::NAN,
                compensation_o: f32::NAN,
                shared: Shared {
                    tables: AtRoughness::unused(),
                    f0: nan,
                    f0_max: f32::NAN,
                    f_ms_metal: nan,
                    f_ms_dielectric: nan,
                    f_ms_layer: f32::NAN,
                    layer_norm: f32::NAN,
                },
            };
        }
        let shared = self.shared();
        let (e, e5) = shared.tables.e_e5(mu);
        let diffuse_o = (1.0 - self.layer_albedo(&shared, (e, e5))).max(0.0);
        let (m, d, t) = self.weights();
        let w = self.spec_weight();
        let comp = self.energy_compensation;
        // The lobes' directional albedos at μo, from the one lookup (`specular_albedo` without
        // and `compensation_albedo`).
        let specular_albedo = |c: Rgb| c * e + (Vec3::ONE - c) * e5;
        let compensation_albedo = |f_ms: Rgb| f_ms * (1.0 - e).max(0.0);
        // A small floor keeps every lobe that can be non-zero samplable.
        let floor = |albedo: f32, present: bool| {
            if present {
                albedo.max(1e-3)
            } else {
                0.0
            }
        };
        let spec =
            m * mean(specular_albedo(self.base_color)) + d * w * mean(specular_albedo(shared.f0));
        let spec = floor(spec, m + d * w > 0.0);
        let mut cosine = d * mean(self.base_color) * diffuse_o;
        if comp && !self.specular_is_delta() {
            cosine += m * mean(compensation_albedo(shared.f_ms_metal))
                + d * w * mean(compensation_albedo(shared.f_ms_dielectric));
        }
        let cosine = floor(
            cosine,
            d > 0.0 || (comp && !self.specular_is_delta() && m + d * w > 0.0),
        );
        let trans = if t > 0.0 {
            let r = fresnel_dielectric(mu, self.eta());
            floor(t * (r + (1.0 - r) * mean(self.base_color)), true)
        } else {
            0.0
        };
        let total = spec + cosine + trans;
        let probs = if total <= 0.0 {
            [0.0; 3]
        } else {
            [spec / total, cosine / total, trans / total]
        };
        Outgoing {
            wo,
            probs,
            albedo: total,
            diffuse_o,
            compensation_o: (1.0 - e).max(0.0),
            shared,
        }
    }

    /// The directional albedo at the `wo` that `at` was made for, as the estimates that choose
    /// its sampling strategies put it (mean over the channels; see [`Outgoing`]): how much of
    /// the light a layer over this base should expect it to return, for choosing between them.
    pub fn albedo_at(&self, at: &Outgoing) -> f32 {
        if at.albedo.is_nan() {
            // Smooth glass that transmits everything (not filled in by `outgoing`, which skips
            // every term for it): what its transmissive strategy would have estimated.
            let r = fresnel_dielectric(at.wo.z.abs(), self.eta());
            return r + (1.0 - r) * mean(self.base_color);
        }
        at.albedo
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
        self.eval_with(wo, wi, &self.outgoing(wo))
    }

    /// [`eval`](Self::eval) given what depends on `wo` alone (computed once per sample).
    fn eval_with(&self, wo: Vec3, wi: Vec3, at: &Outgoing) -> (Rgb, f32) {
        let probs = &at.probs;
        if wo.z == 0.0 || wi.z == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (_, _, t) = self.weights();
        let mut f = Vec3::ZERO;
        let mut pdf = 0.0;
        if wo.z * wi.z > 0.0 {
            let (o, i) = (upper(wo), upper(wi));
            f += self.reflection(o, i, at) * i.z;
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

    /// The relative index η_i / η_o a pair (local frame) crosses: that of the transmissive part
    /// for a refraction through a volume, 1 for reflections and thin-walled transmission.
    pub fn etap(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z >= 0.0 || self.thin_walled {
            1.0
        } else if wo.z > 0.0 {
            self.eta()
        } else {
            1.0 / self.eta()
        }
    }

    /// The pdf with which [`sample`](Self::sample) returns `wi` (that of [`eval`](Self::eval)).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval(wo, wi).1
    }

    /// Samples an incident direction: `u_lobe` chooses the strategy (and, rescaled, reflection
    /// or transmission inside the dielectric), `u` the direction.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<LocalSample> {
        self.sample_with(wo, u_lobe, u, &self.outgoing(wo))
    }

    /// [`sample`](Self::sample) given what depends on `wo` alone.
    fn sample_with(&self, wo: Vec3, u_lobe: f32, u: Vec2, at: &Outgoing) -> Option<LocalSample> {
        if wo.z == 0.0 {
            return None;
        }
        let probs = at.probs;
        let wi = match self.sample_direction_with(wo, u_lobe, u, &probs)? {
            Sampled::Delta(s) => return Some(s),
            Sampled::Smooth(wi) => wi,
        };
        let (f, pdf) = self.eval_with(wo, wi, at);
        if pdf <= 0.0 || f == Vec3::ZERO {
            return None;
        }
        let transmitted = wo.z * wi.z < 0.0;
        let etap = self.etap(wo, wi);
        Some(LocalSample {
            wi,
            weight: f / pdf,
            pdf,
            delta: false,
            transmitted,
            etap,
        })
    }

    /// The direction [`sample`](Self::sample) draws for the `wo` that `at` was made for
    /// ([`outgoing_for`](Self::outgoing_for)), before it is evaluated: a complete sample for
    /// delta lobes, the direction alone for smooth ones (with the density [`pdf`](Self::pdf),
    /// whatever the BSDF's value there: a layered BSDF evaluates its own sum there).
    pub fn sample_direction_at(&self, at: &Outgoing, u_lobe: f32, u: Vec2) -> Option<Sampled> {
        if at.wo.z == 0.0 {
            return None;
        }
        self.sample_direction_with(at.wo, u_lobe, u, &at.probs)
    }

    /// [`sample_direction_at`](Self::sample_direction_at) given `wo`'s strategy probabilities.
    fn sample_direction_with(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        probs: &[f32; 3],
    ) -> Option<Sampled> {
        let (m, d, t) = self.weights();
        let side = wo.z.signum();
        let o = upper(wo);
        let wi = if u_lobe < probs[SPECULAR] {
            if self.specular_is_delta() {
                let fr = conductor_fresnel(self.base_color, o.z) * m
                    + schlick_f0_f90(self.f0(), Vec3::ONE, o.z) * (d * self.spec_weight());
                let p = probs[SPECULAR];
                return Some(Sampled::Delta(LocalSample {
                    wi: Vec3::new(-wo.x, -wo.y, wo.z),
                    weight: fr / p,
                    pdf: p,
                    delta: true,
                    transmitted: false,
                    etap: 1.0,
                }));
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
                return Some(Sampled::Delta(LocalSample {
                    weight: s.weight * tint * (t / p),
                    pdf: s.pdf * p,
                    ..s
                }));
            }
            s.wi
        };
        Some(Sampled::Smooth(wi))
    }
}

impl MetallicRoughness {
    /// Whether a world-space pair is on the same side of the surface by the shading normal but
    /// not by the geometric normal, or the reverse: such pairs would leak light through the
    /// surface and are not scattered (the guard of the legacy `Bsdf::eval`).
    fn leaks(local_same_side: bool, ng: Vec3, wo: Vec3, wi: Vec3) -> bool {
        local_same_side != (wo.dot(ng) * wi.dot(ng) > 0.0)
    }

    /// [`eval`](Self::eval) for world-space directions at a point with shading frame `frame`
    /// (its normal on the front side) and geometric normal `ng`, with the same signature and
    /// meaning as the legacy `Bsdf::eval`.
    pub fn eval_world(&self, frame: &Frame, ng: Vec3, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        self.eval_world_with(frame, ng, wo, wi, None)
    }

    /// [`eval_world`](Self::eval_world) using what `at` holds when it was made for this `wo`
    /// (the same results, without computing it again).
    pub fn eval_world_with(
        &self,
        frame: &Frame,
        ng: Vec3,
        wo: Vec3,
        wi: Vec3,
        at: Option<&Outgoing>,
    ) -> (Rgb, f32) {
        let (lo, li) = (frame.to_local(wo), frame.to_local(wi));
        if Self::leaks(lo.z * li.z > 0.0, ng, wo, wi) {
            return (Vec3::ZERO, 0.0);
        }
        match at {
            Some(at) if at.wo == lo => self.eval_with(lo, li, at),
            _ => self.eval_with(lo, li, &self.outgoing(lo)),
        }
    }

    /// For a smooth transmissive surface (glass: every lobe a Dirac delta, some light
    /// transmitted), the mirror direction of world-space `wo` and the weight (f·|cos θi| / δ)
    /// with which all its lobes together reflect light from there: the expectation of
    /// [`sample_world`](Self::sample_world)'s weight over the samples that return that
    /// direction. `None` for other surfaces, or where the mirror direction would leak through
    /// the geometric surface (then no sample returns it).
    pub fn mirror_reflection_world(
        &self,
        frame: &Frame,
        ng: Vec3,
        wo: Vec3,
    ) -> Option<(Vec3, Rgb)> {
        let (m, d, t) = self.weights();
        if t <= 0.0 || !self.specular_is_delta() {
            return None;
        }
        let lo = frame.to_local(wo);
        if lo.z == 0.0 {
            return None;
        }
        let li = Vec3::new(-lo.x, -lo.y, lo.z);
        let wi = frame.to_world(li);
        if Self::leaks(true, ng, wo, wi) {
            return None;
        }
        let c = lo.z.abs();
        // The opaque specular lobes (the probability of choosing them times their weight),
        // then the transmissive part's reflection: R for a volume, the slab's R′ thin-walled.
        let specular = conductor_fresnel(self.base_color, c) * m
            + schlick_f0_f90(self.f0(), Vec3::ONE, c) * (d * self.spec_weight());
        let r = if self.thin_walled {
            self.thin().smooth_reflectance(c)
        } else {
            self.volume().smooth_reflectance(lo.z)
        };
        Some((wi, specular + Vec3::splat(t * r)))
    }

    /// What depends on world-space `wo` alone, computed once per shading point: the light
    /// sample's evaluation and the BSDF sample both need it (the strategy probabilities cost
    /// about an evaluation, for their albedo estimates).
    pub fn outgoing_for(&self, frame: &Frame, wo: Vec3) -> Outgoing {
        self.outgoing(frame.to_local(wo))
    }

    /// [`sample`](Self::sample) for a world-space `wo`, returning a world-space
    /// [`BsdfSample`] like the legacy `Bsdf::sample` (see [`eval_world`](Self::eval_world)).
    pub fn sample_world(
        &self,
        frame: &Frame,
        ng: Vec3,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
    ) -> Option<BsdfSample> {
        self.sample_world_with(frame, ng, wo, u_lobe, u, None)
    }

    /// [`sample_world`](Self::sample_world) using what `at` holds when it was made for this
    /// `wo` (the same results).
    pub fn sample_world_with(
        &self,
        frame: &Frame,
        ng: Vec3,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        at: Option<&Outgoing>,
    ) -> Option<BsdfSample> {
        let lo = frame.to_local(wo);
        let s = match at {
            Some(at) if at.wo == lo => self.sample_with(lo, u_lobe, u, at)?,
            _ => self.sample_with(lo, u_lobe, u, &self.outgoing(lo))?,
        };
        let world = s.to_world(frame);
        if Self::leaks(lo.z * s.wi.z > 0.0, ng, wo, world.wi) {
            return None;
        }
        Some(world)
    }
}

#[cfg(test)]
mod tests {
    use super::super::chi2;
    use super::super::testing::{dir, hemisphere_integral, random_dir, u3};
    use super::*;
    use crate::sampler::Pcg32;

    /// A material from (base, metallic, roughness, ior, transmission).
    fn mat(
        base: Rgb,
        metallic: f32,
        roughness: f32,
        ior: f32,
        transmission: f32,
    ) -> MetallicRoughness {
        MetallicRoughness {
            ior,
            transmission,
            ..MetallicRoughness::new(base, metallic, roughness)
        }
    }

    const TINT: Vec3 = Vec3::new(0.9, 0.6, 0.3);

    /// Settings spanning the lobes: (name, material, θo in degrees).
    fn rough_settings() -> Vec<(&'static str, MetallicRoughness, f32)> {
        let diffuse_only = MetallicRoughness {
            specular_factor: 0.0,
            ..mat(TINT, 0.0, 0.5, 1.5, 0.0)
        };
        let tinted_specular = MetallicRoughness {
            specular_factor: 0.7,
            specular_color: Vec3::new(1.0, 0.5, 0.2),
            ..mat(TINT, 0.5, 0.6, 1.5, 0.0)
        };
        let single_scatter_metal = MetallicRoughness {
            energy_compensation: false,
            ..mat(TINT, 1.0, 0.8, 1.5, 0.0)
        };
        let thin = MetallicRoughness {
            thin_walled: true,
            ..mat(TINT, 0.2, 0.6, 1.5, 0.7)
        };
        vec![
            ("diffuse", diffuse_only, 30.0),
            ("metal r0.6", mat(TINT, 1.0, 0.6, 1.5, 0.0), 30.0),
            ("metal r0.8 single scattering", single_scatter_metal, 70.0),
            ("plastic", mat(TINT, 0.0, 0.6, 1.5, 0.0), 60.0),
            ("plastic grazing", mat(Vec3::ONE, 0.0, 0.9, 1.5, 0.0), 85.0),
            ("tinted specular", tinted_specular, 10.0),
            ("glass", mat(TINT, 0.0, 0.55, 1.5, 1.0), 40.0),
            ("glass from inside", mat(TINT, 0.0, 0.7, 1.33, 1.0), 130.0),
            ("diamond half metal", mat(TINT, 0.5, 0.8, 2.4, 0.5), 75.0),
            ("thin", thin, 20.0),
        ]
    }

    /// χ² of the whole BSDF's sampling against its pdf for the settings whose parts pass the
    /// filter `transmissive` selects (split in two tests to keep each one fast).
    fn chi2_of_the_whole_bsdf(transmissive: bool) {
        let mut ps = Vec::new();
        for (k, (name, m, theta)) in rough_settings().into_iter().enumerate() {
            if (m.transmission > 0.0) != transmissive {
                continue;
            }
            let wo = dir(theta, 0.4);
            let p = chi2::p_value(
                name,
                100_000,
                200 + k as u64,
                |rng| {
                    let (ul, u) = u3(rng);
                    m.sample(wo, ul, u).map(|s| s.wi)
                },
                |wi| m.pdf(wo, wi),
            );
            ps.push((name.to_string(), p));
        }
        assert!(ps.len() >= 4);
        chi2::assert_all_pass(&ps);
    }

    #[test]
    fn chi2_opaque() {
        chi2_of_the_whole_bsdf(false);
    }

    #[test]
    fn chi2_transmissive() {
        chi2_of_the_whole_bsdf(true);
    }

    #[test]
    fn samples_agree_with_eval() {
        let mut rng = Pcg32::new(6, 6);
        let mut settings = rough_settings();
        settings.push(("smooth plastic", mat(TINT, 0.0, 0.0, 1.5, 0.0), 0.0));
        settings.push(("smooth glass", mat(TINT, 0.3, 0.0, 1.5, 0.8), 0.0));
        settings.push(("near-smooth metal", mat(TINT, 1.0, 0.1, 1.5, 0.0), 0.0));
        let mut taken = 0;
        for (name, m, _) in settings {
            for theta in [0.0f32, 35.0, 70.0, 89.0, 120.0] {
                let wo = dir(theta, 2.0);
                for _ in 0..1000 {
                    let (ul, u) = u3(&mut rng);
                    let Some(s) = m.sample(wo, ul, u) else {
                        continue;
                    };
                    assert!(
                        s.weight.is_finite() && s.weight.min_element() >= 0.0 && s.pdf > 0.0,
                        "{name}: {s:?}"
                    );
                    assert_eq!(s.transmitted, s.wi.z * wo.z < 0.0, "{name}");
                    if s.delta {
                        continue;
                    }
                    let (f, pdf) = m.eval(wo, s.wi);
                    assert!(
                        (s.pdf - pdf).abs() <= 1e-3 * pdf.max(1.0),
                        "{name} θ {theta}: pdf {} vs eval {pdf}",
                        s.pdf
                    );
                    let fs = s.weight * s.pdf;
                    assert!(
                        (fs - f).abs().max_element() <= 1e-3 * f.max_element().max(1.0),
                        "{name} θ {theta}: f {fs:?} vs eval {f:?}"
                    );
                    taken += 1;
                }
            }
        }
        assert!(taken > 40_000, "{taken}");
    }

    #[test]
    fn reciprocity_and_eta_squared_relation() {
        let mut rng = Pcg32::new(12, 3);
        let (mut refl, mut trans) = (0, 0);
        for (name, m, _) in rough_settings() {
            for _ in 0..3000 {
                let wo = random_dir(&mut rng);
                let wi = random_dir(&mut rng);
                let f = |a: Vec3, b: Vec3| m.eval(a, b).0 / b.z.abs();
                let (f_oi, f_io) = (f(wo, wi), f(wi, wo));
                if f_oi.max_element() < 1e-4 {
                    continue;
                }
                // Radiance convention: f(ωo, ωi)/η_o² = f(ωi, ωo)/η_i², η_x the index on ωx's
                // side; thin walls and reflection have η_o = η_i.
                let n = |w: Vec3| {
                    if w.z > 0.0 || m.thin_walled {
                        1.0
                    } else {
                        m.ior
                    }
                };
                let (l, r) = (f_oi / n(wo).powi(2), f_io / n(wi).powi(2));
                assert!(
                    (l - r).abs().max_element() <= 5e-3 * l.max_element(),
                    "{name}: wo {wo:?} wi {wi:?}: {l:?} vs {r:?}"
                );
                if wo.z * wi.z > 0.0 {
                    refl += 1;
                } else {
                    trans += 1;
                }
            }
        }
        assert!(refl > 5000 && trans > 1000, "{refl} {trans}");
    }

    /// Directional albedo in terms of power (transmitted radiance scaled back by η′²), by
    /// sampling: mean of weight·η′².
    fn albedo(m: &MetallicRoughness, wo: Vec3, n: usize, seed: u64) -> Rgb {
        let mut rng = Pcg32::new(seed, 5);
        let mut sum = glam::DVec3::ZERO;
        for _ in 0..n {
            let (ul, u) = u3(&mut rng);
            if let Some(s) = m.sample(wo, ul, u) {
                sum += (s.weight * (s.etap * s.etap)).as_dvec3();
            }
        }
        (sum / n as f64).as_vec3()
    }

    #[test]
    fn albedo_never_exceeds_one() {
        let mut worst = 0.0f32;
        for roughness in [0.0f32, 0.3, 0.7, 1.0] {
            for metallic in [0.0f32, 0.5, 1.0] {
                for (ior, transmission) in [(1.5f32, 0.0f32), (1.5, 1.0), (1.0, 1.0), (2.4, 0.5)] {
                    for theta in [0.0f32, 45.0, 80.0, 89.0, 135.0] {
                        let m = mat(Vec3::ONE, metallic, roughness, ior, transmission);
                        let a = albedo(&m, dir(theta, 0.0), 10_000, 1).max_element();
                        worst = worst.max(a);
                        // 10⁴ samples of weights ≤ ~1: 3σ ≲ 0.01.
                        assert!(
                            a <= 1.01,
                            "r {roughness} m {metallic} ior {ior} t {transmission} θ {theta}: {a}"
                        );
                    }
                }
            }
        }
        assert!(worst > 0.97, "no setting near 1: {worst}");
    }

    /// White furnace: a white rough metal reflects everything with compensation (within 1 %),
    /// and measurably less without it; a white dielectric (diffuse under a specular layer) too.
    #[test]
    fn white_furnace() {
        for roughness in [0.2f32, 0.5, 0.8, 1.0] {
            for theta in [0.0f32, 30.0, 60.0, 80.0] {
                let wo = dir(theta, 0.0);
                let metal = mat(Vec3::ONE, 1.0, roughness, 1.5, 0.0);
                let with = albedo(&metal, wo, 40_000, 2).x;
                let without = albedo(
                    &MetallicRoughness {
                        energy_compensation: false,
                        ..metal
                    },
                    wo,
                    40_000,
                    2,
                )
                .x;
                eprintln!(
                    "white furnace r {roughness} θ {theta}: with {with:.4} without {without:.4}"
                );
                assert!(
                    (with - 1.0).abs() < 0.01,
                    "metal r {roughness} θ {theta}: {with}"
                );
                // Single scattering loses energy, the more the rougher.
                assert!(
                    without < with,
                    "r {roughness} θ {theta}: {without} vs {with}"
                );
                if roughness >= 0.5 {
                    assert!(without < 0.97, "r {roughness} θ {theta}: {without}");
                }
                let plastic = mat(Vec3::ONE, 0.0, roughness, 1.5, 0.0);
                let a = albedo(&plastic, wo, 40_000, 3).x;
                assert!(
                    (a - 1.0).abs() < 0.01,
                    "plastic r {roughness} θ {theta}: {a}"
                );
            }
        }
    }

    /// What depends on `wo` alone, made once per shading point, gives exactly the results of
    /// computing it per call, and what was made for another `wo` is not used.
    #[test]
    fn outgoing_terms_made_once_change_nothing() {
        let mut rng = Pcg32::new(7, 3);
        let frame = Frame::from_normal(Vec3::new(0.3, 0.2, 0.93).normalize());
        let ng = frame.n;
        for k in 0..2_000 {
            let m = mat(
                TINT,
                [0.0, 0.4, 1.0][k % 3],
                [0.0, 0.05, 0.3, 0.9][k % 4],
                [1.0, 1.5, 2.4][k % 3],
                [0.0, 0.0, 0.6, 1.0][(k / 3) % 4],
            );
            let (wo, wi, other) = (
                random_dir(&mut rng),
                random_dir(&mut rng),
                random_dir(&mut rng),
            );
            let at = m.outgoing_for(&frame, wo);
            let key = |e: (Rgb, f32)| (e.0.to_array().map(f32::to_bits), e.1.to_bits());
            for (o, i) in [(wo, wi), (other, wi)] {
                assert_eq!(
                    key(m.eval_world_with(&frame, ng, o, i, Some(&at))),
                    key(m.eval_world(&frame, ng, o, i))
                );
                let (ul, u) = u3(&mut rng);
                let bits = |s: Option<BsdfSample>| {
                    s.map(|s| (s.wi.to_array().map(f32::to_bits), s.pdf.to_bits(), s.delta))
                };
                assert_eq!(
                    bits(m.sample_world_with(&frame, ng, o, ul, u, Some(&at))),
                    bits(m.sample_world(&frame, ng, o, ul, u))
                );
            }
        }
    }

    /// Smooth glass that transmits everything skips the reflection lobes' terms (`outgoing`
    /// leaves them NaN): sampling and evaluation must never read them, whatever the side,
    /// the index, the tint or the thin-walled flag.
    #[test]
    fn smooth_clear_glass_reads_none_of_the_reflection_terms() {
        let mut rng = Pcg32::new(3, 9);
        let frame = Frame::from_normal(Vec3::Z);
        for k in 0..4_000 {
            let mut m = mat(
                Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                0.0,
                0.0,
                [1.0, 1.33, 1.5, 2.4][k % 4],
                1.0,
            );
            m.thin_walled = k % 3 == 0;
            m.energy_compensation = k % 5 != 0;
            let (o, i) = (random_dir(&mut rng), random_dir(&mut rng));
            let at = m.outgoing(o);
            assert_eq!(at.probs, [0.0, 0.0, 1.0]);
            let (f, pdf) = m.eval_with(o, i, &at);
            assert!(f.is_finite() && pdf.is_finite(), "{m:?}: eval {f} {pdf}");
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            if let Some(s) = m.sample_world(&frame, Vec3::Z, o, rng.next_f32(), u) {
                assert!(
                    s.weight.is_finite() && s.wi.is_finite() && s.pdf.is_finite(),
                    "{m:?}: sample {s:?}"
                );
            }
        }
    }

    /// The reflection lobes with their table terms found once per shading point (`Shared`)
    /// equal, bit for bit, the glTF reflection written with the per-pair functions of
    /// `multiple_scattering` (each finding α's place in the tables, F_ms and the layer's
    /// average albedo for itself), and so do the strategy probabilities and μo factors.
    #[test]
    fn shared_table_terms_equal_the_per_pair_formulas() {
        use super::super::multiple_scattering::{
            compensation_albedo, compensation_factor, compensation_from, specular_albedo,
            specular_average_albedo,
        };
        let mut rng = Pcg32::new(11, 5);
        for k in 0..3_000 {
            let mut m = mat(
                Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                [0.0, 0.3, 1.0][k % 3],
                [0.0, 0.02, 0.05, 0.3, 0.7, 1.0][k % 6],
                [1.0, 1.33, 1.5, 2.4][k % 4],
                0.0,
            );
            m.specular_factor = [1.0, 0.5, 0.0][(k / 3) % 3];
            m.energy_compensation = k % 5 != 0;
            let (o, i) = (upper(random_dir(&mut rng)), upper(random_dir(&mut rng)));
            let at = m.outgoing(o);
            // The formulas as written per pair.
            let (mm, d, _) = m.weights();
            let w = m.spec_weight();
            let alpha = m.alpha();
            let comp = m.energy_compensation;
            let f0_max = Vec3::splat(m.f0().max_element());
            let layer = |mu: f32| w * specular_albedo(mu, alpha, f0_max, comp).x;
            let mut f = Vec3::ZERO;
            if !m.specular_is_delta() {
                let wm = (o + i).normalize_or_zero();
                if wm != Vec3::ZERO {
                    let spec = ggx_d(wm, alpha) * ggx_g2(o, i, alpha) / (4.0 * o.z * i.z);
                    let c = o.dot(wm);
                    f += conductor_fresnel(m.base_color, c) * (mm * spec);
                    f += schlick_f0_f90(m.f0(), Vec3::ONE, c) * (d * w * spec);
                }
                if comp {
                    let factor_o = compensation_factor(o.z, alpha);
                    f += compensation_from(factor_o, i.z, alpha, m.base_color) * mm;
                    f += compensation_from(factor_o, i.z, alpha, m.f0()) * (d * w);
                }
            }
            let diffuse_o = (1.0 - layer(o.z)).max(0.0);
            if d > 0.0 {
                let avg = w * specular_average_albedo(alpha, f0_max, comp).x;
                let scale = if 1.0 - avg < 1e-6 {
                    0.0
                } else {
                    diffuse_o * (1.0 - layer(i.z)).max(0.0) / (1.0 - avg)
                };
                f += m.base_color * (d * FRAC_1_PI * scale);
            }
            let bits = |c: Rgb| c.to_array().map(f32::to_bits);
            assert_eq!(bits(m.reflection(o, i, &at)), bits(f), "case {k}: {m:?}");
            assert_eq!(at.diffuse_o.to_bits(), diffuse_o.to_bits(), "case {k}");
            assert_eq!(
                at.compensation_o.to_bits(),
                compensation_factor(o.z, alpha).to_bits()
            );
            let spec = mm * mean(specular_albedo(o.z, alpha, m.base_color, false))
                + d * w * mean(specular_albedo(o.z, alpha, m.f0(), false));
            let mut cosine = d * mean(m.base_color) * diffuse_o;
            if comp && !m.specular_is_delta() {
                cosine += mm * mean(compensation_albedo(o.z, alpha, m.base_color))
                    + d * w * mean(compensation_albedo(o.z, alpha, m.f0()));
            }
            let (spec, cosine) = (spec.max(1e-3), cosine.max(1e-3));
            let total = spec + cosine;
            if mm + d * w > 0.0 && (d > 0.0 || (comp && !m.specular_is_delta())) {
                assert_eq!(
                    at.probs[SPECULAR].to_bits(),
                    (spec / total).to_bits(),
                    "case {k}"
                );
            }
        }
    }

    /// Why the diffuse base is albedo-scaled rather than weighted by glTF's literal
    /// `fresnel_mix` (1 − F(V·H)): the literal form reflects more than it receives at grazing
    /// view (measured ≈ 1.29 at roughness 0.3, θo = 85°, by quadrature of the evaluated BRDF).
    #[test]
    fn literal_fresnel_mix_is_not_energy_conserving() {
        use super::super::fresnel::fresnel_mix;
        let alpha = 0.09;
        let o = dir(85.0, 0.0);
        let literal = hemisphere_integral(600, |wi| {
            let wm = (o + wi).normalize();
            let spec = ggx_d(wm, alpha) * ggx_g2(o, wi, alpha) / (4.0 * o.z * wi.z);
            let diffuse = Vec3::splat(FRAC_1_PI);
            let f = fresnel_mix(1.5, 1.0, Vec3::ONE, o.dot(wm), diffuse, Vec3::splat(spec));
            (f.x * wi.z) as f64
        });
        assert!(literal > 1.2, "literal glTF albedo {literal}");
        let ours = albedo(&mat(Vec3::ONE, 0.0, 0.3, 1.5, 0.0), o, 40_000, 4).x;
        assert!((ours - 1.0).abs() < 0.01, "albedo-scaled {ours}");
    }

    /// The χ² test has power here: the sampler of one roughness against the pdf of a slightly
    /// different one is rejected.
    #[test]
    fn chi2_rejects_a_slightly_wrong_pdf() {
        let m = mat(TINT, 0.7, 0.5, 1.5, 0.0);
        let wrong = mat(TINT, 0.7, 0.53, 1.5, 0.0);
        let wo = dir(40.0, 0.0);
        let p = chi2::p_value(
            "wrong roughness",
            100_000,
            99,
            |rng| {
                let (ul, u) = u3(rng);
                m.sample(wo, ul, u).map(|s| s.wi)
            },
            |wi| wrong.pdf(wo, wi),
        );
        assert!(p < 1e-6, "p = {p}");
    }

    /// The world-space entry points agree with each other under a tilted shading normal and
    /// refuse pairs that the geometric normal puts on the other side.
    #[test]
    fn world_space_entry_points() {
        let frame = Frame::from_normal(Vec3::new(0.3, -0.2, 1.0).normalize());
        let ng = Vec3::Z;
        let mut rng = Pcg32::new(21, 4);
        let mut taken = 0;
        for m in [mat(TINT, 0.3, 0.5, 1.5, 0.0), mat(TINT, 0.0, 0.4, 1.5, 1.0)] {
            for wo in [dir(20.0, 0.5), dir(80.0, 2.5), dir(140.0, 1.0)] {
                for _ in 0..2000 {
                    let (ul, u) = u3(&mut rng);
                    let Some(s) = m.sample_world(&frame, ng, wo, ul, u) else {
                        continue;
                    };
                    assert_eq!(s.transmitted, wo.dot(ng) * s.wi.dot(ng) < 0.0);
                    let (f, pdf) = m.eval_world(&frame, ng, wo, s.wi);
                    assert!((s.pdf - pdf).abs() <= 1e-3 * pdf.max(1.0));
                    assert!(
                        (s.weight * s.pdf - f).abs().max_element()
                            <= 1e-3 * f.max_element().max(1.0)
                    );
                    taken += 1;
                }
            }
        }
        assert!(taken > 5000, "{taken}");
        // Above the shading horizon but below the geometric one: no reflection.
        let m = mat(TINT, 0.0, 0.5, 1.5, 0.0);
        let n = frame.n;
        let wi = (Vec3::new(n.x, n.y, 0.0).normalize() * 0.995 - Vec3::Z * 0.1).normalize();
        assert!(frame.to_local(wi).z > 0.0 && wi.dot(ng) < 0.0);
        assert_eq!(
            m.eval_world(&frame, ng, dir(10.0, 0.0), wi),
            (Vec3::ZERO, 0.0)
        );
    }

    /// ior 0 and ∞ (F0 = 1, used to convert specular-glossiness materials) give finite values
    /// and no energy gain, with or without transmission.
    #[test]
    fn degenerate_ior_is_finite() {
        let mut rng = Pcg32::new(30, 1);
        for ior in [0.0f32, f32::INFINITY] {
            for (roughness, transmission, thin_walled) in [
                (0.0f32, 0.0f32, false),
                (0.5, 0.0, false),
                (0.5, 0.6, false),
                (0.0, 1.0, false),
                (0.4, 0.5, true),
            ] {
                let m = MetallicRoughness {
                    thin_walled,
                    ..mat(TINT, 0.0, roughness, ior, transmission)
                };
                for theta in [10.0f32, 60.0, 120.0] {
                    let wo = dir(theta, 0.3);
                    for _ in 0..500 {
                        let (ul, u) = u3(&mut rng);
                        if let Some(s) = m.sample(wo, ul, u) {
                            assert!(
                                s.weight.is_finite() && s.pdf.is_finite(),
                                "ior {ior}: {s:?}"
                            );
                            let (f, pdf) = m.eval(wo, s.wi);
                            assert!(f.is_finite() && pdf.is_finite(), "ior {ior}");
                        }
                    }
                    let a = albedo(&m, wo, 5_000, 7).max_element();
                    assert!(a <= 1.01, "ior {ior} r {roughness} t {transmission}: {a}");
                }
            }
        }
    }
}
