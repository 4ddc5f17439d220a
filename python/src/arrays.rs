//! Images as numpy arrays without a copy: an (H, W, 3) float32 array whose memory is the
//! image's own pixel buffer, kept alive by the array's `base` (a [`Pixels`] object).

use std::sync::Arc;

use lumo::image::Image;
use lumo::job::Finished;
use numpy::ndarray::ArrayView3;
use numpy::PyArray3;
use pyo3::prelude::*;

// A pixel is three packed f32 (glam's Vec3), so a pixel buffer is an (H, W, 3) f32 array in
// place.
const _: () = assert!(std::mem::size_of::<glam::Vec3>() == 12);
const _: () = assert!(std::mem::align_of::<glam::Vec3>() == 4);

/// Which image of a render.
#[derive(Clone, Copy)]
pub enum Which {
    /// The mean radiance.
    Color,
    /// The per-pixel standard error.
    StdError,
}

/// Where an image's pixels live.
pub enum Source {
    /// An image of a finished render, shared with the result.
    Finished(Arc<Finished>, Which),
    /// An image of its own (a film's mean).
    Owned(Image),
}

/// The owner of an image's pixels: the `base` of the arrays that show them. Its pixels never
/// change or move while it lives.
#[pyclass(frozen, module = "lumo")]
pub struct Pixels {
    source: Source,
}

impl Pixels {
    /// The image.
    pub fn image(&self) -> &Image {
        match &self.source {
            Source::Finished(f, Which::Color) => &f.image,
            Source::Finished(f, Which::StdError) => &f.std_error,
            Source::Owned(image) => image,
        }
    }
}

#[pymethods]
impl Pixels {
    fn __repr__(&self) -> String {
        let i = self.image();
        format!("<lumo pixel buffer {}×{}×3 float32>", i.height, i.width)
    }
}

/// A new owner of an image's pixels.
pub fn pixels(py: Python<'_>, source: Source) -> PyResult<Py<Pixels>> {
    Py::new(py, Pixels { source })
}

/// A read-only (H, W, 3) float32 array of the owner's pixels, without a copy.
pub fn array<'py>(owner: &Bound<'py, Pixels>) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let image = owner.get().image();
    let (h, w) = (image.height as usize, image.width as usize);
    // SAFETY: Vec3 is three packed f32 (asserted above), so the pixel buffer is 3·n f32.
    let floats: &[f32] = unsafe {
        std::slice::from_raw_parts(image.pixels.as_ptr().cast::<f32>(), image.pixels.len() * 3)
    };
    let view = ArrayView3::from_shape((h, w, 3), floats).map_err(|e| {
        pyo3::exceptions::PyRuntimeError::new_err(format!(
            "internal error: an image of {w}×{h} pixels holds {} values: {e}",
            floats.len()
        ))
    })?;
    // SAFETY: the owner is the array's base, so it lives as long as the array; its pixels are
    // never changed, moved or reallocated (the class is frozen and offers no way to).
    let array = unsafe { PyArray3::borrow_from_array(&view, owner.clone().into_any()) };
    // The buffer is the result's: writing to it through one array would change what every
    // other array and `write()` see. `.copy()` gives an array to change.
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(array)
}
