//! Reading the smallest pieces: keywords, braces, numbers, vectors, file names, and the nesting
//! depth.

use lumo_schema::did_you_mean;

use super::super::ast::*;
use super::super::error::Problem;
use super::super::lexer::{parse_float, parse_int, Span};
use super::{describe, shorten, Parser, MAX_COUNT, MAX_DEPTH};

impl Parser<'_> {
    /// The next token's span; at the end of the file, the last token's (so the excerpt shows
    /// where the text stops).
    pub(super) fn here(&mut self) -> Span {
        match self.lx.peek() {
            Some(t) => t.span,
            None => self.lx.last_span(),
        }
    }

    pub(super) fn unexpected(&mut self, expected: &str) -> Problem {
        let found = self.lx.peek();
        let span = self.here();
        let after = if found.is_none() && span.end > span.start {
            " after this"
        } else {
            ""
        };
        Problem::at(
            span,
            format!("expected {expected}, found {}{after}", describe(found)),
        )
    }

    pub(super) fn warn(&mut self, span: Span, msg: impl Into<String>) {
        self.doc.warnings.push((span, msg.into()));
    }

    /// Consumes the exact token `word`.
    pub(super) fn expect(&mut self, word: &str, context: &str) -> Result<Span, Problem> {
        match self.lx.peek() {
            Some(t) if t.text == word => {
                self.lx.next();
                Ok(t.span)
            }
            found => {
                let mut p = self.unexpected(&format!("`{word}` {context}"));
                if let Some(t) = found {
                    if t.text != word && did_you_mean(t.text, [word]).is_some() {
                        p = p.help(format!(
                            "did you mean `{word}`? (keywords are case-sensitive)"
                        ));
                    }
                }
                Err(p)
            }
        }
    }

    pub(super) fn open(&mut self, block: &str) -> Result<Span, Problem> {
        self.expect("{", &format!("to open the {block} block"))
    }

    /// Opens a `block` whose first field is its item count `field` (`numLights`, …) and reads
    /// the count.
    pub(super) fn open_counted(
        &mut self,
        block: &str,
        field: &str,
    ) -> Result<Located<i64>, Problem> {
        self.open(block)?;
        self.expect(field, &format!("as the first field of {block}"))?;
        self.count(field)
    }

    pub(super) fn close(&mut self, block: &str) -> Result<Span, Problem> {
        self.expect("}", &format!("to close the {block} block"))
    }

    pub(super) fn float(&mut self, what: &str) -> Result<Located<f32>, Problem> {
        self.number(what, "a number", parse_float, |text| {
            if text.contains(',') {
                Some("numbers are separated by spaces, not commas")
            } else if matches!(
                text.to_ascii_lowercase().as_str(),
                "inf" | "nan" | "infinity" | "-inf"
            ) {
                Some("write a finite number")
            } else {
                None
            }
        })
    }

    pub(super) fn int(&mut self, what: &str) -> Result<Located<i64>, Problem> {
        self.number(what, "an integer", parse_int, |text| {
            parse_float(text)
                .is_some()
                .then_some("write a whole number without a decimal point")
        })
    }

    /// Consumes a number read by `parse`; `kind` ("a number", "an integer") and `what` name it in
    /// the error, and `help` gives the fix for a token that does not parse, when it knows one.
    fn number<T>(
        &mut self,
        what: &str,
        kind: &str,
        parse: fn(&str) -> Option<T>,
        help: fn(&str) -> Option<&'static str>,
    ) -> Result<Located<T>, Problem> {
        let Some(t) = self.lx.peek() else {
            return Err(self.unexpected(&format!("{kind} ({what})")));
        };
        let Some(value) = parse(t.text) else {
            let p = Problem::at(
                t.span,
                format!("expected {kind} ({what}), found `{}`", shorten(t.text)),
            );
            return Err(match help(t.text) {
                Some(h) => p.help(h),
                None => p,
            });
        };
        self.lx.next();
        Ok(Located {
            value,
            span: t.span,
        })
    }

    pub(super) fn count(&mut self, what: &str) -> Result<Located<i64>, Problem> {
        let n = self.int(what)?;
        if n.value < 0 || n.value > MAX_COUNT {
            return Err(
                Problem::at(n.span, format!("{what} {} is out of range", n.value))
                    .help(format!("use 0 to {MAX_COUNT}")),
            );
        }
        Ok(n)
    }

    pub(super) fn vec3(&mut self, what: &str) -> Result<Located<V3>, Problem> {
        let x = self.float(&format!("x of {what}"))?;
        let y = self.float(&format!("y of {what}"))?;
        let z = self.float(&format!("z of {what}"))?;
        Ok(Located {
            value: [x.value, y.value, z.value],
            span: x.span.to(z.span),
        })
    }

    /// `keyword Vec3` in a fixed position.
    pub(super) fn field_vec3(&mut self, key: &str, block: &str) -> Result<Located<V3>, Problem> {
        self.expect(key, &format!("in {block}"))?;
        self.vec3(&format!("{block} {key}"))
    }

    pub(super) fn field_float(&mut self, key: &str, block: &str) -> Result<Located<f32>, Problem> {
        self.expect(key, &format!("in {block}"))?;
        self.float(&format!("{block} {key}"))
    }

    pub(super) fn path_token(&mut self, what: &str) -> Result<Located<String>, Problem> {
        match self.lx.peek() {
            Some(t) if !matches!(t.text, "{" | "}" | "[" | "]") => {
                self.lx.next();
                Ok(Located {
                    value: t.text.to_string(),
                    span: t.span,
                })
            }
            _ => Err(self.unexpected(&format!("a file name ({what})"))),
        }
    }

    pub(super) fn enter(&mut self, span: Span) -> Result<(), Problem> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(
                Problem::at(span, format!("nesting deeper than {MAX_DEPTH} levels"))
                    .help("flatten the groups and transforms"),
            );
        }
        Ok(())
    }

    pub(super) fn leave(&mut self) {
        self.depth -= 1;
    }
}
