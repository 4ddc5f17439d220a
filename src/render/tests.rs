//! Tests of the pass loop on synthetic films with known means and variances.

use super::*;
use crate::sampler::mix64;

/// A synthetic film whose true pixel means and variances are known in closed form: the left
/// half is smooth (uniform values on [0.4, 0.6]), the right half heavy-tailed like a caustic
/// (value `BIG` with probability `P`, else `SMALL`). Every (pixel, sample index) has its own
/// hash-derived random number, as the renderer's samplers do.
const P: f64 = 0.05;
const BIG: f64 = 20.0;
const SMALL: f64 = 0.2;

fn uniform01(seed: u64, x: u32, y: u32, i: u32) -> f64 {
    (mix64(seed ^ mix64((u64::from(y) << 40) ^ (u64::from(x) << 20) ^ u64::from(i))) >> 11) as f64
        / (1u64 << 53) as f64
}

fn synthetic(
    width: u32,
    seed: u64,
) -> impl Fn(u32, u32, std::ops::Range<u32>, &mut TraceStats) -> PixelSum + Sync {
    move |x, y, range, _| {
        let mut acc = PixelSum::default();
        for i in range {
            let u = uniform01(seed, x, y, i);
            let v = if x < width / 2 {
                0.4 + 0.2 * u
            } else if u < P {
                BIG
            } else {
                SMALL
            };
            acc.add_sample(crate::math::Vec3::splat(v as f32));
        }
        acc
    }
}

/// A pass's sample function that takes each pixel of its work with `pixel(x, y, indices,
/// stats)`.
fn per_pixel(
    pixel: impl Fn(u32, u32, std::ops::Range<u32>, &mut TraceStats) -> PixelSum + Sync,
) -> impl Fn(&[PixelWork], &mut Sink, &mut TraceStats) + Sync {
    move |work, sums, stats| {
        for (w, sum) in work.iter().zip(sums.beauty.iter_mut()) {
            *sum = pixel(w.x, w.y, w.indices.clone(), stats);
        }
    }
}

/// (true mean, per-sample variance) of pixel column x.
fn truth(width: u32, x: u32) -> (f64, f64) {
    if x < width / 2 {
        (0.5, 0.04 / 12.0)
    } else {
        let m = P * BIG + (1.0 - P) * SMALL;
        (m, P * BIG * BIG + (1.0 - P) * SMALL * SMALL - m * m)
    }
}

/// (image mean − true mean) / its standard deviation, given the sample counts (which, when
/// they do not depend on the pixel's own samples, make the per-pixel means independent and
/// unbiased with variance σ²/n).
fn z_score(source: ErrorSource, seed: u64) -> (f64, Film) {
    let (w, h) = (64, 64);
    let plan = Plan {
        width: w,
        height: h,
        spp: 32,
        budget: None,
        seed,
    };
    let options = RenderOptions {
        adaptive: true,
        ..Default::default()
    };
    let (film, _, _) = run_passes(&plan, &options, source, per_pixel(synthetic(w, seed)));
    let sums = film.pixels();
    let n = sums.len() as f64;
    let (mut err, mut var) = (0.0, 0.0);
    for (i, p) in sums.iter().enumerate() {
        let (m, v) = truth(w, i as u32 % w);
        err += (p.mean().x - m) / n;
        var += v / f64::from(p.finite_samples()) / (n * n);
    }
    (err / var.sqrt(), film)
}

#[test]
fn own_sample_decisions_bias_the_mean_and_neighbour_decisions_do_not() {
    // Several seeds so that a chance pass of the biased rule cannot hide the effect.
    let (mut own, mut neighbours) = (0.0, 0.0);
    let seeds = [1, 2, 3, 4];
    for seed in seeds {
        let (z_own, _) = z_score(ErrorSource::Own, seed);
        let (z_nb, film) = z_score(ErrorSource::Neighbours, seed);
        let sums = film.pixels();
        eprintln!("seed {seed}: z own {z_own:+.2}, z neighbours {z_nb:+.2}");
        own += z_own;
        neighbours += z_nb;
        // Same budget, and the heavy-tailed half got more of it.
        let taken: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
        assert_eq!(taken, 64 * 64 * 32);
        let half = |right: bool| {
            sums.iter()
                .enumerate()
                .filter(|(i, _)| (i % 64 >= 32) == right)
                .map(|(_, p)| u64::from(p.taken()))
                .sum::<u64>()
        };
        assert!(
            half(true) > 2 * half(false),
            "right {} vs left {}",
            half(true),
            half(false)
        );
    }
    // Sums of independent unit normals over 4 seeds: divide by √4 for one unit normal.
    let (own, neighbours) = (own / 2.0, neighbours / 2.0);
    assert!(
        own < -5.0,
        "the own-sample rule should show its downward bias: z = {own:.2}"
    );
    assert!(
        neighbours.abs() < 3.0,
        "neighbour rule biased: z = {neighbours:.2}"
    );
}

#[test]
fn uniform_progressive_passes_take_the_same_samples_as_one_pass() {
    let plan = Plan {
        width: 20,
        height: 12,
        spp: 24,
        budget: None,
        seed: 5,
    };
    let (one, _, _) = run_passes(
        &plan,
        &RenderOptions::default(),
        ErrorSource::Neighbours,
        per_pixel(synthetic(20, 5)),
    );
    let (passes, _, _) = run_passes(
        &plan,
        &RenderOptions {
            target_rel_error: Some(0.0),
            ..Default::default()
        },
        ErrorSource::Neighbours,
        per_pixel(synthetic(20, 5)),
    );
    for (a, b) in one.pixels().iter().zip(passes.pixels()) {
        assert_eq!(a.finite_samples(), 24);
        assert_eq!(b.finite_samples(), 24);
        assert!((a.sum() - b.sum()).abs().max_element() < 1e-9);
    }
}

/// The pass sizes (spp) a schedule asks for when every sample takes `seconds_per_sample`.
fn pass_sizes(options: &RenderOptions, seconds_per_sample: f64) -> Vec<u32> {
    let plan = Plan {
        width: 10,
        height: 10,
        spp: 64,
        budget: None,
        seed: 1,
    };
    let film = Film::new(10, 10);
    let mut schedule = Schedule::new(&plan, options, 0);
    let mut sizes = Vec::new();
    while let Some(NextPass::Uniform(spp)) = schedule.next_pass() {
        sizes.push(spp);
        let samples = u64::from(spp) * 100;
        let seconds = samples as f64 * seconds_per_sample;
        schedule.record_pass(samples, Duration::from_secs_f64(seconds), &film);
    }
    sizes
}

/// A render that can only be interrupted measures its throughput on two samples per pixel, then
/// takes the rest in passes as long as `MAX_PASS_SECONDS` allows (one pass when it fits); a
/// render with a pass callback (checkpoints, the preview) doubles its passes.
#[test]
fn interruptible_renders_take_the_rest_in_passes_as_long_as_allowed() {
    use std::sync::atomic::AtomicBool;
    let cancel = AtomicBool::new(false);
    let cancel_only = RenderOptions {
        cancel: Some(&cancel),
        ..Default::default()
    };
    assert_eq!(pass_sizes(&cancel_only, 1e-6), [2, 62]);
    // 200 samples per second: 400 fit in a pass, 4 spp.
    let slow = pass_sizes(&cancel_only, 1.0 / 200.0);
    assert_eq!(slow.iter().sum::<u32>(), 64);
    let middle = &slow[1..slow.len() - 1];
    assert!(
        middle.iter().all(|&spp| spp == 4) && slow[slow.len() - 1] <= 4,
        "{slow:?}"
    );
    let callback = |_: &Film| {};
    let with_callback = RenderOptions {
        cancel: Some(&cancel),
        on_pass: Some(&callback),
        ..Default::default()
    };
    assert_eq!(pass_sizes(&with_callback, 1e-6), [2, 4, 8, 16, 32, 2]);
}

/// After a cancel, each thread finishes at most the tile it is on: at most one tile per thread is
/// sampled after the cancel, and the pass in flight is dropped (the film keeps whole passes
/// only). Counted, not timed.
#[test]
fn a_cancel_stops_every_thread_within_the_tile_it_is_on() {
    use std::collections::HashSet;
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
    use std::sync::Mutex;

    const THREADS: usize = 4;
    let (w, h) = (128u32, 96u32);
    let plan = Plan {
        width: w,
        height: h,
        spp: 64,
        budget: None,
        seed: 1,
    };
    let tile_of = |x: u32, y: u32| (y / TILE) * w.div_ceil(TILE) + x / TILE;
    for cancel_at in [1u64, 700, 5_000, 20_000] {
        let cancel = AtomicBool::new(false);
        let calls = AtomicU64::new(0);
        let after: Mutex<HashSet<u32>> = Mutex::new(HashSet::new());
        let sample = per_pixel(
            |x: u32, y: u32, range: std::ops::Range<u32>, stats: &mut TraceStats| {
                // Read the flag before counting: a call that saw no cancel came before it.
                if cancel.load(Ordering::SeqCst) {
                    after.lock().unwrap().insert(tile_of(x, y));
                }
                if calls.fetch_add(1, Ordering::SeqCst) + 1 == cancel_at {
                    cancel.store(true, Ordering::SeqCst);
                }
                synthetic(w, 1)(x, y, range, stats)
            },
        );
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(THREADS)
            .build()
            .unwrap();
        let options = RenderOptions {
            cancel: Some(&cancel),
            ..Default::default()
        };
        let (film, _, interrupted) =
            pool.install(|| run_passes(&plan, &options, ErrorSource::Neighbours, sample));
        assert!(interrupted, "cancel at call {cancel_at}: not interrupted");
        // Tiles sampled after the cancel: those in progress, and those a thread had already
        // taken (it checked the flag before the cancel) but not yet sampled when the cancel came,
        // which a preempted thread on a loaded machine does. Either way each thread is on one
        // tile, so there are at most as many as threads; a loop that kept taking tiles would
        // exceed that.
        let after = after.into_inner().unwrap();
        assert!(
            after.len() <= THREADS,
            "cancel at call {cancel_at}: {} tiles still sampled after it, more than {THREADS} \
             threads",
            after.len()
        );
        let pass_pixels = u64::from(w * h);
        assert_eq!(
            film.samples_taken() % pass_pixels,
            0,
            "cancel at call {cancel_at}: the film holds part of a pass"
        );
    }
}

/// A cancel stops a thread within the wave step it is on, not at the end of its tile: with the
/// flag already set, a pixel asked for a million samples finishes none of them (its sums are
/// dropped with the pass), at every lane width.
#[test]
fn a_cancel_stops_a_wave_within_a_step() {
    use std::sync::atomic::AtomicBool;
    let scene = crate::load::test_cornell();
    let work = [PixelWork {
        x: 100,
        y: 100,
        indices: 0..1_000_000,
    }];
    for width in crate::lanes::WIDTHS {
        let cancel = AtomicBool::new(true);
        let mut sums = [PixelSum::default()];
        let mut stats = TraceStats::default();
        render_pixels(
            &scene,
            (width, Some(&cancel)),
            (0, 0),
            &work,
            &mut Sink {
                beauty: &mut sums,
                aov: None,
            },
            &mut stats,
        );
        assert_eq!(
            sums[0].taken(),
            0,
            "W = {width}: samples finished after the cancel"
        );
        // Without the cancel the same wave does take samples.
        let mut sums = [PixelSum::default()];
        let work = [PixelWork {
            x: 100,
            y: 100,
            indices: 0..8,
        }];
        let mut sink = Sink {
            beauty: &mut sums,
            aov: None,
        };
        render_pixels(&scene, (width, None), (0, 0), &work, &mut sink, &mut stats);
        assert_eq!(sums[0].taken(), 8, "W = {width}");
    }
}
