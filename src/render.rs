//! The render loop: tiles spread over threads with rayon, each pixel sample drawn from its own
//! random stream so the image is identical whatever the thread count; progressive passes for
//! time budgets, error targets and adaptive sampling; per-pixel error estimates.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

pub use crate::image::Image;
use crate::image::REL_EPSILON;
use crate::integrator::{radiance, TraceStats};
use crate::math::{Vec2, Vec3};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// Side of the square tiles work is split into.
pub const TILE: u32 = 16;

/// What a render did.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    /// Mean samples per pixel taken (rounded).
    pub spp: u32,
    /// Total samples taken.
    pub samples: u64,
    /// Rays cast.
    pub rays: u64,
    /// Samples that produced NaN or infinity and were dropped.
    pub nan_samples: u64,
    /// Wall time.
    pub elapsed: Duration,
    /// RMSE predicted from the per-pixel sample variance (valid for independent samples;
    /// conservative for Sobol points, whose error is lower than their spread suggests).
    pub estimated_rmse: f64,
    /// √(estimated relative MSE): the single relative-error figure used by error targets.
    pub estimated_rel_error: f64,
}

/// Options of a render call.
#[derive(Default)]
pub struct RenderOptions<'a> {
    /// Called with the number of samples finished so far (for progress bars).
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Stop once the estimated relative error falls below this (checked after each pass;
    /// `spp` still caps the samples).
    pub target_rel_error: Option<f64>,
    /// After a uniform start, give each pass's samples to the pixels whose neighbourhood shows
    /// the largest estimated relative error (per unit of time under a time budget). The image
    /// mean stays unbiased: a pixel's own samples never decide how many it gets.
    pub adaptive: bool,
}

/// A render with its per-pixel error estimate.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Mean radiance per pixel.
    pub image: Image,
    /// Standard error of each pixel's mean, per channel.
    pub std_error: Image,
    /// Samples taken per pixel (row-major, top row first): uniform renders take the same
    /// number everywhere, adaptive ones show where the budget went.
    pub counts: Vec<u32>,
    /// Counters.
    pub stats: Stats,
}

/// Running sums of one pixel's samples.
#[derive(Debug, Clone, Copy, Default)]
struct PixelSum {
    sum: DVec3,
    sum_sq: DVec3,
    good: u32,
    bad: u32,
    /// Wall time these samples took, in nanoseconds: the cost model of time-budgeted adaptive
    /// passes (a render against the clock is not reproducible anyway).
    nanos: u64,
}

impl PixelSum {
    fn taken(&self) -> u32 {
        self.good + self.bad
    }

    fn mean(&self) -> DVec3 {
        if self.good == 0 {
            DVec3::ZERO
        } else {
            self.sum / f64::from(self.good)
        }
    }

    /// Variance of the mean, per channel (∞ with fewer than two samples).
    fn var_of_mean(&self) -> DVec3 {
        if self.good < 2 {
            return DVec3::splat(f64::INFINITY);
        }
        let n = f64::from(self.good);
        let m = self.sum / n;
        ((self.sum_sq - m * m * n) / (n - 1.0)).max(DVec3::ZERO) / n
    }

    /// Relative variance of one sample, Σ var / (m² + ε) over channels / 3 (∞ with fewer
    /// than two samples): the aᵢ of the adaptive allocation.
    fn rel_var_per_sample(&self) -> f64 {
        self.rel_var() * f64::from(self.good)
    }

    /// Relative variance of the mean: Σ var / (m² + ε) over channels / 3.
    fn rel_var(&self) -> f64 {
        let m = self.mean();
        (self.var_of_mean() / (m * m + DVec3::splat(REL_EPSILON))).element_sum() / 3.0
    }
}

/// Renders the scene with its settings.
pub fn render(scene: &Scene, options: &RenderOptions) -> (Image, Stats) {
    let r = render_with_error(scene, options);
    (r.image, r.stats)
}

/// Renders the scene and estimates each pixel's error from its samples.
///
/// Without a time budget, error target or adaptivity, all samples are taken in one pass.
/// Otherwise passes of doubling size run until the budget is spent, the target reached or
/// `spp` samples per pixel (on average) taken; with a time budget each pass is sized from the
/// previous pass's throughput so that the last one ends near the deadline instead of
/// overshooting it by up to the length of all passes before it. Each sample index has its own
/// random stream, so the image depends only on which samples were taken, not on passes or threads.
///
/// Adaptive rendering spends the first quarter of the budget (at most 64 spp, at least 2) on
/// uniform passes, then gives each pass to the pixels whose *neighbours* show the largest
/// relative error; see [`allocate_adaptive`] for why the pixel's own samples are left out.
pub fn render_with_error(scene: &Scene, options: &RenderOptions) -> Rendered {
    let start = Instant::now();
    let s = &scene.settings;
    let plan = Plan {
        width: s.width,
        height: s.height,
        spp: s.spp,
        budget: s.time_budget_s.map(|t| Duration::from_secs_f32(t.max(0.0))),
        seed: s.seed,
    };
    let (sums, rays) = run_passes(
        &plan,
        options,
        ErrorSource::Neighbours,
        |x, y, range, stats| render_samples(scene, x, y, range, stats),
    );
    finish(&plan, &sums, rays, start.elapsed())
}

/// The shape and budget of a render, independent of what is rendered.
struct Plan {
    width: u32,
    height: u32,
    /// Samples per pixel (mean), the cap of the budget.
    spp: u32,
    /// Wall-time budget.
    budget: Option<Duration>,
    /// Seed of the render; also seeds the stochastic rounding of adaptive sample counts.
    seed: u64,
}

/// Where adaptive passes take a pixel's error estimate from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ErrorSource {
    /// The pixel's own samples: biased (see [`allocate_adaptive`]); kept only so the tests can
    /// show that the bias exists and that the test detects it.
    #[cfg(test)]
    Own,
    /// The 3×3 neighbourhood without the pixel itself.
    Neighbours,
}

/// Image, error image and counters from the per-pixel sums.
fn finish(plan: &Plan, sums: &[PixelSum], rays: u64, elapsed: Duration) -> Rendered {
    let (w, h) = (plan.width, plan.height);
    let image = Image {
        width: w,
        height: h,
        pixels: sums.iter().map(|p| p.mean().as_vec3()).collect(),
    };
    let std_error = Image {
        width: w,
        height: h,
        pixels: sums
            .iter()
            .map(|p| {
                let v = p.var_of_mean();
                if v.is_finite() {
                    v.map(f64::sqrt).as_vec3()
                } else {
                    Vec3::ZERO
                }
            })
            .collect(),
    };
    let (estimated_rmse, estimated_rel_error) = estimate(sums);
    let samples: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
    let stats = Stats {
        spp: (samples as f64 / sums.len().max(1) as f64).round() as u32,
        samples,
        rays,
        nan_samples: sums.iter().map(|p| u64::from(p.bad)).sum(),
        elapsed,
        estimated_rmse,
        estimated_rel_error,
    };
    Rendered {
        image,
        std_error,
        counts: sums.iter().map(PixelSum::taken).collect(),
        stats,
    }
}

/// Takes all samples of a render, pass by pass; `sample(x, y, indices, stats)` returns the sums
/// of pixel (x, y)'s samples with the given indices. Returns the per-pixel sums and rays cast.
fn run_passes<F>(
    plan: &Plan,
    options: &RenderOptions,
    source: ErrorSource,
    sample: F,
) -> (Vec<PixelSum>, u64)
where
    F: Fn(u32, u32, Range<u32>, &mut TraceStats) -> PixelSum + Sync,
{
    let start = Instant::now();
    let n_pixels = (plan.width * plan.height) as usize;
    let n = n_pixels as u64;
    let mut sums = vec![PixelSum::default(); n_pixels];
    let mut counts = vec![0u32; n_pixels];
    let mut scratch = Scratch::default();
    let rays = AtomicU64::new(0);
    let done = AtomicU64::new(0);
    let total_budget = u64::from(plan.spp) * n;
    let progressive =
        plan.budget.is_some() || options.target_rel_error.is_some() || options.adaptive;
    if !progressive || n == 0 {
        counts.fill(plan.spp);
        render_pass(
            plan, &mut sums, &counts, &rays, &done, options, false, &sample,
        );
        return (sums, rays.into_inner());
    }
    // Uniform pilot of adaptive renders: a quarter of the samples, at most 64 spp (the
    // allocation is refined after every pass anyway), at least 2 so that variances exist.
    let pilot_spp = (plan.spp / 4).clamp(2, 64);
    let mut adaptive_phase = false;
    let mut taken_total = 0u64;
    let mut pass_spp = plan.spp.min(2);
    // Samples per second of the last pass, to size the next one to the time left.
    let mut rate: Option<f64> = None;
    // Whether that rate was measured on an adaptive pass (adaptive samples gather where paths
    // are long, so a uniform pass's rate overestimates theirs, by 2–3× on the glass lathe).
    let mut rate_adaptive = false;
    let mut pass_index = 0u64;
    while taken_total < total_budget {
        let elapsed = start.elapsed();
        // Even a spent budget gets a first pass of two samples per pixel: an image, and an error
        // estimate for every pixel.
        if plan.budget.is_some_and(|b| elapsed >= b) && taken_total >= (2 * n).min(total_budget) {
            break;
        }
        let mean_taken = taken_total / n;
        if options.adaptive
            && !adaptive_phase
            && mean_taken >= 2
            && (mean_taken >= u64::from(pilot_spp) || plan.budget.is_some_and(|b| elapsed * 4 >= b))
        {
            adaptive_phase = true;
        }
        let mut pass_samples = (u64::from(pass_spp) * n).min(total_budget - taken_total);
        let mut time_bound = false;
        if let (Some(b), Some(r)) = (plan.budget, rate) {
            // The pilot of an adaptive render ends at a quarter of the budget.
            let deadline = if options.adaptive && !adaptive_phase {
                b / 4
            } else {
                b
            };
            let mut fit = (r * deadline.saturating_sub(elapsed).as_secs_f64()) as u64;
            if adaptive_phase && !rate_adaptive {
                // First adaptive pass: plan a third of the time left, then measure.
                fit /= 3;
            }
            time_bound = fit < pass_samples;
            pass_samples = pass_samples.min(fit);
        }
        if adaptive_phase {
            // When time runs out, a pass of fewer than 1/16 spp is not worth its per-pass cost.
            if pass_samples == 0 || (time_bound && pass_samples < n / 16) {
                break;
            }
            allocate_adaptive(
                &sums,
                plan,
                source,
                pass_samples,
                pass_index,
                &mut scratch,
                &mut counts,
            );
        } else {
            let mut k = pass_samples / n;
            if k == 0 {
                if mean_taken < 2 {
                    k = 1; // an image needs samples, an error estimate two per pixel
                } else if options.adaptive {
                    adaptive_phase = true; // the pilot's time is up
                    continue;
                } else {
                    break;
                }
            }
            counts.fill(k as u32);
        }
        let mut this_pass: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        // Stochastic rounding may overshoot the samples left by a few: take them back.
        let mut excess = this_pass.saturating_sub(total_budget - taken_total);
        for c in counts.iter_mut().rev() {
            if excess == 0 {
                break;
            }
            let d = u64::from(*c).min(excess) as u32;
            *c -= d;
            excess -= u64::from(d);
            this_pass -= u64::from(d);
        }
        // ... or undershoot it in the last pass of a sample budget: top up from the last pixels
        // (a decision about a handful of samples that depends on all pixels, not on any one).
        if adaptive_phase && !time_bound && pass_samples == total_budget - taken_total {
            let (mut deficit, mut i) = (pass_samples.saturating_sub(this_pass), counts.len());
            while deficit > 0 {
                i = if i == 0 { counts.len() - 1 } else { i - 1 };
                counts[i] += 1;
                deficit -= 1;
                this_pass += 1;
            }
        }
        if this_pass == 0 {
            break;
        }
        let t0 = Instant::now();
        // Per-pixel timing feeds only the cost model of time-budgeted adaptive passes.
        let timed = options.adaptive && plan.budget.is_some();
        render_pass(
            plan, &mut sums, &counts, &rays, &done, options, timed, &sample,
        );
        rate = Some(this_pass as f64 / t0.elapsed().as_secs_f64().max(1e-6));
        rate_adaptive = adaptive_phase;
        taken_total += this_pass;
        pass_index += 1;
        if let Some(target) = options.target_rel_error {
            if estimate(&sums).1 <= target {
                break;
            }
        }
        pass_spp = pass_spp.saturating_mul(2).min(plan.spp.max(1));
    }
    (sums, rays.into_inner())
}

/// (estimated RMSE, estimated relative error) of the image from its per-pixel variances.
fn estimate(sums: &[PixelSum]) -> (f64, f64) {
    let n = sums.len() as f64;
    let mse = sums
        .iter()
        .map(|p| p.var_of_mean().element_sum() / 3.0)
        .sum::<f64>()
        / n;
    let rel = sums.iter().map(PixelSum::rel_var).sum::<f64>() / n;
    (mse.sqrt(), rel.sqrt())
}

/// Buffers of [`allocate_adaptive`], kept across passes.
#[derive(Default)]
struct Scratch {
    per_sample: Vec<f64>,
    cost: Vec<f64>,
    weights: Vec<f64>,
}

/// Splits about `budget` samples over the pixels for one adaptive pass.
///
/// **Target.** Minimising the relative MSE Σ aᵢ/nᵢ for a fixed total Σ nᵢ (aᵢ the per-sample
/// relative variance of pixel i) gives nᵢ ∝ √aᵢ (Lagrange multipliers). Each pixel is given the
/// difference between its share of all samples after this pass and what it has, at most 8× the
/// pass mean, and the wishes are scaled to the pass budget.
///
/// **Why not the pixel's own variance.** The image is the per-pixel sample mean, so the number of
/// samples must not depend on the samples it averages: with a heavy-tailed pixel (a caustic, a
/// glass edge) the samples that missed the rare bright paths have both a low mean and a low
/// variance, so a pixel that by chance drew low values stops early and keeps its low mean, while
/// one that drew a firefly gets more samples that dilute it — a downward bias (about 1% of the
/// image mean on the Cornell box). Estimating aᵢ from the 3×3 neighbourhood *without* pixel i
/// removes the pixel's own samples from the decision (each pixel has its own random streams), in
/// the spirit of the spatially filtered error of Rousselle, Knaus and Zwicker, "Adaptive sampling
/// and reconstruction using greedy error minimization", SIGGRAPH Asia 2011; neighbouring pixels
/// see nearly the same light paths, so their spread predicts the pixel's. What remains coupled is
/// second order (pixel i's samples change a neighbour's count, which changes only the precision,
/// not the expectation, of that neighbour's variance estimate) plus the 1/n share of one pixel in
/// the global scale factor; `tests/adaptive.rs` measures the mean to be unbiased within noise.
/// Fractional counts are rounded stochastically with a hash of (seed, pass, pixel), so rounding
/// does not couple pixels either (error diffusion would carry a neighbour's wish into the count).
/// A floor of a tenth of the mean weight keeps every pixel converging.
///
/// **Time budgets.** When the budget is time, not samples, the sum to minimise is the same but
/// the constraint is Σ cᵢnᵢ = T with cᵢ the cost of a sample of pixel i, so nᵢ ∝ √(aᵢ/cᵢ):
/// a sample through a glass lathe casts more (and costlier) rays than one that sees the floor.
/// cᵢ is the neighbourhood's measured time per sample (the pixel's own is left out for the same
/// reason as its variance: path length correlates with radiance). Timing makes the allocation
/// depend on the machine, which a render against the clock does anyway; sample budgets
/// (`--spp`) keep nᵢ ∝ √aᵢ and stay reproducible.
fn allocate_adaptive(
    sums: &[PixelSum],
    plan: &Plan,
    source: ErrorSource,
    budget: u64,
    pass: u64,
    scratch: &mut Scratch,
    counts: &mut [u32],
) {
    let (w, h) = (plan.width as usize, plan.height as usize);
    let n = sums.len();
    let per_sample = &mut scratch.per_sample;
    per_sample.clear();
    per_sample.extend(sums.iter().map(PixelSum::rel_var_per_sample));
    // Seconds per sample, the cost cᵢ of a sample of pixel i (under a time budget only).
    let cost = &mut scratch.cost;
    cost.clear();
    if plan.budget.is_some() {
        cost.extend(sums.iter().map(|p| {
            if p.taken() > 0 && p.nanos > 0 {
                p.nanos as f64 / f64::from(p.taken())
            } else {
                f64::NAN
            }
        }));
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
    let weights = &mut scratch.weights;
    weights.clear();
    weights.extend((0..n).map(|i| {
        let (a, c) = match source {
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
        let u = (crate::sampler::mix64(
            plan.seed ^ crate::sampler::mix64(pass.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ i as u64),
        ) >> 11) as f64
            / (1u64 << 53) as f64;
        *c = (x + u).floor().min(f64::from(u32::MAX / 2)) as u32;
    }
}

/// Adds `counts[i]` more samples to pixel i, tile by tile in parallel; with `timed`, also
/// records the wall time each pixel's samples took.
#[allow(clippy::too_many_arguments)]
fn render_pass<F>(
    plan: &Plan,
    sums: &mut [PixelSum],
    counts: &[u32],
    rays: &AtomicU64,
    done: &AtomicU64,
    options: &RenderOptions,
    timed: bool,
    sample: &F,
) where
    F: Fn(u32, u32, Range<u32>, &mut TraceStats) -> PixelSum + Sync,
{
    let (w, h) = (plan.width, plan.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let results: Vec<(u32, Vec<PixelSum>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .with_max_len(1)
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let mut stats = TraceStats::default();
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            let mut n = 0u64;
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * w + x) as usize;
                    let first = sums[i].taken();
                    out.push(if counts[i] == 0 {
                        PixelSum::default()
                    } else if timed {
                        let t = Instant::now();
                        let mut add = sample(x, y, first..first + counts[i], &mut stats);
                        add.nanos = t.elapsed().as_nanos() as u64;
                        add
                    } else {
                        sample(x, y, first..first + counts[i], &mut stats)
                    });
                    n += u64::from(counts[i]);
                }
            }
            rays.fetch_add(stats.rays, Ordering::Relaxed);
            let total = done.fetch_add(n, Ordering::Relaxed) + n;
            if let Some(p) = options.progress {
                p(total);
            }
            (tile, out)
        })
        .collect();
    for (tile, out) in results {
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let x1 = (x0 + TILE).min(w);
        for (i, add) in out.into_iter().enumerate() {
            let (dx, dy) = (i as u32 % (x1 - x0), i as u32 / (x1 - x0));
            let p = &mut sums[((y0 + dy) * w + x0 + dx) as usize];
            p.sum += add.sum;
            p.sum_sq += add.sum_sq;
            p.good += add.good;
            p.bad += add.bad;
            p.nanos += add.nanos;
        }
    }
}

fn render_samples(
    scene: &Scene,
    x: u32,
    y: u32,
    range: Range<u32>,
    stats: &mut TraceStats,
) -> PixelSum {
    let s = &scene.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let mut acc = PixelSum::default();
    for i in range {
        let mut sampler = Sampler::with_kind(s.sampler, s.seed, pixel, u64::from(i));
        let jitter = sampler.get_2d();
        let film = Vec2::new(
            (x as f32 + jitter.x) / s.width as f32,
            (y as f32 + jitter.y) / s.height as f32,
        );
        let ray = scene.camera.ray(film, sampler.get_2d());
        let l = radiance(scene, ray, &mut sampler, stats);
        if l.is_finite() {
            let l = l.as_dvec3();
            acc.sum += l;
            acc.sum_sq += l * l;
            acc.good += 1;
        } else {
            acc.bad += 1;
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::mix64;

    /// A synthetic film whose true pixel means and variances are known in closed form: the left
    /// half is smooth (uniform values on [0.4, 0.6]), the right half heavy-tailed like a caustic
    /// (value `BIG` with probability `P`, else `SMALL`). Every (pixel, sample index) has its own
    /// hash-derived random number, as the renderer's samplers do.
    const P: f64 = 0.05;
    const BIG: f64 = 20.0;
    const SMALL: f64 = 0.2;

    fn uniform01(seed: u64, x: u32, y: u32, i: u32) -> f64 {
        (mix64(seed ^ mix64((u64::from(y) << 40) ^ (u64::from(x) << 20) ^ u64::from(i))) >> 11)
            as f64
            / (1u64 << 53) as f64
    }

    fn synthetic(
        width: u32,
        seed: u64,
    ) -> impl Fn(u32, u32, Range<u32>, &mut TraceStats) -> PixelSum + Sync {
        move |x, y, range, _| {
            let mut acc = PixelSum::default();
            for i in range {
                let u = uniform01(seed, x, y, i);
                let v = if x < width / 2 {
                    0.4 + 0.2 * u
                } else if u < P {
                    BIG
                } else {
                    SMALL
                };
                let v = DVec3::splat(v);
                acc.sum += v;
                acc.sum_sq += v * v;
                acc.good += 1;
            }
            acc
        }
    }

    /// (true mean, per-sample variance) of pixel column x.
    fn truth(width: u32, x: u32) -> (f64, f64) {
        if x < width / 2 {
            (0.5, 0.04 / 12.0)
        } else {
            let m = P * BIG + (1.0 - P) * SMALL;
            (m, P * BIG * BIG + (1.0 - P) * SMALL * SMALL - m * m)
        }
    }

    /// (image mean − true mean) / its standard deviation, given the sample counts (which, when
    /// they do not depend on the pixel's own samples, make the per-pixel means independent and
    /// unbiased with variance σ²/n).
    fn z_score(source: ErrorSource, seed: u64) -> (f64, Vec<PixelSum>) {
        let (w, h) = (64, 64);
        let plan = Plan {
            width: w,
            height: h,
            spp: 32,
            budget: None,
            seed,
        };
        let options = RenderOptions {
            adaptive: true,
            ..Default::default()
        };
        let (sums, _) = run_passes(&plan, &options, source, synthetic(w, seed));
        let n = sums.len() as f64;
        let (mut err, mut var) = (0.0, 0.0);
        for (i, p) in sums.iter().enumerate() {
            let (m, v) = truth(w, i as u32 % w);
            err += (p.mean().x - m) / n;
            var += v / f64::from(p.good) / (n * n);
        }
        (err / var.sqrt(), sums)
    }

    #[test]
    fn own_sample_decisions_bias_the_mean_and_neighbour_decisions_do_not() {
        // Several seeds so that a chance pass of the biased rule cannot hide the effect.
        let (mut own, mut neighbours) = (0.0, 0.0);
        let seeds = [1, 2, 3, 4];
        for seed in seeds {
            let (z_own, _) = z_score(ErrorSource::Own, seed);
            let (z_nb, sums) = z_score(ErrorSource::Neighbours, seed);
            eprintln!("seed {seed}: z own {z_own:+.2}, z neighbours {z_nb:+.2}");
            own += z_own;
            neighbours += z_nb;
            // Same budget, and the heavy-tailed half got more of it.
            let taken: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
            assert_eq!(taken, 64 * 64 * 32);
            let half = |right: bool| {
                sums.iter()
                    .enumerate()
                    .filter(|(i, _)| (i % 64 >= 32) == right)
                    .map(|(_, p)| u64::from(p.taken()))
                    .sum::<u64>()
            };
            assert!(
                half(true) > 2 * half(false),
                "right {} vs left {}",
                half(true),
                half(false)
            );
        }
        // Sums of independent unit normals over 4 seeds: divide by √4 for one unit normal.
        let (own, neighbours) = (own / 2.0, neighbours / 2.0);
        assert!(
            own < -5.0,
            "the own-sample rule should show its downward bias: z = {own:.2}"
        );
        assert!(
            neighbours.abs() < 3.0,
            "neighbour rule biased: z = {neighbours:.2}"
        );
    }

    #[test]
    fn uniform_progressive_passes_take_the_same_samples_as_one_pass() {
        let plan = Plan {
            width: 20,
            height: 12,
            spp: 24,
            budget: None,
            seed: 5,
        };
        let (one, _) = run_passes(
            &plan,
            &RenderOptions::default(),
            ErrorSource::Neighbours,
            synthetic(20, 5),
        );
        let (passes, _) = run_passes(
            &plan,
            &RenderOptions {
                target_rel_error: Some(0.0),
                ..Default::default()
            },
            ErrorSource::Neighbours,
            synthetic(20, 5),
        );
        for (a, b) in one.iter().zip(&passes) {
            assert_eq!(a.good, 24);
            assert_eq!(b.good, 24);
            assert!((a.sum - b.sum).abs().max_element() < 1e-9);
        }
    }
}
