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
//! Only lumo's files are diagnosed: a document whose `"$schema"` names `scene.schema.json` or
//! `scene-fragment.schema.json` (in any folder or at any address), or, without a `"$schema"`,
//! one with a top-level `"format_version"` (see [`is_lumo_text`]). Other JSON files
//! (`package.json`, …) get nothing from this server.
//!
//! Positions count UTF-16 code units, as the protocol has it by default; a client that offers
//! `utf-8` or `utf-32` (`general.positionEncodings`) gets the first of those it lists
//! ([`Encoding`]). lumo's own columns count characters and are converted.
//!
//! Messages are framed by [`framing`] (bounded: a message longer than 64 MiB is skipped and
//! reported, a malformed header ends the session with an error on standard error).
//!
//! [`Server`] holds the state and handles one message at a time without doing I/O on the
//! connection, so the protocol logic is tested (and fuzzed) without a process; [`run_stdio`]
//! connects it to standard input and output.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub mod framing;

use lsp_server::{Connection, Message, Notification, Request, Response};
use lsp_types as lsp;
use lumo_schema as schema;
use lumo_schema::locate::{JsonPath, PathSegment};
use serde_json::Value;

/// How long the server waits after the last change before checking the documents again.
pub const DEBOUNCE: Duration = Duration::from_millis(150);

/// How the client counts the characters of a line in a position.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Encoding {
    /// UTF-8 code units (bytes).
    Utf8,
    /// UTF-16 code units, the protocol's default.
    #[default]
    Utf16,
    /// Unicode scalar values (characters).
    Utf32,
}

impl Encoding {
    /// The encoding the server uses with a client whose `initialize` parameters are `params`:
    /// the first of the client's `general.positionEncodings` that is known, else UTF-16.
    pub fn negotiate(params: &Value) -> Encoding {
        params
            .pointer("/capabilities/general/positionEncodings")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
            .find_map(|e| match e.as_str()? {
                "utf-8" => Some(Encoding::Utf8),
                "utf-16" => Some(Encoding::Utf16),
                "utf-32" => Some(Encoding::Utf32),
                _ => None,
            })
            .unwrap_or_default()
    }

    fn kind(self) -> lsp::PositionEncodingKind {
        match self {
            Encoding::Utf8 => lsp::PositionEncodingKind::UTF8,
            Encoding::Utf16 => lsp::PositionEncodingKind::UTF16,
            Encoding::Utf32 => lsp::PositionEncodingKind::UTF32,
        }
    }

    fn units(self, c: char) -> usize {
        match self {
            Encoding::Utf8 => c.len_utf8(),
            Encoding::Utf16 => c.len_utf16(),
            Encoding::Utf32 => 1,
        }
    }
}

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
    /// How positions count characters.
    encoding: Encoding,
}

impl Server {
    /// A server with no open documents, counting positions in UTF-16.
    pub fn new() -> Server {
        Server::default()
    }

    /// A server with no open documents, counting positions in `encoding`.
    pub fn with_encoding(encoding: Encoding) -> Server {
        Server {
            encoding,
            ..Server::default()
        }
    }

    /// What the server can do, for the `initialize` response.
    pub fn capabilities(&self) -> lsp::ServerCapabilities {
        lsp::ServerCapabilities {
            position_encoding: Some(self.encoding.kind()),
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
            let by_uri = if is_lumo_text(&doc.text, doc.last_json.as_deref()) {
                diagnostics(doc, &uri, &unsaved, self.encoding)
            } else {
                // Not a lumo file: nothing of its own, and what it published as one cleared.
                BTreeMap::new()
            };
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

    /// An open document that is a lumo scene or fragment.
    fn document(&self, uri: &lsp::Uri) -> Option<&Document> {
        self.documents
            .get(uri.as_str())
            .filter(|d| is_lumo_text(&d.text, d.last_json.as_deref()))
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
                        let p = position_at(&text, start, self.encoding);
                        Some((file, p.line, p.character))
                    });
                (name.clone(), at)
            })
            .collect()
    }

    fn completion(&self, at: &lsp::TextDocumentPositionParams) -> Option<lsp::CompletionResponse> {
        let doc = self.document(&at.text_document.uri)?;
        let offset = offset_of(&doc.text, at.position, self.encoding)?;
        let Some((map, _)) = reference_at(&doc.text, offset) else {
            return match context_at(&doc.text, offset)? {
                Context::Key { object, quoted } => keywords(scene_schema()?, &object, quoted),
                Context::StringValue { .. } => None,
            };
        };
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
        let offset = offset_of(&doc.text, at.position, self.encoding)?;
        let Some((map, name)) = reference_at(&doc.text, offset) else {
            return file_at(doc, offset);
        };
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
        let offset = offset_of(&doc.text, at.position, self.encoding)?;
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

/// Where a string that names a file (an include, a texture's or mesh's file, the background
/// image, the `$schema`) leads: the start of that file, when it exists. Paths are relative to
/// the document's folder, as lumo reads them.
fn file_at(doc: &Document, offset: usize) -> Option<lsp::GotoDefinitionResponse> {
    let Context::StringValue { path, value } = context_at(&doc.text, offset)? else {
        return None;
    };
    if !names_a_file(&path) || value.is_empty() {
        return None;
    }
    let file = schema::base_dir_of(&doc.path).join(&value);
    if !file.is_file() {
        return None;
    }
    Some(lsp::GotoDefinitionResponse::Scalar(lsp::Location {
        uri: path_to_uri(&file)?,
        range: lsp::Range::default(),
    }))
}

/// Whether the string at `path` names a file: `include[i]`, `$schema`, `background.image`, a
/// texture's `file`, a mesh's `obj` or its glTF `file`.
fn names_a_file(path: &JsonPath) -> bool {
    match path.0.as_slice() {
        [PathSegment::Key(k), PathSegment::Index(_)] if k == "include" => true,
        [PathSegment::Key(k)] if k == "$schema" => true,
        [PathSegment::Key(a), PathSegment::Key(b)] if a == "background" && b == "image" => true,
        [PathSegment::Key(t), PathSegment::Key(_), PathSegment::Key(f)] => {
            t == "textures" && f == "file"
        }
        [.., PathSegment::Key(k)] if k == "obj" => true,
        [.., PathSegment::Key(g), PathSegment::Key(f)] => g == "gltf" && f == "file",
        _ => false,
    }
}

/// The member names the schema allows in the object at `object`, each with its
/// documentation; written with their quotes unless the cursor is already inside them.
fn keywords(root: &Value, object: &JsonPath, quoted: bool) -> Option<lsp::CompletionResponse> {
    let mut here = root;
    for seg in &object.0 {
        here = match seg {
            PathSegment::Key(k) => find_property(root, here, k, 0)?,
            PathSegment::Index(_) => resolve(root, here)?.get("items")?,
        };
    }
    let mut found = BTreeMap::new();
    properties(root, here, 0, &mut found);
    let items = found
        .into_iter()
        .map(|(name, doc)| lsp::CompletionItem {
            insert_text: (!quoted).then(|| format!("\"{name}\"")),
            label: name,
            kind: Some(lsp::CompletionItemKind::PROPERTY),
            documentation: doc.map(|d| {
                lsp::Documentation::MarkupContent(lsp::MarkupContent {
                    kind: lsp::MarkupKind::Markdown,
                    value: d,
                })
            }),
            ..lsp::CompletionItem::default()
        })
        .collect();
    Some(lsp::CompletionResponse::Array(items))
}

/// The properties a schema (and each of its alternatives) names, with their descriptions.
fn properties(
    root: &Value,
    schema: &Value,
    depth: usize,
    out: &mut BTreeMap<String, Option<String>>,
) {
    if depth > 8 {
        return;
    }
    let Some(s) = resolve(root, schema) else {
        return;
    };
    if let Some(Value::Object(members)) = s.get("properties") {
        for (name, p) in members {
            let doc = p
                .get("description")
                .or_else(|| resolve(root, p).and_then(|r| r.get("description")))
                .and_then(Value::as_str)
                .map(str::to_string);
            out.entry(name.clone()).or_insert(doc);
        }
    }
    for combinator in ["oneOf", "anyOf", "allOf"] {
        if let Some(Value::Array(options)) = s.get(combinator) {
            for o in options {
                properties(root, o, depth + 1, out);
            }
        }
    }
}

/// What is at a byte offset of a JSON text.
#[derive(Debug, PartialEq)]
enum Context {
    /// A member name is expected (or being typed) in the object at `object`; `quoted` when
    /// the cursor is inside the name's quotes.
    Key { object: JsonPath, quoted: bool },
    /// The cursor is inside the string value at `path`, whose whole text is `value`.
    StringValue { path: JsonPath, value: String },
}

/// What is at `offset`, read with a small scanner that tolerates broken text after it.
fn context_at(text: &str, offset: usize) -> Option<Context> {
    enum Frame {
        Object(Option<String>),
        Array(usize),
    }
    fn path_of(stack: &[Frame]) -> JsonPath {
        JsonPath(
            stack
                .iter()
                .filter_map(|f| match f {
                    Frame::Object(Some(k)) => Some(PathSegment::Key(k.clone())),
                    Frame::Object(None) => None,
                    Frame::Array(n) => Some(PathSegment::Index(*n)),
                })
                .collect(),
        )
    }
    let bytes = text.as_bytes();
    let offset = offset.min(bytes.len());
    let mut stack: Vec<Frame> = Vec::new();
    let mut expecting_key = false;
    // A member name was read and its `:` has not come yet.
    let mut named = false;
    let mut i = 0;
    while i < offset {
        match bytes[i] {
            b'{' => {
                stack.push(Frame::Object(None));
                expecting_key = true;
                named = false;
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
                Some(Frame::Object(_)) => {
                    expecting_key = true;
                    named = false;
                }
                None => {}
            },
            b':' => expecting_key = false,
            b'"' => {
                let start = i;
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' && bytes[i] != b'\n' {
                    if bytes[i] == b'\\' {
                        i += 1;
                    }
                    i += 1;
                }
                let end = i.min(bytes.len());
                let raw = text.get(start + 1..end).unwrap_or_default();
                let string = serde_json::from_str::<String>(&format!("\"{raw}\""))
                    .unwrap_or_else(|_| raw.to_string());
                if offset <= end {
                    let n = stack.len().saturating_sub(1);
                    return Some(if expecting_key {
                        Context::Key {
                            object: path_of(&stack[..n]),
                            quoted: true,
                        }
                    } else {
                        Context::StringValue {
                            path: path_of(&stack),
                            value: string,
                        }
                    });
                }
                if expecting_key {
                    if let Some(Frame::Object(k)) = stack.last_mut() {
                        *k = Some(string);
                    }
                    named = true;
                }
            }
            _ => {}
        }
        i += 1;
    }
    match stack.last() {
        Some(Frame::Object(_)) if expecting_key && !named => Some(Context::Key {
            object: path_of(&stack[..stack.len() - 1]),
            quoted: false,
        }),
        _ => None,
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
    encoding: Encoding,
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
        let range = range_of(text.as_deref(), &d, encoding);
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
                let p = position_of(Some(&doc.text), *at, encoding);
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
fn range_of(text: Option<&str>, d: &schema::Diagnostic, encoding: Encoding) -> lsp::Range {
    let Some(at) = d.location else {
        return lsp::Range::default();
    };
    let start = position_of(text, at, encoding);
    let end = text
        .and_then(|t| {
            let spans = schema::locate::spans(t, &d.path)?;
            let begin = schema::locate::line_col(t, spans.value.0);
            // Only when the path's value is where the diagnostic is.
            if begin != at {
                return None;
            }
            Some(position_at(t, spans.value.1, encoding))
        })
        .unwrap_or(lsp::Position {
            line: start.line,
            character: start.character + 1,
        });
    lsp::Range { start, end }
}

/// The byte offset of an LSP position (a line, then code units of `encoding` within it; a
/// position inside a character or past the line's end is taken to that character's start or
/// the line's end).
fn offset_of(text: &str, at: lsp::Position, encoding: Encoding) -> Option<usize> {
    let mut offset = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        if i == at.line as usize {
            let content = line.trim_end_matches('\n').trim_end_matches('\r');
            let mut units = 0;
            for (b, c) in content.char_indices() {
                let next = units + encoding.units(c);
                if next > at.character as usize {
                    return Some(offset + b);
                }
                units = next;
            }
            return Some(offset + content.len());
        }
        offset += line.len();
    }
    (at.line as usize == text.split_inclusive('\n').count()).then_some(text.len())
}

/// The LSP position of a byte offset.
fn position_at(text: &str, offset: usize, encoding: Encoding) -> lsp::Position {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    lsp::Position {
        line: before.matches('\n').count() as u32,
        character: before[line_start..]
            .chars()
            .map(|c| encoding.units(c))
            .sum::<usize>() as u32,
    }
}

/// The LSP position of one of lumo's locations (line and column from 1, the column counting
/// characters) in `text`; without the text, characters are taken as code units.
fn position_of(
    text: Option<&str>,
    at: schema::locate::LineCol,
    encoding: Encoding,
) -> lsp::Position {
    let line = at.line.saturating_sub(1);
    let column = at.column.saturating_sub(1);
    let fallback = lsp::Position {
        line: line as u32,
        character: column as u32,
    };
    let Some(text) = text else {
        return fallback;
    };
    let Some(content) = text.split('\n').nth(line) else {
        return fallback;
    };
    lsp::Position {
        line: line as u32,
        character: content
            .chars()
            .take(column)
            .map(|c| encoding.units(c))
            .sum::<usize>() as u32
            + column.saturating_sub(content.chars().count()) as u32,
    }
}

/// Whether a document is lumo's: its `"$schema"` names `scene.schema.json` or
/// `scene-fragment.schema.json` (in any folder or at any address), or it has no `"$schema"`
/// and a top-level `"format_version"`. `last_json` is the document's last text that was JSON,
/// asked when `text` is not; a text that never was JSON is searched for a `"$schema"` member.
pub fn is_lumo_text(text: &str, last_json: Option<&str>) -> bool {
    #[derive(serde::Deserialize)]
    struct Top {
        #[serde(rename = "$schema")]
        schema: Option<Value>,
        format_version: Option<Value>,
    }
    let names_lumo = |s: &str| {
        let s = s.split(['#', '?']).next().unwrap_or_default();
        let file = s.rsplit(['/', '\\']).next().unwrap_or_default();
        file == "scene.schema.json" || file == schema::include::FRAGMENT_SCHEMA
    };
    let parsed = serde_json::from_str::<Top>(text)
        .ok()
        .or_else(|| serde_json::from_str::<Top>(last_json?).ok());
    if let Some(top) = parsed {
        return match top.schema {
            Some(s) => s.as_str().is_some_and(names_lumo),
            None => top.format_version.is_some(),
        };
    }
    // Not JSON yet: the value of the first `"$schema"` member, read as far as it goes.
    let Some(at) = text.find("\"$schema\"") else {
        return text.contains("\"format_version\"");
    };
    let rest = text[at + 9..].trim_start();
    let Some(rest) = rest.strip_prefix(':') else {
        return false;
    };
    let Some(value) = rest.trim_start().strip_prefix('"') else {
        return false;
    };
    names_lumo(value.split(['"', '\n']).next().unwrap_or_default())
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

/// Runs the server over standard input and output until the client exits. Messages are read
/// by [`framing::read_message`]: one that is skipped is reported on standard error and the
/// session goes on; input that cannot be read further ends it with that error.
pub fn run_stdio() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let (to_server, from_client) = crossbeam_channel::bounded::<Message>(0);
    let (to_client, from_server) = crossbeam_channel::bounded::<Message>(0);
    // Why the input could not be read further: set before the reader drops its channel, so
    // the server, seeing the channel closed, finds it here.
    let failed = std::sync::Arc::new(std::sync::Mutex::new(None::<framing::ReadError>));
    let failure = std::sync::Arc::clone(&failed);
    std::thread::Builder::new()
        .name("lumo-lsp-reader".into())
        .spawn(move || {
            let stdin = std::io::stdin();
            let mut input = stdin.lock();
            loop {
                match framing::read_message(&mut input) {
                    Ok(Some(message)) => {
                        let exit =
                            matches!(&message, Message::Notification(n) if n.method == "exit");
                        if to_server.send(message).is_err() || exit {
                            return;
                        }
                    }
                    Ok(None) => return,
                    Err(e @ framing::ReadError::Skipped(_)) => eprintln!("lumo lsp: {e}"),
                    Err(e) => {
                        if let Ok(mut slot) = failure.lock() {
                            *slot = Some(e);
                        }
                        return;
                    }
                }
            }
        })?;
    let writer = std::thread::Builder::new()
        .name("lumo-lsp-writer".into())
        .spawn(move || -> std::io::Result<()> {
            let stdout = std::io::stdout();
            let mut output = stdout.lock();
            for message in from_server {
                message.write(&mut output)?;
            }
            Ok(())
        })?;
    let connection = Connection {
        sender: to_client,
        receiver: from_client,
    };
    let served = serve(&connection);
    drop(connection);
    let written = writer.join();
    // The reader's error explains a session that ended early. A reader still waiting for
    // input (the session ended on a protocol error) ends with the process.
    if let Some(e) = failed.lock().ok().and_then(|mut slot| slot.take()) {
        return Err(e.into());
    }
    served?;
    match written {
        Ok(result) => result?,
        Err(_) => return Err("the message writer stopped unexpectedly".into()),
    }
    Ok(())
}

/// Serves one client on `connection`: initialization, then messages until `exit`, checking
/// changed documents once they have been still for [`DEBOUNCE`].
pub fn serve(connection: &Connection) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let (id, params) = connection.initialize_start()?;
    let mut server = Server::with_encoding(Encoding::negotiate(&params));
    let result = serde_json::json!({
        "capabilities": server.capabilities(),
        "serverInfo": {"name": "lumo", "version": env!("CARGO_PKG_VERSION")},
    });
    connection.initialize_finish(id, result)?;
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
    fn positions_count_code_units_of_the_negotiated_encoding() {
        let text = "{\"🎨 é\": 1,\n \"x\": \"é🎨\"}";
        // The `1` on the first line: after 1 + 1 + 2 + 1 + 1 + 1 + 2 bytes' worth of text.
        let one = text.find('1').unwrap();
        let at = |e| position_at(text, one, e);
        assert_eq!(at(Encoding::Utf8).character, 12);
        assert_eq!(at(Encoding::Utf16).character, 9);
        assert_eq!(at(Encoding::Utf32).character, 8);
        for e in [Encoding::Utf8, Encoding::Utf16, Encoding::Utf32] {
            assert_eq!(offset_of(text, at(e), e), Some(one), "{e:?}");
            // lumo's line and column (characters) land on the same place.
            let lc = schema::locate::line_col(text, one);
            assert_eq!(position_of(Some(text), lc, e), at(e), "{e:?}");
        }
        // Inside the emoji's UTF-16 pair: its start.
        let inside = lsp::Position {
            line: 0,
            character: 3,
        };
        assert_eq!(offset_of(text, inside, Encoding::Utf16), Some(2));
        // Past a line's end: the end of that line.
        let past = lsp::Position {
            line: 1,
            character: 99,
        };
        assert_eq!(offset_of(text, past, Encoding::Utf16), Some(text.len()));
        let offered = serde_json::json!({"capabilities": {"general": {"positionEncodings": ["utf-32", "utf-8"]}}});
        assert_eq!(Encoding::negotiate(&offered), Encoding::Utf32);
        assert_eq!(Encoding::negotiate(&serde_json::json!({})), Encoding::Utf16);
    }

    #[test]
    fn only_lumo_files_are_lumo_files() {
        for (text, lumo) in [
            (
                r#"{"$schema": "../schema/scene.schema.json", "objects": []}"#,
                true,
            ),
            (
                r#"{"$schema": "https://example.org/x/scene-fragment.schema.json"}"#,
                true,
            ),
            (r#"{"format_version": 2}"#, true),
            (r#"{"$schema": "scene.schema.json", "objects": [{"#, true),
            (r#"{"name": "demo", "version": "1.0.0"}"#, false),
            (
                r#"{"$schema": "https://json.schemastore.org/package.json"}"#,
                false,
            ),
            (r#"{"$schema": "not-a-scene.schema.json.bak"}"#, false),
            (r#"{"name": "x", "#, false),
        ] {
            assert_eq!(is_lumo_text(text, None), lumo, "{text}");
        }
        // A broken text is judged by its last JSON.
        assert!(is_lumo_text("{", Some(r#"{"format_version": 2}"#)));
    }

    #[test]
    fn contexts_for_member_names_and_file_paths() {
        let text =
            r#"{"include": ["lib/a.json"], "objects": [{"sphere": {"center": [0, 0, 0], "ra"#;
        assert_eq!(
            context_at(text, text.len()),
            Some(Context::Key {
                object: JsonPath::parse("objects[0].sphere"),
                quoted: true
            })
        );
        let after_comma = text.find(r#", "ra"#).unwrap() + 2;
        assert!(matches!(
            context_at(text, after_comma),
            Some(Context::Key { quoted: false, .. })
        ));
        let include = text.find("lib/").unwrap() + 2;
        let Some(Context::StringValue { path, value }) = context_at(text, include) else {
            panic!("a string value");
        };
        assert_eq!(
            (path.to_string().as_str(), value.as_str()),
            ("include[0]", "lib/a.json")
        );
        assert!(names_a_file(&path));
        assert!(names_a_file(&JsonPath::parse("objects[3].mesh.source.obj")));
        assert!(names_a_file(&JsonPath::parse("textures.wood.file")));
        assert!(!names_a_file(&JsonPath::parse("materials.red.name")));
        // Right after a member name, before its `:`, nothing is offered.
        let named = text.find(r#""include""#).unwrap() + 9;
        assert_eq!(context_at(text, named), None);
        let schema: Value = serde_json::from_str(&schema::json_schema()).unwrap();
        let Some(lsp::CompletionResponse::Array(items)) =
            keywords(&schema, &JsonPath::parse("objects[0].sphere"), true)
        else {
            panic!("completion items");
        };
        let names: Vec<&str> = items.iter().map(|i| i.label.as_str()).collect();
        assert!(
            names.contains(&"radius") && !names.contains(&"base_color"),
            "{names:?}"
        );
    }

    #[test]
    fn uris_and_paths_round_trip() {
        let p = Path::new("/tmp/a b/ü.json");
        let uri = path_to_uri(p).unwrap();
        assert_eq!(uri.as_str(), "file:///tmp/a%20b/%C3%BC.json");
        assert_eq!(uri_to_path(&uri).unwrap(), p);
    }
}
