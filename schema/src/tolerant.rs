//! Tolerant parsing: every problem serde finds while reading a scene, not only the first.
//!
//! The text is parsed into a JSON tree, then read as a [`Scene`] by serde. Each time serde
//! stops, its message becomes a diagnostic and the tree is repaired at that spot (an unknown
//! member removed, a missing one added, a value of the wrong type replaced) with a stand-in
//! value built from the scene's JSON Schema ([`crate::json_schema`]'s source), and serde reads
//! the tree again. The serde types stay the single description of what a scene is: serde's
//! messages are the problems, and the schema generated from the same types only supplies
//! stand-ins. When the repaired tree reads as a scene, the semantic checks run on it, and
//! their findings are kept only where no stand-in can have caused them (see [`Repairs`]).

use std::sync::OnceLock;

use serde_json::{Map, Value};

use crate::diagnostic::Diagnostic;
use crate::locate::{line_col, locate, spans, JsonPath, LineCol, PathSegment};
use crate::scene::Scene;

/// Most problems found while parsing one file; past this many the report stops (a file with
/// hundreds of type errors is not a scene, and each repair rereads the whole tree).
pub const MAX_PARSE_PROBLEMS: usize = 100;

/// The outcome of a tolerant parse.
pub(crate) struct Tolerant {
    /// The repaired scene; `None` when a problem could not be repaired or the report reached
    /// [`MAX_PARSE_PROBLEMS`].
    pub scene: Option<Scene>,
    /// Every problem serde found, each with its location.
    pub problems: Vec<Diagnostic>,
    /// Where the tree was changed to read as a scene.
    pub repairs: Repairs,
}

/// The places of a tree that were changed to make it read as a scene. A semantic finding is
/// sound only away from them: it is dropped when its path lies inside the struct that held a
/// repaired value (a sibling may depend on the stand-in, as the knot count depends on the
/// degree), or when it is an ancestor of a repaired value (a whole-scene or whole-object
/// check saw the stand-in).
#[derive(Debug, Default)]
pub(crate) struct Repairs {
    /// Regions whose findings are dropped.
    regions: Vec<JsonPath>,
    /// The repaired values themselves.
    values: Vec<JsonPath>,
}

impl Repairs {
    fn add(&mut self, repaired: JsonPath) {
        let region = match repaired.0.split_last() {
            Some((PathSegment::Key(_), parent)) if is_struct(&JsonPath(parent.to_vec())) => {
                JsonPath(parent.to_vec())
            }
            _ => repaired.clone(),
        };
        self.regions.push(region);
        self.values.push(repaired);
    }

    /// Whether a semantic finding at `path` can be trusted despite the repairs.
    pub fn is_sound(&self, path: &JsonPath) -> bool {
        !self.regions.iter().any(|r| path.0.starts_with(&r.0))
            && !self.values.iter().any(|v| v.0.starts_with(&path.0))
    }
}

/// Reads `value` (parsed from `text`) as a scene, collecting every problem. `first` is the
/// problem a streaming parse of `text` stopped at, kept as it is (message and location), since
/// that parse sees what a tree cannot (duplicate members). `exact` asks for locations where
/// serde_json's streaming parser reports them (the end of the offending token); otherwise a
/// problem is located at the start of its value (the tree of a migrated file is not the text).
pub(crate) fn read_all(
    text: &str,
    mut value: Value,
    first: Option<Diagnostic>,
    exact: bool,
) -> Tolerant {
    let mut problems: Vec<Diagnostic> = Vec::new();
    let mut repairs = Repairs::default();
    let scene = loop {
        let err = match serde_path_to_error::deserialize::<_, Scene>(&value) {
            Ok(scene) => break Some(scene),
            Err(err) => err,
        };
        if problems.len() + usize::from(first.is_some()) >= MAX_PARSE_PROBLEMS {
            break None;
        }
        let path = convert_path(err.path());
        let raw = err.into_inner().to_string();
        let (message, help) = crate::load::explain(&raw);
        let repaired = match repair(&mut value, &path, &raw) {
            // A problem at or under a value already repaired means the stand-in itself does
            // not read: stop rather than loop.
            Some(r) if !repairs.values.iter().any(|v| r.0.starts_with(&v.0)) => r,
            _ => break None,
        };
        repairs.add(repaired);
        let same_as_first = first.as_ref().is_some_and(|f| f.path == path);
        if !same_as_first {
            let mut d = Diagnostic::new(path.clone(), message);
            d.help = help;
            d.location = if exact {
                streaming_location(text, &path, &raw)
            } else {
                locate(text, &path)
            };
            problems.push(d);
        }
    };
    if let Some(d) = first {
        // A problem the tree does not show (a duplicate member) still taints its region.
        if !repairs.values.contains(&d.path) {
            repairs.add(d.path.clone());
        }
        problems.push(d);
    }
    Tolerant {
        scene,
        problems,
        repairs,
    }
}

/// serde_path_to_error's path as a [`JsonPath`] (segment by segment, so keys may hold dots).
fn convert_path(path: &serde_path_to_error::Path) -> JsonPath {
    use serde_path_to_error::Segment;
    JsonPath(
        path.iter()
            .filter_map(|s| match s {
                Segment::Seq { index } => Some(PathSegment::Index(*index)),
                Segment::Map { key } => Some(PathSegment::Key(key.clone())),
                Segment::Enum { variant } => Some(PathSegment::Key(variant.clone())),
                Segment::Unknown => None,
            })
            .collect(),
    )
}

/// Changes `value` so that serde gets past the problem `raw` at `path`; returns the path of
/// the value changed, or `None` when the tree has no such place.
fn repair(value: &mut Value, path: &JsonPath, raw: &str) -> Option<JsonPath> {
    if raw.starts_with("unknown field `") {
        let (last, parent) = path.0.split_last()?;
        let PathSegment::Key(key) = last else {
            return None;
        };
        let object = value_at_mut(value, parent)?.as_object_mut()?;
        object.remove(key)?;
        return Some(path.clone());
    }
    if let Some(rest) = raw.strip_prefix("missing field `") {
        let field = rest.split('`').next()?;
        let target = path.key(field);
        let stand_in = stand_in(schema_at(&target)?, 0);
        let object = value_at_mut(value, &path.0)?.as_object_mut()?;
        if object.contains_key(field) {
            return None;
        }
        object.insert(field.to_string(), stand_in);
        return Some(target);
    }
    let stand_in = stand_in(schema_at(path)?, 0);
    let slot = value_at_mut(value, &path.0)?;
    if *slot == stand_in {
        return None;
    }
    *slot = stand_in;
    Some(path.clone())
}

fn value_at_mut<'a>(mut value: &'a mut Value, path: &[PathSegment]) -> Option<&'a mut Value> {
    for seg in path {
        value = match seg {
            PathSegment::Key(k) => value.as_object_mut()?.get_mut(k)?,
            PathSegment::Index(i) => value.as_array_mut()?.get_mut(*i)?,
        };
    }
    Some(value)
}

/// Where serde_json's streaming parser reports the problem `raw` at `path`: the last character
/// it read, which is the end of the offending key or value, the closing brace of an object
/// missing a member, or the character before an object or array of the wrong type.
fn streaming_location(text: &str, path: &JsonPath, raw: &str) -> Option<LineCol> {
    let Some(s) = spans(text, path) else {
        return locate(text, path);
    };
    let at = if raw.starts_with("unknown field `") {
        s.key.map_or(s.value.1, |k| k.1)
    } else if raw.starts_with("unknown variant `") {
        s.first_key.map_or(s.value.1, |k| k.1)
    } else if raw.starts_with("invalid type: map") || raw.starts_with("invalid type: sequence") {
        s.value.0
    } else if raw.starts_with("data did not match any variant") {
        // An untagged enum reads its whole value and the blanks after it before deciding.
        let blanks = text.get(s.value.1..).map_or(0, |rest| {
            rest.len() - rest.trim_start_matches([' ', '\t', '\n', '\r']).len()
        });
        s.value.1 + blanks
    } else {
        s.value.1
    };
    Some(line_col(text, at.saturating_sub(1)))
}

/// The scene's JSON Schema as a tree, made once.
fn root_schema() -> &'static Value {
    static SCHEMA: OnceLock<Value> = OnceLock::new();
    SCHEMA.get_or_init(|| schemars::schema_for!(Scene).to_value())
}

/// Follows a `$ref` into `$defs`.
fn resolve(mut schema: &'static Value) -> &'static Value {
    for _ in 0..8 {
        let Some(name) = schema
            .get("$ref")
            .and_then(Value::as_str)
            .and_then(|r| r.strip_prefix("#/$defs/"))
        else {
            break;
        };
        match root_schema().get("$defs").and_then(|d| d.get(name)) {
            Some(s) => schema = s,
            None => break,
        }
    }
    schema
}

/// The alternatives of a schema (`oneOf`, `anyOf`), empty for a plain one.
fn alternatives(schema: &'static Value) -> impl Iterator<Item = &'static Value> {
    ["oneOf", "anyOf"]
        .into_iter()
        .filter_map(|k| schema.get(k).and_then(Value::as_array))
        .flatten()
}

/// The schema of the child `seg` of a value of schema `schema`.
fn child(schema: &'static Value, seg: &PathSegment) -> Option<&'static Value> {
    let schema = resolve(schema);
    let direct = match seg {
        PathSegment::Key(k) => schema
            .get("properties")
            .and_then(|p| p.get(k))
            .or_else(|| schema.get("additionalProperties").filter(|a| a.is_object())),
        PathSegment::Index(i) => schema
            .get("prefixItems")
            .and_then(|p| p.get(*i))
            .or_else(|| schema.get("items").filter(|a| a.is_object())),
    };
    direct.or_else(|| alternatives(schema).find_map(|alt| child(alt, seg)))
}

/// The schema of the value at `path` of a scene.
fn schema_at(path: &JsonPath) -> Option<&'static Value> {
    path.0
        .iter()
        .try_fold(root_schema(), |schema, seg| child(schema, seg))
}

/// Whether the value at `path` is a struct (fixed members) rather than a map of names.
fn is_struct(path: &JsonPath) -> bool {
    schema_at(path)
        .map(resolve)
        .is_some_and(|s| s.get("properties").is_some())
}

/// The simplest value a schema accepts: its default, its first keyword or alternative, or an
/// object of its required members. Stand-ins are never shown; the semantic findings about them
/// are dropped.
fn stand_in(schema: &'static Value, depth: usize) -> Value {
    let schema = resolve(schema);
    if depth > 32 {
        return Value::Null;
    }
    if let Some(v) = schema.get("default").or_else(|| schema.get("const")) {
        return v.clone();
    }
    if let Some(v) = schema
        .get("enum")
        .and_then(Value::as_array)
        .and_then(|e| e.first())
    {
        return v.clone();
    }
    if let Some(alt) = alternatives(schema).next() {
        return stand_in(alt, depth + 1);
    }
    let types: Vec<&str> = match schema.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    };
    if types.contains(&"null") {
        return Value::Null;
    }
    match types.first().copied() {
        Some("object") => {
            let mut object = Map::new();
            let required = schema.get("required").and_then(Value::as_array);
            for name in required.into_iter().flatten().filter_map(Value::as_str) {
                let member = schema
                    .get("properties")
                    .and_then(|p| p.get(name))
                    .map_or(Value::Null, |s| stand_in(s, depth + 1));
                object.insert(name.to_string(), member);
            }
            Value::Object(object)
        }
        Some("array") => {
            let n = schema.get("minItems").and_then(Value::as_u64).unwrap_or(0);
            let items = schema.get("items").filter(|s| s.is_object());
            let prefix = schema.get("prefixItems").and_then(Value::as_array);
            Value::Array(
                (0..n.min(64) as usize)
                    .map(|i| {
                        prefix
                            .and_then(|p| p.get(i))
                            .or(items)
                            .map_or(Value::Null, |s| stand_in(s, depth + 1))
                    })
                    .collect(),
            )
        }
        Some("string") => Value::String(String::new()),
        Some("boolean") => Value::Bool(false),
        Some("integer") | Some("number") => Value::from(0),
        _ => Value::Null,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every type of the scene has a stand-in that reads back as that type.
    #[test]
    fn stand_ins_read_as_their_types() {
        let scene = stand_in(root_schema(), 0);
        let parsed: Result<Scene, _> = serde_json::from_value(scene.clone());
        assert!(parsed.is_ok(), "{scene}: {parsed:?}");
        let defs = root_schema()
            .get("$defs")
            .and_then(Value::as_object)
            .expect("the schema has definitions");
        for name in [
            "Object",
            "Light",
            "Material",
            "Texture",
            "TransformOp",
            "Scale",
        ] {
            let schema = defs.get(name).expect("a definition");
            let v = stand_in(schema, 0);
            let path = match name {
                "Object" => "objects[0]",
                "Light" => "lights[0]",
                "Material" => "materials.m",
                "Texture" => "textures.t",
                _ => continue,
            };
            assert_eq!(
                schema_at(&JsonPath::parse(path)).map(resolve),
                Some(schema),
                "{path}"
            );
            assert!(!v.is_null(), "{name}");
        }
    }

    /// A problem found in the tree is located where the streaming parser reports it alone.
    #[test]
    fn locations_match_the_streaming_parser() {
        let scene = |camera: &str, objects: &str| {
            format!(
                "{{\n  \"format_version\": 2,\n  \"camera\": {camera},\n  \"materials\": \
                 {{ \"m\": {{}} }},\n  \"objects\": [\n    {objects}\n  ]\n}}"
            )
        };
        let good_camera = r#"{ "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40 }"#;
        let good_sphere = r#"{ "sphere": { "material": "m", "radius": 1 } }"#;
        let cases = [
            scene(
                r#"{ "position": [0, 0, 5], "look_at": [0, 0], "fov_y_deg": 40 }"#,
                good_sphere,
            ),
            scene(
                r#"{ "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": "40" }"#,
                good_sphere,
            ),
            scene(
                r#"{ "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40, "fov": 1 }"#,
                good_sphere,
            ),
            scene(
                r#"{ "position": [0, 0, 5], "look_at": [0, 0, 0] }"#,
                good_sphere,
            ),
            scene(
                good_camera,
                r#"{ "sphere": { "material": [1], "radius": 1 } }"#,
            ),
            scene(
                good_camera,
                r#"{ "sphere": { "material": {}, "radius": 1 } }"#,
            ),
            scene(
                good_camera,
                r#"{ "mesh": { "material": "m", "source": { "gltf": { "file": "a.glb", "mesh": -1 } } } }"#,
            ),
            scene(good_camera, r#"{ "cube": { "material": "m" } }"#),
            scene(
                good_camera,
                r#"{ "sphere": { "material": "m", "radius": 1, "transform": [{ "scale": "x" }] } }"#,
            ),
            scene(
                good_camera,
                r#"{ "mesh": { "material": "m", "source": { "obj": 3 } } }"#,
            ),
            scene(
                good_camera,
                r#"{ "mesh": { "material": "m", "source": { "inline": { "positions": [], "indices": [[0, 1]] } } } }"#,
            ),
            scene(
                good_camera,
                r#"{ "sphere": { "material": "m", "radius": true } }"#,
            ),
            scene(
                good_camera,
                r#"{ "sphere": { "material": "m", "radius": null } }"#,
            ),
        ];
        for text in cases {
            let streamed = crate::parse_scene(&text).expect_err(&text);
            let value: Value = serde_json::from_str(&text).expect("well-formed JSON");
            let read = read_all(&text, value, None, true);
            assert_eq!(read.problems.len(), 1, "{text}: {:?}", read.problems);
            assert_eq!(read.problems[0], streamed, "{text}");
        }
    }

    #[test]
    fn soundness_follows_the_repaired_struct() {
        let mut r = Repairs::default();
        r.add(JsonPath::parse("render.spp"));
        r.add(JsonPath::parse("objects[1]"));
        r.add(JsonPath::parse("materials.m"));
        assert!(!r.is_sound(&JsonPath::parse("render.max_depth")));
        assert!(!r.is_sound(&JsonPath::root()));
        assert!(!r.is_sound(&JsonPath::parse("objects[1].sphere.radius")));
        assert!(r.is_sound(&JsonPath::parse("objects[0].sphere.radius")));
        assert!(r.is_sound(&JsonPath::parse("materials.n.specular")));
        assert!(!r.is_sound(&JsonPath::parse("materials.m.specular")));
        assert!(r.is_sound(&JsonPath::parse("textures.t.file")));
    }
}
