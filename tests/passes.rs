//! Render passes (`--aov`) against closed forms, and their exactness: a Lambertian plane's
//! albedo is its base colour, a sphere's normal and depth are the analytic ones, ids name the
//! objects and materials hit, a mirror's albedo shows what it reflects; passes change no bit of
//! the beauty, are the same bits at every SIMD width, and split + merge and checkpoint + resume
//! give the bits of one render.

mod common;

use glam::{Vec2, Vec3};
use lumo::aov::{Aov, AovSet, PassImage, PassPixels};
use lumo::job::{Hooks, JobSettings, RenderJob};
use lumo::render::{render_with_error, Film, RenderOptions};

const ALL: &str = "albedo,normal,depth,position,uv,object_id,material_id,std_error";

fn all() -> AovSet {
    ALL.parse().expect("pass names")
}

/// A red Lambertian floor (object 0), a blue Lambertian ball (1) and a mirror ball (2) under a
/// grey sky; materials sorted by name: blue 1, mirror 2, red 3.
const SCENE: &str = r#"{
  "format_version": 2,
  "image": {"width": 48, "height": 40},
  "render": {"integrator": "path", "spp": 8, "max_depth": 6, "seed": 3},
  "camera": {"position": [0, 1.4, 5], "look_at": [0, 0.5, 0], "up": [0, 1, 0], "fov_y_deg": 40},
  "background": {"color": [0.5, 0.5, 0.5]},
  "materials": {
    "red": {"base_color": [0.7, 0.3, 0.2], "specular": 0},
    "blue": {"base_color": [0.2, 0.4, 0.8], "specular": 0},
    "mirror": {"base_color": [1, 1, 1], "metallic": 1, "roughness": 0}
  },
  "objects": [
    {"plane": {"material": "red", "normal": [0, 1, 0], "offset": 0}},
    {"sphere": {"material": "blue", "center": [0.7, 0.6, 0], "radius": 0.6}},
    {"sphere": {"material": "mirror", "center": [-0.8, 0.6, 0.3], "radius": 0.6}}
  ]
}"#;

const RED: Vec3 = Vec3::new(0.7, 0.3, 0.2);
const BLUE: Vec3 = Vec3::new(0.2, 0.4, 0.8);
const SKY: Vec3 = Vec3::splat(0.5);
const BALL: (Vec3, f32) = (Vec3::new(0.7, 0.6, 0.0), 0.6);
const MIRROR: (Vec3, f32) = (Vec3::new(-0.8, 0.6, 0.3), 0.6);

fn scene_file(dir: &std::path::Path) -> std::path::PathBuf {
    let path = dir.join("passes.json");
    std::fs::write(&path, SCENE).expect("scene written");
    path
}

fn job(settings: JobSettings) -> RenderJob {
    let dir = tempfile::tempdir().expect("temp dir");
    let loaded =
        lumo::load(scene_file(dir.path()), &lumo::LoadOptions::default()).expect("scene loads");
    RenderJob::new(&loaded, settings).expect("job")
}

/// What a ray from `o` along unit `d` hits first: (object index, t, normal), or `None`.
fn trace(o: Vec3, d: Vec3) -> Option<(usize, f32, Vec3)> {
    let mut best: Option<(usize, f32, Vec3)> = None;
    let mut keep = |i: usize, t: f32, n: Vec3| {
        if t > 1e-4 && best.is_none_or(|b| t < b.1) {
            best = Some((i, t, n));
        }
    };
    if d.y < 0.0 {
        keep(0, -o.y / d.y, Vec3::Y);
    }
    for (i, (c, r)) in [(1, BALL), (2, MIRROR)] {
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        if disc > 0.0 {
            let t = -b - disc.sqrt();
            keep(i, t, (o + d * t - c) / r);
        }
    }
    best
}

/// The pixel's (x, y) floats of a pass.
fn at(pass: &PassImage, width: u32, x: u32, y: u32) -> Vec<f32> {
    let c = pass.aov.channels().len();
    let i = (y * width + x) as usize * c;
    match &pass.pixels {
        PassPixels::Float(v) => v[i..i + c].to_vec(),
        PassPixels::Id(v) => v[i..i + c].iter().map(|&x| x as f32).collect(),
    }
}

fn pass(passes: &[PassImage], aov: Aov) -> &PassImage {
    passes
        .iter()
        .find(|p| p.aov == aov)
        .unwrap_or_else(|| panic!("no {aov} pass"))
}

#[test]
fn passes_match_the_closed_forms() {
    let job = job(JobSettings {
        aovs: all(),
        ..Default::default()
    });
    let finished = job.run(&Hooks::default()).expect("renders");
    let passes = finished.passes();
    assert_eq!(
        passes.iter().map(|p| p.aov).collect::<Vec<_>>(),
        Aov::ALL.to_vec()
    );
    let scene = job.scene();
    let (w, h) = (job.width(), job.height());
    let mut seen = [0usize; 4];
    let mut reflected_red = 0;
    for y in 0..h {
        for x in 0..w {
            // The pixel is "pure" when its centre and corners see the same object.
            let ray = |fx: f32, fy: f32| {
                let r = scene.camera.ray(
                    Vec2::new((x as f32 + fx) / w as f32, (y as f32 + fy) / h as f32),
                    Vec2::ZERO,
                );
                (r.o, r.d.normalize())
            };
            let (o, d) = ray(0.5, 0.5);
            let centre = trace(o, d);
            let corners: Vec<_> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .map(|&(fx, fy)| {
                    let (o, d) = ray(fx, fy);
                    trace(o, d).map(|h| (h.0, h.1))
                })
                .collect();
            if corners
                .iter()
                .any(|c| c.map(|c| c.0) != centre.map(|h| h.0))
            {
                continue;
            }
            // The depth averaged over the pixel lies within the corners' range.
            let spread = corners
                .iter()
                .flatten()
                .map(|c| (c.1 - centre.map_or(0.0, |h| h.1)).abs())
                .fold(0.0f32, f32::max);
            let albedo = Vec3::from_slice(&at(pass(&passes, Aov::Albedo), w, x, y));
            let normal = Vec3::from_slice(&at(pass(&passes, Aov::Normal), w, x, y));
            let depth = at(pass(&passes, Aov::Depth), w, x, y)[0];
            let object = at(pass(&passes, Aov::ObjectId), w, x, y)[0] as u32;
            let material = at(pass(&passes, Aov::MaterialId), w, x, y)[0] as u32;
            let here = format!("pixel ({x}, {y})");
            let Some((i, t, n)) = centre else {
                // Sky: documented values.
                assert!(
                    (albedo - SKY).abs().max_element() < 1e-6,
                    "{here}: {albedo}"
                );
                assert_eq!(
                    (normal, depth, object, material),
                    (Vec3::ZERO, 0.0, 0, 0),
                    "{here}"
                );
                seen[3] += 1;
                continue;
            };
            seen[i] += 1;
            assert_eq!(object, i as u32 + 1, "{here}: object id");
            assert_eq!(material, [3, 1, 2][i], "{here}: material id");
            assert!(
                (depth - t).abs() <= spread + 1e-4 * t,
                "{here}: depth {depth}, analytic {t} ± {spread}"
            );
            match i {
                0 => {
                    assert!(
                        (albedo - RED).abs().max_element() < 1e-5,
                        "{here}: {albedo}"
                    );
                    assert!((normal - Vec3::Y).length() < 1e-5, "{here}: {normal}");
                }
                1 => {
                    assert!(
                        (albedo - BLUE).abs().max_element() < 1e-5,
                        "{here}: {albedo}"
                    );
                    assert!(
                        (normal - n).length() < 0.03,
                        "{here}: normal {normal}, analytic {n}"
                    );
                }
                _ => {
                    // A mirror: what it reflects, if every corner reflects the same thing.
                    let p = o + d * t;
                    let what = trace(p, d - 2.0 * d.dot(n) * n).map(|h| h.0);
                    let expected = match what {
                        Some(0) => RED,
                        Some(1) => BLUE,
                        Some(_) => continue,
                        None => SKY,
                    };
                    if (albedo - expected).abs().max_element() < 0.02 {
                        reflected_red += usize::from(what == Some(0));
                    } else {
                        // A pixel whose footprint reflects two things averages them.
                        let others = [RED, BLUE, SKY];
                        assert!(
                            others
                                .iter()
                                .any(|c| (albedo - *c).abs().max_element() >= 0.02),
                            "{here}: mirror albedo {albedo}"
                        );
                    }
                }
            }
        }
    }
    assert!(
        seen.iter().all(|&n| n >= 20),
        "pure pixels per object (floor, ball, mirror, sky): {seen:?}"
    );
    assert!(
        reflected_red >= 10,
        "mirror pixels showing the floor: {reflected_red}"
    );
}

#[test]
fn passes_change_no_bit_of_the_beauty_at_any_lane_width() {
    let scene = common::cornell(24, 6, 5, lumo_schema::SamplerKind::Sobol);
    let plain = render_with_error(&scene, &RenderOptions::default()).film;
    let mut with: Option<Film> = None;
    for width in lumo::lanes::WIDTHS {
        let film = render_with_error(
            &scene,
            &RenderOptions {
                aovs: all(),
                lane_width: Some(width),
                ..Default::default()
            },
        )
        .film;
        assert_eq!(film.pixels(), plain.pixels(), "W = {width}: beauty changed");
        assert!(film.aov_sums().is_some());
        match &with {
            None => with = Some(film),
            Some(first) => assert!(*first == film, "W = {width}: passes differ"),
        }
    }
}

#[test]
fn split_merge_and_resume_with_passes_are_bit_exact() {
    let settings = |samples: Option<(u32, u32)>, spp: Option<u32>| JobSettings {
        aovs: all(),
        samples,
        spp,
        ..Default::default()
    };
    let whole = job(settings(None, Some(8)))
        .run(&Hooks::default())
        .expect("renders");
    let part = |a, b| {
        job(settings(Some((a, b)), None))
            .run(&Hooks::default())
            .expect("renders")
            .film()
            .clone()
    };
    let (late, early) = (part(5, 8), part(0, 5));
    // Merged with the later samples first: ids still come from sample 0.
    let merged = lumo::partial_film::merge(&[late.clone(), early.clone()]).expect("merges");
    assert!(
        merged.film == whole.sums,
        "split + merge differs from one render"
    );
    // Written and read back, then merged.
    let dir = tempfile::tempdir().expect("temp dir");
    let (a, b) = (dir.path().join("a.npz"), dir.path().join("b.npz"));
    early.write(&a).expect("written");
    late.write(&b).expect("written");
    let read = |p: &std::path::Path| lumo::partial_film::PartialFilm::read(p).expect("reads");
    assert!(read(&a) == early, "a film with passes does not round-trip");
    let merged = lumo::partial_film::merge(&[read(&b), read(&a)]).expect("merges");
    assert!(merged.film == whole.sums);
    // Resumed from the first five samples.
    let resumed = job(JobSettings {
        resume: Some(read(&a)),
        ..settings(None, Some(8))
    })
    .run(&Hooks::default())
    .expect("resumes");
    assert!(resumed.sums == whole.sums, "resume differs from one render");
    // Films of other passes do not merge, and say why.
    let other = job(JobSettings {
        aovs: "depth".parse().expect("names"),
        samples: Some((5, 8)),
        ..Default::default()
    })
    .run(&Hooks::default())
    .expect("renders")
    .film()
    .clone();
    let err = lumo::partial_film::merge(&[early, other]).expect_err("refused");
    assert!(err.1.contains("render passes differ"), "{}", err.1);
}

#[test]
fn a_scene_asks_for_passes_in_its_render_settings() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("asks.json");
    let text = SCENE.replace(
        r#""seed": 3}"#,
        r#""seed": 3, "aov": ["depth", "object_id"]}"#,
    );
    assert_ne!(text, SCENE);
    std::fs::write(&path, text).expect("scene written");
    let loaded = lumo::load(&path, &lumo::LoadOptions::default()).expect("scene loads");
    let finished = RenderJob::new(
        &loaded,
        JobSettings {
            aovs: "albedo".parse().expect("names"),
            spp: Some(1),
            ..Default::default()
        },
    )
    .expect("job")
    .run(&Hooks::default())
    .expect("renders");
    let names: Vec<Aov> = finished.passes().iter().map(|p| p.aov).collect();
    assert_eq!(names, [Aov::Albedo, Aov::Depth, Aov::ObjectId]);
    // A misspelt pass is a located error with the names to choose from.
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        SCENE.replace(r#""seed": 3}"#, r#""seed": 3, "aov": ["albedo", "dept"]}"#),
    )
    .expect("scene written");
    let err = match lumo::load(&bad, &lumo::LoadOptions::default()) {
        Ok(_) => panic!("a misspelt pass was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("render.aov") && err.contains("depth"), "{err}");
}
