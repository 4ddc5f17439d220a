//! The camera block: `PerspectiveCamera`, `DepthCamera`, `LensCamera` (legacy-format.md §3, §6).

use super::super::ast::*;
use super::super::error::Problem;
use super::{suggestion, unsupported, Parser};

impl Parser<'_> {
    pub(super) fn camera(&mut self) -> Result<CameraDef, Problem> {
        let Some(kw) = self.lx.next() else {
            return Err(self.unexpected("a camera"));
        };
        let (kind, name) = match kw.text {
            "DepthCamera" => (CameraKind::Depth, "DepthCamera"),
            "LensCamera" => (CameraKind::Lens, "LensCamera"),
            _ => (CameraKind::Perspective, "PerspectiveCamera"),
        };
        self.open(name)?;
        let center = self.field_vec3("center", name)?;
        let direction = self.field_vec3("direction", name)?;
        let up = self.field_vec3("up", name)?;
        let angle = self.field_float("angle", name)?;
        self.expect("width", &format!("in {name}"))?;
        let width = self.int("image width")?;
        self.expect("height", &format!("in {name}"))?;
        let height = self.int("image height")?;
        let lens = match kind {
            CameraKind::Depth => {
                let f = self.field_float("focalLength", name)?;
                let a = self.field_float("aperture", name)?;
                Some((f, a))
            }
            CameraKind::Lens => {
                let f = self.field_float("depth", name)?;
                let a = self.field_float("aperture", name)?;
                Some((f, a))
            }
            CameraKind::Perspective => match self.lx.peek() {
                Some(t) if t.text == "focalLength" => {
                    let f = self.field_float("focalLength", name)?;
                    let a = self.field_float("aperture", name)?;
                    Some((f, a))
                }
                _ => None,
            },
        };
        if let Some(t) = self.lx.peek() {
            if t.text != "}" {
                let mut p = self.unexpected(&format!("`}}` to close the {name} block"));
                if let Some(why) = unsupported(t.text) {
                    p = p.help(why);
                } else if let Some(s) = suggestion(t.text, &["focalLength", "aperture"]) {
                    p = p.help(s);
                }
                return Err(p);
            }
        }
        self.close(name)?;
        Ok(CameraDef {
            kind,
            span: kw.span,
            center,
            direction,
            up,
            angle,
            width,
            height,
            lens,
        })
    }
}
