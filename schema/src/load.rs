//! Reading a scene file: syntax and type errors with their location, then the semantic checks.

use std::path::{Path, PathBuf};

use crate::diagnostic::{did_you_mean, Diagnostic, LoadError};
use crate::locate::{line_col, locate, JsonPath};
use crate::scene::Scene;
use crate::validated::Validated;

/// Largest scene file accepted, in bytes (1 GiB); larger inputs are refused before parsing.
pub const MAX_SCENE_BYTES: u64 = 1 << 30;

/// Parses scene JSON text into a typed [`Scene`] without semantic checks. On failure the single
/// diagnostic names the JSON path, the line and column, and what was expected. A file of an
/// older format version is migrated (see [`parse_scene_noted`] for the notes).
pub fn parse_scene(text: &str) -> Result<Scene, Diagnostic> {
    parse_scene_noted(text).map(|(scene, _)| scene)
}

/// [`parse_scene`], also returning the migration notes of a file of an older format version
/// (empty for a current file).
pub fn parse_scene_noted(text: &str) -> Result<(Scene, Vec<String>), Diagnostic> {
    parse_first(text).map_err(|f| f.diagnostic)
}

/// Why [`parse_first`] stopped.
struct FirstProblem {
    /// The problem, located.
    diagnostic: Diagnostic,
    /// The text is not JSON (nothing more can be read from it).
    syntax: bool,
    /// The tree the problem was found in, when it is not the text's own: the migrated tree of
    /// an older format version, with its notes.
    migrated: Option<(serde_json::Value, Vec<String>)>,
}

/// Reads the scene, stopping at the first problem.
fn parse_first(text: &str) -> Result<(Scene, Vec<String>), Box<FirstProblem>> {
    /// Only the version, read without building the document.
    #[derive(serde::Deserialize)]
    struct Version {
        format_version: Option<serde_json::Value>,
    }
    let old = serde_json::from_str::<Version>(text)
        .ok()
        .and_then(|v| v.format_version)
        .and_then(|v| v.as_u64())
        .is_some_and(|v| v < u64::from(crate::FORMAT_VERSION));
    if old {
        if let Ok(mut value) = serde_json::from_str::<serde_json::Value>(text) {
            let notes = crate::migrate::migrate(&mut value);
            let result: Result<Scene, _> = serde_path_to_error::deserialize(&value);
            return match result {
                Ok(scene) => Ok((scene, notes)),
                Err(err) => {
                    let path = JsonPath::parse(&err.path().to_string());
                    let (message, help) = explain(&err.into_inner().to_string());
                    let mut d = Diagnostic::new(path.clone(), message);
                    d.location = locate(text, &path);
                    d.help = help;
                    Err(Box::new(FirstProblem {
                        diagnostic: d,
                        syntax: false,
                        migrated: Some((value, notes)),
                    }))
                }
            };
        }
    }
    let mut de = serde_json::Deserializer::from_str(text);
    let result: Result<Scene, _> = serde_path_to_error::deserialize(&mut de);
    let (path, inner) = match result {
        Ok(scene) => match de.end() {
            Ok(()) => return Ok((scene, Vec::new())),
            // Trailing characters after the document.
            Err(e) => (JsonPath::root(), e),
        },
        Err(err) => (JsonPath::parse(&err.path().to_string()), err.into_inner()),
    };
    let syntax = !matches!(inner.classify(), serde_json::error::Category::Data);
    Err(Box::new(FirstProblem {
        diagnostic: serde_json_diagnostic(text, path, &inner),
        syntax,
        migrated: None,
    }))
}

/// A diagnostic from a serde_json error at `path`, located where serde_json stopped.
fn serde_json_diagnostic(text: &str, path: JsonPath, inner: &serde_json::Error) -> Diagnostic {
    let (message, help) = explain(&inner.to_string());
    let location = if inner.line() > 0 {
        // serde_json counts the columns consumed, 0 right after a line break.
        Some(crate::locate::LineCol {
            line: inner.line(),
            column: inner.column().max(1),
        })
    } else {
        locate(text, &path)
    };
    let mut d = Diagnostic::new(path, message);
    d.location = location;
    d.help = help;
    d
}

/// Every problem of a scene text whose streaming read stopped at `first`: the other problems
/// serde finds (see [`crate::tolerant`]), then the semantic findings on the parts that read.
fn every_problem(text: &str, first: FirstProblem, base_dir: Option<&Path>) -> Vec<Diagnostic> {
    if first.syntax {
        return vec![first.diagnostic];
    }
    let (value, exact) = match first.migrated {
        Some((value, _)) => (value, false),
        None => match serde_json::from_str::<serde_json::Value>(text) {
            Ok(value) => (value, true),
            // A type problem before a syntax error: both are reported, nothing more is read.
            Err(e) => {
                let mut out = vec![first.diagnostic];
                let syntax = serde_json_diagnostic(text, JsonPath::root(), &e);
                if out[0] != syntax {
                    out.push(syntax);
                }
                return out;
            }
        },
    };
    let read = crate::tolerant::read_all(text, value, Some(first.diagnostic), exact);
    let mut problems = read.problems;
    if let Some(scene) = read.scene {
        for mut d in crate::validate::validate(&scene, base_dir) {
            if read.repairs.is_sound(&d.path) {
                d.location = locate(text, &d.path);
                problems.push(d);
            }
        }
    }
    problems.sort_by_key(|d| d.location.map(|l| (l.line, l.column)));
    problems
}

/// Parses and validates scene text. `base_dir` is where relative file paths resolve (the scene
/// file's folder); `None` skips file-existence checks. `file` labels the diagnostics.
pub fn load_scene_str(
    text: &str,
    file: &Path,
    base_dir: Option<&Path>,
) -> Result<Validated<Scene>, LoadError> {
    load_scene_str_noted(text, file, base_dir).map(|(scene, _)| scene)
}

/// [`load_scene_str`], also returning the migration notes of an older format version.
pub fn load_scene_str_noted(
    text: &str,
    file: &Path,
    base_dir: Option<&Path>,
) -> Result<(Validated<Scene>, Vec<String>), LoadError> {
    if let Some(base) = base_dir.filter(|_| crate::include::has_includes(text)) {
        return load_composed(text, file, base).map(|(scene, notes, _)| (scene, notes));
    }
    let invalid = |diagnostics| LoadError::Invalid {
        file: file.to_path_buf(),
        diagnostics,
    };
    let (scene, notes) = match parse_first(text) {
        Ok(read) => read,
        Err(first) => return Err(invalid(every_problem(text, *first, base_dir))),
    };
    let mut diagnostics = match Validated::new(scene, base_dir) {
        Ok(valid) => return Ok((valid, notes)),
        Err(diagnostics) => diagnostics,
    };
    for d in &mut diagnostics {
        d.location = locate(text, &d.path);
    }
    diagnostics.sort_by_key(|d| d.location.map(|l| (l.line, l.column)));
    Err(invalid(diagnostics))
}

/// A scene that includes fragments ([`crate::include`]): the fragments read and merged, then
/// the composed scene read and validated, every problem placed in the file that wrote it. Also
/// returns the fragments read.
fn load_composed(text: &str, file: &Path, base_dir: &Path) -> Result<SceneRead, LoadError> {
    let invalid = |diagnostics| LoadError::Invalid {
        file: file.to_path_buf(),
        diagnostics,
    };
    let value = serde_json::from_str(text)
        .map_err(|e| invalid(vec![serde_json_diagnostic(text, JsonPath::root(), &e)]))?;
    let composed = crate::include::compose(file, text, value, base_dir).map_err(invalid)?;
    let composed_text = composed.value.to_string();
    match load_scene_str_noted(&composed_text, file, Some(base_dir)) {
        Ok((scene, notes)) => Ok((scene, notes, composed.fragments)),
        Err(LoadError::Invalid { diagnostics, .. }) => Err(invalid(
            diagnostics.into_iter().map(|d| composed.place(d)).collect(),
        )),
        Err(e) => Err(e),
    }
}

/// Checks a scene fragment on its own (a file a scene includes, see [`crate::include`]): every
/// problem a scene including it would find in it (its includes, types, ranges, files), except
/// references to materials and textures, which other files may define. Returns the fragments
/// it includes.
pub fn check_fragment_file(path: &Path) -> Result<Vec<PathBuf>, LoadError> {
    let text = read_scene_text(path)?;
    check_fragment_str(&text, path)
}

/// Reads and validates scene text at `path` (an editor's unsaved buffer), with its includes
/// read from `unsaved` (by canonical path) or from disk.
pub fn load_scene_with(
    text: &str,
    path: &Path,
    unsaved: &std::collections::BTreeMap<PathBuf, String>,
) -> Result<Validated<Scene>, LoadError> {
    let base = base_dir_of(path);
    if !crate::include::has_includes(text) {
        return load_scene_str(text, path, Some(&base));
    }
    let invalid = |diagnostics| LoadError::Invalid {
        file: path.to_path_buf(),
        diagnostics,
    };
    let value = serde_json::from_str(text)
        .map_err(|e| invalid(vec![serde_json_diagnostic(text, JsonPath::root(), &e)]))?;
    let composed =
        crate::include::compose_with(path, text, value, &base, unsaved).map_err(invalid)?;
    match load_scene_str_noted(&composed.value.to_string(), path, Some(&base)) {
        Ok((scene, _)) => Ok(scene),
        Err(LoadError::Invalid { diagnostics, .. }) => Err(invalid(
            diagnostics.into_iter().map(|d| composed.place(d)).collect(),
        )),
        Err(e) => Err(e),
    }
}

/// [`check_fragment_file`] of a fragment's text (an editor's unsaved buffer); `path` is where
/// the file is, which its relative paths resolve against.
pub fn check_fragment_str(text: &str, path: &Path) -> Result<Vec<PathBuf>, LoadError> {
    check_fragment_with(text, path, &std::collections::BTreeMap::new())
}

/// [`check_fragment_str`], reading the files in `unsaved` (by canonical path) from there: an
/// editor's buffers.
pub fn check_fragment_with(
    text: &str,
    path: &Path,
    unsaved: &std::collections::BTreeMap<PathBuf, String>,
) -> Result<Vec<PathBuf>, LoadError> {
    let text = text.to_string();
    let invalid = |diagnostics| LoadError::Invalid {
        file: path.to_path_buf(),
        diagnostics,
    };
    let value: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| invalid(vec![serde_json_diagnostic(&text, JsonPath::root(), &e)]))?;
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return Err(invalid(vec![Diagnostic::new(
            JsonPath::root(),
            "not a file name",
        )]));
    };
    // A scene that includes the fragment and has what every scene needs (only where the
    // fragment does not give it, so that the fragment's own is checked).
    let mut host = serde_json::json!({
        "format_version": crate::FORMAT_VERSION,
        crate::include::INCLUDE: [name],
    });
    for (key, stand_in) in [
        (
            "camera",
            serde_json::json!({"position": [0, 0, 1], "look_at": [0, 0, 0], "fov_y_deg": 40}),
        ),
        ("materials", serde_json::json!({})),
        ("objects", serde_json::json!([])),
    ] {
        if value.get(key).is_none() {
            host[key] = stand_in;
        }
    }
    let base = base_dir_of(path);
    let host_file = base.join(format!(".{name}.host"));
    // The fragment as given, not as saved.
    let mut unsaved = unsaved.clone();
    if let Ok(c) = std::fs::canonicalize(path) {
        unsaved.insert(c, text.clone());
    }
    // Problems in the fragment, without the stand-in scene that included it.
    let own = |mut d: Diagnostic| {
        if let Some(source) = &mut d.source {
            source.included_from.pop();
            if source.file == path && source.included_from.is_empty() {
                d.source = None;
            }
        }
        d
    };
    let host_text = host.to_string();
    let composed = crate::include::compose_with(&host_file, &host_text, host, &base, &unsaved)
        .map_err(|ds| invalid(ds.into_iter().map(own).collect()))?;
    let composed_text = composed.value.to_string();
    match load_scene_str_noted(&composed_text, &host_file, Some(&base)) {
        Ok(_) => Ok(composed.fragments[1..].to_vec()),
        Err(LoadError::Invalid { diagnostics, .. }) => {
            let problems: Vec<Diagnostic> = diagnostics
                .into_iter()
                .filter(|d| !crate::include::names_another_file(d))
                .map(|d| own(composed.place(d)))
                .collect();
            if problems.is_empty() {
                Ok(composed.fragments[1..].to_vec())
            } else {
                Err(invalid(problems))
            }
        }
        Err(e) => Err(e),
    }
}

/// [`load_scene_file_noted`], also returning the fragments the scene includes (every file read
/// besides the scene, before its assets).
pub fn load_scene_file_with_fragments(path: &Path) -> Result<SceneRead, LoadError> {
    let text = read_scene_text(path)?;
    let base = base_dir_of(path);
    if crate::include::has_includes(&text) {
        return load_composed(&text, path, &base);
    }
    load_scene_str_noted(&text, path, Some(&base)).map(|(s, n)| (s, n, Vec::new()))
}

/// A scene file read and validated: the scene, the migration notes of an older format version,
/// and the fragments it includes.
pub type SceneRead = (Validated<Scene>, Vec<String>, Vec<PathBuf>);

/// Reads, parses and validates a scene file; relative paths inside resolve against its folder.
pub fn load_scene_file(path: &Path) -> Result<Validated<Scene>, LoadError> {
    load_scene_file_noted(path).map(|(scene, _)| scene)
}

/// [`load_scene_file`], also returning the migration notes of an older format version.
pub fn load_scene_file_noted(path: &Path) -> Result<(Validated<Scene>, Vec<String>), LoadError> {
    load_scene_file_with_fragments(path).map(|(s, n, _)| (s, n))
}

/// The text of a scene file: an error for a file that cannot be read, is too large or is not
/// UTF-8.
fn read_scene_text(path: &Path) -> Result<String, LoadError> {
    let io = |source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.len() > MAX_SCENE_BYTES {
        return Err(LoadError::Invalid {
            file: path.to_path_buf(),
            diagnostics: vec![Diagnostic::new(
                JsonPath::root(),
                format!(
                    "file is {} bytes, above the limit of {MAX_SCENE_BYTES}",
                    meta.len()
                ),
            )
            .with_help("put large meshes in OBJ or glTF files and reference them")],
        });
    }
    let bytes = std::fs::read(path).map_err(io)?;
    let text = match String::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let text = String::from_utf8_lossy(e.as_bytes()).into_owned();
            let mut d = Diagnostic::new(JsonPath::root(), "file is not valid UTF-8");
            d.location = Some(line_col(&text, at));
            return Err(LoadError::Invalid {
                file: path.to_path_buf(),
                diagnostics: vec![d],
            });
        }
    };
    Ok(text)
}

/// The folder relative paths in the scene file at `path` resolve against.
pub fn base_dir_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Rewrites serde_json's messages into "expected X, found Y" form, with a suggestion for
/// misspelt keys.
pub(crate) fn explain(raw: &str) -> (String, Option<String>) {
    // serde_json appends " at line L column C"; the location is reported separately.
    let msg = match raw.rfind(" at line ") {
        Some(i) => &raw[..i],
        None => raw,
    };
    if let Some(rest) = msg.strip_prefix("invalid type: ") {
        if let Some((found, expected)) = rest.split_once(", expected ") {
            return (
                format!(
                    "expected {}, found {}",
                    plain_type(expected),
                    plain_found(found)
                ),
                None,
            );
        }
    }
    if let Some(rest) = msg.strip_prefix("unknown field `") {
        if let Some((field, expected)) = rest.split_once("`, expected ") {
            let candidates: Vec<&str> = expected
                .split('`')
                .enumerate()
                .filter(|(i, _)| i % 2 == 1)
                .map(|(_, s)| s)
                .collect();
            let help = match did_you_mean(field, candidates.iter().copied()) {
                Some(s) => format!("did you mean `{s}`?"),
                None => format!(
                    "expected one of {}",
                    candidates
                        .iter()
                        .map(|c| format!("`{c}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
            return (format!("unknown field `{field}`"), Some(help));
        }
        if let Some(field) = rest.strip_suffix("`, there are no fields") {
            return (
                format!("unknown field `{field}`"),
                Some("this object takes no fields".into()),
            );
        }
    }
    if let Some(rest) = msg.strip_prefix("unknown variant `") {
        if let Some((variant, expected)) = rest.split_once("`, expected ") {
            let candidates: Vec<&str> = expected
                .split('`')
                .enumerate()
                .filter(|(i, _)| i % 2 == 1)
                .map(|(_, s)| s)
                .collect();
            let help = did_you_mean(variant, candidates.iter().copied())
                .map(|s| format!("did you mean `{s}`?"));
            return (
                format!("unknown kind `{variant}`, expected {expected}"),
                help,
            );
        }
    }
    if msg.starts_with("data did not match any variant of untagged enum Scale") {
        return (
            "expected a number or an array of three numbers".into(),
            Some("a uniform scale is one number, a per-axis scale is [x, y, z]".into()),
        );
    }
    (msg.to_string(), None)
}

/// serde's description of a found value in JSON words (`map` → `an object`).
fn plain_found(found: &str) -> String {
    for (serde, json) in [
        ("string", "a string"),
        ("map", "an object"),
        ("sequence", "an array"),
        ("floating point", "the number"),
        ("integer", "the integer"),
        ("boolean", "the boolean"),
    ] {
        if let Some(rest) = found.strip_prefix(serde) {
            return format!("{json}{rest}");
        }
    }
    found.to_string()
}

/// serde's type names in words a scene author knows.
fn plain_type(expected: &str) -> String {
    match expected {
        "f32" | "f64" => "a number".into(),
        "u32" | "u64" | "usize" => "a non-negative integer".into(),
        "a string" => "a string".into(),
        e if e.starts_with("an array of length") => e.replace("an array of length", "an array of"),
        e => e.to_string(),
    }
}
