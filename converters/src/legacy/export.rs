//! Writing a scene as legacy text, in the path-tracing dialect (`color`, `type`, `refr`,
//! `emission`, `texture`, `DepthCamera`) so that everything lumo can say and the format can
//! hold survives. Numbers are printed with the shortest text that reads back as the same f32,
//! and derived quantities (look-at point, light powers, roughness) are inverted exactly, so
//! importing the output reproduces the scene bit for bit.

use std::collections::HashMap;
use std::fmt::Write;
use std::path::Path;

use lumo_schema::{Light, Material, MeshSource, Object, Profile, Scale, Scene, TransformOp};

use super::error::ExportError;
use super::import::{material_name, uniform_knots};
use super::math;
use lumo_schema::geometry::transform::ops_matrix;

/// Writes `scene` as legacy text, or lists everything the format cannot express.
///
/// Not written (they have no legacy counterpart and do not change what is seen): object
/// names, render settings (integrator, samples, depth, seed) and unused textures. A scene whose
/// materials emit and that also has punctual lights reads back with its lights only under
/// `LightsPolicy::Keep`.
///
/// `base_dir` is the folder the scene's relative paths resolve against (where the text will
/// be written): point lights are fitted at the centre of the objects' bounds as on import, and
/// the bounds of OBJ meshes come from their files.
pub fn export(scene: &Scene, base_dir: &Path) -> Result<String, ExportError> {
    let mut w = Writer {
        out: String::new(),
        problems: Vec::new(),
    };
    w.camera(scene);
    w.line(0, "");
    let bg = &scene.background;
    if bg.image.is_some() || bg.strength != 1.0 || !bg.visible {
        w.problem("background: an environment image, strength or invisibility cannot be written (legacy backgrounds are a colour)");
    }
    w.line(0, "Background {");
    w.line(1, &format!("color {}", v3(scene.background.color)));
    w.line(0, "}");
    w.line(0, "");
    w.lights(scene, base_dir);
    let index = w.materials(scene);
    w.objects(scene, &index);
    if w.problems.is_empty() {
        Ok(w.out)
    } else {
        Err(ExportError {
            problems: w.problems,
        })
    }
}

struct Writer {
    out: String,
    problems: Vec<String>,
}

fn f(x: f32) -> String {
    // Rust prints the shortest decimal that parses back to the same f32, never in exponent
    // form, which C's %f reads.
    format!("{x}")
}

fn v3(v: [f32; 3]) -> String {
    format!("{} {} {}", f(v[0]), f(v[1]), f(v[2]))
}

fn is_token(s: &str) -> bool {
    !s.is_empty()
        && !s
            .chars()
            .any(|c| c.is_whitespace() || matches!(c, '{' | '}' | '[' | ']'))
}

impl Writer {
    fn line(&mut self, indent: usize, text: &str) {
        for _ in 0..indent {
            self.out.push_str("    ");
        }
        self.out.push_str(text);
        self.out.push('\n');
    }

    fn problem(&mut self, p: impl Into<String>) {
        self.problems.push(p.into());
    }

    fn camera(&mut self, scene: &Scene) {
        let c = &scene.camera;
        let dir: [f32; 3] = std::array::from_fn(|i| {
            let p = c.position[i];
            math::invert_exact(c.look_at[i], c.look_at[i] - p, |x| p + x)
        });
        let lens = c.aperture_radius > 0.0;
        self.line(
            0,
            if lens {
                "DepthCamera {"
            } else {
                "PerspectiveCamera {"
            },
        );
        self.line(1, &format!("center {}", v3(c.position)));
        self.line(1, &format!("direction {}", v3(dir)));
        self.line(1, &format!("up {}", v3(c.up)));
        self.line(1, &format!("angle {}", f(c.fov_y_deg)));
        self.line(1, &format!("width {}", scene.image.width));
        self.line(1, &format!("height {}", scene.image.height));
        if lens {
            let focus = c.focus_distance.unwrap_or_else(|| {
                let d: f32 = (0..3).map(|i| (c.look_at[i] - c.position[i]).powi(2)).sum();
                d.sqrt()
            });
            self.line(1, &format!("focalLength {}", f(focus)));
            self.line(1, &format!("aperture {}", f(c.aperture_radius)));
        }
        self.line(0, "}");
    }

    fn lights(&mut self, scene: &Scene, base_dir: &Path) {
        let mut body = Vec::new();
        for (i, l) in scene.lights.iter().enumerate() {
            match l {
                Light::Directional(d) => {
                    let color = d.irradiance.map(|e| math::invert_exact(e, (e as f64 / std::f64::consts::PI) as f32, |c| math::legacy_to_radiometric(c, 1.0)));
                    body.push("DirectionalLight {".to_string());
                    body.push(format!("    direction {}", v3(d.direction)));
                    body.push(format!("    color {}", v3(color)));
                    body.push("}".to_string());
                }
                Light::Point(p) => {
                    let d = math::point_light_reference_distance(scene, p.position, base_dir);
                    let s = d * d;
                    let color = p.intensity.map(|e| math::invert_exact(e, (e as f64 / (std::f64::consts::PI * s)) as f32, |c| math::legacy_to_radiometric(c, s)));
                    body.push("PointLight {".to_string());
                    body.push(format!("    position {}", v3(p.position)));
                    body.push(format!("    color {}", v3(color)));
                    body.push("}".to_string());
                }
                Light::Spot(_) => self.problem(format!("lights[{i}]: a spot light cannot be written (the format has only DirectionalLight and PointLight)")),
            }
        }
        self.line(0, "Lights {");
        self.line(1, &format!("numLights {}", scene.lights.len()));
        for b in body {
            self.line(1, &b);
        }
        self.line(0, "}");
        self.line(0, "");
    }

    /// Writes the Materials block; returns each material's legacy index. Materials named
    /// `material<k>` come first in the order of k (so imported scenes keep their numbering),
    /// then the others by name.
    fn materials(&mut self, scene: &Scene) -> HashMap<String, usize> {
        let mut names: Vec<&String> = scene.materials.keys().collect();
        names.sort_by_key(|n| {
            match n
                .strip_prefix("material")
                .and_then(|k| k.parse::<usize>().ok())
            {
                Some(k) if material_name(k) == **n => (0, k, (*n).clone()),
                _ => (1, 0, (*n).clone()),
            }
        });
        let mut index = HashMap::new();
        self.line(0, "Materials {");
        self.line(1, &format!("numMaterials {}", names.len()));
        for (i, name) in names.iter().enumerate() {
            index.insert((*name).clone(), i);
            let m = &scene.materials[*name];
            self.line(1, "Material {");
            for l in self.material(name, m, scene) {
                self.line(2, &l);
            }
            self.line(1, "}");
        }
        self.line(0, "}");
        self.line(0, "");
        index
    }

    fn material(&mut self, name: &str, m: &Material, scene: &Scene) -> Vec<String> {
        let at = format!("materials.{name}");
        let mut lines = vec![format!("color {}", v3(m.base_color))];
        // The inverse of the importer's mapping: lobe weights metal s, glass t, diffuse d.
        let s = m.metallic;
        let t = (1.0 - s) * m.transmission;
        let d = (1.0 - s) * (1.0 - m.transmission);
        if d > 0.0 && m.specular != 0.0 && m.specular_color != [0.0; 3] {
            self.problem(format!("{at}: a specular reflection over the diffuse base cannot be written (legacy diffuse is Lambertian: set specular 0)"));
        }
        if m.specular_color != [1.0; 3] && m.specular != 0.0 {
            self.problem(format!(
                "{at}.specular_color: a tinted specular reflection cannot be written"
            ));
        }
        if t > 0.0 {
            match &m.volume {
                None => self.problem(format!("{at}: thin-walled transmission cannot be written (legacy glass refracts: add `volume`)")),
                Some(v) if v.absorption() != [0.0; 3] => self.problem(format!("{at}.volume: absorption cannot be written")),
                Some(_) => {}
            }
            if m.roughness > 0.0 {
                self.problem(format!(
                    "{at}: rough transmission cannot be written (legacy glass is smooth)"
                ));
            }
        }
        lines.push(format!("type {} {} {}", f(d), f(s), f(t)));
        if s > 0.0 && m.roughness > 0.0 {
            lines.push(format!(
                "shininess {}",
                f(math::roughness_to_shininess(m.roughness))
            ));
        }
        if t > 0.0 || m.ior != 1.5 {
            lines.push(format!("refr {}", f(m.ior)));
        }
        if m.emission != [0.0; 3] {
            if !m.two_sided_emission {
                self.problem(format!("{at}: one-sided emission cannot be written: legacy emitters emit from both faces (set two_sided_emission)"));
            }
            lines.push(format!("emission {}", v3(m.emission)));
        }
        if let Some(r) = &m.base_color_texture {
            if r.offset != [0.0; 2] || r.rotation_deg != 0.0 || r.scale != [1.0; 2] {
                self.problem(format!(
                    "{at}.base_color_texture: texture coordinate transforms cannot be written"
                ));
            }
            match scene.textures.get(&r.texture) {
                Some(tex) => {
                    if tex.gltf_image.is_some() {
                        self.problem(format!("textures.{}: an image inside a glTF file cannot be written; extract it to a PNG", r.texture));
                    }
                    if tex.color_space != lumo_schema::ColorSpace::Srgb {
                        self.problem(format!("textures.{}: linear colour space cannot be written (legacy textures are colour images)", r.texture));
                    }
                    if (tex.wrap_s, tex.wrap_t)
                        != (lumo_schema::Wrap::Repeat, lumo_schema::Wrap::Repeat)
                    {
                        self.problem(format!("textures.{}: wrap modes {:?}/{:?} cannot be written (legacy textures repeat)", r.texture, tex.wrap_s, tex.wrap_t));
                    }
                    if !is_token(&tex.file) {
                        self.problem(format!("textures.{}: the file name `{}` contains spaces or brackets, which the format cannot hold", r.texture, tex.file));
                    }
                    lines.push(format!("texture {}", tex.file));
                }
                None => self.problem(format!(
                    "{at}.base_color_texture: unknown texture `{}`",
                    r.texture
                )),
            }
        }
        if m.emission_texture.is_some() {
            self.problem(format!(
                "{at}.emission_texture: emission textures cannot be written"
            ));
        }
        for (key, r) in m.texture_refs() {
            if r.is_some() && !matches!(key, "base_color_texture" | "emission_texture") {
                self.problem(format!("{at}.{key}: this texture cannot be written"));
            }
        }
        lines
    }

    fn objects(&mut self, scene: &Scene, index: &HashMap<String, usize>) {
        let mut body: Vec<String> = Vec::new();
        let mut current: Option<usize> = None;
        for (i, obj) in scene.objects.iter().enumerate() {
            let at = format!("objects[{i}].{}", obj.kind());
            let Some(&k) = index.get(obj.material()) else {
                self.problem(format!(
                    "{at}.material: unknown material `{}`",
                    obj.material()
                ));
                continue;
            };
            let Some(shape) = self.shape(&at, obj) else {
                continue;
            };
            if current != Some(k) {
                body.push(format!("MaterialIndex {k}"));
                current = Some(k);
            }
            let ops = obj.transform();
            if ops.is_empty() {
                body.extend(shape);
            } else {
                body.push("Transform {".into());
                for op in transform_lines(ops) {
                    body.push(format!("    {op}"));
                }
                body.extend(shape.into_iter().map(|l| format!("    {l}")));
                body.push("}".into());
            }
        }
        self.line(0, "Group {");
        let n = scene.objects.len();
        self.line(1, &format!("numObjects {n}"));
        for l in body {
            self.line(1, &l);
        }
        self.line(0, "}");
    }

    /// The object's block lines (without its placement), or None after recording a problem.
    fn shape(&mut self, at: &str, obj: &Object) -> Option<Vec<String>> {
        Some(match obj {
            Object::Sphere(s) => vec![
                "Sphere {".into(),
                format!("    center {}", v3(s.center)),
                format!("    radius {}", f(s.radius)),
                "}".into(),
            ],
            Object::Plane(p) => vec![
                "Plane {".into(),
                format!("    normal {}", v3(p.normal)),
                format!("    offset {}", f(p.offset)),
                "}".into(),
            ],
            Object::Triangle(t) => vec![
                "Triangle {".into(),
                format!("    vertex0 {}", v3(t.vertices[0])),
                format!("    vertex1 {}", v3(t.vertices[1])),
                format!("    vertex2 {}", v3(t.vertices[2])),
                "}".into(),
            ],
            Object::Mesh(m) => {
                let file = match &m.source {
                    MeshSource::Obj(file) => file,
                    MeshSource::Gltf(_) => {
                        self.problem(format!("{at}.source: a glTF mesh cannot be written (the format loads OBJ files only); export it to OBJ"));
                        return None;
                    }
                    MeshSource::Inline(_) => {
                        self.problem(format!("{at}.source: an inline mesh cannot be written (the format loads OBJ files only); save it as an OBJ file"));
                        return None;
                    }
                };
                if m.smooth {
                    self.problem(format!("{at}.smooth: smooth shading cannot be written (legacy meshes are flat-shaded)"));
                }
                if !is_token(file) || !file.ends_with(".obj") {
                    self.problem(format!("{at}.source.obj: `{file}` cannot be written: the format needs one token ending in `.obj`"));
                }
                vec![
                    "TriangleMesh {".into(),
                    format!("    obj_file {file}"),
                    "}".into(),
                ]
            }
            Object::Lathe(l) => {
                let (kind, points) = match &l.profile {
                    Profile::Bezier(b) => ("BezierCurve", bezier_for_legacy(&b.points)),
                    Profile::Bspline(b) => {
                        let n = b.points.len();
                        let uniform =
                            b.degree == 3 && b.knots.as_ref().is_some_and(|k| is_uniform(k, n));
                        if !uniform {
                            self.problem(format!(
                                "{at}.profile.bspline: only cubic B-splines with uniform (unclamped) knots can be written; this one has degree {} and {} knots",
                                b.degree,
                                if b.knots.is_some() { "non-uniform" } else { "default clamped" }
                            ));
                            return None;
                        }
                        ("BsplineCurve", b.points.clone())
                    }
                };
                let mut lines = vec![
                    "RevSurface {".into(),
                    format!("    profile {kind} {{"),
                    "        controls".into(),
                ];
                for p in points {
                    lines.push(format!("            [ {} {} 0 ]", f(p[0]), f(p[1])));
                }
                lines.push("    }".into());
                lines.push("}".into());
                lines
            }
        })
    }
}

/// Knots of a cubic B-spline with `n` control points that trace the same curve as the legacy
/// uniform unclamped ones: exactly [`uniform_knots`], or any evenly spaced increasing vector
/// (a uniform B-spline's shape does not depend on the knots' scale or origin).
fn is_uniform(k: &[f32], n: usize) -> bool {
    if k.len() != n + 4 {
        return false;
    }
    if k == uniform_knots(n).as_slice() {
        return true;
    }
    let step = k[1] as f64 - k[0] as f64;
    let span = (k[k.len() - 1] as f64 - k[0] as f64).abs();
    step > 0.0
        && k.windows(2)
            .all(|w| ((w[1] as f64 - w[0] as f64) - step).abs() <= 1e-5 * span)
}

/// The legacy framework needs 3k+1 ≥ 4 Bézier points; other counts are degree-elevated, which
/// keeps the curve exactly: Q_i = i/(n+1) P_{i−1} + (1 − i/(n+1)) P_i (Farin, "Curves and
/// Surfaces for CAGD", §5.1).
fn bezier_for_legacy(points: &[[f32; 2]]) -> Vec<[f32; 2]> {
    let mut p: Vec<[f64; 2]> = points.iter().map(|q| [q[0] as f64, q[1] as f64]).collect();
    while !p.is_empty() && (p.len() < 4 || !(p.len() - 1).is_multiple_of(3)) {
        let n = p.len(); // degree n - 1 → n
        let mut q = Vec::with_capacity(n + 1);
        q.push(p[0]);
        for i in 1..n {
            let a = i as f64 / n as f64;
            q.push([
                a * p[i - 1][0] + (1.0 - a) * p[i][0],
                a * p[i - 1][1] + (1.0 - a) * p[i][1],
            ]);
        }
        q.push(p[n - 1]);
        p = q;
    }
    if p.len() == points.len() {
        return points.to_vec();
    }
    p.iter().map(|q| [q[0] as f32, q[1] as f32]).collect()
}

/// The Transform steps for lumo steps `ops` (first acts first), in legacy file order (last
/// listed acts first). A list containing a matrix is written as one `Matrix4f` of the whole
/// placement, column by column.
fn transform_lines(ops: &[TransformOp]) -> Vec<String> {
    if ops.iter().any(|o| matches!(o, TransformOp::Matrix(_))) {
        let m = ops_matrix(ops);
        let mut s = String::from("Matrix4f {");
        // Column by column: the row index varies fastest.
        for x in m.to_cols_array() {
            let _ = write!(s, " {}", f(x as f32));
        }
        s.push_str(" }");
        return vec![s];
    }
    ops.iter()
        .rev()
        .map(|op| match op {
            TransformOp::Translate(t) => format!("Translate {}", v3(*t)),
            TransformOp::Scale(Scale::Uniform(s)) => format!("UniformScale {}", f(*s)),
            TransformOp::Scale(Scale::PerAxis(s)) => format!("Scale {}", v3(*s)),
            TransformOp::Rotate(r) => match r.axis {
                [1.0, 0.0, 0.0] => format!("XRotate {}", f(r.degrees)),
                [0.0, 1.0, 0.0] => format!("YRotate {}", f(r.degrees)),
                [0.0, 0.0, 1.0] => format!("ZRotate {}", f(r.degrees)),
                a => format!("Rotate {{ {} {} }}", v3(a), f(r.degrees)),
            },
            TransformOp::Matrix(_) => unreachable!("handled above"),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degree_elevation_reaches_a_legacy_count() {
        let q = bezier_for_legacy(&[[0.0, 0.0], [1.0, 2.0], [2.0, 0.0]]);
        assert_eq!(q.len(), 4);
        // A quadratic (0,0),(1,2),(2,0) elevated: (0,0),(2/3,4/3),(4/3,4/3),(2,0).
        assert!((q[1][0] - 2.0 / 3.0).abs() < 1e-6 && (q[1][1] - 4.0 / 3.0).abs() < 1e-6);
        assert_eq!(bezier_for_legacy(&[[0.0, 0.0]; 5]).len(), 7);
        assert_eq!(bezier_for_legacy(&[[0.0, 0.0]; 7]).len(), 7);
    }
}
