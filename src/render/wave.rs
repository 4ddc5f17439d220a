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

/// Runs every sample of `work` in a wave of W lanes, refilling lanes as their paths end.
fn run_wave<const W: usize>(
    scene: &Scene,
    cancel: Option<&AtomicBool>,
    origin: (u32, u32),
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) {
    widest!(
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
#[inline(always)]
fn run_wave_here<const W: usize>(
    scene: &Scene,
    cancel: Option<&AtomicBool>,
    origin: (u32, u32),
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) {
    let mut queue = work
        .iter()
        .enumerate()
        .flat_map(|(k, w)| w.indices.clone().map(move |i| (k, i)));
    let mut lanes: [Option<Lane>; W] = std::array::from_fn(|_| None);
    let mut paths = Box::new(PathLanes::<W>::new());
    let mut samplers = Box::new(SamplerLanes::<W>::new());
    // The paths of the lanes off the Lambertian route, taken out of `paths` for the step.
    let mut off_route: [Option<Path>; W] = std::array::from_fn(|_| None);
    let mut hits: [Option<SurfaceHit>; W] = [None; W];
    let mut vertices: [Option<Vertex>; W] = std::array::from_fn(|_| None);
    let mut scratch = Box::new(Scratch::<W>::new());
    let mut route = Box::new(LambertRoute::<W>::new(scene));
    let mut surfaces = Box::new(SurfaceLanes::<W>::new());
    let mut found = Box::new(LaneSurfaces::<W>::none());
    let mut queue_empty = false;
    // The last pixel whose sampler key was derived, and the key: a pixel's samples mostly
    // follow one another.
    let mut pixel_key = (u64::MAX, 0);
    // Samples whose camera rays are drawn for all new lanes at once (the common case: Sobol
    // points through a pinhole, no render passes); the others one lane at a time.
    let in_lanes = W >= crate::lanes::KERNELS_FROM
        && scene.settings.sampler == SamplerKind::Sobol
        && scene.camera.lens_radius <= 0.0
        && !sums.wants_aovs();
    loop {
        if !queue_empty {
            // The lanes started in lanes, as bits (a mask written lane by lane and then read
            // four lanes at a time waits for its narrow stores).
            let mut fresh_bits = 0u64;
            let mut film = (F32s::<W>::default(), F32s::<W>::default());
            for i in Mask::<W>::from_bits(!occupied(&lanes)).iter() {
                let Some((lane, (x, y))) = next_lane(scene, origin, &mut queue, work, sums, stats)
                else {
                    queue_empty = true;
                    break;
                };
                let index = lane.index;
                lanes[i] = Some(lane);
                if in_lanes {
                    let pixel = pixel_index(scene, x, y);
                    if pixel_key.0 != pixel {
                        pixel_key = (pixel, Sampler::pixel_key(scene.settings.seed, pixel));
                    }
                    let kind = scene.settings.sampler;
                    samplers.set(i, Sampler::with_key(kind, pixel_key.1, u64::from(index)));
                    (film.0[i], film.1[i]) = (x as f32, y as f32);
                    fresh_bits |= 1 << i;
                } else {
                    let (sampler, ray) = camera_sample(scene, x, y, index);
                    let mut path = Path::new(ray);
                    if sums.wants_aovs() {
                        path.aov = Some(Box::default());
                    }
                    samplers.set(i, sampler);
                    paths.put(i, path);
                }
            }
            if fresh_bits != 0 {
                let fresh = Mask::<W>::from_bits(fresh_bits);
                start_in_lanes(scene, fresh, film, &mut samplers, &mut paths);
            }
        }
        let live = Mask::<W>::from_bits(occupied(&lanes));
        if !live.any() || cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return;
        }
        stats.rays += u64::from(live.count());
        scene.intersect_wave(&paths.rays(live), &mut hits, &mut surfaces, &mut found);
        let (ux, uy) = samplers.get_2d(live);
        let u_light: [_; W] = std::array::from_fn(|i| Vec2::new(ux[i], uy[i]));
        route.clear();
        // The hits kept in lanes that belong on the route stay there; the others' are taken
        // out lane by lane.
        let entered = route.enter_lanes(scene, &paths, &found, &u_light);
        // The lanes whose vertex takes the general route (`Path::shade`).
        let mut general_bits = 0u64;
        for i in live.and_not(entered).iter() {
            if found.in_lanes.lane(i) {
                // Left off the route by `enter_lanes`.
                hits[i] = Some(found.hit(i));
            } else if let Some(hit) = &hits[i] {
                if route.enter(i, scene, &paths, hit, u_light[i]) {
                    continue;
                }
            } else if scene.escapes_dark() && !paths.records_passes(i) {
                // Out of the scene, with nothing more to find.
                let (radiance, aov) = paths.end_escaped(i);
                finish(lanes[i].take(), radiance, aov.as_deref(), sums);
                continue;
            }
            let mut path = paths.take(i);
            if path.shade(scene, hits[i].as_ref(), &mut vertices[i]) {
                off_route[i] = Some(path);
                general_bits |= 1 << i;
            } else {
                finish(lanes[i].take(), path.radiance(), path.aov.as_deref(), sums);
            }
        }
        let general = Mask::<W>::from_bits(general_bits);
        if general_bits != 0 {
            Path::sample_lights(
                scene,
                off_route.each_ref().map(Option::as_ref),
                &hits,
                &mut vertices,
                &u_light,
                &mut scratch,
            );
        }
        let wave_hits = WaveHits {
            found: &found,
            hits: &hits,
        };
        route.sample_lights(scene, &paths, wave_hits, (ux, uy));
        // Only this step's vertices: a lane that is idle or whose path just ended traces none.
        let mut shadows = SegmentLanes::<W>::new();
        route.shadows(&mut shadows);
        for i in general.iter() {
            if let Some(shadow) = vertices[i].as_ref().and_then(|v| v.shadow) {
                shadows.set(i, &shadow.ray, shadow.t_max);
            }
        }
        stats.rays += u64::from(shadows.live.count());
        let blocked = scene.occluded_lanes(&shadows);
        let scattering = general | route.on_lanes();
        let u_scatter = samplers.get_choice_2d(scattering);
        let sampled = if general.any() {
            Path::sample_bsdfs(&vertices, &u_scatter, &mut scratch)
        } else {
            [None; W]
        };
        let ended_on_route = route.scatter(&u_scatter, &blocked, &mut paths, &mut samplers);
        for i in ended_on_route.iter() {
            let (radiance, aov) = paths.end(i);
            finish(lanes[i].take(), radiance, aov.as_deref(), sums);
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
            vertices[i] = None;
            if goes_on {
                paths.put(i, path);
            } else {
                finish(lanes[i].take(), path.radiance(), path.aov.as_deref(), sums);
            }
        }
    }
}

/// The lanes holding a sample, as bits (bit i: lane i).
#[inline(always)]
fn occupied<const W: usize>(lanes: &[Option<Lane>; W]) -> u64 {
    lanes
        .iter()
        .enumerate()
        .fold(0, |bits, (i, lane)| bits | (u64::from(lane.is_some()) << i))
}

/// Adds what the finished path of `lane` (taken from its slot, which is then free) gives its
/// pixel, its radiance and its passes' record, to the pixel's sums. (Not the path itself: moving
/// a path assembled from the lanes copied it in 16-byte pieces, which waited for the narrower
/// stores that had just written it.)
fn finish(lane: Option<Lane>, radiance: Rgb, aov: Option<&AovSample>, sums: &mut Sink) {
    if let Some(lane) = lane {
        sums.add(lane.pixel, lane.index, radiance, aov);
    }
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
