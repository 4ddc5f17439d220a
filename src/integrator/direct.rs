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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::test_lcg;

    /// In the Cornell box shadow rays are tested against the two boxes alone (24 of the 36
    /// triangles, `Geometry::limit_shadow_casters`), and every light sample's shadow ray is
    /// blocked or clear exactly as when tested against every triangle: from points all over
    /// the box, the light's own surface among them.
    #[test]
    fn leaving_walls_and_light_out_of_shadow_tests_changes_no_answer() {
        let scene = crate::load::test_cornell();
        assert_eq!(scene.geometry.shadow_caster_count(), Some(24));
        let mut state = 5;
        let mut r = || test_lcg(&mut state);
        let (mut blocked, mut clear, mut on_light) = (0, 0, 0);
        for _ in 0..40_000 {
            let o = Vec3::new(1.8 * r() - 0.9, 1.8 * r() - 0.9, 1.8 * r() - 0.9);
            let d = Vec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0);
            let Some(hit) = scene.intersect(&Ray::new(o, d), 0.0, f32::INFINITY) else {
                continue;
            };
            if (hit.p.y - 0.99).abs() < 1e-5 && hit.p.x.abs() < 0.23 {
                on_light += 1;
            }
            for light in &scene.lights {
                let u = Vec2::new(r(), r());
                let Some(incident) = sample_light(&scene, light, &hit, u, Strategy::Mis) else {
                    continue;
                };
                let (ray, t_max) = (&incident.shadow_ray, incident.t_max);
                let every_triangle = scene.occluded(ray, 0.0, t_max);
                assert_eq!(
                    scene.shadowed(ray, t_max),
                    every_triangle,
                    "{hit:?} {ray:?}"
                );
                if every_triangle {
                    blocked += 1;
                } else {
                    clear += 1;
                }
            }
        }
        assert!(
            blocked > 1_000 && clear > 10_000 && on_light > 100,
            "{blocked} {clear} {on_light}"
        );
    }
}
