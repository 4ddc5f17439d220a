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
use crate::geometry::mesh::SurfaceLanes;
use crate::geometry::SurfaceHit;
use crate::integrator::path::{LambertRoute, Path, Scratch, Vertex};
use crate::integrator::{raycast, TraceStats};
use crate::math::{Ray, Vec2};
use crate::sampler::Sampler;
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

/// A lane's path: the path, its sampler, the entry of the work it is a sample of, and the
/// sample's index.
struct Lane {
    path: Path,
    sampler: Sampler,
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
    let mut queue = work
        .iter()
        .enumerate()
        .flat_map(|(k, w)| w.indices.clone().map(move |i| (k, i)));
    let mut lanes: [Option<Lane>; W] = std::array::from_fn(|_| None);
    let mut rays: [Option<Ray>; W] = [None; W];
    let mut hits: [Option<SurfaceHit>; W] = [None; W];
    let mut vertices: [Option<Vertex>; W] = std::array::from_fn(|_| None);
    let mut scratch = Box::new(Scratch::<W>::new());
    let mut route = Box::new(LambertRoute::<W>::new());
    let mut surfaces = Box::new(SurfaceLanes::<W>::new());
    loop {
        for (lane, ray) in lanes.iter_mut().zip(&mut rays) {
            if lane.is_none() {
                *lane = next_lane(scene, origin, &mut queue, work, sums, stats);
            }
            *ray = lane.as_ref().map(|l| l.path.ray);
        }
        let traced = rays.iter().flatten().count();
        if traced == 0 || cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return;
        }
        stats.rays += traced as u64;
        scene.intersect_lanes(&rays, &mut hits, &mut surfaces);
        let u_light: [_; W] =
            Sampler::get_2d_lanes(lanes.each_mut().map(|l| l.as_mut().map(|l| &mut l.sampler)));
        route.clear();
        for i in 0..W {
            let Some(lane) = &mut lanes[i] else { continue };
            if let Some(hit) = &hits[i] {
                if route.enter(i, scene, &lane.path, hit, u_light[i]) {
                    continue;
                }
            }
            if !lane.path.shade(scene, hits[i].as_ref(), &mut vertices[i]) {
                finish(&mut lanes[i], sums);
            }
        }
        Path::sample_lights(
            scene,
            lanes.each_ref().map(|l| l.as_ref().map(|l| &l.path)),
            &hits,
            &mut vertices,
            &u_light,
            &mut scratch,
        );
        route.sample_lights(
            scene,
            lanes.each_ref().map(|l| l.as_ref().map(|l| &l.path)),
            &hits,
        );
        // Only this step's vertices: a lane that is idle or whose path just ended traces none.
        let shadows: [Option<(Ray, f32)>; W] = std::array::from_fn(|i| {
            let shadow = if route.is_on(i) {
                route.shadow(i)
            } else {
                vertices[i].as_ref().and_then(|v| v.shadow)
            };
            shadow.map(|s| (s.ray, s.t_max))
        });
        stats.rays += shadows.iter().flatten().count() as u64;
        let blocked = scene.occluded_lanes(&shadows);
        let mut scattering =
            lanes
                .iter_mut()
                .zip(&vertices)
                .enumerate()
                .map(
                    |(i, (lane, vertex))| match (lane, vertex.is_some() || route.is_on(i)) {
                        (Some(lane), true) => Some(&mut lane.sampler),
                        _ => None,
                    },
                );
        let u_scatter: [_; W] =
            Sampler::get_choice_2d_lanes(std::array::from_fn(|_| scattering.next().flatten()));
        let sampled = Path::sample_bsdfs(&vertices, &u_scatter, &mut scratch);
        let sampled_on_route = route.sample_bsdfs(&u_scatter);
        for i in 0..W {
            if route.is_on(i) {
                let (Some(lane), Some(hit)) = (&mut lanes[i], &hits[i]) else {
                    continue;
                };
                let shadow = (route.shadow(i), !blocked[i]);
                if !lane
                    .path
                    .scatter_lambert(hit, shadow, sampled_on_route[i], &mut lane.sampler)
                {
                    finish(&mut lanes[i], sums);
                }
                continue;
            }
            let (Some(vertex), Some(lane), Some(hit)) = (&vertices[i], &mut lanes[i], &hits[i])
            else {
                continue;
            };
            let goes_on = lane.path.scatter(
                scene,
                hit,
                vertex,
                !blocked[i],
                sampled[i],
                &mut lane.sampler,
                stats,
            );
            vertices[i] = None;
            if !goes_on {
                finish(&mut lanes[i], sums);
            }
        }
    }
}

/// Adds the lane's finished path to its pixel's sums and frees the lane.
fn finish(lane: &mut Option<Lane>, sums: &mut Sink) {
    if let Some(lane) = lane.take() {
        let aov = lane.path.aov.as_deref();
        sums.add(lane.pixel, lane.index, lane.path.radiance(), aov);
    }
}

/// The next sample of the queue as a lane, its camera ray drawn; `None` when the queue is
/// empty. Samples that trace no path in steps (the ray-cast preview's, or any with a depth of
/// 0) are taken here whole.
fn next_lane(
    scene: &Scene,
    (x0, y0): (u32, u32),
    queue: &mut impl Iterator<Item = (usize, u32)>,
    work: &[PixelWork],
    sums: &mut Sink,
    stats: &mut TraceStats,
) -> Option<Lane> {
    for (k, index) in queue {
        let (mut sampler, ray) = camera_sample(scene, x0 + work[k].x, y0 + work[k].y, index);
        match scene.settings.integrator {
            IntegratorKind::Path if scene.settings.max_depth > 0 => {
                let mut path = Path::new(ray);
                if sums.wants_aovs() {
                    path.aov = Some(Box::default());
                }
                return Some(Lane {
                    path,
                    sampler,
                    pixel: k,
                    index,
                });
            }
            IntegratorKind::Path => sums.add(k, index, glam::Vec3::ZERO, None),
            IntegratorKind::Raycast => {
                let value = raycast::radiance(scene, ray, &mut sampler, stats);
                sums.add(k, index, value, None);
            }
        }
    }
    None
}

/// Sample `index` of pixel (x, y): its sampler, and its camera ray through a jittered point of
/// the pixel (and of the lens).
fn camera_sample(scene: &Scene, x: u32, y: u32, index: u32) -> (Sampler, Ray) {
    let s = &scene.settings;
    let pixel = u64::from(y) * u64::from(s.width) + u64::from(x);
    let mut sampler = Sampler::with_kind(s.sampler, s.seed, pixel, u64::from(index));
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
