//! Render passes and denoising through the `lumo` binary: the multi-channel EXR that
//! `lumo render --aov … --denoise` writes is read back by OpenEXR's own Python bindings with
//! the channels, types and values lumo wrote; PNG output gets each pass beside the image;
//! `lumo merge` keeps the passes and refuses films of different passes; `lumo denoise`
//! denoises a merged EXR; `--denoise` without the library fails before rendering, with exit 2
//! and how to install it.
//!
//! These tests start processes, so they run one at a time (a lock), each bounded in time. Those
//! that need Open Image Denoise and OpenEXR's Python bindings (`tests/oidn/.venv`, see
//! `tests/oidn/requirements.txt`) skip loudly without them, unless `LUMO_REQUIRE_OIDN=1`.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One process test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Longest wait for any process.
const DEADLINE: Duration = Duration::from_secs(60);

const ALL: &str = "albedo,normal,depth,position,uv,object_id,material_id,std_error";
const SIZE: [&str; 6] = ["--width", "40", "--height", "30", "--spp", "4"];

fn lumo() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lumo"));
    c.stdin(Stdio::null());
    c
}

/// Runs the command to its end within the deadline.
fn run(mut cmd: Command) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts");
    let start = Instant::now();
    while child.try_wait().expect("waits").is_none() {
        if start.elapsed() > DEADLINE {
            let _ = child.kill();
            panic!("{cmd:?} did not finish in {DEADLINE:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

fn ok(cmd: Command) -> String {
    let what = format!("{cmd:?}");
    let out = run(cmd);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{what} failed: {err}");
    err
}

fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

fn cornell() -> PathBuf {
    common::root().join("scenes/cornell.json")
}

/// The Python of the test environment with OpenEXR and pyoidn, and the pyoidn folder; `None`
/// after a loud message when missing (a failure under `LUMO_REQUIRE_OIDN=1`).
fn oidn_env() -> Option<(PathBuf, PathBuf)> {
    let venv = common::root().join("tests/oidn/.venv");
    let python = venv.join("bin/python");
    let oidn = std::env::var_os("LUMO_OIDN")
        .map(PathBuf::from)
        .or_else(common::test_venv_pyoidn);
    if let (true, Some(oidn)) = (python.is_file(), oidn) {
        return Some((python, oidn));
    }
    if std::env::var_os("LUMO_REQUIRE_OIDN").is_some_and(|v| v == "1") {
        panic!("tests/oidn/.venv (OpenEXR, pyoidn) not found and LUMO_REQUIRE_OIDN=1");
    }
    eprintln!(
        "\n=== SKIPPED: tests/oidn/.venv not found (python3 -m venv tests/oidn/.venv && \
         tests/oidn/.venv/bin/pip install -r tests/oidn/requirements.txt) ===\n"
    );
    None
}

/// Reads an EXR with OpenEXR's Python bindings; prints, per channel, its pixel type and the
/// sum and first values of its pixels.
const READER: &str = r#"
import sys, json, OpenEXR, numpy as np
with OpenEXR.File(sys.argv[1], separate_channels=True) as f:
    out = {}
    for name, ch in f.channels().items():
        a = ch.pixels
        out[name] = {"dtype": str(a.dtype), "shape": list(a.shape),
                     "sum": float(a.astype(np.float64).sum()),
                     "first": [float(v) for v in a.reshape(-1)[:64]]}
    print(json.dumps(out))
"#;

#[test]
fn exr_passes_are_read_back_by_openexr() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let Some((python, oidn)) = oidn_env() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.exr");
    let mut cmd = lumo();
    cmd.env("LUMO_OIDN", &oidn).args(["render", p(&cornell())]);
    cmd.args(SIZE)
        .args(["--aov", ALL, "--denoise", "-q", "-o", p(&out)]);
    ok(cmd);
    let mut read = Command::new(&python);
    read.args(["-c", READER, p(&out)]);
    let output = run(read);
    assert!(
        output.status.success(),
        "OpenEXR could not read it: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let seen: serde_json::Value = serde_json::from_slice(&output.stdout).expect("json");
    let mut names: Vec<&str> = seen
        .as_object()
        .expect("object")
        .keys()
        .map(String::as_str)
        .collect();
    names.sort_unstable();
    let mut want = vec!["A", "B", "G", "R", "noisy.B", "noisy.G", "noisy.R"];
    for aov in lumo::aov::Aov::ALL {
        for c in aov.channels() {
            want.push(Box::leak(format!("{}.{c}", aov.name()).into_boxed_str()));
        }
    }
    want.sort_unstable();
    assert_eq!(names, want);
    // lumo's own reader agrees with OpenEXR's, channel by channel.
    let mine = lumo::multilayer::read_exr(&out).expect("lumo reads it");
    for (name, info) in seen.as_object().expect("object") {
        let dtype = info["dtype"].as_str().expect("dtype");
        assert_eq!(info["shape"], serde_json::json!([30, 40]), "{name}");
        let ids = name.ends_with(".I");
        assert_eq!(dtype, if ids { "uint32" } else { "float32" }, "{name}");
        let values: Vec<f64> = match name.split_once('.') {
            None => {
                let k = ["R", "G", "B", "A"]
                    .iter()
                    .position(|c| c == name)
                    .expect("rgba");
                mine.beauty
                    .pixels
                    .iter()
                    .map(|px| if k == 3 { 1.0 } else { f64::from(px[k]) })
                    .collect()
            }
            Some((group, suffix)) => {
                let g = mine.group(group).expect("group");
                let c = g.suffixes.len();
                let k = g.suffixes.iter().position(|s| s == suffix).expect("suffix");
                match &g.pixels {
                    lumo::aov::PassPixels::Float(v) => {
                        v.iter().skip(k).step_by(c).map(|&x| f64::from(x)).collect()
                    }
                    lumo::aov::PassPixels::Id(v) => {
                        v.iter().skip(k).step_by(c).map(|&x| f64::from(x)).collect()
                    }
                }
            }
        };
        let sum: f64 = values.iter().sum();
        let theirs = info["sum"].as_f64().expect("sum");
        assert!(
            (sum - theirs).abs() <= 1e-6 * theirs.abs().max(1.0),
            "{name}: sum {sum} here, {theirs} in OpenEXR"
        );
        let first: Vec<f64> = info["first"]
            .as_array()
            .expect("first")
            .iter()
            .filter_map(serde_json::Value::as_f64)
            .collect();
        assert_eq!(first, values[..64].to_vec(), "{name}");
    }
    // The beauty is the denoised one: not the noisy pass.
    let noisy = mine
        .group("noisy")
        .and_then(|g| g.to_rgb(40, 30))
        .expect("noisy");
    assert!(
        noisy.pixels != mine.beauty.pixels,
        "the beauty was not denoised"
    );
    // Object ids are those of the Cornell box's objects (1-based), and some pixels see each
    // wall.
    let ids = seen["object_id.I"]["sum"].as_f64().expect("ids");
    assert!(ids > 0.0);
}

#[test]
fn merged_films_keep_their_passes_and_lumo_denoise_uses_them() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let part = |name: &str, range: &str, aov: &str| {
        let film = dir.path().join(name);
        let mut cmd = lumo();
        cmd.args(["render", p(&cornell())]).args(&SIZE[..4]).args([
            "--samples",
            range,
            "--aov",
            aov,
            "-q",
            "--film",
            p(&film),
        ]);
        ok(cmd);
        film
    };
    // std_error is derived from the beauty's sums, and a merge writes it too.
    let a = part("a.npz", "0..3", "albedo,normal,depth,std_error");
    let b = part("b.npz", "3..6", "albedo,normal,depth,std_error");
    let c = part("c.npz", "3..6", "depth");
    // Films of other passes are refused, with the reason.
    let mut cmd = lumo();
    cmd.args(["merge", p(&a), p(&c), "-o", p(&dir.path().join("x.exr"))]);
    let out = run(cmd);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("render passes differ") && err.contains("--aov"),
        "{err}"
    );
    // The merge of the others is one render's image, passes included.
    let merged = dir.path().join("merged.exr");
    let mut cmd = lumo();
    cmd.args(["merge", p(&b), p(&a), "-o", p(&merged)]);
    ok(cmd);
    let whole = dir.path().join("whole.exr");
    let mut cmd = lumo();
    cmd.args(["render", p(&cornell())]).args(&SIZE[..4]).args([
        "--spp",
        "6",
        "--aov",
        "albedo,normal,depth,std_error",
        "-q",
        "-o",
        p(&whole),
    ]);
    ok(cmd);
    assert_eq!(
        std::fs::read(&merged).expect("merged"),
        std::fs::read(&whole).expect("whole"),
        "the merged EXR differs from one render's"
    );
    let layered = lumo::multilayer::read_exr(&merged).expect("reads");
    let names: Vec<&str> = layered.groups.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["albedo", "depth", "normal", "std_error"]);
    // PNG output: the passes beside the image.
    let png = dir.path().join("m.png");
    let mut cmd = lumo();
    cmd.args(["merge", p(&b), p(&a), "-o", p(&png)]);
    ok(cmd);
    for pass in ["albedo", "normal", "depth"] {
        let side = dir.path().join(format!("m.{pass}.png"));
        let img = image::open(&side).unwrap_or_else(|e| panic!("{}: {e}", side.display()));
        assert_eq!((img.width(), img.height()), (40, 30));
    }
    // lumo denoise on the merged EXR.
    let Some((_, oidn)) = oidn_env() else {
        return;
    };
    let denoised = dir.path().join("denoised.exr");
    let mut cmd = lumo();
    cmd.env("LUMO_OIDN", &oidn)
        .args(["denoise", p(&merged), "-o", p(&denoised)]);
    ok(cmd);
    let out = lumo::multilayer::read_exr(&denoised).expect("reads");
    let noisy = out
        .group("noisy")
        .and_then(|g| g.to_rgb(40, 30))
        .expect("noisy kept");
    assert_eq!(noisy.pixels, layered.beauty.pixels);
    assert_ne!(out.beauty.pixels, layered.beauty.pixels);
    assert!(out.group("albedo").is_some() && out.group("depth").is_some());
}

#[test]
fn denoise_without_the_library_fails_before_rendering() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out.png");
    let mut cmd = lumo();
    // A render that would take minutes: the failure must come before it.
    cmd.env("LUMO_OIDN", dir.path())
        .env_remove("OIDN_DIR")
        .args([
            "render",
            p(&cornell()),
            "--spp",
            "100000",
            "--denoise",
            "-o",
            p(&out),
        ]);
    let start = Instant::now();
    let result = run(cmd);
    let err = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{err}");
    assert!(
        err.contains("pip install pyoidn") && err.contains("LUMO_OIDN"),
        "no install help: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "it rendered first"
    );
    assert!(!out.exists());
    // `lumo denoise` says the same.
    let mut cmd = lumo();
    cmd.env("LUMO_OIDN", dir.path())
        .args(["denoise", p(&out), "-o", p(&dir.path().join("d.exr"))]);
    let result = run(cmd);
    assert_eq!(result.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&result.stderr).contains("pip install pyoidn"));
}
