//! lumo's Cornell box agrees with Mitsuba 3's converged image of the same scene
//! (`tests/reference/cornell_mitsuba_4096.exr`) to within Monte Carlo noise: any bias in
//! lumo's transport, camera, materials or light would show up as excess error.

mod common;

use lumo::render::Image;

/// Box-filters an image down by an integer factor (the same as rendering at the lower
/// resolution with a box pixel filter).
fn downsample(img: &Image, k: u32) -> Image {
    let (w, h) = (img.width / k, img.height / k);
    let mut pixels = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = glam::Vec3::ZERO;
            for dy in 0..k {
                for dx in 0..k {
                    sum += img.pixels[((y * k + dy) * img.width + x * k + dx) as usize];
                }
            }
            pixels.push(sum / (k * k) as f32);
        }
    }
    Image {
        width: w,
        height: h,
        pixels,
    }
}

#[test]
fn cornell_box_matches_mitsuba_within_noise() {
    let reference =
        lumo::output::read_image(&common::root().join("tests/reference/cornell_mitsuba_4096.exr"))
            .unwrap();
    assert_eq!((reference.width, reference.height), (256, 256));
    let reference = downsample(&reference, 2);
    let render = |seed| {
        common::render(&common::cornell(
            128,
            64,
            seed,
            lumo_schema::SamplerKind::Sobol,
        ))
    };
    let (a, b) = (render(1), render(2));
    // Pixels on the light's edge are left out of the RMSE: their error is the random coverage
    // of a radiance-18 emitter, a handful of them would decide the noise estimate. The mean
    // brightness check below still covers them.
    let keep: Vec<bool> = reference
        .pixels
        .iter()
        .map(|p| p.max_element() < 2.0)
        .collect();
    let rmse = |x: &Image, y: &Image| -> f64 {
        let (sum, n) = x
            .pixels
            .iter()
            .zip(&y.pixels)
            .zip(&keep)
            .filter(|(_, k)| **k)
            .fold((0.0, 0usize), |(s, n), ((p, q), _)| {
                (s + f64::from((*p - *q).length_squared()), n + 1)
            });
        (sum / (3 * n) as f64).sqrt()
    };
    // Noise of one lumo render, from two independent ones; the reference's own noise
    // (≈ 0.003 at 256², ≈ 0.0015 after 2×2 averaging) adds in quadrature.
    let lumo_noise = rmse(&a, &b) / 2f64.sqrt();
    let ref_noise = 0.0015;
    let expected = (lumo_noise * lumo_noise + ref_noise * ref_noise).sqrt();
    let error = rmse(&a, &reference);
    eprintln!("RMSE vs Mitsuba: {error:.5}; expected from noise alone: {expected:.5} (lumo noise {lumo_noise:.5})");
    assert!(
        error < 1.15 * expected,
        "lumo differs from Mitsuba by RMSE {error}, noise explains only {expected}"
    );
    // The mean brightness agrees to 1% (a bias check independent of per-pixel noise).
    let (ma, mr) = (a.mean(), reference.mean());
    assert!(
        ((ma - mr) / mr).abs().max_element() < 0.01,
        "mean {ma} vs reference {mr}"
    );
}
