//! `lumo preview` end to end: real server processes on 127.0.0.1, a raw HTTP client, the
//! server-sent event stream awaited for each state (no fixed sleeps where an event can be
//! awaited), and a real browser (Debian's Chromium driven by playwright-core,
//! `tests/browser/preview.mjs`).
//!
//! These tests start processes, so they live in their own test binary and run one at a time
//! (a lock), each bounded in time by a deadline on every wait.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use serde_json::Value;

/// One process test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Longest wait for any state.
const DEADLINE: Duration = Duration::from_secs(60);

/// Small, quick renders.
const SMALL: [&str; 6] = ["--width", "48", "--height", "48", "--spp", "16"];

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A running `lumo preview`, killed when dropped.
struct Preview {
    child: Child,
    addr: SocketAddr,
}

impl Drop for Preview {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Preview {
    /// Starts `lumo preview SCENE --port 0 ARGS…` and reads the address it serves on.
    fn start(scene: &Path, args: &[&str]) -> Preview {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lumo"))
            .arg("preview")
            .arg(scene)
            .args(["--port", "0", "--threads", "2"])
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start lumo preview");
        let stderr = child.stderr.take().expect("stderr");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                eprintln!("[lumo preview] {line}");
                if let Some(rest) = line.split("http://").nth(1) {
                    let addr = rest.trim_end_matches(|c| c != '/').trim_end_matches('/');
                    let _ = tx.send(addr.to_string());
                }
            }
        });
        let addr = rx
            .recv_timeout(DEADLINE)
            .expect("lumo preview printed no address")
            .parse()
            .expect("an address");
        Preview { child, addr }
    }

    /// A request with this server's own `Host`; returns (status, headers, body).
    fn request(&self, method: &str, target: &str) -> (u16, String, Vec<u8>) {
        self.request_as(method, target, &self.addr.to_string())
    }

    /// A request written byte for byte (the target is not normalised, as curl would).
    fn request_as(&self, method: &str, target: &str, host: &str) -> (u16, String, Vec<u8>) {
        let mut s = TcpStream::connect(self.addr).expect("connect");
        s.set_read_timeout(Some(DEADLINE)).expect("timeout");
        write!(
            s,
            "{method} {target} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\nContent-Length: 0\r\n\r\n"
        )
        .expect("send");
        let mut raw = Vec::new();
        s.read_to_end(&mut raw).expect("read response");
        let split = raw
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .expect("a header");
        let head = String::from_utf8_lossy(&raw[..split]).to_string();
        let status = head
            .split(' ')
            .nth(1)
            .and_then(|c| c.parse().ok())
            .expect("a status code");
        let mut body = raw[split + 4..].to_vec();
        if head
            .to_ascii_lowercase()
            .contains("transfer-encoding: chunked")
        {
            body = dechunk(&body);
        }
        (status, head, body)
    }

    fn status(&self) -> Value {
        let (code, _, body) = self.request("GET", "/status");
        assert_eq!(code, 200);
        serde_json::from_slice(&body).expect("status JSON")
    }

    /// Follows the event stream until a status satisfies `until`; returns it.
    fn wait_for(&self, what: &str, until: impl Fn(&Value) -> bool) -> Value {
        let start = Instant::now();
        let mut s = TcpStream::connect(self.addr).expect("connect");
        s.set_read_timeout(Some(Duration::from_secs(1)))
            .expect("timeout");
        write!(
            s,
            "GET /events HTTP/1.1\r\nHost: {}\r\nAccept: text/event-stream\r\n\r\n",
            self.addr
        )
        .expect("send");
        let mut reader = BufReader::new(s);
        let mut line = String::new();
        let mut last = Value::Null;
        loop {
            assert!(
                start.elapsed() < DEADLINE,
                "waited {DEADLINE:?} for {what}; last status: {last}"
            );
            line.clear();
            match reader.read_line(&mut line) {
                Ok(0) => panic!("the event stream ended while waiting for {what}"),
                Ok(_) => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    continue
                }
                Err(e) => panic!("event stream: {e}"),
            }
            // Chunk-size lines and keep-alive comments are not events.
            if let Some(data) = line.trim_end().strip_prefix("data: ") {
                if let Ok(v) = serde_json::from_str::<Value>(data) {
                    if until(&v) {
                        return v;
                    }
                    last = v;
                }
            }
        }
    }

    /// Waits until render number `n` (or a later one) has taken all its samples.
    fn wait_done(&self, n: u64) -> Value {
        self.wait_for(&format!("render {n} done"), |s| {
            s["renders"].as_u64() >= Some(n) && s["state"] == "done"
        })
    }
}

fn dechunk(mut body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let Some(eol) = body.windows(2).position(|w| w == b"\r\n") else {
            return out;
        };
        let size =
            usize::from_str_radix(std::str::from_utf8(&body[..eol]).unwrap_or("0").trim(), 16)
                .unwrap_or(0);
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&body[eol + 2..eol + 2 + size]);
        body = &body[eol + 4 + size..];
    }
}

/// A temporary folder holding a copy of the Cornell box scene (its `$schema` dropped: it
/// points into the repository).
fn cornell_copy(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(common::root().join("scenes/cornell.json")).expect("read");
    let scene = dir.join("cornell.json");
    write_atomically(
        &scene,
        &text.replace("\"$schema\": \"../schema/scene.schema.json\",", ""),
    );
    scene
}

/// Writes as editors do: a temporary file renamed over the target.
fn write_atomically(path: &Path, text: &str) {
    let tmp = path.with_extension("edit-tmp");
    std::fs::write(&tmp, text).expect("write");
    std::fs::rename(&tmp, path).expect("rename");
}

const RED: &str = r#""red": {"base_color": [0.570068, 0.0430135, 0.0443706]"#;

#[test]
fn a_storm_of_fifty_writes_in_a_second_renders_at_most_twice() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let original = std::fs::read_to_string(&scene).expect("read");
    let preview = Preview::start(&scene, &SMALL);
    preview.wait_done(1);
    // 50 writes in a second, each different (a slowly changing wall colour), as a script or an
    // editor's autosave might make them.
    let start = Instant::now();
    for i in 0..50 {
        let v = format!("0.{:02}", 10 + i);
        let text = original.replace(RED, &format!(r#""red": {{"base_color": [{v}, 0.05, 0.05]"#));
        if i % 2 == 0 {
            write_atomically(&scene, &text);
        } else {
            std::fs::write(&scene, &text).expect("write in place");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let storm = start.elapsed();
    let after = preview.wait_done(2);
    // Proving that no further render starts needs a wait: three quiet periods of the watcher.
    std::thread::sleep(Duration::from_millis(450));
    let renders = preview.status()["renders"].as_u64().expect("renders");
    assert!(
        renders <= 3,
        "{renders} renders in all: the initial one and {} for a storm of 50 writes in {storm:?}",
        renders - 1
    );
    assert_eq!(after["error"], Value::Null);
}

#[test]
fn a_deleted_and_recreated_scene_renders_again() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let text = std::fs::read_to_string(&scene).expect("read");
    let preview = Preview::start(&scene, &SMALL);
    let first = preview.wait_done(1);
    std::fs::remove_file(&scene).expect("delete");
    let gone = preview.wait_for("the missing file reported", |s| s["state"] == "failed");
    let message = gone["error"].as_str().unwrap_or_default();
    assert!(
        message.contains("cornell.json") && message.contains("cannot read"),
        "{message}"
    );
    // The last image stays.
    assert_eq!(gone["frame"], first["frame"]);
    std::fs::write(
        &scene,
        text.replace(RED, r#""red": {"base_color": [0.05, 0.1, 0.6]"#),
    )
    .expect("recreate");
    let back = preview.wait_done(3);
    assert_eq!(back["error"], Value::Null);
    assert!(back["frame"].as_u64() > first["frame"].as_u64());
}

#[test]
fn an_invalid_scene_shows_the_located_report_and_a_fix_resumes() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let good = std::fs::read_to_string(&scene).expect("read");
    write_atomically(
        &scene,
        &good.replace(RED, r#""red": {"base_color": [0.5, 0.04]"#),
    );
    let preview = Preview::start(&scene, &SMALL);
    let bad = preview.wait_for("the validation report", |s| s["state"] == "invalid");
    let report = bad["error"].as_str().unwrap_or_default();
    // The same report as `lumo validate`.
    let validate = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("validate")
        .arg(&scene)
        .output()
        .expect("validate");
    assert_eq!(validate.status.code(), Some(2));
    let printed = String::from_utf8_lossy(&validate.stderr);
    assert!(
        printed.contains(report),
        "page: {report}\nlumo validate: {printed}"
    );
    assert!(
        report.contains("cornell.json:") && report.contains("materials.red.base_color"),
        "{report}"
    );
    assert_eq!(bad["frame"], 0, "no image from an invalid scene");
    write_atomically(&scene, &good);
    let fixed = preview.wait_done(2);
    assert_eq!(fixed["error"], Value::Null);
    assert!(fixed["frame"].as_u64() > Some(0));
}

/// Writes a small Radiance HDR sky (`image` encodes it).
fn write_sky(path: &Path) {
    let sky = image::Rgb32FImage::from_fn(16, 8, |x, y| {
        image::Rgb([0.2 + 0.05 * x as f32, 0.3, 0.1 + 0.1 * y as f32])
    });
    image::DynamicImage::ImageRgb32F(sky)
        .save(path)
        .expect("write the sky");
}

#[test]
fn files_the_scene_reads_reach_the_page_only_as_the_render() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::create_dir_all(dir.path().join("scene")).expect("mkdir");
    std::fs::create_dir_all(dir.path().join("outside")).expect("mkdir");
    let sky = dir.path().join("outside/secret_sky.hdr");
    write_sky(&sky);
    let secret = std::fs::read(&sky).expect("read");
    let scene = cornell_copy(&dir.path().join("scene"));
    let text = std::fs::read_to_string(&scene).expect("read");
    let with_sky = text.replace(
        r#""background": {
    "color": [0, 0, 0]
  }"#,
        r#""background": {"image": "../outside/secret_sky.hdr"}"#,
    );
    assert_ne!(with_sky, text, "the scene's background was not replaced");
    write_atomically(&scene, &with_sky);
    let preview = Preview::start(&scene, &SMALL);
    let done = preview.wait_done(1);
    assert_eq!(done["error"], Value::Null, "{done}");
    for target in [
        "/outside/secret_sky.hdr",
        "/../outside/secret_sky.hdr",
        "/%2e%2e/outside/secret_sky.hdr",
        "/..%2foutside%2fsecret_sky.hdr",
        "/frame/../../outside/secret_sky.hdr",
        "/frame?kind=../outside/secret_sky.hdr",
        "/secret_sky.hdr",
        "/cornell.json",
        "/scene/cornell.json",
        "//etc/passwd",
        "/events/../cornell.json",
        &format!("/{}", sky.display()),
    ] {
        let (code, _, body) = preview.request("GET", target);
        assert!(
            code == 404 || code == 400,
            "GET {target}: status {code}, expected 404 or 400"
        );
        assert!(
            !body.windows(16).any(|w| secret.windows(16).any(|s| s == w)),
            "GET {target}: the body holds bytes of the sky file"
        );
        assert!(!String::from_utf8_lossy(&body).contains("\"materials\""));
    }
    // The sky does reach the page, as rendered radiance.
    let (code, _, frame) = preview.request("GET", "/frame?kind=image");
    assert_eq!(code, 200);
    assert_eq!(frame.len(), 48 * 48 * 12);
    // A page elsewhere that resolves its name to 127.0.0.1 (DNS rebinding) is refused.
    let (code, _, _) = preview.request_as("GET", "/status", "attacker.example:80");
    assert_eq!(code, 403);
}

#[test]
fn save_writes_what_lumo_render_writes() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let saved = dir.path().join("saved.png");
    let preview = Preview::start(
        &scene,
        &[&SMALL[..], &["-o", saved.to_str().expect("utf-8")]].concat(),
    );
    preview.wait_done(1);
    let (code, _, body) = preview.request("POST", "/save?tonemap=aces&exposure=0");
    assert_eq!(code, 200, "{}", String::from_utf8_lossy(&body));
    let rendered = dir.path().join("rendered.png");
    let status = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("render")
        .arg(&scene)
        .args(SMALL)
        .args(["--tonemap", "aces", "-q", "-o"])
        .arg(&rendered)
        .status()
        .expect("lumo render");
    assert!(status.success());
    assert_eq!(
        std::fs::read(&saved).expect("saved"),
        std::fs::read(&rendered).expect("rendered"),
        "the saved image differs from lumo render's"
    );
    // No temporary file left beside it.
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .expect("list")
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with(".lumo-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    // Bad requests are refused with a reason.
    let (code, _, body) = preview.request("POST", "/save?tonemap=sepia");
    assert_eq!(code, 400);
    assert!(String::from_utf8_lossy(&body).contains("sepia"));
}

#[test]
fn legacy_and_gltf_scenes_preview_too() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let glb = dir.path().join("cornell.glb");
    let converted = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("convert")
        .arg(common::root().join("scenes/cornell.json"))
        .arg("-o")
        .arg(&glb)
        .status()
        .expect("lumo convert");
    assert!(converted.success());
    for scene in [
        common::root().join("scenes/legacy/cornell_box.txt"),
        glb.clone(),
    ] {
        let preview = Preview::start(
            &scene,
            &[
                &SMALL[..],
                &["-o", dir.path().join("out.png").to_str().expect("utf-8")],
            ]
            .concat(),
        );
        let done = preview.wait_done(1);
        assert_eq!(done["error"], Value::Null, "{}: {done}", scene.display());
        assert_eq!(done["spp"], 16, "{}: {done}", scene.display());
        let (code, _, frame) = preview.request("GET", "/frame?kind=image");
        assert_eq!(code, 200);
        let lit = frame
            .chunks_exact(4)
            .filter(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) > 0.01)
            .count();
        assert!(
            lit > frame.len() / 4 / 4,
            "{}: the image is dark",
            scene.display()
        );
    }
}

/// Whether the browser test can run: Chromium and playwright-core (`npm ci --prefix
/// tests/browser`). CI sets LUMO_REQUIRE_BROWSER=1 so that missing either fails.
fn browser() -> Option<PathBuf> {
    let chromium = std::env::var_os("LUMO_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"));
    let script_dir = common::root().join("tests/browser");
    let ready = chromium.exists()
        && script_dir.join("node_modules/playwright-core").is_dir()
        && Command::new("node").arg("--version").output().is_ok();
    if ready {
        return Some(script_dir.join("preview.mjs"));
    }
    let why = format!(
        "the browser test needs {} and tests/browser/node_modules (npm ci --prefix tests/browser)",
        chromium.display()
    );
    if std::env::var_os("LUMO_REQUIRE_BROWSER").is_some_and(|v| v == "1") {
        panic!("{why}");
    }
    eprintln!("SKIPPED: {why}");
    None
}

#[test]
fn in_a_browser_the_page_follows_edits_errors_and_fixes() {
    let _serial = serial();
    let Some(script) = browser() else { return };
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let preview = Preview::start(&scene, &["--width", "96", "--height", "96", "--spp", "32"]);
    let mut node = Command::new("node");
    node.arg(&script)
        .arg(format!("http://{}/", preview.addr))
        .arg(&scene);
    if let Some(shot) = std::env::var_os("LUMO_PREVIEW_SCREENSHOT") {
        node.arg(shot);
    }
    let mut child = node
        .stdout(Stdio::inherit())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start node");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("the browser test ran past 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.success(), "the browser test failed: {status}");
}

#[test]
fn editing_a_texture_renders_again() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::create_dir_all(dir.path().join("textures")).expect("mkdir");
    let text =
        std::fs::read_to_string(common::root().join("scenes/lathe_vase.json")).expect("read");
    let scene = dir.path().join("lathe_vase.json");
    write_atomically(
        &scene,
        &text.replace("\"$schema\": \"../schema/scene.schema.json\",", ""),
    );
    let texture = dir.path().join("textures/vase_glaze.png");
    std::fs::copy(
        common::root().join("scenes/textures/vase_glaze.png"),
        &texture,
    )
    .expect("copy");
    let preview = Preview::start(&scene, &SMALL);
    preview.wait_done(1);
    let (_, _, before) = preview.request("GET", "/frame?kind=image");
    // Repaint the glaze a flat blue, as an image editor would save it.
    let blue = image::RgbImage::from_pixel(8, 8, image::Rgb([20, 40, 220]));
    let tmp = dir.path().join("textures/.edit.png");
    blue.save(&tmp).expect("write");
    std::fs::rename(&tmp, &texture).expect("rename");
    let after_status = preview.wait_done(2);
    assert_eq!(after_status["error"], Value::Null);
    let (_, _, after) = preview.request("GET", "/frame?kind=image");
    assert_eq!(before.len(), after.len());
    let mean_blue_minus_red = |f: &[u8]| {
        let v: Vec<f32> = f
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        v.chunks_exact(3).map(|p| p[2] - p[0]).sum::<f32>() / (v.len() / 3) as f32
    };
    assert!(
        mean_blue_minus_red(&after) > mean_blue_minus_red(&before) + 0.01,
        "the vase did not turn blue: {} then {}",
        mean_blue_minus_red(&before),
        mean_blue_minus_red(&after)
    );
}

#[test]
fn editing_the_patch_or_an_included_fragment_renders_again() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    // A fragment in a folder of its own, included by the scene.
    std::fs::create_dir_all(dir.path().join("lib")).expect("mkdir");
    let fragment = dir.path().join("lib/extra.json");
    let spare = r#"{"$schema": "scene-fragment.schema.json", "materials": {"spare": {"base_color": [0.5, 0.5, 0.5]}}}"#;
    write_atomically(&fragment, spare);
    let text = std::fs::read_to_string(&scene).expect("read");
    write_atomically(
        &scene,
        &text.replacen('{', r#"{"include": ["lib/extra.json"],"#, 1),
    );
    // The patch, in a folder the scene reads nothing from.
    std::fs::create_dir_all(dir.path().join("patches")).expect("mkdir");
    let patch = dir.path().join("patches/blue.json");
    write_atomically(
        &patch,
        r#"{"materials": {"red": {"base_color": [0.1, 0.1, 0.6]}}}"#,
    );
    let mut args = SMALL.to_vec();
    args.extend(["--patch", patch.to_str().expect("UTF-8 path")]);
    let preview = Preview::start(&scene, &args);
    preview.wait_done(1);
    // A broken patch is reported, placed in the patch file; its fix renders again.
    write_atomically(&patch, r#"{"materials": {"red": {"base_color": "blue"}}}"#);
    let bad = preview.wait_for("the patch's problem", |s| s["state"] == "invalid");
    let report = bad["error"].as_str().unwrap_or_default();
    assert!(report.contains("blue.json:1:"), "{report}");
    write_atomically(
        &patch,
        r#"{"materials": {"red": {"base_color": [0.6, 0.1, 0.1]}}}"#,
    );
    let fixed = preview.wait_done(3);
    assert_eq!(fixed["error"], Value::Null);
    // An edit of the included fragment renders again too.
    write_atomically(&fragment, &spare.replace("0.5, 0.5, 0.5", "0.2, 0.2, 0.2"));
    let again = preview.wait_done(4);
    assert_eq!(again["error"], Value::Null);
}
