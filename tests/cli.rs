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
