//! `lumo lsp` driven over stdio by a real LSP client (`tests/lsp/client.py`, Python's standard
//! library only): diagnostics at `lumo validate`'s positions (in UTF-16 and in a negotiated
//! UTF-8), cleared when fixed, nothing for JSON files that are not lumo's, completion of
//! material names and schema keywords, hover, go to definition into an included fragment and
//! to included and asset files; and the message framing against a hostile `Content-Length`.
//! Processes run one at a time, each bounded in time, in this test binary of their own.

use std::io::Write;
use std::process::{Child, Command, Output, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One `lumo lsp` process at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Waits for `child` to end, killing it after `limit`.
fn wait_bounded(mut child: Child, limit: Duration, what: &str) -> Output {
    let deadline = Instant::now() + limit;
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("{what} took more than {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn an_editor_session_over_stdio() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let child = Command::new("python3")
        .arg(root.join("tests/lsp/client.py"))
        .arg(env!("CARGO_BIN_EXE_lumo"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs the LSP client");
    let out = wait_bounded(child, Duration::from_secs(90), "the LSP session");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("lumo lsp: ok"),
        "{stdout}\n{stderr}"
    );
}

fn frame(body: &str) -> Vec<u8> {
    format!("Content-Length: {}\r\n\r\n{body}", body.len()).into_bytes()
}

/// Runs `lumo lsp` on `input` (written from a thread while the output is read), with
/// standard input closed after it.
fn lsp_on(input: Vec<u8>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lumo"))
        .arg("lsp")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lumo lsp starts");
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        // The server may end before reading everything (a fatal header): a broken pipe is
        // part of what is tested.
        let _ = stdin.write_all(&input);
    });
    let out = wait_bounded(child, Duration::from_secs(30), "lumo lsp");
    writer.join().unwrap();
    out
}

#[test]
fn a_hostile_content_length_is_refused_with_an_error_not_a_panic() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let initialize =
        r#"{"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {"capabilities": {}}}"#;
    let initialized = r#"{"jsonrpc": "2.0", "method": "initialized", "params": {}}"#;
    let shutdown = r#"{"jsonrpc": "2.0", "id": 2, "method": "shutdown"}"#;
    let exit = r#"{"jsonrpc": "2.0", "method": "exit"}"#;

    // 2^63 - 1 bytes announced, a few sent, then the input closed: an error naming the length
    // on standard error and a failed exit, where lsp-server's reader would try to allocate it.
    let mut input = frame(initialize);
    input.extend_from_slice(b"Content-Length: 9223372036854775807\r\n\r\n{\"jsonrpc\"");
    let out = lsp_on(input);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("9223372036854775807"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    // The initialize before it was answered.
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"capabilities\""));

    // A body over the 64 MiB limit that does arrive is skipped, reported, and the session goes
    // on: the requests after it are answered and the server exits cleanly.
    let big = lumo::lsp::framing::MAX_CONTENT_LENGTH as usize + 1;
    let mut input = frame(initialize);
    input.extend_from_slice(frame(initialized).as_slice());
    input.extend_from_slice(format!("Content-Length: {big}\r\n\r\n").as_bytes());
    input.resize(input.len() + big, b' ');
    for m in [shutdown, exit] {
        input.extend_from_slice(&frame(m));
    }
    let out = lsp_on(input);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("longer than") && stderr.contains("skipped"),
        "{stderr}"
    );
    assert!(stdout.contains(r#""id":2"#), "shutdown answered: {stdout}");

    // A malformed header ends the session with an error that says what was wrong.
    let mut input = frame(initialize);
    input.extend_from_slice(b"Content-Length: lots\r\n\r\n{}");
    let out = lsp_on(input);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("`lots` is not a number"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}
