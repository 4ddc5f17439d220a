//! The `Background` block (legacy-format.md §3): loose, an optional `color`.

use super::super::ast::*;
use super::super::error::Problem;
use super::super::lexer::Span;
use super::{shorten, suggestion, Parser};

impl Parser<'_> {
    pub(super) fn background(&mut self) -> Result<(Option<Located<V3>>, Span), Problem> {
        let kw = self.expect("Background", "")?;
        self.open("Background")?;
        let mut color = None;
        loop {
            match self.lx.peek() {
                Some(t) if t.text == "}" => break,
                Some(t) if t.text == "color" => {
                    self.lx.next();
                    color = Some(self.vec3("background color")?);
                }
                Some(t) => {
                    let mut p = Problem::at(
                        t.span,
                        format!(
                            "unknown Background field `{}`: expected `color` or `}}`",
                            shorten(t.text)
                        ),
                    );
                    if let Some(s) = suggestion(t.text, &["color"]) {
                        p = p.help(s);
                    }
                    return Err(p);
                }
                None => return Err(self.unexpected("`}` to close the Background block")),
            }
        }
        self.close("Background")?;
        Ok((color, kw))
    }
}
