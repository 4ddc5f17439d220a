//! Fuzzes the language server's message handling (`lumo lsp`, `lumo::lsp::Server`) with
//! arbitrary bytes, in ways chosen by the first byte:
//! - 0: the rest is a sequence of framed LSP messages (`Content-Length: N` headers and JSON
//!   bodies, as an editor writes them), read by `lumo::lsp::framing` (bounded: a huge
//!   `Content-Length` is skipped, not allocated) and each handled, then the documents checked;
//! - otherwise: the rest is the text of a document opened in the editor (a file under a
//!   temporary folder; when the first byte is odd, after `{"$schema": "scene.schema.json",` so
//!   that most inputs are lumo scenes), then completion, hover and go to definition asked at
//!   positions taken from the first bytes, counted in UTF-8, UTF-16 or UTF-32 as the first
//!   byte says, and the document checked.
//!
//! Nothing may panic, every request gets exactly one response, and an opened document
//! publishes diagnostics exactly when it is a lumo scene or fragment.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use lsp_server::{Message, Notification, Request, RequestId};
use lumo::lsp::framing::{read_message, ReadError};
use lumo::lsp::{is_lumo_text, Encoding, Server};

/// A folder with a fragment the fuzzed scene can include.
fn folder() -> &'static std::path::Path {
    static DIR: OnceLock<std::path::PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join("lumo-fuzz-lsp");
        let _ = std::fs::create_dir_all(&dir);
        let _ = std::fs::write(
            dir.join("lib.json"),
            r#"{"$schema": "scene-fragment.schema.json", "materials": {"red": {"base_color": [1, 0, 0]}}}"#,
        );
        dir
    })
}

fn requests_answered(out: &[Message], asked: usize) {
    let answered = out
        .iter()
        .filter(|m| matches!(m, Message::Response(_)))
        .count();
    assert_eq!(answered, asked, "every request is answered once");
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let encoding = [Encoding::Utf8, Encoding::Utf16, Encoding::Utf32][usize::from(mode / 2 % 3)];
    let mut server = Server::with_encoding(encoding);
    let mut out = Vec::new();
    if mode == 0 {
        let mut reader = rest;
        let mut asked = 0;
        loop {
            let message = match read_message(&mut reader) {
                Ok(Some(m)) => m,
                Ok(None) | Err(ReadError::Fatal(_)) => break,
                Err(ReadError::Skipped(_)) => continue,
            };
            asked += usize::from(matches!(message, Message::Request(_)));
            if !server.handle(message, &mut out) {
                break;
            }
        }
        requests_answered(&out, asked);
        server.check_now(&mut out);
        return;
    }
    let (positions, text) = rest.split_at(rest.len().min(6));
    let mut text = String::from_utf8_lossy(text).into_owned();
    if mode % 2 == 1 {
        text.insert_str(0, r#"{"$schema": "scene.schema.json","#);
    }
    let uri = format!("file://{}/scene.json", folder().display());
    let open = Notification::new(
        "textDocument/didOpen".into(),
        serde_json::json!({"textDocument": {"uri": uri, "languageId": "json", "version": 1, "text": text}}),
    );
    server.handle(Message::Notification(open), &mut out);
    let mut asked = 0;
    for (i, method) in [
        "textDocument/completion",
        "textDocument/hover",
        "textDocument/definition",
    ]
    .iter()
    .enumerate()
    {
        let line = positions.get(2 * i).copied().unwrap_or(0) % 16;
        let character = positions.get(2 * i + 1).copied().unwrap_or(0);
        let request = Request::new(
            RequestId::from(i as i32 + 1),
            (*method).into(),
            serde_json::json!({"textDocument": {"uri": uri}, "position": {"line": line, "character": character}}),
        );
        asked += 1;
        server.handle(Message::Request(request), &mut out);
    }
    requests_answered(&out, asked);
    out.clear();
    server.check_now(&mut out);
    let published = out.iter().any(
        |m| matches!(m, Message::Notification(n) if n.method == "textDocument/publishDiagnostics"),
    );
    assert_eq!(
        published,
        is_lumo_text(&text, None),
        "diagnostics are published for lumo's documents only"
    );
});
