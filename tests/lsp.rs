//! `lumo lsp` driven over stdio by a real LSP client (`tests/lsp/client.py`, Python's standard
//! library only): diagnostics at `lumo validate`'s positions, cleared when fixed, completion of
//! material names, hover, go to definition into an included fragment. One process, bounded in
//! time, in its own test binary.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn an_editor_session_over_stdio() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut child = Command::new("python3")
        .arg(root.join("tests/lsp/client.py"))
        .arg(env!("CARGO_BIN_EXE_lumo"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs the LSP client");
    let deadline = Instant::now() + Duration::from_secs(90);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the LSP session took more than 90 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        status.success() && stdout.contains("lumo lsp: ok"),
        "{stdout}\n{stderr}"
    );
}
