//! Fast preview: primary rays; at each hit, emission plus direct light from every punctual light
//! and one sample of the area lights (no MIS); mirror and dielectric lobes followed up to
//! `max_depth` (the course framework's ray-casting mode, made physically consistent).

use crate::bsdf::Bsdf;
use crate::integrator::{spawn, unoccluded_towards, visible, TraceStats};
use crate::light::Light;
use crate::math::{Ray, Rgb, Vec3};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// Radiance along a camera ray.
pub fn radiance(scene: &Scene, mut ray: Ray, sampler: &mut Sampler, stats: &mut TraceStats) -> Rgb {
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    for depth in 1..=scene.settings.max_depth.max(1) {
        stats.rays += 1;
        let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
            // Only camera rays and delta chains escape here; the environment's direct light is
            // `direct`'s.
            l += beta * scene.escaped(ray.d.normalize(), None, (ray.o, Vec3::ZERO), depth == 1);
            break;
        };
        let wo = -ray.d.normalize();
        let material = scene.material(&hit);
        if let Some(c) = material.unlit_radiance(&scene.textures, &hit) {
            l += beta * c;
            break;
        }
        l += beta * material.emitted(&scene.textures, hit.ng, hit.uv, hit.uv1, wo);
        let bsdf = material.bsdf(&scene.textures, &hit, wo);
        if bsdf.has_smooth_lobe() {
            l += beta * direct(scene, &bsdf, &hit, wo, sampler, stats);
        }
        // Follow only the delta lobes (mirror, smooth glass): a BSDF sample that lands on a
        // smooth lobe ends the path, its light already counted by `direct`; a delta sample's
        // weight carries its lobe's selection probability, so the delta part stays unbiased.
        let Some(s) = bsdf.sample(wo, sampler.get_1d(), sampler.get_2d()) else {
            break;
        };
        if !s.delta {
            break;
        }
        beta *= s.weight;
        ray = spawn(&hit, s.wi);
    }
    l
}

fn direct(
    scene: &Scene,
    bsdf: &Bsdf,
    hit: &crate::geometry::SurfaceHit,
    wo: Vec3,
    sampler: &mut Sampler,
    stats: &mut TraceStats,
) -> Rgb {
    let mut l = Vec3::ZERO;
    let u = sampler.get_2d();
    let u_area = sampler.get_1d();
    for light in &scene.lights {
        let is_area = matches!(light, Light::Triangle { .. } | Light::Sphere { .. });
        if is_area {
            continue;
        }
        if let Some(ls) = light.sample(hit.p, u) {
            let (f, _) = bsdf.eval(wo, ls.wi);
            if f == Vec3::ZERO {
                continue;
            }
            let ok = match light {
                Light::Directional { .. } | Light::Environment { .. } => {
                    unoccluded_towards(scene, hit, ls.wi, stats)
                }
                _ => visible(scene, hit, ls.point, Vec3::ZERO, stats),
            };
            if ok {
                // Delta lights give their contribution; the environment one sample of it.
                l += f * ls.li / if ls.delta { 1.0 } else { ls.pdf };
            }
        }
    }
    // One area-light sample, chosen by the light sampler among all lights; punctual picks are skipped since
    // they were summed above.
    if let Some((index, pmf, _)) = scene.light_sampler.pick(hit.p, hit.ns, u_area) {
        let light = &scene.lights[index];
        if matches!(light, Light::Triangle { .. } | Light::Sphere { .. }) {
            if let Some(ls) = light.sample(hit.p, u) {
                let li = scene.material_of_light(light).map_or(Vec3::ZERO, |m| {
                    m.emitted(&scene.textures, ls.normal, ls.uv, ls.uv, -ls.wi)
                });
                let (f, _) = bsdf.eval(wo, ls.wi);
                if li != Vec3::ZERO
                    && f != Vec3::ZERO
                    && visible(scene, hit, ls.point, ls.normal, stats)
                {
                    l += f * li / (pmf * ls.pdf);
                }
            }
        }
    }
    l
}
