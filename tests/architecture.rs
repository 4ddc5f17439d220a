//! The library's modules import one another in one direction, as its data flows (`src/lib.rs`):
//! no module of `src/` reaches itself through the modules it imports. A new import that closes a
//! circle fails here, naming the circle. Unit-test modules (`#[cfg(test)] mod tests` at the end
//! of a file) may use any module.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The top-level module of a file under `src/` (`load` for `src/load/assets.rs`).
fn module_of(relative: &Path) -> String {
    let first = relative
        .components()
        .next()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .unwrap_or_default();
    first.trim_end_matches(".rs").to_string()
}

/// The code of a file without its comments and its unit-test module.
fn code_of(text: &str) -> String {
    let body = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    body.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level modules `code` names as `crate::NAME`, or inside `use crate::{…}`.
fn imports(code: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let word = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            // Only the first path segment of each item in the group is a module of the crate.
            let mut depth = 0;
            let mut item_start = true;
            for (j, c) in group[..end].char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && (c.is_alphanumeric() || c == '_') => {
                        found.insert(word(&group[j..]));
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else {
            found.insert(word(rest));
        }
    }
    found.retain(|m| modules.contains(m));
    found
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ is readable") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_module_of_the_library_imports_itself_through_others() {
    let src = common::root().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    // The binary (`main.rs`, `cli/`) sits on top of the library; `lib.rs` only declares.
    let outside = ["main", "lib", "cli"];
    let modules: BTreeSet<String> = files
        .iter()
        .map(|f| module_of(f.strip_prefix(&src).expect("under src")))
        .filter(|m| !outside.contains(&m.as_str()))
        .collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let module = module_of(f.strip_prefix(&src).expect("under src"));
        if outside.contains(&module.as_str()) {
            continue;
        }
        let text = std::fs::read_to_string(f).expect("readable source");
        let mut used = imports(&code_of(&text), &modules);
        used.remove(&module);
        graph.entry(module).or_default().extend(used);
    }
    // The circles the data flow forbids by name, then any circle at all.
    assert!(
        !graph["scene"].contains("load"),
        "the scene build imports the loader"
    );
    assert!(
        !graph["load"].contains("partial_film"),
        "the loader imports partial films"
    );
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) {
        if let Some(at) = path.iter().position(|p| p == m) {
            panic!("import circle: {} → {m}", path[at..].join(" → "));
        }
        if done.contains(m) {
            return;
        }
        path.push(m.to_string());
        for next in graph.get(m).into_iter().flatten() {
            visit(next, graph, path, done);
        }
        path.pop();
        done.insert(m.to_string());
    }
    let mut done = BTreeSet::new();
    for m in graph.keys() {
        visit(m, &graph, &mut Vec::new(), &mut done);
    }
    assert!(graph.len() > 15, "only {} modules found", graph.len());
}

/// The checker sees the imports it must: a circle written into sources is found.
#[test]
fn the_import_scan_finds_grouped_and_inline_imports() {
    let modules: BTreeSet<String> = ["light", "light_tree", "math", "render"]
        .map(String::from)
        .into();
    let code = code_of(
        "use crate::{light::Light, math::{Vec3, Rgb}};\nfn f() { crate::render::go(); } // crate::light_tree\n#[cfg(test)]\nmod tests { use crate::light_tree; }",
    );
    let found = imports(&code, &modules);
    assert_eq!(found, ["light", "math", "render"].map(String::from).into());
}
