//! `lumo.Scene`: a scene read and validated, with every mesh and image it references in
//! memory; `lumo.load`, overrides, and `lumo.validate`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use lumo::load::{InputKind, LoadOptions, Loaded};
use lumo_converters::gltf::CameraChoice;
use lumo_converters::legacy::LightsPolicy;
use lumo_schema as schema;
use lumo_schema::overrides::{self, Override};
use lumo_schema::Keyword;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use crate::errors::{load_error, scene_error, Diagnostic};

/// A scene, read and validated, with every mesh and image it references in memory. Made by
/// ``lumo.load``, ``Scene.from_dict`` or ``Scene.with_overrides``; immutable (an override
/// makes a new scene that shares the meshes and images).
#[pyclass(frozen, module = "lumo")]
pub struct Scene {
    pub loaded: Arc<Loaded>,
}

/// `camera=`: a name, or an index into the glTF file's cameras.
fn camera_choice(camera: Option<&Bound<'_, PyAny>>) -> PyResult<Option<CameraChoice>> {
    let Some(c) = camera else { return Ok(None) };
    if c.is_none() {
        return Ok(None);
    }
    if let Ok(i) = c.extract::<u32>() {
        return Ok(Some(CameraChoice::Index(i)));
    }
    if let Ok(name) = c.extract::<String>() {
        return Ok(Some(CameraChoice::Name(name)));
    }
    Err(PyTypeError::new_err(
        "camera= takes a camera's name (str) or its index in the glTF file (int)",
    ))
}

/// The label of a scene given as a dict, in messages.
const DICT_LABEL: &str = "<dict>";

/// `value` as JSON text (Python's `json.dumps`, refusing NaN and infinities, which JSON has
/// not).
fn json_text(value: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    let py = value.py();
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("allow_nan", false)?;
    py.import("json")?
        .call_method("dumps", (value,), Some(&kwargs))
        .and_then(|t| t.extract::<String>())
        .map_err(|e| {
            PyTypeError::new_err(format!("{what} cannot be written as JSON: {}", e.value(py)))
        })
}

/// The `(path, JSON text)` pairs of a mapping of overrides.
fn override_pairs(overrides: &Bound<'_, PyAny>) -> PyResult<Vec<(String, String)>> {
    let mapping = overrides.cast::<pyo3::types::PyMapping>().map_err(|_| {
        PyTypeError::new_err(
            "overrides are a mapping of JSON paths to values, e.g. \
             {\"materials.red.base_color\": [0.8, 0.1, 0.1]}",
        )
    })?;
    let mut pairs = Vec::new();
    for item in mapping.items()?.iter() {
        let (path, value): (Bound<'_, PyAny>, Bound<'_, PyAny>) = item.extract()?;
        let path: String = path.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "override paths are str, not {}",
                path.get_type()
                    .name()
                    .map_or_else(|_| "?".into(), |n| n.to_string())
            ))
        })?;
        let text = json_text(&value, &format!("the value of override `{path}`"))?;
        pairs.push((path, text));
    }
    Ok(pairs)
}

/// `SceneError` for diagnostics without lines and columns (a dict's, or the scene's after
/// overrides, whose text is not the file's): the report and the diagnostics without them.
fn unplaced_scene_error(
    py: Python<'_>,
    heading: &str,
    file: &Path,
    diagnostics: Vec<schema::Diagnostic>,
) -> PyErr {
    let diagnostics: Vec<schema::Diagnostic> = diagnostics
        .into_iter()
        .map(|mut d| {
            d.location = None;
            d
        })
        .collect();
    let report = schema::Report {
        file: file.to_path_buf(),
        diagnostics: diagnostics.clone(),
    };
    let located = diagnostics
        .iter()
        .map(|d| Diagnostic::located(file, d))
        .collect();
    scene_error(
        py,
        format!("{heading}{}", report.to_string().trim_end()),
        file,
        located,
    )
}

/// `lights=`: `"keep"`, `"drop"` or `"auto"`.
fn lights_policy(lights: &str) -> PyResult<LightsPolicy> {
    LightsPolicy::from_keyword(lights).map_err(|e| PyValueError::new_err(format!("lights=: {e}")))
}

/// The load options of `camera=` and `lights=`.
pub fn load_options(
    camera: Option<&Bound<'_, PyAny>>,
    lights: &str,
    scene_dir: Option<PathBuf>,
) -> PyResult<LoadOptions> {
    Ok(LoadOptions {
        lights: lights_policy(lights)?,
        camera: camera_choice(camera)?,
        scene_dir,
        ..LoadOptions::default()
    })
}

impl Scene {
    /// The scene with overrides applied: re-validated, the meshes and images shared.
    fn overridden(
        py: Python<'_>,
        loaded: &Loaded,
        overrides: Vec<(String, String)>,
    ) -> PyResult<Loaded> {
        let file = loaded.description.file.clone();
        let invalid = |diagnostics: Vec<schema::Diagnostic>| {
            unplaced_scene_error(py, "overrides: ", &file, diagnostics)
        };
        let mut parsed = Vec::with_capacity(overrides.len());
        let mut problems = Vec::new();
        for (path, value) in overrides {
            let value: serde_json::Value = match serde_json::from_str(&value) {
                Ok(v) => v,
                Err(e) => {
                    let p = overrides::parse_path(&path).unwrap_or_else(|d| d.path);
                    problems.push(schema::Diagnostic::new(
                        p,
                        format!("the override's value is not JSON: {e}"),
                    ));
                    continue;
                }
            };
            match Override::new(&path, value) {
                Ok(o) => parsed.push(o),
                Err(d) => problems.push(d),
            }
        }
        if !problems.is_empty() {
            return Err(invalid(problems));
        }
        let scene =
            overrides::apply_to_scene(&loaded.description.scene, &parsed).map_err(invalid)?;
        let loaded = loaded.clone();
        // Validation may look at files and reading new assets is I/O: without the GIL.
        let result = py.detach(move || loaded.with_scene(scene));
        result.map_err(|e| match e {
            // Validation's diagnostics have no place in the file's text: the overrides moved
            // the scene away from it.
            lumo::load::LoadError::Invalid { diagnostics, .. } => invalid(diagnostics),
            e => load_error(py, e),
        })
    }
}

#[pymethods]
impl Scene {
    /// A scene from a dict in lumo's scene JSON format (what ``to_dict`` returns). Relative
    /// file paths in it (meshes, textures, the environment image) resolve against
    /// ``base_dir``. Raises ``SceneError`` listing every problem, each with its JSON path.
    #[staticmethod]
    #[pyo3(signature = (scene, base_dir = None))]
    fn from_dict(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        base_dir: Option<PathBuf>,
    ) -> PyResult<Scene> {
        let text = json_text(scene, "the scene")?;
        let base_dir = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let label = PathBuf::from(DICT_LABEL);
        let loaded = py.detach(|| lumo::load::load_json_str(&text, &label, &base_dir));
        match loaded {
            Ok(l) => Ok(Scene {
                loaded: Arc::new(l),
            }),
            Err(e) if e.is_io() => Err(load_error(py, e)),
            Err(lumo::load::LoadError::Invalid { file, diagnostics }) => {
                // A dict has no text of its own: lines and columns would be those of the JSON
                // it was written as.
                Err(unplaced_scene_error(py, "", &file, diagnostics))
            }
            Err(e) => Err(load_error(py, e)),
        }
    }

    /// The scene as a dict in lumo's scene JSON format:
    /// ``Scene.from_dict(s.to_dict(), base_dir=s.base_dir)`` is the same scene.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (self.to_json(),))
    }

    /// The scene as lumo scene JSON text (pretty-printed, as ``lumo convert`` writes it).
    fn to_json(&self) -> String {
        schema::to_json(&self.loaded.description.scene)
    }

    /// A new scene with values replaced by JSON path, validated again.
    ///
    /// Paths are written as lumo's messages print them: ``"materials.red.base_color"``,
    /// ``"objects[2].sphere.radius"``, ``"render.spp"``, ``'textures["a.png"].file'``. Every
    /// step of a path but the last must exist; the last may add a member (a field left at its
    /// default, a new material). A path that names nothing, a value of the wrong type or a
    /// scene that is no longer valid raises ``SceneError`` naming the path. Meshes and images
    /// are shared with this scene, not read again.
    fn with_overrides(&self, py: Python<'_>, overrides: &Bound<'_, PyAny>) -> PyResult<Scene> {
        let pairs = override_pairs(overrides)?;
        let loaded = Scene::overridden(py, &self.loaded, pairs)?;
        Ok(Scene {
            loaded: Arc::new(loaded),
        })
    }

    /// The input file (or the label of a dict, ``<dict>``).
    #[getter]
    fn file(&self) -> String {
        self.loaded.description.file.display().to_string()
    }

    /// The folder relative paths in the scene resolve against.
    #[getter]
    fn base_dir(&self) -> String {
        self.loaded.description.base_dir.display().to_string()
    }

    /// What the input was: ``"json"``, ``"legacy"`` or ``"gltf"``.
    #[getter]
    fn kind(&self) -> &'static str {
        match self.loaded.description.kind {
            InputKind::Json => "json",
            InputKind::Legacy => "legacy",
            InputKind::Gltf => "gltf",
        }
    }

    /// Every file read to load the scene: the input, then its meshes, glTF buffers and images,
    /// each once, in the order first read.
    #[getter]
    fn files(&self) -> Vec<String> {
        self.loaded
            .files()
            .iter()
            .map(|p| p.display().to_string())
            .collect()
    }

    /// Non-fatal problems found while reading the input (a migrated format, a glTF feature
    /// that is not imported).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.loaded.description.warnings.clone()
    }

    /// Image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.loaded.description.scene.image.width
    }

    /// Image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.loaded.description.scene.image.height
    }

    /// Samples per pixel the scene asks for.
    #[getter]
    fn spp(&self) -> u32 {
        self.loaded.description.scene.render.spp
    }

    /// The scene's random seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.loaded.description.scene.render.seed
    }

    /// A hash of everything the render of this scene depends on (the scene after overrides,
    /// the bytes of every file it reads), as partial films record it.
    fn content_hash(&self, py: Python<'_>) -> PyResult<String> {
        let loaded = Arc::clone(&self.loaded);
        py.detach(move || loaded.content_hash())
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        let s = &self.loaded.description.scene;
        format!(
            "<lumo.Scene {} ({}, {}×{}, {} spp, {} objects)>",
            self.loaded.description.file.display(),
            self.kind(),
            s.image.width,
            s.image.height,
            s.render.spp,
            s.objects.len()
        )
    }
}

/// Loads a scene: lumo JSON (``.json``), a legacy text scene (``.txt``) or glTF
/// (``.gltf``/``.glb``), with every file it references.
///
/// ``overrides`` (a mapping of JSON paths to values) are applied as by
/// ``Scene.with_overrides``. ``camera`` picks a glTF camera by name or index; ``lights`` is
/// ``"keep"``, ``"drop"`` or ``"auto"`` for a legacy scene's ``Lights`` block. Raises
/// ``SceneError`` for an invalid scene and ``OSError`` for a file that cannot be read.
#[pyfunction]
#[pyo3(signature = (path, overrides = None, *, camera = None, lights = "auto"))]
pub fn load(
    py: Python<'_>,
    path: PathBuf,
    overrides: Option<&Bound<'_, PyAny>>,
    camera: Option<&Bound<'_, PyAny>>,
    lights: &str,
) -> PyResult<Scene> {
    let options = load_options(camera, lights, None)?;
    let pairs = match overrides.filter(|o| !o.is_none()) {
        Some(o) => override_pairs(o)?,
        None => Vec::new(),
    };
    let loaded = py
        .detach(|| lumo::load(&path, &options))
        .map_err(|e| load_error(py, e))?;
    let loaded = if pairs.is_empty() {
        loaded
    } else {
        Scene::overridden(py, &loaded, pairs)?
    };
    Ok(Scene {
        loaded: Arc::new(loaded),
    })
}

/// Every problem of a scene file (or of a scene dict), as ``lumo validate`` finds them.
///
/// Returns an empty list for a valid scene; never raises for a bad, missing or unreadable file
/// (that is a diagnostic too). A file's assets are not read (as ``lumo validate``); a dict's
/// relative paths resolve against ``base_dir`` (default: the working directory) and its
/// diagnostics have JSON paths but no lines.
#[pyfunction]
#[pyo3(signature = (scene, *, base_dir = None, camera = None, lights = "auto"))]
pub fn validate(
    py: Python<'_>,
    scene: &Bound<'_, PyAny>,
    base_dir: Option<PathBuf>,
    camera: Option<&Bound<'_, PyAny>>,
    lights: &str,
) -> PyResult<Vec<Diagnostic>> {
    let label = Path::new(DICT_LABEL);
    if scene.cast::<pyo3::types::PyMapping>().is_ok() {
        let text = match json_text(scene, "the scene") {
            Ok(t) => t,
            Err(e) => return Ok(vec![Diagnostic::unplaced(label, &e.value(py).to_string())]),
        };
        let base_dir = base_dir.unwrap_or_else(|| PathBuf::from("."));
        return Ok(
            match py.detach(|| schema::load_scene_str(&text, label, Some(&base_dir))) {
                Ok(_) => Vec::new(),
                Err(schema::LoadError::Invalid { diagnostics, .. }) => diagnostics
                    .iter()
                    .map(|d| {
                        let mut d = Diagnostic::located(label, d);
                        d.line = None;
                        d.column = None;
                        d
                    })
                    .collect(),
                Err(e) => vec![Diagnostic::unplaced(label, &e.to_string())],
            },
        );
    }
    let path: PathBuf = scene.extract().map_err(|_| {
        PyTypeError::new_err("validate() takes a scene file's path or a scene dict")
    })?;
    let options = load_options(camera, lights, None)?;
    Ok(
        match py.detach(|| lumo::load::read_scene(&path, &options)) {
            Ok(_) => Vec::new(),
            Err(e) => Diagnostic::of_load_error(&e),
        },
    )
}
