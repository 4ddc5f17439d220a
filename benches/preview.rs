//! Restart latency of `lumo preview`: how long after a saved edit the page has something new.
//!
//! Run: `cargo bench --bench preview`. Two measurements:
//! 1. **Cancel latency, in process.** The Cornell box (256², 4096 spp) renders with a cancel
//!    flag; at a pseudo-random moment the flag is set, and the time until `render_with_error`
//!    returns is recorded (each thread finishes at most the 16×16 tile it is on).
//! 2. **Edit to new image, end to end.** A real `lumo preview` serves a copy of the Cornell box
//!    (256², 4096 spp, so it is always mid-render); the bench rewrites the scene file (a new
//!    wall colour, written and renamed as editors do) and follows the server-sent events until
//!    (a) the first frame of the new scene reaches the event stream (the quick ray-cast pass,
//!    or the first path-traced pass when the two are coalesced) and (b) the first path-traced
//!    pass does. Both include the watcher's quiet period (150 ms), which is what makes a burst
//!    of saves one reload.
//!
//! Prints median and range of each; the machine's load average is printed alongside, since
//! machines here are shared.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use lumo::render::{render_with_error, RenderOptions};

const ROUNDS: usize = 12;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn summary(name: &str, mut ms: Vec<f64>) {
    ms.sort_by(f64::total_cmp);
    println!(
        "{name:<44} median {:7.1} ms   range {:7.1} – {:7.1} ms   (n = {})",
        ms[ms.len() / 2],
        ms[0],
        ms[ms.len() - 1],
        ms.len()
    );
}

fn cancel_latency() -> Vec<f64> {
    let loaded = lumo::load(root().join("scenes/cornell.json"), &Default::default())
        .expect("load the Cornell box");
    let (mut scene, _) = loaded.build().expect("build");
    scene.settings.spp = 4096;
    let mut out = Vec::new();
    for round in 0..ROUNDS {
        let cancel = AtomicBool::new(false);
        let options = RenderOptions {
            cancel: Some(&cancel),
            ..Default::default()
        };
        let wait = Duration::from_millis(150 + 97 * round as u64 % 400);
        let cancelled_at = std::thread::scope(|s| {
            let stopper = s.spawn(|| {
                std::thread::sleep(wait);
                cancel.store(true, Ordering::SeqCst);
                Instant::now()
            });
            let rendered = render_with_error(&scene, &options);
            let returned = Instant::now();
            assert!(rendered.interrupted);
            let at = stopper.join().expect("stopper");
            returned.duration_since(at)
        });
        out.push(cancelled_at.as_secs_f64() * 1e3);
    }
    out
}

/// Follows the preview's event stream, calling `on` with each status until it returns true.
fn follow(addr: &str, mut on: impl FnMut(&serde_json::Value) -> bool) {
    let mut s = TcpStream::connect(addr).expect("connect");
    write!(s, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").expect("send");
    s.set_read_timeout(Some(Duration::from_secs(60)))
        .expect("timeout");
    let mut reader = BufReader::new(s);
    let mut line = String::new();
    loop {
        line.clear();
        if reader.read_line(&mut line).expect("read") == 0 {
            panic!("the event stream ended");
        }
        if let Some(data) = line.trim_end().strip_prefix("data: ") {
            if let Ok(v) = serde_json::from_str(data) {
                if on(&v) {
                    return;
                }
            }
        }
    }
}

fn write_atomically(path: &Path, text: &str) {
    let tmp = path.with_extension("edit-tmp");
    std::fs::write(&tmp, text).expect("write");
    std::fs::rename(&tmp, path).expect("rename");
}

fn edit_to_image() -> (Vec<f64>, Vec<f64>) {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = dir.path().join("cornell.json");
    let original = std::fs::read_to_string(root().join("scenes/cornell.json"))
        .expect("read")
        .replace("\"$schema\": \"../schema/scene.schema.json\",", "");
    write_atomically(&scene, &original);
    let mut child = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("preview")
        .arg(&scene)
        .args(["--port", "0", "--spp", "4096"])
        .stderr(Stdio::piped())
        .spawn()
        .expect("start lumo preview");
    let mut first = String::new();
    BufReader::new(child.stderr.take().expect("stderr"))
        .read_line(&mut first)
        .expect("read the address");
    let addr = first
        .split("http://")
        .nth(1)
        .and_then(|rest| rest.split('/').next())
        .expect("an address")
        .to_string();
    let (mut first_image, mut traced) = (Vec::new(), Vec::new());
    const RED: &str = r#""red": {"base_color": [0.570068, 0.0430135, 0.0443706]"#;
    for round in 0..ROUNDS {
        // Mid-render: a few path-traced passes in.
        follow(&addr, |s| {
            s["state"] == "rendering" && s["spp"].as_u64() >= Some(8)
        });
        let (mut renders, mut frame) = (0, 0);
        follow(&addr, |s| {
            renders = s["renders"].as_u64().unwrap_or(0);
            frame = s["frame"].as_u64().unwrap_or(0);
            true
        });
        let colour = format!(r#""red": {{"base_color": [0.{}, 0.05, 0.05]"#, 30 + round);
        let t0 = Instant::now();
        write_atomically(&scene, &original.replace(RED, &colour));
        let mut seen_new = None;
        // Status events are coalesced when several changes come at once, so the quick frame may
        // arrive together with the first pass: measured is what the page gets.
        follow(&addr, |s| {
            // A new render's frame (the status of a reload still shows the last render's frame).
            let new_frame =
                s["renders"].as_u64() > Some(renders) && s["frame"].as_u64() > Some(frame);
            if new_frame {
                seen_new.get_or_insert_with(|| t0.elapsed());
            }
            if new_frame && s["quick"] == false {
                first_image.push(seen_new.unwrap_or_else(|| t0.elapsed()).as_secs_f64() * 1e3);
                traced.push(t0.elapsed().as_secs_f64() * 1e3);
                return true;
            }
            false
        });
    }
    let _ = child.kill();
    let _ = child.wait();
    (first_image, traced)
}

fn main() {
    // `cargo bench` passes --bench; a filter argument is ignored (this bench is one measurement).
    println!("load average before: {}", load_average());
    summary("cancel → render returns (in process)", cancel_latency());
    let (first_image, traced) = edit_to_image();
    summary("edit saved → first image of the new scene", first_image);
    summary("edit saved → first path-traced pass", traced);
    println!("load average after: {}", load_average());
}
