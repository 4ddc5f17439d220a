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
mod occlusion_queue;
mod pass;
mod schedule;
#[cfg(test)]
mod tests;
mod wave;

use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use adaptive::{AdaptiveAllocator, ErrorSource};
pub(crate) use film::Sink;
pub use film::{ErrorEstimate, Film, PixelSum, MAX_SAMPLE};
use pass::PassContext;
pub use pass::TILE;
use schedule::{NextPass, Plan, Schedule};
use wave::{render_pixels, PixelWork};

use crate::aov::AovSet;
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

/// A window of the image: pixels `x0..x1` × `y0..y1` (top row first).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Window {
    /// The whole of a `width` × `height` image.
    pub fn full(width: u32, height: u32) -> Window {
        Window {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
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
    /// Render only this window of the image (default: all of it); the film covers the window.
    pub crop: Option<Window>,
    /// Index of every pixel's first sample (default 0): a render of `spp` samples takes indices
    /// `first_sample..first_sample + spp`, so that sample ranges rendered apart merge into the
    /// render that takes them all.
    pub first_sample: u32,
    /// Continue from this film (a checkpoint of the same scene, window and first sample): its
    /// samples count towards `spp`, and new samples continue each pixel's indices after them.
    pub resume: Option<&'a Film>,
    /// When set (by a signal handler, say), the render takes no new work: threads stop within
    /// the step of the wave of paths they are on, the pass in flight is dropped, and the film of the passes finished so
    /// far is returned, marked interrupted: it holds whole passes only.
    pub cancel: Option<&'a AtomicBool>,
    /// Called after every finished pass with the film so far (for checkpoints, previews).
    /// Setting it, or `cancel`, makes uniform renders progressive, so that there are whole passes
    /// to keep: with it, passes of doubling size (progress shows early); with `cancel` alone, a
    /// first pass of two samples per pixel and then passes as large as fit; each at most
    /// [`MAX_PASS_SECONDS`] long once the throughput is known. The image is the same bits either
    /// way (the film's sums are exact).
    pub on_pass: Option<&'a (dyn Fn(&Film) + Sync)>,
    /// Paths each thread runs at once, in SIMD lanes: 1, 4, 8 or 16 (default:
    /// [`crate::lanes::default_width`], this CPU's widest or `LUMO_SIMD`). The image is the
    /// same bits at every width; only the speed differs.
    pub lane_width: Option<usize>,
    /// Render passes to sum besides the beauty ([`crate::aov`]); a film resumed from must sum
    /// the same ones. They change no bit of the beauty.
    pub aovs: AovSet,
}

/// Longest pass, in seconds, of renders that can be interrupted or checkpointed: an interruption
/// loses at most this much work.
pub const MAX_PASS_SECONDS: f64 = 2.0;

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
    /// Every sample's sums: what partial films and checkpoints save.
    pub film: Film,
    /// Whether [`RenderOptions::cancel`] stopped the render before its budget was spent.
    pub interrupted: bool,
}

/// Renders the scene with its settings.
pub fn render(scene: &Scene, options: &RenderOptions) -> (Image, Stats) {
    let r = render_with_error(scene, options);
    (r.image, r.stats)
}

/// Renders the scene and estimates each pixel's error from its samples.
///
/// Without a time budget, error target or adaptivity, all samples are taken in one pass (or, for
/// a render that can only be cancelled, in a first pass of two samples per pixel and then passes
/// as long as [`MAX_PASS_SECONDS`] allows). Otherwise passes of doubling size run until the
/// budget is spent, the target reached or `spp` samples per pixel (on average) taken; with a time budget each pass is sized from the
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
    let window = options.crop.unwrap_or(Window::full(s.width, s.height));
    let plan = Plan {
        width: window.width(),
        height: window.height(),
        spp: s.spp,
        budget: s.time_budget_s.map(|t| Duration::from_secs_f32(t.max(0.0))),
        seed: s.seed,
    };
    let (x0, y0) = (window.x0, window.y0);
    let width = options
        .lane_width
        .unwrap_or_else(crate::lanes::default_width);
    let (film, rays, interrupted) = run_passes(
        &plan,
        options,
        ErrorSource::Neighbours,
        |work, sums, stats| {
            render_pixels(scene, (width, options.cancel), (x0, y0), work, sums, stats)
        },
    );
    finish(film, rays, start.elapsed(), interrupted)
}

/// Takes all samples of a render, pass by pass; `sample(work, sums, stats)` puts the sums of the
/// samples `work` lists (pixels in the film's window) into `sums`. Returns the
/// film, the rays cast and whether `options.cancel` interrupted the render.
fn run_passes<F>(
    plan: &Plan,
    options: &RenderOptions,
    source: ErrorSource,
    sample: F,
) -> (Film, u64, bool)
where
    F: Fn(&[PixelWork], &mut Sink, &mut TraceStats) + Sync,
{
    let mut film = match options.resume {
        Some(f) => {
            assert_eq!(
                (f.width(), f.height()),
                (plan.width, plan.height),
                "the film resumed from has another size"
            );
            assert_eq!(
                f.aov_set(),
                Film::with_aovs(1, 1, options.aovs).aov_set(),
                "the film resumed from has other render passes"
            );
            f.clone()
        }
        None => Film::with_aovs(plan.width, plan.height, options.aovs),
    };
    let mut schedule = Schedule::new(plan, options, film.samples_taken());
    let mut allocator = AdaptiveAllocator::new(plan.seed, plan.budget.is_some(), source);
    // Per-pixel timing feeds only the cost model of time-budgeted adaptive passes.
    let timed = options.adaptive && plan.budget.is_some();
    let context = PassContext::new(
        sample,
        options.progress,
        timed,
        options.first_sample,
        options.cancel,
        options.aovs,
    );
    let mut counts = vec![0u32; film.pixels().len()];
    let mut interrupted = false;
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
        if !context.render(&mut film, &counts) {
            interrupted = true;
            break;
        }
        schedule.record_pass(samples, pass_start.elapsed(), &film);
        if let Some(on_pass) = options.on_pass {
            on_pass(&film);
        }
    }
    let rays = context.rays();
    (film, rays, interrupted)
}

/// Image, error image and counters from the film.
fn finish(film: Film, rays: u64, elapsed: Duration, interrupted: bool) -> Rendered {
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
        film,
        interrupted,
    }
}
