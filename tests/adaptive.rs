//! Adaptive sampling on the Cornell box with a glass sphere (`scenes/cornell_glass.json`): the
//! image mean stays unbiased, the budget is kept, and the samples go where the error is.
//!
//! The reference is `tests/reference/cornell_glass_4096.exr` (lumo, 128², 4096 spp; see
//! `tests/reference/README.md`). The renders here are 64²: with a box pixel filter a 64² pixel
//! is exactly the mean of the four 128² pixels it covers, so the reference is box-downsampled.

mod common;

use lumo::render::{render_with_error, Image, RenderOptions, Rendered};
use lumo_schema::SamplerKind;

const SIZE: u32 = 64;
const REF_SPP: u64 = 4096;

fn cornell_glass(spp: u32, seed: u64, sampler: SamplerKind) -> lumo::scene::Scene {
    let mut desc = common::load_scene(&common::root().join("scenes/cornell_glass.json"));
    desc.image.width = SIZE;
    desc.image.height = SIZE;
    desc.render.spp = spp;
    desc.render.seed = seed;
    desc.render.sampler = sampler;
    common::build(&desc, &common::root().join("scenes"))
}

/// The 128² reference averaged over 2×2 blocks.
fn reference() -> Image {
    let r =
        lumo::output::read_image(&common::root().join("tests/reference/cornell_glass_4096.exr"))
            .unwrap();
    assert_eq!((r.width, r.height), (2 * SIZE, 2 * SIZE));
    let w = r.width as usize;
    let pixels = (0..(SIZE * SIZE) as usize)
        .map(|i| {
            let (x, y) = (2 * (i % SIZE as usize), 2 * (i / SIZE as usize));
            (r.pixels[y * w + x]
                + r.pixels[y * w + x + 1]
                + r.pixels[(y + 1) * w + x]
                + r.pixels[(y + 1) * w + x + 1])
                * 0.25
        })
        .collect();
    Image {
        width: SIZE,
        height: SIZE,
        pixels,
    }
}

/// Per channel: (Σ over pixels of adaptive − uniform, variance of that sum) for two renders with
/// the same seed. They share each pixel's first min(Nᵢ, U) samples (a sample's random stream
/// depends only on seed, pixel and index), so the difference of the two means of pixel i is the
/// difference between their unshared samples, of variance σᵢ² |1/Nᵢ − 1/U| when the counts do not
/// depend on the samples (σᵢ² per sample, measured by the uniform render as se²·U). Pixels of
/// the same count cancel exactly, which makes this far more sensitive than comparing either mean
/// with a reference.
fn paired_difference(adaptive: &Rendered, uniform: &Rendered) -> [(f64, f64); 3] {
    std::array::from_fn(|c| {
        let mut sum = 0.0;
        let mut var = 0.0;
        for i in 0..uniform.image.pixels.len() {
            let (n, u) = (f64::from(adaptive.counts[i]), f64::from(uniform.counts[i]));
            sum += f64::from(adaptive.image.pixels[i][c]) - f64::from(uniform.image.pixels[i][c]);
            var +=
                f64::from(uniform.std_error.pixels[i][c]).powi(2) * u * (1.0 / n - 1.0 / u).abs();
        }
        (sum, var)
    })
}

/// Own-sample decisions biased the image mean downwards by about 1% (`docs/performance.md`):
/// pixels that by chance missed the bright paths had a low variance estimate and stopped early.
/// Over eight seeds, the adaptive image must match the uniform image of the same budget and seed
/// within the noise of their difference (independent sampler, so the per-pixel variance estimate
/// is unbiased): z = Σ (adaptive − uniform) / √(Σ variance) per channel, |z| < 4. With the old
/// own-sample rule this setup gives z = −9.7, −5.7, −4.5 in red, green, blue (−2.2%, −1.4%,
/// −1.2%; measured by switching the rule back), with the neighbourhood rule −0.4 … −0.6, so the test
/// does detect that bias; a wrong noise estimate would show as a large |z| for the
/// neighbourhood rule too. Both images are also held to the reference mean, within their noise.
#[test]
fn adaptive_image_mean_is_unbiased_within_measured_noise() {
    let reference = reference();
    let n = f64::from(SIZE * SIZE);
    let ref_mean: [f64; 3] = std::array::from_fn(|c| {
        reference
            .pixels
            .iter()
            .map(|p| f64::from(p[c]))
            .sum::<f64>()
            / n
    });
    let spp = 32u32;
    let seeds = [11u64, 12, 13, 14, 15, 16, 17, 18];
    let (mut paired, mut paired_var) = ([0.0f64; 3], [0.0f64; 3]);
    let (mut vs_ref, mut vs_ref_var) = ([[0.0f64; 3]; 2], [[0.0f64; 3]; 2]);
    for seed in seeds {
        let scene = cornell_glass(spp, seed, SamplerKind::Independent);
        let uniform = render_with_error(&scene, &RenderOptions::default());
        let adaptive = render_with_error(
            &scene,
            &RenderOptions {
                adaptive: true,
                ..Default::default()
            },
        );
        assert_eq!(
            adaptive.stats.samples,
            u64::from(SIZE * SIZE * spp),
            "the budget is kept exactly"
        );
        assert!(adaptive.image.pixels.iter().all(|p| p.is_finite()));
        for (c, (d, v)) in paired_difference(&adaptive, &uniform)
            .into_iter()
            .enumerate()
        {
            paired[c] += d;
            paired_var[c] += v;
        }
        for (k, r) in [&uniform, &adaptive].into_iter().enumerate() {
            for c in 0..3 {
                vs_ref[k][c] +=
                    r.image.pixels.iter().map(|p| f64::from(p[c])).sum::<f64>() / n - ref_mean[c];
                vs_ref_var[k][c] += r
                    .std_error
                    .pixels
                    .iter()
                    .map(|e| f64::from(e[c]).powi(2))
                    .sum::<f64>()
                    / (n * n);
            }
        }
    }
    let s = seeds.len() as f64;
    for c in 0..3 {
        let z = paired[c] / paired_var[c].sqrt();
        eprintln!(
            "channel {c}: adaptive − uniform = {:+.3}% of the mean, z = {z:+.2}",
            100.0 * paired[c] / n / s / ref_mean[c]
        );
        assert!(
            z.abs() < 4.0,
            "channel {c}: adaptive image mean off the uniform one by {:+.3}% (z = {z:.2})",
            100.0 * paired[c] / n / s / ref_mean[c]
        );
        for (k, name) in ["uniform", "adaptive"].into_iter().enumerate() {
            // The reference's own noise (4096 spp at 4× the pixels), the same in every seed's
            // difference: its variance is a fraction spp / (4 · 4096) of one render's.
            let var = vs_ref_var[k][c] * (1.0 + s * f64::from(spp) / (4 * REF_SPP) as f64);
            let z = vs_ref[k][c] / var.sqrt();
            eprintln!(
                "  {name}: mean − reference = {:+.3}%, z = {z:+.2}",
                100.0 * vs_ref[k][c] / s / ref_mean[c]
            );
            assert!(
                z.abs() < 4.0,
                "{name}, channel {c}: image mean off the reference (z = {z:.2})"
            );
        }
    }
}

/// The point of it: at an equal sample budget, giving the samples to the pixels whose
/// neighbourhood is noisy (the glass sphere and its caustic) lowers the relative MSE against the
/// reference. Measured: uniform 0.0410, adaptive 0.0312 (−24%) at 64 spp, two seeds; the bound
/// (−10%) leaves room for seed-to-seed spread while failing if adaptivity stopped helping.
#[test]
fn adaptive_sampling_lowers_the_relative_error_at_equal_samples() {
    let reference = reference();
    let spp = 64u32;
    let (mut uniform, mut adaptive) = (0.0, 0.0);
    let seeds = [21u64, 22];
    for seed in seeds {
        let scene = cornell_glass(spp, seed, SamplerKind::Sobol);
        let u = render_with_error(&scene, &RenderOptions::default());
        let a = render_with_error(
            &scene,
            &RenderOptions {
                adaptive: true,
                ..Default::default()
            },
        );
        assert_eq!(u.stats.samples, a.stats.samples);
        uniform += u.image.rel_mse(&reference);
        adaptive += a.image.rel_mse(&reference);
    }
    eprintln!(
        "relMSE at {spp} spp, mean of {} seeds: uniform {:.5}, adaptive {:.5}",
        seeds.len(),
        uniform / 2.0,
        adaptive / 2.0
    );
    assert!(
        adaptive < 0.9 * uniform,
        "adaptive relMSE {adaptive} vs uniform {uniform}"
    );
}
