//! `lumo._lumo`: the Python extension module of lumo (pyo3). The package `lumo`
//! (`python/lumo/__init__.py`) re-exports it with a thin Python layer (dicts to JSON and back).
//!
//! Renders run on a worker thread with the GIL released; the calling thread waits in short
//! slices, runs Python's signal handlers between them (Ctrl-C raises `KeyboardInterrupt`) and
//! calls the progress callback. The extension installs no signal handler of its own. Images
//! reach Python as numpy arrays over the render's own buffers, without a copy.

#![warn(missing_docs)]

mod arrays;
mod errors;
mod film;
mod render;
mod scene;

use std::path::{Path, PathBuf};

use lumo_schema as schema;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

use crate::errors::load_error;

/// Renders a scene; returns a ``RenderResult`` (``.color``, ``.std_error``, ``.passes``,
/// ``.stats``, ``.film``, ``.write(path)``, ``.denoised()``).
///
/// Every argument overrides what the scene says: ``spp`` samples per pixel; ``seed`` the
/// random seed; ``threads`` worker threads (default: all cores; the image does not depend
/// on it); ``time`` a budget in seconds and ``target_error`` an estimated relative error to
/// stop at (progressive passes; ``spp`` still caps); ``samples=(a, b)`` exactly sample
/// indices a..b-1 and ``crop=(x0, y0, x1, y1)`` a window, for films that ``lumo.merge``
/// adds up; ``adaptive`` spends samples where the estimated error is largest;
/// ``light_sampler`` is ``"auto"``, ``"power"`` or ``"tree"``; ``aov`` the render passes
/// to keep besides the beauty (``"albedo,normal"`` or a list of names: albedo, normal, depth,
/// position, uv, object_id, material_id, std_error), added to the scene's ``render.aov``.
///
/// The GIL is released while rendering. ``progress(done, total)`` is called on this thread
/// as samples finish (``total`` is None for a time or error budget); returning ``False``
/// stops the render within a tile and raises ``RenderCancelled`` with the samples so far on
/// ``e.result``. Ctrl-C does the same with ``KeyboardInterrupt``. The result is the same bits
/// as ``lumo render`` with the same scene and settings.
#[pyfunction]
#[pyo3(name = "render", signature = (scene, spp = None, seed = None, threads = None, time = None, target_error = None, samples = None, crop = None, progress = None, adaptive = false, light_sampler = "auto", aov = None))]
#[allow(clippy::too_many_arguments)]
fn render_py(
    py: Python<'_>,
    scene: PyRef<'_, scene::Scene>,
    spp: Option<u32>,
    seed: Option<u64>,
    threads: Option<usize>,
    time: Option<f64>,
    target_error: Option<f64>,
    samples: Option<(u32, u32)>,
    crop: Option<(u32, u32, u32, u32)>,
    progress: Option<Bound<'_, PyAny>>,
    adaptive: bool,
    light_sampler: &str,
    aov: Option<Bound<'_, PyAny>>,
) -> PyResult<render::RenderResult> {
    let request = render::request(
        spp,
        seed,
        threads,
        time,
        target_error,
        samples,
        crop,
        adaptive,
        light_sampler,
        render::aov_set(aov.as_ref())?,
    )?;
    let progress = progress.filter(|p| !p.is_none());
    render::render(py, &scene, request, progress)
}

/// The JSON Schema (draft 2020-12) of lumo scene files: a dict, or with ``as_text`` the text
/// ``lumo schema`` prints.
#[pyfunction]
#[pyo3(name = "schema", signature = (as_text = false))]
fn schema_py(py: Python<'_>, as_text: bool) -> PyResult<Bound<'_, PyAny>> {
    let text = lumo_schema::json_schema();
    if as_text {
        Ok(pyo3::types::PyString::new(py, &text).into_any())
    } else {
        py.import("json")?.call_method1("loads", (text,))
    }
}

/// Rewrites the scene's file paths (relative to `from`) to be relative to `to`.
fn rebase_paths(scene: &mut schema::Scene, from: &Path, to: &Path) {
    use lumo_converters::gltf::relative_path;
    if relative_path(from, to) == "." {
        return;
    }
    let rel = |f: &mut String| *f = relative_path(&from.join(&*f), to);
    for t in scene.textures.values_mut() {
        rel(&mut t.file);
    }
    for o in &mut scene.objects {
        if let schema::Object::Mesh(m) = o {
            match &mut m.source {
                schema::MeshSource::Obj(f) => rel(f),
                schema::MeshSource::Gltf(g) => rel(&mut g.file),
                schema::MeshSource::Inline(_) => {}
            }
        }
    }
    if let Some(image) = &mut scene.background.image {
        rel(image);
    }
}

/// Writes a text file atomically (a temporary file beside it, then a rename).
fn write_text_atomically(path: &Path, text: &str) -> PyResult<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let fail = |e: std::io::Error| PyOSError::new_err(format!("{}: {e}", path.display()));
    let mut tmp = lumo::output::temp_file_in(dir).map_err(fail)?;
    std::io::Write::write_all(&mut tmp, text.as_bytes()).map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

/// Converts a scene between formats, by extension, as ``lumo convert`` does: lumo JSON
/// (``.json``), legacy text (``.txt``), glTF (``.gltf`` with a ``.bin`` beside it, or
/// ``.glb``). File paths in a written scene are relative to its folder. Returns the
/// converter's warnings (features that were dropped or approximated).
#[pyfunction]
#[pyo3(signature = (src, dst, *, camera = None, lights = "auto"))]
fn convert(
    py: Python<'_>,
    src: PathBuf,
    dst: PathBuf,
    camera: Option<&Bound<'_, PyAny>>,
    lights: &str,
) -> PyResult<Vec<String>> {
    let ext = schema::geometry::paths::lowercase_extension(&dst);
    let out_dir = match dst.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !out_dir.is_dir() {
        return Err(PyOSError::new_err(format!(
            "{}: the output folder does not exist",
            dst.display()
        )));
    }
    let (json_out, legacy_out) = match ext.as_str() {
        "json" => (true, false),
        "txt" => (false, true),
        "gltf" | "glb" => (false, false),
        _ => {
            return Err(PyValueError::new_err(format!(
            "{}: cannot tell the output format from `{ext}` (expected .json, .txt, .gltf or .glb)",
            dst.display()
        )))
        }
    };
    // A converted scene's paths are written relative to the output's folder.
    let options = scene::load_options(camera, lights, json_out.then(|| out_dir.clone()))?;
    let input = py
        .detach(|| lumo::load::read_scene(&src, &options))
        .map_err(|e| load_error(py, e))?;
    let mut warnings: Vec<String> = input
        .warnings
        .iter()
        .map(|w| format!("{}: {w}", src.display()))
        .collect();
    let base_dir = input.base_dir;
    let mut scene = input.scene.into_inner();
    if json_out {
        rebase_paths(&mut scene, &base_dir, &out_dir);
        write_text_atomically(&dst, &schema::to_json(&scene))?;
    } else if legacy_out {
        rebase_paths(&mut scene, &base_dir, &out_dir);
        let text = lumo_converters::legacy::export(&scene, &out_dir)
            .map_err(|e| PyValueError::new_err(format!("{}: {e}", dst.display())))?;
        write_text_atomically(&dst, &text)?;
    } else {
        let exported = py
            .detach(|| lumo_converters::gltf::export(&scene, &base_dir, &dst))
            .map_err(|e| match e {
                lumo_converters::gltf::GltfError::Io { .. } => PyOSError::new_err(e.to_string()),
                _ => PyValueError::new_err(e.to_string()),
            })?;
        warnings.extend(
            exported
                .into_iter()
                .map(|w| format!("{}: {w}", dst.display())),
        );
    }
    Ok(warnings)
}

/// The build id films carry: `sha256:` and the SHA-256 of this extension module's file (the
/// interpreter is not lumo's code), so that films rendered from Python merge with each other.
fn module_build_id(m: &Bound<'_, PyModule>) -> String {
    let file: PyResult<PathBuf> = m.getattr("__file__").and_then(|f| f.extract());
    match file {
        Ok(path) => {
            lumo::partial_film::file_build_id(&path).unwrap_or_else(|e| format!("unknown ({e})"))
        }
        Err(e) => format!("unknown ({e})"),
    }
}

/// lumo's Python extension module.
#[pymodule]
fn _lumo(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let id = module_build_id(m);
    // Only the first module initialisation in a process sets it (a second import of the same
    // file is the same build).
    lumo::partial_film::set_build_id(id);
    m.add("build_id", lumo::partial_film::build_id())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SceneError", py.get_type::<errors::SceneError>())?;
    m.add("RenderCancelled", py.get_type::<errors::RenderCancelled>())?;
    m.add("LumoWarning", py.get_type::<errors::LumoWarning>())?;
    m.add_class::<errors::Diagnostic>()?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<render::RenderResult>()?;
    m.add_class::<render::Stats>()?;
    m.add_class::<film::Film>()?;
    m.add_class::<arrays::Pixels>()?;
    m.add_function(wrap_pyfunction!(render_py, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load, m)?)?;
    m.add_function(wrap_pyfunction!(scene::validate, m)?)?;
    m.add_function(wrap_pyfunction!(film::merge, m)?)?;
    m.add_function(wrap_pyfunction!(convert, m)?)?;
    m.add_function(wrap_pyfunction!(schema_py, m)?)?;
    Ok(())
}
