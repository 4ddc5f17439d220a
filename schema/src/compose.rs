//! Changing a scene from outside its file: a merge patch (RFC 7396, `--patch FILE.json`), then
//! overrides (`--set PATH=JSON`, and the command line's shorthands such as `--width`) in order,
//! applied to the scene as JSON, read back and validated as one scene.
//!
//! Every problem of the result is placed where it was written: in the `--set` argument that
//! wrote the value (`--set #2:1:18`), in the patch file, or in the scene file. Paths use the
//! grammar of [`crate::overrides`].

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::diagnostic::{Diagnostic, LoadError};
use crate::locate::{line_col, locate, JsonPath, LineCol, PathSegment};
use crate::overrides::{self, Override};
use crate::scene::Scene;
use crate::validated::Validated;

/// A merge patch (RFC 7396) read from a file: an object whose members replace the scene's,
/// objects merging member by member and `null` removing a member.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// The patch file.
    pub file: PathBuf,
    /// Its text, to place problems in it.
    pub text: String,
    /// The patch.
    pub value: Value,
}

impl Patch {
    /// Reads a merge patch file. It must be a JSON object; what it changes is checked when it
    /// is applied ([`Composition::apply`]), as part of the scene.
    pub fn read(file: &Path) -> Result<Patch, LoadError> {
        let text = std::fs::read_to_string(file).map_err(|source| LoadError::Io {
            path: file.to_path_buf(),
            source,
        })?;
        Patch::from_text(file, text)
    }

    /// A merge patch from its text; `file` names it in messages.
    pub fn from_text(file: &Path, text: String) -> Result<Patch, LoadError> {
        let invalid = |d: Diagnostic| LoadError::Invalid {
            file: file.to_path_buf(),
            diagnostics: vec![d],
        };
        let value: Value = serde_json::from_str(&text).map_err(|e| {
            let (message, _) = crate::load::explain(&e.to_string());
            let mut d = Diagnostic::new(JsonPath::root(), message).with_help(
                "a merge patch is a JSON object shaped like the part of the scene it changes",
            );
            d.location = Some(LineCol {
                line: e.line().max(1),
                column: e.column().max(1),
            });
            invalid(d)
        })?;
        if !value.is_object() {
            let mut d = Diagnostic::new(
                JsonPath::root(),
                format!(
                    "a merge patch is a JSON object, found {}",
                    overrides::kind(&value)
                ),
            )
            .with_help("for example {\"render\": {\"spp\": 64}}");
            d.location = locate(&text, &JsonPath::root());
            return Err(invalid(d));
        }
        Ok(Patch {
            file: file.to_path_buf(),
            text,
            value,
        })
    }

    /// Whether the patch wrote the value at `path`: the path leads through the patch's objects
    /// to one of its values (a value that is not an object replaces everything below it).
    fn wrote(&self, path: &JsonPath) -> bool {
        let mut here = &self.value;
        for seg in &path.0 {
            match (here, seg) {
                (Value::Object(members), PathSegment::Key(k)) => match members.get(k) {
                    Some(v) => here = v,
                    None => return false,
                },
                (Value::Object(_), PathSegment::Index(_)) => return false,
                _ => return true,
            }
        }
        true
    }
}

/// Applies a merge patch (RFC 7396) to `target`.
pub fn merge_patch(target: &mut Value, patch: &Value) {
    let Value::Object(changes) = patch else {
        *target = patch.clone();
        return;
    };
    if !target.is_object() {
        *target = Value::Object(serde_json::Map::new());
    }
    if let Value::Object(members) = target {
        for (key, change) in changes {
            if change.is_null() {
                members.remove(key);
            } else {
                merge_patch(members.entry(key.clone()).or_insert(Value::Null), change);
            }
        }
    }
}

/// One override and where it was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Set {
    /// What names it in messages: `--set #2`, `--width`.
    pub label: String,
    /// The argument as written (`PATH=JSON`), when it was written as one.
    text: Option<String>,
    /// Byte offsets of the path's segments in `text`.
    segment_starts: Vec<usize>,
    /// Byte offset of the value in `text`.
    value_start: usize,
    /// The override.
    pub change: Override,
}

impl Set {
    /// Reads a `PATH=JSON` argument; `label` names it in messages (`--set #2`). The error is
    /// placed at the character it is about.
    pub fn parse(label: &str, text: &str) -> Result<Set, Diagnostic> {
        match overrides::parse_assignment_spanned(text) {
            Ok(a) => Ok(Set {
                label: label.to_string(),
                text: Some(text.to_string()),
                segment_starts: a.segment_starts,
                value_start: a.value_start,
                change: a.change,
            }),
            Err((mut d, at)) => {
                d.set_file(label);
                d.location = Some(line_col(text, at));
                Err(d)
            }
        }
    }

    /// An override given by a command-line shorthand (`--width 640` is `image.width=640`);
    /// `path` is in the grammar of [`crate::overrides`].
    pub fn shorthand(flag: &str, path: &str, value: Value) -> Set {
        Set {
            label: flag.to_string(),
            text: None,
            segment_starts: Vec::new(),
            value_start: 0,
            change: Override {
                path: JsonPath::parse(path),
                value,
            },
        }
    }

    /// `d` placed in this argument: at the segment of the path it names, or inside the value.
    fn place(&self, mut d: Diagnostic) -> Diagnostic {
        d.set_file(&self.label);
        d.location = self.text.as_deref().map(|text| {
            let own = &self.change.path.0;
            if d.path.0.len() >= own.len() {
                let inside = JsonPath(d.path.0[own.len()..].to_vec());
                let value_text = &text[self.value_start..];
                let at = locate(value_text, &inside).unwrap_or(LineCol { line: 1, column: 1 });
                let start = line_col(text, self.value_start);
                if at.line == 1 {
                    LineCol {
                        line: start.line,
                        column: start.column + at.column - 1,
                    }
                } else {
                    LineCol {
                        line: start.line + at.line - 1,
                        column: at.column,
                    }
                }
            } else {
                let segment = d.path.0.len().saturating_sub(1);
                let at = self.segment_starts.get(segment).copied().unwrap_or(0);
                line_col(text, at)
            }
        });
        d
    }
}

/// Changes to a scene from outside its file: a merge patch, then overrides in order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Composition {
    /// The merge patch, applied first.
    pub patch: Option<Patch>,
    /// The overrides, applied after the patch, in order (a later one wins).
    pub sets: Vec<Set>,
}

impl Composition {
    /// The command line's `--set` arguments (labelled `--set #1`, `--set #2`, …) and
    /// `--patch` file. Every argument that does not parse is reported, placed in it.
    pub fn from_args(sets: &[String], patch: Option<&Path>) -> Result<Composition, LoadError> {
        let mut problems = Vec::new();
        let mut parsed = Vec::new();
        for (i, text) in sets.iter().enumerate() {
            match Set::parse(&format!("--set #{}", i + 1), text) {
                Ok(s) => parsed.push(s),
                Err(d) => problems.push(d),
            }
        }
        if !problems.is_empty() {
            return Err(LoadError::Invalid {
                file: PathBuf::from("the command line"),
                diagnostics: problems,
            });
        }
        Ok(Composition {
            patch: patch.map(Patch::read).transpose()?,
            sets: parsed,
        })
    }

    /// Whether it changes nothing.
    pub fn is_empty(&self) -> bool {
        self.patch.is_none() && self.sets.is_empty()
    }

    /// The scene with the patch and overrides applied, read back and validated (relative
    /// paths resolve against `base_dir`; `None` skips file checks). `file` and `text` are the
    /// scene's file and its text, when it has one, to place problems the changes did not
    /// write. Returns every problem: overrides that name nothing (each reported, the others
    /// still applied), or every problem of the result.
    pub fn apply(
        &self,
        scene: &Scene,
        file: &Path,
        text: Option<&str>,
        base_dir: Option<&Path>,
    ) -> Result<Validated<Scene>, Vec<Diagnostic>> {
        let mut doc = serde_json::to_value(scene).map_err(|e| {
            vec![Diagnostic::new(
                JsonPath::root(),
                format!("internal error: the scene cannot be written as JSON: {e}"),
            )]
        })?;
        if let Some(p) = &self.patch {
            merge_patch(&mut doc, &p.value);
        }
        let mut problems = Vec::new();
        for s in &self.sets {
            if let Err(d) = overrides::apply(&mut doc, &s.change.path, s.change.value.clone()) {
                problems.push(s.place(d));
            }
        }
        if !problems.is_empty() {
            return Err(problems);
        }
        let composed = doc.to_string();
        match crate::load::load_scene_str(&composed, file, base_dir) {
            Ok(valid) => Ok(valid),
            Err(LoadError::Invalid { diagnostics, .. }) => Err(diagnostics
                .into_iter()
                .map(|d| self.place(d, text))
                .collect()),
            Err(e) => Err(vec![Diagnostic::new(JsonPath::root(), e.to_string())]),
        }
    }

    /// `d` (found in the composed scene) placed where its value was written: the last
    /// override at or above its path, else the patch if it wrote it, else the scene file.
    fn place(&self, mut d: Diagnostic, text: Option<&str>) -> Diagnostic {
        if let Some(s) = self
            .sets
            .iter()
            .rev()
            .find(|s| d.path.0.starts_with(&s.change.path.0))
        {
            return s.place(d);
        }
        if let Some(p) = self.patch.as_ref().filter(|p| p.wrote(&d.path)) {
            d.set_file(p.file.clone());
            d.location = locate(&p.text, &d.path);
            return d;
        }
        d.location = text.and_then(|t| locate(t, &d.path));
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn scene() -> Scene {
        crate::parse_scene(
            r#"{"format_version": 2, "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y_deg": 40},
                "materials": {"red": {"base_color": [0.8, 0.1, 0.1]}},
                "objects": [{"sphere": {"center": [0, 0, 0], "radius": 1, "material": "red"}}]}"#,
        )
        .unwrap()
    }

    fn sets(args: &[&str]) -> Composition {
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        Composition::from_args(&args, None).unwrap()
    }

    fn apply(c: &Composition) -> Result<Validated<Scene>, Vec<Diagnostic>> {
        c.apply(&scene(), Path::new("scene.json"), None, None)
    }

    #[test]
    fn merge_patch_follows_rfc_7396() {
        // The examples of RFC 7396, appendix A (a selection).
        for (target, patch, result) in [
            (json!({"a": "b"}), json!({"a": "c"}), json!({"a": "c"})),
            (
                json!({"a": "b"}),
                json!({"b": "c"}),
                json!({"a": "b", "b": "c"}),
            ),
            (json!({"a": "b"}), json!({"a": null}), json!({})),
            (json!({"a": ["b"]}), json!({"a": "c"}), json!({"a": "c"})),
            (json!({"a": "c"}), json!({"a": ["b"]}), json!({"a": ["b"]})),
            (
                json!({"a": {"b": "c"}}),
                json!({"a": {"b": "d", "c": null}}),
                json!({"a": {"b": "d"}}),
            ),
            (
                json!({"a": [{"b": "c"}]}),
                json!({"a": [1]}),
                json!({"a": [1]}),
            ),
            (json!(["a", "b"]), json!(["c", "d"]), json!(["c", "d"])),
            (
                json!({"e": null}),
                json!({"a": 1}),
                json!({"e": null, "a": 1}),
            ),
            (
                json!([1, 2]),
                json!({"a": "b", "c": null}),
                json!({"a": "b"}),
            ),
            (
                json!({}),
                json!({"a": {"bb": {"ccc": null}}}),
                json!({"a": {"bb": {}}}),
            ),
        ] {
            let mut t = target.clone();
            merge_patch(&mut t, &patch);
            assert_eq!(t, result, "{target} + {patch}");
        }
    }

    #[test]
    fn sets_change_the_scene_and_later_ones_win() {
        let c = sets(&[
            "materials.red.base_color=[0.2,0.2,0.8]",
            "render.spp=3",
            "render.spp=5",
        ]);
        let s = apply(&c).unwrap();
        assert_eq!(s.materials["red"].base_color, [0.2, 0.2, 0.8]);
        assert_eq!(s.render.spp, 5);
    }

    #[test]
    fn sets_that_name_nothing_are_placed_in_the_argument() {
        let d = apply(&sets(&[
            "render.spp=4",
            "materials.redd.base_color=[1,1,1]",
        ]))
        .unwrap_err();
        assert_eq!(d.len(), 1);
        let text = crate::Report {
            file: "scene.json".into(),
            diagnostics: d,
        }
        .to_string();
        assert!(
            text.contains("--set #2:1:11: materials.redd: the override names nothing: `materials` has no member `redd`"),
            "{text}"
        );
        assert!(text.contains("did you mean `materials.red`?"), "{text}");
    }

    #[test]
    fn wrong_types_and_invalid_values_are_placed_in_the_value() {
        let d = apply(&sets(&["render.spp=\"many\""])).unwrap_err();
        assert_eq!(d[0].file(), Some(Path::new("--set #1")));
        assert_eq!(
            d[0].location,
            Some(LineCol {
                line: 1,
                column: 12
            })
        );
        assert!(d[0].message.contains("found a string"), "{}", d[0].message);

        let d = apply(&sets(&[
            "objects[0].sphere={\"center\":[0,0,0],\"radius\":1,\"material\":\"blue\"}",
        ]))
        .unwrap_err();
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].path.to_string(), "objects[0].sphere.material");
        assert_eq!(
            d[0].location,
            Some(LineCol {
                line: 1,
                column: 59
            })
        );
        assert!(d[0].message.contains("unknown material `blue`"), "{d:?}");
    }

    #[test]
    fn arguments_that_do_not_parse_are_placed() {
        let args: Vec<String> = ["render.spp=4", "render..spp=4", "render.spp=sixty"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let Err(LoadError::Invalid { diagnostics, .. }) = Composition::from_args(&args, None)
        else {
            panic!("accepted");
        };
        assert_eq!(diagnostics.len(), 2);
        assert_eq!(diagnostics[0].file(), Some(Path::new("--set #2")));
        assert_eq!(
            diagnostics[0].location,
            Some(LineCol { line: 1, column: 8 })
        );
        assert_eq!(diagnostics[1].file(), Some(Path::new("--set #3")));
        assert_eq!(
            diagnostics[1].location,
            Some(LineCol {
                line: 1,
                column: 12
            })
        );
    }

    #[test]
    fn patch_problems_are_placed_in_the_patch() {
        let patch = Patch::from_text(
            Path::new("patch.json"),
            "{\n  \"render\": {\"spp\": 4},\n  \"materials\": {\"red\": {\"roughness\": 2}}\n}"
                .into(),
        )
        .unwrap();
        let c = Composition {
            patch: Some(patch),
            sets: Vec::new(),
        };
        let d = apply(&c).unwrap_err();
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].file(), Some(Path::new("patch.json")));
        assert_eq!(d[0].path.to_string(), "materials.red.roughness");
        assert_eq!(
            d[0].location,
            Some(LineCol {
                line: 3,
                column: 38
            })
        );

        let fine = Patch::from_text(
            Path::new("p.json"),
            r#"{"render": {"spp": 9}, "materials": {"red": {"roughness": null}}}"#.into(),
        )
        .unwrap();
        let s = Composition {
            patch: Some(fine),
            sets: vec![Set::shorthand("--seed", "render.seed", json!(3))],
        };
        let s = apply(&s).unwrap();
        assert_eq!((s.render.spp, s.render.seed), (9, 3));

        for (text, message) in [("[1]", "found an array"), ("{\"a\": ", "EOF")] {
            let Err(LoadError::Invalid { diagnostics, .. }) =
                Patch::from_text(Path::new("p.json"), text.into())
            else {
                panic!("{text} accepted");
            };
            assert!(diagnostics[0].message.contains(message), "{diagnostics:?}");
            assert!(diagnostics[0].location.is_some());
        }
    }
}
