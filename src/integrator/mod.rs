//! Light-transport algorithms: radiance arriving along a camera ray. The path tracer runs in
//! steps, one vertex at a time, for the render loop's waves of lanes ([`path::Path`]); the
//! ray-cast preview takes a whole sample at once ([`raycast::radiance`]).

pub mod direct;
pub mod path;
pub mod raycast;

use crate::geometry::SurfaceHit;
use crate::math::{offset_origin, Ray, Vec3};

/// Counters gathered while tracing.
#[derive(Debug, Clone, Copy, Default)]
pub struct TraceStats {
    /// Rays cast (camera, bounce and shadow rays).
    pub rays: u64,
}

/// A ray leaving a surface point in direction `w`, offset to avoid hitting the surface again.
#[inline]
pub(crate) fn spawn(hit: &SurfaceHit, w: Vec3) -> Ray {
    Ray::new(offset_origin(hit.p, hit.ng, w), w)
}

/// The ray from a surface point to `target` whose parameters (0, 1) span the segment between
/// them, both ends offset off their surfaces (the far end only when it lies on one: normal
/// `target_n` non-zero).
#[inline]
pub(crate) fn segment_to(hit: &SurfaceHit, target: Vec3, target_n: Vec3) -> Ray {
    let dir = target - hit.p;
    let o = offset_origin(hit.p, hit.ng, dir);
    let end = if target_n == Vec3::ZERO {
        target
    } else {
        offset_origin(target, target_n, -dir)
    };
    Ray::new(o, end - o)
}
