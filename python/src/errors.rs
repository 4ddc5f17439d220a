//! Errors as Python sees them: [`Diagnostic`] objects, `lumo.SceneError` (a `ValueError` with
//! the diagnostics and the CLI's report as its message), and the mapping of the library's
//! errors to Python exceptions.

use std::path::Path;

use lumo::job::JobError;
use lumo::load::LoadError;
use lumo_schema as schema;
use pyo3::exceptions::{PyException, PyOSError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyList;

pyo3::create_exception!(
    lumo,
    SceneError,
    PyValueError,
    "A scene that is not valid, or an override that does not fit it.\n\n\
     ``diagnostics`` lists every problem (``lumo.Diagnostic``: file, line, column, JSON path, \
     message, help); ``str(e)`` is the report ``lumo validate`` prints; ``file`` is the scene \
     file (or the label of a dict)."
);

pyo3::create_exception!(
    lumo,
    RenderCancelled,
    PyException,
    "A render stopped because its progress callback returned False.\n\n\
     ``result`` holds what it had rendered (a ``lumo.RenderResult`` with ``interrupted`` set): \
     the whole passes finished before the callback asked to stop."
);

pyo3::create_exception!(
    lumo,
    LumoWarning,
    PyUserWarning,
    "Something lumo dropped or approximated while loading or building a scene."
);

/// One problem in a scene: where it is, what is wrong and how to fix it.
#[pyclass(frozen, module = "lumo")]
#[derive(Clone)]
pub struct Diagnostic {
    /// The scene file (or the label of a dict, `<dict>`); None when not known.
    #[pyo3(get)]
    pub file: Option<String>,
    /// 1-based line in the file, when the problem has a place in its text.
    #[pyo3(get)]
    pub line: Option<usize>,
    /// 1-based column (in characters), with `line`.
    #[pyo3(get)]
    pub column: Option<usize>,
    /// The JSON path of the value at fault (`objects[3].sphere.radius`); empty when the problem
    /// has no place in the scene's JSON (a file that cannot be read, a legacy file's syntax).
    #[pyo3(get)]
    pub path: String,
    /// What is wrong.
    #[pyo3(get)]
    pub message: String,
    /// How to fix it, when there is an obvious fix.
    #[pyo3(get)]
    pub help: Option<String>,
}

#[pymethods]
impl Diagnostic {
    /// The line `lumo validate` prints: `file:line:column: path: message (help: …)`.
    fn __str__(&self) -> String {
        let mut s = String::new();
        if let Some(f) = &self.file {
            s.push_str(f);
            s.push(':');
        }
        if let (Some(l), Some(c)) = (self.line, self.column) {
            s.push_str(&format!("{l}:{c}:"));
        }
        if !s.is_empty() {
            s.push(' ');
        }
        if !self.path.is_empty() {
            s.push_str(&self.path);
            s.push_str(": ");
        }
        s.push_str(&self.message);
        if let Some(h) = &self.help {
            s.push_str(&format!(" (help: {h})"));
        }
        s
    }

    fn __repr__(&self) -> String {
        let opt = |v: &Option<String>| v.as_ref().map_or("None".to_string(), |s| format!("{s:?}"));
        let num = |v: Option<usize>| v.map_or("None".to_string(), |n| n.to_string());
        format!(
            "Diagnostic(file={}, line={}, column={}, path={:?}, message={:?}, help={})",
            opt(&self.file),
            num(self.line),
            num(self.column),
            self.path,
            self.message,
            opt(&self.help)
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Diagnostic>().is_ok_and(|o| {
            let o = o.get();
            (
                &self.file,
                self.line,
                self.column,
                &self.path,
                &self.message,
                &self.help,
            ) == (&o.file, o.line, o.column, &o.path, &o.message, &o.help)
        })
    }
}

impl Diagnostic {
    /// A located diagnostic of the schema.
    pub fn located(file: &Path, d: &schema::Diagnostic) -> Diagnostic {
        Diagnostic {
            file: Some(d.file().unwrap_or(file).display().to_string()),
            line: d.location.map(|l| l.line),
            column: d.location.map(|l| l.column),
            path: d.path.to_string(),
            message: d.message.clone(),
            help: d.help.clone(),
        }
    }

    /// A problem with no place in the JSON: the message names the file itself.
    pub fn unplaced(file: &Path, message: &str) -> Diagnostic {
        // The library's messages start with the file's name; the diagnostic holds it apart.
        let name = file.display().to_string();
        let message = message
            .strip_prefix(&name)
            .and_then(|m| m.strip_prefix(':'))
            .map_or(message, str::trim_start);
        Diagnostic {
            file: Some(name),
            line: None,
            column: None,
            path: String::new(),
            message: message.to_string(),
            help: None,
        }
    }

    /// The diagnostics of a load error: the located ones of an invalid scene, else one that
    /// carries the message.
    pub fn of_load_error(e: &LoadError) -> Vec<Diagnostic> {
        match e {
            LoadError::Invalid { file, diagnostics } => diagnostics
                .iter()
                .map(|d| Diagnostic::located(file, d))
                .collect(),
            LoadError::Io { file, message } | LoadError::Rejected { file, message } => {
                vec![Diagnostic::unplaced(file, message)]
            }
        }
    }
}

/// `lumo.SceneError` with `message` (the report), `diagnostics` and `file`.
pub fn scene_error(
    py: Python<'_>,
    message: String,
    file: &Path,
    diagnostics: Vec<Diagnostic>,
) -> PyErr {
    let err = SceneError::new_err(message);
    let set = || -> PyResult<()> {
        let value = err.value(py);
        value.setattr("diagnostics", PyList::new(py, diagnostics)?)?;
        value.setattr("file", file.display().to_string())?;
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// The Python exception for a load error: `OSError` when a file could not be read, else
/// `lumo.SceneError`.
pub fn load_error(py: Python<'_>, e: LoadError) -> PyErr {
    if e.is_io() {
        return PyOSError::new_err(e.to_string());
    }
    let diagnostics = Diagnostic::of_load_error(&e);
    scene_error(py, e.to_string(), e.file(), diagnostics)
}

/// The Python exception for a job error: load errors as [`load_error`], I/O as `OSError`,
/// settings that do not fit the scene as `ValueError`.
pub fn job_error(py: Python<'_>, e: JobError) -> PyErr {
    match e {
        JobError::Load(e) => load_error(py, e),
        JobError::Io(m) => PyOSError::new_err(m),
        JobError::Invalid(m) | JobError::Resume(m) => PyValueError::new_err(m),
    }
}
