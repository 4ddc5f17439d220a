//! The render loop: each pixel sample drawn from its own random stream so the image is
//! identical whatever the thread count; progressive passes for time budgets, error targets and
//! adaptive sampling; per-pixel error estimates.
//!
//! One concern per file: per-pixel accumulation in `film.rs`, pass sizing and stopping in
//! `schedule.rs`, adaptive allocation of a pass's samples in `adaptive.rs`, rendering one pass
//! over tiles in parallel in `pass.rs`, and one pixel's camera samples in `pixel.rs`. This file
//! holds the public entry points and wires those together.

mod adaptive;
mod film;
mod pass;
mod pixel;
mod schedule;
#[cfg(test)]
mod tests;

use std::ops::Range;
use std::time::{Duration, Instant};

use adaptive::{AdaptiveAllocator, ErrorSource};
use film::{Film, PixelSum};
use pass::PassContext;
pub use pass::TILE;
use pixel::render_samples;
use schedule::{NextPass, Plan, Schedule};

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
/// relative error; the allocator (`src/render/adaptive.rs`) explains why the pixel's own
/// samples are left out.
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
    let (film, rays) = run_passes(
        &plan,
        options,
        ErrorSource::Neighbours,
        |x, y, indices, stats| render_samples(scene, x, y, indices, stats),
    );
    finish(&film, rays, start.elapsed())
}

/// Takes all samples of a render, pass by pass; `sample(x, y, indices, stats)` returns the sums
/// of pixel (x, y)'s samples with the given indices. Returns the film and the rays cast.
fn run_passes<F>(
    plan: &Plan,
    options: &RenderOptions,
    source: ErrorSource,
    sample: F,
) -> (Film, u64)
where
    F: Fn(u32, u32, Range<u32>, &mut TraceStats) -> PixelSum + Sync,
{
    let mut schedule = Schedule::new(plan, options);
    let mut film = Film::new(plan.width, plan.height);
    let mut allocator = AdaptiveAllocator::new(plan.seed, plan.budget.is_some(), source);
    // Per-pixel timing feeds only the cost model of time-budgeted adaptive passes.
    let timed = options.adaptive && plan.budget.is_some();
    let context = PassContext::new(sample, options.progress, timed);
    let mut counts = vec![0u32; film.pixels().len()];
    while let Some(next) = schedule.next_pass() {
        let samples = match next {
            NextPass::Uniform(spp) => {
                counts.fill(spp);
                u64::from(spp) * counts.len() as u64
            }
            NextPass::Adaptive(pass) => match allocator.allocate(&film, &pass, &mut counts) {
                0 => break,
                samples => samples,
            },
        };
        let pass_start = Instant::now();
        film.merge(&context.render(&film, &counts));
        schedule.record_pass(samples, pass_start.elapsed(), &film);
    }
    let rays = context.rays();
    (film, rays)
}

/// Image, error image and counters from the film.
fn finish(film: &Film, rays: u64, elapsed: Duration) -> Rendered {
    let estimate = film.estimate();
    let samples = film.samples_taken();
    let stats = Stats {
        spp: (samples as f64 / film.pixels().len().max(1) as f64).round() as u32,
        samples,
        rays,
        nan_samples: film.dropped_samples(),
        elapsed,
        estimated_rmse: estimate.rmse,
        estimated_rel_error: estimate.rel_error,
    };
    Rendered {
        image: film.image(),
        std_error: film.std_error(),
        counts: film.counts(),
        stats,
    }
}
