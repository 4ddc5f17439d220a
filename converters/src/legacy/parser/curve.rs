//! `BezierCurve` and `BsplineCurve` with their control points (legacy-format.md §5).

use super::super::ast::*;
use super::super::error::Problem;
use super::{Parser, MAX_CONTROL_POINTS};

impl Parser<'_> {
    /// `BezierCurve|BsplineCurve { controls [ x y z ]* }`.
    pub(super) fn curve(&mut self) -> Result<CurveDef, Problem> {
        let Some(kw) = self.lx.next() else {
            return Err(self.unexpected("a curve"));
        };
        let kind = if kw.text == "BezierCurve" {
            CurveKind::Bezier
        } else {
            CurveKind::Bspline
        };
        self.open(kw.text)?;
        self.expect("controls", &format!("in {}", kw.text))?;
        let mut points = Vec::new();
        loop {
            match self.lx.peek() {
                Some(t) if t.text == "}" => break,
                Some(t) if t.text == "[" => {
                    self.lx.next();
                    let p = self.vec3("control point")?;
                    let end = self.expect("]", "to close the control point")?;
                    points.push(Located {
                        value: p.value,
                        span: t.span.to(end),
                    });
                    if points.len() > MAX_CONTROL_POINTS {
                        return Err(Problem::at(
                            t.span,
                            format!("more than {MAX_CONTROL_POINTS} control points"),
                        ));
                    }
                }
                _ => return Err(self.unexpected("a control point `[ x y z ]` or `}`")),
            }
        }
        self.close(kw.text)?;
        let n = points.len();
        match kind {
            CurveKind::Bezier if n < 4 || (n - 1) % 3 != 0 => {
                return Err(Problem::at(
                    kw.span,
                    format!("a BezierCurve needs 3k+1 control points (4, 7, 10, ...), found {n}"),
                )
                .help("the course framework rejects other counts"));
            }
            CurveKind::Bspline if n < 4 => {
                return Err(Problem::at(
                    kw.span,
                    format!("a BsplineCurve needs at least 4 control points, found {n}"),
                ));
            }
            _ => {}
        }
        Ok(CurveDef {
            kind,
            span: kw.span,
            points,
        })
    }
}
