//! Renders that survive interruption and split across processes: `--samples`, `--crop`,
//! `--film`, checkpoints, `--resume`, signal handling, and `lumo merge`.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use lumo::job;
use lumo::output::ToneMap;
use lumo::partial_film::{self, PartialFilm};
use lumo::render::Window;

use super::{CliError, EXIT_INVALID};

/// Exit code after SIGINT (128 + 2).
pub const EXIT_SIGINT: i32 = 130;
/// Exit code after SIGTERM (128 + 15).
pub const EXIT_SIGTERM: i32 = 143;

/// Parses `A..B` (sample indices A to B − 1).
pub fn parse_samples(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{text}` is not a sample range A..B with A < B (e.g. 64..128)");
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    let (a, b) = (
        a.trim().parse::<u32>().map_err(|_| bad())?,
        b.trim().parse::<u32>().map_err(|_| bad())?,
    );
    if a >= b {
        return Err(bad());
    }
    Ok((a, b))
}

/// Parses `x0,y0,x1,y1` (pixels x0..x1 × y0..y1).
pub fn parse_crop(text: &str) -> Result<Window, String> {
    let bad = || format!("`{text}` is not a window x0,y0,x1,y1 with x0 < x1 and y0 < y1");
    let v: Vec<u32> = text
        .split(',')
        .map(|p| p.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok(Window { x0, y0, x1, y1 }),
        _ => Err(bad()),
    }
}

/// [`lumo::job::check_writable`] with the CLI's exit codes.
pub fn check_writable(path: &Path, what: &str) -> Result<(), CliError> {
    Ok(job::check_writable(path, what)?)
}

/// SIGINT and SIGTERM: the first sets `cancel` (the render stops taking work and saves what it
/// has); a second one exits at once with 130 or 143 (outputs are written by rename, so no file
/// is left half-written).
pub struct Signals {
    /// Set by the first signal.
    pub cancel: Arc<AtomicBool>,
    sigterm: Arc<AtomicBool>,
}

impl Signals {
    /// Installs the handlers.
    pub fn install() -> Result<Signals, CliError> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        use signal_hook::flag;
        let cancel = Arc::new(AtomicBool::new(false));
        let sigterm = Arc::new(AtomicBool::new(false));
        let fail = |e: std::io::Error| CliError::failure(format!("cannot handle signals: {e}"));
        // Registered before the flag setters: the second signal finds `cancel` set and exits.
        flag::register_conditional_shutdown(SIGINT, EXIT_SIGINT, Arc::clone(&cancel))
            .map_err(fail)?;
        flag::register_conditional_shutdown(SIGTERM, EXIT_SIGTERM, Arc::clone(&cancel))
            .map_err(fail)?;
        flag::register(SIGTERM, Arc::clone(&sigterm)).map_err(fail)?;
        flag::register(SIGINT, Arc::clone(&cancel)).map_err(fail)?;
        flag::register(SIGTERM, Arc::clone(&cancel)).map_err(fail)?;
        Ok(Signals { cancel, sigterm })
    }

    /// The exit code of an interrupted render: 143 after SIGTERM, else 130.
    pub fn exit_code(&self) -> i32 {
        if self.sigterm.load(Ordering::Relaxed) {
            EXIT_SIGTERM
        } else {
            EXIT_SIGINT
        }
    }
}

/// Reads a partial film, mapping errors to exit codes (2 for a bad file, 1 for I/O).
pub fn read_film(path: &Path) -> Result<PartialFilm, CliError> {
    PartialFilm::read(path).map_err(|e| CliError {
        code: if e.io {
            super::EXIT_FAILURE
        } else {
            EXIT_INVALID
        },
        message: e.to_string(),
    })
}

/// Writes a partial film, mapping errors to exit code 1.
pub fn write_film(film: &PartialFilm, path: &Path) -> Result<(), CliError> {
    film.write(path)
        .map_err(|e| CliError::failure(e.to_string()))
}

/// `lumo merge`.
pub fn merge_cmd(
    parts: &[PathBuf],
    output: Option<&Path>,
    film_out: Option<&Path>,
    allow_partial: bool,
    tonemap: ToneMap,
) -> Result<(), CliError> {
    if let Some(o) = output {
        job::check_image_path(o, "output")?;
    }
    if let Some(f) = film_out {
        job::check_film_path(f, "merged film")?;
    }
    let films = parts
        .iter()
        .map(|p| read_film(p))
        .collect::<Result<Vec<_>, _>>()?;
    let merged = partial_film::merge(&films).map_err(|(i, m)| {
        CliError::invalid(format!(
            "{}: {m} (first film: {})",
            parts[i].display(),
            parts[0].display()
        ))
    })?;
    if output.is_some() && !merged.gaps.is_empty() && !allow_partial {
        return Err(CliError::invalid(format!(
            "the films do not make a complete render:\n  {}\n(pass --allow-partial to merge them anyway: each pixel then averages the samples it has)",
            merged.gaps.join("\n  ")
        )));
    }
    if let Some(f) = film_out {
        if !merged.uniform {
            return Err(CliError::invalid(format!(
                "{}: a partial film holds the same samples in every pixel, and these films do not:\n  {}",
                f.display(),
                merged.gaps.join("\n  ")
            )));
        }
        write_film(
            &PartialFilm {
                header: merged.header.clone(),
                film: merged.film.clone(),
            },
            f,
        )?;
        eprintln!("wrote {}", f.display());
    }
    if let Some(o) = output {
        let aovs = merged
            .header
            .aov_set()
            .map_err(|e| CliError::invalid(format!("{}: {e}", parts[0].display())))?;
        job::write_with_passes(
            o,
            tonemap,
            &merged.film,
            aovs,
            (
                &merged.header.window(),
                merged.header.width,
                merged.header.height,
            ),
            None,
        )
        .map_err(|e| CliError::failure(e.to_string()))?;
        eprintln!(
            "merged {} films ({} samples per pixel{}) → {}",
            films.len(),
            if merged.uniform {
                partial_film::ranges_text(&merged.header.samples)
            } else {
                "varying".to_string()
            },
            if merged.gaps.is_empty() {
                ""
            } else {
                ", with gaps"
            },
            o.display()
        );
    }
    Ok(())
}
