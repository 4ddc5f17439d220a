//! Denoising with Open Image Denoise pays: at equal wall time (render + denoise) the denoised
//! Cornell box is at least twice as close to Mitsuba's 4096-spp reference as a render that
//! spent the denoising time on samples (relMSE, the visible lamp masked, three seeds), with the
//! image mean kept within 1 %; on a textured glTF asset under an HDR world (DamagedHelmet) the
//! filter takes out most of an 8-spp render's error with the mean kept within 1 %; and the
//! albedo and normal guides are used: a textured floor comes out closer to the reference with
//! them than without.
//!
//! Needs OIDN (`pip install pyoidn`; see README): from `LUMO_OIDN`, else the test environment
//! `tests/oidn/.venv`. Without it the tests print a loud SKIPPED message and pass, unless
//! `LUMO_REQUIRE_OIDN=1` (CI), which makes them fail.

mod common;
#[path = "support/helmet.rs"]
mod helmet;

use std::sync::Mutex;
use std::time::Instant;

use lumo::aov::AovSet;
use lumo::denoise::{Oidn, Prefilter};
use lumo::image::Image;
use lumo::job::{Hooks, JobSettings, RenderJob};

use helmet::Helmet;

/// One test at a time: the equal-time comparison must not share the cores with another test.
static SERIAL: Mutex<()> = Mutex::new(());

fn oidn() -> Option<Oidn> {
    let dir = common::oidn_dir()?;
    Some(Oidn::load_from(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())))
}

/// relMSE over the pixels where `keep` is true.
fn rel_mse(x: &Image, reference: &Image, keep: &[bool]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for ((p, r), k) in x.pixels.iter().zip(&reference.pixels).zip(keep) {
        if *k {
            let (p, r) = (p.as_dvec3(), r.as_dvec3());
            let d = p - r;
            sum += (d * d / (r * r + glam::DVec3::splat(lumo::image::REL_EPSILON))).element_sum();
            n += 3;
        }
    }
    sum / n as f64
}

fn cornell_job(spp: Option<u32>, time_s: Option<f32>, seed: u64, aovs: AovSet) -> RenderJob {
    let loaded = lumo::load(
        common::root().join("scenes/cornell.json"),
        &lumo::LoadOptions::default(),
    )
    .expect("scene loads");
    let mut loaded = loaded;
    loaded
        .edit(|s| s.render.seed = seed)
        .expect("seed override");
    RenderJob::new(
        &loaded,
        JobSettings {
            spp,
            time_s,
            aovs,
            ..Default::default()
        },
    )
    .expect("job")
}

#[test]
fn denoised_cornell_box_beats_equal_time_rendering() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let Some(mut oidn) = oidn() else { return };
    let reference =
        lumo::output::read_image(&common::root().join("tests/reference/cornell_mitsuba_4096.exr"))
            .expect("reference");
    // The visible lamp (radiance ≈ 18) is left out: the filter softens its edge, which the
    // error of a handful of pixels would decide; the mean check keeps it.
    let keep: Vec<bool> = reference
        .pixels
        .iter()
        .map(|p| p.max_element() < 2.0)
        .collect();
    let guides: AovSet = "albedo,normal".parse().expect("names");
    let mut rows = Vec::new();
    for seed in 1..=3u64 {
        // Building the scene is left out of the clock, as the time budget leaves it out.
        let noisy_job = cornell_job(Some(16), None, seed, guides);
        let start = Instant::now();
        let noisy = noisy_job.run(&Hooks::default()).expect("renders");
        let denoised = noisy.denoised(&mut oidn).expect("denoises");
        let spent = start.elapsed().as_secs_f32();
        let equal_time = cornell_job(None, Some(spent), seed + 100, AovSet::NONE)
            .run(&Hooks::default())
            .expect("renders");
        let e_noisy = rel_mse(&noisy.image, &reference, &keep);
        let e_denoised = rel_mse(&denoised, &reference, &keep);
        let e_equal = rel_mse(&equal_time.image, &reference, &keep);
        eprintln!(
            "seed {seed}: 16 spp relMSE {e_noisy:.5}, denoised {e_denoised:.5} ({spent:.2} s in \
             all), equal time ({} spp) {e_equal:.5}",
            equal_time.stats.spp
        );
        let (m, r) = (denoised.mean(), reference.mean());
        assert!(
            ((m - r) / r).abs().max_element() < 0.01,
            "seed {seed}: denoised mean {m} vs reference {r}"
        );
        rows.push((e_denoised, e_equal));
    }
    for (seed, (d, e)) in rows.iter().enumerate() {
        assert!(
            *d <= 0.5 * e,
            "seed {}: denoised relMSE {d} is not at most half the equal-time render's {e}",
            seed + 1
        );
    }
}

/// A checkered floor in soft light: the texture's edges are what a denoiser without the
/// albedo guide blurs.
const TEXTURED: &str = r#"{
  "format_version": 2,
  "image": {"width": 64, "height": 64},
  "render": {"integrator": "path", "spp": 4, "max_depth": 3, "seed": 1},
  "camera": {"position": [0, 2.2, 2.2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 50},
  "background": {"color": [0.05, 0.05, 0.05]},
  "textures": {"checks": {"file": "checks.png"}},
  "materials": {
    "floor": {"base_color": [1, 1, 1], "base_color_texture": {"texture": "checks"}, "specular": 0},
    "ball": {"base_color": [0.6, 0.6, 0.6], "specular": 0},
    "lamp": {"base_color": [0, 0, 0], "emission": [6, 6, 6]}
  },
  "objects": [
    {"plane": {"material": "floor", "normal": [0, 1, 0], "offset": 0}},
    {"sphere": {"material": "ball", "center": [0.3, 0.4, 0], "radius": 0.4}},
    {"sphere": {"material": "lamp", "center": [-1, 2, -0.5], "radius": 0.5}}
  ]
}"#;

#[test]
fn albedo_and_normal_guides_are_used() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let Some(mut oidn) = oidn() else { return };
    let dir = tempfile::tempdir().expect("temp dir");
    // 4 × 4 checks of 16 texels, light and dark.
    let checks = image::RgbImage::from_fn(64, 64, |x, y| {
        if (x / 16 + y / 16) % 2 == 0 {
            image::Rgb([230, 220, 200])
        } else {
            image::Rgb([40, 60, 90])
        }
    });
    checks.save(dir.path().join("checks.png")).expect("texture");
    let scene = dir.path().join("textured.json");
    std::fs::write(&scene, TEXTURED).expect("scene");
    let loaded = lumo::load(&scene, &lumo::LoadOptions::default()).expect("loads");
    let run = |spp: u32, seed: u64, aovs: &str| {
        let mut loaded = loaded.clone();
        loaded.edit(|s| s.render.seed = seed).expect("seed");
        RenderJob::new(
            &loaded,
            JobSettings {
                spp: Some(spp),
                aovs: aovs.parse().expect("names"),
                ..Default::default()
            },
        )
        .expect("job")
        .run(&Hooks::default())
        .expect("renders")
    };
    let reference = run(256, 99, "").image;
    let keep = vec![true; reference.pixels.len()];
    let (mut with, mut without) = (0.0, 0.0);
    for seed in 1..=3 {
        let noisy = run(4, seed, "albedo,normal");
        let guided = noisy.denoised(&mut oidn).expect("denoises");
        let plain = oidn
            .denoise(&noisy.image, None, None, Prefilter::Clean)
            .expect("denoises");
        let (g, p) = (
            rel_mse(&guided, &reference, &keep),
            rel_mse(&plain, &reference, &keep),
        );
        eprintln!("seed {seed}: relMSE with guides {g:.5}, colour only {p:.5}");
        with += g;
        without += p;
    }
    assert!(
        with < 0.8 * without,
        "the guides do not help: relMSE {with} with albedo and normal, {without} without"
    );
}

/// A textured glTF asset under an HDR world: DamagedHelmet (base colour, normal, metal/rough and
/// emissive textures) lit by `studio.exr`, 256², 8 spp, against lumo's own 1024-spp render of it
/// (`tests/reference/damaged_helmet_studio_1024.exr`, with its standard error; see that folder's
/// README). The error is taken over the pixels the helmet covers (the first sample's
/// `object_id`): the sky around it is noise free and would only dilute the figure. The
/// reference's own variance is subtracted, so the figure estimates the error against the
/// converged image.
///
/// What it asserts is what holds on any machine: the filter, guided by the albedo and normal,
/// takes out at least 70 % of the 8-spp render's error over the textured helmet (measured
/// 80–86 %: 0.102–0.124 → 0.018–0.021) in each of three seeds, and keeps the image's mean
/// within 1 %. It is not an equal-time comparison, which depends on the machine's load and here
/// on a few pixels: relMSE over the helmet is decided by the rare bright samples of paths that
/// find `studio.exr`'s small lamps, which the filter removes, so an equal-time render (15–22
/// spp) scores anywhere from 0.018 to 0.082 with the same seeds, and with the worst 0.1 % of
/// pixels left out both score 0.012–0.015. docs/passes.md has the measurements.
#[test]
fn denoising_a_textured_asset_removes_most_of_its_error() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let Some(shared) = common::shared() else {
        return;
    };
    let Some(mut oidn) = oidn() else { return };
    const SPP: u32 = 8;
    let helmet_scene = Helmet::new(
        &shared,
        &common::root().join("tests/reference/damaged_helmet_studio_1024.exr"),
    );
    let reference = &helmet_scene.reference;
    for seed in 1..=3u64 {
        let noisy = helmet_scene
            .job(Some(SPP), None, seed, "albedo,normal,object_id", 8)
            .run(&Hooks::default())
            .expect("renders");
        let denoised = noisy.denoised(&mut oidn).expect("denoises");
        let ids = noisy
            .passes()
            .into_iter()
            .find(|p| p.aov == lumo::aov::Aov::ObjectId)
            .expect("ids");
        let lumo::aov::PassPixels::Id(ids) = ids.pixels else {
            panic!("ids are integers")
        };
        let helmet: Vec<bool> = ids.iter().map(|&id| id != 0).collect();
        let covered = helmet.iter().filter(|&&h| h).count();
        assert!(covered > 8000, "the helmet covers {covered} pixels");
        let e_noisy = helmet_scene.rel_mse(&noisy.image, &helmet);
        let e_denoised = helmet_scene.rel_mse(&denoised, &helmet);
        // The filter takes out some of the bright outliers' energy: the helmet's mean drops by
        // 0.6–3.1 % (measured); the image's mean, as for the Cornell box, stays within 1 %.
        let mean_over = |img: &Image| {
            img.pixels
                .iter()
                .zip(&helmet)
                .filter(|(_, &h)| h)
                .map(|(p, _)| p.as_dvec3())
                .sum::<glam::DVec3>()
                / covered as f64
        };
        let (mh, rh) = (mean_over(&denoised), mean_over(reference));
        eprintln!(
            "DamagedHelmet seed {seed}: {SPP} spp relMSE {e_noisy:.5}, denoised {e_denoised:.5}; \
             helmet mean {:+.2} % (denoised against reference)",
            100.0 * ((mh - rh) / rh).element_sum() / 3.0
        );
        assert!(
            e_denoised <= 0.3 * e_noisy,
            "seed {seed}: denoised relMSE {e_denoised:.5} is not at most 0.3× the noisy {e_noisy:.5}"
        );
        let (m, r) = (denoised.mean(), reference.mean());
        assert!(
            ((m - r) / r).abs().max_element() < 0.01,
            "seed {seed}: denoised mean {m} vs reference {r}"
        );
    }
}
