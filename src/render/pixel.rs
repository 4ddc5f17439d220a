//! The samples of one pixel: camera rays traced by the integrator.

use std::ops::Range;

use super::film::PixelSum;
use crate::integrator::{radiance, TraceStats};
use crate::math::Vec2;
use crate::sampler::Sampler;
use crate::scene::Scene;

pub(super) fn render_samples(
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
