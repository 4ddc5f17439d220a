//! Problems found in a scene, each pointing at the exact spot.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::locate::{JsonPath, LineCol};

/// One problem in a scene file: where it is, what is wrong, and how to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// JSON path of the offending value (`objects[3].sphere.radius`).
    pub path: JsonPath,
    /// Line and column of the offending value in the file, when the text is known.
    pub location: Option<LineCol>,
    /// What is wrong.
    pub message: String,
    /// How to fix it, when there is an obvious fix (e.g. "did you mean `white`?").
    pub help: Option<String>,
    /// Where `location` is, when it is not in the file the report is about.
    pub source: Option<Box<Source>>,
}

/// Where a diagnostic is, when it is not in the file the report is about.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// An included fragment, a merge patch, or a command-line argument (`--set #2`).
    pub file: PathBuf,
    /// The chain of includes that brought `file` in, innermost first: each the including file
    /// and where it names the fragment.
    pub included_from: Vec<(PathBuf, LineCol)>,
}

impl Diagnostic {
    /// A diagnostic at `path` with no location yet (filled in by [`crate::load_scene_str`]).
    pub fn new(path: JsonPath, message: impl Into<String>) -> Self {
        Diagnostic {
            path,
            location: None,
            message: message.into(),
            help: None,
            source: None,
        }
    }

    /// The file `location` is in, when it is not the report's.
    pub fn file(&self) -> Option<&Path> {
        self.source.as_deref().map(|s| s.file.as_path())
    }

    /// Places the diagnostic in `file` (keeping the chain of includes, if any).
    pub fn set_file(&mut self, file: impl Into<PathBuf>) {
        match &mut self.source {
            Some(s) => s.file = file.into(),
            None => {
                self.source = Some(Box::new(Source {
                    file: file.into(),
                    included_from: Vec::new(),
                }))
            }
        }
    }

    /// Adds a suggestion.
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(at) = self.location {
            write!(f, "{}:{}: ", at.line, at.column)?;
        }
        write!(f, "{}: {}", self.path, self.message)?;
        if let Some(help) = &self.help {
            write!(f, " (help: {help})")?;
        }
        Ok(())
    }
}

/// Why a scene file could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The file was read but is not a valid scene.
    #[error("{}", Report { file: file.clone(), diagnostics: diagnostics.clone() })]
    Invalid {
        /// The file (or a label such as `<stdin>`).
        file: PathBuf,
        /// Every problem found, in document order.
        diagnostics: Vec<Diagnostic>,
    },
}

/// A list of diagnostics for one file, printed one per line as `file:line:col: path: message`.
#[derive(Debug, Clone)]
pub struct Report {
    /// The file the diagnostics are about.
    pub file: PathBuf,
    /// The diagnostics.
    pub diagnostics: Vec<Diagnostic>,
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.diagnostics.len();
        writeln!(
            f,
            "{}: {} problem{}:",
            self.file.display(),
            n,
            if n == 1 { "" } else { "s" }
        )?;
        for d in &self.diagnostics {
            let file = d.file().unwrap_or(&self.file);
            writeln!(f, "  {}:{d}", file.display())?;
            let chain = d
                .source
                .as_deref()
                .map_or(&[][..], |s| &s.included_from[..]);
            for (by, at) in chain {
                writeln!(
                    f,
                    "    included from {}:{}:{}",
                    by.display(),
                    at.line,
                    at.column
                )?;
            }
        }
        Ok(())
    }
}

/// The closest candidate to `word` by edit distance, if it is close enough to be a likely typo.
pub fn did_you_mean<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (edit_distance(&word.to_lowercase(), &c.to_lowercase()), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// Levenshtein distance between two strings, in characters.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_close_names_only() {
        assert_eq!(
            did_you_mean("whte", ["white", "red", "green"]),
            Some("white")
        );
        assert_eq!(did_you_mean("blue", ["white", "red", "green"]), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
