//! The render loop: tiles spread over threads with rayon, each pixel sample drawn from its own
//! random stream so the image is identical whatever the thread count; progressive passes for
//! time budgets, error targets and adaptive sampling; per-pixel error estimates.

mod adaptive;
mod film;
mod pass;
mod pixel;
mod schedule;
#[cfg(test)]
mod tests;

use std::ops::Range;
use std::sync::atomic::AtomicU64;
use std::time::{Duration, Instant};

use adaptive::{allocate_adaptive, ErrorSource, Scratch};
use film::{estimate, finish, PixelSum};
use pass::render_pass;
pub use pass::TILE;
use pixel::render_samples;
use schedule::Plan;

pub use crate::image::Image;
use crate::integrator::TraceStats;
use crate::scene::Scene;

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
