//! The samples of one pixel: camera rays traced by the integrator.

use std::ops::Range;

use super::film::PixelSum;
use crate::integrator::{radiance, TraceStats};
use crate::math::Vec2;
use crate::sampler::Sampler;
use crate::scene::Scene;

/// The sums of pixel (x, y)'s samples with indices `indices`: for each, a camera ray through a
/// jittered point of the pixel, traced by the scene's integrator.
pub(super) fn render_samples(
    scene: &Scene,
    x: u32,
    y: u32,
    indices: Range<u32>,
    stats: &mut TraceStats,
) -> PixelSum {
    let s = &scene.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let mut sums = PixelSum::default();
    for i in indices {
        let mut sampler = Sampler::with_kind(s.sampler, s.seed, pixel, u64::from(i));
        let jitter = sampler.get_2d();
        let film = Vec2::new(
            (x as f32 + jitter.x) / s.width as f32,
            (y as f32 + jitter.y) / s.height as f32,
        );
        let u_lens = if scene.camera.lens_radius > 0.0 {
            sampler.get_2d()
        } else {
            sampler.skip_2d();
            Vec2::ZERO
        };
        let ray = scene.camera.ray(film, u_lens);
        sums.add_sample(radiance(scene, ray, &mut sampler, stats));
    }
    sums
}
