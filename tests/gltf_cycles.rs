//! glTF sample models render as Blender Cycles renders them (issue 12).
//!
//! The references in `tests/data/cycles_gltf/` were made by `benches/peers/cycles_gltf.py`
//! (Blender 5.0.1, 2048 spp, lumo's camera, a constant grey 0.5 world as the only light; see
//! that folder's README for every setting). Each has a mean image and the per-pixel variance of
//! that mean, from 8 independent passes.
//!
//! lumo renders each model twice with different seeds under the same camera and light
//! (`max_depth` 8 = Cycles' 6 bounces). With m the mean of the two renders, c the Cycles mean,
//! and the variances v_m = (a − b)²/4 (per pixel, from the two renders) and v_c (the file):
//!
//! - **noise ratio** R = mean (m − c)² / mean (v_m + v_c). For two unbiased estimates of the
//!   same image R ≈ 1 (± a few % over 16k pixels); a systematic difference of the size of the
//!   noise doubles it. Each model's bound is stated with its measured value.
//! - **mean difference**: |mean(m) − mean(c)| / mean(c) over the image, which catches a global
//!   loss of energy (a single-scattering GGX lobe's few percent) that R might dilute.
//!
//! `LUMO_CYCLES_OUT=dir` writes each lumo mean as `dir/<model>.exr` for inspection.

mod common;

use lumo::image::Image;
use lumo::LoadOptions;
use serde_json::Value;

const SIZE: u32 = 128;
const SPP: u32 = 64;

/// A model, the largest noise ratio R and relative mean difference it must stay within.
struct Case {
    name: &'static str,
    max_ratio: f64,
    max_mean_diff: f64,
}

const CASES: &[Case] = &[
    // Measured at 64 spp (lumo) against 2048 spp (Cycles), 2026-11-29: R = 1.65, 0.08 %.
    Case {
        name: "MetalRoughSpheresNoTextures",
        max_ratio: 2.0,
        max_mean_diff: 0.01,
    },
    // R = 1.13, 0.07 %.
    Case {
        name: "AlphaBlendModeTest",
        max_ratio: 1.5,
        max_mean_diff: 0.01,
    },
    // R = 1.62, 0.03 %.
    Case {
        name: "DamagedHelmet",
        max_ratio: 2.0,
        max_mean_diff: 0.01,
    },
    // R = 1.12, 0.01 %.
    Case {
        name: "GlassVaseFlowers",
        max_ratio: 1.5,
        max_mean_diff: 0.01,
    },
];

fn reference(name: &str, suffix: &str) -> Image {
    let path = common::root().join(format!("tests/data/cycles_gltf/{name}{suffix}.exr"));
    lumo::output::read_image(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn render(path: &std::path::Path, camera: &Value, seed: u64) -> Image {
    let mut inp = lumo::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    inp.edit(|s| {
        s.image.width = SIZE;
        s.image.height = SIZE;
        s.render.spp = SPP;
        s.render.seed = seed;
        s.render.max_depth = 8;
        s.background.color = [0.5; 3];
        s.lights.clear();
        let close = |a: [f32; 3], b: &Value| {
            (0..3).all(|k| (f64::from(a[k]) - b[k].as_f64().unwrap()).abs() < 1e-6)
        };
        assert!(
            close(s.camera.position, &camera["position"])
                && close(s.camera.look_at, &camera["look_at"])
                && close(s.camera.up, &camera["up"])
                && (f64::from(s.camera.fov_y_deg) - camera["fov_y_deg"].as_f64().unwrap()).abs()
                    < 1e-6,
            "{}: lumo's camera {:?} is not the one the reference used ({camera})",
            path.display(),
            s.camera
        );
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let (scene, _) = inp.build().unwrap_or_else(|e| panic!("{e}"));
    common::render(&scene)
}

/// (noise ratio R, relative mean difference) of lumo's renders `a`, `b` against the Cycles
/// mean `c` with variance `vc`.
fn compare(a: &Image, b: &Image, c: &Image, vc: &Image) -> (f64, f64) {
    let (mut err, mut var) = (0.0f64, 0.0f64);
    let (mut sum_m, mut sum_c) = (0.0f64, 0.0f64);
    for i in 0..a.pixels.len() {
        for k in 0..3 {
            let (a, b) = (f64::from(a.pixels[i][k]), f64::from(b.pixels[i][k]));
            let (c, vc) = (f64::from(c.pixels[i][k]), f64::from(vc.pixels[i][k]));
            let m = 0.5 * (a + b);
            err += (m - c) * (m - c);
            var += 0.25 * (a - b) * (a - b) + vc;
            sum_m += m;
            sum_c += c;
        }
    }
    (
        err / var.max(1e-30),
        (sum_m - sum_c).abs() / sum_c.max(1e-30),
    )
}

#[test]
fn gltf_samples_match_cycles() {
    let Some(shared) = common::shared() else {
        return;
    };
    let meta: Value = serde_json::from_str(
        &std::fs::read_to_string(common::root().join("tests/data/cycles_gltf/cameras.json"))
            .unwrap(),
    )
    .unwrap();
    let out = std::env::var_os("LUMO_CYCLES_OUT").map(std::path::PathBuf::from);
    let mut failures = Vec::new();
    for case in CASES {
        let model = &meta["models"][case.name];
        let path = shared.join("gltf").join(model["gltf"].as_str().unwrap());
        let (a, b) = (
            render(&path, &model["camera"], 1),
            render(&path, &model["camera"], 2),
        );
        let (c, vc) = (reference(case.name, ""), reference(case.name, ".var"));
        let (ratio, mean_diff) = compare(&a, &b, &c, &vc);
        eprintln!(
            "{}: noise ratio R = {ratio:.3} (bound {}), mean difference {:.2} % (bound {} %)",
            case.name,
            case.max_ratio,
            100.0 * mean_diff,
            100.0 * case.max_mean_diff
        );
        if let Some(dir) = &out {
            let mean = Image {
                pixels: a
                    .pixels
                    .iter()
                    .zip(&b.pixels)
                    .map(|(x, y)| 0.5 * (*x + *y))
                    .collect(),
                ..a.clone()
            };
            std::fs::create_dir_all(dir).unwrap();
            lumo::output::write_image(
                &mean,
                &dir.join(format!("{}.exr", case.name)),
                lumo::output::ToneMap::Clamp,
            )
            .unwrap();
        }
        if ratio > case.max_ratio || mean_diff > case.max_mean_diff {
            failures.push(format!(
                "{}: R = {ratio:.3}, mean difference {:.2} %",
                case.name,
                100.0 * mean_diff
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
