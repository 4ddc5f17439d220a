//! `lumo preview` end to end: real server processes on 127.0.0.1, a raw HTTP client, the
//! server-sent event stream awaited for each state (no fixed sleeps where an event can be
//! awaited), and a real browser (Debian's Chromium driven by playwright-core,
//! `tests/browser/preview.mjs` and `passes.mjs`).
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
        Preview::start_with(scene, args, &[])
    }

    /// [`Preview::start`] with environment variables set.
    fn start_with(scene: &Path, args: &[&str], env: &[(&str, &std::ffi::OsStr)]) -> Preview {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lumo"))
            .arg("preview")
            .arg(scene)
            .args(["--port", "0", "--threads", "2"])
            .args(args)
            .envs(env.iter().copied())
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
    // With passes, written beside the image as `lumo render` writes them.
    let preview = Preview::start(
        &scene,
        &[
            &SMALL[..],
            &["--aov", PASSES, "-o", saved.to_str().expect("utf-8")],
        ]
        .concat(),
    );
    preview.wait_done(1);
    let (code, _, body) = preview.request("POST", "/save?tonemap=aces&exposure=0");
    assert_eq!(code, 200, "{}", String::from_utf8_lossy(&body));
    let rendered = dir.path().join("rendered.png");
    let status = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("render")
        .arg(&scene)
        .args(SMALL)
        .args(["--aov", PASSES, "--tonemap", "aces", "-q", "-o"])
        .arg(&rendered)
        .status()
        .expect("lumo render");
    assert!(status.success());
    let passes = PASSES.split(',').map(|p| format!("{p}.png"));
    for suffix in std::iter::once("png".to_string()).chain(passes) {
        let file = |stem: &str| dir.path().join(format!("{stem}.{suffix}"));
        assert_eq!(
            std::fs::read(file("saved")).unwrap_or_else(|e| panic!("saved.{suffix}: {e}")),
            std::fs::read(file("rendered")).unwrap_or_else(|e| panic!("rendered.{suffix}: {e}")),
            "the saved {suffix} differs from lumo render's"
        );
    }
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

/// Runs a browser script (`node …`) to its end, within 120 s, and asserts that it passed.
fn run_browser_script(node: &mut Command) {
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
    run_browser_script(&mut node);
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

// Render passes, the denoised view, and the page as an image viewer.

/// A frame answer decoded by its headers.
#[derive(Debug)]
struct Served {
    width: usize,
    height: usize,
    channels: Vec<String>,
    /// `x-lumo-frame`.
    frame: u64,
    /// The values of an `f32` answer.
    floats: Vec<f32>,
    /// The values of a `u32` answer (ids).
    ids: Vec<u32>,
}

/// The value of header `name` in a response head.
fn header<'a>(head: &'a str, name: &str) -> Option<&'a str> {
    head.lines().find_map(|line| {
        let (key, value) = line.split_once(':')?;
        key.trim()
            .eq_ignore_ascii_case(name)
            .then_some(value.trim())
    })
}

impl Preview {
    /// GETs a frame route that must answer 200, and decodes it by its headers.
    fn served(&self, target: &str) -> Served {
        let (code, head, body) = self.request("GET", target);
        assert_eq!(
            code,
            200,
            "GET {target}: {}",
            String::from_utf8_lossy(&body)
        );
        let get = |name: &str| {
            header(&head, name).unwrap_or_else(|| panic!("GET {target}: no {name} header"))
        };
        let width: usize = get("x-lumo-width").parse().expect("width");
        let height: usize = get("x-lumo-height").parse().expect("height");
        let channels: Vec<String> = get("x-lumo-channels")
            .split(',')
            .map(String::from)
            .collect();
        assert_eq!(
            body.len(),
            width * height * channels.len() * 4,
            "GET {target}: {width}×{height} pixels of {channels:?} in {} bytes",
            body.len()
        );
        let words = body.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]);
        let (floats, ids) = match get("x-lumo-type") {
            "f32" => (words.map(f32::from_le_bytes).collect(), Vec::new()),
            "u32" => (Vec::new(), words.map(u32::from_le_bytes).collect()),
            other => panic!("GET {target}: x-lumo-type {other}"),
        };
        Served {
            width,
            height,
            channels,
            frame: get("x-lumo-frame").parse().expect("frame"),
            floats,
            ids,
        }
    }

    /// Waits until the first render is done and the denoiser has been looked for.
    fn wait_settled(&self) -> Value {
        self.wait_for("render 1 done and the denoiser looked for", |s| {
            s["state"] == "done" && s["denoiser"] != "loading"
        })
    }
}

/// The Cornell box's red wall, from the scene file: its object id (index + 1 in `objects`),
/// its material id (index + 1 among the materials sorted by name) and its base colour.
fn red_wall(scene: &Path) -> (u32, u32, [f32; 3]) {
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(scene).expect("read")).expect("JSON");
    let objects = v["objects"].as_array().expect("objects");
    let object = objects
        .iter()
        .position(|o| o["mesh"]["material"] == "red")
        .expect("a red object");
    let mut names: Vec<&String> = v["materials"]
        .as_object()
        .expect("materials")
        .keys()
        .collect();
    names.sort();
    let material = names.iter().position(|n| *n == "red").expect("red");
    let base: Vec<f32> = v["materials"]["red"]["base_color"]
        .as_array()
        .expect("base_color")
        .iter()
        .map(|c| c.as_f64().expect("a number") as f32)
        .collect();
    (
        object as u32 + 1,
        material as u32 + 1,
        [base[0], base[1], base[2]],
    )
}

const PASSES: &str = "albedo,normal,depth,object_id,material_id,std_error";

#[test]
fn the_passes_are_served_bit_for_bit_as_lumo_render_writes_them() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    // OIDN pointed at an empty folder: the denoised view must say how to install it.
    let nowhere = dir.path().join("no-oidn");
    std::fs::create_dir(&nowhere).expect("mkdir");
    let preview = Preview::start_with(
        &scene,
        &[&SMALL[..], &["--aov", PASSES]].concat(),
        &[("LUMO_OIDN", nowhere.as_os_str())],
    );
    let done = preview.wait_settled();
    assert_eq!(
        done["passes"],
        serde_json::json!(["albedo", "normal", "depth", "object_id", "material_id"]),
        "the standard error is every frame's, not listed among the passes"
    );
    let frame = done["frame"].as_u64().expect("frame");
    // The same render by `lumo render`, its passes read back from its EXR.
    let exr = dir.path().join("rendered.exr");
    let rendered = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("render")
        .arg(&scene)
        .args(SMALL)
        .args(["--aov", PASSES, "-q", "-o"])
        .arg(&exr)
        .status()
        .expect("lumo render");
    assert!(rendered.success());
    let layered = lumo::multilayer::read_exr(&exr).expect("read the EXR");
    let image = preview.served("/frame?kind=image");
    assert_eq!((image.width, image.height, image.frame), (48, 48, frame));
    assert_eq!(image.channels, ["R", "G", "B"]);
    let beauty: Vec<f32> = layered
        .beauty
        .pixels
        .iter()
        .flat_map(|p| p.to_array())
        .collect();
    assert!(
        image.floats == beauty,
        "the beauty differs from lumo render's"
    );
    let mut served = std::collections::HashMap::new();
    for aov in lumo::aov::Aov::ALL {
        if aov == lumo::aov::Aov::Position || aov == lumo::aov::Aov::Uv {
            continue;
        }
        let pass = preview.served(&format!("/frame?kind=pass&name={aov}"));
        assert_eq!(
            (pass.width, pass.height, pass.frame),
            (48, 48, frame),
            "{aov}"
        );
        assert_eq!(pass.channels, aov.channels(), "{aov}");
        match &layered
            .group(aov.name())
            .expect("the pass in the EXR")
            .pixels
        {
            lumo::aov::PassPixels::Float(v) => assert!(pass.floats == *v, "{aov} differs"),
            lumo::aov::PassPixels::Id(v) => assert!(pass.ids == *v, "{aov} differs"),
        }
        served.insert(aov.name(), pass);
    }
    // In closed form: the red wall's albedo is its base colour and its normal +x, wherever a
    // pixel and its eight neighbours all see the wall.
    let (object, material, base) = red_wall(&scene);
    let materials = &served["material_id"].ids;
    let wall = |x: usize, y: usize| materials[y * 48 + x] == material;
    let inside: Vec<usize> = (1..47)
        .flat_map(|y| (1..47).map(move |x| (x, y)))
        .filter(|&(x, y)| (0..9).all(|k| wall(x + k % 3 - 1, y + k / 3 - 1)))
        .map(|(x, y)| y * 48 + x)
        .collect();
    assert!(
        inside.len() >= 20,
        "{} pixels inside the red wall",
        inside.len()
    );
    for &i in &inside {
        let albedo = &served["albedo"].floats[3 * i..3 * i + 3];
        let normal = &served["normal"].floats[3 * i..3 * i + 3];
        for k in 0..3 {
            assert!(
                (albedo[k] - base[k]).abs() < 1e-5,
                "albedo {albedo:?}, base colour {base:?}"
            );
            assert!(
                (normal[k] - [1.0, 0.0, 0.0][k]).abs() < 1e-4,
                "normal {normal:?}"
            );
        }
        assert_eq!(served["object_id"].ids[i], object);
        assert!(served["depth"].floats[i] > 1.0);
    }
    // The standard error as a pass is the error view.
    let error = preview.served("/frame?kind=error");
    assert!(served["std_error"].floats == error.floats);
    // Refusals say why.
    for (target, code, says) in [
        ("/frame?kind=pass&name=uv", 404, "--aov uv"),
        (
            "/frame?kind=pass&name=sepia",
            400,
            "choose from albedo, normal",
        ),
        ("/frame?kind=pass", 400, "name=PASS"),
        ("/frame?kind=denoised", 503, "pip install pyoidn"),
        (
            "/frame?kind=sepia",
            400,
            "kind is image, error, denoised, or pass",
        ),
    ] {
        let (got, _, body) = preview.request("GET", target);
        let body = String::from_utf8_lossy(&body);
        assert_eq!(got, code, "GET {target}: {body}");
        assert!(body.contains(says), "GET {target}: {body}");
    }
    assert_eq!(done["denoiser"], "missing");
    let note = done["denoiser_note"].as_str().unwrap_or_default();
    assert!(note.contains("pip install pyoidn"), "{note}");
}

#[test]
fn the_denoised_view_is_oidn_guided_by_the_passes_and_follows_the_frames() {
    let _serial = serial();
    let Some(oidn) = common::oidn_dir() else {
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let preview = Preview::start_with(&scene, &SMALL, &[("LUMO_OIDN", oidn.as_os_str())]);
    let done = preview.wait_settled();
    assert_eq!(done["denoiser"], "ready", "{done}");
    let frame = done["frame"].as_u64().expect("frame");
    let denoised = preview.served("/frame?kind=denoised");
    assert_eq!((denoised.width, denoised.height), (48, 48));
    assert_eq!(denoised.frame, frame);
    assert_eq!(denoised.channels, ["R", "G", "B"]);
    // Without --aov the passes are not rendered: OIDN filters the colour alone. The same filter
    // run here on the served beauty gives the served result.
    let image = |s: &Served| lumo::image::Image {
        width: s.width as u32,
        height: s.height as u32,
        pixels: s
            .floats
            .chunks_exact(3)
            .map(|p| glam::Vec3::new(p[0], p[1], p[2]))
            .collect(),
    };
    let beauty = image(&preview.served("/frame?kind=image"));
    let mut filter = lumo::denoise::Oidn::load_from(&oidn).expect("OIDN");
    let expected = filter
        .denoise(&beauty, None, None, lumo::denoise::Prefilter::None)
        .expect("denoise");
    let largest = |a: &lumo::image::Image, b: &lumo::image::Image| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (*p - *q).abs().max_element())
            .fold(0.0f32, f32::max)
    };
    let served = image(&denoised);
    assert!(largest(&served, &expected) < 1e-3);
    assert!(
        largest(&served, &beauty) > 0.05,
        "the denoised view is the beauty"
    );
    // A new frame is denoised anew (the cache is per frame): the red wall turned blue.
    let left_wall = |s: &Served| {
        let (mut red, mut blue) = (0.0, 0.0);
        for y in 12..36 {
            for x in 1..6 {
                red += s.floats[3 * (y * 48 + x)];
                blue += s.floats[3 * (y * 48 + x) + 2];
            }
        }
        (red, blue)
    };
    let (red, blue) = left_wall(&denoised);
    assert!(red > 2.0 * blue, "the left wall is not red: {red} {blue}");
    let text = std::fs::read_to_string(&scene).expect("read");
    write_atomically(
        &scene,
        &text.replace(RED, r#""red": {"base_color": [0.05, 0.1, 0.6]"#),
    );
    let again = preview.wait_done(2);
    let recoloured = preview.served("/frame?kind=denoised");
    assert_eq!(recoloured.frame, again["frame"].as_u64().expect("frame"));
    let (red, blue) = left_wall(&recoloured);
    assert!(
        blue > 2.0 * red,
        "the denoised left wall did not turn blue: {red} {blue}"
    );
    drop(preview);

    // With albedo and normal rendered, they guide it.
    let preview = Preview::start_with(
        &scene,
        &[&SMALL[..], &["--aov", "albedo,normal"]].concat(),
        &[("LUMO_OIDN", oidn.as_os_str())],
    );
    let done = preview.wait_settled();
    assert_eq!(done["denoiser"], "ready", "{done}");
    let beauty = image(&preview.served("/frame?kind=image"));
    let albedo = image(&preview.served("/frame?kind=pass&name=albedo"));
    let normal = image(&preview.served("/frame?kind=pass&name=normal"));
    let served = image(&preview.served("/frame?kind=denoised"));
    let guided = filter
        .denoise(
            &beauty,
            Some(&albedo),
            Some(&normal),
            lumo::denoise::Prefilter::None,
        )
        .expect("denoise");
    let alone = filter
        .denoise(&beauty, None, None, lumo::denoise::Prefilter::None)
        .expect("denoise");
    assert!(largest(&served, &guided) < 1e-3);
    assert!(
        largest(&served, &alone) > 1e-2,
        "the guides made no difference"
    );
    // A second request is answered from the cache, with the same values.
    let (_, head, _) = preview.request("GET", "/frame?kind=denoised");
    let seconds: f64 = header(&head, "x-lumo-denoise-seconds")
        .and_then(|s| s.parse().ok())
        .expect("x-lumo-denoise-seconds");
    assert!(seconds < 0.005, "a cached answer took {seconds} s");
}

/// Whether `shown` (the page's parse of a value it printed) is `value` as printed: 4 decimals,
/// or 4 significant digits in exponent form.
fn printed_as(shown: &str, value: f32) -> bool {
    let Ok(v) = shown.parse::<f64>() else {
        return false;
    };
    let value = f64::from(value);
    (v - value).abs() <= 5.001e-5_f64.max(5.001e-4 * value.abs())
}

#[test]
fn in_a_browser_the_page_shows_passes_zooms_and_reads_out_pixels() {
    let _serial = serial();
    let Some(script) = browser() else { return };
    let script = script.with_file_name("passes.mjs");
    let oidn = common::oidn_dir();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    let env: Vec<(&str, &std::ffi::OsStr)> = oidn
        .as_ref()
        .map(|d| ("LUMO_OIDN", d.as_os_str()))
        .into_iter()
        .collect();
    let aovs = "albedo,normal,depth,position,uv,object_id,material_id";
    let preview = Preview::start_with(
        &scene,
        &[
            "--width", "64", "--height", "48", "--spp", "16", "--aov", aovs,
        ],
        &env,
    );
    let out = dir.path().join("browser");
    std::fs::create_dir(&out).expect("mkdir");
    run_browser_script(
        Command::new("node")
            .arg(&script)
            .arg(format!("http://{}/", preview.addr))
            .arg(&out),
    );
    let report: Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).expect("report"))
            .expect("report JSON");
    let frame = report["status"]["frame"].as_u64().expect("frame");

    // The selector: the beauty, the denoised beauty (disabled without OIDN), the error, and the
    // passes asked for.
    let options: Vec<&str> = report["options"]
        .as_array()
        .expect("options")
        .iter()
        .map(|o| o["value"].as_str().unwrap_or_default())
        .collect();
    assert_eq!(
        options,
        [
            "image",
            "denoised",
            "error",
            "albedo",
            "normal",
            "depth",
            "position",
            "uv",
            "object_id",
            "material_id"
        ]
    );
    let denoised_disabled = report["options"][1]["disabled"] == true;
    assert_eq!(
        denoised_disabled,
        oidn.is_none(),
        "{}",
        report["options"][1]
    );

    // Every view shows the served values in the colours of lumo's PNG passes.
    let canvas = |kind: &str| -> Vec<[u8; 3]> {
        let view = &report["views"][kind];
        assert_eq!(view["frame"].as_u64(), Some(frame), "{kind}");
        assert_eq!(
            (view["width"].as_u64(), view["height"].as_u64()),
            (Some(64), Some(48))
        );
        view["rgba"]
            .as_array()
            .expect("rgba")
            .chunks_exact(4)
            .map(|p| std::array::from_fn(|k| p[k].as_u64().unwrap_or(999) as u8))
            .collect()
    };
    let compare = |kind: &str, expected: &[[u8; 3]], tolerance: i32| {
        let shown = canvas(kind);
        assert_eq!(shown.len(), expected.len());
        let worst = shown
            .iter()
            .zip(expected)
            .flat_map(|(a, b)| (0..3).map(move |k| (i32::from(a[k]) - i32::from(b[k])).abs()))
            .max()
            .unwrap_or(0);
        assert!(worst <= tolerance, "{kind}: a pixel is off by {worst}");
    };
    for aov in [
        lumo::aov::Aov::Normal,
        lumo::aov::Aov::Depth,
        lumo::aov::Aov::Position,
        lumo::aov::Aov::Uv,
        lumo::aov::Aov::ObjectId,
        lumo::aov::Aov::MaterialId,
        lumo::aov::Aov::Albedo,
    ] {
        let served = preview.served(&format!("/frame?kind=pass&name={aov}"));
        assert_eq!(served.frame, frame);
        let pass = lumo::aov::PassImage {
            aov,
            pixels: if served.ids.is_empty() {
                lumo::aov::PassPixels::Float(served.floats)
            } else {
                lumo::aov::PassPixels::Id(served.ids)
            },
        };
        // The page's sRGB curve is JavaScript's pow, lumo's its own: one step apart at most.
        let tolerance = i32::from(aov == lumo::aov::Aov::Albedo);
        compare(
            aov.name(),
            &lumo::multilayer::pass_to_rgb8(&pass),
            tolerance,
        );
    }
    // Radiance through the clamp tone map and the sRGB curve, as `lumo render`'s PNG.
    let radiance = |kind: &str| -> Vec<[u8; 3]> {
        preview
            .served(&format!("/frame?kind={kind}"))
            .floats
            .chunks_exact(3)
            .map(|p| {
                std::array::from_fn(|k| (lumo::math::linear_to_srgb(p[k]) * 255.0 + 0.5) as u8)
            })
            .collect()
    };
    compare("image", &radiance("image"), 1);
    compare("error", &radiance("error"), 1);
    if oidn.is_some() {
        compare("denoised", &radiance("denoised"), 1);
    } else {
        let note = report["denoise_note"].as_str().unwrap_or_default();
        assert!(note.contains("pip install pyoidn"), "{note}");
    }

    // The readout under the cursor: the served values at that pixel.
    let kinds = [
        ("image", "/frame?kind=image"),
        ("error", "/frame?kind=error"),
        ("albedo", "/frame?kind=pass&name=albedo"),
        ("normal", "/frame?kind=pass&name=normal"),
        ("depth", "/frame?kind=pass&name=depth"),
        ("position", "/frame?kind=pass&name=position"),
        ("uv", "/frame?kind=pass&name=uv"),
        ("object_id", "/frame?kind=pass&name=object_id"),
        ("material_id", "/frame?kind=pass&name=material_id"),
    ];
    let served: Vec<(&str, Served)> = kinds
        .iter()
        .map(|(kind, target)| (*kind, preview.served(target)))
        .collect();
    for readout in report["readouts"].as_array().expect("readouts") {
        let (x, y) = (
            readout["x"].as_u64().expect("x") as usize,
            readout["y"].as_u64().expect("y") as usize,
        );
        let rows = readout["rows"].as_array().expect("rows");
        let listed: Vec<&str> = rows.iter().filter_map(|r| r["kind"].as_str()).collect();
        assert_eq!(listed, kinds.map(|k| k.0), "the readout's rows");
        for (row, (kind, s)) in rows.iter().zip(&served) {
            for (k, channel) in s.channels.iter().enumerate() {
                let shown = row["values"][channel.as_str()].as_str().unwrap_or_default();
                let i = (y * s.width + x) * s.channels.len() + k;
                if s.ids.is_empty() {
                    assert!(
                        printed_as(shown, s.floats[i]),
                        "({x}, {y}) {kind}.{channel}: the page shows {shown}, the server has {}",
                        s.floats[i]
                    );
                } else {
                    assert_eq!(shown, s.ids[i].to_string(), "({x}, {y}) {kind}.{channel}");
                }
            }
        }
    }

    // Magnified, the pixels are drawn nearest-neighbour: every screen pixel of the screenshot
    // not on a pixel's edge has the colour of the canvas pixel under it.
    let zoom = &report["zoom"];
    assert_eq!(zoom["rendering"], "pixelated");
    let shot = image::open(out.join("zoom.png"))
        .expect("screenshot")
        .to_rgb8();
    let image_view = canvas("image");
    let [cx, cy, cw, ch] = ["x", "y", "w", "h"].map(|k| zoom["canvas"][k].as_f64().expect("box"));
    let scale = cw / 64.0;
    assert!(
        (ch / 48.0 - scale).abs() < 1e-6 && scale > 8.0,
        "scale {scale}"
    );
    let (mut checked, mut wrong) = (0, 0);
    for (sx, sy, px) in shot.enumerate_pixels() {
        let u = (f64::from(sx) + 0.5 - cx) / scale;
        let v = (f64::from(sy) + 0.5 - cy) / scale;
        let edge = |t: f64| (t - t.round()).abs() * scale < 1.0;
        if u < 0.0 || v < 0.0 || u >= 64.0 || v >= 48.0 || edge(u) || edge(v) {
            continue;
        }
        checked += 1;
        if image_view[v as usize * 64 + u as usize] != px.0 {
            wrong += 1;
        }
    }
    assert!(checked > 100_000, "{checked} screen pixels checked");
    assert_eq!(
        wrong, 0,
        "{wrong} of {checked} screen pixels are not their canvas pixel's colour"
    );
}

#[test]
fn the_quick_frame_says_the_passes_come_with_the_first_path_traced_pass() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = cornell_copy(dir.path());
    // Large enough that the path tracer's first pass (2 spp of 512²) takes a second or more
    // after the quick frame (128², ray cast) is published.
    let preview = Preview::start(
        &scene,
        &[
            "--width", "512", "--height", "512", "--spp", "4", "--aov", "albedo",
        ],
    );
    let quick = preview.wait_for("the quick frame", |s| s["quick"] == true);
    let (code, head, body) = preview.request("GET", "/frame?kind=image");
    assert_eq!(code, 200);
    assert_eq!(header(&head, "x-lumo-width"), Some("128"));
    if header(&head, "x-lumo-frame") != Some(&quick["frame"].to_string()) {
        panic!("the first path-traced pass came too soon to see the quick frame's answers");
    }
    assert_eq!(body.len(), 128 * 128 * 12);
    for target in ["/frame?kind=pass&name=albedo", "/frame?kind=denoised"] {
        let (code, _, body) = preview.request("GET", target);
        let body = String::from_utf8_lossy(&body);
        assert_eq!(code, 409, "GET {target}: {body}");
        assert!(
            body.contains("first path-traced pass"),
            "GET {target}: {body}"
        );
    }
}
