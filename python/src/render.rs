//! `lumo.render`: a render job on a worker thread, with the GIL released; progress, cancel and
//! Ctrl-C handled on the calling (Python) thread; the result's images as numpy arrays without
//! a copy.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use lumo::aov::{AovSet, PassImage, PassPixels};
use lumo::denoise::Oidn;
use lumo::job::{Finished, Hooks, JobError, JobSettings, LightChoice, RenderJob};
use lumo::render::Window;
use numpy::{IntoPyArray, PyArray3, PyArrayMethods};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyString};

use crate::arrays::{array, pixels, Pixels, Source, Which};
use crate::errors::{job_error, LumoWarning, RenderCancelled};
use crate::film::{tonemap, write_full_image, Film};
use crate::scene::Scene;

/// How long the calling thread waits, without the GIL, between looks at signals and progress.
const SLICE: Duration = Duration::from_millis(25);

/// What a render did.
#[pyclass(frozen, module = "lumo", get_all)]
#[derive(Clone)]
pub struct Stats {
    /// Mean samples per pixel taken (rounded).
    pub spp: u32,
    /// Samples taken in all (a resumed render's included).
    pub samples: u64,
    /// Samples this call took.
    pub new_samples: u64,
    /// Wall time of the render, in seconds.
    pub seconds: f64,
    /// Samples this call took per second.
    pub samples_per_second: f64,
    /// Rays cast.
    pub rays: u64,
    /// Samples that were NaN or infinite (or absurdly large) and were dropped.
    pub dropped_samples: u64,
    /// √(estimated relative MSE) from the samples' variance: the figure ``target_error``
    /// stops at (conservative for Sobol points).
    pub estimated_error: f64,
    /// RMSE predicted from the samples' variance.
    pub estimated_rmse: f64,
}

#[pymethods]
impl Stats {
    fn __repr__(&self) -> String {
        format!(
            "Stats(spp={}, samples={}, seconds={:.3}, samples_per_second={:.0}, rays={}, \
             dropped_samples={}, estimated_error={:.5})",
            self.spp,
            self.samples,
            self.seconds,
            self.samples_per_second,
            self.rays,
            self.dropped_samples,
            self.estimated_error
        )
    }
}

/// A finished (or interrupted) render: its images, counters and film.
#[pyclass(frozen, module = "lumo")]
pub struct RenderResult {
    finished: Arc<Finished>,
    color: Py<Pixels>,
    std_error: Py<Pixels>,
    stats: Py<Stats>,
    film: Py<Film>,
    /// The render passes as read-only arrays, in `Aov::ALL`'s order.
    passes: Vec<(&'static str, Py<PyAny>)>,
    warnings: Vec<String>,
}

impl RenderResult {
    fn new(py: Python<'_>, finished: Finished, warnings: Vec<String>) -> PyResult<RenderResult> {
        let s = finished.stats;
        let seconds = s.elapsed.as_secs_f64();
        let stats = Stats {
            spp: s.spp,
            samples: s.samples,
            new_samples: finished.new_samples,
            seconds,
            samples_per_second: if seconds > 0.0 {
                finished.new_samples as f64 / seconds
            } else {
                0.0
            },
            rays: s.rays,
            dropped_samples: s.nan_samples,
            estimated_error: s.estimated_rel_error,
            estimated_rmse: s.estimated_rmse,
        };
        let passes = finished
            .passes()
            .into_iter()
            .map(|p| Ok((p.aov.name(), pass_array(py, p, finished.image.width)?)))
            .collect::<PyResult<Vec<_>>>()?;
        let finished = Arc::new(finished);
        Ok(RenderResult {
            color: pixels(py, Source::Finished(Arc::clone(&finished), Which::Color))?,
            std_error: pixels(py, Source::Finished(Arc::clone(&finished), Which::StdError))?,
            stats: Py::new(py, stats)?,
            film: Py::new(py, Film::of_result(Arc::clone(&finished)))?,
            finished,
            passes,
            warnings,
        })
    }
}

/// A pass as a read-only numpy array of the window: (H, W) for one channel (depth, ids),
/// (H, W, C) otherwise; float32, ids uint32.
pub fn pass_array(py: Python<'_>, pass: PassImage, width: u32) -> PyResult<Py<PyAny>> {
    let channels = pass.aov.channels().len();
    let w = width as usize;
    let shape = |len: usize| {
        let h = len / (w * channels).max(1);
        if channels == 1 {
            vec![h, w]
        } else {
            vec![h, w, channels]
        }
    };
    let array = match pass.pixels {
        PassPixels::Float(v) => {
            let s = shape(v.len());
            v.into_pyarray(py).reshape(s)?.into_any()
        }
        PassPixels::Id(v) => {
            let s = shape(v.len());
            v.into_pyarray(py).reshape(s)?.into_any()
        }
    };
    // Read-only like `color`: the same arrays are handed out by every `passes` call.
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(array.unbind())
}

/// The passes of `lumo.render`'s ``aov=``: None, a comma-separated string or a sequence of
/// names.
pub fn aov_set(aov: Option<&Bound<'_, PyAny>>) -> PyResult<AovSet> {
    let Some(aov) = aov.filter(|a| !a.is_none()) else {
        return Ok(AovSet::NONE);
    };
    let text = if aov.is_instance_of::<PyString>() {
        aov.extract::<String>()?
    } else {
        let names: Vec<String> = aov.extract().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(
                "aov= takes pass names: a string (\"albedo,normal\") or a list of strings",
            )
        })?;
        if let Some(bad) = names.iter().find(|n| n.contains(',')) {
            return Err(PyValueError::new_err(format!(
                "aov=: {bad:?} is not one pass name (give a list of names or one \
                 comma-separated string)"
            )));
        }
        names.join(",")
    };
    text.parse::<AovSet>()
        .map_err(|e| PyValueError::new_err(format!("aov=: {e}")))
}

#[pymethods]
impl RenderResult {
    /// Mean radiance per pixel of the rendered window: a read-only (H, W, 3) float32 array that
    /// is the render's own buffer (no copy; ``.copy()`` gives one to change). Its ``base``
    /// keeps the buffer alive.
    #[getter]
    fn color<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        array(self.color.bind(py))
    }

    /// Standard error of each pixel's mean, per channel: a read-only (H, W, 3) float32 array,
    /// without a copy.
    #[getter]
    fn std_error<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        array(self.std_error.bind(py))
    }

    /// The render passes asked for (``aov=`` and the scene's ``render.aov``), by name: a new
    /// dict of read-only arrays of the rendered window, (H, W, 3) for albedo, normal, position
    /// and std_error, (H, W, 2) for uv, (H, W) for depth, and (H, W) uint32 for object_id and
    /// material_id (index + 1 in the scene, 0 where the first sample hit nothing). The
    /// definitions are lumo render's (docs/passes.md).
    #[getter]
    fn passes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for (name, array) in &self.passes {
            dict.set_item(*name, array.bind(py))?;
        }
        Ok(dict)
    }

    /// The beauty denoised with Intel Open Image Denoise, as a new (H, W, 3) float32 array,
    /// guided by the albedo and normal passes when the render kept them (``aov="albedo,normal"``;
    /// prefiltered, as for final frames). OIDN is loaded at run time, as for ``lumo render
    /// --denoise`` (``LUMO_OIDN``, ``OIDN_DIR``, or ``pip install pyoidn``); without it this
    /// raises ``OSError`` saying how to install it. The GIL is released while denoising.
    fn denoised<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let finished = Arc::clone(&self.finished);
        let image = py
            .detach(move || {
                let mut oidn = Oidn::load().map_err(|e| e.to_string())?;
                finished.denoised(&mut oidn).map_err(|e| e.to_string())
            })
            .map_err(PyOSError::new_err)?;
        let (h, w) = (image.height as usize, image.width as usize);
        let floats: Vec<f32> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
        floats.into_pyarray(py).reshape([h, w, 3])
    }

    /// Counters: samples per pixel, seconds, samples per second, rays, dropped samples,
    /// estimated error.
    #[getter]
    fn stats(&self, py: Python<'_>) -> Py<Stats> {
        self.stats.clone_ref(py)
    }

    /// The render's samples as a partial film (``lumo.merge``, ``film.write(path)``).
    #[getter]
    fn film(&self, py: Python<'_>) -> Py<Film> {
        self.film.clone_ref(py)
    }

    /// Whether the render stopped before its budget was spent (Ctrl-C, or the progress
    /// callback returned False): it holds the whole passes finished before.
    #[getter]
    fn interrupted(&self) -> bool {
        self.finished.interrupted
    }

    /// Samples per pixel the render holds.
    #[getter]
    fn spp(&self) -> u32 {
        self.finished.samples_per_pixel()
    }

    /// Full image width of the render.
    #[getter]
    fn width(&self) -> u32 {
        self.finished.width()
    }

    /// Full image height of the render.
    #[getter]
    fn height(&self) -> u32 {
        self.finished.height()
    }

    /// The window rendered: ``(x0, y0, x1, y1)`` (all of the image unless ``crop`` was given).
    #[getter]
    fn crop(&self) -> (u32, u32, u32, u32) {
        let w = self.finished.window();
        let [x0, y0, x1, y1] = [w.x0, w.y0, w.x1, w.y1];
        (x0, y0, x1, y1)
    }

    /// What the scene build dropped or approximated, and notes about the job.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// Writes the image at the render's full size (black outside a crop window) with its render
    /// passes, atomically: PNG/BMP tone mapped (``"clamp"`` or ``"aces"``) to 8-bit sRGB, EXR/HDR
    /// linear; the passes as channels of the same EXR (``albedo.R``, …) or as PNG files beside
    /// the image (``OUT.albedo.png``). With ``denoise=True`` the beauty is denoised (see
    /// ``denoised()``) and the noisy one kept as the pass ``noisy``. The same bytes ``lumo render
    /// -o`` (``--aov``, ``--denoise``) writes for the same scene and settings.
    #[pyo3(signature = (path, tonemap = "clamp", denoise = false))]
    fn write(&self, py: Python<'_>, path: PathBuf, tonemap: &str, denoise: bool) -> PyResult<()> {
        let tone = self::tonemap(tonemap)?;
        let finished = Arc::clone(&self.finished);
        py.detach(move || {
            let denoised = if denoise {
                let mut oidn = Oidn::load().map_err(|e| PyOSError::new_err(e.to_string()))?;
                let image = finished
                    .denoised(&mut oidn)
                    .map_err(|e| PyOSError::new_err(e.to_string()))?;
                Some(image)
            } else {
                None
            };
            let f = &finished;
            lumo::job::write_with_passes(
                &path,
                tone,
                &f.sums,
                f.aovs(),
                (&f.window(), f.width(), f.height()),
                denoised.as_ref(),
            )
            .map_err(|e| match e {
                lumo::output::ImageIoError::Format { .. } => PyValueError::new_err(e.to_string()),
                lumo::output::ImageIoError::Io { .. } => PyOSError::new_err(e.to_string()),
            })
        })
    }

    /// Writes the per-pixel standard error (linear; ``.exr`` or ``.hdr``), as
    /// ``lumo render --error-image`` does.
    fn write_std_error(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let f = &self.finished;
        write_full_image(
            py,
            &f.std_error,
            &f.window(),
            (f.width(), f.height()),
            path,
            lumo::output::ToneMap::Clamp,
        )
    }

    /// The image as PNG bytes (clamped, sRGB), for notebooks.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let dir = tempfile::tempdir()
            .map_err(|e| PyRuntimeError::new_err(format!("cannot make a temporary folder: {e}")))?;
        let path = dir.path().join("image.png");
        let f = &self.finished;
        write_full_image(
            py,
            &f.image,
            &f.window(),
            (f.width(), f.height()),
            path.clone(),
            lumo::output::ToneMap::Clamp,
        )?;
        let bytes = std::fs::read(&path).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(PyBytes::new(py, &bytes))
    }

    fn __repr__(&self) -> String {
        let w = self.finished.window();
        format!(
            "<lumo.RenderResult {}×{} at {} spp in {:.3} s{}>",
            w.width(),
            w.height(),
            self.finished.samples_per_pixel(),
            self.finished.stats.elapsed.as_secs_f64(),
            if self.finished.interrupted {
                ", interrupted"
            } else {
                ""
            }
        )
    }
}

/// What the worker thread tells the calling thread.
enum Message {
    /// The job is built: its total samples (`None` when open-ended) and warnings.
    Started(Option<u64>, Vec<String>),
    /// The job is done (or failed).
    Done(Box<Result<Finished, JobError>>, Vec<String>),
}

/// The settings of `lumo.render`'s keyword arguments.
pub struct Request {
    pub settings: JobSettings,
    pub seed: Option<u64>,
}

/// Parses the keyword arguments into job settings.
#[allow(clippy::too_many_arguments)]
pub fn request(
    spp: Option<u32>,
    seed: Option<u64>,
    threads: Option<usize>,
    time: Option<f64>,
    target_error: Option<f64>,
    samples: Option<(u32, u32)>,
    crop: Option<(u32, u32, u32, u32)>,
    adaptive: bool,
    light_sampler: &str,
    aovs: AovSet,
) -> PyResult<Request> {
    let bad = |m: String| Err(PyValueError::new_err(m));
    if spp == Some(0) {
        return bad("spp= must be at least 1".into());
    }
    if let Some(s) = spp {
        if s > lumo_schema::MAX_SPP {
            return bad(format!(
                "spp={s} is above lumo's limit of {}",
                lumo_schema::MAX_SPP
            ));
        }
    }
    if threads == Some(0) {
        return bad("threads= must be at least 1 (None: all cores)".into());
    }
    if let Some(t) = time {
        if !(t.is_finite() && t > 0.0) {
            return bad(format!("time={t} is not a positive number of seconds"));
        }
    }
    if let Some(e) = target_error {
        if !(e.is_finite() && e > 0.0) {
            return bad(format!("target_error={e} is not a positive number"));
        }
    }
    if let Some((a, b)) = samples {
        if a >= b {
            return bad(format!(
                "samples=({a}, {b}) is empty: give (start, end) with start < end"
            ));
        }
    }
    let crop = match crop {
        Some((x0, y0, x1, y1)) if x0 < x1 && y0 < y1 => Some(Window { x0, y0, x1, y1 }),
        Some(c) => {
            return bad(format!(
                "crop={c:?} is not a window (x0, y0, x1, y1) with x0 < x1 and y0 < y1"
            ))
        }
        None => None,
    };
    let light_sampler = match light_sampler {
        "auto" => LightChoice::Auto,
        "power" => LightChoice::Power,
        "tree" => LightChoice::Tree,
        other => {
            return bad(format!(
                "light_sampler={other:?}: expected \"auto\", \"power\" or \"tree\""
            ))
        }
    };
    Ok(Request {
        settings: JobSettings {
            spp,
            samples,
            crop,
            time_s: time.map(|t| t as f32),
            target_error,
            adaptive,
            light_sampler,
            threads,
            aovs,
            ..JobSettings::default()
        },
        seed,
    })
}

/// Why the calling thread stopped waiting before the job was done.
enum Stop {
    /// The progress callback returned False.
    Callback,
    /// An exception: a signal's (KeyboardInterrupt) or the callback's.
    Raised(PyErr),
}

/// Renders `scene` with `request` on a worker thread; see `lumo.render`.
pub fn render(
    py: Python<'_>,
    scene: &Scene,
    request: Request,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<RenderResult> {
    let mut loaded = (*scene.loaded).clone();
    if let Some(seed) = request.seed {
        loaded
            .edit(|s| s.render.seed = seed)
            .map_err(|e| crate::errors::load_error(py, e))?;
    }
    let cancel = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicU64::new(0));
    let (tx, rx) = mpsc::channel::<Message>();
    // Shared with the closure that waits without the GIL, which must be Sync.
    let rx = Mutex::new(rx);
    let worker = {
        let (cancel, done) = (Arc::clone(&cancel), Arc::clone(&done));
        let settings = request.settings;
        std::thread::Builder::new()
            .name("lumo-render".into())
            .spawn(move || {
                let job = match RenderJob::new(&loaded, settings) {
                    Ok(job) => job,
                    Err(e) => {
                        let _ = tx.send(Message::Done(Box::new(Err(e)), Vec::new()));
                        return;
                    }
                };
                drop(loaded);
                let _ = tx.send(Message::Started(
                    job.total_samples(),
                    job.warnings().to_vec(),
                ));
                let warned = Mutex::new(Vec::new());
                let progress = |n: u64| done.store(n, Ordering::Relaxed);
                let warn = |w: &str| {
                    if let Ok(mut v) = warned.lock() {
                        v.push(w.to_string());
                    }
                };
                let hooks = Hooks {
                    progress: Some(&progress),
                    cancel: Some(&cancel),
                    warn: Some(&warn),
                    on_pass: None,
                };
                let result = job.run(&hooks);
                let warned = warned.into_inner().unwrap_or_default();
                let _ = tx.send(Message::Done(Box::new(result), warned));
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the render thread: {e}")))?
    };
    let mut total = None;
    let mut warnings = Vec::new();
    let mut reported = None;
    let mut stop: Option<Stop> = None;
    let outcome = loop {
        // Without the GIL: other Python threads run while this one waits.
        let message = py.detach(|| match rx.lock() {
            Ok(rx) => rx.recv_timeout(SLICE),
            Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
        });
        match message {
            Ok(Message::Started(t, w)) => {
                total = t;
                warnings = w;
            }
            Ok(Message::Done(result, w)) => {
                warnings.extend(w);
                break *result;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                let _ = worker.join();
                return Err(PyRuntimeError::new_err(
                    "internal error: the render thread ended without a result",
                ));
            }
        }
        if stop.is_some() {
            // Cancelled: wait for the job to stop (within a tile), ignoring further signals.
            continue;
        }
        // A signal's handler runs here: Ctrl-C raises KeyboardInterrupt.
        if let Err(e) = py.check_signals() {
            stop = Some(Stop::Raised(e));
        } else if let Some(cb) = &progress {
            let now = done.load(Ordering::Relaxed);
            if reported != Some(now) {
                reported = Some(now);
                match cb.call1((now, total)) {
                    Ok(v) if v.cast::<PyBool>().is_ok_and(|b| !b.is_true()) => {
                        stop = Some(Stop::Callback);
                    }
                    Ok(_) => {}
                    Err(e) => stop = Some(Stop::Raised(e)),
                }
            }
        }
        if stop.is_some() {
            cancel.store(true, Ordering::Relaxed);
        }
    };
    let _ = py.detach(|| worker.join());
    let finished = outcome.map_err(|e| job_error(py, e))?;
    if let (None, Some(cb)) = (&stop, &progress) {
        // The last count, so that a progress bar ends full.
        let now = done.load(Ordering::Relaxed).max(finished.stats.samples);
        if reported != Some(now) {
            cb.call1((now, total))?;
        }
    }
    emit_warnings(py, &warnings)?;
    let result = RenderResult::new(py, finished, warnings)?;
    match stop {
        None => Ok(result),
        Some(Stop::Callback) => {
            let err = RenderCancelled::new_err("the render was cancelled by its progress callback");
            err.value(py).setattr("result", Py::new(py, result)?)?;
            Err(err)
        }
        Some(Stop::Raised(err)) => {
            // Keep the samples taken so far on the exception (KeyboardInterrupt's `result`).
            let _ = err.value(py).setattr("result", Py::new(py, result)?);
            Err(err)
        }
    }
}

/// Issues the job's warnings as Python warnings (`lumo.LumoWarning`; Python shows each once).
fn emit_warnings(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    if warnings.is_empty() {
        return Ok(());
    }
    let category = py.get_type::<LumoWarning>();
    let warn = py.import("warnings")?.getattr("warn")?;
    for w in warnings {
        warn.call1((w.as_str(), &category, 2))?;
    }
    Ok(())
}
