//! A scene file reports every problem at once: those serde finds while reading it (unknown
//! members, wrong types, missing members, unknown keywords) and the semantic ones, each at its
//! line and column, in document order. Random damage to a valid scene never panics and every
//! reported location lies inside the file.

use std::path::{Path, PathBuf};

use lumo_schema::{load_scene_str, Diagnostic, LoadError};
use proptest::prelude::*;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the schema crate lives in the workspace")
        .to_path_buf()
}

/// The problems of `text`, checked against the files of `dir`.
fn problems_in(text: &str, dir: &Path) -> Vec<Diagnostic> {
    match load_scene_str(text, &dir.join("scene.json"), Some(dir)) {
        Err(LoadError::Invalid { diagnostics, .. }) => diagnostics,
        other => panic!("expected an invalid scene, got {other:?}"),
    }
}

/// (path, line, column, message) of each problem.
fn summary(ds: &[Diagnostic]) -> Vec<(String, usize, usize, String)> {
    ds.iter()
        .map(|d| {
            let at = d.location.expect("every problem of a file is located");
            (d.path.to_string(), at.line, at.column, d.message.clone())
        })
        .collect()
}

const ISSUE_EXAMPLE: &str = r#"{
  "format_version": 2,
  "render": { "spp": "64" },
  "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40 },
  "textures": { "wood": { "file": "no_such_wood.png" } },
  "materials": {
    "floor": { "base_colour": [0.8, 0.8, 0.8], "base_color_texture": { "texture": "wood" } }
  },
  "objects": [ { "sphere": { "material": "floor", "radius": 1 } } ]
}
"#;

#[test]
fn a_typo_a_wrong_type_and_a_missing_texture_are_three_located_problems() {
    let dir = texture_free_dir();
    let ds = problems_in(ISSUE_EXAMPLE, &dir);
    assert_eq!(
        summary(&ds),
        vec![
            (
                "render.spp".into(),
                3,
                25,
                "expected a non-negative integer, found a string \"64\"".into()
            ),
            (
                "textures.wood.file".into(),
                5,
                35,
                format!(
                    "texture file `no_such_wood.png` not found (looked for {})",
                    dir.join("no_such_wood.png").display()
                )
            ),
            (
                "materials.floor.base_colour".into(),
                7,
                28,
                "unknown field `base_colour`".into()
            ),
        ]
    );
    assert_eq!(ds[2].help.as_deref(), Some("did you mean `base_color`?"));
}

#[test]
fn typos_in_different_objects_are_each_reported_with_a_suggestion() {
    let text = r#"{
  "format_version": 2,
  "imag": { "width": 8 },
  "camera": { "positon": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40 },
  "materials": { "red": { "roughnes": 0.5 } },
  "objects": [ { "sphere": { "material": "red", "radius": 1, "centre": [0, 0, 0] } } ]
}"#;
    let ds = problems_in(text, &workspace());
    let got: Vec<(String, usize, Option<String>)> = ds
        .iter()
        .map(|d| {
            (
                d.path.to_string(),
                d.location.map_or(0, |l| l.line),
                d.help.clone(),
            )
        })
        .collect();
    let help = |s: &str| Some(format!("did you mean `{s}`?"));
    assert_eq!(
        got,
        vec![
            ("imag".into(), 3, help("image")),
            // The misspelt member leaves `position` missing: that is reported at the camera's
            // closing brace, after the typo itself.
            ("camera.positon".into(), 4, help("position")),
            ("camera".into(), 4, None),
            ("materials.red.roughnes".into(), 5, help("roughness")),
            ("objects[0].sphere.centre".into(), 6, help("center")),
        ],
        "{ds:#?}"
    );
    assert_eq!(ds[2].message, "missing field `position`");
}

#[test]
fn a_wrong_type_inside_an_array_element_and_a_bad_keyword_are_reported_with_the_rest() {
    let text = r#"{
  "format_version": 2,
  "render": { "integrator": "bdpt" },
  "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40 },
  "materials": { "m": {} },
  "objects": [
    { "sphere": { "material": "m", "radius": 1 } },
    { "triangle": { "material": "m", "vertices": [[0, 0, 0], [1, "0", 0], [0, 1, 0]] } },
    { "sphere": { "material": "m", "radius": -1 } },
    { "cube": { "material": "m" } }
  ]
}"#;
    let ds = problems_in(text, &workspace());
    assert_eq!(
        summary(&ds),
        vec![
            (
                "render.integrator".into(),
                3,
                34,
                "unknown kind `bdpt`, expected `path` or `raycast`".into()
            ),
            (
                "objects[1].triangle.vertices[1][1]".into(),
                8,
                68,
                "expected a number, found a string \"0\"".into()
            ),
            (
                "objects[2].sphere.radius".into(),
                9,
                46,
                "radius must be > 0, found -1".into()
            ),
            (
                "objects[3]".into(),
                10,
                12,
                "unknown kind `cube`, expected one of `sphere`, `plane`, `triangle`, `mesh`, `lathe`"
                    .into()
            ),
        ]
    );
}

/// A stand-in value never shows up as a problem of its own: a wrong-typed radius is one
/// problem, not also "radius must be > 0", and a missing material is not an unknown one.
#[test]
fn findings_about_repaired_values_are_not_reported() {
    let text = r#"{
  "format_version": 2,
  "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y_deg": 40 },
  "materials": { "m": {} },
  "objects": [
    { "sphere": { "radius": "1" } },
    { "lathe": { "material": "m", "profile": { "bspline": {
      "degree": "2", "points": [[1, 0], [1, 1], [0.5, 2]], "knots": [0, 0, 0, 1, 1, 1] } } } }
  ]
}"#;
    let ds = problems_in(text, &workspace());
    let messages: Vec<&str> = ds.iter().map(|d| d.message.as_str()).collect();
    assert_eq!(
        messages,
        vec![
            "expected a number, found a string \"1\"",
            "missing field `material`",
            "expected a non-negative integer, found a string \"2\""
        ],
        "{ds:#?}"
    );
}

/// A file of nothing but mistakes gets a report of bounded length, not one line per mistake.
#[test]
fn the_report_stops_at_the_limit() {
    let spheres: Vec<String> = (0..150)
        .map(|_| r#"{ "sphere": { "material": "m", "radius": "x" } }"#.to_string())
        .collect();
    let text = format!(
        "{{\"format_version\": 2,\n\"camera\": {{ \"position\": [0, 0, 5], \"look_at\": [0, 0, 0], \
         \"fov_y_deg\": 40 }},\n\"materials\": {{ \"m\": {{}} }},\n\"objects\": [\n{}\n]}}",
        spheres.join(",\n")
    );
    let ds = problems_in(&text, &workspace());
    assert_eq!(ds.len(), lumo_schema::MAX_PARSE_PROBLEMS);
    assert!(ds
        .iter()
        .all(|d| d.message == "expected a number, found a string \"x\""));
}

/// Text that is not JSON stops at the syntax error; a problem the streaming parse met before
/// it is reported too, but nothing after it can be read.
#[test]
fn a_syntax_error_still_stops_at_the_first() {
    let text = "{\n  \"format_version\": 2\n  \"x\": 1,\n  \"imag\": {}\n}";
    let ds = problems_in(text, &workspace());
    assert_eq!(
        summary(&ds),
        vec![("(root)".into(), 3, 3, "expected `,` or `}`".into())]
    );
    let text = "{\n  \"format_version\": 2,\n  \"imag\": {},\n  \"camera\": {\n}\n  \"x\": 1\n}";
    let ds = problems_in(text, &workspace());
    assert_eq!(
        summary(&ds),
        vec![
            ("imag".into(), 3, 8, "unknown field `imag`".into()),
            ("(root)".into(), 6, 3, "expected `,` or `}`".into())
        ]
    );
}

/// A folder that exists and holds no texture: the crate's own tests folder.
fn texture_free_dir() -> PathBuf {
    workspace().join("schema/tests")
}

/// The valid scene damaged by the property test.
fn base_scene() -> String {
    std::fs::read_to_string(workspace().join("scenes/cornell.json"))
        .expect("scenes/cornell.json is readable")
}

/// Edits of a scene text: each replaces up to 7 bytes at some offset with a JSON fragment, which
/// misspells a key, breaks the syntax or puts a value of another type in place.
fn mutate(text: &str, edits: &[(usize, usize, usize)]) -> String {
    const FRAGMENTS: &[&str] = &[
        "\"x\"",
        "1",
        "-1",
        "[]",
        "{}",
        "null",
        "true",
        "\"sphere\"",
        "1.5",
        "[1, 2]",
        "{\"cube\": {}}",
        "\"\"",
        "0",
        "1e40",
        "\"bdpt\"",
    ];
    let mut out = text.to_string();
    for &(at, len, which) in edits {
        let at = at % (out.len() + 1);
        let mut start = at;
        while !out.is_char_boundary(start) {
            start -= 1;
        }
        let mut end = (start + len % 8).min(out.len());
        while !out.is_char_boundary(end) {
            end += 1;
        }
        let fragment = FRAGMENTS[which % FRAGMENTS.len()];
        out.replace_range(start..end, fragment);
    }
    out
}

/// Replaces the value after the `n`-th colon with a fragment: well-formed JSON, wrong scenes.
fn replace_value(text: &str, n: usize, which: usize) -> String {
    const VALUES: &[&str] = &[
        "\"x\"",
        "1",
        "-1",
        "[]",
        "{}",
        "null",
        "true",
        "1.5",
        "[1, 2]",
        "{\"cube\": {}}",
        "\"bdpt\"",
        "[[1]]",
        "{\"a\": 1}",
    ];
    let colons: Vec<usize> = text.match_indices(':').map(|(i, _)| i).collect();
    if colons.is_empty() {
        return text.to_string();
    }
    let at = colons[n % colons.len()] + 1;
    // The value after the colon ends where a streaming parse of the rest stops.
    let rest = &text[at..];
    let mut stream = serde_json::Deserializer::from_str(rest).into_iter::<serde_json::Value>();
    match stream.next() {
        Some(Ok(_)) => {
            let end = at + stream.byte_offset();
            format!(
                "{}{}{}",
                &text[..at],
                VALUES[which % VALUES.len()],
                &text[end..]
            )
        }
        _ => text.to_string(),
    }
}

fn check_locations(text: &str, ds: &[Diagnostic]) {
    let lines: Vec<&str> = text.split('\n').collect();
    for d in ds {
        let Some(at) = d.location else { continue };
        assert!(
            at.line >= 1 && at.line <= lines.len(),
            "{d} lies outside the file's {} lines",
            lines.len()
        );
        let width = lines[at.line - 1].chars().count();
        assert!(
            at.column >= 1 && at.column <= width + 1,
            "{d} lies outside its line of {width} characters"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Arbitrary byte-range damage: never a panic, every location inside the file.
    #[test]
    fn damaged_scenes_never_panic_and_are_located_inside_the_file(
        edits in prop::collection::vec((any::<usize>(), 0usize..8, any::<usize>()), 1..4)
    ) {
        let text = mutate(&base_scene(), &edits);
        let dir = workspace().join("scenes");
        if let Err(LoadError::Invalid { diagnostics, .. }) =
            load_scene_str(&text, &dir.join("scene.json"), Some(&dir))
        {
            prop_assert!(!diagnostics.is_empty());
            check_locations(&text, &diagnostics);
        }
    }

    /// Values replaced by others, in well-formed JSON: never a panic, every problem located
    /// inside the file, in document order.
    #[test]
    fn wrong_values_are_each_reported(
        picks in prop::collection::vec((any::<usize>(), any::<usize>()), 1..5)
    ) {
        let mut text = base_scene();
        for &(n, which) in &picks {
            text = replace_value(&text, n, which);
        }
        let dir = workspace().join("scenes");
        match load_scene_str(&text, &dir.join("scene.json"), Some(&dir)) {
            Err(LoadError::Invalid { diagnostics, .. }) => {
                prop_assert!(!diagnostics.is_empty());
                check_locations(&text, &diagnostics);
                // Document order.
                let at: Vec<_> = diagnostics.iter().map(|d| d.location.map(|l| (l.line, l.column))).collect();
                let mut sorted = at.clone();
                sorted.sort();
                prop_assert_eq!(at, sorted);
            }
            Err(other) => prop_assert!(false, "{other}"),
            Ok(_) => {}
        }
    }
}
