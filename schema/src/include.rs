//! Scenes made of files: a top-level `"include": ["common/materials.json", …]` reads scene
//! fragments (files shaped like a scene with every top-level field optional, following
//! `scene-fragment.schema.json`) into the scene.
//!
//! - Named maps (`materials`, `textures`) merge by key, and every other top-level object
//!   (`camera`, `render`, `image`, `background`) counts as one key: a key that two included
//!   files define is an error, unless the including file defines it too (the includer wins).
//! - `objects` and `lights` concatenate: the included files' in include order, then the
//!   including file's own.
//! - File paths inside a fragment (textures, meshes, the environment image) are relative to the
//!   fragment; they are rewritten relative to the scene's folder.
//! - A fragment may include others; a file that includes itself, directly or not, is refused.
//! - `$schema` and `format_version` are each file's own and are not merged.
//!
//! Every problem of the composed scene is placed in the file that wrote the value, at its line
//! and column, with the chain of includes that brought that file in
//! ([`crate::Diagnostic::source`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use crate::diagnostic::{Diagnostic, Source};
use crate::locate::{line_col, locate, JsonPath, LineCol, PathSegment};

/// The top-level member naming the files to include.
pub const INCLUDE: &str = "include";

/// Top-level maps whose members merge by name.
const NAMED: [&str; 2] = ["materials", "textures"];
/// Top-level lists that concatenate.
const LISTS: [&str; 2] = ["objects", "lights"];
/// Top-level members that belong to each file and are not merged.
const OWN: [&str; 2] = ["$schema", "format_version"];
/// Most files one scene may read through includes.
const MAX_FRAGMENTS: usize = 1000;

/// Where a value of the composed scene was written.
#[derive(Debug, Clone)]
struct Origin {
    /// The file (the scene itself or a fragment).
    file: PathBuf,
    /// The value's path in that file.
    path: JsonPath,
    /// The includes that brought `file` in, innermost first (empty for the scene itself).
    chain: Vec<(PathBuf, LineCol)>,
}

/// One file's contribution, with its includes merged in.
#[derive(Debug, Default)]
struct Layer {
    single: BTreeMap<String, (Value, Origin)>,
    named: BTreeMap<String, BTreeMap<String, (Value, Origin)>>,
    lists: BTreeMap<String, Vec<(Value, Origin)>>,
}

/// A scene with its includes read: the composed JSON and where each part came from.
#[derive(Debug)]
pub struct Composed {
    /// The composed scene, without `include`.
    pub value: Value,
    /// Every fragment read, in the order first read.
    pub fragments: Vec<PathBuf>,
    /// The composed path of each part, and where it was written.
    origins: Vec<(JsonPath, Origin)>,
    /// The text of every file read, to place problems in it.
    texts: BTreeMap<PathBuf, String>,
    /// The scene file.
    file: PathBuf,
}

/// Whether a scene's JSON text has a top-level `include` (read without building the document).
pub fn has_includes(text: &str) -> bool {
    #[derive(serde::Deserialize)]
    struct Top {
        include: Option<serde::de::IgnoredAny>,
    }
    serde_json::from_str::<Top>(text).is_ok_and(|t| t.include.is_some())
}

/// Reads the includes of the scene `file` (whose text is `text`, already parsed as `value`);
/// relative include names and paths resolve against `base_dir`. Returns every problem of the
/// includes themselves (files missing or not JSON, cycles, keys defined twice).
pub fn compose(
    file: &Path,
    text: &str,
    value: Value,
    base_dir: &Path,
) -> Result<Composed, Vec<Diagnostic>> {
    compose_with(file, text, value, base_dir, &BTreeMap::new())
}

/// [`compose`], reading the files in `unsaved` (by canonical path) from there rather than from
/// disk: an editor's buffers.
pub fn compose_with(
    file: &Path,
    text: &str,
    value: Value,
    base_dir: &Path,
    unsaved: &BTreeMap<PathBuf, String>,
) -> Result<Composed, Vec<Diagnostic>> {
    let mut reader = Reader {
        unsaved,
        texts: BTreeMap::new(),
        fragments: Vec::new(),
        stack: Vec::new(),
        problems: Vec::new(),
    };
    reader.texts.insert(file.to_path_buf(), text.to_string());
    if let Ok(c) = std::fs::canonicalize(file) {
        reader.stack.push(c);
    }
    let layer = reader.layer(file, base_dir, Path::new(""), value, &[]);
    if !reader.problems.is_empty() {
        return Err(reader.problems);
    }
    let mut doc = Map::new();
    let mut origins = Vec::new();
    for (key, (v, o)) in layer.single {
        origins.push((JsonPath::root().key(&key), o));
        doc.insert(key, v);
    }
    for (map, members) in layer.named {
        let mut m = Map::new();
        for (key, (v, o)) in members {
            origins.push((JsonPath::root().key(&map).key(&key), o));
            m.insert(key, v);
        }
        doc.insert(map, Value::Object(m));
    }
    for (list, items) in layer.lists {
        let mut l = Vec::new();
        for (i, (v, o)) in items.into_iter().enumerate() {
            origins.push((JsonPath::root().key(&list).index(i), o));
            l.push(v);
        }
        doc.insert(list, Value::Array(l));
    }
    Ok(Composed {
        value: Value::Object(doc),
        fragments: reader.fragments,
        origins,
        texts: reader.texts,
        file: file.to_path_buf(),
    })
}

impl Composed {
    /// Where the value at `path` of the composed scene (or the part that holds it) was
    /// written: the file, the value's path in it and its line and column there.
    pub fn origin_of(&self, path: &JsonPath) -> Option<(PathBuf, JsonPath, LineCol)> {
        let (prefix, origin) = self
            .origins
            .iter()
            .filter(|(p, _)| path.0.starts_with(&p.0))
            .max_by_key(|(p, _)| p.0.len())?;
        let mut inner = origin.path.clone();
        inner.0.extend_from_slice(&path.0[prefix.0.len()..]);
        let at = locate(self.texts.get(&origin.file)?, &inner)?;
        Some((origin.file.clone(), inner, at))
    }

    /// `d`, found in the composed scene, placed where its value was written: its path and
    /// location in that file, and the includes that brought it in.
    pub fn place(&self, mut d: Diagnostic) -> Diagnostic {
        let found = self
            .origins
            .iter()
            .filter(|(p, _)| d.path.0.starts_with(&p.0))
            .max_by_key(|(p, _)| p.0.len());
        let Some((prefix, origin)) = found else {
            d.location = self.texts.get(&self.file).and_then(|t| locate(t, &d.path));
            return d;
        };
        let mut path = origin.path.clone();
        path.0.extend_from_slice(&d.path.0[prefix.0.len()..]);
        d.location = self.texts.get(&origin.file).and_then(|t| locate(t, &path));
        d.path = path;
        if origin.file != self.file {
            d.source = Some(Box::new(Source {
                file: origin.file.clone(),
                included_from: origin.chain.clone(),
            }));
        }
        d
    }
}

struct Reader<'a> {
    unsaved: &'a BTreeMap<PathBuf, String>,
    texts: BTreeMap<PathBuf, String>,
    fragments: Vec<PathBuf>,
    /// Canonical paths of the files being read, outermost first (to refuse cycles).
    stack: Vec<PathBuf>,
    problems: Vec<Diagnostic>,
}

impl Reader<'_> {
    /// A problem at `path` of `file` (brought in by `chain`).
    fn problem(
        &mut self,
        file: &Path,
        chain: &[(PathBuf, LineCol)],
        path: JsonPath,
        message: String,
        help: &str,
    ) {
        let mut d = Diagnostic::new(path, message).with_help(help);
        d.location = self.texts.get(file).and_then(|t| locate(t, &d.path));
        d.source = Some(Box::new(Source {
            file: file.to_path_buf(),
            included_from: chain.to_vec(),
        }));
        self.problems.push(d);
    }

    /// The layer of `file` (its JSON `value`): its includes, then its own members over them.
    /// `dir` is the file's folder; `rel` the same folder relative to the scene's (where its
    /// relative file paths are rewritten to).
    fn layer(
        &mut self,
        file: &Path,
        dir: &Path,
        rel: &Path,
        value: Value,
        chain: &[(PathBuf, LineCol)],
    ) -> Layer {
        let Value::Object(mut members) = value else {
            // Not an object: the scene's own reading reports it.
            return Layer::default();
        };
        let includes = members.remove(INCLUDE);
        let mut below = Layer::default();
        let mut conflicts = Vec::new();
        let names: Vec<(usize, String)> = match includes {
            None => Vec::new(),
            Some(Value::Array(items)) => {
                let mut names = Vec::new();
                for (i, item) in items.into_iter().enumerate() {
                    match item {
                        Value::String(s) => names.push((i, s)),
                        other => self.problem(
                            file,
                            chain,
                            JsonPath::root().key(INCLUDE).index(i),
                            format!(
                                "expected the name of a file to include, found {}",
                                crate::overrides::kind(&other)
                            ),
                            "write the file's path as a string, relative to this file",
                        ),
                    }
                }
                names
            }
            Some(other) => {
                self.problem(
                    file,
                    chain,
                    JsonPath::root().key(INCLUDE),
                    format!(
                        "expected an array of file names, found {}",
                        crate::overrides::kind(&other)
                    ),
                    "for example \"include\": [\"common/materials.json\"]",
                );
                Vec::new()
            }
        };
        for (i, name) in names {
            let at_path = JsonPath::root().key(INCLUDE).index(i);
            let at = self
                .texts
                .get(file)
                .and_then(|t| locate(t, &at_path))
                .unwrap_or(LineCol { line: 1, column: 1 });
            if let Some(fragment) = self.fragment(file, dir, &name, at_path, chain) {
                let mut inner_chain = vec![(file.to_path_buf(), at)];
                inner_chain.extend_from_slice(chain);
                let (path, value, canonical) = fragment;
                let frag_dir = crate::base_dir_of(&path);
                let frag_rel = match Path::new(&name).parent() {
                    Some(p) if Path::new(&name).is_absolute() => p.to_path_buf(),
                    Some(p) => rel.join(p),
                    None => rel.to_path_buf(),
                };
                self.stack.push(canonical);
                let layer = self.layer(&path, &frag_dir, &frag_rel, value, &inner_chain);
                self.stack.pop();
                merge_fragment(&mut below, layer, &mut conflicts);
            }
        }
        // This file's own members win over its includes.
        if !rel.as_os_str().is_empty() {
            rebase_paths(&mut members, rel);
        }
        let own_origin = |path: JsonPath| Origin {
            file: file.to_path_buf(),
            path,
            chain: chain.to_vec(),
        };
        let fragment = !chain.is_empty();
        // Keys two includes define are an error unless this file defines them too.
        for (first, second) in conflicts {
            let defined_here = match &second.path.0[..] {
                [PathSegment::Key(map), PathSegment::Key(name)] => members
                    .get(map)
                    .and_then(Value::as_object)
                    .is_some_and(|m| m.contains_key(name)),
                [PathSegment::Key(key)] => members.contains_key(key),
                _ => false,
            };
            if !defined_here {
                self.defined_twice(&first, &second);
            }
        }
        for (key, v) in members {
            if NAMED.contains(&key.as_str()) {
                if let Value::Object(m) = v {
                    let into = below.named.entry(key.clone()).or_default();
                    for (name, item) in m {
                        let o = own_origin(JsonPath::root().key(&key).key(&name));
                        into.insert(name, (item, o));
                    }
                    continue;
                }
            } else if LISTS.contains(&key.as_str()) {
                if let Value::Array(items) = v {
                    let into = below.lists.entry(key.clone()).or_default();
                    for (i, item) in items.into_iter().enumerate() {
                        into.push((item, own_origin(JsonPath::root().key(&key).index(i))));
                    }
                    continue;
                }
            } else if fragment && OWN.contains(&key.as_str()) {
                continue;
            }
            // Anything else (or a map or list of the wrong type, which the scene's reading
            // reports) is one value.
            let o = own_origin(JsonPath::root().key(&key));
            below.named.remove(&key);
            below.lists.remove(&key);
            below.single.insert(key, (v, o));
        }
        below
    }

    /// Reads the fragment `name` included by `file`: its path, JSON and canonical path, or
    /// `None` after reporting why it cannot be read.
    fn fragment(
        &mut self,
        file: &Path,
        dir: &Path,
        name: &str,
        at: JsonPath,
        chain: &[(PathBuf, LineCol)],
    ) -> Option<(PathBuf, Value, PathBuf)> {
        let path = dir.join(name);
        let canonical = match std::fs::canonicalize(&path) {
            Ok(c) => c,
            Err(e) => {
                self.problem(
                    file,
                    chain,
                    at,
                    format!("cannot read the included file `{}`: {e}", path.display()),
                    "include paths are relative to the file that names them",
                );
                return None;
            }
        };
        if let Some(start) = self.stack.iter().position(|c| *c == canonical) {
            let cycle: Vec<String> = self.stack[start..]
                .iter()
                .chain(std::iter::once(&canonical))
                .map(|c| c.display().to_string())
                .collect();
            self.problem(
                file,
                chain,
                at,
                format!("this include makes a cycle: {}", cycle.join(" → ")),
                "a file must not include itself, directly or through others",
            );
            return None;
        }
        if self.fragments.len() >= MAX_FRAGMENTS {
            self.problem(
                file,
                chain,
                at,
                format!("more than {MAX_FRAGMENTS} files are included"),
                "include fewer, larger fragments",
            );
            return None;
        }
        if !self.fragments.contains(&path) {
            self.fragments.push(path.clone());
        }
        let read = match self.unsaved.get(&canonical) {
            Some(t) => Ok(t.clone()),
            // Only a regular file of a scene's size (not a device that never ends).
            None => match std::fs::metadata(&canonical) {
                Ok(m) if !m.is_file() => Err(std::io::Error::other("not a regular file")),
                Ok(m) if m.len() > crate::MAX_SCENE_BYTES => Err(std::io::Error::other(format!(
                    "{} bytes, above the limit of {}",
                    m.len(),
                    crate::MAX_SCENE_BYTES
                ))),
                Ok(_) => std::fs::read_to_string(&path),
                Err(e) => Err(e),
            },
        };
        let text = match read {
            Ok(t) => t,
            Err(e) => {
                self.problem(
                    file,
                    chain,
                    at,
                    format!("cannot read the included file `{}`: {e}", path.display()),
                    "include paths are relative to the file that names them",
                );
                return None;
            }
        };
        let mut inner_chain = vec![(
            file.to_path_buf(),
            self.texts
                .get(file)
                .and_then(|t| locate(t, &at))
                .unwrap_or(LineCol { line: 1, column: 1 }),
        )];
        inner_chain.extend_from_slice(chain);
        self.texts.insert(path.clone(), text);
        let text = &self.texts[&path];
        let value: Value = match serde_json::from_str(text) {
            Ok(v) => v,
            Err(e) => {
                let (message, _) = crate::load::explain(&e.to_string());
                let location = if e.line() > 0 {
                    LineCol {
                        line: e.line(),
                        column: e.column().max(1),
                    }
                } else {
                    line_col(text, 0)
                };
                let mut d = Diagnostic::new(JsonPath::root(), message);
                d.location = Some(location);
                d.source = Some(Box::new(Source {
                    file: path.clone(),
                    included_from: inner_chain,
                }));
                self.problems.push(d);
                return None;
            }
        };
        if !value.is_object() {
            self.problem(
                &path,
                &inner_chain,
                JsonPath::root(),
                format!(
                    "a scene fragment is a JSON object, found {}",
                    crate::overrides::kind(&value)
                ),
                "a fragment is shaped like a scene, every member optional",
            );
            return None;
        }
        Some((path, value, canonical))
    }

    /// Reports a key that two included files define, at its second definition.
    fn defined_twice(&mut self, first: &Origin, second: &Origin) {
        let first_at = self
            .texts
            .get(&first.file)
            .and_then(|t| locate(t, &first.path))
            .map(|l| format!(":{}:{}", l.line, l.column))
            .unwrap_or_default();
        self.problem(
            &second.file,
            &second.chain,
            second.path.clone(),
            format!(
                "`{}` is also defined in {}{first_at}",
                second.path,
                first.file.display()
            ),
            "define it in one included file only, or in the including file to choose",
        );
    }
}

/// Adds an included file's layer to the includes read so far. A key both define keeps its
/// first definition and is listed in `conflicts` (first, second).
fn merge_fragment(into: &mut Layer, layer: Layer, conflicts: &mut Vec<(Origin, Origin)>) {
    for (key, (v, o)) in layer.single {
        if let Some((_, first)) = into.single.get(&key) {
            conflicts.push((first.clone(), o));
        } else {
            into.single.insert(key, (v, o));
        }
    }
    for (map, members) in layer.named {
        let target = into.named.entry(map).or_default();
        for (key, (v, o)) in members {
            if let Some((_, first)) = target.get(&key) {
                conflicts.push((first.clone(), o));
            } else {
                target.insert(key, (v, o));
            }
        }
    }
    for (list, items) in layer.lists {
        into.lists.entry(list).or_default().extend(items);
    }
}

/// Rewrites the relative file paths of a fragment's members (textures, meshes, the environment
/// image) to be relative to the scene's folder: `rel` joined with them.
fn rebase_paths(members: &mut Map<String, Value>, rel: &Path) {
    let rebase = |v: &mut Value| {
        if let Value::String(s) = v {
            if !Path::new(s.as_str()).is_absolute() {
                let joined = rel.join(s.as_str());
                // Forward slashes, as scene files write paths on every system, and a folder
                // followed by `..` dropped (`common/../textures/a.png` is `textures/a.png`), so
                // that the composed scene names each file as a scene written by hand would.
                let mut parts: Vec<String> = Vec::new();
                for c in joined.components() {
                    let part = c.as_os_str().to_string_lossy().into_owned();
                    let is_folder = parts
                        .last()
                        .is_some_and(|p| !matches!(p.as_str(), ".." | "." | "/"));
                    if c == std::path::Component::ParentDir && is_folder {
                        parts.pop();
                    } else if c != std::path::Component::CurDir {
                        parts.push(part);
                    }
                }
                *s = parts.join("/");
            }
        }
    };
    if let Some(Value::Object(textures)) = members.get_mut("textures") {
        for t in textures.values_mut() {
            if let Some(f) = t.get_mut("file") {
                rebase(f);
            }
        }
    }
    if let Some(Value::Array(objects)) = members.get_mut("objects") {
        for o in objects {
            if let Some(source) = o.get_mut("mesh").and_then(|m| m.get_mut("source")) {
                if let Some(f) = source.get_mut("obj") {
                    rebase(f);
                }
                if let Some(f) = source.get_mut("gltf").and_then(|g| g.get_mut("file")) {
                    rebase(f);
                }
            }
        }
    }
    if let Some(image) = members
        .get_mut("background")
        .and_then(|b| b.get_mut("image"))
    {
        rebase(image);
    }
}

/// The schema file name of fragments; a file whose `$schema` ends with it is a fragment.
pub const FRAGMENT_SCHEMA: &str = "scene-fragment.schema.json";

/// Whether a JSON text is a scene fragment: its `$schema` names the fragment schema.
pub fn is_fragment(text: &str) -> bool {
    #[derive(serde::Deserialize)]
    struct Top {
        #[serde(rename = "$schema")]
        schema: Option<String>,
    }
    serde_json::from_str::<Top>(text)
        .ok()
        .and_then(|t| t.schema)
        .is_some_and(|s| s.ends_with(FRAGMENT_SCHEMA))
}

/// Whether a problem is about a name another file may define (a fragment checked on its own
/// may use the materials and textures of the files next to it).
pub(crate) fn names_another_file(d: &Diagnostic) -> bool {
    d.message.starts_with("unknown material `") || d.message.starts_with("unknown texture `")
}
