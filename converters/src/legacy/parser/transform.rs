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
            let op = match self.transform_op(t.text)? {
                Some(op) => op,
                None if OBJECT_KINDS.contains(&t.text) => break,
                None => {
                    let word = t.text;
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

    /// The transform step starting with `keyword`, read with its arguments (the keyword
    /// consumed); `None`, with nothing consumed, when `keyword` starts no step.
    fn transform_op(&mut self, keyword: &str) -> Result<Option<Op>, Problem> {
        let read: fn(&mut Self) -> Result<Op, Problem> = match keyword {
            "Scale" => |p| Ok(Op::Scale(p.vec3("Scale")?.value)),
            "UniformScale" => |p| Ok(Op::UniformScale(p.float("UniformScale")?.value)),
            "Translate" => |p| Ok(Op::Translate(p.vec3("Translate")?.value)),
            "XRotate" => |p| Ok(Op::XRotate(p.float("XRotate degrees")?.value)),
            "YRotate" => |p| Ok(Op::YRotate(p.float("YRotate degrees")?.value)),
            "ZRotate" => |p| Ok(Op::ZRotate(p.float("ZRotate degrees")?.value)),
            "Rotate" => |p| {
                p.open("Rotate")?;
                let axis = p.vec3("rotation axis")?;
                let deg = p.float("rotation angle in degrees")?;
                p.close("Rotate")?;
                Ok(Op::Rotate(axis.value, deg.value))
            },
            "Matrix4f" => |p| {
                p.open("Matrix4f")?;
                let mut m = [0.0f32; 16];
                for (i, v) in m.iter_mut().enumerate() {
                    *v = p.float(&format!("matrix entry {} of 16", i + 1))?.value;
                }
                p.close("Matrix4f")?;
                Ok(Op::Matrix4f(m))
            },
            _ => return Ok(None),
        };
        self.lx.next();
        read(self).map(Some)
    }
}
