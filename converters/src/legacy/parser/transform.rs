//! The `Transform` block: its steps and the one object they place (legacy-format.md §4).

use super::super::ast::*;
use super::super::error::Problem;
use super::objects::OBJECT_KINDS;
use super::{shorten, suggestion, Parser};

const TRANSFORM_OPS: &[&str] = &[
    "Scale",
    "UniformScale",
    "Translate",
    "XRotate",
    "YRotate",
    "ZRotate",
    "Rotate",
    "Matrix4f",
];

impl Parser<'_> {
    /// After `Transform`: `{ op* object }`.
    pub(super) fn transform(&mut self) -> Result<ObjectKind, Problem> {
        self.open("Transform")?;
        let mut ops = Vec::new();
        loop {
            let Some(t) = self.lx.peek() else {
                return Err(self.unexpected("a transform step or an object"));
            };
            let span = t.span;
            let op = match t.text {
                "Scale" => {
                    self.lx.next();
                    Op::Scale(self.vec3("Scale")?.value)
                }
                "UniformScale" => {
                    self.lx.next();
                    Op::UniformScale(self.float("UniformScale")?.value)
                }
                "Translate" => {
                    self.lx.next();
                    Op::Translate(self.vec3("Translate")?.value)
                }
                "XRotate" => {
                    self.lx.next();
                    Op::XRotate(self.float("XRotate degrees")?.value)
                }
                "YRotate" => {
                    self.lx.next();
                    Op::YRotate(self.float("YRotate degrees")?.value)
                }
                "ZRotate" => {
                    self.lx.next();
                    Op::ZRotate(self.float("ZRotate degrees")?.value)
                }
                "Rotate" => {
                    self.lx.next();
                    self.open("Rotate")?;
                    let axis = self.vec3("rotation axis")?;
                    let deg = self.float("rotation angle in degrees")?;
                    self.close("Rotate")?;
                    Op::Rotate(axis.value, deg.value)
                }
                "Matrix4f" => {
                    self.lx.next();
                    self.open("Matrix4f")?;
                    let mut m = [0.0f32; 16];
                    for (i, v) in m.iter_mut().enumerate() {
                        *v = self.float(&format!("matrix entry {} of 16", i + 1))?.value;
                    }
                    self.close("Matrix4f")?;
                    Op::Matrix4f(m)
                }
                word if OBJECT_KINDS.contains(&word) => break,
                word => {
                    let mut p = Problem::at(
                        span,
                        format!(
                            "expected a transform step or an object, found `{}`",
                            shorten(word)
                        ),
                    );
                    let all: Vec<&'static str> =
                        TRANSFORM_OPS.iter().chain(OBJECT_KINDS).copied().collect();
                    if word == "}" {
                        p = Problem::at(span, "a Transform needs exactly one object before `}`")
                            .help("wrap the object to transform inside the block");
                    } else if let Some(s) = suggestion(word, &all) {
                        p = p.help(s);
                    }
                    return Err(p);
                }
            };
            let end = self.lx.last_span();
            ops.push(Located {
                value: op,
                span: span.to(end),
            });
            if ops.len() > 10_000 {
                return Err(Problem::at(span, "more than 10000 steps in one Transform"));
            }
        }
        let child = self.object()?;
        if let Some(t) = self.lx.peek() {
            if t.text != "}" && OBJECT_KINDS.contains(&t.text) {
                return Err(Problem::at(t.span, "a Transform holds exactly one object")
                    .help("wrap several objects in a Group inside the Transform"));
            }
        }
        self.close("Transform")?;
        Ok(ObjectKind::Transform(ops, Box::new(child)))
    }
}
