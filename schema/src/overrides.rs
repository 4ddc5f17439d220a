//! Overrides: changing one value of a scene by its JSON path, as lumo's diagnostics print it
//! (`materials.red.base_color`, `objects[2].sphere.radius`, `render.spp`).
//!
//! # Path grammar
//!
//! ```text
//! path    = segment ( "." key | "[" index "]" | "[" quoted "]" )*
//! segment = key | "[" index "]" | "[" quoted "]"
//! key     = one or more letters, digits, `_`, `$` or `-`
//! index   = decimal digits (an array element)
//! quoted  = a double-quoted string with JSON or Rust escapes (a member whose name has other
//!           characters: `textures["wood.png"]`)
//! ```
//!
//! This is exactly what [`JsonPath`]'s `Display` writes, so a path copied from a diagnostic
//! names the value the diagnostic is about. An assignment (`--set PATH=JSON`) is a path, `=`,
//! and a JSON value ([`parse_assignment`]).
//!
//! # Applying
//!
//! [`apply`] works on the scene as a [`serde_json::Value`]: every step but the last must name an
//! existing member or element; the last replaces an existing value or adds a member to an
//! object (a field left at its default is absent from the JSON, and a new material is a new
//! member). Whether the result is a scene at all (a field that does not exist, a value of the
//! wrong type) is then decided by reading it back ([`apply_to_scene`]), with the same messages
//! and suggestions as a scene file; checking it ([`crate::validate()`]) is the caller's next
//! step, as for any scene.

use serde_json::Value;

use crate::diagnostic::{did_you_mean, Diagnostic};
use crate::locate::{JsonPath, PathSegment};
use crate::scene::Scene;

/// Longest override path accepted, in bytes.
pub const MAX_PATH_LEN: usize = 4096;

/// One override: the value at `path` becomes `value`.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// Where, in the scene's JSON.
    pub path: JsonPath,
    /// The new value.
    pub value: Value,
}

impl Override {
    /// An override of the value at `path` (in the grammar of the module documentation).
    pub fn new(path: &str, value: Value) -> Result<Override, Diagnostic> {
        Ok(Override {
            path: parse_path(path)?,
            value,
        })
    }
}

/// Parses an override path (`materials.red.base_color`, `objects[2].sphere.radius`,
/// `textures["wood.png"].file`). The error names the character where the path goes wrong; its
/// diagnostic's path is the part read so far.
pub fn parse_path(text: &str) -> Result<JsonPath, Diagnostic> {
    parse_path_spanned(text)
        .map(|(path, _)| path)
        .map_err(|(d, _)| d)
}

/// [`parse_path`], also returning the byte offset where each segment starts (its name, or its
/// `[`), or on error the byte offset of the character the error names: what places a problem
/// in a command-line argument.
pub fn parse_path_spanned(text: &str) -> Result<(JsonPath, Vec<usize>), (Diagnostic, usize)> {
    let mut segments = Vec::new();
    let mut starts = Vec::new();
    let fail = |segments: &Vec<PathSegment>, at: usize, what: &str| {
        let column = text[..at].chars().count() + 1;
        let d = Diagnostic::new(
            JsonPath(segments.clone()),
            format!("cannot read the override path `{text}` at character {column}: {what}"),
        )
        .with_help(
            "write a path as lumo's messages print it: `materials.red.base_color`, \
             `objects[2].sphere.radius`, `textures[\"a.b\"].file`",
        );
        (d, at)
    };
    if text.is_empty() {
        return Err(fail(&segments, 0, "the path is empty"));
    }
    if text.len() > MAX_PATH_LEN {
        return Err(fail(
            &segments,
            0,
            &format!("the path is longer than {MAX_PATH_LEN} bytes"),
        ));
    }
    let bytes = text.as_bytes();
    let mut pos = 0;
    while pos < bytes.len() {
        let first = segments.is_empty();
        match bytes[pos] {
            b'[' => {
                starts.push(pos);
                pos += 1;
                if bytes.get(pos) == Some(&b'"') {
                    let (key, end) =
                        quoted(text, pos).map_err(|(at, m)| fail(&segments, at, &m))?;
                    segments.push(PathSegment::Key(key));
                    pos = end;
                } else {
                    let start = pos;
                    while bytes.get(pos).is_some_and(u8::is_ascii_digit) {
                        pos += 1;
                    }
                    if start == pos {
                        return Err(fail(
                            &segments,
                            start,
                            "expected an index (`[2]`) or a quoted name (`[\"a.b\"]`) after `[`",
                        ));
                    }
                    let index = text[start..pos]
                        .parse::<usize>()
                        .map_err(|_| fail(&segments, start, "the index is too large"))?;
                    segments.push(PathSegment::Index(index));
                }
                if bytes.get(pos) != Some(&b']') {
                    return Err(fail(&segments, pos, "expected `]`"));
                }
                pos += 1;
            }
            b'.' if !first => {
                pos += 1;
                starts.push(pos);
                let (key, end) = plain_key(text, pos);
                if key.is_empty() {
                    return Err(fail(&segments, pos, "expected a member name after `.`"));
                }
                segments.push(PathSegment::Key(key.to_string()));
                pos = end;
            }
            _ if first => {
                starts.push(pos);
                let (key, end) = plain_key(text, pos);
                if key.is_empty() {
                    return Err(fail(&segments, pos, "expected a member name"));
                }
                segments.push(PathSegment::Key(key.to_string()));
                pos = end;
            }
            _ => {
                return Err(fail(
                    &segments,
                    pos,
                    "expected `.name`, `[index]` or `[\"name\"]`",
                ))
            }
        }
    }
    Ok((JsonPath(segments), starts))
}

/// Whether `c` may appear in a member name written without quotes (as [`JsonPath`] prints it).
fn plain_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_' || c == '$' || c == '-'
}

/// The plain member name starting at byte `pos`, and the byte after it.
fn plain_key(text: &str, pos: usize) -> (&str, usize) {
    let rest = &text[pos..];
    let len = rest
        .char_indices()
        .find(|&(_, c)| !plain_char(c))
        .map_or(rest.len(), |(i, _)| i);
    (&rest[..len], pos + len)
}

/// The double-quoted string starting at byte `pos` (its opening quote), unescaped, and the
/// byte after its closing quote. Takes JSON escapes and Rust's (`\u{…}`, `\0`, `\'`), since
/// [`JsonPath`] prints quoted names with Rust's.
fn quoted(text: &str, pos: usize) -> Result<(String, usize), (usize, String)> {
    let mut out = String::new();
    let mut chars = text[pos + 1..]
        .char_indices()
        .map(|(i, c)| (pos + 1 + i, c));
    let hex = |s: &str, at: usize| {
        u32::from_str_radix(s, 16).map_err(|_| (at, format!("`{s}` is not a hexadecimal number")))
    };
    while let Some((i, c)) = chars.next() {
        match c {
            '"' => return Ok((out, i + 1)),
            '\\' => {
                let Some((j, e)) = chars.next() else {
                    break;
                };
                match e {
                    '"' | '\\' | '/' | '\'' => out.push(e),
                    'n' => out.push('\n'),
                    'r' => out.push('\r'),
                    't' => out.push('\t'),
                    'b' => out.push('\u{8}'),
                    'f' => out.push('\u{c}'),
                    '0' => out.push('\0'),
                    'u' => {
                        let rest = &text[j + 1..];
                        let code = if let Some(braced) = rest.strip_prefix('{') {
                            let close = braced
                                .find('}')
                                .ok_or((j, "`\\u{` without its `}`".to_string()))?;
                            let code = hex(&braced[..close], j + 2)?;
                            for _ in 0..close + 2 {
                                chars.next();
                            }
                            code
                        } else {
                            let four = rest
                                .get(..4)
                                .ok_or((j, "`\\u` takes four hexadecimal digits".to_string()))?;
                            for _ in 0..4 {
                                chars.next();
                            }
                            let high = hex(four, j + 1)?;
                            if (0xD800..0xDC00).contains(&high) {
                                // A UTF-16 surrogate pair, as JSON writes characters past U+FFFF.
                                let low = text[j + 5..]
                                    .strip_prefix("\\u")
                                    .and_then(|r| r.get(..4))
                                    .and_then(|s| u32::from_str_radix(s, 16).ok())
                                    .filter(|l| (0xDC00..0xE000).contains(l))
                                    .ok_or((j, "an unpaired UTF-16 surrogate".to_string()))?;
                                for _ in 0..6 {
                                    chars.next();
                                }
                                0x10000 + ((high - 0xD800) << 10) + (low - 0xDC00)
                            } else {
                                high
                            }
                        };
                        out.push(
                            char::from_u32(code)
                                .ok_or((j, format!("U+{code:X} is not a character")))?,
                        );
                    }
                    other => return Err((j, format!("unknown escape `\\{other}`"))),
                }
            }
            c => out.push(c),
        }
    }
    Err((pos, "the quoted name has no closing `\"`".to_string()))
}

/// Parses `PATH=JSON` (the command line's `--set`): the path up to the first `=` outside a
/// quoted name, then a JSON value (`render.spp=64`, `materials.red.base_color=[0.8,0.1,0.1]`,
/// `camera.name="top"`).
pub fn parse_assignment(text: &str) -> Result<Override, Diagnostic> {
    parse_assignment_spanned(text)
        .map(|a| a.change)
        .map_err(|(d, _)| d)
}

/// An assignment read by [`parse_assignment_spanned`], with where its parts are in its text.
#[derive(Debug, Clone, PartialEq)]
pub struct SpannedAssignment {
    /// The override.
    pub change: Override,
    /// The byte offset where each segment of the path starts (see [`parse_path_spanned`]).
    pub segment_starts: Vec<usize>,
    /// The byte offset where the value starts (after the `=`).
    pub value_start: usize,
}

/// [`parse_assignment`], also returning where the path's segments and the value start, or on
/// error the byte offset of the character the error is about.
pub fn parse_assignment_spanned(text: &str) -> Result<SpannedAssignment, (Diagnostic, usize)> {
    let mut in_quotes = false;
    let mut escaped = false;
    let mut split = None;
    for (i, c) in text.char_indices() {
        match c {
            _ if escaped => escaped = false,
            '\\' if in_quotes => escaped = true,
            '"' => in_quotes = !in_quotes,
            '=' if !in_quotes => {
                split = Some(i);
                break;
            }
            _ => {}
        }
    }
    let Some(eq) = split else {
        let d = Diagnostic::new(
            JsonPath::root(),
            format!("`{text}` is not an override: expected PATH=VALUE"),
        )
        .with_help("for example `render.spp=64` or `materials.red.base_color=[0.8,0.1,0.1]`");
        return Err((d, text.len()));
    };
    let (path, segment_starts) = parse_path_spanned(&text[..eq])?;
    let value_start = eq + 1;
    let value_text = &text[value_start..];
    let value = serde_json::from_str(value_text).map_err(|e| {
        let d = Diagnostic::new(
            path.clone(),
            format!("the value `{value_text}` is not JSON: {e}"),
        )
        .with_help("strings are quoted (`\"top\"`), arrays are `[0.8,0.1,0.1]`");
        // serde_json's column counts characters of the line, 0 before the first.
        let line_start = value_text
            .split_inclusive('\n')
            .take(e.line().saturating_sub(1))
            .map(str::len)
            .sum::<usize>();
        let at = value_text[line_start..]
            .char_indices()
            .nth(e.column().saturating_sub(1))
            .map_or(value_text.len(), |(i, _)| line_start + i);
        (d, value_start + at)
    })?;
    Ok(SpannedAssignment {
        change: Override { path, value },
        segment_starts,
        value_start,
    })
}

/// JSON's word for the type of a value, for messages.
pub(crate) fn kind(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// Sets the value at `path` in `doc` to `value`. Every step but the last must exist; the last
/// may add a member to an object. On error `doc` is unchanged and the diagnostic names the
/// first step that names nothing (with the closest existing member as help).
pub fn apply(doc: &mut Value, path: &JsonPath, value: Value) -> Result<(), Diagnostic> {
    let Some((last, parents)) = path.0.split_last() else {
        return Err(Diagnostic::new(
            JsonPath::root(),
            "an override must name a value inside the scene, not the whole scene",
        )
        .with_help("to replace the whole scene, load another one"));
    };
    let mut here = doc;
    let mut walked = JsonPath::root();
    for seg in parents {
        here = step(here, &walked, seg)?;
        walked.0.push(seg.clone());
    }
    match (here, last) {
        (Value::Object(map), PathSegment::Key(k)) => {
            map.insert(k.clone(), value);
            Ok(())
        }
        (Value::Array(items), PathSegment::Index(i)) => match items.get_mut(*i) {
            Some(slot) => {
                *slot = value;
                Ok(())
            }
            None => Err(no_element(&walked, *i, items.len())),
        },
        (other, seg) => Err(wrong_container(&walked, other, seg)),
    }
}

/// The child of `here` (at `walked`) named by `seg`, which must exist.
fn step<'a>(
    here: &'a mut Value,
    walked: &JsonPath,
    seg: &PathSegment,
) -> Result<&'a mut Value, Diagnostic> {
    match (here, seg) {
        (Value::Object(map), PathSegment::Key(k)) => {
            if map.contains_key(k) {
                return map.get_mut(k).ok_or_else(|| no_member(walked, k, &[]));
            }
            let mut names: Vec<&str> = map.keys().map(String::as_str).collect();
            names.sort_unstable();
            Err(no_member(walked, k, &names))
        }
        (Value::Array(items), PathSegment::Index(i)) => {
            let len = items.len();
            items.get_mut(*i).ok_or_else(|| no_element(walked, *i, len))
        }
        (other, seg) => Err(wrong_container(walked, other, seg)),
    }
}

fn where_(path: &JsonPath) -> String {
    if path.0.is_empty() {
        "the scene".to_string()
    } else {
        format!("`{path}`")
    }
}

fn no_member(walked: &JsonPath, key: &str, names: &[&str]) -> Diagnostic {
    let d = Diagnostic::new(
        walked.key(key),
        format!(
            "the override names nothing: {} has no member `{key}`",
            where_(walked)
        ),
    );
    match did_you_mean(key, names.iter().copied()) {
        Some(s) => d.with_help(format!("did you mean `{}`?", walked.key(s))),
        None if names.is_empty() => d,
        None if names.len() <= 12 => d.with_help(format!(
            "its members are {}",
            names
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", ")
        )),
        None => d.with_help(format!("it has {} members", names.len())),
    }
}

fn no_element(walked: &JsonPath, index: usize, len: usize) -> Diagnostic {
    let d = Diagnostic::new(
        walked.index(index),
        format!(
            "the override names nothing: {} has {len} element{}",
            where_(walked),
            if len == 1 { "" } else { "s" }
        ),
    );
    match len {
        0 => d,
        1 => d.with_help(format!("the only index is `{}`", walked.index(0))),
        n => d.with_help(format!("indices run from 0 to {}", n - 1)),
    }
}

fn wrong_container(walked: &JsonPath, here: &Value, seg: &PathSegment) -> Diagnostic {
    let (path, wants) = match seg {
        PathSegment::Key(k) => (walked.key(k), format!("member `{k}`")),
        PathSegment::Index(i) => (walked.index(*i), format!("element [{i}]")),
    };
    let d = Diagnostic::new(
        path,
        format!(
            "the override names nothing: {} is {}, which has no {wants}",
            where_(walked),
            kind(here)
        ),
    );
    match (here, seg) {
        (Value::Array(_), PathSegment::Key(_)) => {
            d.with_help("elements of an array are named by index: `objects[2]`")
        }
        (Value::Object(_), PathSegment::Index(_)) => {
            d.with_help("members of an object are named by name: `materials.red`")
        }
        _ => d.with_help(format!("set {} itself", where_(walked))),
    }
}

/// Applies every override to a copy of `scene` and reads the result back as a scene. Returns
/// every problem: overrides that name nothing (each reported, the others still applied), then
/// the first place where the result is not a scene (an unknown field, a value of the wrong
/// type), with its path and a suggestion. The result is not yet validated.
pub fn apply_to_scene(scene: &Scene, overrides: &[Override]) -> Result<Scene, Vec<Diagnostic>> {
    let mut doc = serde_json::to_value(scene).map_err(|e| {
        vec![Diagnostic::new(
            JsonPath::root(),
            format!("internal error: the scene cannot be written as JSON: {e}"),
        )]
    })?;
    let mut problems = Vec::new();
    for o in overrides {
        if let Err(d) = apply(&mut doc, &o.path, o.value.clone()) {
            problems.push(d);
        }
    }
    if !problems.is_empty() {
        return Err(problems);
    }
    from_value(&doc)
}

/// Reads a JSON value as a scene, with the messages of a scene file but no line and column (the
/// text is not the user's).
fn from_value(doc: &Value) -> Result<Scene, Vec<Diagnostic>> {
    let text = doc.to_string();
    crate::load::parse_scene(&text).map_err(|mut d| {
        d.location = None;
        vec![d]
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use serde_json::json;

    fn path(text: &str) -> JsonPath {
        parse_path(text).unwrap_or_else(|d| panic!("{text}: {d}"))
    }

    fn key(k: &str) -> PathSegment {
        PathSegment::Key(k.into())
    }

    #[test]
    fn parses_the_paths_diagnostics_print() {
        assert_eq!(
            path("materials.red.base_color").0,
            vec![key("materials"), key("red"), key("base_color")]
        );
        assert_eq!(
            path("objects[2].sphere.radius").0,
            vec![
                key("objects"),
                PathSegment::Index(2),
                key("sphere"),
                key("radius")
            ]
        );
        assert_eq!(path("render.spp").0, vec![key("render"), key("spp")]);
        assert_eq!(path("$schema").0, vec![key("$schema")]);
        assert_eq!(
            path(r#"textures["wood.png"].file"#).0,
            vec![key("textures"), key("wood.png"), key("file")]
        );
        assert_eq!(
            path(r#"["a\"b"][0][1]"#).0,
            vec![key("a\"b"), PathSegment::Index(0), PathSegment::Index(1)]
        );
        assert_eq!(
            path(r#"m["\u00e9\u{1F600}\ud83d\ude00"]"#).0[1],
            key("é😀😀")
        );
        assert_eq!(
            path("matériaux.rouge").0,
            vec![key("matériaux"), key("rouge")]
        );
    }

    #[test]
    fn bad_paths_say_where() {
        for (text, column, what) in [
            ("", 1, "empty"),
            ("render.", 8, "member name after `.`"),
            ("render..spp", 8, "member name after `.`"),
            (".render", 1, "expected a member name"),
            ("objects[2", 10, "expected `]`"),
            ("objects[]", 9, "expected an index"),
            ("objects[-1]", 9, "expected an index"),
            ("objects[99999999999999999999999]", 9, "too large"),
            ("objects[2]x", 11, "expected `.name`"),
            ("render spp", 7, "expected `.name`"),
            (r#"a["b"#, 3, "no closing"),
            (r#"a["\q"]"#, 5, "unknown escape"),
            (r#"a["\ud800"]"#, 5, "surrogate"),
            (r#"a["\u{110000}"]"#, 5, "not a character"),
        ] {
            let d = parse_path(text).expect_err(text);
            assert!(
                d.message.contains(&format!("at character {column}:")) && d.message.contains(what),
                "{text}: {}",
                d.message
            );
            assert!(d.help.is_some());
        }
        assert!(parse_path(&"a.".repeat(3000)).is_err());
    }

    #[test]
    fn printed_paths_parse_back() {
        let p = JsonPath(vec![
            key("textures"),
            key("wood grain.png"),
            key("tab\there \"q\" \\ \u{7}"),
            PathSegment::Index(3),
            key("plain_$-é"),
        ]);
        assert_eq!(path(&p.to_string()), p);
    }

    #[test]
    fn applies_and_adds_members() {
        let mut doc = json!({"materials": {"red": {"base_color": [1, 0, 0]}}, "objects": [{"sphere": {"radius": 1}}]});
        apply(
            &mut doc,
            &path("materials.red.base_color"),
            json!([0.8, 0.1, 0.1]),
        )
        .unwrap();
        apply(&mut doc, &path("objects[0].sphere.radius"), json!(2.5)).unwrap();
        apply(&mut doc, &path("materials.red.roughness"), json!(0.3)).unwrap();
        apply(
            &mut doc,
            &path("materials.blue"),
            json!({"base_color": [0, 0, 1]}),
        )
        .unwrap();
        assert_eq!(
            doc,
            json!({"materials": {"red": {"base_color": [0.8, 0.1, 0.1], "roughness": 0.3}, "blue": {"base_color": [0, 0, 1]}}, "objects": [{"sphere": {"radius": 2.5}}]})
        );
    }

    #[test]
    fn overrides_that_name_nothing_are_located_and_leave_the_document() {
        let doc = json!({"materials": {"red": {"base_color": [1, 0, 0]}, "white": {}}, "objects": [{"sphere": {"radius": 1}}], "render": {"spp": 4}});
        for (text, at, message, help) in [
            (
                "materials.redd.base_color",
                "materials.redd",
                "`materials` has no member `redd`",
                Some("did you mean `materials.red`?"),
            ),
            (
                "objects[3].sphere.radius",
                "objects[3]",
                "`objects` has 1 element",
                Some("the only index is `objects[0]`"),
            ),
            (
                "objects[1]",
                "objects[1]",
                "`objects` has 1 element",
                Some("the only index"),
            ),
            (
                "objects.sphere",
                "objects.sphere",
                "`objects` is an array, which has no member `sphere`",
                Some("by index"),
            ),
            (
                "render[0]",
                "render[0]",
                "`render` is an object",
                Some("by name"),
            ),
            (
                "render.spp.x",
                "render.spp.x",
                "`render.spp` is a number",
                Some("set `render.spp` itself"),
            ),
            (
                "camera.fov",
                "camera",
                "the scene has no member `camera`",
                Some("its members are `materials`, `objects`, `render`"),
            ),
        ] {
            let mut changed = doc.clone();
            let d = apply(&mut changed, &path(text), json!(1)).expect_err(text);
            assert_eq!(changed, doc, "{text}");
            assert_eq!(d.path.to_string(), at, "{text}");
            assert!(d.message.contains(message), "{text}: {}", d.message);
            if let Some(h) = help {
                assert!(
                    d.help.as_deref().is_some_and(|x| x.contains(h)),
                    "{text}: {:?}",
                    d.help
                );
            }
        }
        let mut root = doc.clone();
        assert!(apply(&mut root, &JsonPath::root(), json!({})).is_err());
    }

    #[test]
    fn assignments() {
        let o = parse_assignment("materials.red.base_color=[0.8, 0.1, 0.1]").unwrap();
        assert_eq!(o.path, path("materials.red.base_color"));
        assert_eq!(o.value, json!([0.8, 0.1, 0.1]));
        let o = parse_assignment(r#"textures["a=b"].file="x=y.png""#).unwrap();
        assert_eq!(o.path.0[1], key("a=b"));
        assert_eq!(o.value, json!("x=y.png"));
        assert!(parse_assignment("render.spp").is_err());
        let d = parse_assignment("render.spp=sixty").unwrap_err();
        assert_eq!(d.path.to_string(), "render.spp");
        assert!(d.message.contains("not JSON"));
    }

    fn scene() -> Scene {
        crate::parse_scene(
            r#"{"format_version": 2, "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y_deg": 40},
                "materials": {"red": {"base_color": [0.8, 0.1, 0.1]}},
                "objects": [{"sphere": {"center": [0, 0, 0], "radius": 1, "material": "red"}}]}"#,
        )
        .unwrap()
    }

    #[test]
    fn scene_overrides_are_read_back_with_located_errors() {
        let s = scene();
        let changed = apply_to_scene(
            &s,
            &[
                Override::new("materials.red.base_color", json!([0.1, 0.8, 0.1])).unwrap(),
                Override::new("render.spp", json!(7)).unwrap(),
                Override::new("objects[0].sphere.radius", json!(0.5)).unwrap(),
            ],
        )
        .unwrap();
        assert_eq!(changed.render.spp, 7);
        assert_eq!(crate::validate(&changed, None), vec![]);
        assert_ne!(changed, s);

        // A field that does not exist: serde's unknown field, with the suggestion.
        let d = apply_to_scene(
            &s,
            &[Override::new("materials.red.base_colour", json!([1, 1, 1])).unwrap()],
        )
        .unwrap_err();
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].path.to_string(), "materials.red.base_colour");
        assert!(d[0].message.contains("unknown field"), "{}", d[0].message);
        assert_eq!(d[0].help.as_deref(), Some("did you mean `base_color`?"));
        assert_eq!(d[0].location, None);

        // The wrong type.
        let d =
            apply_to_scene(&s, &[Override::new("render.spp", json!("many")).unwrap()]).unwrap_err();
        assert_eq!(d[0].path.to_string(), "render.spp");
        assert!(
            d[0].message
                .contains("expected a non-negative integer, found a string"),
            "{}",
            d[0].message
        );

        // Every override that names nothing is reported.
        let d = apply_to_scene(
            &s,
            &[
                Override::new("objects[4].sphere.radius", json!(1)).unwrap(),
                Override::new("materials.bleu.base_color", json!([0, 0, 1])).unwrap(),
            ],
        )
        .unwrap_err();
        assert_eq!(d.len(), 2);
        assert_eq!(d[0].path.to_string(), "objects[4]");
        assert_eq!(d[1].path.to_string(), "materials.bleu");
    }

    proptest! {
        #[test]
        fn any_path_prints_and_parses_back(segs in proptest::collection::vec(
            prop_oneof![
                "[a-z_$-]{1,6}".prop_map(PathSegment::Key),
                any::<String>().prop_map(PathSegment::Key),
                (0usize..1000).prop_map(PathSegment::Index),
            ],
            1..6,
        )) {
            let p = JsonPath(segs);
            prop_assert_eq!(parse_path(&p.to_string()).map_err(|d| d.message), Ok(p));
        }

        #[test]
        fn arbitrary_text_never_panics(text in ".{0,40}", value in any::<i32>()) {
            if let Ok(p) = parse_path(&text) {
                let mut doc = serde_json::json!({"a": {"b": [1, 2, {"c": 3}]}});
                let _ = apply(&mut doc, &p, value.into());
            }
            let _ = parse_assignment(&text);
        }
    }
}
