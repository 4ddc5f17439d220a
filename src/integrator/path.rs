//! Unidirectional path tracing with next-event estimation, combined with BSDF sampling by
//! multiple importance sampling (Veach and Guibas 1995, power heuristic), and Russian roulette.
//!
//! Depth is counted as in Mitsuba 3: the camera ray's hit is vertex 1, emission seen there is a
//! path of depth 1, light sampled from it a path of depth 2, and so on up to `max_depth`.

use std::f32::consts::FRAC_1_PI;

use crate::aov::AovSample;
use crate::bsdf::{Bsdf, BsdfSample, LambertLanes, Lobes};
use crate::geometry::mesh::SurfacesOut;
use crate::geometry::{LaneSurfaces, SegmentLanes, SurfaceHit};
use crate::integrator::direct::{sample_light, Strategy};
use crate::integrator::{spawn, TraceStats};
use crate::lanes::{F32s, Mask, V3s};
use crate::light::{Light, TriangleLanes};
use crate::light_sampler::PowerSampler;
use crate::material::Material;
use crate::math::{offset_origin_lanes, Ray, Rgb, Vec3};
use crate::sampler::{Sampler, SamplerLanes};
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
    /// Whether next-event estimation samples a light here (some lobe is not a Dirac delta).
    needs_light: bool,
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
    pub radiance: Rgb,
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

    /// What a light sample at the next vertex reads of the path: its throughput and the
    /// medium it travels in.
    #[inline]
    fn seen(&self) -> (Rgb, Option<Vec3>) {
        (self.beta, self.medium)
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
        let needs_light = bsdf.has_smooth_lobe();
        if let (Some(aov), true) = (&mut self.aov, needs_light) {
            aov.smooth_vertex(bsdf.frame.n);
        }
        *vertex = Some(Vertex {
            material,
            bsdf,
            wo,
            split,
            needs_light,
            shadow: None,
        });
        true
    }

    /// Next-event estimation at a wave's vertices (`vertices[i]`, made by lane `i`'s
    /// [`shade`](Path::shade) of `hits[i]`, when it needs a light sample): each lane picks a
    /// light with the first coordinate of its `u_light` (which is then remapped to sample a
    /// point on it) and leaves the shadow ray in its vertex. Lanes that sample a triangle light
    /// by area from a Lambertian surface, outside any medium (most of an interior's light
    /// samples), run in SIMD lanes when the wave is [`LANE_KERNELS_FROM`] lanes wide or more;
    /// the others one at a time. Both compute each lane's numbers with the same operations, so
    /// a lane's bits are the same whichever way it went and whatever the width.
    pub fn sample_lights<const W: usize>(
        scene: &Scene,
        paths: [Option<&Path>; W],
        hits: &[Option<SurfaceHit>; W],
        vertices: &mut [Option<Vertex>; W],
        u_light: &[glam::Vec2; W],
        scratch: &mut Scratch<W>,
    ) {
        let mut picked: [Option<Picked>; W] = [None; W];
        let mut in_lanes: [Option<LaneLight>; W] = [None; W];
        for i in 0..W {
            let (Some(path), Some(hit), Some(vertex)) = (paths[i], &hits[i], &mut vertices[i])
            else {
                continue;
            };
            if !vertex.needs_light {
                continue;
            }
            let Some((pick, light)) = Picked::choose(scene, hit, u_light[i]) else {
                continue;
            };
            picked[i] = Some(pick);
            let emission = if LANE_KERNELS_FROM <= W && path.medium.is_none() {
                kernel_emission(scene, light)
            } else {
                None
            };
            match (emission, &vertex.bsdf.lobes) {
                (Some(emission), &Lobes::Lambert(albedo)) => {
                    in_lanes[i] = Some(LaneLight {
                        light,
                        emission,
                        albedo,
                    })
                }
                _ => vertex.shadow = Path::light_sample(path.seen(), scene, hit, vertex, pick),
            }
        }
        if in_lanes.iter().all(Option::is_none) {
            return;
        }
        let input = &mut scratch.lights;
        input.gather(&paths, hits, vertices, &picked, &in_lanes);
        let out = input.run();
        for i in 0..W {
            let (Some(path), Some(hit), Some(vertex), Some(pick)) =
                (paths[i], &hits[i], &mut vertices[i], picked[i])
            else {
                continue;
            };
            if in_lanes[i].is_none() {
                continue;
            }
            vertex.shadow = match out.shadow(i) {
                Some(shadow) => shadow,
                None => Path::light_sample(path.seen(), scene, hit, vertex, pick),
            };
        }
    }

    /// Next-event estimation at `hit` (one lane of [`sample_lights`](Path::sample_lights),
    /// one at a time) with the light it picked. The shadow ray to the point sampled on the
    /// light, if the sample can add anything.
    fn light_sample(
        (beta, medium): (Rgb, Option<Vec3>),
        scene: &Scene,
        hit: &SurfaceHit,
        vertex: &Vertex,
        Picked { light, pmf, u }: Picked,
    ) -> Option<Shadow> {
        let &Vertex {
            ref bsdf,
            wo,
            split,
            ..
        } = vertex;
        let light = &scene.lights[light];
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
        let tr = medium.map_or(Vec3::ONE, |sigma| transmittance(sigma, ls.distance));
        Some(Shadow {
            ray: incident.shadow_ray,
            t_max: incident.t_max,
            radiance: beta * f * ls.li * tr * (weight / pdf_light),
        })
    }

    /// The BSDF samples of a wave's vertices (`None` where a lane has none, or its BSDF
    /// samples nothing), each with its lane's lobe choice and 2D point (lane i of `u`'s three:
    /// the vertex's next sampler dimensions, drawn for every lane at once): for
    /// [`scatter`](Path::scatter).
    /// Lambertian lanes are sampled in SIMD lanes (from [`LANE_KERNELS_FROM`] lanes on), the
    /// others one at a time; a lane's bits are the same either way.
    pub fn sample_bsdfs<const W: usize>(
        vertices: &[Option<Vertex>; W],
        (u_lobe, ux, uy): &(F32s<W>, F32s<W>, F32s<W>),
        scratch: &mut Scratch<W>,
    ) -> [Option<BsdfSample>; W] {
        let mut sampled = [None; W];
        let mut lambert = [None; W];
        for i in 0..W {
            let Some(vertex) = &vertices[i] else { continue };
            match vertex.bsdf.lobes {
                Lobes::Lambert(albedo) if LANE_KERNELS_FROM <= W => lambert[i] = Some(albedo),
                _ => {
                    let u = glam::Vec2::new(ux[i], uy[i]);
                    sampled[i] = vertex.bsdf.sample(vertex.wo, u_lobe[i], u);
                }
            }
        }
        if lambert.iter().all(Option::is_none) {
            return sampled;
        }
        let lanes = &mut scratch.lambert;
        for i in 0..W {
            let (Some(vertex), Some(_)) = (&vertices[i], lambert[i]) else {
                continue;
            };
            let frame = &vertex.bsdf.frame;
            lanes.s.set(i, frame.s);
            lanes.t.set(i, frame.t);
            lanes.n.set(i, frame.n);
            lanes.ng.set(i, vertex.bsdf.ng);
            lanes.wo.set(i, vertex.wo);
            (lanes.u.0[i], lanes.u.1[i]) = (ux[i], uy[i]);
        }
        let out = lanes.sample();
        for i in 0..W {
            if let Some(albedo) = lambert[i] {
                sampled[i] = out.lane(i, albedo);
            }
        }
        sampled
    }

    /// Finishes `vertex` (at `hit`): adds its light sample when `unblocked` (what its shadow
    /// ray found), and continues the path by `sampled`, its BSDF sample from
    /// [`sample_bsdfs`](Path::sample_bsdfs); further numbers (the split samples', Russian
    /// roulette's) come from `sampler`. Returns whether the path goes on.
    #[allow(clippy::too_many_arguments)]
    pub fn scatter(
        &mut self,
        scene: &Scene,
        hit: &SurfaceHit,
        vertex: &Vertex,
        unblocked: bool,
        sampled: Option<BsdfSample>,
        sampler: &mut Sampler,
        stats: &mut TraceStats,
    ) -> bool {
        let &Vertex {
            material,
            ref bsdf,
            wo,
            split,
            shadow,
            ..
        } = vertex;
        if let (Some(shadow), true) = (shadow, unblocked) {
            self.l += shadow.radiance;
        }
        let medium = self.medium;
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
        let count_found = split == 1.0 && !(mirror.is_some() && s.delta && !s.transmitted);
        self.go_on(material.absorption, hit, s, count_found, sampler)
    }

    /// Whether [`scatter`](Path::scatter) at `vertex` adds nothing to the radiance after the
    /// light sample's term (no split samples, no mirror ray): then that term may be added
    /// later, before anything the path's next vertex adds, with the same bits (the render
    /// loop does so while the sample's shadow ray waits to be tested with others).
    pub fn light_sample_comes_last(&self, vertex: &Vertex) -> bool {
        vertex.split == 1.0
            && (self.depth > MIRROR_SPLIT_DEPTH
                || vertex.bsdf.mirror_reflection(vertex.wo).is_none())
    }

    /// Continues the path from `hit` by its BSDF sample `s` (`absorption`: the medium inside
    /// the surface's solid, entered or left by transmission; `count_found`: whether the next
    /// vertex counts the light it finds), with Russian roulette from [`RR_DEPTH`] on. Returns
    /// whether the path goes on.
    fn go_on(
        &mut self,
        absorption: Option<Vec3>,
        hit: &SurfaceHit,
        s: BsdfSample,
        count_found: bool,
        sampler: &mut Sampler,
    ) -> bool {
        self.beta *= s.weight;
        if s.transmitted {
            self.eta_scale *= s.etap * s.etap;
            if let Some(sigma) = absorption {
                // Entering the solid (towards the back of the surface) or leaving it.
                self.medium = (s.wi.dot(hit.ng) < 0.0).then_some(sigma);
            }
        }
        self.prev_pdf = s.pdf;
        self.prev_delta = s.delta;
        self.count_found = count_found;
        self.prev_p = hit.p;
        self.prev_n = hit.ns;
        self.ray = spawn(hit, s.wi);
        if self.depth >= RR_DEPTH {
            let Some(beta) = russian_roulette(self.beta, self.eta_scale, sampler.get_1d()) else {
                return false;
            };
            self.beta = beta;
        }
        self.depth += 1;
        self.beta != Vec3::ZERO
    }
}

/// Russian roulette at a vertex from [`RR_DEPTH`] on, with the uniform number `u`: the
/// throughput `beta` of a path that survives, reweighted, or `None` for one that ends.
///
/// Survival is in proportion to the throughput without the refractions' 1/η′² (`eta_scale`):
/// a path inside glass carries 1/1.5² of the radiance it will have again outside, and with the
/// bare throughput 56 % of those paths were ended at each depth from `RR_DEPTH` on
/// (GlassVaseFlowers, depth 8: 1.19-1.23× the variance per sample). Paths that keep their
/// throughput always survive (pbrt-v4; Mitsuba 3 caps q at 0.95, which it needs for unbounded
/// depths, but `max_depth` bounds every path here, and the cap cost GlassVaseFlowers' specular
/// chains another 1.07-1.11× the variance). Any q > 0 is unbiased.
#[inline]
fn russian_roulette(beta: Rgb, eta_scale: f32, u: f32) -> Option<Rgb> {
    let q = (beta * eta_scale).max_element().min(1.0);
    (u < q).then(|| beta / q)
}

/// The paths of a wave, one per lane, as a structure of arrays: what [`Path`] holds, kept in
/// the form the stages that run in SIMD lanes read and write ([`LambertRoute`] continues its
/// lanes' paths here without taking them out). A lane whose vertex takes the general route
/// is [`take`](Self::take)n out as a [`Path`] and [`put`](Self::put) back when it goes on;
/// either way a lane's numbers are the same.
#[repr(C, align(64))]
pub struct PathLanes<const W: usize> {
    ray_o: V3s<W>,
    ray_d: V3s<W>,
    depth: [u32; W],
    l: V3s<W>,
    beta: V3s<W>,
    prev_pdf: F32s<W>,
    prev_p: V3s<W>,
    prev_n: V3s<W>,
    eta_scale: F32s<W>,
    prev_delta: [bool; W],
    medium: [Option<Vec3>; W],
    count_found: [bool; W],
    aov: [Option<Box<AovSample>>; W],
}

impl<const W: usize> PathLanes<W> {
    /// Lanes of no path (zeros).
    pub fn new() -> Self {
        PathLanes {
            ray_o: V3s::default(),
            ray_d: V3s::default(),
            depth: [0; W],
            l: V3s::default(),
            beta: V3s::default(),
            prev_pdf: F32s::default(),
            prev_delta: [false; W],
            prev_p: V3s::default(),
            prev_n: V3s::default(),
            medium: [None; W],
            eta_scale: F32s::default(),
            count_found: [false; W],
            aov: std::array::from_fn(|_| None),
        }
    }

    /// Puts `path` in lane `i`.
    #[inline]
    pub fn put(&mut self, i: usize, path: Path) {
        self.ray_o.set(i, path.ray.o);
        self.ray_d.set(i, path.ray.d);
        self.depth[i] = path.depth;
        self.l.set(i, path.l);
        self.beta.set(i, path.beta);
        self.prev_pdf[i] = path.prev_pdf;
        self.prev_delta[i] = path.prev_delta;
        self.prev_p.set(i, path.prev_p);
        self.prev_n.set(i, path.prev_n);
        self.medium[i] = path.medium;
        self.eta_scale[i] = path.eta_scale;
        self.count_found[i] = path.count_found;
        self.aov[i] = path.aov;
    }

    /// Puts in each `fresh` lane a path leaving the camera along `o + t·d`: the state
    /// [`Path::new`] sets (without render passes), written as selects (`tests/lane_widths.rs`
    /// holds the two to the same bits).
    #[inline(always)]
    pub fn start(&mut self, fresh: Mask<W>, o: V3s<W>, d: V3s<W>) {
        self.ray_o = V3s::select(fresh, o, self.ray_o);
        self.ray_d = V3s::select(fresh, d, self.ray_d);
        self.prev_p = V3s::select(fresh, o, self.prev_p);
        self.l = V3s::select(fresh, V3s::default(), self.l);
        self.beta = V3s::select(fresh, V3s::splat(Vec3::ONE), self.beta);
        self.prev_pdf = F32s::select(fresh, F32s::splat(0.0), self.prev_pdf);
        self.prev_n = V3s::select(fresh, V3s::default(), self.prev_n);
        self.eta_scale = F32s::select(fresh, F32s::splat(1.0), self.eta_scale);
        for i in 0..W {
            let fresh = fresh.lane(i);
            self.depth[i] = if fresh { 1 } else { self.depth[i] };
            self.prev_delta[i] |= fresh;
            self.count_found[i] |= fresh;
        }
        for i in fresh.iter() {
            self.medium[i] = None;
            self.aov[i] = None;
        }
    }

    /// What lane `i`'s finished path gives its pixel: its radiance and its passes' record
    /// (taken out; the lane then means nothing until a path is put there). What
    /// [`take`](Self::take) would give of it, without assembling the rest of the path.
    #[inline]
    pub fn end(&mut self, i: usize) -> (Rgb, Option<Box<AovSample>>) {
        (self.l.lane(i), self.aov[i].take())
    }

    /// Adds `radiance` to the radiance of the `lanes`' paths: the terms of light samples whose
    /// shadow rays were answered after their vertices scattered, added as the vertices would
    /// have added them.
    #[inline(always)]
    pub fn add_radiance(&mut self, lanes: Mask<W>, radiance: &V3s<W>) {
        self.l = V3s::select(lanes, self.l + *radiance, self.l);
    }

    /// Ends lane `i`'s path where its ray left a scene without an environment
    /// (`Scene::escapes_dark`), as [`Path::shade`] does without a hit (the lane must record no
    /// passes): it finds no light, `Scene::escaped`'s zero, added with the same operations.
    /// Returns what [`end`](Self::end) returns.
    #[inline]
    pub fn end_escaped(&mut self, i: usize) -> (Rgb, Option<Box<AovSample>>) {
        debug_assert!(self.aov[i].is_none());
        if self.count_found[i] {
            self.l
                .set(i, self.l.lane(i) + self.beta.lane(i) * Rgb::ZERO);
        }
        self.end(i)
    }

    /// Whether lane `i`'s path records render passes.
    #[inline]
    pub fn records_passes(&self, i: usize) -> bool {
        self.aov[i].is_some()
    }

    /// Takes lane `i`'s path out (the lane then means nothing until a path is put there).
    #[inline]
    pub fn take(&mut self, i: usize) -> Path {
        Path {
            ray: self.ray(i),
            depth: self.depth[i],
            l: self.l.lane(i),
            beta: self.beta.lane(i),
            prev_pdf: self.prev_pdf[i],
            prev_delta: self.prev_delta[i],
            prev_p: self.prev_p.lane(i),
            prev_n: self.prev_n.lane(i),
            medium: self.medium[i],
            eta_scale: self.eta_scale[i],
            count_found: self.count_found[i],
            aov: self.aov[i].take(),
        }
    }

    /// The rays of the `live` lanes to their next vertices, over (0, ∞).
    #[inline]
    pub fn rays(&self, live: Mask<W>) -> SegmentLanes<W> {
        SegmentLanes {
            live,
            o: self.ray_o,
            d: self.ray_d,
            t_max: F32s::splat(f32::INFINITY),
        }
    }

    /// Whether lane `i`'s next vertex takes the general route whatever its material: its path
    /// records render passes, runs inside a medium, or has reached its last vertex
    /// (`max_depth`). Without short-circuits, so with no branch per condition.
    #[inline]
    pub fn needs_general_route(&self, i: usize, max_depth: u32) -> bool {
        self.aov[i].is_some() | self.medium[i].is_some() | (self.depth[i] == max_depth)
    }

    /// Lane `i`'s ray to its next vertex.
    #[inline]
    pub fn ray(&self, i: usize) -> Ray {
        Ray::new(self.ray_o.lane(i), self.ray_d.lane(i))
    }
}

impl<const W: usize> Default for PathLanes<W> {
    fn default() -> Self {
        Self::new()
    }
}

pub use crate::lanes::KERNELS_FROM as LANE_KERNELS_FROM;

/// A wave's working memory for the stages that run in SIMD lanes, kept from step to step.
#[repr(C, align(64))]
pub struct Scratch<const W: usize> {
    lights: LightLanes<W>,
    lambert: LambertLanes<W>,
}

impl<const W: usize> Scratch<W> {
    /// Working memory for a wave of W lanes.
    pub fn new() -> Self {
        Scratch {
            lights: LightLanes::new(),
            lambert: LambertLanes::default(),
        }
    }
}

impl<const W: usize> Default for Scratch<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// The lanes of a wave whose vertex lies on a plain Lambertian surface
/// ([`Material::is_plain_lambertian`]), outside any medium, below the last depth and without
/// render passes: the common vertex of interiors. What [`Path::shade`] would make of them is
/// only an albedo and a shading frame, which go straight into the inputs of the light-sample
/// and BSDF-sample kernels, without a [`Vertex`] and its [`Bsdf`]; their light is picked and
/// their shadow rays made as in [`Path::sample_lights`], and they scatter by
/// [`Path::scatter_lambert`]. The same operations in the same order, so the same bits as the
/// general route. Used from [`LANE_KERNELS_FROM`] lanes on.
#[repr(C, align(64))]
pub struct LambertRoute<const W: usize> {
    /// The lanes on the route this step.
    on: Mask<W>,
    /// The lanes on the route whose light sample runs in the light kernel.
    in_kernel: Mask<W>,
    /// The lanes on the route whose light is sampled one lane at a time.
    deferred: Mask<W>,
    /// The lanes whose shading frame [`enter`](Self::enter) computed (the others' is computed
    /// in lanes).
    scalar_frame: Mask<W>,
    /// Where `power` is set: each lane's light (an exact integer).
    light_index: F32s<W>,
    /// The lanes with a light sample: its shadow ray (over (0, `shadow_t`)) and its radiance.
    has_shadow: Mask<W>,
    shadow_o: V3s<W>,
    shadow_d: V3s<W>,
    shadow_t: F32s<W>,
    shadow_radiance: V3s<W>,
    albedo: V3s<W>,
    /// The hit point and its shading normal (the geometric one is the BSDF's `ng`).
    p: V3s<W>,
    ns: V3s<W>,
    lights: LightLanes<W>,
    bsdf: LambertLanes<W>,
    picked: [Option<Picked>; W],
    /// The scene's lights, when the route picks them in lanes.
    power: Option<PowerLights>,
    /// Per instance, whether every hit on it whose surface is computed in lanes belongs on
    /// the route, and then its albedo ([`Material::route_albedo`]).
    instance_albedo: Vec<(bool, Rgb)>,
}

impl<const W: usize> LambertRoute<W> {
    /// A route with no lane on it, for `scene`.
    pub fn new(scene: &Scene) -> Self {
        LambertRoute {
            on: Mask::splat(false),
            in_kernel: Mask::splat(false),
            deferred: Mask::splat(false),
            scalar_frame: Mask::splat(false),
            picked: [None; W],
            power: PowerLights::of(scene),
            light_index: F32s::default(),
            instance_albedo: scene
                .geometry
                .instances
                .iter()
                .map(|instance| {
                    let albedo = scene.materials[instance.material as usize].route_albedo();
                    (albedo.is_some(), albedo.unwrap_or(Rgb::ZERO))
                })
                .collect(),
            has_shadow: Mask::splat(false),
            shadow_o: V3s::default(),
            shadow_d: V3s::default(),
            shadow_t: F32s::default(),
            shadow_radiance: V3s::default(),
            albedo: V3s::default(),
            p: V3s::default(),
            ns: V3s::default(),
            lights: LightLanes::new(),
            bsdf: LambertLanes::default(),
        }
    }

    /// Takes every lane off the route, for the wave's next step.
    pub fn clear(&mut self) {
        self.on = Mask::splat(false);
        self.in_kernel = Mask::splat(false);
        self.deferred = Mask::splat(false);
        self.picked = [None; W];
        self.has_shadow = Mask::splat(false);
    }

    /// Sets lane `i`'s light sample.
    #[inline]
    fn set_shadow(&mut self, i: usize, shadow: Option<Shadow>) {
        if let Some(shadow) = shadow {
            self.has_shadow.set(i, true);
            self.shadow_o.set(i, shadow.ray.o);
            self.shadow_d.set(i, shadow.ray.d);
            self.shadow_t[i] = shadow.t_max;
            self.shadow_radiance.set(i, shadow.radiance);
        }
    }

    /// The route's lanes with a light sample, and the radiance each adds where its shadow ray
    /// is clear.
    #[inline]
    pub fn light_samples(&self) -> (Mask<W>, &V3s<W>) {
        (self.has_shadow & self.on, &self.shadow_radiance)
    }

    /// The lanes on the route this step.
    #[inline]
    pub fn on_lanes(&self) -> Mask<W> {
        self.on
    }

    /// Whether lane `i` is on the route this step.
    #[inline]
    pub fn is_on(&self, i: usize) -> bool {
        self.on.lane(i)
    }

    /// Puts lane `i` on the route when the vertex of its path (in `paths`) at `hit` belongs
    /// there, picking its light with the lane's `u_light` (as [`Path::sample_lights`] does;
    /// where the route has the scene's lights, `power`, they are picked later for all lanes
    /// at once); returns whether it did. A lane left off takes [`Path::shade`] as before.
    pub fn enter(
        &mut self,
        i: usize,
        scene: &Scene,
        paths: &PathLanes<W>,
        hit: &SurfaceHit,
        u_light: glam::Vec2,
    ) -> bool {
        if W < LANE_KERNELS_FROM || paths.needs_general_route(i, scene.settings.max_depth) {
            return false;
        }
        let material = scene.material(hit);
        if !material.is_plain_lambertian() {
            return false;
        }
        // What `shade` computes here: no light is found on the surface (it neither emits nor
        // is unlit), and the BSDF is the material's Lambertian lobe. Its frame is computed
        // here where the shading normal depends on the view, else for all lanes at once in
        // `prepare`.
        let flat = material.shades_flat(hit);
        if !flat {
            let wo = -paths.ray_d.lane(i).normalize();
            let Some((_, frame)) = material.lambert(&scene.textures, hit, wo) else {
                return false;
            };
            let b = &mut self.bsdf;
            b.s.set(i, frame.s);
            b.t.set(i, frame.t);
            b.n.set(i, frame.n);
        }
        self.scalar_frame.set(i, !flat);
        self.on.set(i, true);
        self.albedo
            .set(i, material.lambert_albedo(&scene.textures, hit));
        self.p.set(i, hit.p);
        self.ns.set(i, hit.ns);
        self.bsdf.ng.set(i, hit.ng);
        if self.power.is_none() {
            self.choose_light(i, scene, hit, u_light);
        }
        true
    }

    /// Puts the lanes of `found` (the wave's hits whose surfaces were computed in lanes) on
    /// the route where their vertices belong there, as [`enter`](Self::enter) would one lane
    /// at a time (`u_light`: the lanes' light-sample points), and returns them. Their
    /// materials come from a table per instance, and their points and normals are taken as
    /// vectors.
    #[inline(always)]
    pub fn enter_lanes(
        &mut self,
        scene: &Scene,
        paths: &PathLanes<W>,
        found: &LaneSurfaces<W>,
        u_light: &[glam::Vec2; W],
    ) -> Mask<W> {
        let mut on = Mask::splat(false);
        if W < LANE_KERNELS_FROM || !found.in_lanes.any() {
            return on;
        }
        let max_depth = scene.settings.max_depth;
        // The lanes on the route as bits, made a mask whole (written lane by lane, a mask
        // read four lanes at a time next waits for its narrow stores).
        let mut on_bits = 0u64;
        for i in found.in_lanes.iter() {
            let (plain, albedo) = self.instance_albedo[found.instance[i] as usize];
            on_bits |= u64::from(plain & !paths.needs_general_route(i, max_depth)) << i;
            self.albedo.set(i, albedo);
        }
        if on_bits == 0 {
            return on;
        }
        on = Mask::from_bits(on_bits);
        let flat = self.take_surfaces(on, &found.out);
        let bent = on.and_not(flat);
        for i in bent.iter() {
            let hit = found.hit(i);
            let wo = -paths.ray_d.lane(i).normalize();
            match scene.material(&hit).lambert(&scene.textures, &hit, wo) {
                Some((_, frame)) => {
                    let b = &mut self.bsdf;
                    b.s.set(i, frame.s);
                    b.t.set(i, frame.t);
                    b.n.set(i, frame.n);
                }
                None => on.set(i, false),
            }
        }
        self.scalar_frame = bent | self.scalar_frame.and_not(on);
        self.on = self.on | on;
        if self.power.is_none() {
            for i in on.iter() {
                self.choose_light(i, scene, &found.hit(i), u_light[i]);
            }
        }
        on
    }

    /// [`take_surfaces_here`](Self::take_surfaces_here), compiled for the widest vector
    /// instructions the CPU has that suit W lanes.
    #[inline(always)]
    fn take_surfaces(&mut self, on: Mask<W>, out: &SurfacesOut<W>) -> Mask<W> {
        crate::lanes::widest!(
            W,
            (route: &mut LambertRoute<W>, on: Mask<W>, out: &SurfacesOut<W>) => Mask<W>,
            (self, on, out),
            route.take_surfaces_here(on, out)
        )
    }

    /// Takes the points and normals of the `on` lanes' hits from `out`; returns the lanes
    /// whose shading is flat (as `Material::shades_flat`: the interpolated normal, turned to
    /// the geometric normal's side, is the geometric normal).
    #[inline(always)]
    fn take_surfaces_here(&mut self, on: Mask<W>, out: &SurfacesOut<W>) -> Mask<W> {
        self.p = V3s::select(on, out.p, self.p);
        self.ns = V3s::select(on, out.ns, self.ns);
        self.bsdf.ng = V3s::select(on, out.ng, self.bsdf.ng);
        let turned = V3s::select(out.ns.dot(out.ng).lt(F32s::splat(0.0)), -out.ns, out.ns);
        turned.eq(out.ng)
    }

    /// Picks lane `i`'s light at `hit` with its light-sample point `u_light`, one lane at a
    /// time (where the route does not pick them in lanes), and sets the light kernel's inputs
    /// for it or defers its light sample.
    fn choose_light(&mut self, i: usize, scene: &Scene, hit: &SurfaceHit, u_light: glam::Vec2) {
        let Some((pick, light)) = Picked::choose(scene, hit, u_light) else {
            return;
        };
        self.picked[i] = Some(pick);
        match kernel_emission(scene, light) {
            Some(emission) => {
                self.in_kernel.set(i, true);
                self.lights.set_light(i, pick, light, emission);
            }
            // Sampled one lane at a time once the vertex is complete (`prepare`).
            None => self.deferred.set(i, true),
        }
    }

    /// Completes the vertices of the lanes that [`enter`](Self::enter)ed: the direction to the
    /// viewer and the shading frame of every lane at once (where `enter` left it), the light
    /// kernel's inputs, and the light samples of lights the kernel does not take.
    #[inline(always)]
    fn prepare(&mut self, scene: &Scene, paths: &PathLanes<W>, hits: WaveHits<'_, W>) {
        self.prepare_lanes(paths);
        self.sample_lights_alone(self.deferred, scene, paths, hits);
    }

    /// The light samples of the `lanes` one lane at a time ([`sample_light_alone`]): seldom
    /// any, so tested first.
    ///
    /// [`sample_light_alone`]: Self::sample_light_alone
    #[inline(always)]
    fn sample_lights_alone(
        &mut self,
        lanes: Mask<W>,
        scene: &Scene,
        paths: &PathLanes<W>,
        hits: WaveHits<'_, W>,
    ) {
        if !lanes.any() {
            return;
        }
        for i in lanes.iter() {
            if let Some(hit) = hits.get(i) {
                self.sample_light_alone(i, scene, paths, &hit);
            }
        }
    }

    /// Lane `i`'s light sample (its vertex at `hit` complete), taken by [`Path::light_sample`]
    /// one lane at a time: for lights the kernel does not take, and lanes it leaves undecided.
    fn sample_light_alone(
        &mut self,
        i: usize,
        scene: &Scene,
        paths: &PathLanes<W>,
        hit: &SurfaceHit,
    ) {
        let Some(pick) = self.pick(i) else { return };
        let vertex = self.vertex(i, scene, hit);
        let beta = paths.beta.lane(i);
        self.set_shadow(
            i,
            Path::light_sample((beta, None), scene, hit, &vertex, pick),
        );
    }

    /// The vector part of [`prepare`](Self::prepare), compiled for the widest vector
    /// instructions the CPU has that suit W lanes.
    fn prepare_lanes(&mut self, paths: &PathLanes<W>) {
        crate::lanes::widest!(
            W,
            (route: &mut LambertRoute<W>, paths: &PathLanes<W>) => (),
            (self, paths),
            route.prepare_here(paths)
        )
    }

    /// The operations of `Material::lambert` and `Path::shade` for the view and the frame
    /// (`-ray.d.normalize()`; [`Frame::from_normal`](crate::math::Frame::from_normal) of the
    /// normal turned to the geometric normal's side), in their order, in every lane.
    #[inline(always)]
    fn prepare_here(&mut self, paths: &PathLanes<W>) {
        let wo = -paths.ray_d.normalize();
        let ng = self.bsdf.ng;
        let n = V3s::select(self.ns.dot(ng).lt(F32s::splat(0.0)), -self.ns, self.ns);
        let [s, t, n] = crate::math::Frame::from_normal_lanes(n);
        let keep = self.scalar_frame;
        let b = &mut self.bsdf;
        // The normal kept in a register for the light kernel: read back from `b.n`, it waited
        // for the stores of the lanes just blended.
        let n = V3s::select(keep, b.n, n);
        b.s = V3s::select(keep, b.s, s);
        b.t = V3s::select(keep, b.t, t);
        b.n = n;
        b.wo = wo;
        let l = &mut self.lights;
        l.p = self.p;
        l.ng = ng;
        l.frame_n = n;
        l.bsdf_ng = ng;
        l.albedo = self.albedo;
        l.wo = wo;
        l.split = F32s::splat(1.0);
        l.beta = paths.beta;
    }

    /// Lane `i`'s vertex as [`Path::shade`] would have made it, for the rare light samples
    /// taken one lane at a time (lights other than constant triangles, and triangles that
    /// may be seen large).
    fn vertex<'a>(&self, i: usize, scene: &'a Scene, hit: &SurfaceHit) -> Vertex<'a> {
        let b = &self.bsdf;
        Vertex {
            material: scene.material(hit),
            bsdf: Bsdf {
                frame: crate::math::Frame {
                    s: b.s.lane(i),
                    t: b.t.lane(i),
                    n: b.n.lane(i),
                },
                ng: hit.ng,
                lobes: Lobes::Lambert(self.albedo.lane(i)),
            },
            wo: b.wo.lane(i),
            split: 1.0,
            needs_light: true,
            shadow: None,
        }
    }

    /// Lane `i`'s light choice, wherever it was made.
    fn pick(&self, i: usize) -> Option<Picked> {
        if self.power.is_none() {
            return self.picked[i];
        }
        self.in_kernel.lane(i).then(|| Picked {
            light: self.light_index[i] as usize,
            pmf: self.lights.pmf[i],
            u: glam::Vec2::new(self.lights.u.0[i], self.lights.u.1[i]),
        })
    }

    /// Picks the lights of the route's lanes with their light-sample points `u` (as
    /// [`Picked::choose`] does one lane at a time) and sets the light kernel's inputs for
    /// them, for all lanes at once, where the route has the scene's lights (`power`).
    #[inline(always)]
    fn choose_lights(&mut self, u: (F32s<W>, F32s<W>)) {
        let Some(power) = &self.power else { return };
        let on = self.on;
        (self.in_kernel, self.light_index) = self.lights.choose(power, u, on);
    }

    /// Runs the light kernel over the route's lanes that need it (`paths` and `hits`: the
    /// wave's, `u_light` their light-sample points), leaving each lane's shadow ray for
    /// [`shadow`](Self::shadow).
    #[inline(always)]
    pub fn sample_lights(
        &mut self,
        scene: &Scene,
        paths: &PathLanes<W>,
        hits: WaveHits<'_, W>,
        u_light: (F32s<W>, F32s<W>),
    ) {
        if !self.on.any() {
            return;
        }
        self.choose_lights(u_light);
        self.prepare(scene, paths, hits);
        if !self.in_kernel.any() {
            return;
        }
        let out = self.lights.run();
        let in_kernel = self.in_kernel;
        self.take_light_samples(&out);
        // The lanes the kernel left to the scalar code (seldom any).
        self.sample_lights_alone(in_kernel.and_not(out.decided), scene, paths, hits);
    }

    /// [`advance_here`](Self::advance_here), compiled for the widest vector instructions the
    /// CPU has that suit W lanes (the same operations, so the same bits).
    #[inline(always)]
    fn advance(&self, paths: &mut PathLanes<W>, on: Mask<W>, lit: Mask<W>) -> Mask<W> {
        crate::lanes::widest!(
            W,
            (route: &LambertRoute<W>, paths: &mut PathLanes<W>, on: Mask<W>, lit: Mask<W>) => Mask<W>,
            (self, paths, on, lit),
            route.advance_here(paths, on, lit)
        )
    }

    /// The arithmetic of [`scatter`](Self::scatter) over all lanes at once: the light
    /// samples of the `lit` lanes added, the Lambertian lobe sampled in the `on` lanes, and
    /// the paths of those with a sample continued as [`Path::go_on`] continues them up to
    /// Russian roulette (their sample's weight is the albedo, its pdf not a delta's, and it
    /// reflects). Returns the lanes with a sample.
    #[inline(always)]
    fn advance_here(&self, paths: &mut PathLanes<W>, on: Mask<W>, lit: Mask<W>) -> Mask<W> {
        paths.l = V3s::select(lit, paths.l + self.shadow_radiance, paths.l);
        let sampled = self.bsdf.sample_here();
        let go = on & sampled.valid;
        paths.beta = V3s::select(go, paths.beta * self.albedo, paths.beta);
        paths.prev_pdf = F32s::select(go, sampled.pdf, paths.prev_pdf);
        paths.prev_p = V3s::select(go, self.p, paths.prev_p);
        paths.prev_n = V3s::select(go, self.ns, paths.prev_n);
        let origin = offset_origin_lanes(self.p, self.bsdf.ng, sampled.wi);
        paths.ray_o = V3s::select(go, origin, paths.ray_o);
        paths.ray_d = V3s::select(go, sampled.wi, paths.ray_d);
        go
    }

    /// Takes the light kernel's samples (`out`) of the lanes it decided, compiled for the
    /// widest vector instructions the CPU has that suit W lanes.
    #[inline(always)]
    fn take_light_samples(&mut self, out: &LightLanesOut<W>) {
        crate::lanes::widest!(
            W,
            (route: &mut LambertRoute<W>, out: &LightLanesOut<W>) => (),
            (self, out),
            route.take_light_samples_here(out)
        )
    }

    #[inline(always)]
    fn take_light_samples_here(&mut self, out: &LightLanesOut<W>) {
        let lit = self.in_kernel & out.decided & out.valid;
        self.has_shadow = self.has_shadow | lit;
        self.shadow_o = V3s::select(lit, out.origin, self.shadow_o);
        self.shadow_d = V3s::select(lit, out.dir, self.shadow_d);
        self.shadow_t = F32s::select(lit, F32s::splat(1.0), self.shadow_t);
        self.shadow_radiance = V3s::select(lit, out.radiance, self.shadow_radiance);
    }

    /// Puts the shadow rays of the route's light samples in their lanes of `segments`.
    #[inline(always)]
    pub fn shadows(&self, segments: &mut SegmentLanes<W>) {
        crate::lanes::widest!(
            W,
            (route: &LambertRoute<W>, segments: &mut SegmentLanes<W>) => (),
            (self, segments),
            route.shadows_here(segments)
        )
    }

    #[inline(always)]
    fn shadows_here(&self, segments: &mut SegmentLanes<W>) {
        let lit = self.has_shadow;
        segments.live = segments.live | lit;
        segments.o = V3s::select(lit, self.shadow_o, segments.o);
        segments.d = V3s::select(lit, self.shadow_d, segments.d);
        segments.t_max = F32s::select(lit, self.shadow_t, segments.t_max);
    }

    /// Finishes the route's vertices, as [`Path::scatter`] does there (no split samples, no
    /// mirror ray, no render passes), on the lanes' paths in `paths`: adds each lane's light
    /// sample where its shadow ray was not `blocked`, samples the Lambertian lobe with the
    /// lane's 2D point (`u`'s second and third lanes) in the BSDF kernel, and continues the
    /// path as [`Path::go_on`] does, in SIMD lanes, Russian roulette included (its numbers
    /// drawn from the lanes' samplers in `samplers` in lanes, only by the lanes that play it).
    /// Returns the lanes whose path ended.
    #[inline(always)]
    pub fn scatter(
        &mut self,
        &(_, ux, uy): &(F32s<W>, F32s<W>, F32s<W>),
        blocked: &[bool; W],
        paths: &mut PathLanes<W>,
        samplers: &mut SamplerLanes<W>,
    ) -> Mask<W> {
        if !self.on.any() {
            return Mask::splat(false);
        }
        self.bsdf.u = (ux, uy);
        let on = self.on;
        let lit = self.has_shadow & on & !Mask::from_bools(blocked);
        let go = self.advance(paths, on, lit);
        // Russian roulette (`russian_roulette`) in the lanes that go on from its depth.
        // (The masks as arrays first: a mask held in registers and read lane by lane is copied
        // to the stack again at every lane.)
        let go_lanes = go.to_bools();
        let roulette: [bool; W] =
            std::array::from_fn(|i| go_lanes[i] & (paths.depth[i] >= RR_DEPTH));
        let mut survive = go;
        if roulette.contains(&true) {
            let roulette = Mask::from_bools(&roulette);
            let u = samplers.get_1d(roulette);
            survive = go.and_not(roulette.and_not(russian_roulette_lanes(paths, roulette, u)));
        }
        let black = paths.beta.is_zero();
        let survive_lanes = survive.to_bools();
        for i in 0..W {
            let (go, survive) = (go_lanes[i], survive_lanes[i]);
            paths.prev_delta[i] &= !go;
            paths.count_found[i] |= go;
            paths.depth[i] += u32::from(survive);
        }
        on.and_not(survive.and_not(black))
    }
}

/// [`russian_roulette`] in the `playing` lanes of `paths` with their numbers `u`, compiled for
/// the widest vector instructions the CPU has that suit W lanes: the survivors' throughputs
/// divided by their chance; returns the lanes that survive.
fn russian_roulette_lanes<const W: usize>(
    paths: &mut PathLanes<W>,
    playing: Mask<W>,
    u: F32s<W>,
) -> Mask<W> {
    crate::lanes::widest!(
        W,
        (paths: &mut PathLanes<W>, playing: Mask<W>, u: F32s<W>) => Mask<W>,
        (paths, playing, u),
        russian_roulette_here(paths, playing, u)
    )
}

#[inline(always)]
fn russian_roulette_here<const W: usize>(
    paths: &mut PathLanes<W>,
    playing: Mask<W>,
    u: F32s<W>,
) -> Mask<W> {
    let (b, e) = (paths.beta, paths.eta_scale);
    // `(beta * eta_scale).max_element().min(1.0)`: std's `min` gives the lanes' bits, its
    // second argument never being NaN.
    let q = (b * e).max_element().min(F32s::splat(1.0));
    let kept = u.lt(q);
    paths.beta = V3s::select(playing & kept, b / q, b);
    kept
}

/// A wave's hits: those whose surfaces were computed in lanes, and the others lane by lane.
#[derive(Clone, Copy)]
pub struct WaveHits<'a, const W: usize> {
    /// The hits kept as lanes.
    pub found: &'a LaneSurfaces<W>,
    /// The others (`None` in the lanes of `found`).
    pub hits: &'a [Option<SurfaceHit>; W],
}

impl<const W: usize> WaveHits<'_, W> {
    /// Lane `i`'s hit, if it has one.
    #[inline]
    pub fn get(&self, i: usize) -> Option<SurfaceHit> {
        match &self.hits[i] {
            Some(hit) => Some(*hit),
            None => self.found.get(i),
        }
    }
}

/// The most lights the route picks in lanes (one comparison and a few selects per light and
/// lane).
const POWER_LANES_MAX: usize = 8;

/// The scene's lights when next-event estimation picks them by power alone, there are at most
/// [`POWER_LANES_MAX`] of them, and each is a triangle of constant emission (the light kernel's
/// case, [`kernel_emission`]): a Cornell box's quad. The route then picks every lane's light in
/// lanes and sets the kernel's inputs by selects, instead of one lane at a time.
struct PowerLights {
    sampler: PowerSampler,
    /// Each light with its emission (radiance, two-sided).
    lights: Vec<(Light, (Rgb, bool))>,
}

impl PowerLights {
    /// `scene`'s lights, when they are such.
    fn of(scene: &Scene) -> Option<PowerLights> {
        let sampler = scene.light_sampler.by_power()?;
        let n = sampler.len();
        if n == 0 || n > POWER_LANES_MAX || n != scene.lights.len() {
            return None;
        }
        let lights = scene
            .lights
            .iter()
            .map(|light| Some((light.clone(), kernel_emission(scene, light)?)))
            .collect::<Option<Vec<_>>>()?;
        Some(PowerLights {
            sampler: sampler.clone(),
            lights,
        })
    }
}

/// A lane's light choice for next-event estimation: the light, its probability, and the 2D
/// point that samples it.
#[derive(Debug, Clone, Copy)]
struct Picked {
    light: usize,
    pmf: f32,
    u: glam::Vec2,
}

impl Picked {
    /// The light that next-event estimation at `hit` picks with the first coordinate of `u`
    /// (the vertex's light-sample point, whose first coordinate is then remapped to sample a
    /// point on that light), and the light itself; `None` when the scene has none to pick.
    #[inline]
    fn choose<'a>(
        scene: &'a Scene,
        hit: &SurfaceHit,
        u: glam::Vec2,
    ) -> Option<(Picked, &'a Light)> {
        let (light, pmf, u_x) = scene.light_sampler.pick(hit.p, hit.ns, u.x)?;
        let pick = Picked {
            light,
            pmf,
            u: glam::Vec2::new(u_x, u.y),
        };
        Some((pick, &scene.lights[light]))
    }
}

/// A lane of [`Path::sample_lights`] that runs in the vector kernel: its triangle light, that
/// light's constant emission (see [`kernel_emission`]) and the Lambertian albedo of its surface.
#[derive(Clone, Copy)]
struct LaneLight<'a> {
    light: &'a Light,
    emission: (Rgb, bool),
    albedo: Rgb,
}

/// What the light kernel reads of a lane's vertex besides its hit: the BSDF's shading and
/// geometric normals, the direction to the viewer, the BSDF samples drawn for direct light
/// there (see [`SPLIT`]) and the path's throughput.
#[derive(Clone, Copy)]
struct LaneVertex {
    frame_n: Vec3,
    bsdf_ng: Vec3,
    wo: Vec3,
    split: f32,
    beta: Rgb,
}

/// For a triangle light whose radiance is the same everywhere (an emissive material without an
/// emission texture), the light kernel's case: that radiance and whether both faces emit it.
fn kernel_emission(scene: &Scene, light: &Light) -> Option<(Rgb, bool)> {
    if !matches!(light, Light::Triangle { .. }) {
        return None;
    }
    let material = scene.material_of_light(light)?;
    (material.is_emissive() && material.emission_texture.is_none())
        .then_some((material.emission, material.two_sided_emission))
}

/// The lanes of [`Path::sample_lights`] that sample a triangle light by area from a
/// Lambertian surface: what [`Path::light_sample`] reads, one lane per path (structure of
/// arrays; other lanes hold zeros, and their results mean nothing).
#[repr(C, align(64))]
struct LightLanes<const W: usize> {
    triangles: TriangleLanes<W>,
    u: (F32s<W>, F32s<W>),
    pmf: F32s<W>,
    /// The light's radiance and whether both its faces emit it.
    emission: V3s<W>,
    two_sided_emission: Mask<W>,
    /// The hit point and its geometric normal.
    p: V3s<W>,
    ng: V3s<W>,
    /// The BSDF's shading normal, geometric normal and albedo, and the direction to the eye.
    frame_n: V3s<W>,
    bsdf_ng: V3s<W>,
    albedo: V3s<W>,
    wo: V3s<W>,
    split: F32s<W>,
    beta: V3s<W>,
}

/// What [`LightLanes::run`] found in each lane.
#[repr(C, align(64))]
struct LightLanesOut<const W: usize> {
    /// The lanes whose result is here (the others sample a triangle that may be seen large:
    /// see [`TriangleSamples::decided`](crate::light::TriangleSamples)).
    decided: Mask<W>,
    /// The decided lanes with a shadow ray.
    valid: Mask<W>,
    origin: V3s<W>,
    dir: V3s<W>,
    radiance: V3s<W>,
}

impl<const W: usize> LightLanesOut<W> {
    /// Lane `i`'s light sample: `None` where the kernel left the lane undecided (the scalar
    /// code then takes it), else the shadow ray, if the sample can add anything.
    #[inline]
    fn shadow(&self, i: usize) -> Option<Option<Shadow>> {
        self.decided.lane(i).then(|| {
            self.valid.lane(i).then(|| Shadow {
                ray: Ray::new(self.origin.lane(i), self.dir.lane(i)),
                t_max: 1.0,
                radiance: self.radiance.lane(i),
            })
        })
    }
}

impl<const W: usize> LightLanes<W> {
    /// Lanes of nothing (zeros).
    fn new() -> Self {
        LightLanes {
            triangles: TriangleLanes::new(),
            u: (F32s::default(), F32s::default()),
            pmf: F32s::default(),
            emission: V3s::default(),
            two_sided_emission: Mask::splat(false),
            p: V3s::default(),
            ng: V3s::default(),
            frame_n: V3s::default(),
            bsdf_ng: V3s::default(),
            albedo: V3s::default(),
            wo: V3s::default(),
            split: F32s::default(),
            beta: V3s::default(),
        }
    }

    /// Sets the lanes of `lights` (the others keep what they held, which means nothing).
    fn gather(
        &mut self,
        paths: &[Option<&Path>; W],
        hits: &[Option<SurfaceHit>; W],
        vertices: &[Option<Vertex>; W],
        picked: &[Option<Picked>; W],
        lights: &[Option<LaneLight>; W],
    ) {
        for i in 0..W {
            let (Some(path), Some(hit), Some(vertex), Some(pick), Some(lane)) =
                (paths[i], &hits[i], &vertices[i], picked[i], lights[i])
            else {
                continue;
            };
            let seen = LaneVertex {
                frame_n: vertex.bsdf.frame.n,
                bsdf_ng: vertex.bsdf.ng,
                wo: vertex.wo,
                split: vertex.split,
                beta: path.beta,
            };
            self.set(i, (pick, lane), hit, seen);
        }
    }

    /// [`choose_here`](Self::choose_here), compiled for the widest vector instructions the
    /// CPU has that suit W lanes.
    fn choose(
        &mut self,
        power: &PowerLights,
        u: (F32s<W>, F32s<W>),
        on: Mask<W>,
    ) -> (Mask<W>, F32s<W>) {
        crate::lanes::widest!(
            W,
            (lights: &mut LightLanes<W>, power: &PowerLights, u: (F32s<W>, F32s<W>), on: Mask<W>)
                => (Mask<W>, F32s<W>),
            (self, power, u, on),
            lights.choose_here(power, u, on)
        )
    }

    /// Picks the light of each lane of `on` by power with its light-sample point `(ux, uy)`
    /// and sets its inputs (as [`set_light`](Self::set_light) sets them one lane at a time).
    /// Returns the lanes that picked a light and each lane's light.
    #[inline(always)]
    fn choose_here(
        &mut self,
        power: &PowerLights,
        (ux, uy): (F32s<W>, F32s<W>),
        on: Mask<W>,
    ) -> (Mask<W>, F32s<W>) {
        let pick = power.sampler.pick_lanes(ux);
        let chosen = on & pick.picked;
        self.u = (
            F32s::select(chosen, pick.u, self.u.0),
            F32s::select(chosen, uy, self.u.1),
        );
        self.pmf = F32s::select(chosen, pick.pmf, self.pmf);
        // Every lane takes the first light, and the lanes that picked another then take theirs:
        // a lane that picked none is not read (`chosen` is the kernel's lanes), and the first
        // light needs no blend with what the lanes held.
        let mut lights = power.lights.iter().enumerate();
        if let Some((_, (light, (emission, two_sided)))) = lights.next() {
            self.triangles.set_where(Mask::splat(true), light);
            self.emission = V3s::splat(*emission);
            self.two_sided_emission = Mask::splat(*two_sided);
        }
        for (k, (light, (emission, two_sided))) in lights {
            let here = chosen & pick.light.eq(F32s::splat(k as f32));
            self.triangles.set_where(here, light);
            self.emission = V3s::select(here, V3s::splat(*emission), self.emission);
            self.two_sided_emission = if *two_sided {
                self.two_sided_emission | here
            } else {
                self.two_sided_emission.and_not(here)
            };
        }
        (chosen, pick.light)
    }

    /// Sets lane `i`'s light: the triangle light `light` picked by `pick`, with the constant
    /// emission `(radiance, two-sided)` of [`kernel_emission`] (the vertex's inputs are set
    /// apart).
    #[inline]
    fn set_light(
        &mut self,
        i: usize,
        pick: Picked,
        light: &Light,
        (emission, two_sided): (Rgb, bool),
    ) {
        self.triangles.set(i, light);
        (self.u.0[i], self.u.1[i], self.pmf[i]) = (pick.u.x, pick.u.y, pick.pmf);
        self.emission.set(i, emission);
        self.two_sided_emission.set(i, two_sided);
    }

    /// Sets lane `i` to the light `lane` picked by `pick`, sampled from `hit` whose vertex
    /// reads as `seen`.
    #[inline(always)]
    fn set(
        &mut self,
        i: usize,
        (pick, lane): (Picked, LaneLight),
        hit: &SurfaceHit,
        seen: LaneVertex,
    ) {
        let LaneLight {
            light,
            emission,
            albedo,
        } = lane;
        self.set_light(i, pick, light, emission);
        let l = self;
        l.p.set(i, hit.p);
        l.ng.set(i, hit.ng);
        l.frame_n.set(i, seen.frame_n);
        l.bsdf_ng.set(i, seen.bsdf_ng);
        l.albedo.set(i, albedo);
        l.wo.set(i, seen.wo);
        l.split[i] = seen.split;
        l.beta.set(i, seen.beta);
    }

    /// [`Path::light_sample`] in every lane, compiled for the widest vector instructions the
    /// CPU has that suit W lanes (the same operations, so the same bits).
    fn run(&self) -> LightLanesOut<W> {
        crate::lanes::widest!(W, lanes: &LightLanes<W> => LightLanesOut<W>, self, lanes.run_here())
    }

    /// The operations of [`Path::light_sample`], [`sample_light`], `Material::emitted`, the
    /// Lambertian `Bsdf::eval` and `segment_to`, in their order.
    #[inline(always)]
    fn run_here(&self) -> LightLanesOut<W> {
        let zero = F32s::splat(0.0);
        let s = self.triangles.sample(self.p, self.u);
        // The emitter's radiance towards the hit point (none from behind a one-sided one).
        let cos_emitted = self.triangles.normal().dot(-s.wi);
        let dark = !self.two_sided_emission & cos_emitted.le(zero);
        // The Lambertian lobe: f·|cos θi| and its pdf, none across the surface.
        let (cos_o, cos_i) = (self.wo.dot(self.frame_n), s.wi.dot(self.frame_n));
        let across = (cos_o * cos_i).le(zero)
            | (self.wo.dot(self.bsdf_ng) * s.wi.dot(self.bsdf_ng)).le(zero);
        let pdf_bsdf = cos_i.abs() * FRAC_1_PI;
        let f = self.albedo * pdf_bsdf;
        let pdf_light = self.pmf * s.pdf;
        let weight = power_heuristic_lanes(pdf_light, self.split * pdf_bsdf);
        let radiance = self.beta * f * self.emission * (weight / pdf_light);
        // The shadow segment, both ends offset off their surfaces.
        let dir = s.point - self.p;
        let origin = offset_origin_lanes(self.p, self.ng, dir);
        let end = offset_origin_lanes(s.point, self.triangles.normal(), -dir);
        LightLanesOut {
            decided: s.decided,
            valid: s.valid & !dark & !self.emission.is_zero() & !across & !f.is_zero(),
            origin,
            dir: end - origin,
            radiance,
        }
    }
}

/// [`power_heuristic`] in every lane.
#[inline(always)]
fn power_heuristic_lanes<const W: usize>(pdf_a: F32s<W>, pdf_b: F32s<W>) -> F32s<W> {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let weight = F32s::select(
        a.eq(F32s::splat(f32::INFINITY)),
        F32s::splat(1.0),
        a / (a + b),
    );
    F32s::select(a.eq(F32s::splat(0.0)), F32s::splat(0.0), weight)
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
