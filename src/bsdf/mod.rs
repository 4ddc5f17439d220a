//! Scattering at a surface: glTF 2.0's metallic-roughness BSDF ([`metallic_roughness`]) or,
//! when a material only reflects diffusely, the plain Lambertian lobe it reduces to (so a
//! diffuse surface costs what Lambert costs).
//!
//! Conventions follow pbrt-v4 ch. 9: `wo` points away from the surface towards the viewer, `wi`
//! towards the light; `f` includes no cosine; sample weights are f·|cos θi| / pdf.
//!
//! The submodules are the scattering functions: [`microfacet`] (GGX), [`fresnel`],
//! [`dielectric`] (rough and thin-walled interfaces), [`multiple_scattering`] (Kulla–Conty
//! energy compensation) and [`metallic_roughness`] (the glTF BSDF itself).

use std::f32::consts::FRAC_1_PI;

use crate::lanes::{F32s, Mask, V3s};
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::sampling::cosine_hemisphere;

#[cfg(test)]
pub(crate) mod chi2;
pub mod dielectric;
mod dielectric_table;
pub mod fresnel;
pub mod layered;
pub mod metallic_roughness;
pub mod microfacet;
pub mod multiple_scattering;
mod tables;
#[cfg(test)]
mod testing;

pub use fresnel::fresnel_dielectric;
pub use metallic_roughness::{MetallicRoughness, Outgoing};

/// The scattering function of one surface point (textures already applied).
#[derive(Debug, Clone)]
pub struct Bsdf {
    /// Shading frame; `frame.n` is on the front side (that of the geometric normal).
    pub frame: Frame,
    /// Geometric normal (front side).
    pub ng: Vec3,
    /// The lobes.
    pub lobes: Lobes,
}

/// The lobes a material needs at a point: only those it uses are built.
#[derive(Debug, Clone)]
pub enum Lobes {
    /// A Lambertian reflector of this albedo, on both faces (a material with no metal, no
    /// specular reflection and no transmission).
    Lambert(Rgb),
    /// The full glTF metallic-roughness BSDF, with what depends on the `wo` it was made for
    /// alone.
    MetallicRoughness(MetallicRoughness, Outgoing),
    /// The metallic-roughness base under sheen and/or clearcoat layers (boxed: it is large, and
    /// every other hit would pay for copying it).
    Layered(Box<layered::Layered>),
}

/// ∫ f(ωi) dωi over the upper hemisphere by the midpoint rule on an n × n grid in (cos θ, φ),
/// whose cells have equal solid angle 2π / n² (used to tabulate albedos, and by the tests to
/// check sampling routines without one).
#[cfg(test)]
pub(crate) fn hemisphere_integral(n: usize, mut f: impl FnMut(Vec3) -> f64) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..n {
        let z = (i as f32 + 0.5) / n as f32;
        let r = (1.0 - z * z).sqrt();
        for j in 0..n {
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / n as f32;
            sum += f(Vec3::new(r * phi.cos(), r * phi.sin(), z));
        }
    }
    sum * std::f64::consts::TAU / (n * n) as f64
}

/// Roughness α below which a GGX lobe is treated as a perfect mirror (or smooth interface).
pub const DELTA_ALPHA: f32 = 1e-3;

/// A sampled direction.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample {
    /// World-space incident direction (unit).
    pub wi: Vec3,
    /// f·|cos θi| / pdf, including the lobe-selection probability.
    pub weight: Rgb,
    /// Solid-angle pdf of the mixture for non-delta samples; the lobe probability for delta ones.
    pub pdf: f32,
    /// Whether the direction came from a Dirac delta lobe (mirror or smooth dielectric).
    pub delta: bool,
    /// Whether the direction passes through the surface.
    pub transmitted: bool,
    /// Relative index of refraction η_i / η_o across the boundary for transmitted samples, 1
    /// otherwise (as [`LocalSample::etap`]): a refraction scales radiance by 1/η′², which the
    /// path tracer's Russian roulette divides back out of the throughput.
    pub etap: f32,
}

/// A direction sampled by the lobes of [`metallic_roughness`] and [`dielectric`], in the local
/// shading frame (z = shading normal on the front side). Same conventions as [`BsdfSample`]; turn
/// it into one with [`LocalSample::to_world`].
#[derive(Debug, Clone, Copy)]
pub struct LocalSample {
    /// Local incident direction (unit).
    pub wi: Vec3,
    /// f·|cos θi| / pdf, including the lobe-selection probability.
    pub weight: Rgb,
    /// Solid-angle pdf of the mixture for non-delta samples; the discrete probability of the
    /// chosen delta lobe for delta ones.
    pub pdf: f32,
    /// Whether the direction came from a Dirac delta lobe.
    pub delta: bool,
    /// Whether the direction passes through the surface (`wi.z` and `wo.z` of opposite signs).
    pub transmitted: bool,
    /// Relative index of refraction η_i / η_o across the boundary for transmitted samples (the
    /// index on `wi`'s side over that on `wo`'s side), 1 otherwise (pbrt-v4's `BSDFSample::eta`).
    pub etap: f32,
}

impl LocalSample {
    /// The same sample with `wi` expressed in world space through `frame`.
    pub fn to_world(&self, frame: &Frame) -> BsdfSample {
        BsdfSample {
            wi: frame.to_world(self.wi),
            weight: self.weight,
            pdf: self.pdf,
            delta: self.delta,
            transmitted: self.transmitted,
            etap: self.etap,
        }
    }
}

impl Bsdf {
    /// Whether any lobe has a non-delta (smooth) part, so light sampling can help.
    pub fn has_smooth_lobe(&self) -> bool {
        match &self.lobes {
            Lobes::Lambert(_) => true,
            Lobes::MetallicRoughness(m, _) => m.has_smooth_lobe(),
            Lobes::Layered(l) => l.has_smooth_lobe(),
        }
    }

    /// Whether the BSDF is an opaque glossy reflector whose smooth, narrow specular lobe
    /// (roughness below 0.5) is sampled at least half of the time for the `wo` it was made for
    /// (polished metals, shiny plastics): where BSDF sampling finds most of the direct light,
    /// and where the path tracer draws more BSDF samples for it at the first vertex.
    pub fn is_glossy_dominated(&self) -> bool {
        match &self.lobes {
            Lobes::MetallicRoughness(m, at) => m.is_glossy_dominated(at),
            Lobes::Lambert(_) | Lobes::Layered(_) => false,
        }
    }

    /// For smooth glass, the mirror direction of `wo` and the weight with which the surface
    /// reflects light from there (see [`MetallicRoughness::mirror_reflection_world`]); `None`
    /// for every other surface.
    pub fn mirror_reflection(&self, wo: Vec3) -> Option<(Vec3, Rgb)> {
        match &self.lobes {
            Lobes::MetallicRoughness(m, _) => m.mirror_reflection_world(&self.frame, self.ng, wo),
            Lobes::Lambert(_) | Lobes::Layered(_) => None,
        }
    }

    /// f·|cos θi| and the pdf with which [`sample`](Self::sample) returns `wi` (delta lobes
    /// contribute nothing to evaluation). Pairs on the same side by the shading normal but not
    /// by the geometric normal, or the reverse, are not scattered (light would leak).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        match &self.lobes {
            Lobes::Lambert(albedo) => {
                let (lo, li) = (self.frame.to_local(wo), self.frame.to_local(wi));
                if lo.z * li.z <= 0.0 || wo.dot(self.ng) * wi.dot(self.ng) <= 0.0 {
                    return (Vec3::ZERO, 0.0);
                }
                let pdf = li.z.abs() * FRAC_1_PI;
                (*albedo * pdf, pdf)
            }
            Lobes::MetallicRoughness(m, p) => {
                m.eval_world_with(&self.frame, self.ng, wo, wi, Some(p))
            }
            Lobes::Layered(l) => l.eval(&self.frame, self.ng, wo, wi),
        }
    }

    /// Samples an incident direction for `wo` (world space). `u_lobe` picks the lobe, `u` the
    /// direction within it.
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        match &self.lobes {
            Lobes::Lambert(albedo) => {
                let lo = self.frame.to_local(wo);
                if lo.z == 0.0 {
                    return None;
                }
                let mut li = cosine_hemisphere(u);
                if li.z <= 0.0 {
                    return None;
                }
                let pdf = li.z * FRAC_1_PI;
                li.z = li.z.copysign(lo.z);
                let wi = self.frame.to_world(li);
                if wo.dot(self.ng) * wi.dot(self.ng) <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: *albedo,
                    pdf,
                    delta: false,
                    transmitted: false,
                    etap: 1.0,
                })
            }
            Lobes::MetallicRoughness(m, p) => {
                m.sample_world_with(&self.frame, self.ng, wo, u_lobe, u, Some(p))
            }
            Lobes::Layered(l) => l.sample(&self.frame, self.ng, wo, u_lobe, u),
        }
    }
}

/// The Lambertian lobes of W lanes (one per lane, structure of arrays) for
/// [`LambertLanes::sample`]: what [`Bsdf::sample`] reads of a [`Lobes::Lambert`] BSDF.
#[derive(Default)]
#[repr(C, align(64))]
pub(crate) struct LambertLanes<const W: usize> {
    /// The shading frame's axes.
    pub s: V3s<W>,
    /// Second tangent.
    pub t: V3s<W>,
    /// Shading normal.
    pub n: V3s<W>,
    /// Geometric normal.
    pub ng: V3s<W>,
    /// Direction to the viewer.
    pub wo: V3s<W>,
    /// The 2D sample point.
    pub u: (F32s<W>, F32s<W>),
}

/// What [`LambertLanes::sample`] found in each lane.
#[repr(C, align(64))]
pub(crate) struct LambertSamples<const W: usize> {
    /// The lanes with a sample ([`Bsdf::sample`] gives `Some`).
    pub valid: Mask<W>,
    /// The sampled direction.
    pub wi: V3s<W>,
    /// Its pdf.
    pub pdf: F32s<W>,
}

impl<const W: usize> LambertSamples<W> {
    /// Lane `i`'s sample as [`Bsdf::sample`] gives it for a Lambertian lobe of `albedo`.
    #[inline]
    pub fn lane(&self, i: usize, albedo: Rgb) -> Option<BsdfSample> {
        self.valid.lane(i).then(|| BsdfSample {
            wi: self.wi.lane(i),
            weight: albedo,
            pdf: self.pdf[i],
            delta: false,
            transmitted: false,
            etap: 1.0,
        })
    }
}

impl<const W: usize> LambertLanes<W> {
    /// [`Bsdf::sample`] of a Lambertian BSDF in every lane, compiled for the widest vector
    /// instructions the CPU has that suit W lanes.
    pub fn sample(&self) -> LambertSamples<W> {
        crate::lanes::widest!(W, lanes: &LambertLanes<W> => LambertSamples<W>, self,
            lanes.sample_here())
    }

    /// The operations of [`Bsdf::sample`]'s Lambertian case, [`cosine_hemisphere`] and
    /// [`crate::sampling::concentric_disk`], in their order, so with their bits.
    #[inline(always)]
    pub fn sample_here(&self) -> LambertSamples<W> {
        use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
        let zero = F32s::splat(0.0);
        let lo_z = self.wo.dot(self.n);
        // The concentric map of the unit square to the disk.
        let (ox, oy) = (self.u.0 * 2.0 - 1.0, self.u.1 * 2.0 - 1.0);
        let centre = ox.eq(zero) & oy.eq(zero);
        let by_x = ox.abs().gt(oy.abs());
        let r = F32s::select(by_x, ox, oy);
        let theta = F32s::select(
            by_x,
            FRAC_PI_4 * (oy / ox),
            FRAC_PI_2 - FRAC_PI_4 * (ox / oy),
        );
        let (sin, cos) = F32s::sin_cos(theta);
        let (dx, dy) = (
            F32s::select(centre, zero, r * cos),
            F32s::select(centre, zero, r * sin),
        );
        // Lifted to the hemisphere (Malley), on the side of `wo`.
        let z = (1.0 - (dx * dx + dy * dy)).max(zero).sqrt();
        let pdf = z * FRAC_1_PI;
        let wi = self.s * dx + self.t * dy + self.n * z.copysign(lo_z);
        let across = (self.wo.dot(self.ng) * wi.dot(self.ng)).le(zero);
        LambertSamples {
            valid: lo_z.ne(zero) & !z.le(zero) & !across,
            wi,
            pdf,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use std::f32::consts::PI;

    /// The tables the BSDFs read, computed as the embedded ones were.
    fn computed_tables() -> Vec<(&'static str, &'static str, Vec<Vec<f32>>)> {
        let ggx = multiple_scattering::compute();
        let rows = |t: &[[f32; 32]]| t.iter().map(|r| r.to_vec()).collect::<Vec<_>>();
        vec![
            ("GGX_E", "const", rows(&ggx.e)),
            ("GGX_E5", "const", rows(&ggx.e5)),
            ("GGX_E_AVG", "const", vec![ggx.e_avg.to_vec()]),
            ("GGX_E5_AVG", "const", vec![ggx.e5_avg.to_vec()]),
            ("SHEEN_E", "const", rows(&layered::Sheen::compute_table())),
            (
                "DIELECTRIC_LOBE_WEIGHTS",
                "static",
                dielectric::compute_lobe_weights()
                    .iter()
                    .map(|w| w.to_vec())
                    .collect(),
            ),
        ]
    }

    /// The embedded tables (`src/bsdf/tables.rs`) are those the code computes, bit for bit
    /// (regenerate them with `LUMO_BLESS=1 cargo test -p lumo --lib regenerate_bsdf_tables --
    /// --ignored` after changing how one is computed).
    #[test]
    fn embedded_bsdf_tables_are_current() {
        let embedded: Vec<Vec<f32>> = [
            tables::GGX_E.iter().map(|r| r.to_vec()).collect::<Vec<_>>(),
            tables::GGX_E5.iter().map(|r| r.to_vec()).collect(),
            vec![tables::GGX_E_AVG.to_vec()],
            vec![tables::GGX_E5_AVG.to_vec()],
            tables::SHEEN_E.iter().map(|r| r.to_vec()).collect(),
            tables::DIELECTRIC_LOBE_WEIGHTS
                .iter()
                .map(|r| r.to_vec())
                .collect(),
        ]
        .into_iter()
        .map(|t: Vec<Vec<f32>>| t.concat())
        .collect();
        for ((name, _, computed), embedded) in computed_tables().into_iter().zip(embedded) {
            let computed = computed.concat();
            assert_eq!(computed.len(), embedded.len(), "{name}: size");
            for (k, (c, e)) in computed.iter().zip(&embedded).enumerate() {
                assert!(
                    c.to_bits() == e.to_bits(),
                    "{name}[{k}]: embedded {e}, computed {c}: src/bsdf/tables.rs is stale \
                     (LUMO_BLESS=1 cargo test -p lumo --lib regenerate_bsdf_tables -- --ignored)"
                );
            }
        }
    }

    /// Regenerates `src/bsdf/tables.rs`.
    #[test]
    #[ignore = "regenerates the embedded tables; run with LUMO_BLESS=1 and --ignored"]
    fn regenerate_bsdf_tables() {
        if std::env::var_os("LUMO_BLESS").is_none() {
            return;
        }
        let mut text = String::from(
            "//! Generated by `regenerate_bsdf_tables` in `bsdf/mod.rs`; do not edit. Tables of\n\
             //! directional albedos and lobe weights, computed by quadrature\n\
             //! (`multiple_scattering::compute`, `layered::Sheen::compute_table`,\n\
             //! `dielectric::compute_lobe_weights`) and embedded so that no render waits for them.\n",
        );
        for (name, kind, rows) in computed_tables() {
            let values = |r: &[f32]| {
                r.chunks(8)
                    .map(|c| {
                        c.iter()
                            .map(|v| format!("{v:?},"))
                            .collect::<Vec<_>>()
                            .join(" ")
                    })
                    .collect::<Vec<_>>()
            };
            let width = rows[0].len();
            if rows.len() == 1 {
                text +=
                    &format!("\n#[rustfmt::skip]\npub(super) {kind} {name}: [f32; {width}] = [\n");
                for line in values(&rows[0]) {
                    text += &format!("    {line}\n");
                }
                text += "];\n";
            } else {
                let n = rows.len();
                let len = if name == "DIELECTRIC_LOBE_WEIGHTS" {
                    "17 * 16".to_string()
                } else {
                    n.to_string()
                };
                text += &format!(
                    "\n#[rustfmt::skip]\npub(super) {kind} {name}: [[f32; {width}]; {len}] = [\n"
                );
                for r in &rows {
                    let lines = values(r);
                    if lines.len() == 1 {
                        text += &format!("    [{}],\n", lines[0].trim_end_matches(','));
                    } else {
                        text += "    [\n";
                        for line in lines {
                            text += &format!("        {line}\n");
                        }
                        text += "    ],\n";
                    }
                }
                text += "];\n";
            }
        }
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/tables.rs");
        std::fs::write(path, text).unwrap();
    }

    fn lambert(albedo: Rgb) -> Bsdf {
        Bsdf {
            frame: Frame::from_normal(Vec3::Z),
            ng: Vec3::Z,
            lobes: Lobes::Lambert(albedo),
        }
    }

    fn dir(theta_deg: f32) -> Vec3 {
        let t = theta_deg.to_radians();
        Vec3::new(t.sin(), 0.0, t.cos())
    }

    /// Monte Carlo estimate of the directional albedo by sampling, and by uniform-sphere
    /// integration of `eval` (independent of the sampling routine).
    fn albedo_two_ways(b: &Bsdf, wo: Vec3, n: usize) -> (Rgb, Rgb) {
        let mut rng = Pcg32::new(42, 7);
        // Accumulate in f64: summing 10⁵ f32 values would itself be off by ~10⁻³.
        let mut by_sampling = glam::DVec3::ZERO;
        let mut by_eval = glam::DVec3::ZERO;
        for _ in 0..n {
            if let Some(s) = b.sample(
                wo,
                rng.next_f32(),
                Vec2::new(rng.next_f32(), rng.next_f32()),
            ) {
                assert!(
                    s.weight.is_finite() && s.weight.min_element() >= 0.0,
                    "bad weight {:?}",
                    s.weight
                );
                by_sampling += s.weight.as_dvec3();
            }
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = 2.0 * PI * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let (f, pdf) = b.eval(wo, wi);
            assert!(f.is_finite() && f.min_element() >= 0.0 && pdf.is_finite() && pdf >= 0.0);
            by_eval += (f * (4.0 * PI)).as_dvec3();
        }
        (
            (by_sampling / n as f64).as_vec3(),
            (by_eval / n as f64).as_vec3(),
        )
    }

    #[test]
    fn lambertian_integrates_to_its_albedo() {
        let albedo = Vec3::new(0.8, 0.5, 0.2);
        let b = lambert(albedo);
        for theta in [0.0, 30.0, 60.0, 85.0] {
            let (s, e) = albedo_two_ways(&b, dir(theta), 200_000);
            assert!((s - albedo).abs().max_element() < 1e-4, "sampled {s:?}");
            assert!((e - albedo).abs().max_element() < 0.01, "evaluated {e:?}");
        }
    }

    /// The Lambertian shortcut in `sample` returns what `eval` says for the sampled direction,
    /// on both sides of the surface and with a tilted shading normal.
    #[test]
    fn lambertian_samples_agree_with_eval() {
        let mut rng = Pcg32::new(5, 5);
        let mut b = lambert(Vec3::new(0.56, 0.35, 0.14));
        b.frame = Frame::from_normal(Vec3::new(0.2, 0.1, 1.0).normalize());
        let mut taken = 0;
        for wo in [dir(10.0), dir(70.0), -dir(35.0)] {
            for _ in 0..2000 {
                let Some(s) = b.sample(
                    wo,
                    rng.next_f32(),
                    Vec2::new(rng.next_f32(), rng.next_f32()),
                ) else {
                    continue;
                };
                let (f, pdf) = b.eval(wo, s.wi);
                assert!(
                    (s.pdf - pdf).abs() <= 1e-4 * pdf.max(1.0),
                    "pdf {} vs eval {pdf}",
                    s.pdf
                );
                assert!(
                    (s.weight - f / pdf).abs().max_element() < 1e-3,
                    "weight {:?} vs eval {:?}",
                    s.weight,
                    f / pdf
                );
                taken += 1;
            }
        }
        assert!(taken > 5000);
    }
}
