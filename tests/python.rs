//! The Python package (`python/`) tested from Python: runs its pytest suite (`python/tests`) in
//! the environment `python/.venv` with the `lumo` binary of this build (`LUMO_BIN`), which the
//! suite compares the package's images and films against, byte for byte.
//!
//! `.ci/run` makes the environment (`pip install ./python pytest numpy`, so the package is built
//! from the current source). Without it this test prints a loud SKIPPED message and returns,
//! unless `LUMO_REQUIRE_PYTHON=1` (set by `.ci/run`), which turns the skip into a failure. For a
//! development environment: `python3 -m venv python/.venv && python/.venv/bin/pip install
//! maturin pytest numpy`, then `maturin develop` in `python/` after each change (this test
//! warns when the installed module is older than the Rust source).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant, SystemTime};

const LUMO: &str = env!("CARGO_BIN_EXE_lumo");
/// The suite must be done within this, or the test fails (and kills it).
const DEADLINE: Duration = Duration::from_secs(300);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The environment's Python, or `None` after a loud message (a panic under
/// `LUMO_REQUIRE_PYTHON=1`).
fn venv_python() -> Option<PathBuf> {
    let python = root().join("python/.venv/bin/python");
    if python.is_file() {
        return Some(python);
    }
    let what = format!(
        "{} is missing (make it: python3 -m venv python/.venv && \
         python/.venv/bin/pip install ./python pytest numpy)",
        python.display()
    );
    if std::env::var_os("LUMO_REQUIRE_PYTHON").is_some_and(|v| v == "1") {
        panic!("the Python environment is required (LUMO_REQUIRE_PYTHON=1): {what}");
    }
    // Straight to stderr: the test harness would hide eprintln!'s output of a passing test.
    let _ = writeln!(
        std::io::stderr(),
        "\n=== SKIPPED: the Python package's tests: {what} ===\n"
    );
    None
}

/// The newest modification time of the `.rs` files under `dir`.
fn newest_source(dir: &Path) -> Option<SystemTime> {
    let mut newest = None;
    for entry in fs::read_dir(dir).ok()?.flatten() {
        let path = entry.path();
        let time = if path.is_dir() {
            newest_source(&path)
        } else if path.extension().is_some_and(|e| e == "rs") {
            entry.metadata().and_then(|m| m.modified()).ok()
        } else {
            None
        };
        newest = newest.max(time);
    }
    newest
}

/// Warns when the installed extension module is older than the Rust source it is built from.
fn warn_if_stale(python: &Path) {
    let out = Command::new(python)
        .args(["-c", "import lumo._lumo as m; print(m.__file__)"])
        .output();
    let Ok(out) = out else { return };
    let module = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    let Ok(built) = fs::metadata(&module).and_then(|m| m.modified()) else {
        return;
    };
    let source = ["python/src", "src", "schema/src", "converters/src"]
        .iter()
        .filter_map(|d| newest_source(&root().join(d)))
        .max();
    if source.is_some_and(|s| s > built) {
        let _ = writeln!(
            std::io::stderr(),
            "\n=== WARNING: {} is older than the Rust source: the tests run the old build \
             (rebuild it: cd python && maturin develop) ===\n",
            module.display()
        );
    }
}

#[test]
fn python_package_test_suite() {
    let Some(python) = venv_python() else { return };
    warn_if_stale(&python);
    let log = std::env::temp_dir().join(format!("lumo-pytest-{}.log", std::process::id()));
    let file = fs::File::create(&log).expect("a log file in the temporary folder");
    let mut child = Command::new(&python)
        .args([
            "-m",
            "pytest",
            "python/tests",
            "-q",
            "-p",
            "no:cacheprovider",
        ])
        .current_dir(root())
        .env("LUMO_BIN", LUMO)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdin(Stdio::null())
        .stdout(file.try_clone().expect("the log file"))
        .stderr(file)
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()));
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Some(status),
            Ok(None) if start.elapsed() > DEADLINE => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(100)),
            Err(e) => panic!("waiting for pytest: {e}"),
        }
    };
    let output = fs::read_to_string(&log).unwrap_or_default();
    let _ = fs::remove_file(&log);
    println!("{output}");
    match status {
        None => panic!(
            "the Python tests did not finish within {} s (killed); their output is above",
            DEADLINE.as_secs()
        ),
        Some(s) if s.success() => {
            let summary = output.lines().rev().find(|l| !l.trim().is_empty());
            let _ = writeln!(
                std::io::stderr(),
                "python/tests (pytest): {}",
                summary.unwrap_or("passed")
            );
        }
        // pytest's 5: no test was collected, which is a failure here too.
        Some(s) => panic!("the Python tests failed ({s}); their output is above"),
    }
}
