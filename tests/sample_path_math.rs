//! No libm transcendental on the render's path: every sine, arctangent, exponential, logarithm
//! or power a render computes goes through lumo's own functions (`lumo::lanes::math`), whose
//! bits are the same on every CPU and at every lane width; libm's are not (glibc picks FMA
//! code paths by CPU, and other platforms' libms differ). This test scans the library's and the
//! command's code under `src/` for calls of the float methods that reach libm and fails on any
//! that is not on the allow-list below, each entry with its reason.
//!
//! Left out of the scan: comments, `#[cfg(test)]` items and the files of `#[cfg(test)]`
//! modules (tests use libm as a reference), and `src/lanes/`, which defines lumo's own
//! functions. A method call matches by name whatever the receiver's type, so lane code outside
//! `src/lanes/` calls lumo's lane functions by path (`F32s::sin_cos(x)`), which the scan does
//! not flag. `sqrt` is exactly rounded by IEEE-754 and is not in the list; `powi` is (its
//! result is not specified bit for bit: LLVM may expand it or call a helper).

mod common;

use std::path::{Path, PathBuf};

/// The float methods whose results libm (or an unspecified expansion) decides.
const TRANSCENDENTAL: [&str; 26] = [
    "sin", "cos", "tan", "sin_cos", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
    "asinh", "acosh", "atanh", "exp", "exp2", "exp_m1", "ln", "log", "log2", "log10", "ln_1p",
    "powf", "powi", "hypot", "cbrt",
];

/// Uses off the render's path: (file under `src/`, the call as written, the reason).
const ALLOWED: [(&str, &str, &str); 3] = [
    (
        "cli/converge.rs",
        ".log10(",
        "the axis ticks and decimals of the convergence report",
    ),
    (
        "cli/preview/server.rs",
        ".exp2(",
        "the preview's display exposure, applied to a copy of the image sent to the browser",
    ),
    (
        "bsdf/dielectric.rs",
        ".exp()",
        "node_eta: the η of the rough-dielectric albedo table's nodes, used only to compute the \
         table (compute_albedo), which is embedded",
    ),
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ is readable") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `text` without comments (`//` to the end of the line, string contents kept) and without
/// the items marked `#[cfg(test)]`; also the names of the `#[cfg(test)] mod name;` it declares.
fn code_of(text: &str) -> (String, Vec<String>) {
    let lines: Vec<&str> = text
        .lines()
        .map(|l| match l.find("//") {
            Some(i) if !l[..i].contains('"') => &l[..i],
            _ => l,
        })
        .collect();
    let mut out = Vec::new();
    let mut test_modules = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim() != "#[cfg(test)]" {
            out.push(lines[i]);
            i += 1;
            continue;
        }
        // Skip the attribute and the item after it: one line ending in ';', or up to the
        // brace that closes its first '{'.
        i += 1;
        while i < lines.len() && lines[i].trim_start().starts_with("#[") {
            i += 1;
        }
        if i >= lines.len() {
            break;
        }
        let first = lines[i].trim();
        if first.ends_with(';') && !first.contains('{') {
            if let Some(name) = first.split_whitespace().skip_while(|w| *w != "mod").nth(1) {
                test_modules.push(name.trim_end_matches(';').to_string());
            }
            i += 1;
            continue;
        }
        let mut depth = 0i32;
        let mut opened = false;
        while i < lines.len() {
            for c in lines[i].chars() {
                match c {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            i += 1;
            if opened && depth == 0 {
                break;
            }
        }
    }
    (out.join("\n"), test_modules)
}

/// Each call of a [`TRANSCENDENTAL`] method in `code`, as `.name(` with its line.
fn calls(code: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        for name in TRANSCENDENTAL {
            for method in [
                format!(".{name}("),
                format!("f32::{name}("),
                format!("f64::{name}("),
            ] {
                let mut from = 0;
                while let Some(at) = line[from..].find(&method) {
                    let end = from + at + method.len();
                    let call = if line[end..].starts_with(')') {
                        format!("{method})")
                    } else {
                        method.clone()
                    };
                    found.push((n + 1, call));
                    from = end;
                }
            }
        }
    }
    found
}

#[test]
fn no_libm_transcendental_is_reached_while_rendering() {
    let src = common::root().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut codes = Vec::new();
    let mut test_files = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).expect("readable source");
        let (code, test_modules) = code_of(&text);
        let dir = if f
            .file_name()
            .is_some_and(|n| n == "mod.rs" || n == "lib.rs")
        {
            f.parent().expect("a parent").to_path_buf()
        } else {
            f.with_extension("")
        };
        for m in test_modules {
            test_files.push(dir.join(format!("{m}.rs")));
            test_files.push(dir.join(&m).join("mod.rs"));
        }
        codes.push((f.clone(), code));
    }
    let mut unlisted = Vec::new();
    let mut used = [false; ALLOWED.len()];
    let mut scanned = 0;
    for (f, code) in &codes {
        let relative = f.strip_prefix(&src).expect("under src");
        let name = relative.to_string_lossy().replace('\\', "/");
        if name.starts_with("lanes/") || test_files.contains(f) {
            continue;
        }
        scanned += 1;
        for (line, call) in calls(code) {
            match ALLOWED
                .iter()
                .position(|(file, c, _)| *file == name && call.starts_with(c))
            {
                Some(k) => used[k] = true,
                None => unlisted.push(format!(
                    "src/{name}: {call} (line {line} of the scanned code)"
                )),
            }
        }
    }
    assert!(scanned > 50, "only {scanned} files scanned");
    assert!(
        unlisted.is_empty(),
        "libm transcendentals in the library's code (use lumo::lanes::math's, or list a use \
         off the render's path in ALLOWED with its reason):\n{}",
        unlisted.join("\n")
    );
    let stale: Vec<&str> = ALLOWED
        .iter()
        .zip(used)
        .filter(|(_, u)| !u)
        .map(|(a, _)| a.0)
        .collect();
    assert!(
        stale.is_empty(),
        "allow-list entries that match nothing: {stale:?}"
    );
}

/// The scan finds what it must and skips what it must.
#[test]
fn the_scan_finds_calls_and_skips_tests_and_comments() {
    let text = "fn f(x: f32) -> f32 {\n    x.sin() + f64::atan2(1.0, 2.0) as f32 // .cos()\n}\n\
                #[cfg(test)]\nmod helpers;\n\
                #[cfg(test)]\nfn g(x: f64) -> f64 {\n    x.exp()\n}\n\
                fn h(x: f64) -> f64 {\n    x.powi(2) + x.sqrt()\n}\n";
    let (code, modules) = code_of(text);
    assert_eq!(modules, ["helpers"]);
    let found: Vec<String> = calls(&code).into_iter().map(|(_, c)| c).collect();
    assert_eq!(found, [".sin()", "f64::atan2(", ".powi("]);
}
