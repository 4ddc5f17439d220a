//! Unidirectional path tracing with next-event estimation, combined with BSDF sampling by
//! multiple importance sampling (Veach and Guibas 1995, power heuristic), and Russian roulette.
//!
//! Depth is counted as in Mitsuba 3: the camera ray's hit is vertex 1, emission seen there is a
//! path of depth 1, light sampled from it a path of depth 2, and so on up to `max_depth`.

use crate::aov::AovSample;
use crate::bsdf::Bsdf;
use crate::geometry::SurfaceHit;
use crate::integrator::direct::{sample_light, Strategy};
use crate::integrator::{spawn, TraceStats};
use crate::material::Material;
use crate::math::{Ray, Rgb, Vec3};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::Scene;

/// Depth from which Russian roulette may end paths (as in Mitsuba 3).
pub const RR_DEPTH: u32 = 5;

/// A path being traced: what its next vertex needs from the vertices before it. The render loop
/// ([`crate::render`]) runs paths in waves of lanes, one step per vertex: it traces the closest
/// hits of every lane's [`ray`](Path::ray), lets each lane [`shade`](Path::shade) its hit up to
/// the light sample, traces the lanes' shadow rays, and lets each lane
/// [`scatter`](Path::scatter) into its next ray. Every lane's numbers are its own (its sampler,
/// its state), so a sample's value does not depend on which lane, or with which others, it ran.
#[derive(Debug, Clone)]
pub struct Path {
    /// The ray to the next vertex.
    pub ray: Ray,
    /// The next vertex's depth (the camera ray's hit is 1).
    depth: u32,
    /// Radiance gathered so far.
    l: Rgb,
    /// Throughput.
    beta: Rgb,
    /// The previous scattering event, for MIS on emitters hit by BSDF sampling.
    prev_pdf: f32,
    prev_delta: bool,
    prev_p: Vec3,
    /// Its shading normal, which light selection saw there.
    prev_n: Vec3,
    /// Absorption coefficient of the medium the path is in (inside a `volume` material).
    medium: Option<Vec3>,
    /// The product of η′² over the refractions so far: each scaled the throughput by 1/η′²
    /// (radiance is compressed into the denser medium), which Russian roulette must not read as
    /// lost energy (pbrt-v4's `etaScale`, Mitsuba 3's `eta`).
    eta_scale: f32,
    /// Whether the light this vertex finds by BSDF sampling (emission, the environment, an
    /// unlit surface) counts: not where the previous vertex collected that light with rays of
    /// its own (its `SPLIT` samples, or the mirror reflection of glass), the path's ray then
    /// only carrying on for the light from further surfaces.
    count_found: bool,
    /// What the sample sees for the render passes, when they are asked for ([`crate::aov`]).
    pub aov: Option<Box<AovSample>>,
}

/// A vertex between its light sample and its BSDF sample: what [`Path::shade`] leaves for
/// [`Path::scatter`] while the shadow ray is traced.
pub struct Vertex<'a> {
    material: &'a Material,
    bsdf: Bsdf,
    wo: Vec3,
    /// BSDF samples drawn for direct light here (see [`SPLIT`]), or 1.
    split: f32,
    /// The light sample's shadow ray, if it can add anything.
    pub shadow: Option<Shadow>,
}

/// A shadow ray and the radiance its light sample adds when nothing blocks it.
#[derive(Debug, Clone, Copy)]
pub struct Shadow {
    /// From the vertex towards the light.
    pub ray: Ray,
    /// The segment to test: (0, `t_max`) along `ray`.
    pub t_max: f32,
    /// Throughput × BSDF × light × MIS weight ÷ pdf.
    radiance: Rgb,
}

impl Path {
    /// A path leaving the camera along `ray`.
    pub fn new(ray: Ray) -> Path {
        Path {
            prev_p: ray.o,
            ray,
            depth: 1,
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            prev_pdf: 0.0,
            prev_delta: true,
            prev_n: Vec3::ZERO,
            medium: None,
            eta_scale: 1.0,
            count_found: true,
            aov: None,
        }
    }

    /// The radiance the path has gathered: the sample's value once it has ended.
    pub fn radiance(&self) -> Rgb {
        self.l
    }

    /// The vertex where [`ray`](Path::ray) hits (`hit`, its closest hit): the light found
    /// there by BSDF sampling, and the light sample of next-event estimation (with the 2D point
    /// `u_light`, the vertex's first sampler dimension, which the caller draws for every lane
    /// at once, used or not), whose shadow ray the caller traces before
    /// [`scatter`](Path::scatter). The vertex is left in `vertex` (written in place: it is a few
    /// hundred bytes); returns whether the path goes on, which it does not when it left the
    /// scene or met an unlit surface or its last vertex.
    pub fn shade<'a>(
        &mut self,
        scene: &'a Scene,
        hit: Option<&SurfaceHit>,
        u_light: glam::Vec2,
        vertex: &mut Option<Vertex<'a>>,
    ) -> bool {
        let depth = self.depth;
        let Some(hit) = hit else {
            if self.count_found {
                let bsdf_pdf = (!self.prev_delta).then_some(self.prev_pdf);
                self.l += self.beta
                    * scene.escaped(
                        self.ray.d.normalize(),
                        bsdf_pdf,
                        (self.prev_p, self.prev_n),
                        depth == 1,
                    );
            }
            if let Some(aov) = &mut self.aov {
                let d = self.ray.d.normalize();
                let env = scene.escaped(d, None, (self.prev_p, self.prev_n), depth == 1);
                aov.escaped(self.beta, env);
            }
            return false;
        };
        if let (Some(aov), 1) = (&mut self.aov, depth) {
            aov.camera_hit(scene, hit, &self.ray);
        }
        if let Some(sigma) = self.medium {
            // Beer–Lambert along the segment travelled inside.
            self.beta *= transmittance(sigma, hit.t * self.ray.d.length());
        }
        let wo = -self.ray.d.normalize();
        let material = scene.material(hit);
        let direct = found_light(
            scene,
            material,
            hit,
            wo,
            self.prev_p,
            self.prev_n,
            (!self.prev_delta).then_some(self.prev_pdf),
        );
        if self.count_found && direct.weight > 0.0 {
            self.l += self.beta * direct.radiance * direct.weight;
        }
        if let (Some(aov), true) = (&mut self.aov, direct.unlit) {
            aov.unlit(self.beta, direct.radiance, hit.ns);
        }
        if direct.unlit || depth == scene.settings.max_depth {
            return false;
        }
        let bsdf = material.bsdf(&scene.textures, hit, wo);
        // Glossy-dominated surfaces seen from the camera estimate the direct light that BSDF
        // sampling finds with `SPLIT` samples of their own (multi-sample MIS, Veach 1997 §9.2:
        // the weights compare SPLIT × the BSDF pdf with the light's).
        let split = if depth == 1 && bsdf.is_glossy_dominated() {
            SPLIT
        } else {
            1.0
        };
        // Next-event estimation only where a lobe is not a Dirac delta (a vertex that only
        // scatters by delta lobes leaves its point unused).
        let shadow = if bsdf.has_smooth_lobe() {
            if let Some(aov) = &mut self.aov {
                aov.smooth_vertex(bsdf.frame.n);
            }
            self.light_sample(scene, hit, &bsdf, wo, split, u_light)
        } else {
            None
        };
        *vertex = Some(Vertex {
            material,
            bsdf,
            wo,
            split,
            shadow,
        });
        true
    }

    /// Next-event estimation at `hit`: one light, chosen (by power or by the light tree, for
    /// this point and normal) with the first coordinate of `u_light`, which is then remapped to
    /// sample a point on it. The shadow ray to that point, if the sample can add anything.
    fn light_sample(
        &self,
        scene: &Scene,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        wo: Vec3,
        split: f32,
        u_light: glam::Vec2,
    ) -> Option<Shadow> {
        let (index, pmf, u_x) = scene.light_sampler.pick(hit.p, hit.ns, u_light.x)?;
        let light = &scene.lights[index];
        let u = glam::Vec2::new(u_x, u_light.y);
        let incident = sample_light(scene, light, hit, u, Strategy::Mis)?;
        let ls = incident.sample;
        let (f, pdf_bsdf) = bsdf.eval(wo, ls.wi);
        if f == Vec3::ZERO {
            return None;
        }
        let pdf_light = pmf * ls.pdf;
        let weight = if ls.delta {
            1.0
        } else {
            power_heuristic(pdf_light, split * pdf_bsdf)
        };
        let tr = self
            .medium
            .map_or(Vec3::ONE, |sigma| transmittance(sigma, ls.distance));
        Some(Shadow {
            ray: incident.shadow_ray,
            t_max: incident.t_max,
            radiance: self.beta * f * ls.li * tr * (weight / pdf_light),
        })
    }

    /// Finishes `vertex` (at `hit`): adds its light sample when `unblocked` (what its shadow
    /// ray found), and samples the BSDF for the path's next ray with the lobe choice and 2D
    /// point `(u_lobe, u_dir)` (the vertex's next sampler dimensions, drawn by the caller for
    /// every lane at once); further numbers (the split samples', Russian roulette's) come from
    /// `sampler`. Returns whether the path goes on.
    #[allow(clippy::too_many_arguments)]
    pub fn scatter(
        &mut self,
        scene: &Scene,
        hit: &SurfaceHit,
        vertex: &Vertex,
        unblocked: bool,
        (u_lobe, u_dir): (f32, glam::Vec2),
        sampler: &mut Sampler,
        stats: &mut TraceStats,
    ) -> bool {
        let &Vertex {
            material,
            ref bsdf,
            wo,
            split,
            shadow,
        } = vertex;
        if let (Some(shadow), true) = (shadow, unblocked) {
            self.l += shadow.radiance;
        }
        let medium = self.medium;
        // Continue the path by sampling the BSDF.
        let sampled = bsdf.sample(wo, u_lobe, u_dir);
        if let Some(aov) = &mut self.aov {
            aov.scattered(self.beta, sampled.map(|s| s.weight));
        }
        if split > 1.0 {
            // Drawn together, so that over a pixel's samples they are one stratified set; each
            // counts 1/SPLIT, whether or not the others succeed. The path goes on with its own
            // sample, whose found light the next vertex leaves to these.
            let mut points = [(0.0f32, glam::Vec2::ZERO); SPLIT as usize];
            sampler.get_choice_2d_padded(&mut points);
            for &(u_lobe, u_dir) in &points {
                if let Some(s2) = bsdf.sample(wo, u_lobe, u_dir) {
                    let pdf = (!s2.delta).then_some(split * s2.pdf);
                    let found = light_along(scene, hit, s2.wi, pdf, medium, stats);
                    self.l += self.beta * s2.weight * found / split;
                }
            }
        }
        // Smooth glass near the camera: its mirror reflection, chosen with probability R (a few
        // per cent), is where it shows the environment's brightest spots, so the light along it
        // is collected by a ray of its own every time, with the whole weight R; the path, when
        // it reflects, then counts none of the light it finds there (it still goes on for the
        // light reflected from further surfaces).
        let mirror = if self.depth <= MIRROR_SPLIT_DEPTH {
            bsdf.mirror_reflection(wo)
        } else {
            None
        };
        if let Some((wi, weight)) = mirror {
            self.l += self.beta * weight * light_along(scene, hit, wi, None, medium, stats);
        }
        let Some(s) = sampled else {
            return false;
        };
        self.beta *= s.weight;
        if s.transmitted {
            self.eta_scale *= s.etap * s.etap;
            if let Some(sigma) = material.absorption {
                // Entering the solid (towards the back of the surface) or leaving it.
                self.medium = (s.wi.dot(hit.ng) < 0.0).then_some(sigma);
            }
        }
        self.prev_pdf = s.pdf;
        self.prev_delta = s.delta;
        self.count_found = split == 1.0 && !(mirror.is_some() && s.delta && !s.transmitted);
        self.prev_p = hit.p;
        self.prev_n = hit.ns;
        self.ray = spawn(hit, s.wi);
        if self.depth >= RR_DEPTH {
            // Survival in proportion to the throughput without the refractions' 1/η′²: a
            // path inside glass carries 1/1.5² of the radiance it will have again outside, and
            // with the bare throughput 56 % of those paths were ended at each depth from
            // `RR_DEPTH` on (GlassVaseFlowers, depth 8: 1.19-1.23× the variance per sample). Paths
            // that keep their throughput always survive (pbrt-v4; Mitsuba 3 caps q at 0.95,
            // which it needs for unbounded depths, but `max_depth` bounds every path here, and
            // the cap cost GlassVaseFlowers' specular chains another 1.07-1.11× the variance). Any
            // q > 0 is unbiased.
            let q = (self.beta * self.eta_scale).max_element().min(1.0);
            if sampler.get_1d() >= q {
                return false;
            }
            self.beta /= q;
        }
        self.depth += 1;
        self.beta != Vec3::ZERO
    }
}

/// BSDF samples drawn for direct light at a glossy-dominated surface seen from the camera (see
/// `radiance`; a power of two, for the padded draw): there the error of glTF assets under an
/// HDR environment is almost all direct light found by BSDF sampling (DamagedHelmet: 80 % of
/// the variance per sample). Each costs a ray and an environment lookup. On DamagedHelmet (160²,
/// 64 spp, 16 seeds, 1 thread) MSE × time was 0.0290 with the path's own sample and 3 more
/// drawn independently; with 4, 8 (kept) or 2 padded samples besides the path's, 0.0261, 0.0248
/// and 0.0333.
const SPLIT: f32 = 8.0;

/// The depths up to which smooth glass collects the light of its mirror direction with a ray of
/// its own (see `radiance`).
const MIRROR_SPLIT_DEPTH: u32 = 1;

/// The light a ray leaving `hit` in direction `wi` finds (emission, the environment or an
/// unlit surface: see [`found_light`]), its MIS weight against light sampling for a direction
/// sampled with density `bsdf_pdf` (`None` for delta lobes) applied, attenuated by the medium
/// the ray travels in.
fn light_along(
    scene: &Scene,
    hit: &crate::geometry::SurfaceHit,
    wi: Vec3,
    bsdf_pdf: Option<f32>,
    medium: Option<Vec3>,
    stats: &mut TraceStats,
) -> Vec3 {
    stats.rays += 1;
    let ray = spawn(hit, wi);
    match scene.intersect(&ray, 0.0, f32::INFINITY) {
        None => scene.escaped(ray.d.normalize(), bsdf_pdf, (hit.p, hit.ns), false),
        Some(hit2) => {
            let tr = medium.map_or(Vec3::ONE, |sigma| {
                transmittance(sigma, hit2.t * ray.d.length())
            });
            let material = scene.material(&hit2);
            let f = found_light(
                scene,
                material,
                &hit2,
                -ray.d.normalize(),
                hit.p,
                hit.ns,
                bsdf_pdf,
            );
            tr * f.radiance * f.weight
        }
    }
}

/// The light a BSDF-sampled ray finds where it hits: see [`found_light`].
struct Found {
    /// Emitted radiance, or the unlit colour.
    radiance: Rgb,
    /// Its MIS weight (1 for an unlit colour).
    weight: f32,
    /// The surface is unlit: it scatters nothing.
    unlit: bool,
}

/// What a ray that hit `hit` (on `material`, travelling towards −`wo`) from a vertex at
/// `from_p` with shading normal `from_n` finds there by BSDF sampling: the surface's emission
/// with the MIS weight against light sampling (`bsdf_pdf`: the pdf, × the number of BSDF
/// samples, with which the vertex drew the direction; `None` for a delta lobe), or an unlit
/// surface's colour.
fn found_light(
    scene: &Scene,
    material: &crate::material::Material,
    hit: &crate::geometry::SurfaceHit,
    wo: Vec3,
    from_p: Vec3,
    from_n: Vec3,
    bsdf_pdf: Option<f32>,
) -> Found {
    if let Some(c) = material.unlit_radiance(&scene.textures, hit) {
        // Unlit: the colour as seen, nothing scattered.
        return Found {
            radiance: c,
            weight: 1.0,
            unlit: true,
        };
    }
    let le = material.emitted(&scene.textures, hit.ng, hit.uv, hit.uv1, wo);
    if le == Vec3::ZERO {
        return Found {
            radiance: Vec3::ZERO,
            weight: 0.0,
            unlit: false,
        };
    }
    let weight = match (scene.light_of(hit), bsdf_pdf) {
        (Some(li), Some(pdf)) => {
            let pdf_light = scene.light_sampler.pmf(from_p, from_n, li)
                * scene.lights[li].pdf(from_p, hit.p, hit.ng);
            power_heuristic(pdf, pdf_light)
        }
        _ => 1.0,
    };
    Found {
        radiance: le,
        weight,
        unlit: false,
    }
}

/// exp(−σ·d) per channel: the fraction of light that crosses a distance `d` of a medium with
/// absorption coefficient `sigma` (1 for a clear medium, without evaluating exp).
fn transmittance(sigma: Vec3, d: f32) -> Rgb {
    if sigma == Vec3::ZERO {
        return Vec3::ONE;
    }
    (-sigma * d).to_array().map(crate::lanes::math::exp).into()
}
