//! Pass scheduling: when a render stops (samples, time or error target reached) and how many
//! samples its next pass takes.
//!
//! Without a time budget, error target or adaptivity, all samples are taken in one pass. A
//! render that can only be interrupted (a cancel flag and nothing else) takes a first pass of two
//! samples per pixel, which measures the throughput, then passes as large as
//! [`super::MAX_PASS_SECONDS`] allows (each pass costs a few milliseconds of per-pixel set-up,
//! film merging and threads waiting for the last tile: the doubling passes cost GlassVaseFlowers'
//! 64-spp benchmark render 7 %). Otherwise passes of doubling size run, so that progress shows
//! early and error targets are not overshot by much; with a time budget each pass is sized from
//! the previous pass's throughput so that the last one ends near the deadline. Adaptive renders
//! start with a uniform pilot, then hand each pass to the adaptive allocator.

use std::time::{Duration, Instant};

use super::adaptive::AdaptivePass;
use super::film::Film;
use super::RenderOptions;

/// The shape and budget of a render, independent of what is rendered.
pub(super) struct Plan {
    /// Image width in pixels.
    pub(super) width: u32,
    /// Image height in pixels.
    pub(super) height: u32,
    /// Samples per pixel (mean), the cap of the budget.
    pub(super) spp: u32,
    /// Wall-time budget.
    pub(super) budget: Option<Duration>,
    /// Seed of the render; also seeds the stochastic rounding of adaptive sample counts.
    pub(super) seed: u64,
}

/// What the next pass takes.
#[derive(Debug, Clone, Copy)]
pub(super) enum NextPass {
    /// The same number of samples in every pixel.
    Uniform(u32),
    /// Samples spread by the adaptive allocator.
    Adaptive(AdaptivePass),
}

/// Samples per second of the last pass, to size the next one to the time left.
#[derive(Debug, Clone, Copy)]
struct Throughput {
    samples_per_second: f64,
    /// Whether it was measured on an adaptive pass (adaptive samples gather where paths are
    /// long, so a uniform pass's rate overestimates theirs, by 2–3× on the glass lathe).
    adaptive: bool,
}

/// The pass schedule of one render: decides each pass from the ones before it.
pub(super) struct Schedule {
    /// When the render started.
    start: Instant,
    /// Wall-time budget.
    budget: Option<Duration>,
    /// Samples per pixel (mean), the cap of the budget.
    spp: u32,
    /// Pixels in the image.
    pixels: u64,
    /// Samples of the whole render at most: `spp` per pixel.
    total_samples: u64,
    /// All samples in one pass (no time budget, error target or adaptivity).
    single_pass: bool,
    /// Passes after the first fill the time cap instead of doubling: nothing but a cancel flag
    /// wants them (no progress callback, budget, error target, adaptivity or resumed film).
    fill_passes: bool,
    /// Whether passes after the pilot are adaptive.
    adaptive: bool,
    /// Stop once the estimated relative error falls below this.
    target_rel_error: Option<f64>,
    /// Samples per pixel of the uniform pilot of adaptive renders.
    pilot_spp: u32,
    /// Whether the pilot is over and passes are adaptive.
    adaptive_phase: bool,
    /// Samples taken so far.
    samples_taken: u64,
    /// Samples per pixel of the next uniform pass, doubling from pass to pass.
    pass_spp: u32,
    /// Throughput of the last pass.
    throughput: Option<Throughput>,
    /// Passes finished.
    passes: u64,
    /// Whether the error target has been reached.
    target_reached: bool,
    /// Longest pass in seconds, once the throughput is known (interruptible renders).
    max_pass_seconds: Option<f64>,
}

impl Schedule {
    /// The schedule of a render of `plan` with `options`, starting now with `samples_taken`
    /// samples already in the film (a resumed render).
    pub(super) fn new(plan: &Plan, options: &RenderOptions, samples_taken: u64) -> Schedule {
        let pixels = u64::from(plan.width * plan.height);
        let interruptible = options.cancel.is_some() || options.on_pass.is_some();
        let progressive = plan.budget.is_some()
            || options.target_rel_error.is_some()
            || options.adaptive
            || interruptible
            || samples_taken > 0;
        Schedule {
            start: Instant::now(),
            budget: plan.budget,
            spp: plan.spp,
            pixels,
            total_samples: u64::from(plan.spp) * pixels,
            single_pass: !progressive || pixels == 0,
            fill_passes: options.on_pass.is_none()
                && plan.budget.is_none()
                && options.target_rel_error.is_none()
                && !options.adaptive
                && samples_taken == 0,
            adaptive: options.adaptive,
            target_rel_error: options.target_rel_error,
            // Uniform pilot of adaptive renders: a quarter of the samples, at most 64 spp (the
            // allocation is refined after every pass anyway), at least 2 so that variances exist.
            pilot_spp: (plan.spp / 4).clamp(2, 64),
            adaptive_phase: false,
            samples_taken,
            pass_spp: plan.spp.min(2),
            throughput: None,
            passes: 0,
            target_reached: false,
            max_pass_seconds: interruptible.then_some(super::MAX_PASS_SECONDS),
        }
    }

    /// The next pass, or `None` once the render is done.
    pub(super) fn next_pass(&mut self) -> Option<NextPass> {
        if self.single_pass {
            return (self.passes == 0).then_some(NextPass::Uniform(self.spp));
        }
        let n = self.pixels;
        loop {
            if self.target_reached || self.samples_taken >= self.total_samples {
                return None;
            }
            let samples_left = self.total_samples - self.samples_taken;
            let elapsed = self.start.elapsed();
            // Even a spent budget gets a first pass of two samples per pixel: an image, and an
            // error estimate for every pixel.
            if self.budget.is_some_and(|b| elapsed >= b)
                && self.samples_taken >= (2 * n).min(self.total_samples)
            {
                return None;
            }
            let mean_taken = self.samples_taken / n;
            if self.adaptive
                && !self.adaptive_phase
                && mean_taken >= 2
                && (mean_taken >= u64::from(self.pilot_spp)
                    || self.budget.is_some_and(|b| elapsed * 4 >= b))
            {
                self.adaptive_phase = true;
            }
            let mut pass_samples = (u64::from(self.pass_spp) * n).min(samples_left);
            if let (Some(cap), Some(throughput)) = (self.max_pass_seconds, self.throughput) {
                let fit = (throughput.samples_per_second * cap) as u64;
                pass_samples = pass_samples.min(fit.max(n));
            }
            let mut time_bound = false;
            if let (Some(b), Some(throughput)) = (self.budget, self.throughput) {
                // The pilot of an adaptive render ends at a quarter of the budget.
                let deadline = if self.adaptive && !self.adaptive_phase {
                    b / 4
                } else {
                    b
                };
                let mut fit = (throughput.samples_per_second
                    * deadline.saturating_sub(elapsed).as_secs_f64())
                    as u64;
                if self.adaptive_phase && !throughput.adaptive {
                    // First adaptive pass: plan a third of the time left, then measure.
                    fit /= 3;
                }
                time_bound = fit < pass_samples;
                pass_samples = pass_samples.min(fit);
            }
            if self.adaptive_phase {
                // When time runs out, a pass of fewer than 1/16 spp is not worth its per-pass cost.
                if pass_samples == 0 || (time_bound && pass_samples < n / 16) {
                    return None;
                }
                return Some(NextPass::Adaptive(AdaptivePass {
                    samples: pass_samples,
                    samples_left,
                    last: !time_bound && pass_samples == samples_left,
                    index: self.passes,
                }));
            }
            let mut k = pass_samples / n;
            if k == 0 {
                if mean_taken < 2 {
                    k = 1; // an image needs samples, an error estimate two per pixel
                } else if self.adaptive {
                    self.adaptive_phase = true; // the pilot's time is up
                    continue;
                } else {
                    return None;
                }
            }
            return Some(NextPass::Uniform(k as u32));
        }
    }

    /// Records a finished pass: `samples` taken in `duration`, leaving `film` with the
    /// render's samples so far (checked against the error target).
    pub(super) fn record_pass(&mut self, samples: u64, duration: Duration, film: &Film) {
        self.throughput = Some(Throughput {
            samples_per_second: samples as f64 / duration.as_secs_f64().max(1e-6),
            adaptive: self.adaptive_phase,
        });
        self.samples_taken += samples;
        self.passes += 1;
        if let Some(target) = self.target_rel_error {
            if film.estimate().rel_error <= target {
                self.target_reached = true;
                return;
            }
        }
        self.pass_spp = if self.fill_passes {
            self.spp.max(1)
        } else {
            self.pass_spp.saturating_mul(2).min(self.spp.max(1))
        };
    }
}
