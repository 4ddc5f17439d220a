//! The render loop: tiles spread over threads with rayon, each pixel's samples drawn from its
//! own random streams so the image is identical whatever the thread count.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::integrator::{radiance, TraceStats};
use crate::math::{Rgb, Vec2, Vec3};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// Side of the square tiles work is split into.
pub const TILE: u32 = 16;

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
    /// Root-mean-square difference over all pixels and channels.
    pub fn rmse(&self, other: &Image) -> f64 {
        assert_eq!((self.width, self.height), (other.width, other.height), "images differ in size");
        let sum: f64 = self
            .pixels
            .iter()
            .zip(&other.pixels)
            .map(|(a, b)| {
                let d = *a - *b;
                f64::from(d.x).powi(2) + f64::from(d.y).powi(2) + f64::from(d.z).powi(2)
            })
            .sum();
        (sum / (3.0 * self.pixels.len() as f64)).sqrt()
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let sum = self.pixels.iter().fold(glam::DVec3::ZERO, |a, p| a + p.as_dvec3());
        (sum / self.pixels.len() as f64).as_vec3()
    }
}

/// What a render did.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    /// Samples per pixel taken.
    pub spp: u32,
    /// Rays cast.
    pub rays: u64,
    /// Samples that produced NaN or infinity and were dropped.
    pub nan_samples: u64,
    /// Wall time.
    pub elapsed: Duration,
}

/// Options of a render call.
pub struct RenderOptions<'a> {
    /// Called with the number of samples finished so far (for progress bars).
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
}

/// Running sums of one pixel's samples.
#[derive(Debug, Clone, Copy, Default)]
struct PixelSum {
    sum: glam::DVec3,
    good: u32,
    bad: u32,
}

/// Renders the scene with its settings. Without a time budget all samples are taken in one
/// pass; with one, passes of doubling size run until the budget is spent or `spp` is reached.
/// Either way each sample index has its own random stream, so the image depends only on the
/// number of samples taken, not on how they were split into passes or threads.
pub fn render(scene: &Scene, options: &RenderOptions) -> (Image, Stats) {
    let start = Instant::now();
    let s = &scene.settings;
    let (w, h) = (s.width, s.height);
    let budget = s.time_budget_s.map(|t| Duration::from_secs_f32(t.max(0.0)));
    let mut sums = vec![PixelSum::default(); (w * h) as usize];
    let rays = AtomicU64::new(0);
    let done = AtomicU64::new(0);
    let mut taken = 0u32;
    let mut pass = if budget.is_some() { 1 } else { s.spp };
    while taken < s.spp {
        let end = (taken + pass).min(s.spp);
        render_pass(scene, &mut sums, taken..end, &rays, &done, options);
        taken = end;
        if budget.is_some_and(|b| start.elapsed() >= b) {
            break;
        }
        pass = pass.saturating_mul(2);
    }
    let pixels = sums.iter().map(|p| if p.good > 0 { (p.sum / f64::from(p.good)).as_vec3() } else { Vec3::ZERO }).collect();
    let nan_samples = sums.iter().map(|p| u64::from(p.bad)).sum();
    let stats = Stats { spp: taken, rays: rays.into_inner(), nan_samples, elapsed: start.elapsed() };
    (Image { width: w, height: h, pixels }, stats)
}

/// Adds samples `range` of every pixel to `sums`, tile by tile in parallel.
fn render_pass(scene: &Scene, sums: &mut [PixelSum], range: std::ops::Range<u32>, rays: &AtomicU64, done: &AtomicU64, options: &RenderOptions) {
    let (w, h) = (scene.settings.width, scene.settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let per_pixel = u64::from(range.end - range.start);
    let tiles: Vec<(u32, Vec<PixelSum>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let mut stats = TraceStats::default();
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    out.push(render_samples(scene, x, y, range.clone(), &mut stats));
                }
            }
            rays.fetch_add(stats.rays, Ordering::Relaxed);
            let n = u64::from((x1 - x0) * (y1 - y0)) * per_pixel;
            let total = done.fetch_add(n, Ordering::Relaxed) + n;
            if let Some(p) = options.progress {
                p(total);
            }
            (tile, out)
        })
        .collect();
    for (tile, out) in tiles {
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let x1 = (x0 + TILE).min(w);
        for (i, add) in out.into_iter().enumerate() {
            let (dx, dy) = (i as u32 % (x1 - x0), i as u32 / (x1 - x0));
            let p = &mut sums[((y0 + dy) * w + x0 + dx) as usize];
            p.sum += add.sum;
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
            acc.sum += l.as_dvec3();
            acc.good += 1;
        } else {
            acc.bad += 1;
        }
    }
    acc
}

