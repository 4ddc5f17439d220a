//! Adaptive allocation of a pass's samples to pixels: the pixels whose neighbourhood shows the
//! largest relative error (per unit of time under a time budget) get the most.

use super::film::{Film, PixelSum};
use crate::sampler::mix64;

/// Where adaptive passes take a pixel's error estimate from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ErrorSource {
    /// The pixel's own samples: biased (see [`AdaptiveAllocator::split`]); kept only so the
    /// tests can show that the bias exists and that the test detects it.
    #[cfg(test)]
    Own,
    /// The 3×3 neighbourhood without the pixel itself.
    Neighbours,
}

/// One adaptive pass as the schedule sizes it.
#[derive(Debug, Clone, Copy)]
pub(super) struct AdaptivePass {
    /// Samples to spread over the pixels (about: counts are rounded stochastically).
    pub(super) samples: u64,
    /// Samples the render has left; the pass never takes more.
    pub(super) samples_left: u64,
    /// Whether this is the last pass of a sample budget, which takes exactly `samples`.
    pub(super) last: bool,
    /// Number of the pass in the render (seeds the stochastic rounding).
    pub(super) index: u64,
}

/// Splits adaptive passes' samples over pixels; keeps its buffers across passes.
pub(super) struct AdaptiveAllocator {
    /// Seed of the render: seeds the stochastic rounding of the counts.
    seed: u64,
    /// Weigh pixels by their measured time per sample (under a time budget).
    weigh_by_cost: bool,
    /// Where a pixel's error estimate comes from.
    source: ErrorSource,
    per_sample: Vec<f64>,
    cost: Vec<f64>,
    weights: Vec<f64>,
}

impl AdaptiveAllocator {
    /// An allocator for a render with `seed`; with `weigh_by_cost` (time budgets) pixels are
    /// weighed by their neighbourhood's time per sample too.
    pub(super) fn new(seed: u64, weigh_by_cost: bool, source: ErrorSource) -> AdaptiveAllocator {
        AdaptiveAllocator {
            seed,
            weigh_by_cost,
            source,
            per_sample: Vec::new(),
            cost: Vec::new(),
            weights: Vec::new(),
        }
    }

    /// Sets `counts[i]`, the samples pixel i takes in `pass`, from the samples in `film`;
    /// returns their total: about `pass.samples`, never more than `pass.samples_left`, and
    /// exactly `pass.samples` in the last pass of a sample budget.
    pub(super) fn allocate(&mut self, film: &Film, pass: &AdaptivePass, counts: &mut [u32]) -> u64 {
        self.split(film, pass.samples, pass.index, counts);
        let mut allocated: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        // Stochastic rounding may overshoot the samples left by a few: take them back.
        let mut excess = allocated.saturating_sub(pass.samples_left);
        for c in counts.iter_mut().rev() {
            if excess == 0 {
                break;
            }
            let d = u64::from(*c).min(excess) as u32;
            *c -= d;
            excess -= u64::from(d);
            allocated -= u64::from(d);
        }
        // ... or undershoot it in the last pass of a sample budget: top up from the last pixels
        // (a decision about a handful of samples that depends on all pixels, not on any one).
        if pass.last {
            let (mut deficit, mut i) = (pass.samples.saturating_sub(allocated), counts.len());
            while deficit > 0 {
                i = if i == 0 { counts.len() - 1 } else { i - 1 };
                counts[i] += 1;
                deficit -= 1;
                allocated += 1;
            }
        }
        allocated
    }

    /// Splits about `budget` samples over the pixels for pass number `pass` into `counts`.
    ///
    /// **Target.** Minimising the relative MSE Σ aᵢ/nᵢ for a fixed total Σ nᵢ (aᵢ the per-sample
    /// relative variance of pixel i) gives nᵢ ∝ √aᵢ (Lagrange multipliers). Each pixel is given the
    /// difference between its share of all samples after this pass and what it has, at most 8× the
    /// pass mean, and the wishes are scaled to the pass budget.
    ///
    /// **Why not the pixel's own variance.** The image is the per-pixel sample mean, so the number
    /// of samples must not depend on the samples it averages: with a heavy-tailed pixel (a caustic,
    /// a glass edge) the samples that missed the rare bright paths have both a low mean and a low
    /// variance, so a pixel that by chance drew low values stops early and keeps its low mean,
    /// while one that drew a firefly gets more samples that dilute it — a downward bias (about 1%
    /// of the image mean on the Cornell box). Estimating aᵢ from the 3×3 neighbourhood *without*
    /// pixel i removes the pixel's own samples from the decision (each pixel has its own random
    /// streams), in the spirit of the spatially filtered error of Rousselle, Knaus and Zwicker,
    /// "Adaptive sampling and reconstruction using greedy error minimization", SIGGRAPH Asia 2011;
    /// neighbouring pixels see nearly the same light paths, so their spread predicts the pixel's.
    /// What remains coupled is second order (pixel i's samples change a neighbour's count, which
    /// changes only the precision, not the expectation, of that neighbour's variance estimate) plus
    /// the 1/n share of one pixel in the global scale factor; `tests/adaptive.rs` measures the mean
    /// to be unbiased within noise. Fractional counts are rounded stochastically with a hash of
    /// (seed, pass, pixel), so rounding does not couple pixels either (error diffusion would carry
    /// a neighbour's wish into the count). A floor of a tenth of the mean weight keeps every pixel
    /// converging.
    ///
    /// **Time budgets.** When the budget is time, not samples, the sum to minimise is the same but
    /// the constraint is Σ cᵢnᵢ = T with cᵢ the cost of a sample of pixel i, so nᵢ ∝ √(aᵢ/cᵢ): a
    /// sample through a glass lathe casts more (and costlier) rays than one that sees the floor. cᵢ
    /// is the neighbourhood's measured time per sample (the pixel's own is left out for the same
    /// reason as its variance: path length correlates with radiance). Timing makes the allocation
    /// depend on the machine, which a render against the clock does anyway; sample budgets
    /// (`--spp`) keep nᵢ ∝ √aᵢ and stay reproducible.
    fn split(&mut self, film: &Film, budget: u64, pass: u64, counts: &mut [u32]) {
        let sums = film.pixels();
        let (w, h) = (film.width() as usize, film.height() as usize);
        let n = sums.len();
        let per_sample = &mut self.per_sample;
        per_sample.clear();
        per_sample.extend(sums.iter().map(PixelSum::rel_var_per_sample));
        // Seconds per sample, the cost cᵢ of a sample of pixel i (under a time budget only).
        let cost = &mut self.cost;
        cost.clear();
        if self.weigh_by_cost {
            cost.extend(
                sums.iter()
                    .map(|p| p.nanos_per_sample().unwrap_or(f64::NAN)),
            );
        }
        let known: Vec<f64> = per_sample
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        let global = if known.is_empty() {
            0.0
        } else {
            known.iter().sum::<f64>() / known.len() as f64
        };
        let weights = &mut self.weights;
        weights.clear();
        weights.extend((0..n).map(|i| {
            let (a, c) = match self.source {
                #[cfg(test)]
                ErrorSource::Own => (per_sample[i], cost.get(i).copied().unwrap_or(f64::NAN)),
                ErrorSource::Neighbours => {
                    let (x, y) = (i % w, i / w);
                    let (mut sum, mut k, mut c_sum, mut c_k) = (0.0, 0u32, 0.0, 0u32);
                    for ny in y.saturating_sub(1)..(y + 2).min(h) {
                        for nx in x.saturating_sub(1)..(x + 2).min(w) {
                            let j = ny * w + nx;
                            if j == i {
                                continue;
                            }
                            if per_sample[j].is_finite() {
                                sum += per_sample[j];
                                k += 1;
                            }
                            if let Some(&cj) = cost.get(j).filter(|c| c.is_finite()) {
                                c_sum += cj;
                                c_k += 1;
                            }
                        }
                    }
                    (
                        if k == 0 { global } else { sum / f64::from(k) },
                        if c_k == 0 {
                            f64::NAN
                        } else {
                            c_sum / f64::from(c_k)
                        },
                    )
                }
            };
            let a = if a.is_finite() { a.max(0.0) } else { global };
            // Equal time: minimising Σ aᵢ/nᵢ subject to Σ cᵢnᵢ = T gives nᵢ ∝ √(aᵢ/cᵢ).
            if c.is_finite() && c > 0.0 {
                (a / c).sqrt()
            } else {
                a.sqrt()
            }
        }));
        let mean_w = weights.iter().sum::<f64>() / n as f64;
        if mean_w <= 0.0 || !mean_w.is_finite() {
            weights.fill(1.0);
        } else {
            weights.iter_mut().for_each(|x| *x += 0.1 * mean_w);
        }
        let total_w: f64 = weights.iter().sum();
        let already: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
        let after = (already + budget) as f64;
        let cap = (8 * budget).div_ceil(n as u64) as f64;
        // Wishes (reusing the weight buffer): pixels already above their share get nothing.
        let mut wish_sum = 0.0;
        for (x, p) in weights.iter_mut().zip(sums) {
            *x = (after * *x / total_w - f64::from(p.taken())).clamp(0.0, cap);
            wish_sum += *x;
        }
        if wish_sum <= 0.0 {
            // Everyone is at or above their share (only by rounding): spread the pass evenly.
            weights.fill(1.0);
            wish_sum = n as f64;
        }
        let scale = budget as f64 / wish_sum;
        for (i, (c, wish)) in counts.iter_mut().zip(weights.iter()).enumerate() {
            let x = wish * scale;
            let u = (mix64(self.seed ^ mix64(pass.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ i as u64))
                >> 11) as f64
                / (1u64 << 53) as f64;
            *c = (x + u).floor().min(f64::from(u32::MAX / 2)) as u32;
        }
    }
}
