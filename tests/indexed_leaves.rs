//! Indexed BVH leaves (`LUMO_BVH_LEAVES=indexed`, what sets of a million triangles or more get)
//! render the same bits as leaf packets (what smaller sets get): every scene in `scenes/`, each
//! legacy scene there, and each shared glTF sample model under a sunlit HDR environment, built
//! once with each kind of leaf for every triangle set, give identical films. One test in a
//! binary of its own, as it sets the variable for its whole process.

mod common;

use std::path::{Path, PathBuf};

use lumo::geometry::triangle_bvh::LEAVES_VARIABLE;
use lumo::render::{render_with_error, PixelSum, RenderOptions};

/// The film of `file` (rendered small, with `edit` applied) with the leaves `LUMO_BVH_LEAVES`
/// names.
fn film(file: &Path, edit: &dyn Fn(&mut lumo_schema::Scene), leaves: &str) -> Vec<PixelSum> {
    std::env::set_var(LEAVES_VARIABLE, leaves);
    let scene = common::small_scene(file, edit);
    let film = render_with_error(&scene, &RenderOptions::default()).film;
    assert!(film.samples_taken() > 0, "{}: no samples", file.display());
    film.pixels().to_vec()
}

#[test]
fn indexed_leaves_render_the_same_bits_as_packets() {
    let scenes = common::root().join("scenes");
    // The scenes themselves (not the fragments they include) and the legacy ones.
    let mut files: Vec<(PathBuf, Option<PathBuf>)> = std::fs::read_dir(&scenes)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .chain(common::files_in(&scenes.join("legacy"), &["txt"]))
        .map(|f| (f, None))
        .collect();
    files.sort();
    if let Some(shared) = common::shared() {
        let sky = shared.join("hdri/sunrise.exr");
        files.extend(
            common::files_in(&shared.join("gltf"), &["gltf", "glb"])
                .into_iter()
                .map(|f| (f, Some(sky.clone()))),
        );
    }
    assert!(files.len() >= 10, "only {} scenes", files.len());
    for (file, sky) in &files {
        let edit = |s: &mut lumo_schema::Scene| {
            if let Some(sky) = sky {
                s.background = lumo_schema::Background {
                    image: Some(sky.to_string_lossy().into_owned()),
                    ..Default::default()
                }
            }
        };
        let packets = film(file, &edit, "packets");
        let indexed = film(file, &edit, "indexed");
        assert!(
            packets == indexed,
            "{}: indexed leaves render other bits than packets",
            file.display()
        );
    }
}
