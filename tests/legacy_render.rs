//! Every legacy scene (the shared real ones and our examples in `scenes/legacy/`) loads through
//! the CLI's input dispatch and renders tiny in both integrators without error or NaN. A contact
//! sheet of all of them is written as a test artefact (`$CARGO_TARGET_TMPDIR/legacy-contact-sheet.png`)
//! so a person can check at a glance that they look right.

mod common;

use std::path::{Path, PathBuf};

use lumo::render::{render, Image, RenderOptions};
use lumo::LoadOptions;
use lumo_schema::Integrator;

fn legacy_scenes() -> Vec<PathBuf> {
    let mut files = Vec::new();
    if let Some(shared) = common::shared() {
        files.extend(txt_files(&shared.join("legacy-scenes")));
        assert!(files.len() >= 16, "expected the 16 shared legacy scenes");
    }
    files.extend(txt_files(&common::root().join("scenes").join("legacy")));
    files
}

fn txt_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    v.sort();
    v
}

/// Loads a legacy scene like `lumo render` does, overrides size and samples, builds and renders.
fn render_legacy(path: &Path, integrator: Option<Integrator>, w: u32, h: u32, spp: u32) -> Image {
    let mut input = lumo::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    input
        .edit(|s| {
            s.image.width = w;
            s.image.height = h;
            s.render.spp = spp;
            s.render.max_depth = 6;
            if let Some(i) = integrator {
                s.render.integrator = i;
            }
        })
        .unwrap_or_else(|e| panic!("{e}"));
    let built = match input.build() {
        Ok((scene, _)) => scene,
        Err(e) => panic!("{}: {e}", path.display()),
    };
    let (img, stats) = render(
        &built,
        &RenderOptions {
            progress: None,
            target_rel_error: None,
            adaptive: false,
            ..Default::default()
        },
    );
    assert_eq!(
        stats.nan_samples,
        0,
        "{}: {} NaN/Inf samples ({integrator:?})",
        path.display(),
        stats.nan_samples
    );
    assert!(
        img.pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0),
        "{}: non-finite or negative pixel",
        path.display()
    );
    img
}

#[test]
fn every_legacy_scene_renders_in_both_integrators() {
    for path in legacy_scenes() {
        for integrator in [Integrator::Raycast, Integrator::Path] {
            render_legacy(&path, Some(integrator), 32, 24, 2);
        }
    }
}

#[test]
fn legacy_contact_sheet() {
    const T: u32 = 64;
    let scenes = legacy_scenes();
    let cols = 6u32;
    let rows = (scenes.len() as u32).div_ceil(cols);
    let mut sheet = Image {
        width: cols * T,
        height: rows * T,
        pixels: vec![lumo::math::Vec3::ZERO; (cols * T * rows * T) as usize],
    };
    let mut lit = 0;
    for (i, path) in scenes.iter().enumerate() {
        eprintln!("contact sheet cell {i}: {}", path.display());
        // The scene's own integrator: raycast for the original ray caster, path otherwise.
        let img = render_legacy(path, None, T, T, 8);
        eprintln!("  mean {:?}", img.mean());
        if img.mean().max_element() > 1e-3 {
            lit += 1;
        }
        let (cx, cy) = ((i as u32 % cols) * T, (i as u32 / cols) * T);
        for y in 0..T {
            for x in 0..T {
                sheet.pixels[((cy + y) * sheet.width + cx + x) as usize] =
                    img.pixels[(y * T + x) as usize];
            }
        }
    }
    // Every scene except the curves-only one (scene08_core: nothing to render) shows something.
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("legacy-contact-sheet.png");
    lumo::output::write_image(&sheet, &out, lumo::output::ToneMap::Aces).unwrap();
    assert!(
        lit + 1 >= scenes.len(),
        "only {lit} of {} thumbnails are not black",
        scenes.len()
    );
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("legacy-contact-sheet.png");
    lumo::output::write_image(&sheet, &out, lumo::output::ToneMap::Aces).unwrap();
    eprintln!("contact sheet: {}", out.display());
}

#[test]
fn cli_renders_a_legacy_scene_and_reports_legacy_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cornell.png");
    let scene = common::root()
        .join("scenes")
        .join("legacy")
        .join("cornell_box.txt");
    let ok = assert_cmd::Command::cargo_bin("lumo")
        .unwrap()
        .args([
            "render", "-q", "--spp", "1", "--width", "16", "--height", "16", "--lights", "auto",
        ])
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert!(out.is_file());
    // The importer's warnings reach the user with their legacy line:column.
    let stderr = String::from_utf8_lossy(&ok.stderr);
    assert!(
        stderr.contains("cornell_box.txt: 10:1: dropping the Lights block"),
        "{stderr}"
    );

    let bad = common::root()
        .join("converters")
        .join("tests")
        .join("legacy-invalid")
        .join("misspelt_material_field.txt");
    let fail = assert_cmd::Command::cargo_bin("lumo")
        .unwrap()
        .arg("render")
        .arg(&bad)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(fail.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&fail.stderr);
    assert!(
        stderr.contains(
            "misspelt_material_field.txt:3:16: error: unknown material field `diffuseColour`"
        ),
        "{stderr}"
    );
    assert!(stderr.contains("did you mean `diffuseColor`?"), "{stderr}");
}
