//! Recursive-descent parser for the legacy grammar (shared/legacy-format.md §2–§6).
//!
//! Fixed-order blocks (camera, lights, geometry) are strict; `Material` and `Background` are
//! loose. Every deviation is a [`Problem`] with the span of the offending token, what was
//! expected and what was found, and a did-you-mean suggestion for misspelt keywords.

mod background;
mod camera;
mod curve;
mod group;
mod lights;
mod materials;
mod objects;
mod tokens;
mod transform;

use lumo_schema::did_you_mean;

use super::ast::*;
use super::error::Problem;
use super::lexer::{Lexer, Span, Token};

/// Deepest nesting of groups, transforms and curves accepted (the original has no limit; a
/// limit keeps hostile input from overflowing the stack).
pub const MAX_DEPTH: usize = 64;
/// Largest `numObjects`, `numMaterials` or `numLights`, and most objects in one file.
pub const MAX_COUNT: i64 = 1_000_000;
/// Most control points in one curve.
pub const MAX_CONTROL_POINTS: usize = 100_000;

const TOP_BLOCKS: &[&str] = &[
    "PerspectiveCamera",
    "DepthCamera",
    "LensCamera",
    "Background",
    "Lights",
    "Materials",
    "Group",
];
/// Keywords some student dialects added that lumo cannot represent, with the reason.
fn unsupported(word: &str) -> Option<&'static str> {
    Some(match word {
        "DiskLight" => "`DiskLight` (zhanglbthu's disk area light) cannot be represented: lumo has no disk primitive; model the light as an emissive Sphere or Triangle instead",
        "AreaLight" | "SpotLight" => "this light of Chenyu-Yang-2000's dialect is not supported; use an emissive object (area light) instead",
        "FinitePlane" => "`FinitePlane` (Chenyu-Yang-2000) is not supported; use two Triangles",
        "SphereMoving" => "`SphereMoving` (motion blur, 1unx1) cannot be represented: lumo renders a single instant",
        "BRDF" => "`BRDF` (Chenyu-Yang-2000's 7-number material) is not supported; use `type`, `shininess` and `refr`",
        "bump" => "bump maps cannot be represented in lumo",
        "time1" | "time2" => "the shutter interval (`time1`/`time2`, motion blur) cannot be represented: lumo renders a single instant",
        _ => return None,
    })
}

/// Parses a whole legacy file. Returns the document or the first problem.
pub fn parse_document(src: &str) -> Result<Document, Problem> {
    let mut p = Parser {
        lx: Lexer::new(src),
        depth: 0,
        current_material: None,
        num_materials: None,
        material_index_used: false,
        objects: 0,
        doc: Document::default(),
    };
    p.document()?;
    Ok(p.doc)
}

struct Parser<'a> {
    lx: Lexer<'a>,
    depth: usize,
    /// The global "current material" set by `MaterialIndex` (parse order, no scoping).
    current_material: Option<usize>,
    /// Number of materials in the current `Materials` block.
    num_materials: Option<usize>,
    material_index_used: bool,
    objects: i64,
    doc: Document,
}

fn describe(t: Option<Token<'_>>) -> String {
    match t {
        Some(t) => format!("`{}`", shorten(t.text)),
        None => "the end of the file".to_string(),
    }
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        let head: String = s.chars().take(37).collect();
        format!("{head}...")
    } else {
        s.to_string()
    }
}

fn suggestion(word: &str, candidates: &[&'static str]) -> Option<String> {
    did_you_mean(word, candidates.iter().copied()).map(|s| format!("did you mean `{s}`?"))
}

impl Parser<'_> {
    fn document(&mut self) -> Result<(), Problem> {
        while let Some(t) = self.lx.peek() {
            match t.text {
                "PerspectiveCamera" | "DepthCamera" | "LensCamera" => self.replace_block(
                    t.span,
                    "a second camera block replaces the first (later blocks win)",
                    |doc| &mut doc.camera,
                    Self::camera,
                )?,
                "Background" => self.replace_block(
                    t.span,
                    "a second Background block replaces the first (later blocks win)",
                    |doc| &mut doc.background,
                    Self::background,
                )?,
                "Lights" => self.replace_block(
                    t.span,
                    "a second Lights block replaces the first (later blocks win)",
                    |doc| &mut doc.lights,
                    Self::lights,
                )?,
                "Materials" => {
                    if self.material_index_used {
                        return Err(Problem::at(t.span, "a Materials block after a MaterialIndex is not supported")
                            .help("the original keeps pointers into the replaced block; define all materials once, before the first Group"));
                    }
                    self.replace_block(
                        t.span,
                        "a second Materials block replaces the first (later blocks win)",
                        |doc| &mut doc.materials,
                        Self::materials,
                    )?;
                    self.num_materials = self.doc.materials.as_ref().map(|m| m.materials.len());
                }
                "Group" => self.replace_block(
                    t.span,
                    "a second top-level Group replaces the first as the scene root (later blocks win)",
                    |doc| &mut doc.root,
                    Self::object,
                )?,
                word => {
                    let mut p = Problem::at(t.span, format!("expected a top-level block (a camera, Background, Lights, Materials or Group), found `{}`", shorten(word)));
                    if let Some(s) = suggestion(word, TOP_BLOCKS) {
                        p = p.help(s);
                    } else if word.starts_with('#') || word.starts_with("//") {
                        p = p.help("the legacy format has no comments");
                    } else if let Some(why) = unsupported(word) {
                        p = p.help(why);
                    }
                    return Err(p);
                }
            }
        }
        Ok(())
    }
    /// Parses a top-level block that the file may give more than once: a later block replaces
    /// the earlier one (the original's behaviour), and `warning` is given at the keyword `span`
    /// of every block after the first. `slot` is where the block lives in the document.
    fn replace_block<T>(
        &mut self,
        span: Span,
        warning: &str,
        slot: fn(&mut Document) -> &mut Option<T>,
        parse: fn(&mut Self) -> Result<T, Problem>,
    ) -> Result<(), Problem> {
        if slot(&mut self.doc).is_some() {
            self.warn(span, warning);
        }
        let block = parse(self)?;
        *slot(&mut self.doc) = Some(block);
        Ok(())
    }
}

/// Checks a declared count (`numLights 2`, the `Located` number after `field`) against the `found`
/// items of kind `item` the `holder` ("block", "group") has; `note` ends the suggested fix.
fn check_count(
    declared: Located<i64>,
    found: usize,
    field: &str,
    holder: &str,
    item: &str,
    note: &str,
) -> Result<(), Problem> {
    if found as i64 == declared.value {
        return Ok(());
    }
    Err(Problem::at(
        declared.span,
        format!(
            "{field} is {} but the {holder} has {found} {item}{}",
            declared.value,
            plural(found)
        ),
    )
    .help(format!("write `{field} {found}`{note}")))
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}
