//! lumo as a library: one `lumo::load` for every input kind, the files it read, and a build
//! that reads nothing.

mod common;

use std::path::{Path, PathBuf};

use lumo::load::{InputKind, LoadError};
use lumo::LoadOptions;

/// The README's five lines, with the sample count lowered for a test.
#[test]
fn loads_renders_and_writes_a_scene_in_five_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cornell.png");
    let mut loaded = lumo::load(
        common::root().join("scenes/cornell.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    loaded.edit(|s| s.render.spp = 4).unwrap();
    let (scene, _warnings) = loaded.build().unwrap();
    let (image, _stats) = lumo::render::render(&scene, &Default::default());
    lumo::output::write_image(&image, &out, lumo::output::ToneMap::Clamp).unwrap();
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (256, 256));
    assert!(image.mean().length() > 0.05, "the Cornell box is not black");
}

fn names(files: &[PathBuf]) -> Vec<String> {
    files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect()
}

/// Every kind of input reports the files it read: the scene, then its meshes and images.
#[test]
fn every_input_kind_lists_the_files_it_read() {
    let root = common::root();
    let json = lumo::load(
        root.join("scenes/glass_bunny.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(json.description.kind, InputKind::Json);
    assert_eq!(names(&json.files()), ["glass_bunny.json", "glass_blob.obj"]);

    let legacy = root.join("scenes/legacy/transformed_mesh.txt");
    let legacy = lumo::load(&legacy, &LoadOptions::default()).unwrap();
    assert_eq!(legacy.description.kind, InputKind::Legacy);
    // Referenced twice, read once.
    assert_eq!(
        names(&legacy.files()),
        ["transformed_mesh.txt", "pyramid.obj"]
    );

    let Some(shared) = common::shared() else {
        return;
    };
    let gltf = shared.join("gltf/BoxTextured/glTF/BoxTextured.gltf");
    let gltf = lumo::load(&gltf, &LoadOptions::default()).unwrap();
    assert_eq!(gltf.description.kind, InputKind::Gltf);
    let mut files = names(&gltf.files());
    files.sort();
    assert_eq!(
        files,
        ["BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"]
    );
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// A temporary copy of `scenes/` with its assets.
fn scenes_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&common::root().join("scenes"), dir.path());
    copy_dir(
        &common::root().join("scenes/assets"),
        &dir.path().join("assets"),
    );
    dir
}

/// Building reads no file: the scene builds (and renders the same) after every file it
/// read is gone.
#[test]
fn building_reads_no_file() {
    let dir = scenes_copy();
    let mut loaded =
        lumo::load(dir.path().join("glass_bunny.json"), &LoadOptions::default()).unwrap();
    loaded
        .edit(|s| {
            s.image.width = 32;
            s.image.height = 32;
            s.render.spp = 2;
        })
        .unwrap();
    let before = lumo::render::render(&loaded.build().unwrap().0, &Default::default()).0;
    for f in loaded.files() {
        std::fs::remove_file(&f).unwrap();
    }
    let after = lumo::render::render(&loaded.build().unwrap().0, &Default::default()).0;
    assert_eq!(before.pixels, after.pixels);
}

/// Overrides are validated like the file: an invalid one is refused, with the file named, and
/// leaves the scene as it was.
#[test]
fn an_invalid_override_is_refused_and_changes_nothing() {
    let path = common::root().join("scenes/cornell.json");
    let mut loaded = lumo::load(&path, &LoadOptions::default()).unwrap();
    let err = loaded.edit(|s| s.camera.fov_y_deg = 200.0).unwrap_err();
    let LoadError::Invalid { diagnostics, .. } = &err else {
        panic!("not a located report: {err:?}");
    };
    assert_eq!(diagnostics.len(), 1, "{err}");
    assert_eq!(diagnostics[0].path.to_string(), "camera.fov_y_deg");
    assert!(!err.is_io());
    let msg = err.to_string();
    assert!(
        msg.contains("cornell.json") && msg.contains("camera.fov_y_deg"),
        "{msg}"
    );
    assert!((loaded.description.scene.camera.fov_y_deg - 200.0).abs() > 1.0);
}

/// A missing input is an I/O error, an unknown extension invalid input; both name the file.
#[test]
fn load_errors_say_whose_fault() {
    let missing = lumo::load("no/such/scene.json", &LoadOptions::default()).unwrap_err();
    assert!(missing.is_io(), "{missing}");
    assert_eq!(missing.file(), std::path::Path::new("no/such/scene.json"));
    let unknown = lumo::load("scene.yaml", &LoadOptions::default()).unwrap_err();
    assert!(!unknown.is_io(), "{unknown}");
    assert!(unknown.diagnostics().is_empty());
    assert!(unknown.to_string().contains(".json, .txt, .gltf or .glb"));
}

/// A job's films are the contract of split renders: two sample ranges rendered as separate
/// jobs (threads differ too) merge into the bits of one job taking all the samples, and the
/// merged film's header is that job's.
#[test]
fn two_sample_range_jobs_merge_into_one_job() {
    use lumo::job::{Hooks, JobSettings, RenderJob};
    let mut loaded = lumo::load(
        common::root().join("scenes/cornell.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    loaded
        .edit(|s| {
            s.image.width = 24;
            s.image.height = 18;
        })
        .unwrap();
    let run = |settings: JobSettings| {
        RenderJob::new(&loaded, settings)
            .unwrap()
            .run(&Hooks::default())
            .unwrap()
    };
    let whole = run(JobSettings {
        spp: Some(8),
        ..Default::default()
    });
    let first = run(JobSettings {
        samples: Some((0, 3)),
        threads: Some(1),
        ..Default::default()
    });
    let second = run(JobSettings {
        samples: Some((3, 8)),
        threads: Some(2),
        ..Default::default()
    });
    let merged = lumo::partial_film::merge(&[second.film().clone(), first.film().clone()]).unwrap();
    assert!(merged.gaps.is_empty(), "{:?}", merged.gaps);
    assert_eq!(merged.film, whole.sums);
    assert_eq!(merged.header.samples, vec![[0, 8]]);
    assert_eq!(merged.header.scene_hash, whole.film().header.scene_hash);
    assert_eq!(merged.film.image().pixels, whole.image.pixels);
}

/// A job whose scene hash is deferred (`lumo render` without `--film`, `--checkpoint` or
/// `--resume`) spends no start time on it, and its films still carry the hash an eager job
/// takes, so an interrupted render's checkpoint resumes; when a file of the scene changed
/// after loading, its films match no other film and it keeps no checkpoint.
#[test]
fn a_deferred_scene_hash_is_the_eager_one_or_none() {
    use lumo::job::{Hooks, JobSettings, RenderJob};
    let dir = scenes_copy();
    let options = LoadOptions {
        defer_input_hash: true,
        ..LoadOptions::default()
    };
    let mut loaded = lumo::load(dir.path().join("glass_bunny.json"), &options).unwrap();
    loaded
        .edit(|s| {
            s.image.width = 16;
            s.image.height = 12;
        })
        .unwrap();
    let run = |defer_scene_hash: bool| {
        RenderJob::new(
            &loaded,
            JobSettings {
                spp: Some(2),
                defer_scene_hash,
                ..Default::default()
            },
        )
        .unwrap()
        .run(&Hooks::default())
        .unwrap()
    };
    let eager = run(false);
    let deferred = run(true);
    let hash = &eager.film().header.scene_hash;
    assert!(hash.starts_with("sha256:"), "{hash}");
    assert_eq!(&deferred.film().header.scene_hash, hash);
    assert!(deferred.scene_hash_failure().is_none());
    assert!(deferred.checkpoint().is_some());

    // A mesh rewritten (one byte longer) after the job was set up.
    let later = run(true);
    let mesh = loaded
        .files()
        .into_iter()
        .find(|f| f.extension().is_some_and(|e| e == "obj"))
        .expect("the glass bunny reads an OBJ mesh");
    let mut bytes = std::fs::read(&mesh).unwrap();
    bytes.push(b'\n');
    std::fs::write(&mesh, bytes).unwrap();
    let failure = later
        .scene_hash_failure()
        .expect("the changed mesh is noticed");
    assert!(
        failure.contains(&*mesh.file_name().unwrap().to_string_lossy()),
        "{failure}"
    );
    assert!(later.checkpoint().is_none());
    assert_ne!(&later.film().header.scene_hash, hash);
    // The eager job's films were hashed when it was set up.
    assert_eq!(&eager.film().header.scene_hash, hash);
}

/// A job checks what it cannot render before it starts: a window outside the image, a sample
/// range together with a time budget, and a checkpoint of another resolution (named as such,
/// not as another scene).
#[test]
fn a_job_refuses_what_it_cannot_render() {
    use lumo::job::{JobError, JobSettings, RenderJob};
    use lumo::render::Window;
    let loaded = lumo::load(
        common::root().join("scenes/cornell.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    let err = |settings: JobSettings| match RenderJob::new(&loaded, settings) {
        Ok(_) => panic!("accepted"),
        Err(e) => e,
    };
    let e = err(JobSettings {
        crop: Some(Window {
            x0: 0,
            y0: 0,
            x1: 300,
            y1: 10,
        }),
        ..Default::default()
    });
    assert!(
        e.to_string().contains("not inside the 256×256 image"),
        "{e}"
    );
    let e = err(JobSettings {
        samples: Some((0, 4)),
        time_s: Some(1.0),
        ..Default::default()
    });
    assert!(matches!(e, JobError::Invalid(_)), "{e}");
    let mut small = loaded.clone();
    small.edit(|s| s.image.width = 16).unwrap();
    let ck = RenderJob::new(
        &small,
        JobSettings {
            spp: Some(1),
            ..Default::default()
        },
    )
    .unwrap()
    .run(&Default::default())
    .unwrap()
    .checkpoint()
    .expect("a uniform render has a checkpoint");
    let e = err(JobSettings {
        resume: Some(ck),
        ..Default::default()
    });
    assert!(
        matches!(&e, JobError::Resume(m) if m.contains("the resolution differs: 256×256 here, 16×256")),
        "{e}"
    );
}

/// A scene edited as data keeps the meshes and images it shares with the scene it came from,
/// and is validated like a file.
#[test]
fn a_scene_with_another_description_shares_its_assets() {
    let loaded = lumo::load(
        common::root().join("scenes/glass_bunny.json"),
        &LoadOptions::default(),
    )
    .unwrap();
    let mut scene = (*loaded.description.scene).clone();
    scene.render.seed += 1;
    let edited = loaded.with_scene(scene.clone()).unwrap();
    let mesh = |l: &lumo::Loaded| {
        let source = l
            .description
            .scene
            .objects
            .iter()
            .find_map(|o| match o {
                lumo_schema::Object::Mesh(m)
                    if matches!(m.source, lumo_schema::MeshSource::Obj(_)) =>
                {
                    Some(m.source.clone())
                }
                _ => None,
            })
            .expect("the bunny is an OBJ mesh");
        l.assets.mesh(&source).expect("read").clone()
    };
    assert!(std::sync::Arc::ptr_eq(&mesh(&loaded), &mesh(&edited)));
    scene.camera.fov_y_deg = 200.0;
    let e = loaded.with_scene(scene).unwrap_err();
    assert_eq!(e.diagnostics().len(), 1, "{e}");
    assert_eq!(e.diagnostics()[0].path.to_string(), "camera.fov_y_deg");
}
