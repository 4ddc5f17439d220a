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

/// Renders the scene with its settings.
pub fn render(scene: &Scene, options: &RenderOptions) -> (Image, Stats) {
    let start = Instant::now();
    let s = &scene.settings;
    let (w, h) = (s.width, s.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let rays = AtomicU64::new(0);
    let nans = AtomicU64::new(0);
    let done = AtomicU64::new(0);
    let tiles: Vec<(u32, Vec<Rgb>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            let (tx, ty) = (tile % tiles_x, tile / tiles_x);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            let mut stats = TraceStats::default();
            let mut tile_nans = 0;
            for y in y0..y1 {
                for x in x0..x1 {
                    let (c, bad) = render_pixel(scene, x, y, &mut stats);
                    tile_nans += bad;
                    out.push(c);
                }
            }
            rays.fetch_add(stats.rays, Ordering::Relaxed);
            nans.fetch_add(tile_nans, Ordering::Relaxed);
            let n = done.fetch_add(u64::from((x1 - x0) * (y1 - y0)) * u64::from(s.spp), Ordering::Relaxed);
            if let Some(p) = options.progress {
                p(n + u64::from((x1 - x0) * (y1 - y0)) * u64::from(s.spp));
            }
            (tile, out)
        })
        .collect();
    let mut pixels = vec![Vec3::ZERO; (w * h) as usize];
    for (tile, out) in tiles {
        let (tx, ty) = (tile % tiles_x, tile / tiles_x);
        let (x0, y0) = (tx * TILE, ty * TILE);
        let x1 = (x0 + TILE).min(w);
        for (i, c) in out.into_iter().enumerate() {
            let (dx, dy) = (i as u32 % (x1 - x0), i as u32 / (x1 - x0));
            pixels[((y0 + dy) * w + x0 + dx) as usize] = c;
        }
    }
    let stats = Stats { spp: s.spp, rays: rays.into_inner(), nan_samples: nans.into_inner(), elapsed: start.elapsed() };
    (Image { width: w, height: h, pixels }, stats)
}

/// The mean of a pixel's samples (box filter: each sample uniformly jittered in the pixel), and
/// the number of samples dropped for being NaN or infinite.
pub fn render_pixel(scene: &Scene, x: u32, y: u32, stats: &mut TraceStats) -> (Rgb, u64) {
    let s = &scene.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let mut sum = glam::DVec3::ZERO;
    let mut good = 0u32;
    let mut bad = 0u64;
    for i in 0..s.spp {
        let mut sampler = Sampler::with_kind(s.sampler, s.seed, pixel, u64::from(i));
        let jitter = sampler.get_2d();
        let film = Vec2::new((x as f32 + jitter.x) / s.width as f32, (y as f32 + jitter.y) / s.height as f32);
        let ray = scene.camera.ray(film, sampler.get_2d());
        let l = radiance(scene, ray, &mut sampler, stats);
        if l.is_finite() {
            sum += l.as_dvec3();
            good += 1;
        } else {
            bad += 1;
        }
    }
    let c = if good > 0 { (sum / f64::from(good)).as_vec3() } else { Vec3::ZERO };
    (c, bad)
}
