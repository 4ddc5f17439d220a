//! The command-line contract: subcommands, exit codes, messages, atomic outputs.

mod common;

use assert_cmd::Command;

fn lumo() -> Command {
    let mut c = Command::cargo_bin("lumo").unwrap();
    c.current_dir(common::root());
    c
}

#[test]
fn renders_a_tiny_cornell_box_to_png_and_exr() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["png", "exr", "hdr", "bmp"] {
        let out = dir.path().join(format!("c.{ext}"));
        let assert = lumo()
            .args([
                "render",
                "scenes/cornell.json",
                "--spp",
                "2",
                "--width",
                "24",
                "--height",
                "16",
                "-q",
                "-o",
            ])
            .arg(&out)
            .assert()
            .success();
        let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(
            stderr.contains("rendered 24×16 at 2 spp"),
            "summary line missing: {stderr}"
        );
        let img = image::open(&out).unwrap();
        assert_eq!((img.width(), img.height()), (24, 16));
    }
    // Nothing but the outputs is left behind (no temporary files).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 4);
}

#[test]
fn a_failed_render_keeps_the_previous_image() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("keep.png");
    std::fs::write(&out, b"previous image").unwrap();
    lumo()
        .args(["render", "tests/invalid/three_mistakes.json", "-o"])
        .arg(&out)
        .assert()
        .code(2);
    assert_eq!(std::fs::read(&out).unwrap(), b"previous image");
}

#[test]
fn validate_exit_codes_and_messages() {
    lumo()
        .args(["validate", "scenes/cornell.json"])
        .assert()
        .success()
        .stdout(predicates::str::contains("ok"));
    let out = lumo()
        .args([
            "validate",
            "scenes/cornell.json",
            "tests/invalid/three_mistakes.json",
        ])
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    for needle in [
        "3 problems",
        "three_mistakes.json:3:",
        "camera.up",
        "three_mistakes.json:5:",
        "materials.mix",
        "three_mistakes.json:8:",
        "objects[0].sphere.radius",
    ] {
        assert!(err.contains(needle), "`{needle}` missing from:\n{err}");
    }
    lumo()
        .args(["validate", "no/such/file.json"])
        .assert()
        .code(1)
        .stderr(predicates::str::contains("cannot read"));
    lumo()
        .args(["validate", "Cargo.toml"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("input kind"));
}

#[test]
fn schema_command_prints_the_checked_in_schema() {
    let out = lumo().arg("schema").assert().success();
    let on_disk = std::fs::read_to_string(common::root().join("schema/scene.schema.json")).unwrap();
    assert_eq!(String::from_utf8_lossy(&out.get_output().stdout), on_disk);
}

#[test]
fn bad_arguments_are_invalid_input() {
    lumo()
        .args(["render", "scenes/cornell.json", "-o", "x.jpg"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("unsupported image format"));
    lumo()
        .args(["render", "scenes/cornell.json", "-o", "x.png", "--spp", "0"])
        .assert()
        .code(2);
    for sub in ["render", "validate", "schema"] {
        lumo()
            .args([sub, "--help"])
            .assert()
            .success()
            .stdout(predicates::str::contains("Example:"));
    }
}

/// `lumo version` says how many paths each thread runs in SIMD lanes (this CPU's widest, or
/// what `LUMO_SIMD` forces); a `LUMO_SIMD` that is not a width is refused before any work, with
/// exit code 2 and the values allowed.
#[test]
fn lane_width_is_reported_and_can_be_forced() {
    let version = |simd: Option<&str>| {
        let mut c = lumo();
        c.arg("version");
        match simd {
            Some(v) => c.env("LUMO_SIMD", v),
            None => c.env_remove("LUMO_SIMD"),
        };
        let out = c.assert().success().get_output().stdout.clone();
        serde_json::from_slice::<serde_json::Value>(&out).unwrap()
    };
    let native = version(None)["native_lanes"].as_u64().unwrap();
    assert!([1, 4, 8, 16].contains(&native), "native width {native}");
    assert_eq!(version(None)["lanes"].as_u64(), Some(native));
    assert_eq!(version(Some("4"))["lanes"].as_u64(), Some(4));
    let dir = tempfile::tempdir().unwrap();
    let assert = lumo()
        .env("LUMO_SIMD", "3")
        .args(["render", "scenes/cornell.json", "--spp", "1", "-q", "-o"])
        .arg(dir.path().join("c.png"))
        .assert()
        .code(2);
    let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
    assert!(
        stderr.contains("LUMO_SIMD") && stderr.contains("1, 4, 8 or 16"),
        "{stderr}"
    );
    assert!(!dir.path().join("c.png").exists());
}

/// `lumo render` of cornell.json at 24×16, 2 spp, with `extra` arguments, as linear pixels.
fn tiny_render(scene: &std::path::Path, extra: &[&str], out: &std::path::Path) -> Vec<f32> {
    lumo()
        .args([
            "render", "--spp", "2", "--width", "24", "--height", "16", "-q",
        ])
        .arg(scene)
        .args(extra)
        .arg("-o")
        .arg(out)
        .assert()
        .success();
    image::open(out).unwrap().to_rgb32f().into_raw()
}

#[test]
fn set_renders_the_changed_scene_and_bundles_hash_it() {
    let dir = tempfile::tempdir().unwrap();
    let cornell = common::root().join("scenes/cornell.json");
    let set = ["--set", "materials.red.base_color=[0.2,0.2,0.8]"];
    let changed = tiny_render(&cornell, &set, &dir.path().join("set.exr"));
    let original = tiny_render(&cornell, &[], &dir.path().join("original.exr"));
    // The same change written into a copy of the file.
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cornell).unwrap()).unwrap();
    doc["materials"]["red"]["base_color"] = serde_json::json!([0.2, 0.2, 0.8]);
    let baked = dir.path().join("baked.json");
    std::fs::write(&baked, doc.to_string()).unwrap();
    let written = tiny_render(&baked, &[], &dir.path().join("baked.exr"));
    assert_eq!(changed, written, "--set and the edited file render alike");
    assert_ne!(changed, original);
    // The red wall turned blue: over the image, blue gains on red.
    let blue_minus_red = |img: &[f32]| img.chunks(3).map(|p| p[2] - p[0]).sum::<f32>();
    assert!(
        blue_minus_red(&changed) > blue_minus_red(&original) + 10.0,
        "{} {}",
        blue_minus_red(&changed),
        blue_minus_red(&original)
    );

    // Partial films and bundles hash the composed scene: the same as the edited file's.
    let hash = |scene: &std::path::Path, extra: &[&str], name: &str| {
        let out = lumo()
            .arg("bundle")
            .arg(scene)
            .args(extra)
            .arg("-o")
            .arg(dir.path().join(name))
            .assert()
            .success();
        let line: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
        line["scene_hash"].as_str().unwrap().to_string()
    };
    let set_hash = hash(&cornell, &set, "set.zip");
    assert_eq!(set_hash, hash(&baked, &[], "baked.zip"));
    assert_ne!(set_hash, hash(&cornell, &[], "original.zip"));
    // A patch does the same, and the shorthands are the same mechanism.
    let patch = dir.path().join("blue.json");
    std::fs::write(
        &patch,
        r#"{"materials": {"red": {"base_color": [0.2, 0.2, 0.8]}}}"#,
    )
    .unwrap();
    let patched = hash(&cornell, &["--patch", patch.to_str().unwrap()], "p.zip");
    assert_eq!(patched, set_hash);
    assert_eq!(
        hash(&cornell, &["--set", "render.seed=7"], "s.zip"),
        hash(&cornell, &["--seed", "7"], "seed.zip")
    );
}

#[test]
fn overrides_that_name_nothing_or_mistype_are_located() {
    let dir = tempfile::tempdir().unwrap();
    for command in ["validate", "convert", "render", "bundle"] {
        let mut c = lumo();
        c.args([command, "scenes/cornell.json"]);
        c.args([
            "--set",
            "render.spp=4",
            "--set",
            "materials.redd.base_color=[1,1,1]",
        ]);
        match command {
            "convert" => c.arg("-o").arg(dir.path().join("out.json")),
            "render" => c.arg("-o").arg(dir.path().join("out.png")),
            "bundle" => c.arg("-o").arg(dir.path().join("out.zip")),
            _ => &mut c,
        };
        let out = c.assert().code(2);
        let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        assert!(
            err.contains("--set #2:1:11: materials.redd: the override names nothing")
                && err.contains("did you mean `materials.red`?"),
            "{command}: {err}"
        );
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    let err = |args: &[&str]| {
        let out = lumo().args(args).assert().code(2);
        String::from_utf8_lossy(&out.get_output().stderr).to_string()
    };
    let e = err(&[
        "validate",
        "scenes/cornell.json",
        "--set",
        "render.spp=\"64\"",
    ]);
    assert!(
        e.contains("--set #1:1:12: render.spp: expected a non-negative integer, found a string"),
        "{e}"
    );
    let e = err(&["validate", "scenes/cornell.json", "--set", "render.spp"]);
    assert!(
        e.contains("--set #1:1:11:") && e.contains("expected PATH=VALUE"),
        "{e}"
    );
    let patch = dir.path().join("patch.json");
    std::fs::write(&patch, "{\n  \"render\": {\"spp\": -1}\n}\n").unwrap();
    let e = err(&[
        "validate",
        "scenes/cornell.json",
        "--patch",
        patch.to_str().unwrap(),
    ]);
    assert!(
        e.contains(&format!("{}:2:21: render.spp:", patch.display())),
        "{e}"
    );
}

#[test]
fn scenes_with_includes_flatten_bundle_and_validate_their_fragments() {
    let dir = tempfile::tempdir().unwrap();
    let flat = dir.path().join("flat.json");
    lumo()
        .args(["convert", "scenes/studio.json", "-o"])
        .arg(&flat)
        .assert()
        .success();
    let text = std::fs::read_to_string(&flat).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(doc.get("include").is_none(), "{text}");
    assert!(
        doc["materials"]["softbox"].is_object() && doc["lights"].as_array().unwrap().len() == 2
    );
    // The flat scene is the same scene: the same content hash.
    let hash = |scene: &std::path::Path, name: &str| {
        let out = lumo()
            .arg("bundle")
            .arg(scene)
            .arg("-o")
            .arg(dir.path().join(name))
            .assert()
            .success();
        let line: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
        line["scene_hash"].as_str().unwrap().to_string()
    };
    assert_eq!(
        hash(&common::root().join("scenes/studio.json"), "a.zip"),
        hash(&flat, "b.zip")
    );
    // Fragments validate on their own; a problem in one is placed in it.
    let out = lumo()
        .args([
            "validate",
            "scenes/studio.json",
            "scenes/common/materials.json",
        ])
        .assert()
        .success();
    let said = String::from_utf8_lossy(&out.get_output().stdout).to_string();
    assert!(
        said.contains("materials.json: ok (a scene fragment)"),
        "{said}"
    );
    let fragment = dir.path().join("rig.json");
    std::fs::write(
        &fragment,
        "{\"$schema\": \"scene-fragment.schema.json\",\n \"materials\": {\"a\": {\"roughness\": 3}}}",
    )
    .unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(
        &scene,
        "{\"format_version\": 2,\n \"camera\": {\"position\": [0, 0, 3], \"look_at\": [0, 0, 0], \"fov_y_deg\": 40},\n \"materials\": {},\n \"include\": [\"rig.json\"], \"objects\": []}",
    )
    .unwrap();
    for (file, chain) in [(&fragment, false), (&scene, true)] {
        let out = lumo().arg("validate").arg(file).assert().code(2);
        let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        assert!(
            err.contains(&format!(
                "{}:2:35: materials.a.roughness: roughness 3 is outside [0, 1]",
                fragment.display()
            )),
            "{err}"
        );
        assert_eq!(
            err.contains(&format!("included from {}:4:14", scene.display())),
            chain,
            "{err}"
        );
    }
}

/// Every file path a JSON scene stores (textures, meshes, the background image).
fn stored_paths(doc: &serde_json::Value) -> Vec<String> {
    let mut found = Vec::new();
    if let Some(textures) = doc["textures"].as_object() {
        found.extend(
            textures
                .values()
                .filter_map(|t| t["file"].as_str().map(String::from)),
        );
    }
    for o in doc["objects"].as_array().into_iter().flatten() {
        let source = &o["mesh"]["source"];
        found.extend(source["obj"].as_str().map(String::from));
        found.extend(source["gltf"]["file"].as_str().map(String::from));
    }
    found.extend(doc["background"]["image"].as_str().map(String::from));
    found
}

#[test]
fn converted_scenes_name_one_schema_beside_them_and_paths_that_travel() {
    let dir = tempfile::tempdir().unwrap();
    let check = |out: &std::path::Path| -> Vec<String> {
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
        assert_eq!(doc["$schema"], "scene.schema.json", "{}", out.display());
        let beside = out.parent().unwrap().join("scene.schema.json");
        assert_eq!(
            std::fs::read_to_string(&beside).unwrap(),
            lumo_schema::json_schema(),
            "the schema is written beside {}",
            out.display()
        );
        lumo().arg("validate").arg(out).assert().success();
        stored_paths(&doc)
    };

    // Legacy → JSON, written far from the legacy scene's assets (the temporary folder and the
    // checkout share no folder but the root): absolute paths, never `../../…` up to the root.
    std::fs::create_dir_all(dir.path().join("legacy")).unwrap();
    for input in ["transformed_mesh.txt", "textured_sphere.txt"] {
        let out = dir
            .path()
            .join("legacy")
            .join(input.replace(".txt", ".json"));
        lumo()
            .args(["convert", &format!("scenes/legacy/{input}"), "-o"])
            .arg(&out)
            .assert()
            .success();
        let paths = check(&out);
        assert!(!paths.is_empty(), "{input}");
        for p in paths {
            assert!(std::path::Path::new(&p).is_absolute(), "{input}: {p}");
        }
    }

    // A project folder (a scene and its mesh) converted to .glb and back to JSON two folders
    // down: the mesh's path is relative, and the folder still loads once moved elsewhere.
    let project = dir.path().join("project");
    std::fs::create_dir_all(project.join("assets")).unwrap();
    std::fs::create_dir_all(project.join("out/json")).unwrap();
    std::fs::copy(
        common::root().join("scenes/assets/glass_blob.obj"),
        project.join("assets/glass_blob.obj"),
    )
    .unwrap();
    std::fs::copy(
        common::root().join("scenes/glass_bunny.json"),
        project.join("bunny.json"),
    )
    .unwrap();
    lumo()
        .arg("convert")
        .arg(project.join("bunny.json"))
        .arg("-o")
        .arg(project.join("out/bunny.glb"))
        .assert()
        .success();
    let out = project.join("out/json/bunny.json");
    lumo()
        .arg("convert")
        .arg(project.join("out/bunny.glb"))
        .arg("-o")
        .arg(&out)
        .assert()
        .success();
    let paths = check(&out);
    assert_eq!(paths, ["../../assets/glass_blob.obj"]);
    let moved = dir.path().join("moved");
    std::fs::rename(&project, &moved).unwrap();
    lumo()
        .arg("validate")
        .arg(moved.join("out/json/bunny.json"))
        .assert()
        .success();

    // A file of that name that is not lumo's schema is left alone.
    let foreign = dir.path().join("foreign");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("scene.schema.json"), "{\"title\": \"mine\"}").unwrap();
    // (With a background image, whose path is rewritten for the new folder like the others.)
    let assert = lumo()
        .args([
            "convert",
            "scenes/cornell.json",
            "--set",
            r#"background.image="../tests/reference/cornell_mitsuba_4096.exr""#,
            "-o",
        ])
        .arg(foreign.join("c.json"))
        .assert()
        .success();
    let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
    assert!(stderr.contains("not lumo's scene schema"), "{stderr}");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(foreign.join("c.json")).unwrap()).unwrap();
    assert_eq!(
        stored_paths(&doc),
        [common::root()
            .join("tests/reference/cornell_mitsuba_4096.exr")
            .display()
            .to_string()]
    );
    lumo()
        .arg("validate")
        .arg(foreign.join("c.json"))
        .assert()
        .success();
    assert_eq!(
        std::fs::read_to_string(foreign.join("scene.schema.json")).unwrap(),
        "{\"title\": \"mine\"}"
    );
}

#[test]
fn converge_takes_set_and_patch() {
    // A --set that names nothing is a located error, as in every command that loads a scene.
    let assert = lumo()
        .args(["converge", "scenes/cornell.json", "--set", "image.wdth=32"])
        .assert()
        .code(2);
    let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
    assert!(stderr.contains("--set #1:"), "{stderr}");
    // A valid one changes the scene converge renders: here its size, which no longer matches
    // the reference's (refused before any render).
    let dir = tempfile::tempdir().unwrap();
    let assert = lumo()
        .args([
            "converge",
            "scenes/cornell.json",
            "--reference",
            "tests/reference/cornell_mitsuba_4096.exr",
            "--set",
            "image.width=32",
            "-o",
        ])
        .arg(dir.path().join("conv"))
        .assert()
        .failure();
    let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
    assert!(stderr.contains("but the scene renders 32×"), "{stderr}");
}
