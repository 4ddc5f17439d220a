//! Renderer tests with closed-form answers, determinism and convergence.

mod common;

use lumo::math::Vec3;
use lumo::render::Image;
use std::path::Path;

fn scene_from(json: &str) -> lumo::scene::Scene {
    let desc = lumo_schema::parse_scene(json).unwrap_or_else(|d| panic!("{d}"));
    let problems = lumo_schema::validate(&desc, None);
    assert!(problems.is_empty(), "{problems:?}");
    common::build(&desc, Path::new("."))
}

/// Pixels whose four corner rays all hit (or all miss) a sphere at the origin of radius `r`,
/// i.e. pixels entirely inside or outside its silhouette.
fn classify(scene: &lumo::scene::Scene, r: f32) -> Vec<Option<bool>> {
    let (w, h) = (scene.settings.width, scene.settings.height);
    let hits = |fx: f32, fy: f32| {
        let ray = scene.camera.ray(
            lumo::math::Vec2::new(fx / w as f32, fy / h as f32),
            lumo::math::Vec2::ZERO,
        );
        let b = ray.o.dot(ray.d);
        b * b - (ray.o.length_squared() - r * r) >= 0.0
    };
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x as f32, y as f32)))
        .map(|(x, y)| {
            let c = [
                hits(x, y),
                hits(x + 1.0, y),
                hits(x, y + 1.0),
                hits(x + 1.0, y + 1.0),
            ];
            if c.iter().all(|&v| v) {
                Some(true)
            } else if c.iter().all(|&v| !v) {
                Some(false)
            } else {
                None
            }
        })
        .collect()
}

const FURNACE: &str = r#"{
  "format_version": 2,
  "image": { "width": 32, "height": 32 },
  "render": { "spp": SPP, "max_depth": 64, "seed": 3 },
  "camera": { "position": [0, 0, 4], "look_at": [0, 0, 0], "fov_y_deg": 40 },
  "background": { "color": [0.5, 0.7, 0.9] },
  "materials": { "m": MATERIAL },
  "objects": [ { "sphere": { "material": "m", "radius": 1 } } ]
}"#;

#[test]
fn white_furnace_diffuse_sphere_reflects_albedo_times_background() {
    let json = FURNACE.replace("SPP", "64").replace(
        "MATERIAL",
        r#"{ "base_color": [0.8, 0.5, 0.25], "specular": 0 }"#,
    );
    let scene = scene_from(&json);
    let img = common::render(&scene);
    let bg = Vec3::new(0.5, 0.7, 0.9);
    let expect_on = bg * Vec3::new(0.8, 0.5, 0.25);
    let mut counted = (0, 0);
    let mut on = Vec::new();
    for (p, class) in img.pixels.iter().zip(classify(&scene, 1.0)) {
        match class {
            // A convex diffuse sphere sees only the background: a·L. The background is a light,
            // sampled and combined with BSDF sampling by MIS, so single samples scatter around
            // it; the mean below must be a·L within that noise.
            Some(true) => {
                on.push(*p);
                counted.0 += 1;
            }
            Some(false) => {
                assert!((*p - bg).abs().max_element() < 1e-6);
                counted.1 += 1;
            }
            None => {}
        }
    }
    assert!(counted.0 > 100 && counted.1 > 100, "{counted:?}");
    let n = on.len() as f32;
    let mean = on.iter().copied().sum::<Vec3>() / n;
    let var = on.iter().map(|p| (*p - mean) * (*p - mean)).sum::<Vec3>() / (n - 1.0);
    for k in 0..3 {
        let tol = 4.0 * (var[k] / n).sqrt() + 1e-6;
        assert!(
            (mean[k] - expect_on[k]).abs() <= tol,
            "channel {k}: {} vs {} (tolerance {tol})",
            mean[k],
            expect_on[k]
        );
    }
}

#[test]
fn white_furnace_glass_sphere_is_invisible() {
    // A clear dielectric sphere conserves energy: on average every pixel shows the background.
    let json = FURNACE.replace("SPP", "256").replace(
        "MATERIAL",
        r#"{ "base_color": [1, 1, 1], "roughness": 0, "transmission": 1, "ior": 1.5, "volume": {} }"#,
    );
    let scene = scene_from(&json);
    let img = common::render(&scene);
    let bg = Vec3::new(0.5, 0.7, 0.9);
    let inside: Vec<Vec3> = img
        .pixels
        .iter()
        .zip(classify(&scene, 1.0))
        .filter(|(_, c)| *c == Some(true))
        .map(|(p, _)| *p)
        .collect();
    let n = inside.len() as f32;
    let mean = inside.iter().fold(Vec3::ZERO, |a, p| a + *p) / n;
    // Standard error of the mean from the per-pixel spread (pixels are independent).
    let var = inside
        .iter()
        .fold(Vec3::ZERO, |a, p| a + (*p - mean) * (*p - mean))
        / (n - 1.0);
    let se = (var / n).max_element().sqrt();
    assert!(
        ((mean - bg) / bg).abs().max_element() < 0.01_f32.max(4.0 * se),
        "mean {mean} vs {bg} (se {se})"
    );
    assert!(img.pixels.iter().all(|p| p.is_finite()));
}

#[test]
fn lambertian_plane_under_a_directional_light() {
    // L = a·E·cos θ / π, exactly, for every pixel that sees the plane.
    for theta_deg in [0.0f32, 30.0, 60.0] {
        let t = theta_deg.to_radians();
        let json = format!(
            r#"{{
              "format_version": 2,
              "image": {{ "width": 16, "height": 16 }},
              "render": {{ "spp": 2, "max_depth": 8 }},
              "camera": {{ "position": [0, 3, 0.001], "look_at": [0, 0, 0], "fov_y_deg": 30 }},
              "materials": {{ "m": {{ "base_color": [0.6, 0.4, 0.2], "specular": 0 }} }},
              "objects": [ {{ "plane": {{ "material": "m", "normal": [0, 1, 0] }} }} ],
              "lights": [ {{ "directional": {{ "direction": [{}, {}, 0], "irradiance": [2, 3, 4] }} }} ]
            }}"#,
            t.sin(),
            -t.cos()
        );
        let img = common::render(&scene_from(&json));
        let expect = Vec3::new(0.6 * 2.0, 0.4 * 3.0, 0.2 * 4.0) * t.cos() / std::f32::consts::PI;
        for p in &img.pixels {
            assert!(
                ((*p - expect) / expect).abs().max_element() < 1e-4,
                "θ = {theta_deg}: {p} vs {expect}"
            );
        }
    }
}

/// The Cornell box with the default (Sobol) sampler.
fn cornell(size: u32, spp: u32, seed: u64) -> lumo::scene::Scene {
    common::cornell(size, spp, seed, lumo_schema::SamplerKind::Sobol)
}

#[test]
fn output_is_identical_whatever_the_thread_count() {
    let scene = cornell(40, 4, 7);
    let render_with = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| common::render(&scene))
    };
    let one = render_with(1);
    let three = render_with(3);
    assert!(one
        .pixels
        .iter()
        .zip(&three.pixels)
        .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
    assert!(one
        .pixels
        .iter()
        .all(|p| p.is_finite() && p.min_element() >= 0.0));
}

#[test]
fn cornell_error_shrinks_as_one_over_sqrt_spp() {
    // RMSE between two independent renders at n and 4n samples: the ratio must be about 2.
    // Pixels that see the light's edge are left out: their error is dominated by the random
    // coverage of a radiance-18 emitter, so a handful of them would decide the estimate (they
    // carry > 90% of the squared error in a 64² image at any spp).
    let renders = |spp| {
        (
            common::render(&cornell(48, spp, 1)),
            common::render(&cornell(48, spp, 2)),
        )
    };
    let (lo_a, lo_b) = renders(8);
    let (hi_a, hi_b) = renders(32);
    let mask: Vec<bool> = hi_a
        .pixels
        .iter()
        .zip(&hi_b.pixels)
        .map(|(a, b)| (a.max_element() + b.max_element()) < 2.0)
        .collect();
    let rmse = |a: &Image, b: &Image| -> f64 {
        let (sum, n) = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .zip(&mask)
            .filter(|(_, m)| **m)
            .fold((0.0, 0usize), |(s, n), ((x, y), _)| {
                (s + f64::from((*x - *y).length_squared()), n + 1)
            });
        (sum / (3 * n) as f64).sqrt()
    };
    let (e8, e32) = (rmse(&lo_a, &lo_b), rmse(&hi_a, &hi_b));
    let ratio = e8 / e32;
    eprintln!("cornell 1/sqrt(spp): RMSE {e8:.4} at 8 spp, {e32:.4} at 32 spp, ratio {ratio:.3}");
    assert!(
        (1.75..2.3).contains(&ratio),
        "RMSE {e8} at 8 spp, {e32} at 32 spp: ratio {ratio}, expected ≈ 2"
    );
}

#[test]
fn depth_of_field_blurs_by_the_circle_of_confusion() {
    // A tiny emitter on the plane of focus stays a point; one nearer blurs into a disk whose
    // diameter on the film is A·|d − f|/d projected: D_px = 2a·(f − d)/d / (2 f tan(fov/2)) · H.
    // The emitter is small but not tiny, so every pixel of the blur disk catches it within
    // 256 samples; the expected lit width is the disk plus the emitter's own image.
    let (a, f, fov, h, r) = (0.1f32, 4.0f32, 30.0f32, 96u32, 0.01f32);
    let image_size = |d: f32, len: f32| len / (2.0 * d * (fov.to_radians() / 2.0).tan()) * h as f32;
    let spot_width = |d: f32| -> f32 {
        let json = format!(
            r#"{{
              "format_version": 2,
              "image": {{ "width": {h}, "height": {h} }},
              "render": {{ "spp": 256, "max_depth": 1 }},
              "camera": {{ "position": [0, 0, 0], "look_at": [0, 0, -1], "fov_y_deg": {fov}, "aperture_radius": {a}, "focus_distance": {f} }},
              "materials": {{ "e": {{ "base_color": [0, 0, 0], "emission": [1, 1, 1] }} }},
              "objects": [ {{ "sphere": {{ "material": "e", "center": [0, 0, -{d}], "radius": {r} }} }} ]
            }}"#
        );
        let img = common::render(&scene_from(&json));
        // Width of the lit region along the middle row (the spot is centred in the image).
        let row = h / 2;
        let lit = (0..h)
            .filter(|&x| img.pixels[(row * h + x) as usize].x > 0.0)
            .count();
        lit as f32
    };
    let sharp = spot_width(f);
    assert!(sharp <= 2.0, "in-focus spot is {sharp} px wide");
    let d = 2.0;
    let predicted = image_size(f, 2.0 * a * (f - d) / d) + image_size(d, 2.0 * r);
    let blurred = spot_width(d);
    assert!(
        (blurred - predicted).abs() <= 2.0,
        "blurred spot {blurred} px, predicted {predicted} px"
    );
}

#[test]
fn progressive_passes_give_the_same_image_as_one_pass() {
    let mut desc = common::load_scene(&common::root().join("scenes/cornell.json"));
    desc.image.width = 24;
    desc.image.height = 24;
    desc.render.spp = 13;
    let one_pass = common::render(&common::build(&desc, &common::root().join("scenes")));
    // A budget that is never reached: passes of 2, 4, 7 samples.
    desc.render.time_budget_s = Some(1e6);
    let (passes, stats) = lumo::render::render(
        &common::build(&desc, &common::root().join("scenes")),
        &Default::default(),
    );
    assert_eq!(stats.spp, 13);
    assert!(one_pass
        .pixels
        .iter()
        .zip(&passes.pixels)
        .all(|(a, b)| (*a - *b).abs().max_element() <= 1e-6 * a.max_element().max(1.0)));
    // A budget that is spent at once stops after the first pass (2 samples, so that every
    // pixel has a variance estimate).
    desc.render.time_budget_s = Some(1e-9);
    let (_, stats) = lumo::render::render(
        &common::build(&desc, &common::root().join("scenes")),
        &Default::default(),
    );
    assert_eq!(stats.spp, 2);
}
