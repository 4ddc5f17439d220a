//! The environment as a light: an HDR image lights the scene, importance-sampled and combined
//! with BSDF sampling by MIS, and a constant one keeps the white furnace exact in the mean.

mod common;

use lumo::image::Image;

/// A grey diffuse sphere on a grey diffuse floor under `background` (JSON), 32², `spp`.
fn scene(dir: &std::path::Path, background: &str, spp: u32, seed: u64) -> lumo::scene::Scene {
    let text = format!(
        r#"{{"format_version": 2,
        "image": {{"width": 32, "height": 32}},
        "render": {{"spp": {spp}, "max_depth": 4, "seed": {seed}}},
        "camera": {{"position": [0, 1.2, 4], "look_at": [0, 0.6, 0], "fov_y_deg": 40}},
        "background": {background},
        "materials": {{"grey": {{"base_color": [0.6, 0.6, 0.6], "specular": 0}}}},
        "objects": [
            {{"sphere": {{"material": "grey", "center": [0, 0.6, 0], "radius": 0.6}}}},
            {{"plane": {{"material": "grey", "normal": [0, 1, 0], "offset": 0}}}}
        ]}}"#
    );
    let path = dir.join("env.json");
    std::fs::write(&path, text).unwrap();
    common::build(&common::load_scene(&path), dir)
}

/// The same scene with the environment reached by BSDF sampling only.
fn without_environment_sampling(mut scene: lumo::scene::Scene) -> lumo::scene::Scene {
    let i = scene.environment_light.take().unwrap();
    scene.lights.remove(i);
    scene.light_sampler = lumo::light::LightSampler::new(&scene.lights);
    scene
}

fn rmse(a: &Image, b: &Image) -> f64 {
    a.rmse(b)
}

/// Light sampling pays under a real HDR sky with a sun 70,000 times its mean: at equal spp the
/// error against a high-sample reference is at least 5× lower with environment sampling + MIS
/// than with BSDF sampling alone.
#[test]
fn environment_sampling_beats_bsdf_sampling_under_a_sun() {
    let Some(shared) = common::shared() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let sky = shared.join("hdri/sunrise.exr");
    // Invisible to the camera: the error measured is that of the lighting, not of the sun's
    // texels seen directly.
    let bg = format!(r#"{{"image": "{}", "visible": false}}"#, sky.display());
    let reference = common::render(&scene(dir.path(), &bg, 2048, 99));
    let spp = 16;
    let (mut with, mut without) = (0.0, 0.0);
    for seed in 1..=2 {
        with += rmse(
            &common::render(&scene(dir.path(), &bg, spp, seed)),
            &reference,
        );
        without += rmse(
            &common::render(&without_environment_sampling(scene(
                dir.path(),
                &bg,
                spp,
                seed,
            ))),
            &reference,
        );
    }
    let factor = without / with;
    eprintln!(
        "RMSE at {spp} spp: {:.4} with environment sampling, {:.4} without: ÷ {factor:.1}",
        with / 2.0,
        without / 2.0
    );
    assert!(
        factor >= 5.0,
        "environment sampling lowers the RMSE only {factor:.2}×"
    );
}

/// White furnace: a white diffuse sphere inside a constant environment L reflects exactly L
/// (in the mean: with light sampling each sample is no longer exactly L).
#[test]
fn constant_environment_white_furnace() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{"format_version": 2,
        "image": {"width": 16, "height": 16},
        "render": {"spp": 256, "max_depth": 64, "seed": 3},
        "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "fov_y_deg": 20},
        "background": {"color": [0.5, 0.5, 0.5]},
        "materials": {"white": {"base_color": [1, 1, 1], "specular": 0}},
        "objects": [{"sphere": {"material": "white", "radius": 1}}]}"#;
    let path = dir.path().join("furnace.json");
    std::fs::write(&path, text).unwrap();
    let scene = common::build(&common::load_scene(&path), dir.path());
    let image = common::render(&scene);
    let mean = image.mean();
    // 16² pixels × 256 spp; the per-sample spread is below 0.5 (MIS weights in [0, 1]).
    let tol = 4.0 * 0.5 / (16.0f32 * 16.0 * 256.0).sqrt();
    for c in mean.to_array() {
        assert!((c - 0.5).abs() < tol, "mean {mean:?}");
    }
}
