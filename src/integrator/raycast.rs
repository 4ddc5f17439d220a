//! Fast preview: primary rays; at each hit, emission plus direct light from every punctual light
//! and one sample of the area lights (no MIS); mirror and dielectric lobes followed up to
//! `max_depth` (the course framework's ray-casting mode, made physically consistent).

use crate::bsdf::Bsdf;
use crate::integrator::direct::{sample_light, Strategy};
use crate::integrator::{spawn, TraceStats};
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

/// Direct light at `hit`: every light without a surface (punctual lights, the environment)
/// sampled once, and one light with a surface chosen by the light sampler (punctual picks are
/// skipped, since they were summed already). No MIS: the preview follows delta lobes only.
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
    let mut add = |light: &Light, pmf: f32, l: &mut Rgb| {
        let Some(incident) = sample_light(scene, light, hit, u, Strategy::Alone) else {
            return;
        };
        let ls = incident.sample;
        let (f, _) = bsdf.eval(wo, ls.wi);
        if f == Vec3::ZERO {
            return;
        }
        stats.rays += 1;
        if !scene.shadowed(&incident.shadow_ray, incident.t_max) {
            // Delta lights give their contribution; the others one sample of it.
            *l += f * ls.li / if ls.delta { pmf } else { pmf * ls.pdf };
        }
    };
    for light in scene
        .lights
        .iter()
        .filter(|l| l.surface_instance().is_none())
    {
        add(light, 1.0, &mut l);
    }
    if let Some((index, pmf, _)) = scene.light_sampler.pick(hit.p, hit.ns, u_area) {
        let light = &scene.lights[index];
        if light.surface_instance().is_some() {
            add(light, pmf, &mut l);
        }
    }
    l
}
