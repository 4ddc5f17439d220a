//! The light tree changes which light next-event estimation samples, never the expected image:
//! `scenes/many_lights.json` (600 triangle lights) plus point, spot and directional lights,
//! rendered with the tree and with selection by power, has the same mean within its noise.

mod common;

use lumo::light::Light;
use lumo::light_sampler::{LightSampler, LightSamplerKind};
use lumo::math::Vec3;

/// The many-lights scene at 48×36 with the independent sampler (so that pixels' errors are
/// independent and their estimates exact in expectation), with a few punctual lights added.
fn scene(spp: u32, seed: u64, kind: LightSamplerKind) -> lumo::scene::Scene {
    let mut desc = common::load_scene(&common::root().join("scenes/many_lights.json"));
    desc.image.width = 48;
    desc.image.height = 36;
    desc.render.spp = spp;
    desc.render.seed = seed;
    desc.render.sampler = lumo_schema::SamplerKind::Independent;
    let mut s = common::build(&desc, &common::root().join("scenes"));
    for k in 0..3 {
        let x = -3.0 + 3.0 * k as f32;
        s.lights.push(Light::Point {
            position: Vec3::new(x, 1.0, 1.0),
            intensity: Vec3::new(1.0, 0.8, 0.5),
        });
        s.lights.push(Light::Spot {
            position: Vec3::new(x + 1.0, 2.5, -1.0),
            axis: Vec3::new(0.3, -1.0, 0.2).normalize(),
            intensity: Vec3::new(2.0, 3.0, 4.0),
            cos_inner: 0.95,
            cos_outer: 0.85,
        });
    }
    s.lights.push(Light::Directional {
        to_light: Vec3::new(0.5, 1.0, 0.8).normalize(),
        irradiance: Vec3::splat(0.3),
        scene_radius: 10.0,
    });
    s.light_sampler = LightSampler::new(&s.lights, kind);
    s
}

/// Mean radiance of the image and the standard error of that mean, per channel.
fn mean_and_error(scene: &lumo::scene::Scene) -> ([f64; 3], [f64; 3]) {
    let r = lumo::render::render_with_error(scene, &Default::default());
    let n = r.image.pixels.len() as f64;
    let (mut m, mut v) = ([0.0f64; 3], [0.0f64; 3]);
    for (p, e) in r.image.pixels.iter().zip(&r.std_error.pixels) {
        for c in 0..3 {
            m[c] += f64::from(p[c]) / n;
            v[c] += f64::from(e[c]).powi(2) / (n * n);
        }
    }
    (m, v.map(f64::sqrt))
}

#[test]
fn tree_and_power_selection_render_the_same_mean() {
    let tree = scene(512, 5, LightSamplerKind::Tree);
    let power = scene(512, 6, LightSamplerKind::Power);
    assert!(tree.light_sampler.is_tree() && !power.light_sampler.is_tree());
    let (mt, et) = mean_and_error(&tree);
    let (mp, ep) = mean_and_error(&power);
    for c in 0..3 {
        let sigma = (et[c] * et[c] + ep[c] * ep[c]).sqrt();
        let z = (mt[c] - mp[c]) / sigma;
        eprintln!(
            "channel {c}: tree {:.5} ± {:.5}, power {:.5} ± {:.5}, z = {z:.2}",
            mt[c], et[c], mp[c], ep[c]
        );
        // The test can see a bias: 4σ is under 3 % of the mean (about 2 % here).
        assert!(4.0 * sigma < 0.03 * mp[c], "channel {c}: too noisy to tell");
        assert!(z.abs() < 4.0, "channel {c}: means differ by {z:.2} σ");
    }
    // The tree's image is less noisy for the same samples.
    assert!(et.iter().zip(&ep).all(|(t, p)| t < p), "{et:?} vs {ep:?}");
}
