//! Pearson's χ² goodness-of-fit test of a direction sampler against its claimed pdf, as
//! Mitsuba's test suite does it (Jakob et al., `mitsuba/python/chi2.py`): the sphere is cut into
//! bins of equal solid angle in (cos θ, φ); sampled directions are counted per bin; the expected
//! count is N times the pdf integrated over the bin (composite midpoint rule on a fine sub-grid);
//! bins with an expected count below [`MIN_EXPECTED`] are pooled into one; the statistic is
//! compared with the χ² distribution of (bins − 1) degrees of freedom.
//!
//! Samplers may fail (return `None`): the pdf must then integrate to the probability of success,
//! which the test checks too since expected counts are not renormalised.

use std::f64::consts::PI;

use crate::math::Vec3;
use crate::sampler::Pcg32;

/// Bins in cos θ ∈ [−1, 1].
const THETA_BINS: usize = 16;
/// Bins in φ ∈ [0, 2π).
const PHI_BINS: usize = 32;
/// Midpoint-rule sub-cells per bin side when integrating the pdf.
const SUB: usize = 24;
/// Bins expected to receive fewer samples are pooled (the usual validity rule of Pearson's test).
const MIN_EXPECTED: f64 = 5.0;

/// Significance level of one family of χ² tests; a test function running `k` configurations
/// rejects at the Šidák-corrected level 1 − (1 − α)^(1/k), as Mitsuba does.
pub const SIGNIFICANCE: f64 = 0.01;

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9; |error| < 1e-13 here).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) (Numerical Recipes §6.2: series below a + 1,
/// Lentz continued fraction above).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let lg = ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - lg).exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - lg).exp() * h
    }
}

fn direction(cos_theta: f64, phi: f64) -> Vec3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(
        (s * phi.cos()) as f32,
        (s * phi.sin()) as f32,
        cos_theta as f32,
    )
}

fn bin_of(w: Vec3) -> usize {
    let z = (w.z as f64).clamp(-1.0, 1.0);
    let t = (((z + 1.0) * 0.5 * THETA_BINS as f64) as usize).min(THETA_BINS - 1);
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let p = ((phi / (2.0 * PI) * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
    t * PHI_BINS + p
}

/// Runs the test with `n` samples drawn by `sample` and returns the p-value. Panics (failing the
/// calling test) when the pdf integrates to more than the success rate allows.
pub fn p_value(
    name: &str,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Pcg32) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> f64 {
    let mut observed = vec![0.0f64; THETA_BINS * PHI_BINS];
    let mut rng = Pcg32::new(seed, 11);
    let mut successes = 0usize;
    for _ in 0..n {
        if let Some(w) = sample(&mut rng) {
            assert!(
                w.is_finite() && (w.length() - 1.0).abs() < 1e-3,
                "{name}: bad direction {w:?}"
            );
            observed[bin_of(w)] += 1.0;
            successes += 1;
        }
    }
    let dz = 2.0 / THETA_BINS as f64;
    let dphi = 2.0 * PI / PHI_BINS as f64;
    let mut expected = vec![0.0f64; THETA_BINS * PHI_BINS];
    let mut total = 0.0;
    for t in 0..THETA_BINS {
        for p in 0..PHI_BINS {
            let mut sum = 0.0;
            for i in 0..SUB {
                let z = -1.0 + dz * (t as f64 + (i as f64 + 0.5) / SUB as f64);
                for j in 0..SUB {
                    let phi = dphi * (p as f64 + (j as f64 + 0.5) / SUB as f64);
                    let v = pdf(direction(z, phi)) as f64;
                    assert!(v.is_finite() && v >= 0.0, "{name}: pdf {v}");
                    sum += v;
                }
            }
            let integral = sum * dz * dphi / (SUB * SUB) as f64;
            total += integral;
            expected[t * PHI_BINS + p] = integral * n as f64;
        }
    }
    let rate = successes as f64 / n as f64;
    assert!(
        (total - rate).abs() < 0.02 + 4.0 * (rate * (1.0 - rate) / n as f64).sqrt(),
        "{name}: pdf integrates to {total}, but {rate} of the samples succeeded"
    );
    p_value_of_counts(name, &observed, &expected)
}

/// Pearson's test of observed against expected counts per bin (bins expected to receive fewer
/// than [`MIN_EXPECTED`] samples pooled); returns the p-value. Panics when a bin whose expected
/// count is zero received samples.
pub fn p_value_of_counts(name: &str, observed: &[f64], expected: &[f64]) -> f64 {
    // Pool the bins with small expected counts (Mitsuba: sorted by expectation, merged until the
    // pool itself is large enough).
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    let (mut chi2, mut dof) = (0.0, 0usize);
    for &k in &order {
        if expected[k] == 0.0 && observed[k] > 0.0 {
            panic!(
                "{name}: {} samples in bin {k} where the pdf is zero",
                observed[k]
            );
        }
        if pool_e < MIN_EXPECTED || expected[k] < MIN_EXPECTED {
            pool_e += expected[k];
            pool_o += observed[k];
        } else {
            chi2 += (observed[k] - expected[k]).powi(2) / expected[k];
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    gamma_q(dof as f64 * 0.5, chi2 * 0.5)
}

/// Asserts that every p-value of a family of `ps.len()` tests passes the Šidák-corrected level.
pub fn assert_all_pass(ps: &[(String, f64)]) {
    let level = 1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / ps.len() as f64);
    for (name, p) in ps {
        eprintln!("χ² {name}: p = {p:.4} (level {level:.2e})");
        assert!(*p > level, "χ² test {name}: p-value {p:.3e} < {level:.3e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incomplete_gamma_matches_known_values() {
        // χ² survival function: Q(k/2, x/2). Values from tables of the χ² distribution.
        assert!((gamma_q(0.5, 3.841_459 / 2.0) - 0.05).abs() < 1e-6); // k = 1
        assert!((gamma_q(5.0, 23.209_25 / 2.0) - 0.01).abs() < 1e-6); // k = 10
        assert!((gamma_q(50.0, 124.342_1 / 2.0) - 0.05).abs() < 1e-5); // k = 100
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn uniform_sphere_passes_and_a_wrong_pdf_fails() {
        let uniform = |rng: &mut Pcg32| {
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Some(Vec3::new(r * phi.cos(), r * phi.sin(), z))
        };
        let good = p_value("uniform", 100_000, 3, uniform, |_| {
            0.25 * std::f32::consts::FRAC_1_PI
        });
        assert!(good > 0.01, "p = {good}");
        // The same samples against a pdf off by 10 % between hemispheres must be rejected.
        let bad = p_value("skewed", 100_000, 3, uniform, |w| {
            0.25 * std::f32::consts::FRAC_1_PI * if w.z > 0.0 { 1.1 } else { 0.9 }
        });
        assert!(bad < 1e-6, "p = {bad}");
    }
}
