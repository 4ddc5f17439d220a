//! The legacy text scene format of the Tsinghua / MIT 6.837 course ray tracer, and the
//! path-tracing dialects students added to it, in both directions.
//!
//! - [`import`] reads a `.txt` scene into a [`lumo_schema::Scene`], with warnings for everything
//!   it had to interpret, and compiler-style errors ([`LegacyError`]) for everything else.
//! - [`export`] writes a scene back as legacy text, or lists everything the format cannot say.
//!
//! The grammar is described in `shared/legacy-format.md`; every mapping rule and every choice
//! made where that description says "ambiguous" is in `docs/legacy.md`.

pub mod ast;
mod error;
mod export;
mod import;
pub mod lexer;
mod material;
pub mod math;
mod parser;

use std::path::{Path, PathBuf};

pub use error::{ExportError, LegacyError, Problem};
pub use export::export;
pub use import::{material_name, uniform_knots, DEFAULT_BACKGROUND};
pub use material::GLOSSY_ALPHA;
pub use parser::{MAX_CONTROL_POINTS, MAX_COUNT, MAX_DEPTH};

/// Largest legacy scene file accepted, in bytes (64 MiB): real ones are a few kilobytes, and
/// meshes live in OBJ files.
pub const MAX_LEGACY_BYTES: u64 = 64 << 20;

/// What to do with the file's `Lights` block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightsPolicy {
    /// Keep the punctual lights.
    Keep,
    /// Drop them (light the scene by emissive materials only).
    Drop,
    /// Keep them when no object has an emissive material (the original ray caster), drop them
    /// otherwise (the path-tracing dialects, which ignore the block).
    #[default]
    Auto,
}

lumo_schema::keyword_enum!(LightsPolicy, "keep" => LightsPolicy::Keep, "drop" => LightsPolicy::Drop, "auto" => LightsPolicy::Auto);

/// How to import.
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// What to do with the `Lights` block. Default [`LightsPolicy::Auto`].
    pub lights: LightsPolicy,
    /// The folder the resulting JSON will be written to: file paths (OBJ meshes, textures) are
    /// written relative to it. `None`: relative to the legacy scene's own folder.
    pub output_dir: Option<PathBuf>,
}

/// An imported scene and what the importer had to tell about it.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The scene (already validated).
    pub scene: lumo_schema::Scene,
    /// Warnings, each `file:line:col: warning: …` (or `file: warning: …`).
    pub warnings: Vec<String>,
}

/// Reads the legacy scene at `path` and converts it. Relative file names inside are looked up
/// in the scene's folder, or first in the folder above it when the scene lives in `testcases/`
/// (the course programs ran from the project root).
pub fn import(path: &Path, options: &ImportOptions) -> Result<Imported, LegacyError> {
    let io = |source| LegacyError::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.len() > MAX_LEGACY_BYTES {
        return Err(LegacyError::invalid(
            path,
            "",
            Problem::whole(format!(
                "the file is {} bytes, above the limit of {MAX_LEGACY_BYTES} for a legacy scene",
                meta.len()
            )),
        ));
    }
    let bytes = std::fs::read(path).map_err(io)?;
    let text = decode(path, &bytes)?;
    import_str(&text, path, options)
}

/// Decodes the file as UTF-8 (legacy files are ASCII), or reports where it is not.
fn decode(path: &Path, bytes: &[u8]) -> Result<String, LegacyError> {
    match std::str::from_utf8(bytes) {
        Ok(t) => Ok(t.to_string()),
        Err(e) => {
            let at = e.valid_up_to();
            let text = String::from_utf8_lossy(bytes).into_owned();
            let prefix = &bytes[..at];
            let line = prefix.iter().filter(|b| **b == b'\n').count() as u32 + 1;
            let line_start = prefix
                .iter()
                .rposition(|b| *b == b'\n')
                .map(|i| i + 1)
                .unwrap_or(0);
            let col = String::from_utf8_lossy(&prefix[line_start..])
                .chars()
                .count() as u32
                + 1;
            // Offsets in the lossy text: the valid prefix is unchanged.
            let span = lexer::Span {
                start: at,
                end: (at + 1).min(text.len()),
                line,
                col,
            };
            Err(LegacyError::invalid(
                path,
                &text,
                Problem::at(span, "the file is not valid UTF-8 text")
                    .help("legacy scenes are plain ASCII"),
            ))
        }
    }
}

/// Converts legacy scene `text`; `path` names the file in messages and locates relative file
/// names (it need not exist).
pub fn import_str(
    text: &str,
    path: &Path,
    options: &ImportOptions,
) -> Result<Imported, LegacyError> {
    let fail = |p: Problem| LegacyError::invalid(path, text, p);
    let doc = parser::parse_document(text).map_err(fail)?;
    let scene_dir = lumo_schema::base_dir_of(path);
    let mut search = vec![scene_dir.clone()];
    if scene_dir.file_name().is_some_and(|n| n == "testcases") {
        if let Some(parent) = scene_dir.parent() {
            let parent = if parent.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                parent.to_path_buf()
            };
            search.insert(0, parent);
        }
    }
    let out_dir = options
        .output_dir
        .clone()
        .unwrap_or_else(|| scene_dir.clone());
    let mut raw_warnings = Vec::new();
    let mut ctx = import::Context {
        search,
        out_dir: out_dir.clone(),
        lights: options.lights,
        warnings: &mut raw_warnings,
    };
    let (scene, origins) = import::to_scene(&doc, &mut ctx).map_err(fail)?;

    // Safety net: the converted scene must pass lumo's own checks; point any failure back at
    // the legacy text it came from.
    let base = out_dir.is_dir().then_some(out_dir.as_path());
    let diagnostics = lumo_schema::validate(&scene, base);
    if let Some(d) = diagnostics.first() {
        let where_ = d.path.to_string();
        let span = locate(&where_, &origins);
        let mut p = Problem {
            span,
            message: format!("the converted scene is invalid at {where_}: {}", d.message),
            help: d.help.clone(),
        };
        if diagnostics.len() > 1 {
            p.message
                .push_str(&format!(" (and {} more problem(s))", diagnostics.len() - 1));
        }
        return Err(fail(p));
    }

    let warnings = raw_warnings
        .into_iter()
        .map(|(span, msg)| match span {
            Some(s) => format!("{}:{}:{}: warning: {msg}", path.display(), s.line, s.col),
            None => format!("{}: warning: {msg}", path.display()),
        })
        .collect();
    Ok(Imported { scene, warnings })
}

/// The legacy span a JSON path of the converted scene came from.
fn locate(path: &str, o: &import::Origins) -> Option<lexer::Span> {
    let index = |rest: &str| {
        rest.strip_prefix('[')
            .and_then(|r| r.split(']').next())
            .and_then(|n| n.parse::<usize>().ok())
    };
    let path = path.trim_start_matches('$').trim_start_matches('.');
    if let Some(rest) = path.strip_prefix("objects") {
        return index(rest).and_then(|i| o.objects.get(i).copied());
    }
    if let Some(rest) = path.strip_prefix("lights") {
        return index(rest).and_then(|i| o.lights.get(i).copied());
    }
    if let Some(rest) = path.strip_prefix("materials.") {
        let name = rest.split(['.', '[']).next().unwrap_or("");
        return o.materials.get(name).copied();
    }
    if path.starts_with("camera") || path.starts_with("image") {
        return o.camera;
    }
    None
}

/// Parses legacy text into its document without mapping it (for tools and fuzzing).
pub fn parse(text: &str) -> Result<ast::Document, Problem> {
    parser::parse_document(text)
}
