//! Direct lighting: one light sample as every integrator uses it. Each light kind samples
//! itself ([`Light::sample`], [`Light::sample_mis`]) and says what its samples are (emitted by a
//! surface whose material gives the radiance, or carrying their own; at a point or at
//! infinity); this module turns a sample into the incident radiance at a shading point and the
//! shadow ray that decides whether it arrives, so the path tracer and the ray-cast preview
//! treat every light kind alike, and a new kind needs no case here.

use crate::geometry::SurfaceHit;
use crate::integrator::{segment_to, spawn};
use crate::light::{Light, LightSample};
use crate::math::{Ray, Vec2, Vec3};
use crate::scene::Scene;

/// A light sample seen from a shading point.
#[derive(Debug, Clone, Copy)]
pub struct Incident {
    /// The sample, its radiance `li` filled in: the emitting surface's for area lights.
    pub sample: LightSample,
    /// The shadow ray from the shading point towards the sample.
    pub shadow_ray: Ray,
    /// The segment the shadow ray tests: (0, `t_max`).
    pub t_max: f32,
}

/// How the light's point is drawn: as for MIS with BSDF sampling (the environment then
/// samples its compensated distribution), or alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Combined with BSDF sampling by multiple importance sampling.
    Mis,
    /// Light sampling alone.
    Alone,
}

/// Samples `light` from `hit` with the 2D point `u`: the incident radiance and its shadow ray,
/// or `None` when the light sends nothing towards `hit` (behind a one-sided emitter, outside a
/// spot's cone, a sample of zero radiance).
pub fn sample_light(
    scene: &Scene,
    light: &Light,
    hit: &SurfaceHit,
    u: Vec2,
    strategy: Strategy,
) -> Option<Incident> {
    let mut sample = match strategy {
        Strategy::Mis => light.sample_mis(hit.p, u)?,
        Strategy::Alone => light.sample(hit.p, u)?,
    };
    if light.surface_instance().is_some() {
        sample.li = scene.material_of_light(light).map_or(Vec3::ZERO, |m| {
            m.emitted(
                &scene.textures,
                sample.normal,
                sample.uv,
                sample.uv,
                -sample.wi,
            )
        });
    }
    if sample.li == Vec3::ZERO {
        return None;
    }
    let (shadow_ray, t_max) = if light.at_infinity() {
        (spawn(hit, sample.wi), f32::INFINITY)
    } else {
        (segment_to(hit, sample.point, sample.normal), 1.0)
    };
    Some(Incident {
        sample,
        shadow_ray,
        t_max,
    })
}
