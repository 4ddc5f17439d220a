//! Loading any supported input into a validated scene and the data it references.
//!
//! [`load`] is the one way in: it reads a lumo scene (`.json`), a legacy text scene (`.txt`) or
//! a glTF file (`.gltf`/`.glb`), validates it, and reads every asset it references (OBJ and
//! glTF meshes, texture images) into plain arrays ([`Assets`]), recording each file it read.
//! [`Loaded::build`] then turns it into the renderer's scene graph without touching a file.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let loaded = lumo::load("scenes/cornell.json", &lumo::LoadOptions::default())?;
//! let (scene, _warnings) = loaded.build()?;
//! let (image, _stats) = lumo::render::render(&scene, &Default::default());
//! lumo::output::write_image(&image, "cornell.png".as_ref(), lumo::output::ToneMap::Clamp)?;
//! # Ok(())
//! # }
//! ```

mod assets;
mod gltf;
mod obj;

use std::path::{Path, PathBuf};

use std::sync::Arc;

use lumo_converters::gltf::{CameraChoice, GltfFile, ImportOptions};
use lumo_converters::legacy;
use lumo_schema as schema;
use lumo_schema::Validated;

pub use crate::assets::{Assets, MeshData, TextureImage};
pub use assets::AssetError;

/// The kinds of input lumo reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// lumo scene JSON.
    Json,
    /// The course's legacy text scene format (`.txt`), converted on the fly.
    Legacy,
    /// glTF 2.0 (.gltf or .glb).
    Gltf,
}

/// Options for inputs that need them.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Legacy scenes: keep, drop, or decide per scene whether to use the `Lights` block.
    pub lights: legacy::LightsPolicy,
    /// glTF: which camera to use (`--camera NAME|INDEX`).
    pub camera: Option<CameraChoice>,
    /// glTF: the folder the scene's relative paths should be relative to (where a converted
    /// scene file will be written). Default: the glTF file's folder.
    pub scene_dir: Option<PathBuf>,
    /// Changes from outside the file (`--patch`, `--set` and their shorthands), applied to the
    /// scene before it is validated, so that everything downstream (assets read, the content
    /// hash of partial films, bundles, conversions) sees the composed scene.
    pub composition: schema::compose::Composition,
    /// Do not start hashing a glTF input while it is parsed (for jobs that take the scene's
    /// content hash only when a film is asked for, [`crate::job::JobSettings::defer_scene_hash`]:
    /// hashing a 31 MB `.glb` costs about 20 ms of a core, beside a scene build that wants
    /// every core).
    pub defer_input_hash: bool,
}

/// Why an input could not be loaded. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// A file could not be read (missing, unreadable): not the input's fault.
    #[error("{message}")]
    Io {
        /// The file that could not be read.
        file: PathBuf,
        /// The message, naming the file.
        message: String,
    },
    /// The scene is invalid: every problem, located by line, column and JSON path.
    #[error("{}", report(file, diagnostics))]
    Invalid {
        /// The scene file (or a label such as `<dict>`).
        file: PathBuf,
        /// Every problem found, in document order.
        diagnostics: Vec<schema::Diagnostic>,
    },
    /// The input is invalid in a way that has no JSON location (a legacy or glTF file that does
    /// not parse, an asset that does not decode): the message says where and how to fix it.
    #[error("{message}")]
    Rejected {
        /// The input file.
        file: PathBuf,
        /// The message, naming the file.
        message: String,
    },
}

/// The report of a scene's diagnostics, as `lumo validate` prints it (without the final newline).
fn report(file: &Path, diagnostics: &[schema::Diagnostic]) -> String {
    let report = schema::Report {
        file: file.to_path_buf(),
        diagnostics: diagnostics.to_vec(),
    };
    report.to_string().trim_end().to_string()
}

impl LoadError {
    /// The input file the error is about.
    pub fn file(&self) -> &Path {
        match self {
            LoadError::Io { file, .. }
            | LoadError::Invalid { file, .. }
            | LoadError::Rejected { file, .. } => file,
        }
    }

    /// Whether a file could not be read (rather than being invalid).
    pub fn is_io(&self) -> bool {
        matches!(self, LoadError::Io { .. })
    }

    /// The located problems of an invalid scene (empty for the other kinds).
    pub fn diagnostics(&self) -> &[schema::Diagnostic] {
        match self {
            LoadError::Invalid { diagnostics, .. } => diagnostics,
            _ => &[],
        }
    }

    fn rejected(file: &Path, message: impl Into<String>) -> LoadError {
        LoadError::Rejected {
            file: file.to_path_buf(),
            message: message.into(),
        }
    }

    fn io(file: &Path, message: impl Into<String>) -> LoadError {
        LoadError::Io {
            file: file.to_path_buf(),
            message: message.into(),
        }
    }
}

/// A scene description read from any supported input, validated, before its assets are read.
#[derive(Debug, Clone)]
pub struct SceneFile {
    /// The validated scene description.
    pub scene: Validated<schema::Scene>,
    /// Folder relative paths in `scene` resolve against.
    pub base_dir: PathBuf,
    /// Non-fatal problems found while reading, without the file name.
    pub warnings: Vec<String>,
    /// The input file itself (its assets are listed by [`Assets::files`]).
    pub file: PathBuf,
    /// What kind of input it was.
    pub kind: InputKind,
    /// The scene fragments the input includes (see `lumo_schema::include`), in the order
    /// first read.
    pub fragments: Vec<PathBuf>,
}

impl SceneFile {
    /// Applies command-line style overrides (sample count, image size, …) to the scene and
    /// validates the result; an override that makes the scene invalid is an error naming the
    /// file.
    pub fn edit(&mut self, change: impl FnOnce(&mut schema::Scene)) -> Result<(), LoadError> {
        let file = self.file.clone();
        self.scene
            .edit(Some(&self.base_dir), change)
            .map_err(|d| invalid_report(&file, d))
    }
}

/// A scene read and validated, with every asset it references in memory.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The scene description and where it came from.
    pub description: SceneFile,
    /// The meshes and images the scene references.
    pub assets: Assets,
    /// A glTF input file's SHA-256, begun when loading began (see [`Loaded::content_hash`]).
    input_hash: EarlyHash,
}

/// The SHA-256 of a file, computed on a thread of its own from the moment the loader knows the
/// file: a big `.glb` given as the input (31 MB: about 20 ms of hashing) is then hashed while
/// the loader parses it, alone on one core, instead of beside the scene build, which wants both.
#[derive(Debug, Clone, Default)]
struct EarlyHash(Option<Arc<EarlyHashState>>);

#[derive(Debug)]
struct EarlyHashState {
    path: PathBuf,
    running: std::sync::Mutex<Option<std::thread::JoinHandle<std::io::Result<[u8; 32]>>>>,
    done: std::sync::OnceLock<Option<[u8; 32]>>,
}

impl EarlyHash {
    /// Starts hashing `path`.
    fn start(path: &Path) -> EarlyHash {
        let owned = path.to_path_buf();
        let running = std::thread::Builder::new()
            .name("lumo-hash".into())
            .spawn(move || crate::hash::sha256_file(&owned))
            .ok();
        EarlyHash(Some(Arc::new(EarlyHashState {
            path: path.to_path_buf(),
            running: std::sync::Mutex::new(running),
            done: std::sync::OnceLock::new(),
        })))
    }

    /// The hash of `path` when it is the file hashed early and hashing it succeeded (else the
    /// caller hashes the file itself, and reports its errors).
    fn of(&self, path: &Path) -> Option<[u8; 32]> {
        let state = self.0.as_ref()?;
        if state.path != path {
            return None;
        }
        *state.done.get_or_init(|| {
            let running = state.running.lock().ok()?.take()?;
            running.join().ok()?.ok()
        })
    }
}

impl Loaded {
    /// Builds the renderer's scene graph (no file is read here). Returns the scene and
    /// warnings about what was dropped or approximated.
    pub fn build(&self) -> Result<(crate::scene::Scene, Vec<String>), crate::scene::BuildError> {
        crate::scene::build(&self.description.scene, &self.assets)
    }

    /// Every file read to load this scene: the input, the fragments it includes, then its
    /// meshes, glTF buffers and images, each once, in the order first read.
    pub fn files(&self) -> Vec<PathBuf> {
        let mut files = vec![self.description.file.clone()];
        files.extend(self.description.fragments.iter().cloned());
        for f in self.assets.files() {
            if !files.contains(f) {
                files.push(f.clone());
            }
        }
        files
    }

    /// A hash of what the render of this scene depends on, whatever the files are called or
    /// where they are: see [`HashInputs::content_hash`].
    pub fn content_hash(&self) -> std::io::Result<String> {
        content_hash_of(&self.description, self.assets.files(), &self.input_hash)
    }

    /// What [`content_hash`](Self::content_hash) reads, to hash later without the assets in
    /// memory: the scene description, the files read, and each file's length and time of last
    /// change as they are now.
    pub fn hash_inputs(&self) -> HashInputs {
        let stamps = self.files().into_iter().map(|f| (stamp(&f), f)).collect();
        HashInputs {
            description: self.description.clone(),
            assets: self.assets.files().to_vec(),
            input_hash: self.input_hash.clone(),
            stamps,
        }
    }

    /// The same input with another scene description (the scene edited as data, a Python
    /// dict's overrides): validated against the input's folder, with every mesh and image the
    /// two scenes share kept in memory, not read again, and those only the new one references
    /// read. [`Loaded::files`] then lists the files of both.
    pub fn with_scene(&self, scene: schema::Scene) -> Result<Loaded, LoadError> {
        let d = &self.description;
        let scene =
            Validated::new(scene, Some(&d.base_dir)).map_err(|e| invalid_report(&d.file, e))?;
        let mut assets = self.assets.clone();
        assets
            .read_missing(&scene, &d.base_dir, None)
            .map_err(|e| LoadError::rejected(&d.file, format!("{}: {e}", d.file.display())))?;
        Ok(Loaded {
            description: SceneFile { scene, ..d.clone() },
            assets,
            input_hash: self.input_hash.clone(),
        })
    }

    /// See [`SceneFile::edit`]. Overrides must not change what the scene references: the
    /// assets were read for the scene as loaded (a build then reports the missing asset).
    pub fn edit(&mut self, change: impl FnOnce(&mut schema::Scene)) -> Result<(), LoadError> {
        self.description.edit(change)?;
        // An override may name an environment image the scene did not have.
        let d = &self.description;
        self.assets
            .read_environment(&d.scene.background, &d.base_dir)
            .map_err(|e| LoadError::rejected(&d.file, format!("{}: {e}", d.file.display())))
    }
}

/// What a scene's content hash is taken from ([`Loaded::hash_inputs`]), kept apart from the
/// assets so that the hash can be taken after they are dropped.
#[derive(Debug, Clone)]
pub struct HashInputs {
    description: SceneFile,
    /// The assets' files, in the order first read.
    assets: Vec<PathBuf>,
    input_hash: EarlyHash,
    /// Every file read (the input, its fragments, its assets) with its length and time of
    /// last change when the inputs were taken (`None` where they could not be read).
    stamps: Vec<(Option<(u64, std::time::SystemTime)>, PathBuf)>,
}

impl HashInputs {
    /// A hash of what the render of this scene depends on, whatever the files are called or
    /// where they are: SHA-256 of the scene (after overrides) as lumo JSON with every file
    /// reference replaced by the SHA-256 of the file's bytes, then of the bytes of every other
    /// file read (glTF buffers and images), in the order of their hashes. The sample count and
    /// time budget are left out (sample ranges of one render, or a checkpoint resumed with a new
    /// target, are the same scene).
    pub fn content_hash(&self) -> std::io::Result<String> {
        content_hash_of(&self.description, &self.assets, &self.input_hash)
    }

    /// The first file read for the scene that has changed (or gone) since
    /// [`Loaded::hash_inputs`]: its length or time of last change differs. A hash taken now
    /// would describe what is on disk, no longer what was loaded.
    pub fn changed_file(&self) -> Option<&Path> {
        self.stamps
            .iter()
            .find(|(then, f)| stamp(f) != *then)
            .map(|(_, f)| f.as_path())
    }
}

/// [`HashInputs::content_hash`] of a scene description `d`, its assets' files and its input's
/// early hash.
fn content_hash_of(
    d: &SceneFile,
    assets: &[PathBuf],
    input_hash: &EarlyHash,
) -> std::io::Result<String> {
    use crate::hash::{hex, sha256, sha256_file};
    // Every file read, hashed once (the scene's references are among them, under the
    // paths the loader resolved: base_dir joined with the reference).
    let mut read: Vec<(&PathBuf, [u8; 32])> = Vec::new();
    for f in assets {
        let hash = match input_hash.of(f) {
            Some(hash) => hash,
            None => sha256_file(f)?,
        };
        read.push((f, hash));
    }
    // The same file however it is spelt (`./a.glb` and `a.glb`): a file read is not read
    // and hashed again.
    let canonical = |p: &Path| std::fs::canonicalize(p).ok();
    let file_hash = |f: &str| -> std::io::Result<String> {
        let path = d.base_dir.join(f);
        let found = read.iter().find(|(p, _)| **p == path).or_else(|| {
            let c = canonical(&path)?;
            read.iter().find(|(p, _)| canonical(p).as_ref() == Some(&c))
        });
        let hash = match found {
            Some((_, h)) => *h,
            None => sha256_file(&path)?,
        };
        Ok(format!("sha256:{}", hex(&hash)))
    };
    let mut scene = (*d.scene).clone();
    scene.render.spp = 1;
    scene.render.time_budget_s = None;
    // Where an editor finds the schema is no part of the render.
    scene.schema = None;
    for t in scene.textures.values_mut() {
        t.file = file_hash(&t.file)?;
    }
    for o in &mut scene.objects {
        if let schema::Object::Mesh(m) = o {
            match &mut m.source {
                schema::MeshSource::Obj(f) => *f = file_hash(f)?,
                schema::MeshSource::Gltf(g) => g.file = file_hash(&g.file)?,
                schema::MeshSource::Inline(_) => {}
            }
        }
    }
    if let Some(image) = &mut scene.background.image {
        *image = file_hash(image)?;
    }
    let mut others: Vec<[u8; 32]> = read.iter().map(|(_, h)| *h).collect();
    others.sort_unstable();
    let mut all = schema::to_json(&scene).into_bytes();
    for h in others {
        all.extend_from_slice(&h);
    }
    Ok(format!("sha256:{}", hex(&sha256(&all))))
}

/// A file's length and time of last change, if they can be read.
fn stamp(path: &Path) -> Option<(u64, std::time::SystemTime)> {
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.len(), meta.modified().ok()?))
}

/// The input kind of a path, by extension.
pub fn kind_of(path: &Path) -> Result<InputKind, LoadError> {
    let ext = lumo_schema::geometry::paths::lowercase_extension(path);
    match ext.as_str() {
        "json" => Ok(InputKind::Json),
        "txt" => Ok(InputKind::Legacy),
        "gltf" | "glb" => Ok(InputKind::Gltf),
        _ => Err(LoadError::rejected(path, format!(
            "{}: cannot tell the input kind from the extension `{ext}` (expected .json, .txt, .gltf or .glb)",
            path.display()
        ))),
    }
}

/// Whether `path` is a scene fragment (a `.json` file whose `$schema` names the fragment
/// schema): a part of scenes, checked with `lumo_schema::check_fragment_file`, not loaded.
pub fn is_fragment_file(path: &Path) -> bool {
    kind_of(path).is_ok_and(|k| k == InputKind::Json)
        && std::fs::read_to_string(path).is_ok_and(|t| schema::include::is_fragment(&t))
}

/// Reads and validates the scene at `path` and reads every asset it references.
pub fn load(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Loaded, LoadError> {
    let path = path.as_ref();
    crate::phases::mark("load: start");
    // A glTF input is itself among the assets the content hash covers (a JSON or legacy
    // input is hashed as the scene it describes, not as a file).
    let input_hash = match kind_of(path) {
        Ok(InputKind::Gltf) if !options.defer_input_hash => EarlyHash::start(path),
        _ => EarlyHash::default(),
    };
    let (description, opened) = read_scene_keeping_gltf(path, options)?;
    crate::phases::mark("load: scene read and validated");
    let assets = Assets::read_with(&description.scene, &description.base_dir, opened)
        .map_err(|e| LoadError::rejected(path, format!("{}: {e}", path.display())))?;
    crate::phases::mark("load: assets read");
    Ok(Loaded {
        description,
        assets,
        input_hash,
    })
}

/// Reads and validates the scene description at `path` without reading its assets (for
/// converting and validating).
pub fn read_scene(path: &Path, options: &LoadOptions) -> Result<SceneFile, LoadError> {
    read_scene_keeping_gltf(path, options).map(|(scene, _)| scene)
}

/// [`read_scene`], also returning the glTF file it opened (parsed, buffers loaded) so that
/// reading the assets does not open and parse it a second time.
fn read_scene_keeping_gltf(
    path: &Path,
    options: &LoadOptions,
) -> Result<(SceneFile, Option<Arc<GltfFile>>), LoadError> {
    let kind = kind_of(path)?;
    let mut opened = None;
    let mut fragments = Vec::new();
    let (scene, base_dir, warnings) = match kind {
        InputKind::Gltf => {
            use lumo_converters::gltf as g;
            let opts = ImportOptions {
                camera: options.camera.clone(),
                scene_dir: options.scene_dir.clone(),
            };
            let gltf_error = |e: g::GltfError| match e {
                g::GltfError::Io { .. } => LoadError::io(path, e.to_string()),
                _ => LoadError::rejected(path, e.to_string()),
            };
            let file = Arc::new(GltfFile::open(path).map_err(gltf_error)?);
            crate::phases::mark("load: glTF file read and parsed");
            let imported = file.import(&opts).map_err(gltf_error)?;
            opened = Some(file);
            let base_dir = match &options.scene_dir {
                Some(d) => d.clone(),
                None => schema::base_dir_of(path),
            };
            let scene = Validated::new(imported.scene, Some(&base_dir)).map_err(|d| {
                let problems: Vec<String> = d.iter().map(ToString::to_string).collect();
                LoadError::rejected(
                    path,
                    format!(
                        "{}: the imported scene is not valid: {}",
                        path.display(),
                        problems.join("; ")
                    ),
                )
            })?;
            (scene, base_dir, imported.warnings)
        }
        InputKind::Json => {
            let (scene, notes, read) =
                schema::load_scene_file_with_fragments(path).map_err(from_schema)?;
            fragments = read;
            (scene, schema::base_dir_of(path), notes)
        }
        InputKind::Legacy => {
            // Paths in the converted scene stay relative to the legacy file's folder.
            let opts = legacy::ImportOptions {
                lights: options.lights,
                output_dir: None,
            };
            let imported = legacy::import(path, &opts).map_err(|e| match e {
                legacy::LegacyError::Io { .. } => LoadError::io(path, e.to_string()),
                legacy::LegacyError::Invalid { .. } => LoadError::rejected(path, e.to_string()),
            })?;
            // The importer's warnings read `file:line:col: warning: …`; keep only
            // `line:col: …` (callers name the file themselves).
            let prefix = format!("{}:", path.display());
            let warnings = imported
                .warnings
                .iter()
                .map(|w| {
                    w.strip_prefix(&prefix)
                        .unwrap_or(w)
                        .replacen(" warning: ", " ", 1)
                        .trim_start()
                        .to_string()
                })
                .collect();
            let base_dir = schema::base_dir_of(path);
            let scene = Validated::new(imported.scene, Some(&base_dir))
                .map_err(|d| invalid_report(path, d))?;
            (scene, base_dir, warnings)
        }
    };
    let scene = if options.composition.is_empty() {
        scene
    } else {
        // Problems the changes did not write are placed in the scene file's own text.
        let text = match kind {
            InputKind::Json => std::fs::read_to_string(path).ok(),
            _ => None,
        };
        options
            .composition
            .apply(&scene, path, text.as_deref(), Some(&base_dir))
            .map_err(|d| invalid_report(path, d))?
    };
    let description = SceneFile {
        scene,
        base_dir,
        warnings,
        file: path.to_path_buf(),
        kind,
        fragments,
    };
    Ok((description, opened))
}

fn invalid_report(file: &Path, diagnostics: Vec<schema::Diagnostic>) -> LoadError {
    LoadError::Invalid {
        file: file.to_path_buf(),
        diagnostics,
    }
}

/// The loader's error for the schema's.
pub fn from_schema(e: schema::LoadError) -> LoadError {
    match e {
        schema::LoadError::Io { ref path, .. } => LoadError::io(path, e.to_string()),
        schema::LoadError::Invalid { file, diagnostics } => invalid_report(&file, diagnostics),
    }
}

/// Reads and validates a lumo scene given as JSON text (not a file: a scene built in memory, a
/// Python dict), with every asset it references; `label` names it in messages (`<dict>`), and
/// relative paths in it resolve against `base_dir`.
pub fn load_json_str(text: &str, label: &Path, base_dir: &Path) -> Result<Loaded, LoadError> {
    let (scene, warnings) =
        schema::load_scene_str_noted(text, label, Some(base_dir)).map_err(from_schema)?;
    let assets = Assets::read_with(&scene, base_dir, None)
        .map_err(|e| LoadError::rejected(label, format!("{}: {e}", label.display())))?;
    Ok(Loaded {
        description: SceneFile {
            scene,
            base_dir: base_dir.to_path_buf(),
            warnings,
            file: label.to_path_buf(),
            kind: InputKind::Json,
            fragments: Vec::new(),
        },
        assets,
        input_hash: EarlyHash::default(),
    })
}

/// The repository's Cornell box (`scenes/cornell.json`), built, for the unit tests.
#[cfg(test)]
pub(crate) fn test_cornell() -> crate::scene::Scene {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json");
    let (scene, _) = load(&file, &LoadOptions::default())
        .unwrap()
        .build()
        .unwrap();
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.glb` input's content hash is the same whether its bytes were hashed as loading began
    /// or are hashed when the hash is asked for, and the early hash is the file's SHA-256; a
    /// JSON input starts no such hash.
    #[test]
    fn an_input_hashed_early_hashes_the_same() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("cornell.glb");
        let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let cornell = read_scene(&scenes.join("cornell.json"), &LoadOptions::default()).unwrap();
        lumo_converters::gltf::export(&cornell.scene, &scenes, &data).unwrap();
        let early = load(&data, &LoadOptions::default()).unwrap();
        let hash = early.content_hash().unwrap();
        assert_eq!(
            early.input_hash.of(&data),
            Some(crate::hash::sha256_file(&data).unwrap()),
            "the input was hashed early, and whole"
        );
        let mut late = early.clone();
        late.input_hash = EarlyHash::default();
        assert_eq!(late.content_hash().unwrap(), hash);
        // A JSON input is no asset: nothing is hashed for it ahead.
        let json = load(scenes.join("cornell.json"), &LoadOptions::default()).unwrap();
        assert!(json.input_hash.0.is_none());
    }
}
