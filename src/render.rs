//! The render loop: tiles spread over threads with rayon, each pixel sample drawn from its own
//! random stream so the image is identical whatever the thread count; progressive passes for
//! time budgets, error targets and adaptive sampling; per-pixel error estimates.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use crate::integrator::{radiance, TraceStats};
use crate::math::{Rgb, Vec2, Vec3};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// Side of the square tiles work is split into.
pub const TILE: u32 = 16;

/// ε in relative errors (x − r)² / (r² + ε), so that dark pixels do not dominate
/// (the usual choice in rendering papers, e.g. Rousselle et al. 2011).
pub const REL_EPSILON: f64 = 1e-2;

/// A rendered image in linear radiance.
#[derive(Debug, Clone)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, row-major, top row first.
    pub pixels: Vec<Rgb>,
}

impl Image {
    fn squared_errors<'a>(&'a self, other: &'a Image) -> impl Iterator<Item = (DVec3, DVec3)> + 'a {
        assert_eq!((self.width, self.height), (other.width, other.height), "images differ in size");
        self.pixels.iter().zip(&other.pixels).map(|(a, b)| {
            let d = (*a - *b).as_dvec3();
            (d * d, b.as_dvec3())
        })
    }

    /// Root-mean-square difference over all pixels and channels.
    pub fn rmse(&self, other: &Image) -> f64 {
        let sum: f64 = self.squared_errors(other).map(|(d2, _)| d2.element_sum()).sum();
        (sum / (3.0 * self.pixels.len() as f64)).sqrt()
    }

    /// Relative mean squared error against a reference: mean of (x − r)² / (r² + ε).
    pub fn rel_mse(&self, reference: &Image) -> f64 {
        let sum: f64 = self.squared_errors(reference).map(|(d2, r)| (d2 / (r * r + DVec3::splat(REL_EPSILON))).element_sum()).sum();
        sum / (3.0 * self.pixels.len() as f64)
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let sum = self.pixels.iter().fold(DVec3::ZERO, |a, p| a + p.as_dvec3());
        (sum / self.pixels.len() as f64).as_vec3()
    }
}

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
    /// After a uniform start, give each pass's samples to the pixels with the largest
    /// estimated relative error.
    pub adaptive: bool,
}

/// A render with its per-pixel error estimate.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Mean radiance per pixel.
    pub image: Image,
    /// Standard error of each pixel's mean, per channel.
    pub std_error: Image,
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
}

impl PixelSum {
    fn taken(&self) -> u32 {
        self.good + self.bad
    }

    fn mean(&self) -> DVec3 {
        if self.good == 0 { DVec3::ZERO } else { self.sum / f64::from(self.good) }
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
/// `spp` samples per pixel (on average) taken. Each sample index has its own random stream, so
/// the image depends only on which samples were taken, not on passes or threads.
pub fn render_with_error(scene: &Scene, options: &RenderOptions) -> Rendered {
    let start = Instant::now();
    let s = &scene.settings;
    let (w, h) = (s.width, s.height);
    let n_pixels = (w * h) as usize;
    let budget = s.time_budget_s.map(|t| Duration::from_secs_f32(t.max(0.0)));
    let progressive = budget.is_some() || options.target_rel_error.is_some() || options.adaptive;
    let mut sums = vec![PixelSum::default(); n_pixels];
    let rays = AtomicU64::new(0);
    let done = AtomicU64::new(0);
    let total_budget = u64::from(s.spp) * n_pixels as u64;
    let mut taken_total = 0u64;
    // Samples per pixel (on average) of the next pass: start with 2 so variances exist.
    let mut pass = if progressive { s.spp.min(2) } else { s.spp };
    // Adaptive passes start once every pixel has a few samples.
    let uniform_until = (s.spp / 4).max(4);
    let mut counts = vec![0u32; n_pixels];
    while taken_total < total_budget {
        let remaining = total_budget - taken_total;
        let mean_taken = (taken_total / n_pixels as u64) as u32;
        if options.adaptive && mean_taken >= uniform_until {
            allocate_adaptive(&sums, &mut counts, (u64::from(pass) * n_pixels as u64).min(remaining));
        } else {
            let k = u64::from(pass).min(remaining / n_pixels as u64).max(1) as u32;
            counts.iter_mut().for_each(|c| *c = k);
        }
        let this_pass: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        if this_pass == 0 {
            break;
        }
        taken_total += this_pass;
        render_pass(scene, &mut sums, &counts, &rays, &done, options);
        if budget.is_some_and(|b| start.elapsed() >= b) {
            break;
        }
        if let Some(target) = options.target_rel_error {
            if estimate(&sums).1 <= target {
                break;
            }
        }
        pass = pass.saturating_mul(2).min(s.spp.max(1));
    }
    let image = Image { width: w, height: h, pixels: sums.iter().map(|p| p.mean().as_vec3()).collect() };
    let std_error = Image {
        width: w,
        height: h,
        pixels: sums.iter().map(|p| {
            let v = p.var_of_mean();
            if v.is_finite() { v.map(f64::sqrt).as_vec3() } else { Vec3::ZERO }
        }).collect(),
    };
    let (estimated_rmse, estimated_rel_error) = estimate(&sums);
    let samples: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
    let stats = Stats {
        spp: (samples as f64 / n_pixels as f64).round() as u32,
        samples,
        rays: rays.into_inner(),
        nan_samples: sums.iter().map(|p| u64::from(p.bad)).sum(),
        elapsed: start.elapsed(),
        estimated_rmse,
        estimated_rel_error,
    };
    Rendered { image, std_error, stats }
}

/// (estimated RMSE, estimated relative error) of the image from its per-pixel variances.
fn estimate(sums: &[PixelSum]) -> (f64, f64) {
    let n = sums.len() as f64;
    let mse = sums.iter().map(|p| p.var_of_mean().element_sum() / 3.0).sum::<f64>() / n;
    let rel = sums.iter().map(PixelSum::rel_var).sum::<f64>() / n;
    (mse.sqrt(), rel.sqrt())
}

/// Splits `budget` samples over pixels so that each pixel's total approaches the optimum
/// nᵢ ∝ √aᵢ for minimising Σ aᵢ/nᵢ, with aᵢ = nᵢ·relvarᵢ its per-sample relative variance
/// (Lagrange multipliers); a pixel gets at most 8× the mean of the pass.
fn allocate_adaptive(sums: &[PixelSum], counts: &mut [u32], budget: u64) {
    let weights: Vec<f64> = sums.iter().map(|p| (p.rel_var() * f64::from(p.good.max(1))).sqrt()).map(|w| if w.is_finite() { w } else { 0.0 }).collect();
    let total_w: f64 = weights.iter().sum();
    let already: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
    let after = (already + budget) as f64;
    let cap = (8 * budget / sums.len() as u64).max(1) as f64;
    if total_w <= 0.0 {
        let k = (budget / sums.len() as u64).max(1) as u32;
        counts.iter_mut().for_each(|c| *c = k);
        return;
    }
    // Pixels already above their share get nothing, so scale the others to fit the budget.
    let wants: Vec<f64> = weights.iter().zip(sums).map(|(w, p)| (after * w / total_w - f64::from(p.taken())).clamp(0.0, cap)).collect();
    let scale = (budget as f64 / wants.iter().sum::<f64>().max(1.0)).min(1.0);
    for (c, want) in counts.iter_mut().zip(&wants) {
        *c = (want * scale).floor() as u32;
    }
}

/// Adds `counts[i]` more samples to pixel i, tile by tile in parallel.
fn render_pass(scene: &Scene, sums: &mut [PixelSum], counts: &[u32], rays: &AtomicU64, done: &AtomicU64, options: &RenderOptions) {
    let (w, h) = (scene.settings.width, scene.settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let results: Vec<(u32, Vec<PixelSum>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
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
                    out.push(render_samples(scene, x, y, first..first + counts[i], &mut stats));
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
        }
    }
}

fn render_samples(scene: &Scene, x: u32, y: u32, range: std::ops::Range<u32>, stats: &mut TraceStats) -> PixelSum {
    let s = &scene.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let mut acc = PixelSum::default();
    for i in range {
        let mut sampler = Sampler::with_kind(s.sampler, s.seed, pixel, u64::from(i));
        let jitter = sampler.get_2d();
        let film = Vec2::new((x as f32 + jitter.x) / s.width as f32, (y as f32 + jitter.y) / s.height as f32);
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
