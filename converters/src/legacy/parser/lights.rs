//! The `Lights` block: `numLights` and the punctual lights (legacy-format.md §3).

use super::super::ast::*;
use super::super::error::Problem;
use super::{check_count, shorten, suggestion, unsupported, Parser, MAX_COUNT};

const LIGHT_KINDS: &[&str] = &["DirectionalLight", "PointLight"];

impl Parser<'_> {
    pub(super) fn lights(&mut self) -> Result<LightsDef, Problem> {
        let kw = self.expect("Lights", "")?;
        let n = self.open_counted("Lights", "numLights")?;
        let mut lights = Vec::new();
        loop {
            let Some(t) = self.lx.peek() else {
                return Err(self.unexpected("a light or `}`"));
            };
            let span = t.span;
            match t.text {
                "}" => break,
                "DirectionalLight" => {
                    self.lx.next();
                    self.open("DirectionalLight")?;
                    let direction = self.field_vec3("direction", "DirectionalLight")?;
                    let color = self.field_vec3("color", "DirectionalLight")?;
                    self.close("DirectionalLight")?;
                    lights.push(LightDef::Directional {
                        span,
                        direction,
                        color,
                    });
                }
                "PointLight" => {
                    self.lx.next();
                    self.open("PointLight")?;
                    let position = self.field_vec3("position", "PointLight")?;
                    let color = self.field_vec3("color", "PointLight")?;
                    self.close("PointLight")?;
                    lights.push(LightDef::Point {
                        span,
                        position,
                        color,
                    });
                }
                word => {
                    let mut p = Problem::at(
                        span,
                        format!(
                            "expected a light (DirectionalLight or PointLight) or `}}`, found `{}`",
                            shorten(word)
                        ),
                    );
                    if let Some(why) = unsupported(word) {
                        p = p.help(why);
                    } else if let Some(s) = suggestion(word, LIGHT_KINDS) {
                        p = p.help(s);
                    }
                    return Err(p);
                }
            }
            if lights.len() as i64 > MAX_COUNT {
                return Err(Problem::at(span, format!("more than {MAX_COUNT} lights")));
            }
        }
        check_count(n, lights.len(), "numLights", "block", "light", "")?;
        self.close("Lights")?;
        Ok(LightsDef { span: kw, lights })
    }
}
