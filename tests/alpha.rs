//! Alpha (glTF `alphaMode`): cut-away parts of a `mask` surface are invisible to camera and
//! shadow rays alike, and a `blend` surface of alpha a lets 1 − a of the light through.

mod common;

use lumo::math::{Ray, Vec3};

/// A floor (y = 0) under a 2 × 2 quad at y = 1 whose material is `material` (JSON), with a
/// texture `cut` whose left half has alpha 0 and right half alpha 1, and an emissive floor so
/// that a render through the quad shows what it lets through.
fn alpha_scene(material: &str) -> (tempfile::TempDir, lumo::scene::Scene) {
    let dir = tempfile::tempdir().unwrap();
    let mut img = image::RgbaImage::new(8, 1);
    for x in 0..8 {
        img.put_pixel(
            x,
            0,
            image::Rgba([255, 255, 255, if x < 4 { 0 } else { 255 }]),
        );
    }
    img.save(dir.path().join("cut.png")).unwrap();
    let text = format!(
        r#"{{"format_version": 2,
        "image": {{"width": 32, "height": 32}},
        "render": {{"spp": 64, "max_depth": 4, "seed": 1}},
        "camera": {{"position": [0, 3, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "fov_y_deg": 20}},
        "textures": {{"cut": {{"file": "cut.png", "color_space": "linear", "wrap_s": "clamp", "wrap_t": "clamp"}}}},
        "materials": {{
            "floor": {{"base_color": [0, 0, 0], "specular": 0, "emission": [1, 1, 1]}},
            "quad": {material}
        }},
        "objects": [
            {{"plane": {{"material": "floor", "normal": [0, 1, 0], "offset": 0}}}},
            {{"mesh": {{"material": "quad", "source": {{"inline": {{
                "positions": [[-1, 1, 1], [1, 1, 1], [1, 1, -1], [-1, 1, -1]],
                "uvs": [[0, 0], [1, 0], [1, 1], [0, 1]],
                "indices": [[0, 1, 2], [0, 2, 3]]}}}}}}}}
        ]}}"#
    );
    let path = dir.path().join("alpha.json");
    std::fs::write(&path, text).unwrap();
    let desc = common::load_scene(&path);
    let scene = common::build(&desc, dir.path());
    (dir, scene)
}

/// The fraction of vertical rays from the floor at `x` (z spread over the quad) that reach
/// y = 2 unblocked, by shadow-ray queries and by closest-hit queries.
fn passing(scene: &lumo::scene::Scene, x: f32, n: usize) -> (f64, f64) {
    let (mut shadow, mut camera) = (0usize, 0usize);
    for i in 0..n {
        let z = -0.9 + 1.8 * (i as f32 + 0.5) / n as f32;
        let ray = Ray::new(Vec3::new(x, 1e-3, z), Vec3::Y);
        shadow += usize::from(!scene.occluded(&ray, 0.0, 2.0));
        camera += usize::from(scene.intersect(&ray, 0.0, 2.0).is_none());
    }
    (shadow as f64 / n as f64, camera as f64 / n as f64)
}

#[test]
fn mask_cut_outs_let_camera_and_shadow_rays_through() {
    let mask = r#"{"base_color_texture": {"texture": "cut"}, "alpha_mode": "mask"}"#;
    let (_dir, scene) = alpha_scene(mask);
    // Under the cut-away left half everything passes; under the right half nothing does.
    assert_eq!(passing(&scene, -0.5, 200), (1.0, 1.0));
    assert_eq!(passing(&scene, 0.5, 200), (0.0, 0.0));
    // The same quad opaque blocks both halves: the texture's alpha only counts with a mode.
    let (_dir, opaque) = alpha_scene(r#"{"base_color_texture": {"texture": "cut"}}"#);
    assert_eq!(passing(&opaque, -0.5, 200), (0.0, 0.0));
}

#[test]
fn blend_at_one_half_transmits_half() {
    let blend = r#"{"base_color": [0, 0, 0], "specular": 0, "alpha": 0.5, "alpha_mode": "blend"}"#;
    let (_dir, scene) = alpha_scene(blend);
    let n = 20_000;
    for x in [-0.5, 0.5] {
        let (shadow, camera) = passing(&scene, x, n);
        // Binomial: σ = √(0.25 / n) ≈ 0.0035; 4σ.
        let tol = 4.0 * (0.25 / n as f64).sqrt();
        assert!((shadow - 0.5).abs() < tol, "shadow rays: {shadow}");
        assert!((camera - 0.5).abs() < tol, "camera rays: {camera}");
    }
    // Rendered from above through the black half-transparent quad, the white emitting floor
    // (radiance 1) reads 0.5.
    let image = common::render(&scene);
    let mean = image.mean();
    let n_samples = f64::from(image.width * image.height * 64);
    let tol = 4.0 * (0.25 / n_samples).sqrt();
    for c in mean.to_array() {
        assert!((f64::from(c) - 0.5).abs() < tol, "mean radiance {mean:?}");
    }
}

/// Rays pass ten stacked blended quads of alpha 0.2 with probability 0.8¹⁰, and both surfaces
/// of a blended sphere of alpha 0.5 with probability 0.25: every layer decides on its own
/// (meshes skip their transparent hits within one traversal, other shapes are asked again past
/// each), for shadow rays and closest-hit rays alike.
#[test]
fn stacked_layers_and_blended_spheres_transmit_the_product() {
    let dir = tempfile::tempdir().unwrap();
    let quads: Vec<String> = (0..10)
        .map(|k| {
            let y = 1.0 + 0.1 * k as f32;
            format!(
                r#"{{"mesh": {{"material": "leaf", "source": {{"inline": {{
                "positions": [[-1, {y}, 1], [1, {y}, 1], [1, {y}, -1], [-1, {y}, -1]],
                "indices": [[0, 1, 2], [0, 2, 3]]}}}}}}}}"#
            )
        })
        .collect();
    let text = format!(
        r#"{{"format_version": 2,
        "camera": {{"position": [0, 9, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "fov_y_deg": 30}},
        "materials": {{
            "leaf": {{"alpha": 0.2, "alpha_mode": "blend"}},
            "glass": {{"alpha": 0.5, "alpha_mode": "blend"}}
        }},
        "objects": [{}, {{"sphere": {{"material": "glass", "center": [5, 1.5, 0], "radius": 0.5}}}}]}}"#,
        quads.join(", ")
    );
    let path = dir.path().join("layers.json");
    std::fs::write(&path, text).unwrap();
    let scene = common::build(&common::load_scene(&path), dir.path());
    let n = 20_000;
    for (x, expected) in [(0.0f32, 0.8f64.powi(10)), (5.0, 0.25)] {
        let (mut shadow, mut camera) = (0usize, 0usize);
        for i in 0..n {
            let z = -0.3 + 0.6 * (i as f32 + 0.5) / n as f32;
            let ray = Ray::new(Vec3::new(x + 0.1 * (z * 7.0).sin(), 0.5, z), Vec3::Y);
            shadow += usize::from(!scene.occluded(&ray, 0.0, 3.0));
            camera += usize::from(scene.intersect(&ray, 0.0, 3.0).is_none());
        }
        let tol = 4.0 * (expected * (1.0 - expected) / n as f64).sqrt();
        for (name, passed) in [("shadow", shadow), ("camera", camera)] {
            let p = passed as f64 / n as f64;
            assert!(
                (p - expected).abs() < tol,
                "x {x}, {name} rays: {p} vs {expected}"
            );
        }
    }
}
