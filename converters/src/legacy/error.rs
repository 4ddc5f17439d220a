//! Errors of the legacy converter, rendered like a compiler's: `file:line:col: message`, then the
//! offending line with a caret under the token (drawn by miette), then a suggestion.

use std::fmt;
use std::path::{Path, PathBuf};

use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, NamedSource};

use super::lexer::Span;

/// A problem at a place in the legacy text, before the file name is attached.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// Where (None: the file as a whole).
    pub span: Option<Span>,
    /// What is wrong: "expected X, found Y".
    pub message: String,
    /// How to fix it.
    pub help: Option<String>,
}

impl Problem {
    /// A problem at `span`.
    pub fn at(span: Span, message: impl Into<String>) -> Self {
        Problem {
            span: Some(span),
            message: message.into(),
            help: None,
        }
    }

    /// A problem with the file as a whole.
    pub fn whole(message: impl Into<String>) -> Self {
        Problem {
            span: None,
            message: message.into(),
            help: None,
        }
    }

    /// Adds a suggestion.
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

/// Why a legacy scene could not be imported. `Display` gives the full report: a
/// `file:line:col: error: …` header, the source line with a caret, and the help.
#[derive(Debug, thiserror::Error)]
pub enum LegacyError {
    /// The scene file could not be read.
    #[error("{}: cannot read the scene file: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The text is not a valid scene (syntax, or a value lumo cannot represent).
    #[error("{}", render(file, source_text, problem))]
    Invalid {
        /// The scene file (or a label).
        file: PathBuf,
        /// Its text, for the excerpt.
        source_text: String,
        /// What and where.
        problem: Box<Problem>,
    },
}

impl LegacyError {
    /// An error located in `text` of `file`.
    pub(crate) fn invalid(file: &Path, text: &str, problem: Problem) -> Self {
        LegacyError::Invalid {
            file: file.to_path_buf(),
            source_text: text.to_string(),
            problem: Box::new(problem),
        }
    }

    /// `(line, column)` of the error, 1-based, when it has a location.
    pub fn location(&self) -> Option<(u32, u32)> {
        match self {
            LegacyError::Invalid { problem, .. } => problem.span.map(|s| (s.line, s.col)),
            _ => None,
        }
    }

    /// The one-line message without location or excerpt.
    pub fn message(&self) -> String {
        match self {
            LegacyError::Io { source, .. } => format!("cannot read the scene file: {source}"),
            LegacyError::Invalid { problem, .. } => problem.message.clone(),
        }
    }

    /// The suggestion, if any.
    pub fn help(&self) -> Option<&str> {
        match self {
            LegacyError::Invalid { problem, .. } => problem.help.as_deref(),
            LegacyError::Io { .. } => None,
        }
    }
}

/// A miette diagnostic for one problem.
#[derive(Debug)]
struct Excerpt {
    message: String,
    help: Option<String>,
    label: LabeledSpan,
    source: NamedSource<String>,
}

impl fmt::Display for Excerpt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Excerpt {}

impl miette::Diagnostic for Excerpt {
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        Some(&self.source)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        Some(Box::new(std::iter::once(self.label.clone())))
    }
}

/// The full report text (no colours, so it reads the same in a terminal, a log or a test).
fn render(file: &Path, text: &str, p: &Problem) -> String {
    let mut out = String::new();
    let Some(span) = p.span else {
        out.push_str(&format!("{}: error: {}", file.display(), p.message));
        if let Some(h) = &p.help {
            out.push_str(&format!("\n  help: {h}"));
        }
        return out;
    };
    out.push_str(&format!(
        "{}:{}:{}: error: {}\n",
        file.display(),
        span.line,
        span.col,
        p.message
    ));
    let start = span.start.min(text.len());
    let len = span.end.saturating_sub(span.start).min(text.len() - start);
    let diag = Excerpt {
        message: p.message.clone(),
        help: p.help.clone(),
        label: LabeledSpan::new(Some("here".into()), start, len),
        source: NamedSource::new(file.display().to_string(), text.to_string()),
    };
    let handler = GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor())
        .with_width(100)
        .with_context_lines(1);
    let mut drawn = String::new();
    if handler.render_report(&mut drawn, &diag).is_ok() {
        // Our header line replaces miette's "× message" line; keep its excerpt and help.
        let body: Vec<&str> = drawn.lines().collect();
        for line in body.iter().skip_while(|l| !l.contains('╭')) {
            out.push_str(line);
            out.push('\n');
        }
        if let Some(h) = &p.help {
            if !drawn.contains("help:") {
                out.push_str(&format!("  help: {h}\n"));
            }
        }
    } else if let Some(h) = &p.help {
        out.push_str(&format!("  help: {h}\n"));
    }
    while out.ends_with('\n') {
        out.pop();
    }
    out
}

/// Why a scene cannot be written in the legacy format: everything it cannot express, listed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the scene cannot be written as a legacy text scene:\n{}", .problems.iter().map(|p| format!("  - {p}")).collect::<Vec<_>>().join("\n"))]
pub struct ExportError {
    /// One line per thing the legacy format cannot express, naming the JSON path.
    pub problems: Vec<String>,
}
