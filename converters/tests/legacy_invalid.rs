//! Bad legacy input of every kind gives a precise, located error: each file in
//! `tests/legacy-invalid/` is listed in `expected.tsv` with the line:column of the error, a
//! fragment of its message and of its help.

mod common;

use std::collections::BTreeSet;
use std::path::Path;

use lumo_converters::legacy::{self, ImportOptions};

#[test]
fn every_invalid_file_fails_where_expected() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("legacy-invalid");
    let table = std::fs::read_to_string(dir.join("expected.tsv")).expect("expected.tsv");
    let mut listed = BTreeSet::new();
    for line in table
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
    {
        let cols: Vec<&str> = line.split('\t').collect();
        assert_eq!(cols.len(), 4, "bad line in expected.tsv: {line}");
        let (file, at, message, help) = (cols[0], cols[1], cols[2], cols[3]);
        listed.insert(file.to_string());
        let path = dir.join(file);
        let err = match legacy::import(&path, &ImportOptions::default()) {
            Ok(_) => panic!("{file}: imported without error"),
            Err(e) => e,
        };
        let want = if at == "-" {
            None
        } else {
            let (l, c) = at.split_once(':').expect("line:col");
            Some((l.parse().unwrap(), c.parse().unwrap()))
        };
        assert_eq!(err.location(), want, "{file}: wrong location\n{err}");
        assert!(
            err.message().contains(message),
            "{file}: message {:?} lacks {message:?}",
            err.message()
        );
        if help != "-" {
            let h = err.help().unwrap_or("");
            assert!(h.contains(help), "{file}: help {h:?} lacks {help:?}");
        }
        // The rendered report names the file and location and shows the line with a caret.
        let report = err.to_string();
        let header = match want {
            Some((l, c)) => format!("{}:{l}:{c}: error: ", path.display()),
            None => format!("{}: error: ", path.display()),
        };
        assert!(
            report.starts_with(&header),
            "{file}: report header\n{report}"
        );
        if want.is_some() {
            assert!(report.contains("╰── here"), "{file}: no caret in\n{report}");
        }
    }
    let on_disk: BTreeSet<String> = common::txt_files(&dir)
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        on_disk, listed,
        "every .txt in legacy-invalid/ must be listed in expected.tsv and vice versa"
    );
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let depth = 10_000;
    let mut text = String::from(
        "PerspectiveCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 angle 40 width 8 height 8 }\n",
    );
    for _ in 0..depth {
        text.push_str("Group { numObjects 1 ");
    }
    let err =
        legacy::import_str(&text, Path::new("deep.txt"), &ImportOptions::default()).unwrap_err();
    assert!(err.message().contains("nesting deeper than"), "{err}");
    let mut text = String::from("Group { numObjects 1 ");
    for _ in 0..depth {
        text.push_str("Transform { Translate 1 0 0 ");
    }
    let err =
        legacy::import_str(&text, Path::new("deep.txt"), &ImportOptions::default()).unwrap_err();
    assert!(err.message().contains("nesting deeper than"), "{err}");
}

#[test]
fn huge_counts_are_refused_before_allocating() {
    let err = legacy::import_str(
        "Materials { numMaterials 99999999999 }",
        Path::new("n.txt"),
        &ImportOptions::default(),
    )
    .unwrap_err();
    assert_eq!(err.location(), Some((1, 26)), "{err}");
    assert!(err.message().contains("out of range"), "{err}");
}

#[test]
fn invalid_utf8_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.txt");
    std::fs::write(&path, b"Background {\n  color 0 \xff 0 }\n").unwrap();
    let err = legacy::import(&path, &ImportOptions::default()).unwrap_err();
    assert_eq!(err.location(), Some((2, 11)), "{err}");
}
