//! Every render is the same bits at every lane width: each scene in `scenes/`, each legacy
//! scene there, and each shared glTF sample model under a sunlit HDR environment, rendered at
//! W = 1, 4, 8 and 16 paths per thread, give identical films (every pixel's exact sums), as
//! must a render that refines adaptively. A width the CPU has no vector registers for runs the
//! same code in narrower instructions, so all four are tested on any machine.

mod common;

use std::path::{Path, PathBuf};

use lumo::render::{render_with_error, RenderOptions};

/// The films of `file` (rendered small, with `edit` applied) at every lane width, compared
/// with W = 1's; `adaptive` renders with adaptive sampling.
fn same_at_every_width(file: &Path, edit: impl Fn(&mut lumo_schema::Scene), adaptive: bool) {
    let scene = common::small_scene(file, edit);
    let film_at = |width: usize| {
        let options = RenderOptions {
            lane_width: Some(width),
            adaptive,
            ..Default::default()
        };
        render_with_error(&scene, &options).film
    };
    let one = film_at(1);
    assert!(one.samples_taken() > 0, "{}: no samples", file.display());
    for width in [4, 8, 16] {
        assert!(
            film_at(width).pixels() == one.pixels(),
            "{}: W = {width} differs from W = 1{}",
            file.display(),
            if adaptive { " (adaptive)" } else { "" }
        );
    }
}

#[test]
fn every_scene_renders_the_same_bits_at_every_lane_width() {
    let scenes = common::root().join("scenes");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&scenes)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.extend(common::files_in(&scenes.join("legacy"), &["txt"]));
    files.sort();
    assert!(files.len() >= 10, "only {} scenes", files.len());
    for file in &files {
        same_at_every_width(file, |_| {}, false);
    }
    same_at_every_width(&scenes.join("cornell.json"), |_| {}, true);
    // A thin lens (its rays are drawn one lane at a time, a pinhole's in SIMD lanes), and
    // independent numbers (drawn one lane at a time) with and without it.
    for (lens, sampler) in [
        (0.05, lumo_schema::SamplerKind::Sobol),
        (0.0, lumo_schema::SamplerKind::Independent),
        (0.05, lumo_schema::SamplerKind::Independent),
    ] {
        same_at_every_width(
            &scenes.join("cornell.json"),
            |s| {
                s.camera.aperture_radius = lens;
                s.render.sampler = sampler;
            },
            false,
        );
    }
    // The ray-cast preview integrator too.
    same_at_every_width(
        &scenes.join("cornell_glass.json"),
        |s| s.render.integrator = lumo_schema::Integrator::Raycast,
        false,
    );
}

#[test]
fn every_shared_gltf_model_renders_the_same_bits_at_every_lane_width() {
    let Some(shared) = common::shared() else {
        return;
    };
    let sky = shared.join("hdri/sunrise.exr");
    let files = common::files_in(&shared.join("gltf"), &["gltf", "glb"]);
    assert!(files.len() >= 20, "only {} sample files", files.len());
    for file in &files {
        same_at_every_width(
            file,
            |s| {
                s.background = lumo_schema::Background {
                    image: Some(sky.to_string_lossy().into_owned()),
                    ..Default::default()
                }
            },
            false,
        );
    }
}
