//! The render loop's core: a thread takes its tile's samples as a *wave* of W paths, one per
//! lane, and advances all of them a vertex at a time (closest hits, shading up to the light
//! sample, shadow rays, BSDF sampling), each stage over every lane at once. A lane whose path
//! ends takes the tile's next sample at once (path regeneration, Novák et al. 2010), so lanes
//! stay busy whatever the paths' lengths; the film's sums are exact integers, so which lane ran
//! a sample, and in what order samples finish, changes no bit of the image.
//!
//! W is chosen per render ([`crate::lanes::default_width`]: 16 with AVX-512, 8 with AVX2, 4
//! with SSE2 or NEON, or `LUMO_SIMD`), and W = 1 is the same code with one lane. Every lane's
//! numbers are a function of its own (seed, pixel, sample index), so all widths give the same
//! image bit for bit (`tests/lane_widths.rs`).

use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

use super::film::Sink;
use super::occlusion_queue::OcclusionQueue;
use crate::aov::AovSample;
use crate::geometry::mesh::SurfaceLanes;
use crate::geometry::{LaneSurfaces, SegmentLanes, SurfaceHit};
use crate::integrator::path::{LambertRoute, Path, PathLanes, Scratch, Vertex, WaveHits};
use crate::integrator::{raycast, TraceStats};
use crate::lanes::{widest, F32s, Mask, V3s};
use crate::math::{Ray, Rgb, Vec2};
use crate::sampler::{Sampler, SamplerKind, SamplerLanes};
use crate::scene::{IntegratorKind, Scene};

/// A pixel's share of a pass: pixel (x, y) takes the samples with `indices`.
#[derive(Debug, Clone)]
pub(super) struct PixelWork {
    /// Column in the image.
    pub x: u32,
    /// Row in the image.
    pub y: u32,
    /// Sample indices to take.
    pub indices: Range<u32>,
}

/// The sums of `work`'s samples, pixel by pixel into `sums` (one per entry of `work`), taken
/// `width` lanes at a time; `origin` is added to the work's pixel coordinates to place them in
/// the image. When `cancel` is set the work stops within a step of the wave, its sums left
/// incomplete (the pass they belong to is dropped).
pub(super) fn render_pixels(
    scene: &Scene,
    (width, cancel): (usize, Option<&AtomicBool>),
    origin: (u32, u32),
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) {
    match width {
        16 => run_wave::<16>(scene, cancel, origin, work, sums, stats),
        8 => run_wave::<8>(scene, cancel, origin, work, sums, stats),
        4 => run_wave::<4>(scene, cancel, origin, work, sums, stats),
        _ => run_wave::<1>(scene, cancel, origin, work, sums, stats),
    }
}

/// A lane's sample: the entry of the work it is a sample of, and the sample's index (its path
/// and its sampler are the lane's in the wave's [`PathLanes`] and [`SamplerLanes`]).
struct Lane {
    pixel: usize,
    index: u32,
}

/// How many waves a thread keeps in flight, so that the shadow rays of several fill the
/// occlusion kernel's lanes ([`OcclusionQueue`]).
const WAVES: usize = 3;

/// Runs every sample of `work` in waves of W lanes, refilling lanes as their paths end.
fn run_wave<const W: usize>(
    scene: &Scene,
    cancel: Option<&AtomicBool>,
    origin: (u32, u32),
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) {
    widest!(
        gfni;
        W,
        (
            scene: &Scene,
            cancel: Option<&AtomicBool>,
            origin: (u32, u32),
            work: &[PixelWork],
            sums: &mut Sink,
            stats: &mut TraceStats
        ) => (),
        (scene, cancel, origin, work, sums, stats),
        run_wave_here::<W>(scene, cancel, origin, work, sums, stats)
    )
}

/// [`run_wave`]'s loop, inlined into each of its copies (the same operations, so the same
/// bits).
///
/// The waves take turns, a step each. A step's light samples add their terms only once their
/// shadow rays are answered, which is at the start of the wave's next turn, before anything
/// the step after adds: the same sums in the same order as if the rays had been tested at
/// once. Meanwhile the other waves' turns queue their rays, so that the occlusion kernel mostly
/// runs on full lanes. A wave whose step cannot wait (a vertex that adds more light after its
/// light sample: split BSDF samples, the mirror ray of glass) has its rays tested at once.
#[inline(always)]
fn run_wave_here<const W: usize>(
    scene: &Scene,
    cancel: Option<&AtomicBool>,
    origin: (u32, u32),
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) {
    let mut source = Samples {
        scene,
        origin,
        work,
        queue: work
            .iter()
            .enumerate()
            .flat_map(|(k, w)| w.indices.clone().map(move |i| (k, i))),
        empty: false,
        pixel_key: (u64::MAX, 0),
        // Samples whose camera rays are drawn for all new lanes at once (the common case:
        // Sobol points through a pinhole, no render passes); the others one lane at a time.
        in_lanes: W >= crate::lanes::KERNELS_FROM
            && scene.settings.sampler == SamplerKind::Sobol
            && scene.camera.lens_radius <= 0.0
            && !sums.wants_aovs(),
    };
    let mut waves: [Wave<W>; WAVES] = std::array::from_fn(|_| Wave::new());
    // Small work (a pixel's samples at a time, as time-budgeted passes take them) in fewer
    // waves, each filled a few times over: a wave draining its last paths runs its steps
    // for few lanes.
    let samples: usize = work.iter().map(|w| w.indices.len()).sum();
    let in_flight = samples.div_ceil(4 * W).clamp(1, WAVES);
    let mut step = Box::new(Step::new(scene));
    let mut shadow_rays = OcclusionQueue::<W, WAVES>::new();
    loop {
        let mut any_live = false;
        for (w, wave) in waves[..in_flight].iter_mut().enumerate() {
            wave.settle(w, scene, &mut shadow_rays, sums, stats);
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return;
            }
            if !source.empty {
                wave.refill(&mut source, sums, stats);
            }
            if wave.step(w, &mut step, &mut shadow_rays, scene, sums, stats) {
                any_live = true;
            }
            while shadow_rays.is_full() {
                shadow_rays.run(scene, stats);
            }
        }
        if !any_live {
            return;
        }
    }
}

/// Where the waves take their samples from: the work's samples in order, and what starting
/// them needs.
struct Samples<'a, Q> {
    scene: &'a Scene,
    origin: (u32, u32),
    work: &'a [PixelWork],
    /// The samples not taken yet, as (entry of `work`, sample index).
    queue: Q,
    /// Whether `queue` ran out.
    empty: bool,
    /// The last pixel whose sampler key was derived, and the key: a pixel's samples mostly
    /// follow one another.
    pixel_key: (u64, u64),
    /// Whether new lanes' camera rays are drawn in lanes ([`start_in_lanes`]).
    in_lanes: bool,
}

/// A wave of W paths, and what its last step left to do: the terms of the light samples whose
/// shadow rays wait, and the paths that ended at it.
#[repr(C, align(64))]
struct Wave<const W: usize> {
    paths: PathLanes<W>,
    samplers: SamplerLanes<W>,
    /// The lanes whose light sample waits for its shadow ray, and the radiance each adds
    /// where the ray is clear.
    waiting: Mask<W>,
    waiting_radiance: V3s<W>,
    /// The lanes whose path ended at the last step (their samples go to the film when the
    /// wave settles, after their light samples' terms).
    ended: Mask<W>,
    /// Each lane's sample, where bit i of `occupied` is set.
    lanes: [Lane; W],
    occupied: u64,
}

/// What one step of a wave works with, shared by the waves, which step one at a time (kept
/// out of the waves so that the data a thread touches stays in its first-level cache).
#[repr(C, align(64))]
struct Step<'s, const W: usize> {
    scratch: Scratch<W>,
    route: LambertRoute<W>,
    surfaces: SurfaceLanes<W>,
    found: LaneSurfaces<W>,
    shadows: SegmentLanes<W>,
    /// The paths of the lanes off the Lambertian route, taken out of the wave's for the step.
    off_route: [Option<Path>; W],
    hits: [Option<SurfaceHit>; W],
    vertices: [Option<Vertex<'s>>; W],
}

impl<'s, const W: usize> Step<'s, W> {
    /// A step of no lane, for `scene`.
    fn new(scene: &'s Scene) -> Self {
        Step {
            off_route: std::array::from_fn(|_| None),
            hits: [None; W],
            vertices: std::array::from_fn(|_| None),
            scratch: Scratch::new(),
            route: LambertRoute::new(scene),
            surfaces: SurfaceLanes::new(),
            found: LaneSurfaces::none(),
            shadows: SegmentLanes::new(),
        }
    }
}

impl<const W: usize> Wave<W> {
    /// A wave of idle lanes.
    fn new() -> Self {
        Wave {
            lanes: std::array::from_fn(|_| Lane { pixel: 0, index: 0 }),
            occupied: 0,
            paths: PathLanes::new(),
            samplers: SamplerLanes::new(),
            waiting: Mask::splat(false),
            waiting_radiance: V3s::default(),
            ended: Mask::splat(false),
        }
    }

    /// Finishes what the wave's last step (wave `w` of `shadow_rays`) left: adds the light
    /// samples' terms whose shadow rays are clear (running the queue until they are all
    /// answered) and hands the paths that ended to the film.
    #[inline(always)]
    fn settle<const N: usize>(
        &mut self,
        w: usize,
        scene: &Scene,
        shadow_rays: &mut OcclusionQueue<W, N>,
        sums: &mut Sink,
        stats: &mut TraceStats,
    ) {
        let blocked = shadow_rays.answers(w, scene, stats);
        if self.waiting.any() {
            let clear = self.waiting.and_not(blocked);
            self.paths.add_radiance(clear, &self.waiting_radiance);
            self.waiting = Mask::splat(false);
        }
        for i in self.ended.iter() {
            let (radiance, aov) = self.paths.end(i);
            finish(&self.lanes[i], radiance, aov.as_deref(), sums);
        }
        self.occupied &= !self.ended.bits();
        self.ended = Mask::splat(false);
    }

    /// One step of the wave (wave `w` of `shadow_rays`): finds every path's next vertex, shades
    /// it, samples its light and queues the shadow ray, and scatters it. Returns `false` when
    /// no lane has a sample.
    #[inline(always)]
    fn step<'s, const N: usize>(
        &mut self,
        w: usize,
        step: &mut Step<'s, W>,
        shadow_rays: &mut OcclusionQueue<W, N>,
        scene: &'s Scene,
        sums: &mut Sink,
        stats: &mut TraceStats,
    ) -> bool {
        if self.occupied == 0 {
            return false;
        }
        let live = Mask::<W>::from_bits(self.occupied);
        let Wave {
            lanes,
            occupied,
            paths,
            samplers,
            ..
        } = self;
        let Step {
            off_route,
            hits,
            vertices,
            scratch,
            route,
            surfaces,
            found,
            shadows,
        } = step;
        stats.rays += u64::from(live.count());
        // Drawn before the intersections, which do not need them: the draws' chains of
        // multiplications then run beside the intersection kernel's first triangles.
        let ((ux, uy), scatter_point) = samplers.get_2d_and_scatter_point(live);
        scene.intersect_wave(&paths.rays(live), hits, surfaces, found);
        let u_light: [_; W] = std::array::from_fn(|i| Vec2::new(ux[i], uy[i]));
        route.clear();
        // The hits kept in lanes that belong on the route stay there; the others' are taken
        // out lane by lane.
        let entered = route.enter_lanes(scene, paths, found, &u_light);
        // The lanes whose vertex takes the general route (`Path::shade`).
        let mut general_bits = 0u64;
        for i in live.and_not(entered).iter() {
            if found.in_lanes.lane(i) {
                // Left off the route by `enter_lanes`.
                hits[i] = Some(found.hit(i));
            } else if let Some(hit) = &hits[i] {
                if route.enter(i, scene, paths, hit, u_light[i]) {
                    continue;
                }
            } else if scene.escapes_dark() && !paths.records_passes(i) {
                // Out of the scene, with nothing more to find.
                let (radiance, aov) = paths.end_escaped(i);
                finish(&lanes[i], radiance, aov.as_deref(), sums);
                *occupied &= !(1 << i);
                continue;
            }
            let mut path = paths.take(i);
            if path.shade(scene, hits[i].as_ref(), &mut vertices[i]) {
                off_route[i] = Some(path);
                general_bits |= 1 << i;
            } else {
                finish(&lanes[i], path.radiance(), path.aov.as_deref(), sums);
                *occupied &= !(1 << i);
            }
        }
        let general = Mask::<W>::from_bits(general_bits);
        if general_bits != 0 {
            Path::sample_lights(
                scene,
                off_route.each_ref().map(Option::as_ref),
                hits,
                vertices,
                &u_light,
                scratch,
            );
        }
        let wave_hits = WaveHits { found, hits };
        route.sample_lights(scene, paths, wave_hits, (ux, uy));
        // Only this step's vertices: a lane that is idle or whose path just ended traces none.
        *shadows = SegmentLanes::new();
        route.shadows(shadows);
        let mut waits = true;
        for i in general.iter() {
            let (Some(vertex), Some(path)) = (&vertices[i], &off_route[i]) else {
                continue;
            };
            if let Some(shadow) = vertex.shadow {
                shadows.set(i, &shadow.ray, shadow.t_max);
                waits &= path.light_sample_comes_last(vertex);
            }
        }
        shadow_rays.push(w, shadows);
        // The answers now, if some vertex cannot wait for them; else none yet (the light
        // samples' terms are added when the wave settles).
        let blocked = if waits {
            [true; W]
        } else {
            shadow_rays.answers(w, scene, stats).to_bools()
        };
        let scattering = general | route.on_lanes();
        // A lobe choice only where a vertex off the route may have several lobes.
        let u_scatter = samplers.get_choice_2d_from(scattering, scatter_point, general.any());
        let sampled = if general.any() {
            Path::sample_bsdfs(vertices, &u_scatter, scratch)
        } else {
            [None; W]
        };
        let mut ended = route.scatter(&u_scatter, &blocked, paths, samplers);
        if waits {
            let (lanes_lit, radiance) = route.light_samples();
            self.waiting = lanes_lit;
            self.waiting_radiance = *radiance;
        }
        for i in general.iter() {
            let (Some(vertex), Some(hit), Some(mut path)) =
                (&vertices[i], &hits[i], off_route[i].take())
            else {
                continue;
            };
            let goes_on = samplers.with(i, |sampler| {
                path.scatter(scene, hit, vertex, !blocked[i], sampled[i], sampler, stats)
            });
            if let (true, Some(shadow)) = (waits, vertex.shadow) {
                self.waiting.set(i, true);
                self.waiting_radiance.set(i, shadow.radiance);
            }
            vertices[i] = None;
            paths.put(i, path);
            ended.set(i, !goes_on);
        }
        // To the film when the wave settles (after its light samples' terms, if they wait).
        self.ended = ended;
        true
    }

    /// Gives the idle lanes the next samples of `source` (until it runs out).
    #[inline(always)]
    fn refill<Q: Iterator<Item = (usize, u32)>>(
        &mut self,
        source: &mut Samples<Q>,
        sums: &mut Sink,
        stats: &mut TraceStats,
    ) {
        let scene = source.scene;
        // The lanes started in lanes, as bits (a mask written lane by lane and then read four
        // lanes at a time waits for its narrow stores).
        let mut fresh_bits = 0u64;
        let mut film = (F32s::<W>::default(), F32s::<W>::default());
        for i in Mask::<W>::from_bits(!self.occupied).iter() {
            let Some((lane, (x, y))) = next_lane(
                scene,
                source.origin,
                &mut source.queue,
                source.work,
                sums,
                stats,
            ) else {
                source.empty = true;
                break;
            };
            let index = lane.index;
            self.lanes[i] = lane;
            self.occupied |= 1 << i;
            if source.in_lanes {
                let pixel = pixel_index(scene, x, y);
                if source.pixel_key.0 != pixel {
                    source.pixel_key = (pixel, Sampler::pixel_key(scene.settings.seed, pixel));
                }
                let kind = scene.settings.sampler;
                let sampler = Sampler::with_key(kind, source.pixel_key.1, u64::from(index));
                self.samplers.set(i, sampler);
                (film.0[i], film.1[i]) = (x as f32, y as f32);
                fresh_bits |= 1 << i;
            } else {
                let (sampler, ray) = camera_sample(scene, x, y, index);
                let mut path = Path::new(ray);
                if sums.wants_aovs() {
                    path.aov = Some(Box::default());
                }
                self.samplers.set(i, sampler);
                self.paths.put(i, path);
            }
        }
        if fresh_bits != 0 {
            let fresh = Mask::<W>::from_bits(fresh_bits);
            start_in_lanes(scene, fresh, film, &mut self.samplers, &mut self.paths);
        }
    }
}

/// Adds what the finished path of `lane` gives its
/// pixel, its radiance and its passes' record, to the pixel's sums. (Not the path itself: moving
/// a path assembled from the lanes copied it in 16-byte pieces, which waited for the narrower
/// stores that had just written it.)
fn finish(lane: &Lane, radiance: Rgb, aov: Option<&AovSample>, sums: &mut Sink) {
    sums.add(lane.pixel, lane.index, radiance, aov);
}

/// The next sample of the queue that traces a path in steps, as a lane and its pixel's
/// position in the image; `None` when the queue is empty. Samples that trace no path in steps
/// (the ray-cast preview's, or any with a depth of 0) are taken here whole.
#[inline(always)]
fn next_lane(
    scene: &Scene,
    (x0, y0): (u32, u32),
    queue: &mut impl Iterator<Item = (usize, u32)>,
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) -> Option<(Lane, (u32, u32))> {
    for (k, index) in queue {
        let (x, y) = (x0 + work[k].x, y0 + work[k].y);
        match scene.settings.integrator {
            IntegratorKind::Path if scene.settings.max_depth > 0 => {
                return Some((Lane { pixel: k, index }, (x, y)));
            }
            IntegratorKind::Path => sums.add(k, index, glam::Vec3::ZERO, None),
            IntegratorKind::Raycast => {
                let (mut sampler, ray) = camera_sample(scene, x, y, index);
                let value = raycast::radiance(scene, ray, &mut sampler, stats);
                sums.add(k, index, value, None);
            }
        }
    }
    None
}

/// Starts the samples of the `fresh` lanes, whose samplers are set (pixel (x, y) in the lanes
/// of `xy`), as [`camera_sample`] does one at a time, for all of them at once: the jitter,
/// the film position and the pinhole camera's ray (the lens point left out).
#[inline(always)]
fn start_in_lanes<const W: usize>(
    scene: &Scene,
    fresh: Mask<W>,
    xy: (F32s<W>, F32s<W>),
    samplers: &mut SamplerLanes<W>,
    paths: &mut PathLanes<W>,
) {
    let jitter = samplers.get_2d(fresh);
    samplers.skip_2d(fresh);
    crate::lanes::widest!(
        W,
        (scene: &Scene, fresh: Mask<W>, xy: (F32s<W>, F32s<W>), jitter: (F32s<W>, F32s<W>), paths: &mut PathLanes<W>) => (),
        (scene, fresh, xy, jitter, paths),
        start_here(scene, fresh, xy, jitter, paths)
    )
}

/// The arithmetic of [`start_in_lanes`], in every lane.
#[inline(always)]
fn start_here<const W: usize>(
    scene: &Scene,
    fresh: Mask<W>,
    (x, y): (F32s<W>, F32s<W>),
    (jx, jy): (F32s<W>, F32s<W>),
    paths: &mut PathLanes<W>,
) {
    let s = &scene.settings;
    let film = (
        (x + jx) / F32s::splat(s.width as f32),
        (y + jy) / F32s::splat(s.height as f32),
    );
    let d = scene.camera.pinhole_directions(film);
    paths.start(fresh, V3s::splat(scene.camera.position), d);
}

/// The sampler of sample `index` of pixel (x, y).
fn pixel_sampler(scene: &Scene, x: u32, y: u32, index: u32) -> Sampler {
    let s = &scene.settings;
    Sampler::with_kind(
        s.sampler,
        s.seed,
        pixel_index(scene, x, y),
        u64::from(index),
    )
}

/// Pixel (x, y)'s index in the image, row by row: what its samplers are keyed by.
fn pixel_index(scene: &Scene, x: u32, y: u32) -> u64 {
    u64::from(y) * u64::from(scene.settings.width) + u64::from(x)
}

/// Sample `index` of pixel (x, y): its sampler, and its camera ray through a jittered point of
/// the pixel (and of the lens).
fn camera_sample(scene: &Scene, x: u32, y: u32, index: u32) -> (Sampler, Ray) {
    let s = &scene.settings;
    let mut sampler = pixel_sampler(scene, x, y, index);
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
    (sampler, ray)
}
