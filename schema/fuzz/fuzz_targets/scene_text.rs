//! Fuzzes reading a scene file with every problem reported (`lumo validate`): for any text,
//! loading returns a scene or a list of problems, never panics, and every problem lies inside
//! the file (a line that exists, a column at most one past its end). Seed corpus: the example
//! scenes and `tests/invalid/` (the command is in the README, under "Scene files").
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use lumo_schema::{load_scene_str, LoadError};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // No base folder: file-existence checks are skipped, everything else runs.
    if let Err(LoadError::Invalid { diagnostics, .. }) =
        load_scene_str(text, Path::new("fuzz.json"), None)
    {
        assert!(!diagnostics.is_empty());
        let lines: Vec<&str> = text.split('\n').collect();
        for d in &diagnostics {
            let Some(at) = d.location else { continue };
            assert!(at.line >= 1 && at.line <= lines.len(), "{d}");
            let width = lines[at.line - 1].chars().count();
            assert!(at.column >= 1 && at.column <= width + 1, "{d}");
        }
        let mut order: Vec<_> = diagnostics
            .iter()
            .map(|d| d.location.map(|l| (l.line, l.column)))
            .collect();
        let before = order.clone();
        order.sort();
        assert_eq!(order, before, "problems come in document order");
    }
});
