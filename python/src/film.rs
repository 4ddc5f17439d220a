//! `lumo.Film`: a partial film (the exact per-pixel sums of a sample range of a render, or of
//! a window of it), read, written and merged as `lumo render --film` and `lumo merge` do.

use std::path::PathBuf;
use std::sync::Arc;

use lumo::job::{self, Finished};
use lumo::output::ToneMap;
use lumo::partial_film::{self, PartialFilm};
use numpy::PyArray3;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{array, pixels, Source};

/// Where a film's sums live.
pub enum FilmSource {
    /// The film of a render result, shared with it.
    Finished(Arc<Finished>),
    /// A film of its own (read from a file, or merged).
    Owned(Box<PartialFilm>),
}

/// A partial film: the exact sums of some sample indices of some pixels of one render. Films of
/// one scene and build merge bit for bit into the render that takes all their samples
/// (``lumo.merge``). Written as the ``.npz`` that ``lumo render --film`` writes.
#[pyclass(frozen, module = "lumo")]
pub struct Film {
    source: FilmSource,
    /// Whether every pixel holds the same sample indices (merged films may not).
    uniform: bool,
    /// What is missing for a complete image (merged films).
    gaps: Vec<String>,
}

impl Film {
    /// The film of a render.
    pub fn of_result(finished: Arc<Finished>) -> Film {
        Film {
            uniform: finished.uniform,
            source: FilmSource::Finished(finished),
            gaps: Vec::new(),
        }
    }

    /// The partial film.
    pub fn film(&self) -> &PartialFilm {
        match &self.source {
            FilmSource::Finished(f) => f.film(),
            FilmSource::Owned(f) => f,
        }
    }
}

/// A tone map by name.
pub fn tonemap(name: &str) -> PyResult<ToneMap> {
    use lumo_schema::Keyword;
    ToneMap::from_keyword(name).map_err(|e| PyValueError::new_err(format!("tonemap=: {e}")))
}

/// Writes `image` (the window of a `width` × `height` render) at full size, atomically.
pub fn write_full_image(
    py: Python<'_>,
    image: &lumo::image::Image,
    window: &lumo::render::Window,
    size: (u32, u32),
    path: PathBuf,
    tonemap: ToneMap,
) -> PyResult<()> {
    py.detach(|| {
        let full = job::embed(image, window, size.0, size.1);
        lumo::output::write_image(&full, &path, tonemap)
    })
    .map_err(|e| match e {
        lumo::output::ImageIoError::Format { .. } => PyValueError::new_err(e.to_string()),
        lumo::output::ImageIoError::Io { .. } => PyOSError::new_err(e.to_string()),
    })
}

#[pymethods]
impl Film {
    /// Reads a partial film (``.npz``) and checks it: a truncated, corrupt or inconsistent file
    /// raises ``ValueError`` naming the file and the problem; one that cannot be read,
    /// ``OSError``.
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Film> {
        match py.detach(|| PartialFilm::read(&path)) {
            Ok(f) => Ok(Film {
                source: FilmSource::Owned(Box::new(f)),
                uniform: true,
                gaps: Vec::new(),
            }),
            Err(e) if e.io => Err(PyOSError::new_err(e.to_string())),
            Err(e) => Err(PyValueError::new_err(e.to_string())),
        }
    }

    /// Writes the film atomically as a ``.npz`` partial film (``lumo merge`` reads it). A
    /// merged film whose pixels hold different samples cannot be written (``ValueError``).
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        if !self.uniform {
            return Err(PyValueError::new_err(format!(
                "{}: a partial film holds the same samples in every pixel, and this one does \
                 not:\n  {}",
                path.display(),
                self.gaps.join("\n  ")
            )));
        }
        py.detach(|| -> Result<(), job::JobError> {
            job::check_film_path(&path, "film")?;
            self.film()
                .write(&path)
                .map_err(|e| job::JobError::Io(e.to_string()))
        })
        .map_err(|e| crate::errors::job_error(py, e))
    }

    /// The mean radiance of the film's window: an (h, w, 3) float32 array (a new buffer each
    /// call, owned by the array).
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let image = py.detach(|| self.film().film.image());
        array(pixels(py, Source::Owned(image))?.bind(py))
    }

    /// The render passes the film holds (its render's ``aov``), by name: a new dict of new
    /// arrays of the film's window, shaped as ``RenderResult.passes``.
    fn passes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let film = self.film();
        let set = film.header.aov_set().map_err(PyValueError::new_err)?;
        let passes = py.detach(|| film.film.passes(set));
        let width = film.header.window().width();
        let dict = PyDict::new(py);
        for pass in passes {
            let name = pass.aov.name();
            dict.set_item(name, crate::render::pass_array(py, pass, width)?)?;
        }
        Ok(dict)
    }

    /// The standard error of each pixel's mean, per channel: an (h, w, 3) float32 array.
    fn std_error<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let image = py.detach(|| self.film().film.std_error());
        array(pixels(py, Source::Owned(image))?.bind(py))
    }

    /// Writes the film's image at the render's full size (black outside its window), as
    /// ``lumo merge -o`` does: PNG/BMP tone mapped to 8-bit sRGB, EXR/HDR linear.
    #[pyo3(signature = (path, tonemap = "clamp"))]
    fn write_image(&self, py: Python<'_>, path: PathBuf, tonemap: &str) -> PyResult<()> {
        let tone = self::tonemap(tonemap)?;
        let f = self.film();
        let image = py.detach(|| f.film.image());
        write_full_image(
            py,
            &image,
            &f.header.window(),
            (f.header.width, f.header.height),
            path,
            tone,
        )
    }

    /// The film's header as a dict (format, build id, scene hash, size, crop window, seed,
    /// sampler, sample ranges), as stored in the file.
    #[getter]
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.film().header)
            .map_err(|e| PyValueError::new_err(format!("internal error: {e}")))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Full image width of the render.
    #[getter]
    fn width(&self) -> u32 {
        self.film().header.width
    }

    /// Full image height of the render.
    #[getter]
    fn height(&self) -> u32 {
        self.film().header.height
    }

    /// The window of the image the film covers: ``(x0, y0, x1, y1)``.
    #[getter]
    fn crop(&self) -> (u32, u32, u32, u32) {
        let [x0, y0, x1, y1] = self.film().header.crop;
        (x0, y0, x1, y1)
    }

    /// The sample indices every pixel holds, as ``[(start, end), …]`` (empty for a merged
    /// film whose pixels hold different samples).
    #[getter]
    fn samples(&self) -> Vec<(u32, u32)> {
        self.film()
            .header
            .samples
            .iter()
            .map(|r| (r[0], r[1]))
            .collect()
    }

    /// Samples per pixel the film holds.
    #[getter]
    fn spp(&self) -> u64 {
        self.film().header.spp()
    }

    /// The build that rendered it (SHA-256 of the lumo binary or extension module).
    #[getter]
    fn build_id(&self) -> String {
        self.film().header.build_id.clone()
    }

    /// The content hash of the scene it is of.
    #[getter]
    fn scene_hash(&self) -> String {
        self.film().header.scene_hash.clone()
    }

    /// Whether the film makes a complete image: every pixel of its window holds the same
    /// samples, with no index missing between its ranges.
    #[getter]
    fn complete(&self) -> bool {
        self.uniform && self.gaps.is_empty()
    }

    /// What is missing for a complete image (merged films): pixels without samples, pixels
    /// with fewer samples than others, sample indices absent between the ranges.
    #[getter]
    fn gaps(&self) -> Vec<String> {
        self.gaps.clone()
    }

    fn __repr__(&self) -> String {
        let h = &self.film().header;
        let samples = if h.samples.is_empty() {
            "varying samples".to_string()
        } else {
            format!("samples {}", partial_film::ranges_text(&h.samples))
        };
        format!(
            "<lumo.Film {}×{} crop {:?} {samples}>",
            h.width, h.height, h.crop
        )
    }
}

/// Merges partial films of one render (sample ranges and/or crop windows) by adding their exact
/// sums: the result is bit for bit the render that takes all their samples, whatever the order.
/// Films of another scene, build, size, seed or sampler, or overlapping samples, raise
/// ``ValueError`` naming the film. Unless ``allow_partial``, the films must make a complete
/// image.
#[pyfunction]
#[pyo3(signature = (films, allow_partial = false))]
pub fn merge(py: Python<'_>, films: Vec<PyRef<'_, Film>>, allow_partial: bool) -> PyResult<Film> {
    let parts: Vec<PartialFilm> = films.iter().map(|f| f.film().clone()).collect();
    let merged = py
        .detach(|| partial_film::merge(&parts))
        .map_err(|(i, m)| PyValueError::new_err(format!("films[{i}]: {m}")))?;
    if !merged.gaps.is_empty() && !allow_partial {
        return Err(PyValueError::new_err(format!(
            "the films do not make a complete render:\n  {}\n(pass allow_partial=True to merge \
             them anyway: each pixel then averages the samples it has)",
            merged.gaps.join("\n  ")
        )));
    }
    Ok(Film {
        source: FilmSource::Owned(Box::new(PartialFilm {
            header: merged.header,
            film: merged.film,
        })),
        uniform: merged.uniform,
        gaps: merged.gaps,
    })
}
