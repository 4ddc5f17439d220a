//! Light-transport algorithms: radiance arriving along a camera ray.

pub mod path;
pub mod raycast;

use crate::geometry::SurfaceHit;
use crate::math::{offset_origin, Ray, Vec3};
use crate::sampler::Sampler;
use crate::scene::{IntegratorKind, Scene};

/// Counters gathered while tracing.
#[derive(Debug, Clone, Copy, Default)]
pub struct TraceStats {
    /// Rays cast (camera, bounce and shadow rays).
    pub rays: u64,
}

/// Radiance along `ray` with the scene's chosen integrator.
pub fn radiance(scene: &Scene, ray: Ray, sampler: &mut Sampler, stats: &mut TraceStats) -> Vec3 {
    match scene.settings.integrator {
        IntegratorKind::Path => path::radiance(scene, ray, sampler, stats),
        IntegratorKind::Raycast => raycast::radiance(scene, ray, sampler, stats),
    }
}

/// A ray leaving a surface point in direction `w`, offset to avoid hitting the surface again.
#[inline]
pub(crate) fn spawn(hit: &SurfaceHit, w: Vec3) -> Ray {
    Ray::new(offset_origin(hit.p, hit.ng, w), w)
}

/// Whether the segment from a surface point to `target` is unblocked. The far end is offset
/// too when it lies on a surface (normal `target_n` non-zero).
#[inline]
pub(crate) fn visible(
    scene: &Scene,
    hit: &SurfaceHit,
    target: Vec3,
    target_n: Vec3,
    stats: &mut TraceStats,
) -> bool {
    stats.rays += 1;
    let dir = target - hit.p;
    let o = offset_origin(hit.p, hit.ng, dir);
    let end = if target_n == Vec3::ZERO {
        target
    } else {
        offset_origin(target, target_n, -dir)
    };
    !scene.occluded(&Ray::new(o, end - o), 0.0, 1.0)
}

/// Whether a ray towards a directional light escapes the scene.
#[inline]
pub(crate) fn unoccluded_towards(
    scene: &Scene,
    hit: &SurfaceHit,
    w: Vec3,
    stats: &mut TraceStats,
) -> bool {
    stats.rays += 1;
    !scene.occluded(&spawn(hit, w), 0.0, f32::INFINITY)
}
