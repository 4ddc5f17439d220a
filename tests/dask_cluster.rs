//! `lumo-dask` (`distributed/`) end to end on a real Dask cluster on 127.0.0.1: a scheduler and
//! two workers, started here as separate processes, render the Cornell box in chunks of samples,
//! and the merged EXR must be byte-identical to one `lumo render` of all the samples — with both
//! workers up, with one worker killed (SIGKILL, its whole process group) in the middle of a
//! task, and with a worker that returns a wrong film once. A worker whose lumo is another build
//! is refused (exit code 2, naming that worker).
//!
//! Needs the Python environment `distributed/.venv` (made by `.ci/run`). Without it every test
//! prints a loud SKIPPED message and returns, unless `LUMO_REQUIRE_DASK=1` (set by `.ci/run`),
//! which turns the skip into a failure. The tests take turns (a lock), each within a deadline;
//! every process they start is killed with its process group when the test ends, however it ends.

use std::fs;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

const LUMO: &str = env!("CARGO_BIN_EXE_lumo");
/// Each test must be done within this, or it fails (and kills what it started).
const DEADLINE: Duration = Duration::from_secs(120);
/// The render every test makes: the Cornell box, 64×48, 32 spp in chunks of 4.
const SCENE: &str = "scenes/cornell.json";
const RENDER: [&str; 6] = ["--spp", "32", "--width", "64", "--height", "48"];
const CHUNK_SPP: &str = "4";

/// The tests start processes: one at a time, whatever the test harness's thread count.
static SERIAL: Mutex<()> = Mutex::new(());

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `bin/` folder of `distributed/.venv` with Dask and lumo-dask installed, or `None` after a
/// loud message (a panic under `LUMO_REQUIRE_DASK=1`).
fn venv() -> Option<PathBuf> {
    let bin = root().join("distributed/.venv/bin");
    let missing: Vec<_> = ["python", "dask", "lumo-dask"]
        .into_iter()
        .filter(|name| !bin.join(name).is_file())
        .collect();
    if missing.is_empty() {
        return Some(bin);
    }
    let what = format!(
        "{} missing from {} (make it: python3 -m venv distributed/.venv && \
         distributed/.venv/bin/pip install -r distributed/requirements.txt ./distributed)",
        missing.join(", "),
        bin.display()
    );
    if std::env::var_os("LUMO_REQUIRE_DASK").is_some_and(|v| v == "1") {
        panic!("the Dask environment is required (LUMO_REQUIRE_DASK=1): {what}");
    }
    eprintln!("\n=== SKIPPED: the Dask environment is not there: {what} ===\n");
    None
}

/// A temporary folder, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Scratch {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let dir = std::env::temp_dir().join(format!(
            "lumo-dask-test-{}-{}-{nanos}",
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

/// A process started in its own process group with its output in a log file. Dropping it kills
/// the whole group (a Dask worker is a nanny, its worker process and their lumo children) and,
/// when the test is failing, prints the end of its log.
struct Proc {
    name: String,
    child: Child,
    log: PathBuf,
    status: Option<ExitStatus>,
}

impl Proc {
    fn spawn(name: &str, mut cmd: Command, log: PathBuf) -> Proc {
        let file = fs::File::create(&log).unwrap();
        cmd.stdin(Stdio::null())
            .stdout(file.try_clone().unwrap())
            .stderr(file)
            .process_group(0);
        let child = cmd
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name} ({cmd:?}): {e}"));
        Proc {
            name: name.to_string(),
            child,
            log,
            status: None,
        }
    }

    fn log(&self) -> String {
        fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// The exit status, once the process has ended.
    fn exited(&mut self) -> Option<ExitStatus> {
        if self.status.is_none() {
            self.status = self.child.try_wait().unwrap();
        }
        self.status
    }

    /// SIGKILL to the whole process group, then reap the leader.
    fn kill(&mut self) {
        let _ = Command::new("kill")
            .args(["-KILL", "--", &format!("-{}", self.child.id())])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
        let _ = self.child.kill();
        if self.status.is_none() {
            self.status = self.child.wait().ok();
        }
    }

    /// Waits until the process has ended, at most until `deadline`.
    fn wait(&mut self, deadline: Instant) -> ExitStatus {
        let name = self.name.clone();
        wait_until(deadline, &format!("{name} to finish"), || self.exited())
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
        if std::thread::panicking() {
            let log = self.log();
            let tail: String = {
                let chars: Vec<char> = log.chars().collect();
                chars[chars.len().saturating_sub(6000)..].iter().collect()
            };
            eprintln!("----- {} ({}) -----\n{tail}", self.name, self.log.display());
        }
    }
}

/// Polls `ready` every 20 ms until it gives a value; fails at `deadline`.
fn wait_until<T>(deadline: Instant, what: &str, mut ready: impl FnMut() -> Option<T>) -> T {
    loop {
        if let Some(value) = ready() {
            return value;
        }
        assert!(
            Instant::now() < deadline,
            "timed out waiting for {what} ({} s)",
            DEADLINE.as_secs()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `PATH` with these folders first.
fn path_with(first: &[&Path]) -> std::ffi::OsString {
    let rest = std::env::var_os("PATH").unwrap_or_default();
    let mut dirs: Vec<PathBuf> = first.iter().map(|p| p.to_path_buf()).collect();
    dirs.extend(std::env::split_paths(&rest));
    std::env::join_paths(dirs).unwrap()
}

fn lumo_dir() -> PathBuf {
    Path::new(LUMO).parent().unwrap().to_path_buf()
}

/// Writes an executable shell script.
fn script(path: &Path, text: &str) {
    fs::create_dir_all(path.parent().unwrap()).unwrap();
    fs::write(path, text).unwrap();
    fs::set_permissions(path, fs::Permissions::from_mode(0o755)).unwrap();
}

/// A Dask scheduler and workers on 127.0.0.1, each worker with its own folder first on PATH
/// (where it finds `lumo`). Fields drop in order: the processes die before their folder goes.
struct Cluster {
    workers: Vec<(Proc, String)>,
    _scheduler: Proc,
    address: String,
    venv: PathBuf,
    dir: Scratch,
}

impl Cluster {
    fn start(venv: &Path, worker_paths: &[&Path], deadline: Instant) -> Cluster {
        let dir = Scratch::new();
        let file = dir.0.join("scheduler.json");
        let mut cmd = Command::new(venv.join("dask"));
        cmd.args(["scheduler", "--host", "127.0.0.1", "--port", "0"])
            .args(["--dashboard-address", "127.0.0.1:0", "--scheduler-file"])
            .arg(&file)
            .env("PATH", path_with(&[venv]))
            .current_dir(&dir.0);
        let mut scheduler = Proc::spawn("dask scheduler", cmd, dir.0.join("scheduler.log"));
        let address = wait_until(deadline, "the scheduler's address", || {
            if let Some(status) = scheduler.exited() {
                panic!("the scheduler exited ({status}):\n{}", scheduler.log());
            }
            let text = fs::read_to_string(&file).ok()?;
            let at = text.find("\"address\"")?;
            let start = at + text[at..].find("tcp://")?;
            let end = start + text[start..].find('"')?;
            Some(text[start..end].to_string())
        });
        let mut workers = Vec::new();
        for (i, first) in worker_paths.iter().enumerate() {
            let name = format!("w{}", i + 1);
            let mut cmd = Command::new(venv.join("dask"));
            cmd.args(["worker", &address, "--nworkers", "1", "--nthreads", "1"])
                .args(["--host", "127.0.0.1", "--dashboard-address", "127.0.0.1:0"])
                .args([
                    "--name",
                    &name,
                    "--death-timeout",
                    "60",
                    "--local-directory",
                ])
                .arg(dir.0.join(&name))
                .env("PATH", path_with(&[first, venv]))
                .current_dir(&dir.0);
            let log = dir.0.join(format!("{name}.log"));
            workers.push((
                Proc::spawn(&format!("dask worker {name}"), cmd, log),
                String::new(),
            ));
        }
        for (worker, address) in &mut workers {
            *address = wait_until(deadline, "the workers to register", || {
                if let Some(status) = worker.exited() {
                    panic!("{} exited ({status}):\n{}", worker.name, worker.log());
                }
                let log = worker.log();
                if !log.contains("Registered to:") {
                    return None;
                }
                let line = log.lines().find(|l| l.contains("Start worker at:"))?;
                Some(line.split_whitespace().last()?.to_string())
            });
        }
        Cluster {
            workers,
            _scheduler: scheduler,
            address,
            venv: venv.to_path_buf(),
            dir,
        }
    }

    /// Starts `lumo-dask` on this cluster (the real lumo first on its PATH), writing `out`.
    fn driver(&self, out: &Path, extra: &[&str]) -> Proc {
        self.driver_of(SCENE, out, extra)
    }

    /// [`Cluster::driver`] of another scene.
    fn driver_of(&self, scene: &str, out: &Path, extra: &[&str]) -> Proc {
        let mut cmd = Command::new(self.venv.join("lumo-dask"));
        cmd.arg(scene)
            .args(RENDER)
            .args(["--chunk-spp", CHUNK_SPP, "--scheduler", &self.address])
            .args(extra)
            .arg("-o")
            .arg(out)
            .env("PATH", path_with(&[&lumo_dir(), &self.venv]))
            .current_dir(root());
        Proc::spawn("lumo-dask", cmd, self.dir.0.join("driver.log"))
    }

    /// One-machine `lumo render` of the same image: the bytes every distributed render must give.
    fn reference(&self) -> Vec<u8> {
        self.reference_of(SCENE, &[])
    }

    /// [`Cluster::reference`] of another scene, with more `lumo render` flags.
    fn reference_of(&self, scene: &str, extra: &[&str]) -> Vec<u8> {
        let path = self.dir.0.join("reference.exr");
        let out = Command::new(LUMO)
            .args(["render", scene])
            .args(RENDER)
            .args(extra)
            .args(["-q", "-o"])
            .arg(&path)
            .current_dir(root())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "lumo render failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        fs::read(path).unwrap()
    }

    fn worker(&mut self, address: &str) -> &mut Proc {
        let known: Vec<_> = self.workers.iter().map(|(_, a)| a.clone()).collect();
        self.workers
            .iter_mut()
            .find(|(_, a)| a == address)
            .map(|(p, _)| p)
            .unwrap_or_else(|| panic!("no worker at {address}; the workers are {known:?}"))
    }
}

fn assert_same_image(got: &Path, want: &[u8]) {
    let got_bytes = fs::read(got).unwrap_or_else(|e| panic!("{}: {e}", got.display()));
    assert!(
        got_bytes == want,
        "{} ({} bytes) differs from the one-machine render ({} bytes)",
        got.display(),
        got_bytes.len(),
        want.len()
    );
}

/// The workers named in the driver's `… accepted from worker tcp://…` lines, in order.
fn accepted_from(log: &str) -> Vec<String> {
    log.lines()
        .filter_map(|l| l.split("accepted from worker ").nth(1))
        .filter_map(|rest| rest.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

#[test]
fn two_workers_render_the_same_image_as_one_machine() {
    let _turn = serial();
    let Some(venv) = venv() else { return };
    let deadline = Instant::now() + DEADLINE;
    let lumo = lumo_dir();
    let cluster = Cluster::start(&venv, &[&lumo, &lumo], deadline);
    let want = cluster.reference();
    let out = cluster.dir.0.join("out.exr");
    let mut driver = cluster.driver(&out, &[]);
    let status = driver.wait(deadline);
    let log = driver.log();
    assert!(status.success(), "lumo-dask failed ({status}):\n{log}");
    assert_same_image(&out, &want);
    assert_eq!(
        accepted_from(&log).len(),
        8,
        "8 chunks of 4 samples:\n{log}"
    );
    assert!(log.contains("done: "), "no summary:\n{log}");

    // `--light-sampler` reaches every task: on a scene of many lights (where the default picks
    // by the light tree) the image is that of `lumo render --light-sampler power`, not the
    // default's.
    let scene = "scenes/many_lights.json";
    let by_tree = cluster.reference_of(scene, &[]);
    let want = cluster.reference_of(scene, &["--light-sampler", "power"]);
    assert_ne!(by_tree, want, "the light choice must change the image");
    let mut driver = cluster.driver_of(scene, &out, &["--light-sampler", "power"]);
    let status = driver.wait(deadline);
    let log = driver.log();
    assert!(status.success(), "lumo-dask failed ({status}):\n{log}");
    assert_same_image(&out, &want);
}

#[test]
fn a_worker_killed_mid_task_changes_nothing() {
    let _turn = serial();
    let Some(venv) = venv() else { return };
    let deadline = Instant::now() + DEADLINE;
    let dir = Scratch::new();
    // Renders take half a second longer, so that the kill lands in the middle of a task.
    let slow = dir.0.join("slow");
    script(
        &slow.join("lumo"),
        &format!(
            "#!/bin/sh\n\
             # Test double: lumo, half a second slower to render.\n\
             if [ \"$1\" = render ]; then sleep 0.5; fi\n\
             exec '{LUMO}' \"$@\"\n"
        ),
    );
    let mut cluster = Cluster::start(&venv, &[&slow, &slow], deadline);
    let want = cluster.reference();
    let out = cluster.dir.0.join("out.exr");
    let mut driver = cluster.driver(&out, &["--progress-every", "0"]);
    // The first film is in: its worker has moved on to its next chunk. Kill it there.
    let victim = wait_until(deadline, "the first partial image", || {
        if let Some(status) = driver.exited() {
            panic!("lumo-dask ended early ({status}):\n{}", driver.log());
        }
        let log = driver.log();
        if !log.contains("wrote partial") {
            return None;
        }
        assert!(
            !log.contains("done: "),
            "the job ended before the kill:\n{log}"
        );
        assert!(
            out.is_file(),
            "no partial image after `wrote partial`:\n{log}"
        );
        accepted_from(&log).into_iter().next()
    });
    cluster.worker(&victim).kill();
    let before = accepted_from(&driver.log()).len();
    assert!(before < 8, "all chunks were in before the kill");
    let status = driver.wait(deadline);
    let log = driver.log();
    assert!(status.success(), "lumo-dask failed ({status}):\n{log}");
    assert_same_image(&out, &want);
    // The chunk the victim was rendering ran again on the other worker.
    assert!(
        log.contains("started again on"),
        "no task was run again after the kill of {victim}:\n{log}"
    );
    let survivor: Vec<_> = accepted_from(&log).into_iter().skip(before + 1).collect();
    assert!(
        survivor.iter().all(|w| *w != victim),
        "films accepted from the killed worker {victim} after it died:\n{log}"
    );
}

#[test]
fn a_wrong_film_is_rejected_and_its_chunk_rendered_again() {
    let _turn = serial();
    let Some(venv) = venv() else { return };
    let deadline = Instant::now() + DEADLINE;
    let dir = Scratch::new();
    // The first render on this worker is asked for sample 0 alone, whatever chunk it was given.
    let faulty = dir.0.join("faulty");
    let mark = dir.0.join("faulty-used");
    script(
        &faulty.join("lumo"),
        &format!(
            "#!/bin/sh\n\
             # Test double: lumo whose first render renders the wrong samples.\n\
             if [ \"$1\" = render ] && mkdir '{}' 2>/dev/null; then\n\
             \x20 prev=\n\
             \x20 for a do\n\
             \x20   shift\n\
             \x20   if [ \"$prev\" = --samples ]; then set -- \"$@\" 0..1; else set -- \"$@\" \"$a\"; fi\n\
             \x20   prev=$a\n\
             \x20 done\n\
             fi\n\
             exec '{LUMO}' \"$@\"\n",
            mark.display()
        ),
    );
    let lumo = lumo_dir();
    let cluster = Cluster::start(&venv, &[&faulty, &lumo], deadline);
    let bad = cluster.workers[0].1.clone();
    let want = cluster.reference();
    let out = cluster.dir.0.join("out.exr");
    let mut driver = cluster.driver(&out, &[]);
    let status = driver.wait(deadline);
    let log = driver.log();
    assert!(status.success(), "lumo-dask failed ({status}):\n{log}");
    assert!(mark.is_dir(), "the faulty worker rendered nothing:\n{log}");
    assert!(
        log.contains(&format!(
            "rejected the film from worker {bad}: wrong sample ranges"
        )),
        "the wrong film was not rejected:\n{log}"
    );
    assert!(log.contains("(0 failed, 1 rejected)"), "summary:\n{log}");
    assert_same_image(&out, &want);
}

#[test]
fn a_worker_with_another_lumo_build_is_refused() {
    let _turn = serial();
    let Some(venv) = venv() else { return };
    let deadline = Instant::now() + DEADLINE;
    let dir = Scratch::new();
    // The same program with one byte more: another build id (the SHA-256 of the executable).
    let other = dir.0.join("other");
    fs::create_dir_all(&other).unwrap();
    let mut bytes = fs::read(LUMO).unwrap();
    bytes.push(0);
    fs::write(other.join("lumo"), bytes).unwrap();
    fs::set_permissions(other.join("lumo"), fs::Permissions::from_mode(0o755)).unwrap();
    let lumo = lumo_dir();
    let cluster = Cluster::start(&venv, &[&lumo, &other], deadline);
    let (good, bad) = (cluster.workers[0].1.clone(), cluster.workers[1].1.clone());
    let out = cluster.dir.0.join("out.exr");
    let mut driver = cluster.driver(&out, &[]);
    let status = driver.wait(deadline);
    let log = driver.log();
    assert_eq!(
        status.code(),
        Some(2),
        "lumo-dask must refuse (exit 2):\n{log}"
    );
    assert!(
        log.contains(&format!("worker {bad} "))
            && log.contains(&format!("runs lumo {} sha256:", env!("CARGO_PKG_VERSION"))),
        "the message must name the worker and its build:\n{log}"
    );
    assert!(
        !log.contains(&good),
        "the good worker is not at fault:\n{log}"
    );
    assert!(!out.exists(), "no image from a refused job");
}
