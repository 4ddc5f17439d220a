//! The base protocol's message framing (`Content-Length: N` headers, a blank line, then N bytes
//! of JSON), read with bounds: `lsp-server`'s own reader allocates whatever length a header
//! announces and gives up on the stream at the first malformed header, so `lumo lsp` frames
//! its input itself and hands `lsp-server` only whole messages.
//!
//! - A body longer than [`MAX_CONTENT_LENGTH`] is read and discarded without being kept, and
//!   reported ([`ReadError::Skipped`]): the stream stays in step and the next message is read.
//! - A body that is not UTF-8 JSON-RPC is reported the same way.
//! - A header line longer than [`MAX_HEADER_LINE`], a header without `:`, a `Content-Length`
//!   that is not a number or no `Content-Length` at all leave nothing to find the next message
//!   by ([`ReadError::Fatal`]); so does the input ending inside a message.

use std::fmt;
use std::io::{self, BufRead, Read};

use lsp_server::Message;

/// The longest message body read (64 MiB): scenes with inline meshes run to a few MiB.
pub const MAX_CONTENT_LENGTH: u64 = 64 << 20;

/// The longest header line read, in bytes.
pub const MAX_HEADER_LINE: u64 = 8 << 10;

/// Why a message could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// This message was skipped whole; the next one can be read.
    Skipped(String),
    /// The stream cannot be read any further.
    Fatal(String),
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Skipped(m) => write!(f, "{m}; message skipped"),
            ReadError::Fatal(m) => write!(f, "{m}; cannot read further messages"),
        }
    }
}

impl std::error::Error for ReadError {}

fn io_fatal(what: &str, e: &io::Error) -> ReadError {
    ReadError::Fatal(format!("{what}: {e}"))
}

/// Reads one header line (without its `\r\n` or `\n`), or `None` at the end of the input.
fn header_line(r: &mut impl BufRead) -> Result<Option<String>, ReadError> {
    let mut line = Vec::new();
    let n = r
        .by_ref()
        .take(MAX_HEADER_LINE + 1)
        .read_until(b'\n', &mut line)
        .map_err(|e| io_fatal("reading a message header", &e))?;
    if n == 0 {
        return Ok(None);
    }
    if !line.ends_with(b"\n") {
        return Err(ReadError::Fatal(if n as u64 > MAX_HEADER_LINE {
            format!("a header line is longer than {MAX_HEADER_LINE} bytes")
        } else {
            "the input ended inside a message header".to_string()
        }));
    }
    line.pop();
    if line.ends_with(b"\r") {
        line.pop();
    }
    String::from_utf8(line)
        .map(Some)
        .map_err(|_| ReadError::Fatal("a message header is not UTF-8".to_string()))
}

/// Reads the next message: `Ok(None)` when the input ends between messages.
pub fn read_message(r: &mut impl BufRead) -> Result<Option<Message>, ReadError> {
    let mut length: Option<u64> = None;
    let mut first = true;
    loop {
        let Some(line) = header_line(r)? else {
            return if first {
                Ok(None)
            } else {
                Err(ReadError::Fatal(
                    "the input ended inside a message header".into(),
                ))
            };
        };
        if line.is_empty() {
            if first {
                // Blank lines between messages are tolerated.
                continue;
            }
            break;
        }
        first = false;
        let Some((name, value)) = line.split_once(':') else {
            return Err(ReadError::Fatal(format!(
                "malformed header `{}` (expected `Name: value`, such as `Content-Length: 42`)",
                shorten(&line)
            )));
        };
        if name.trim().eq_ignore_ascii_case("Content-Length") {
            let value = value.trim();
            let n = value.parse::<u64>().map_err(|_| {
                ReadError::Fatal(format!(
                    "Content-Length `{}` is not a number of bytes",
                    shorten(value)
                ))
            })?;
            length = Some(n);
        }
        // Other headers (Content-Type) are allowed and ignored.
    }
    let Some(length) = length else {
        return Err(ReadError::Fatal(
            "a message has no Content-Length header".to_string(),
        ));
    };
    if length > MAX_CONTENT_LENGTH {
        let skipped = io::copy(&mut r.by_ref().take(length), &mut io::sink())
            .map_err(|e| io_fatal("skipping a message", &e))?;
        if skipped < length {
            return Err(ReadError::Fatal(format!(
                "a message announced {length} bytes (more than the {MAX_CONTENT_LENGTH} read) \
                 and the input ended after {skipped}"
            )));
        }
        return Err(ReadError::Skipped(format!(
            "a message of {length} bytes is longer than the {MAX_CONTENT_LENGTH} bytes read"
        )));
    }
    // Grown as bytes arrive, not allocated from the header.
    let mut body = Vec::new();
    r.by_ref()
        .take(length)
        .read_to_end(&mut body)
        .map_err(|e| io_fatal("reading a message", &e))?;
    if (body.len() as u64) < length {
        return Err(ReadError::Fatal(format!(
            "the input ended after {} of a message's {length} bytes",
            body.len()
        )));
    }
    let text = std::str::from_utf8(&body)
        .map_err(|e| ReadError::Skipped(format!("a message is not UTF-8 ({e})")))?;
    serde_json::from_str(text).map(Some).map_err(|e| {
        ReadError::Skipped(format!(
            "a message is not a JSON-RPC request, response or notification ({e}): {}",
            shorten(text)
        ))
    })
}

/// At most 80 characters of `text`, for messages.
fn shorten(text: &str) -> String {
    let mut out: String = text.chars().take(80).collect();
    if out.len() < text.len() {
        out.push('…');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(body: &str) -> String {
        format!("Content-Length: {}\r\n\r\n{body}", body.len())
    }

    const EXIT: &str = r#"{"jsonrpc": "2.0", "method": "exit"}"#;

    #[test]
    fn reads_messages_in_turn() {
        let input = format!(
            "{}Content-Type: application/vscode-jsonrpc; charset=utf-8\r\n{}",
            frame(r#"{"jsonrpc": "2.0", "id": 1, "method": "shutdown"}"#),
            frame(EXIT)
        );
        let mut r = input.as_bytes();
        assert!(matches!(
            read_message(&mut r),
            Ok(Some(Message::Request(q))) if q.method == "shutdown"
        ));
        assert!(matches!(
            read_message(&mut r),
            Ok(Some(Message::Notification(n))) if n.method == "exit"
        ));
        assert!(matches!(read_message(&mut r), Ok(None)));
    }

    #[test]
    fn a_huge_content_length_is_skipped_without_allocating_it() {
        // Announces 2^63 bytes and sends 10: nothing of that size is allocated, and the
        // stream's end inside the message is reported.
        let input = "Content-Length: 9223372036854775807\r\n\r\n0123456789";
        let e = read_message(&mut input.as_bytes()).unwrap_err();
        assert!(
            matches!(&e, ReadError::Fatal(m) if m.contains("9223372036854775807")),
            "{e}"
        );
        // A body just over the limit that does arrive is skipped, and the next message read.
        let big = MAX_CONTENT_LENGTH + 1;
        let header = format!("Content-Length: {big}\r\n\r\n");
        let next = frame(EXIT);
        let mut r = io::BufReader::new(
            header
                .as_bytes()
                .chain(io::repeat(b' ').take(big))
                .chain(next.as_bytes()),
        );
        let e = read_message(&mut r).unwrap_err();
        assert!(
            matches!(&e, ReadError::Skipped(m) if m.contains("longer than")),
            "{e}"
        );
        assert!(matches!(
            read_message(&mut r),
            Ok(Some(Message::Notification(_)))
        ));
    }

    #[test]
    fn malformed_headers_and_bodies_are_errors() {
        for (input, fatal, says) in [
            ("Content-Length: lots\r\n\r\n{}", true, "not a number"),
            ("Content-Length: -1\r\n\r\n{}", true, "not a number"),
            ("Content-Length 2\r\n\r\n{}", true, "malformed header"),
            ("Content-Type: x\r\n\r\n{}", true, "no Content-Length"),
            ("Content-Length: 20\r\n\r\n{}", true, "ended after 2"),
            ("Content-Length: 2\r\n", true, "ended inside"),
            ("Content-Length: 2\r\n\r\n{}", false, "not a JSON-RPC"),
        ] {
            let e = read_message(&mut input.as_bytes()).unwrap_err();
            assert_eq!(matches!(e, ReadError::Fatal(_)), fatal, "{input:?}: {e}");
            assert!(e.to_string().contains(says), "{input:?}: {e}");
        }
        let e = read_message(&mut &b"Content-Length: 2\r\n\r\n\xff\xfe"[..]).unwrap_err();
        assert!(
            matches!(&e, ReadError::Skipped(m) if m.contains("not UTF-8")),
            "{e}"
        );
        let long = format!("X-{}: 1\r\n", "a".repeat(MAX_HEADER_LINE as usize));
        let e = read_message(&mut long.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("longer than"), "{e}");
        // A skipped body leaves the next message readable.
        let input = format!("{}{}", frame("[1, 2]"), frame(EXIT));
        let mut r = input.as_bytes();
        assert!(matches!(read_message(&mut r), Err(ReadError::Skipped(_))));
        assert!(matches!(read_message(&mut r), Ok(Some(_))));
    }
}
