//! One object at an object position: the primitives, and where a Group, Transform, curve or
//! RevSurface starts (legacy-format.md §3, §5).

use super::super::ast::*;
use super::super::error::Problem;
use super::{shorten, suggestion, unsupported, Parser, MAX_COUNT};

pub(super) const OBJECT_KINDS: &[&str] = &[
    "Group",
    "Sphere",
    "Plane",
    "Triangle",
    "TriangleMesh",
    "Transform",
    "BezierCurve",
    "BsplineCurve",
    "RevSurface",
];

impl Parser<'_> {
    /// One object (or a nested Group) at an object position.
    pub(super) fn object(&mut self) -> Result<ObjectNode, Problem> {
        let Some(t) = self.lx.peek() else {
            return Err(self.unexpected("an object"));
        };
        let span = t.span;
        self.objects += 1;
        if self.objects > MAX_COUNT {
            return Err(Problem::at(span, format!("more than {MAX_COUNT} objects")));
        }
        let material = self.current_material;
        let kind = match t.text {
            "Group" => {
                self.lx.next();
                self.enter(span)?;
                let g = self.group_body()?;
                self.leave();
                ObjectKind::Group(g)
            }
            "Sphere" => {
                self.lx.next();
                self.open("Sphere")?;
                let center = self.field_vec3("center", "Sphere")?;
                let radius = self.field_float("radius", "Sphere")?;
                self.close("Sphere")?;
                ObjectKind::Sphere { center, radius }
            }
            "Plane" => {
                self.lx.next();
                self.open("Plane")?;
                let normal = self.field_vec3("normal", "Plane")?;
                let offset = self.field_float("offset", "Plane")?;
                self.close("Plane")?;
                ObjectKind::Plane { normal, offset }
            }
            "Triangle" => {
                self.lx.next();
                self.open("Triangle")?;
                let a = self.field_vec3("vertex0", "Triangle")?;
                let b = self.field_vec3("vertex1", "Triangle")?;
                let c = self.field_vec3("vertex2", "Triangle")?;
                self.close("Triangle")?;
                ObjectKind::Triangle([a, b, c])
            }
            "TriangleMesh" => {
                self.lx.next();
                self.open("TriangleMesh")?;
                self.expect("obj_file", "in TriangleMesh")?;
                let file = self.path_token("OBJ mesh")?;
                if !file.value.ends_with(".obj") {
                    return Err(Problem::at(
                        file.span,
                        format!(
                            "mesh file `{}` does not end in `.obj`",
                            shorten(&file.value)
                        ),
                    )
                    .help("the legacy format loads Wavefront OBJ meshes only"));
                }
                self.close("TriangleMesh")?;
                ObjectKind::Mesh(file)
            }
            "Transform" => {
                self.lx.next();
                self.enter(span)?;
                let tr = self.transform()?;
                self.leave();
                tr
            }
            "BezierCurve" | "BsplineCurve" => {
                self.enter(span)?;
                let c = self.curve()?;
                self.leave();
                ObjectKind::Curve(c)
            }
            "RevSurface" => {
                self.lx.next();
                self.enter(span)?;
                self.open("RevSurface")?;
                self.expect("profile", "in RevSurface")?;
                match self.lx.peek() {
                    Some(t) if t.text == "BezierCurve" || t.text == "BsplineCurve" => {}
                    Some(t) => {
                        let mut p =
                            self.unexpected("a profile curve (BezierCurve or BsplineCurve)");
                        if let Some(s) = suggestion(t.text, &["BezierCurve", "BsplineCurve"]) {
                            p = p.help(s);
                        }
                        return Err(p);
                    }
                    None => return Err(self.unexpected("a profile curve")),
                }
                let c = self.curve()?;
                self.close("RevSurface")?;
                self.leave();
                ObjectKind::RevSurface(c)
            }
            word => {
                let mut p = Problem::at(
                    span,
                    format!("expected an object, found `{}`", shorten(word)),
                );
                if let Some(why) = unsupported(word) {
                    p = p.help(why);
                } else if let Some(s) = suggestion(word, OBJECT_KINDS) {
                    p = p.help(s);
                } else {
                    p = p.help(format!("objects are {}", OBJECT_KINDS.join(", ")));
                }
                return Err(p);
            }
        };
        Ok(ObjectNode {
            span,
            material,
            kind,
        })
    }
}
