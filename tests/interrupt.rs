//! Interrupting real `lumo render` processes (SIGINT, SIGTERM, SIGKILL, at pseudo-random
//! moments, several times in a row) never leaves a corrupt file, and resuming from the
//! checkpoint gives the bytes of an uninterrupted render.
//!
//! These tests start processes, so they live in their own test binary and run one at a time
//! (a lock), each bounded in time by a deadline on every wait.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use lumo::partial_film::PartialFilm;

/// One process test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Longest wait for any process.
const DEADLINE: Duration = Duration::from_secs(90);

/// Enough samples that a render outlasts its first checkpoint and the signal after it (0.7 s
/// on a Zen 5 core pair; 160 took 0.18 s there, and every render finished first).
const SPP: &str = "640";
const SIZE: [&str; 4] = ["--width", "96", "--height", "72"];

fn lumo() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lumo"))
}

fn scene() -> PathBuf {
    common::root().join("scenes/cornell.json")
}

fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 temp path")
}

/// A child killed when dropped (a failing test leaves no process behind).
struct Guard(Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Guard {
    fn signal(&self, name: &str) {
        let _ = Command::new("kill")
            .args([&format!("-{name}"), &self.0.id().to_string()])
            .status();
    }

    /// Waits for the process to end, within the deadline.
    fn wait(&mut self) -> (ExitStatus, String) {
        let start = Instant::now();
        loop {
            if let Some(status) = self.0.try_wait().expect("wait") {
                let mut err = String::new();
                if let Some(mut e) = self.0.stderr.take() {
                    let _ = std::io::Read::read_to_string(&mut e, &mut err);
                }
                return (status, err);
            }
            assert!(
                start.elapsed() < DEADLINE,
                "lumo did not finish in {DEADLINE:?}"
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Whether the process is still running.
    fn running(&mut self) -> bool {
        self.0.try_wait().expect("wait").is_none()
    }
}

/// The uninterrupted render's bytes.
fn reference(dir: &Path) -> Vec<u8> {
    let out = dir.join("reference.exr");
    let scene = scene();
    let mut args = vec!["render", p(&scene), "--spp", SPP, "-q", "-o", p(&out)];
    args.extend(SIZE);
    let status = lumo().args(&args).status().expect("lumo runs");
    assert!(status.success());
    std::fs::read(out).expect("reference")
}

/// Starts a checkpointed render into `out`, resuming from `ck` when it exists.
fn start(out: &Path, ck: &Path, every: &str) -> Guard {
    let scene = scene();
    let mut args = vec![
        "render",
        p(&scene),
        "--spp",
        SPP,
        "-q",
        "-o",
        p(out),
        "--checkpoint",
        p(ck),
        "--checkpoint-every",
        every,
    ];
    args.extend(SIZE);
    if ck.exists() {
        args.extend(["--resume", p(ck)]);
    }
    Guard(
        lumo()
            .args(&args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("lumo starts"),
    )
}

/// Pseudo-random delays (a fixed LCG: the same moments on every run).
struct Moments(u64);

impl Moments {
    fn next_ms(&mut self, max: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % max
    }
}

/// Every file at these paths is absent or complete: checkpoints read as films, images decode.
fn assert_no_corrupt_file(out: &Path, ck: &Path) {
    if ck.exists() {
        let film = PartialFilm::read(ck).unwrap_or_else(|e| panic!("corrupt checkpoint: {e}"));
        assert_eq!(film.header.samples.len(), 1, "{:?}", film.header.samples);
        assert_eq!(film.header.samples[0][0], 0);
    }
    if out.exists() {
        image::open(out).unwrap_or_else(|e| panic!("corrupt image {}: {e}", out.display()));
    }
    // No stray temporary files either (every write is a rename of a complete one).
    let dir = out.parent().expect("folder");
    for entry in std::fs::read_dir(dir).expect("list") {
        let name = entry.expect("entry").file_name();
        let name = name.to_string_lossy();
        assert!(
            !name.ends_with(".tmp") || name.starts_with(".lumo-"),
            "unexpected file {name}"
        );
    }
}

/// The checkpoint's modification time and size, if it exists.
fn stamp(ck: &Path) -> Option<(std::time::SystemTime, u64)> {
    let m = std::fs::metadata(ck).ok()?;
    Some((m.modified().ok()?, m.len()))
}

/// Waits until the render has written a new checkpoint (so it is past loading and its signal
/// handlers are in place), or ended, then a pseudo-random while longer.
fn wait_for_progress(
    child: &mut Guard,
    ck: &Path,
    before: Option<(std::time::SystemTime, u64)>,
    moments: &mut Moments,
    max_ms: u64,
) {
    let start = Instant::now();
    while child.running() && stamp(ck) == before && start.elapsed() < DEADLINE {
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_millis(moments.next_ms(max_ms)));
}

#[test]
fn sigint_and_sigterm_keep_the_image_and_resume_to_the_same_bits() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let reference = reference(dir.path());
    let (out, ck) = (dir.path().join("out.exr"), dir.path().join("out.ck.npz"));
    let mut moments = Moments(7);
    let mut interrupted = 0;
    for round in 0..5 {
        let before = stamp(&ck);
        let mut child = start(&out, &ck, "50ms");
        wait_for_progress(&mut child, &ck, before, &mut moments, 150);
        let (signal, code) = if round % 2 == 0 {
            ("INT", 130)
        } else {
            ("TERM", 143)
        };
        child.signal(signal);
        let (status, err) = child.wait();
        assert_no_corrupt_file(&out, &ck);
        if status.code() == Some(0) {
            break; // finished before the signal
        }
        assert_eq!(status.code(), Some(code), "SIG{signal}: {err}");
        assert!(err.contains("interrupted after"), "{err}");
        if err.contains("wrote") {
            assert!(out.exists());
        }
        interrupted += 1;
    }
    assert!(
        interrupted >= 2,
        "only {interrupted} renders were interrupted"
    );
    let mut child = start(&out, &ck, "50ms");
    let (status, err) = child.wait();
    assert!(status.success(), "{err}");
    assert_eq!(std::fs::read(&out).expect("image"), reference);
}

#[test]
fn a_second_ctrl_c_exits_at_once_without_corrupt_files() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let (out, ck) = (dir.path().join("out.exr"), dir.path().join("out.ck.npz"));
    let mut moments = Moments(11);
    for _ in 0..3 {
        let before = stamp(&ck);
        let mut child = start(&out, &ck, "20ms");
        wait_for_progress(&mut child, &ck, before, &mut moments, 100);
        child.signal("INT");
        std::thread::sleep(Duration::from_millis(moments.next_ms(5)));
        child.signal("INT");
        let (status, err) = child.wait();
        assert!(matches!(status.code(), Some(0 | 130)), "{status:?}: {err}");
        assert_no_corrupt_file(&out, &ck);
    }
}

#[test]
fn killed_at_any_moment_even_mid_checkpoint_resumes_to_the_same_bits() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let reference = reference(dir.path());
    let (out, ck) = (dir.path().join("out.exr"), dir.path().join("out.ck.npz"));
    let mut moments = Moments(3);
    // A checkpoint after every pass: the kills land during writes as often as not.
    for _ in 0..6 {
        let before = stamp(&ck);
        let mut child = start(&out, &ck, "1ms");
        wait_for_progress(&mut child, &ck, before, &mut moments, 120);
        child.signal("KILL");
        let _ = child.wait();
        assert_no_corrupt_file(&out, &ck);
        // Leftover temporary files of a killed writer are never at the target paths.
        for entry in std::fs::read_dir(dir.path()).expect("list") {
            let path = entry.expect("entry").path();
            if path.to_string_lossy().ends_with(".tmp") {
                std::fs::remove_file(path).expect("remove");
            }
        }
    }
    let mut child = start(&out, &ck, "1ms");
    let (status, err) = child.wait();
    assert!(status.success(), "{err}");
    assert_eq!(std::fs::read(&out).expect("image"), reference);
}

#[test]
fn a_resumed_time_budget_continues_with_the_time_that_was_left() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let (out, ck) = (dir.path().join("out.exr"), dir.path().join("out.ck.npz"));
    let scene = scene();
    let mut child = Guard(
        lumo()
            .args([
                "render",
                p(&scene),
                "--time",
                "3s",
                "-q",
                "-o",
                p(&out),
                "--checkpoint",
                p(&ck),
                "--checkpoint-every",
                "50ms",
            ])
            .args(SIZE)
            .stderr(Stdio::piped())
            .spawn()
            .expect("lumo starts"),
    );
    let mut moments = Moments(5);
    wait_for_progress(&mut child, &ck, None, &mut moments, 50);
    let t = Instant::now();
    child.signal("INT");
    let (status, err) = child.wait();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(
        t.elapsed() < Duration::from_secs(10),
        "the interrupt took {:?}",
        t.elapsed()
    );
    let film = PartialFilm::read(&ck).expect("checkpoint");
    let left = film
        .header
        .time_left_s
        .expect("a time-budgeted checkpoint records the time left");
    assert!(left > 0.5 && left < 3.0, "{left}");
    // Without --time, the resumed render gets the budget that was left: it ends after about
    // that long (loosely bounded: a loaded machine only lengthens the loading and the last pass).
    let t = Instant::now();
    let status = lumo()
        .args(["render", p(&scene), "-q", "-o", p(&out), "--resume", p(&ck)])
        .args(SIZE)
        .status()
        .expect("lumo runs");
    assert!(status.success());
    let took = t.elapsed().as_secs_f64();
    assert!(
        took > 0.5 * left && took < left + 8.0,
        "took {took} s with {left} s left"
    );
}

#[test]
fn an_interrupted_sample_range_resumes_into_the_same_film() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let scene = scene();
    let (film, ck, whole) = (
        d.join("part.npz"),
        d.join("part.ck.npz"),
        d.join("whole.npz"),
    );
    let render = |extra: &[&str]| {
        let mut c = lumo();
        c.args(["render", p(&scene), "-q"]).args(SIZE).args(extra);
        c
    };
    let mut child = Guard(
        render(&[
            "--samples",
            "40..200",
            "--film",
            p(&film),
            "--checkpoint",
            p(&ck),
            "--checkpoint-every",
            "50ms",
        ])
        .stderr(Stdio::piped())
        .spawn()
        .expect("lumo starts"),
    );
    wait_for_progress(&mut child, &ck, None, &mut Moments(9), 60);
    child.signal("INT");
    let (status, err) = child.wait();
    if status.code() == Some(130) {
        assert!(!film.exists(), "an interrupted range wrote its film: {err}");
        let kept = PartialFilm::read(&ck).expect("checkpoint");
        assert_eq!(kept.header.samples[0][0], 40);
        let status = render(&["--resume", p(&ck), "--film", p(&film)])
            .status()
            .expect("lumo runs");
        assert!(status.success());
    } else {
        assert!(status.success(), "{err}");
    }
    let status = render(&["--samples", "40..200", "--film", p(&whole)])
        .status()
        .expect("lumo runs");
    assert!(status.success());
    let (a, b) = (
        PartialFilm::read(&film).expect("resumed film"),
        PartialFilm::read(&whole).expect("film"),
    );
    assert_eq!(a.header.samples, vec![[40, 200]]);
    assert_eq!(
        a.film, b.film,
        "the resumed range differs from the uninterrupted one"
    );
}

/// A checkpoint records its scene and the flags that change pixels: `lumo render --resume CK
/// -o OUT` continues on its own to the bytes of an uninterrupted render, and resuming it into
/// another scene is refused with the command that would continue it.
#[test]
fn a_checkpoint_resumes_on_its_own() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let reference = reference(dir.path());
    let (out, ck) = (dir.path().join("out.exr"), dir.path().join("out.ck.npz"));
    let mut moments = Moments(11);
    let mut child = start(&out, &ck, "50ms");
    wait_for_progress(&mut child, &ck, None, &mut moments, 100);
    child.signal("INT");
    let (status, err) = child.wait();
    assert!(ck.exists(), "no checkpoint ({status:?}): {err}");
    let header = PartialFilm::read(&ck).expect("checkpoint").header;
    let command = header.command.expect("the checkpoint records its command");
    assert!(command[0].ends_with("cornell.json"), "{command:?}");
    assert!(
        command.windows(2).any(|w| w == ["--width", "96"]),
        "{command:?}"
    );

    let glass = common::root().join("scenes/cornell_glass.json");
    let refused = lumo()
        .args(["render", p(&glass), "-q", "-o", p(&out), "--resume", p(&ck)])
        .args(SIZE)
        .output()
        .expect("lumo runs");
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{err}");
    assert!(
        err.contains("the scene differs") && err.contains("the checkpoint's render: lumo render"),
        "{err}"
    );

    let resumed = dir.path().join("resumed.exr");
    let done = lumo()
        .args(["render", "--resume", p(&ck), "-q", "-o", p(&resumed)])
        .output()
        .expect("lumo runs");
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    assert_eq!(std::fs::read(&resumed).expect("image"), reference);
}

/// A render without `--checkpoint` takes its scene's content hash only if it is interrupted
/// (`JobSettings::defer_scene_hash`): the checkpoint it then keeps beside its output carries
/// the hash an eager render takes, and resumes to the bytes of an uninterrupted render.
#[test]
fn an_interrupted_render_without_checkpoint_flags_resumes() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = scene();
    let size = ["--width", "48", "--height", "36"];
    let render = |out: &Path, extra: &[&str]| {
        let mut args = vec!["render", p(&scene), "--spp", "4000", "-q", "-o", p(out)];
        args.extend(size);
        args.extend(extra);
        let mut command = lumo();
        command.args(&args);
        command
    };
    let reference = dir.path().join("reference.exr");
    assert!(render(&reference, &[])
        .output()
        .expect("lumo runs")
        .status
        .success());
    let out = dir.path().join("out.exr");
    let mut child = Guard(
        render(&out, &[])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("lumo starts"),
    );
    // Past loading (a few milliseconds) and well before the end (about a second).
    std::thread::sleep(Duration::from_millis(250));
    child.signal("INT");
    let (status, err) = child.wait();
    assert_eq!(status.code(), Some(130), "{err}");
    let ck = lumo::job::default_checkpoint(&out);
    assert!(err.contains("checkpoint"), "{err}");
    let header = PartialFilm::read(&ck).expect("checkpoint").header;
    assert!(
        header.scene_hash.starts_with("sha256:"),
        "{}",
        header.scene_hash
    );
    let resumed = dir.path().join("resumed.exr");
    let done = render(&resumed, &["--resume", p(&ck)])
        .output()
        .expect("lumo runs");
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    assert_eq!(
        std::fs::read(&resumed).expect("image"),
        std::fs::read(&reference).expect("reference")
    );
}

#[test]
fn an_interrupted_render_writes_its_passes() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().expect("temp dir");
    let (out, ck) = (dir.path().join("out.exr"), dir.path().join("out.ck.npz"));
    let scene = scene();
    let mut args = vec![
        "render",
        p(&scene),
        "--spp",
        "100000",
        "-q",
        "--aov",
        "albedo,depth,object_id",
        "-o",
        p(&out),
        "--checkpoint",
        p(&ck),
        "--checkpoint-every",
        "20ms",
    ];
    args.extend(SIZE);
    let mut child = Guard(
        lumo()
            .args(&args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("lumo starts"),
    );
    // After a checkpoint: past loading, with samples taken.
    wait_for_progress(&mut child, &ck, None, &mut Moments(3), 20);
    child.signal("INT");
    let (status, err) = child.wait();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("wrote"), "{err}");
    let layered = lumo::multilayer::read_exr(&out).expect("the interrupted image reads");
    for pass in ["albedo", "depth", "object_id"] {
        assert!(layered.group(pass).is_some(), "{pass} is missing");
    }
    let film = PartialFilm::read(&ck).expect("checkpoint");
    assert_eq!(film.header.aovs, ["albedo", "depth", "object_id"]);
}
