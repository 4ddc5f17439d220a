//! Ground truth for multiple scattering on a rough conductor: the stochastic random walk of
//! Heitz, Hanika, d'Eon & Dachsbacher, "Multiple-Scattering Microfacet BSDFs with the Smith
//! Model", SIGGRAPH 2016, on the Smith GGX microsurface, beside two models of the energy that
//! single scattering loses:
//!
//! - **lumo**: the single-scattering GGX lobe plus Kulla & Conty's compensation lobe, as
//!   [`MetallicRoughness`] evaluates it (`src/bsdf/multiple_scattering.rs`);
//! - **Cycles** (4.0 and later, `microfacet_ggx_preserve_energy` in
//!   `intern/cycles/kernel/closure/bsdf_microfacet.h`): the single-scattering lobe scaled by
//!   1 + F_ms (1 − E(μo)) / E(μo), where μo is the cosine of the direction towards the camera
//!   and F_ms = F_ss E_avg / (1 − F_ss (1 − E_avg)) for the average Fresnel F_ss (1 for a white
//!   conductor, where the scale is 1/E(μo)).
//!
//! The walk (the paper's section 4 and its supplemental code): a ray enters the microsurface
//! from direction ωo; its next height of intersection follows from the masking function of a
//! microsurface with uniformly distributed heights (C1(h) = (h + 1)/2 on [−1, 1]; the BSDF does
//! not depend on the height distribution); at each intersection a microfacet normal is drawn
//! from the distribution of normals visible from the ray (for rays going down *and* up, so the
//! sampler must accept a direction below the horizon), the ray reflects, and its weight takes
//! the Fresnel factor of that facet. When it leaves, its direction is a sample of
//! f(ωo, ωi) cos θi, the sample's bounce count tells single from multiple scattering. Its
//! single-scattering part is exactly the height-correlated Smith lobe lumo evaluates, which
//! the program checks.
//!
//! Output (CSV, in the folder given as the first argument, default
//! `target/microsurface_walk`):
//! - `albedo.csv`: directional albedo against μo for each α, for a white conductor and a
//!   gold one (glTF base colour F0 = (1.0, 0.766, 0.336), Schlick's Fresnel), by the walk, by
//!   lumo's model and by Cycles'.
//! - `lobes.csv`: the reflected radiance density f(ωo, ωi) cos θi of a white conductor,
//!   averaged over bins of (μi, |φi|) (φi = 0 is the side of ωo, φi = π the mirror side), total
//!   and multiple-scattering part, for each model.
//!
//! Deterministic (fixed seeds, one stream per configuration). Run:
//! `cargo run --release --example microsurface_walk [out_dir]`; plot with
//! `python3 benches/peers/multiscatter_plot.py`.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::PathBuf;

use glam::DVec3;
use lumo::bsdf::multiple_scattering::{albedo, average_albedo, schlick_average};
use lumo::bsdf::MetallicRoughness;
use lumo::math::Vec3;
use rayon::prelude::*;

/// GGX widths α (glTF roughness √α).
const ALPHAS: [f64; 4] = [0.25, 0.5, 0.75, 1.0];
/// Bins in μi (uniform, so that with uniform φ bins every bin has the same solid angle).
const N_MU: usize = 16;
/// Bins in |φi| over [0, π].
const N_PHI: usize = 24;
/// The outgoing directions of the lobes: μo at bin centres, so that the reciprocity check can
/// pair (ωo → bin of ωi) with (ωi → bin of ωo).
const LOBE_MU_BINS: [usize; 4] = [15, 13, 8, 4];
/// Walks per lobe.
const LOBE_WALKS: u64 = 4_000_000;
/// μo nodes of the albedo curves and walks per node.
const ALBEDO_MUS: usize = 20;
const ALBEDO_WALKS: u64 = 400_000;
/// Bounces after which a walk is stopped (and counted as lost: none reach it in practice).
const MAX_BOUNCES: u32 = 256;
/// glTF base colour of the gold conductor (Schlick F0).
const GOLD: [f64; 3] = [1.0, 0.766, 0.336];

/// SplitMix64: a small deterministic generator (one stream per configuration).
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }
    /// Uniform in [0, 1) with 53 bits.
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Smith Λ(ω) of GGX for a direction in either hemisphere (the paper's eq. 4 for an upward ω;
/// Λ(−ω) = −1 − Λ(ω) for a downward one).
fn lambda(w: DVec3, alpha: f64) -> f64 {
    let z = w.z.clamp(-1.0, 1.0);
    let tan2 = (1.0 - z * z).max(0.0) / (z * z);
    let up = ((1.0 + alpha * alpha * tan2).sqrt() - 1.0) * 0.5;
    if z > 0.0 {
        up
    } else {
        -1.0 - up
    }
}

/// C1 of the uniform height distribution on [−1, 1] and its inverse.
fn c1(h: f64) -> f64 {
    ((h + 1.0) * 0.5).clamp(0.0, 1.0)
}
fn inv_c1(u: f64) -> f64 {
    (2.0 * u - 1.0).clamp(-1.0, 1.0)
}

/// The height of the next intersection of a ray leaving height `h` in direction `w`, or `None`
/// when it escapes (the paper's algorithm 2): an upward ray escapes with probability
/// G1(w, h) = C1(h)^Λ(w); otherwise, and always for a downward ray, the height follows from
/// inverting 1 − U = (C1(h) / C1(h'))^Λ(w).
fn next_height(w: DVec3, h: f64, u: f64, alpha: f64) -> Option<f64> {
    if w.z > 0.9999 {
        return None;
    }
    if w.z < -0.9999 {
        return Some(inv_c1(u * c1(h)));
    }
    if w.z.abs() < 1e-4 {
        return Some(h);
    }
    let l = lambda(w, alpha);
    if w.z > 0.0 {
        let g1 = c1(h).powf(l);
        if u > 1.0 - g1 {
            return None;
        }
    }
    Some(inv_c1(c1(h) / (1.0 - u).powf(1.0 / l)))
}

/// A GGX normal visible from `v` (a unit vector towards the viewer, in *either* hemisphere):
/// Dupuy & Benyoub, "Sampling Visible GGX Normals with Spherical Caps", HPG 2023. In the
/// stretched configuration (α = 1) the half vector of v and a uniform direction c has density
/// ∝ (h·v)⁺; keeping h.z ≥ 0 means drawing c on the cap c.z ≥ −v.z, which holds for v below the
/// horizon too (the walk's upward rays see facets from below).
fn sample_visible(v: DVec3, alpha: f64, u1: f64, u2: f64) -> DVec3 {
    let vs = DVec3::new(alpha * v.x, alpha * v.y, v.z).normalize();
    let phi = 2.0 * PI * u1;
    let z = (1.0 - u2) * (1.0 + vs.z) - vs.z;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let h = DVec3::new(s * phi.cos(), s * phi.sin(), z) + vs;
    DVec3::new(alpha * h.x, alpha * h.y, h.z.max(0.0)).normalize()
}

/// Schlick's Fresnel with F90 = 1.
fn schlick(f0: [f64; 3], c: f64) -> [f64; 3] {
    let k = (1.0 - c.clamp(0.0, 1.0)).powi(5);
    f0.map(|f| f + (1.0 - f) * k)
}

/// One walk entering from direction `wo` (towards the viewer): the exit direction, the bounce
/// count and the gold conductor's Fresnel weight; `None` if it was stopped.
fn walk(wo: DVec3, alpha: f64, rng: &mut Rng) -> Option<(DVec3, u32, [f64; 3])> {
    let mut dir = -wo;
    // Start above the microsurface (the supplemental code's 1 + C1⁻¹(0.999)).
    let mut h = 1.0 + inv_c1(0.999);
    let mut weight = [1.0f64; 3];
    for bounce in 0..MAX_BOUNCES {
        match next_height(dir, h, rng.next(), alpha) {
            None => return (bounce > 0).then_some((dir, bounce, weight)),
            Some(next) => h = next,
        }
        let m = sample_visible(-dir, alpha, rng.next(), rng.next());
        let c = (-dir).dot(m);
        let f = schlick(GOLD, c);
        for k in 0..3 {
            weight[k] *= f[k];
        }
        dir = (dir - 2.0 * dir.dot(m) * m).normalize();
    }
    None
}

/// Local direction from (μ, φ).
fn direction(mu: f64, phi: f64) -> DVec3 {
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), mu)
}

fn v3(d: DVec3) -> Vec3 {
    Vec3::new(d.x as f32, d.y as f32, d.z as f32)
}

/// f(ωo, ωi) cos θi of the white conductor by each model: (lumo total, lumo single, Cycles
/// total), the single-scattering lobe being the same in both.
fn models(wo: DVec3, wi: DVec3, alpha: f64) -> (f64, f64, f64) {
    let rough = alpha.sqrt() as f32;
    let with = MetallicRoughness::new(Vec3::ONE, 1.0, rough);
    let mut without = with;
    without.energy_compensation = false;
    let (o, i) = (v3(wo), v3(wi));
    let lumo = with.eval(o, i).0.x as f64;
    let single = without.eval(o, i).0.x as f64;
    let e = albedo(o.z, rough * rough) as f64;
    (lumo, single, single / e)
}

/// The density of reflected energy f cos θi of the models, averaged over a bin on a 6 × 6
/// grid of points.
fn model_bin(wo: DVec3, alpha: f64, bi: usize, bp: usize) -> (f64, f64, f64) {
    const SUB: usize = 6;
    let mut acc = (0.0, 0.0, 0.0);
    for a in 0..SUB {
        let mu = (bi as f64 + (a as f64 + 0.5) / SUB as f64) / N_MU as f64;
        for b in 0..SUB {
            let phi = PI * (bp as f64 + (b as f64 + 0.5) / SUB as f64) / N_PHI as f64;
            let (l, s, c) = models(wo, direction(mu, phi), alpha);
            acc = (acc.0 + l, acc.1 + s, acc.2 + c);
        }
    }
    let n = (SUB * SUB) as f64;
    (acc.0 / n, acc.1 / n, acc.2 / n)
}

fn bin_of(w: DVec3) -> (usize, usize) {
    let mu = ((w.z * N_MU as f64) as usize).min(N_MU - 1);
    let phi = w.y.atan2(w.x).abs();
    let p = ((phi / PI * N_PHI as f64) as usize).min(N_PHI - 1);
    (mu, p)
}

/// The lobes of one (α, μo): CSV rows.
fn lobe_rows(alpha: f64, mu_bin: usize, seed: u64) -> String {
    let mu_o = (mu_bin as f64 + 0.5) / N_MU as f64;
    let wo = direction(mu_o, 0.0);
    let mut total = vec![0u64; N_MU * N_PHI];
    let mut multi = vec![0u64; N_MU * N_PHI];
    let mut rng = Rng::new(seed);
    let mut lost = 0u64;
    for _ in 0..LOBE_WALKS {
        match walk(wo, alpha, &mut rng) {
            Some((wi, bounces, _)) if wi.z > 0.0 => {
                let (a, b) = bin_of(wi);
                total[a * N_PHI + b] += 1;
                if bounces > 1 {
                    multi[a * N_PHI + b] += 1;
                }
            }
            _ => lost += 1,
        }
    }
    // Bin solid angle: Δμ · Δφ, twice (the bins fold φ and −φ).
    let omega = (1.0 / N_MU as f64) * (PI / N_PHI as f64) * 2.0;
    let scale = 1.0 / (LOBE_WALKS as f64 * omega);
    let mut out = String::new();
    for a in 0..N_MU {
        for b in 0..N_PHI {
            let (lumo, single, cycles) = model_bin(wo, alpha, a, b);
            let k = a * N_PHI + b;
            let _ = writeln!(
                out,
                "{alpha},{mu_o},{a},{b},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{lost}",
                total[k] as f64 * scale,
                multi[k] as f64 * scale,
                lumo,
                lumo - single,
                cycles,
                cycles - single,
                single,
            );
        }
    }
    out
}

/// One albedo row: walk (white total, white single, gold r g b), lumo gold, Cycles gold.
fn albedo_row(alpha: f64, mu_o: f64, seed: u64) -> String {
    let wo = direction(mu_o, 0.0);
    let mut rng = Rng::new(seed);
    let (mut white, mut single, mut gold) = (0u64, 0u64, [0.0f64; 3]);
    for _ in 0..ALBEDO_WALKS {
        if let Some((wi, bounces, w)) = walk(wo, alpha, &mut rng) {
            if wi.z > 0.0 {
                white += 1;
                single += (bounces == 1) as u64;
                for k in 0..3 {
                    gold[k] += w[k];
                }
            }
        }
    }
    let n = ALBEDO_WALKS as f64;
    let a32 = alpha as f32;
    let f0 = Vec3::new(GOLD[0] as f32, GOLD[1] as f32, GOLD[2] as f32);
    let mu32 = mu_o as f32;
    // lumo: F0·E + (1 − F0)·E5 + F_ms (1 − E), the albedo its BSDF integrates to.
    let lumo = lumo::bsdf::multiple_scattering::specular_albedo(mu32, a32, f0, true);
    // Cycles: the single-scattering albedo times 1 + F_ms (1 − E)/E, F_ms from F_ss = Schlick's
    // average (Cycles' F82-tint Fresnel with a white tint is Schlick's).
    let e = albedo(mu32, a32);
    let e_avg = average_albedo(a32);
    let f_ss = schlick_average(f0);
    let f_ms = f_ss * e_avg / (Vec3::ONE - f_ss * (1.0 - e_avg));
    let ss = lumo::bsdf::multiple_scattering::specular_albedo(mu32, a32, f0, false);
    let cycles = ss * (Vec3::ONE + f_ms * ((1.0 - e) / e));
    format!(
        "{alpha},{mu_o:.5},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
        white as f64 / n,
        single as f64 / n,
        e,
        gold[0] / n,
        gold[1] / n,
        gold[2] / n,
        lumo.x,
        lumo.y,
        lumo.z,
        cycles.x,
        cycles.y,
        cycles.z,
    )
}

fn main() -> std::io::Result<()> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/microsurface_walk"));
    std::fs::create_dir_all(&out)?;

    let configs: Vec<(usize, usize)> = (0..ALPHAS.len())
        .flat_map(|a| (0..ALBEDO_MUS).map(move |m| (a, m)))
        .collect();
    let rows: Vec<String> = configs
        .par_iter()
        .map(|&(a, m)| {
            let mu = (m as f64 + 0.5) / ALBEDO_MUS as f64;
            albedo_row(ALPHAS[a], mu, 1000 + (a * ALBEDO_MUS + m) as u64)
        })
        .collect();
    let mut csv = String::from(
        "alpha,mu_o,walk_white,walk_single,table_e,walk_gold_r,walk_gold_g,walk_gold_b,\
         lumo_gold_r,lumo_gold_g,lumo_gold_b,cycles_gold_r,cycles_gold_g,cycles_gold_b\n",
    );
    rows.iter().for_each(|r| csv.push_str(r));
    std::fs::write(out.join("albedo.csv"), csv)?;

    let configs: Vec<(usize, usize)> = (0..ALPHAS.len())
        .flat_map(|a| LOBE_MU_BINS.iter().map(move |&m| (a, m)))
        .collect();
    let rows: Vec<String> = configs
        .par_iter()
        .map(|&(a, m)| lobe_rows(ALPHAS[a], m, 5000 + (a * N_MU + m) as u64))
        .collect();
    let mut csv = String::from(
        "alpha,mu_o,mu_bin,phi_bin,walk,walk_ms,lumo,lumo_ms,cycles,cycles_ms,single,lost\n",
    );
    rows.iter().for_each(|r| csv.push_str(r));
    std::fs::write(out.join("lobes.csv"), csv)?;
    eprintln!("wrote {}/albedo.csv and lobes.csv", out.display());
    Ok(())
}
