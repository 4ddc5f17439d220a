//! `lumo lsp`: a language server for scene files and fragments, over stdio.
//!
//! - Diagnostics as the user types (debounced by [`DEBOUNCE`]): exactly `lumo validate`'s
//!   problems, each at its line and column, with the help text as related information.
//!   Problems in an included fragment are published for the fragment, and the include that
//!   brought them in is marked in the including file. A file's diagnostics are cleared when it
//!   is fixed.
//! - Completion of material and texture names where a scene names one (`"material": "…"`,
//!   `"texture": "…"`), from the scene and its includes.
//! - Hover on a member name: the schema's documentation of that field.
//! - Go to definition from a material or texture name to where it is defined, across includes.
//!
//! [`Server`] holds the state and handles one message at a time without doing I/O on the
//! connection, so the protocol logic is tested (and fuzzed) without a process; [`run_stdio`]
//! connects it to standard input and output.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use lsp_server::{Connection, Message, Notification, Request, Response};
use lsp_types as lsp;
use lumo_schema as schema;
use lumo_schema::locate::{JsonPath, PathSegment};
use serde_json::Value;

/// How long the server waits after the last change before checking the documents again.
pub const DEBOUNCE: Duration = Duration::from_millis(150);

/// An open document.
#[derive(Debug, Clone)]
struct Document {
    /// Its path on disk (relative paths inside it resolve against its folder).
    path: PathBuf,
    /// Its current text (possibly unsaved).
    text: String,
    /// Its last text that was JSON, to find names while the current text is not.
    last_json: Option<String>,
}

/// Where a name is defined: the file, and the line and character (from 0) of its name.
type Definition = (PathBuf, u32, u32);

/// The language server's state.
#[derive(Debug, Default)]
pub struct Server {
    /// Open documents by URI.
    documents: BTreeMap<String, Document>,
    /// Documents changed since they were last checked.
    dirty: BTreeSet<String>,
    /// When the dirty documents are due to be checked.
    due: Option<Instant>,
    /// For each checked document, the URIs it published diagnostics to.
    published: BTreeMap<String, BTreeSet<String>>,
    /// Whether the client asked to shut down.
    shutting_down: bool,
}

impl Server {
    /// A server with no open documents.
    pub fn new() -> Server {
        Server::default()
    }

    /// What the server can do, for the `initialize` response.
    pub fn capabilities() -> lsp::ServerCapabilities {
        lsp::ServerCapabilities {
            text_document_sync: Some(lsp::TextDocumentSyncCapability::Kind(
                lsp::TextDocumentSyncKind::FULL,
            )),
            completion_provider: Some(lsp::CompletionOptions {
                trigger_characters: Some(vec!["\"".into()]),
                ..lsp::CompletionOptions::default()
            }),
            hover_provider: Some(lsp::HoverProviderCapability::Simple(true)),
            definition_provider: Some(lsp::OneOf::Left(true)),
            ..lsp::ServerCapabilities::default()
        }
    }

    /// When the next check is due, if documents are waiting for one.
    pub fn due(&self) -> Option<Instant> {
        self.due
    }

    /// Handles one message from the client (after initialization); replies and notifications
    /// go to `out`. Returns `false` when the client has asked the server to exit.
    pub fn handle(&mut self, message: Message, out: &mut Vec<Message>) -> bool {
        match message {
            Message::Request(r) => {
                let response = self.request(r);
                out.push(Message::Response(response));
                true
            }
            Message::Notification(n) => self.notification(n),
            Message::Response(_) => true,
        }
    }

    fn request(&mut self, r: Request) -> Response {
        let id = r.id.clone();
        let result = match r.method.as_str() {
            "shutdown" => {
                self.shutting_down = true;
                Ok(Value::Null)
            }
            "textDocument/completion" => params::<lsp::CompletionParams>(r.params)
                .map(|p| to_value(self.completion(&p.text_document_position))),
            "textDocument/hover" => params::<lsp::HoverParams>(r.params)
                .map(|p| to_value(self.hover(&p.text_document_position_params))),
            "textDocument/definition" => params::<lsp::GotoDefinitionParams>(r.params)
                .map(|p| to_value(self.definition(&p.text_document_position_params))),
            other => Err(Response::new_err(
                id.clone(),
                lsp_server::ErrorCode::MethodNotFound as i32,
                format!("lumo lsp does not handle `{other}`"),
            )),
        };
        match result {
            Ok(value) => Response::new_ok(id, value),
            Err(mut e) => {
                e.id = id;
                e
            }
        }
    }

    fn notification(&mut self, n: Notification) -> bool {
        match n.method.as_str() {
            "exit" => return false,
            "textDocument/didOpen" => {
                if let Ok(p) = params::<lsp::DidOpenTextDocumentParams>(n.params) {
                    self.set_text(&p.text_document.uri, p.text_document.text);
                }
            }
            "textDocument/didChange" => {
                if let Ok(p) = params::<lsp::DidChangeTextDocumentParams>(n.params) {
                    // Full synchronisation: the last change is the whole text.
                    if let Some(change) = p.content_changes.into_iter().next_back() {
                        self.set_text(&p.text_document.uri, change.text);
                    }
                }
            }
            "textDocument/didSave" => {
                // Other documents may include the one saved: check them all again.
                let all: Vec<String> = self.documents.keys().cloned().collect();
                self.dirty.extend(all);
                self.due = Some(Instant::now() + DEBOUNCE);
            }
            "textDocument/didClose" => {
                if let Ok(p) = params::<lsp::DidCloseTextDocumentParams>(n.params) {
                    let uri = p.text_document.uri.as_str().to_string();
                    self.documents.remove(&uri);
                    self.dirty.remove(&uri);
                }
            }
            _ => {}
        }
        true
    }

    fn set_text(&mut self, uri: &lsp::Uri, text: String) {
        let Some(path) = uri_to_path(uri) else {
            return;
        };
        let key = uri.as_str().to_string();
        let last_json = if serde_json::from_str::<serde::de::IgnoredAny>(&text).is_ok() {
            Some(text.clone())
        } else {
            self.documents.get(&key).and_then(|d| d.last_json.clone())
        };
        self.documents.insert(
            key.clone(),
            Document {
                path,
                text,
                last_json,
            },
        );
        // A change may fix or break the documents that include this one too.
        let all: Vec<String> = self.documents.keys().cloned().collect();
        self.dirty.extend(all);
        self.dirty.insert(key);
        self.due = Some(Instant::now() + DEBOUNCE);
    }

    /// Checks every changed document now, publishing its diagnostics (and clearing those no
    /// longer found).
    pub fn check_now(&mut self, out: &mut Vec<Message>) {
        self.due = None;
        let dirty = std::mem::take(&mut self.dirty);
        let unsaved = self.unsaved();
        for uri in dirty {
            let Some(doc) = self.documents.get(&uri) else {
                continue;
            };
            let by_uri = diagnostics(doc, &uri, &unsaved);
            let before = self.published.remove(&uri).unwrap_or_default();
            for (target, list) in &by_uri {
                out.push(publish(target, list.clone()));
            }
            for stale in before.iter().filter(|u| !by_uri.contains_key(*u)) {
                out.push(publish(stale, Vec::new()));
            }
            self.published.insert(uri, by_uri.into_keys().collect());
        }
    }

    /// The open documents' texts by canonical path, for reading includes.
    fn unsaved(&self) -> BTreeMap<PathBuf, String> {
        self.documents
            .values()
            .filter_map(|d| Some((std::fs::canonicalize(&d.path).ok()?, d.text.clone())))
            .collect()
    }

    fn document(&self, uri: &lsp::Uri) -> Option<&Document> {
        self.documents.get(uri.as_str())
    }

    /// The names the scene (with its includes) defines under `map` (`materials`, `textures`),
    /// each with where it is defined.
    /// `cursor`, when given, is where a name is being typed: a string left open there is
    /// closed to read the rest of the document.
    fn names(
        &self,
        doc: &Document,
        map: &str,
        cursor: Option<usize>,
    ) -> Vec<(String, Option<Definition>)> {
        let closed = cursor.map(|at| format!("{}\"{}", &doc.text[..at], &doc.text[at..]));
        let candidates = [Some(&doc.text), closed.as_ref(), doc.last_json.as_ref()];
        let Some((text, value)) = candidates.into_iter().flatten().find_map(|t| {
            serde_json::from_str::<Value>(t)
                .ok()
                .map(|v| (t.as_str(), v))
        }) else {
            return Vec::new();
        };
        let base = schema::base_dir_of(&doc.path);
        let Ok(composed) =
            schema::include::compose_with(&doc.path, &doc.text, value, &base, &self.unsaved())
        else {
            return Vec::new();
        };
        let Some(Value::Object(members)) = composed.value.get(map) else {
            return Vec::new();
        };
        members
            .keys()
            .map(|name| {
                let at = composed
                    .origin_of(&JsonPath::root().key(map).key(name))
                    .and_then(|(file, inner, _)| {
                        let text = if file == doc.path {
                            text.to_string()
                        } else {
                            std::fs::read_to_string(&file).ok()?
                        };
                        // The member's name, not its value.
                        let spans = schema::locate::spans(&text, &inner)?;
                        let (start, _) = spans.key.unwrap_or(spans.value);
                        let lc = schema::locate::line_col(&text, start);
                        Some((file, lc.line as u32 - 1, lc.column as u32 - 1))
                    });
                (name.clone(), at)
            })
            .collect()
    }

    fn completion(&self, at: &lsp::TextDocumentPositionParams) -> Option<lsp::CompletionResponse> {
        let doc = self.document(&at.text_document.uri)?;
        let offset = offset_of(&doc.text, at.position)?;
        let map = reference_at(&doc.text, offset)?.0;
        let items = self
            .names(doc, map, Some(offset))
            .into_iter()
            .map(|(name, _)| lsp::CompletionItem {
                label: name,
                kind: Some(lsp::CompletionItemKind::REFERENCE),
                detail: Some(format!("defined under `{map}`")),
                ..lsp::CompletionItem::default()
            })
            .collect();
        Some(lsp::CompletionResponse::Array(items))
    }

    fn definition(
        &self,
        at: &lsp::TextDocumentPositionParams,
    ) -> Option<lsp::GotoDefinitionResponse> {
        let doc = self.document(&at.text_document.uri)?;
        let offset = offset_of(&doc.text, at.position)?;
        let (map, name) = reference_at(&doc.text, offset)?;
        let (_, found) = self
            .names(doc, map, None)
            .into_iter()
            .find(|(n, _)| *n == name)?;
        let (file, line, character) = found?;
        let position = lsp::Position { line, character };
        Some(lsp::GotoDefinitionResponse::Scalar(lsp::Location {
            uri: path_to_uri(&file)?,
            range: lsp::Range {
                start: position,
                end: position,
            },
        }))
    }

    fn hover(&self, at: &lsp::TextDocumentPositionParams) -> Option<lsp::Hover> {
        let doc = self.document(&at.text_document.uri)?;
        let offset = offset_of(&doc.text, at.position)?;
        let path = path_at(&doc.text, offset)?;
        let doc_text = describe(scene_schema()?, &path)?;
        Some(lsp::Hover {
            contents: lsp::HoverContents::Markup(lsp::MarkupContent {
                kind: lsp::MarkupKind::Markdown,
                value: format!("`{path}`\n\n{doc_text}"),
            }),
            range: None,
        })
    }
}

/// The scene's JSON Schema, for hover (generated once).
fn scene_schema() -> Option<&'static Value> {
    static SCHEMA: std::sync::OnceLock<Option<Value>> = std::sync::OnceLock::new();
    SCHEMA
        .get_or_init(|| serde_json::from_str(&schema::json_schema()).ok())
        .as_ref()
}

/// A request's or notification's parameters, or the error response for bad ones.
fn params<P: serde::de::DeserializeOwned>(value: Value) -> Result<P, Response> {
    serde_json::from_value(value).map_err(|e| {
        Response::new_err(
            lsp_server::RequestId::from(0),
            lsp_server::ErrorCode::InvalidParams as i32,
            e.to_string(),
        )
    })
}

fn to_value<T: serde::Serialize>(v: T) -> Value {
    serde_json::to_value(v).unwrap_or(Value::Null)
}

fn publish(uri: &str, diagnostics: Vec<lsp::Diagnostic>) -> Message {
    Message::Notification(Notification::new(
        "textDocument/publishDiagnostics".into(),
        serde_json::json!({ "uri": uri, "diagnostics": diagnostics }),
    ))
}

/// The diagnostics of a document, by the URI they belong to: its own, and those of the
/// fragments it includes (each also marked at the include in the document).
fn diagnostics(
    doc: &Document,
    uri: &str,
    unsaved: &BTreeMap<PathBuf, String>,
) -> BTreeMap<String, Vec<lsp::Diagnostic>> {
    let result = if schema::include::is_fragment(&doc.text) {
        schema::check_fragment_with(&doc.text, &doc.path, unsaved).map(|_| ())
    } else {
        schema::load_scene_with(&doc.text, &doc.path, unsaved).map(|_| ())
    };
    let mut out: BTreeMap<String, Vec<lsp::Diagnostic>> = BTreeMap::new();
    out.insert(uri.to_string(), Vec::new());
    let problems = match result {
        Ok(()) => return out,
        Err(schema::LoadError::Invalid { diagnostics, .. }) => diagnostics,
        Err(e) => {
            let d = schema::Diagnostic::new(JsonPath::root(), e.to_string());
            vec![d]
        }
    };
    for d in problems {
        let (file, text) = match d.file() {
            Some(f) if f != doc.path => (f.to_path_buf(), std::fs::read_to_string(f).ok()),
            _ => (doc.path.clone(), Some(doc.text.clone())),
        };
        let target = if file == doc.path {
            uri.to_string()
        } else {
            match path_to_uri(&file) {
                Some(u) => u.as_str().to_string(),
                None => continue,
            }
        };
        let range = range_of(text.as_deref(), &d);
        let target_uri = target.parse::<lsp::Uri>().ok();
        let related = match (&d.help, &target_uri) {
            (Some(help), Some(u)) => Some(vec![lsp::DiagnosticRelatedInformation {
                location: lsp::Location {
                    uri: u.clone(),
                    range,
                },
                message: format!("help: {help}"),
            }]),
            _ => None,
        };
        let message = format!("{}: {}", d.path, d.message);
        out.entry(target.clone())
            .or_default()
            .push(lsp::Diagnostic {
                range,
                severity: Some(lsp::DiagnosticSeverity::ERROR),
                source: Some("lumo".into()),
                message: message.clone(),
                related_information: related,
                ..lsp::Diagnostic::default()
            });
        // Marked at the include (in this document) that brought the fragment in.
        if target != uri {
            let chain = d
                .source
                .as_deref()
                .map_or(&[][..], |s| &s.included_from[..]);
            if let Some((_, at)) = chain.iter().find(|(f, _)| *f == doc.path) {
                let p = lsp::Position {
                    line: at.line as u32 - 1,
                    character: at.column as u32 - 1,
                };
                out.entry(uri.to_string())
                    .or_default()
                    .push(lsp::Diagnostic {
                        range: lsp::Range { start: p, end: p },
                        severity: Some(lsp::DiagnosticSeverity::ERROR),
                        source: Some("lumo".into()),
                        message: format!("in {}: {message}", file.display()),
                        ..lsp::Diagnostic::default()
                    });
            }
        }
    }
    out
}

/// The range of a diagnostic: from its line and column over the value at its path.
fn range_of(text: Option<&str>, d: &schema::Diagnostic) -> lsp::Range {
    let Some(at) = d.location else {
        return lsp::Range::default();
    };
    let start = lsp::Position {
        line: at.line as u32 - 1,
        character: at.column as u32 - 1,
    };
    let end = text
        .and_then(|t| {
            let spans = schema::locate::spans(t, &d.path)?;
            let begin = schema::locate::line_col(t, spans.value.0);
            // Only when the path's value is where the diagnostic is.
            if begin != at {
                return None;
            }
            let lc = schema::locate::line_col(t, spans.value.1);
            Some(lsp::Position {
                line: lc.line as u32 - 1,
                character: lc.column as u32 - 1,
            })
        })
        .unwrap_or(lsp::Position {
            line: start.line,
            character: start.character + 1,
        });
    lsp::Range { start, end }
}

/// The byte offset of an LSP position (lines, then characters; lumo's columns count
/// characters too).
fn offset_of(text: &str, at: lsp::Position) -> Option<usize> {
    let mut offset = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        if i == at.line as usize {
            let within = line
                .char_indices()
                .nth(at.character as usize)
                .map_or(line.trim_end_matches('\n').len(), |(b, _)| b);
            return Some(offset + within);
        }
        offset += line.len();
    }
    (at.line as usize == text.split_inclusive('\n').count()).then_some(text.len())
}

/// When `offset` is inside the string value of a `"material"` or `"texture"` member: the map
/// its names are defined in and the name written so far (the whole string).
fn reference_at(text: &str, offset: usize) -> Option<(&'static str, String)> {
    let before = text.get(..offset)?;
    let quote = before.rfind('"')?;
    // The string must not be closed before the cursor.
    if before[quote + 1..].contains(['"', '\n']) {
        return None;
    }
    let key_part = before[..quote].trim_end().strip_suffix(':')?.trim_end();
    let map = if key_part.ends_with("\"material\"") {
        "materials"
    } else if key_part.ends_with("\"texture\"") {
        "textures"
    } else {
        return None;
    };
    let rest = &text[quote + 1..];
    let name = rest.split(['"', '\n']).next().unwrap_or_default();
    Some((map, name.to_string()))
}

/// The JSON path of the member name at `offset` (hovering `"roughness"` in a material gives
/// `materials.red.roughness`), read with a small scanner that tolerates text after `offset`.
fn path_at(text: &str, offset: usize) -> Option<JsonPath> {
    enum Frame {
        Object(Option<String>),
        Array(usize),
    }
    let bytes = text.as_bytes();
    let mut stack: Vec<Frame> = Vec::new();
    let mut i = 0;
    let mut expecting_key = false;
    while i < bytes.len() {
        match bytes[i] {
            b'{' => {
                stack.push(Frame::Object(None));
                expecting_key = true;
            }
            b'[' => {
                stack.push(Frame::Array(0));
                expecting_key = false;
            }
            b'}' | b']' => {
                stack.pop();
                expecting_key = false;
            }
            b',' => match stack.last_mut() {
                Some(Frame::Array(n)) => *n += 1,
                Some(Frame::Object(_)) => expecting_key = true,
                None => {}
            },
            b':' => expecting_key = false,
            b'"' => {
                let start = i;
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' {
                    if bytes[i] == b'\\' {
                        i += 1;
                    }
                    i += 1;
                }
                let end = i.min(bytes.len());
                if expecting_key {
                    let key: String = serde_json::from_str(text.get(start..=end)?).ok()?;
                    if let Some(Frame::Object(k)) = stack.last_mut() {
                        *k = Some(key);
                    }
                    if (start..=end).contains(&offset) {
                        let segments = stack
                            .iter()
                            .filter_map(|f| match f {
                                Frame::Object(Some(k)) => Some(PathSegment::Key(k.clone())),
                                Frame::Object(None) => None,
                                Frame::Array(n) => Some(PathSegment::Index(*n)),
                            })
                            .collect();
                        return Some(JsonPath(segments));
                    }
                }
            }
            _ => {}
        }
        if i >= offset && !expecting_key {
            // Past the cursor and not on a member name.
            if i > offset {
                return None;
            }
        }
        i += 1;
    }
    None
}

/// The schema's description of the field at `path`.
fn describe(root: &Value, path: &JsonPath) -> Option<String> {
    let mut here = root;
    let mut description = None;
    for seg in &path.0 {
        let next = match seg {
            PathSegment::Key(k) => find_property(root, here, k, 0)?,
            PathSegment::Index(_) => {
                let s = resolve(root, here)?;
                s.get("items")?
            }
        };
        description = next
            .get("description")
            .or_else(|| resolve(root, next).and_then(|r| r.get("description")))
            .and_then(Value::as_str)
            .map(str::to_string);
        here = next;
    }
    description
}

/// Follows a `$ref` (into `$defs`).
fn resolve<'a>(root: &'a Value, schema: &'a Value) -> Option<&'a Value> {
    match schema.get("$ref").and_then(Value::as_str) {
        Some(r) => {
            let name = r.strip_prefix("#/$defs/")?;
            root.get("$defs")?.get(name)
        }
        None => Some(schema),
    }
}

/// The schema of member `key` of a value following `schema`: a property, a map's values, or
/// the same in one of its alternatives.
fn find_property<'a>(
    root: &'a Value,
    schema: &'a Value,
    key: &str,
    depth: usize,
) -> Option<&'a Value> {
    if depth > 8 {
        return None;
    }
    let s = resolve(root, schema)?;
    if let Some(p) = s.get("properties").and_then(|p| p.get(key)) {
        return Some(p);
    }
    for combinator in ["oneOf", "anyOf", "allOf"] {
        if let Some(Value::Array(options)) = s.get(combinator) {
            for o in options {
                if let Some(found) = find_property(root, o, key, depth + 1) {
                    return Some(found);
                }
            }
        }
    }
    s.get("additionalProperties").filter(|a| a.is_object())
}

/// The path of a `file:` URI.
fn uri_to_path(uri: &lsp::Uri) -> Option<PathBuf> {
    let rest = uri.as_str().strip_prefix("file://")?;
    let mut bytes = Vec::new();
    let raw = rest.as_bytes();
    let mut i = 0;
    while i < raw.len() {
        if raw[i] == b'%' && i + 2 < raw.len() {
            let hex = std::str::from_utf8(&raw[i + 1..i + 3]).ok()?;
            bytes.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            bytes.push(raw[i]);
            i += 1;
        }
    }
    Some(PathBuf::from(String::from_utf8(bytes).ok()?))
}

/// The `file:` URI of a path (made absolute).
fn path_to_uri(path: &Path) -> Option<lsp::Uri> {
    let absolute = std::path::absolute(path).ok()?;
    let mut text = String::from("file://");
    for b in absolute.to_str()?.bytes() {
        if b.is_ascii_alphanumeric() || b"/-_.~".contains(&b) {
            text.push(b as char);
        } else {
            text.push_str(&format!("%{b:02X}"));
        }
    }
    text.parse().ok()
}

/// Runs the server over standard input and output until the client exits.
pub fn run_stdio() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let (connection, io_threads) = Connection::stdio();
    serve(&connection)?;
    drop(connection);
    io_threads.join()?;
    Ok(())
}

/// Serves one client on `connection`: initialization, then messages until `exit`, checking
/// changed documents once they have been still for [`DEBOUNCE`].
pub fn serve(connection: &Connection) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let capabilities = serde_json::to_value(Server::capabilities())?;
    connection.initialize(capabilities)?;
    let mut server = Server::new();
    loop {
        let mut out = Vec::new();
        let message = match server.due() {
            Some(due) => {
                let wait = due.saturating_duration_since(Instant::now());
                match connection.receiver.recv_timeout(wait) {
                    Ok(m) => Some(m),
                    Err(crossbeam_channel::RecvTimeoutError::Timeout) => None,
                    Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
                }
            }
            None => match connection.receiver.recv() {
                Ok(m) => Some(m),
                Err(_) => break,
            },
        };
        let keep_going = match message {
            Some(m) => server.handle(m, &mut out),
            None => {
                server.check_now(&mut out);
                true
            }
        };
        for m in out {
            connection.sender.send(m)?;
        }
        if !keep_going {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_references_and_member_paths() {
        let text = "{\n  \"materials\": {\"red\": {\"roughness\": 0.5}},\n  \"objects\": [{\"sphere\": {\"material\": \"re";
        let at = text.len();
        assert_eq!(
            reference_at(text, at),
            Some(("materials", "re".to_string()))
        );
        let hover = text.find("roughness").unwrap() + 2;
        assert_eq!(
            path_at(text, hover).map(|p| p.to_string()),
            Some("materials.red.roughness".to_string())
        );
        let sphere = text.find("sphere").unwrap();
        assert_eq!(
            path_at(text, sphere).map(|p| p.to_string()),
            Some("objects[0].sphere".to_string())
        );
        let schema: Value = serde_json::from_str(&schema::json_schema()).unwrap();
        let doc = describe(&schema, &JsonPath::parse("materials.red.roughness")).unwrap();
        assert!(
            doc.contains("roughness") || doc.contains("Roughness"),
            "{doc}"
        );
        assert!(describe(&schema, &JsonPath::parse("objects[0].sphere.radius")).is_some());
    }

    #[test]
    fn uris_and_paths_round_trip() {
        let p = Path::new("/tmp/a b/ü.json");
        let uri = path_to_uri(p).unwrap();
        assert_eq!(uri.as_str(), "file:///tmp/a%20b/%C3%BC.json");
        assert_eq!(uri_to_path(&uri).unwrap(), p);
    }
}
