//! Mapping a parsed legacy document onto lumo's scene model. Each rule is documented in
//! `docs/legacy.md`; the comments here say why.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lumo_schema as schema;
use lumo_schema::{
    BezierProfile, BsplineProfile, Camera, Lathe, Light, Material, Mesh, MeshSource, Object, Plane,
    Profile, Rotation, Scale, Scene, Sphere, Texture, TransformOp, Triangle,
};

use super::ast::*;
use super::error::Problem;
use super::lexer::Span;
use super::material::material;
use super::math::{self, M4};
use super::LightsPolicy;
use lumo_schema::geometry::paths::portable;
use lumo_schema::geometry::transform::to_rows;

/// The framework's default background when the file has none (PA1/PA3 parser).
pub const DEFAULT_BACKGROUND: [f32; 3] = [0.5, 0.5, 0.5];

/// Where things came from, to point validation problems back at the legacy text.
#[derive(Debug, Default)]
pub struct Origins {
    /// Span of each output object.
    pub objects: Vec<Span>,
    /// Span of each material by name.
    pub materials: BTreeMap<String, Span>,
    /// Span of each output light.
    pub lights: Vec<Span>,
    /// Span of the camera keyword.
    pub camera: Option<Span>,
}

/// Inputs of the mapping besides the document.
pub struct Context<'a> {
    /// Folders relative file names are looked up in, in order.
    pub search: Vec<PathBuf>,
    /// The folder the output JSON will live in; written paths are relative to it.
    pub out_dir: PathBuf,
    /// What to do with the Lights block.
    pub lights: LightsPolicy,
    /// Warnings (span, message) collected on the way.
    pub warnings: &'a mut Vec<(Option<Span>, String)>,
}

impl Context<'_> {
    pub(super) fn warn(&mut self, span: Span, msg: impl Into<String>) {
        self.warnings.push((Some(span), msg.into()));
    }
}

pub(super) fn is_zero(v: [f32; 3]) -> bool {
    v == [0.0; 3]
}

fn len(v: [f32; 3]) -> f64 {
    v.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt()
}

pub(super) fn fmt3(v: [f32; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

/// Maps a document to a scene.
pub fn to_scene(doc: &Document, ctx: &mut Context<'_>) -> Result<(Scene, Origins), Problem> {
    let mut origins = Origins::default();
    for (span, msg) in &doc.warnings {
        ctx.warn(*span, msg.clone());
    }
    let Some(cam) = &doc.camera else {
        return Err(Problem::whole("the scene has no camera").help(
            "add `PerspectiveCamera { center … direction … up … angle … width … height … }`",
        ));
    };
    origins.camera = Some(cam.span);
    let (camera, image) = camera(cam, ctx)?;

    let background = match &doc.background {
        Some((Some(c), _)) => {
            check_color(c, "background colour", None)?;
            c.value
        }
        Some((None, span)) => {
            ctx.warn(
                *span,
                format!(
                    "Background has no color: using the framework's default {}",
                    fmt3(DEFAULT_BACKGROUND)
                ),
            );
            DEFAULT_BACKGROUND
        }
        None => {
            ctx.warnings.push((
                None,
                format!(
                    "no Background block: using the framework's default colour {}",
                    fmt3(DEFAULT_BACKGROUND)
                ),
            ));
            DEFAULT_BACKGROUND
        }
    };

    // Materials, named material0, material1, … by their index in the file.
    let mut textures: BTreeMap<String, Texture> = BTreeMap::new();
    let mut materials: BTreeMap<String, Material> = BTreeMap::new();
    let defs: &[MaterialDef] = doc
        .materials
        .as_ref()
        .map(|m| m.materials.as_slice())
        .unwrap_or(&[]);
    for (i, def) in defs.iter().enumerate() {
        let m = material(def, ctx, &mut textures)?;
        materials.insert(material_name(i), m);
        origins.materials.insert(material_name(i), def.span);
    }

    // Objects: flatten groups and transforms into a list of leaves with their placement.
    let mut objects = Vec::new();
    let mut default_material: Option<String> = None;
    match &doc.root {
        Some(root) => {
            let mut w = Walker {
                ctx,
                objects: &mut objects,
                spans: &mut origins.objects,
                default_material: &mut default_material,
                n_materials: defs.len(),
            };
            w.node(root, &Chain::default())?;
        }
        None => ctx.warnings.push((
            None,
            "the scene has no Group: it contains no objects".into(),
        )),
    }
    if let Some(name) = &default_material {
        // The legacy defaults of a Material block with no fields: white diffuse.
        materials.insert(name.clone(), Material::lambert([1.0; 3]));
    }

    let mut scene = Scene {
        schema: Some(schema::SCENE_SCHEMA.into()),
        format_version: schema::FORMAT_VERSION,
        image,
        render: schema::RenderSettings::default(),
        camera,
        background: schema::Background {
            color: background,
            ..schema::Background::default()
        },
        textures,
        materials,
        objects,
        lights: Vec::new(),
    };

    drop_black_planes_behind_camera(&mut scene, &mut origins, ctx);

    // Lights: the path-tracing dialects light the scene with emissive materials and ignore the
    // Lights block; the original ray caster uses it. Auto keeps it only when no object emits.
    let emitters = scene
        .objects
        .iter()
        .filter(|o| {
            scene
                .materials
                .get(o.material())
                .is_some_and(|m| !is_zero(m.emission))
        })
        .count();
    if let Some(lights) = &doc.lights {
        let keep = match ctx.lights {
            LightsPolicy::Keep => true,
            LightsPolicy::Drop => false,
            LightsPolicy::Auto => emitters == 0,
        };
        if keep {
            for l in &lights.lights {
                let (light, span) = light(l, &scene, ctx)?;
                scene.lights.push(light);
                origins.lights.push(span);
            }
            if emitters > 0 && !lights.lights.is_empty() {
                ctx.warn(lights.span, format!("keeping the Lights block although {emitters} object(s) emit light: the scene is lit twice"));
            }
        } else if !lights.lights.is_empty() {
            let why = match ctx.lights {
                LightsPolicy::Drop => "as asked".to_string(),
                _ => format!("because {emitters} object(s) have emissive materials (the path-tracing dialects light the scene by emission only); set the lights policy to keep (`--lights keep`) to keep them"),
            };
            ctx.warn(
                lights.span,
                format!(
                    "dropping the Lights block ({} light{}) {why}",
                    lights.lights.len(),
                    if lights.lights.len() == 1 { "" } else { "s" }
                ),
            );
        }
    } else {
        ctx.warnings.push((None, "no Lights block".into()));
    }
    // The original ray caster (punctual lights, no emitters) is lumo's raycast preview; the
    // path-tracing dialects are path traced.
    scene.render.integrator = if emitters == 0 && !scene.lights.is_empty() {
        schema::Integrator::Raycast
    } else {
        schema::Integrator::Path
    };
    Ok((scene, origins))
}

/// Some dialects' planes are one-sided: zhanglbthu's intersect only rays arriving from the
/// front (dot(n, d) < 0), and smallpt-style cameras start their rays well inside the room. A
/// smallpt "front wall" with the camera on its back side is then invisible to the camera, while
/// lumo's two-sided plane would hide the whole scene. When such a plane is also perfectly black
/// (black base colour, no transmission, no emission, no texture) and the background is black,
/// it absorbs exactly what open space would, so leaving it out is exact: do that, with a
/// warning. Any other plane with the camera behind it is kept, with a warning.
fn drop_black_planes_behind_camera(
    scene: &mut Scene,
    origins: &mut Origins,
    ctx: &mut Context<'_>,
) {
    let c = scene.camera.position.map(|x| x as f64);
    let black_background = is_zero(scene.background.color);
    let mut i = 0;
    while i < scene.objects.len() {
        let Object::Plane(p) = &scene.objects[i] else {
            i += 1;
            continue;
        };
        let n = p.normal.map(|x| x as f64);
        let l = len(p.normal);
        let side = (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) / l - p.offset as f64;
        if !p.transform.is_empty() || side >= 0.0 {
            i += 1;
            continue;
        }
        let span = origins.objects[i];
        let black = scene.materials.get(&p.material).is_some_and(|m| {
            is_zero(m.base_color)
                && m.transmission == 0.0
                && is_zero(m.emission)
                && m.base_color_texture.is_none()
                && m.emission_texture.is_none()
        });
        if black && black_background {
            ctx.warn(span, "the camera is behind this black plane (on the side its normal points away from); the dialects' planes are one-sided, so it is invisible from the camera and absorbs like open space: left out");
            scene.objects.remove(i);
            origins.objects.remove(i);
        } else {
            ctx.warn(span, "the camera is behind this plane (on the side its normal points away from): lumo's planes are two-sided, so it may hide the scene (the dialects' planes are one-sided)");
            i += 1;
        }
    }
}

/// Name of the material with legacy index `i`.
pub fn material_name(i: usize) -> String {
    format!("material{i}")
}

fn camera(c: &CameraDef, ctx: &mut Context<'_>) -> Result<(Camera, schema::Image), Problem> {
    for (v, what) in [(&c.width, "width"), (&c.height, "height")] {
        if v.value < 1 || v.value > schema::MAX_IMAGE_SIDE as i64 {
            return Err(
                Problem::at(v.span, format!("image {what} {} is out of range", v.value))
                    .help(format!("use 1 to {} pixels", schema::MAX_IMAGE_SIDE)),
            );
        }
    }
    if (c.width.value as u64) * (c.height.value as u64) > schema::MAX_PIXELS {
        return Err(Problem::at(
            c.height.span,
            format!(
                "{}×{} pixels is above the limit of {}",
                c.width.value,
                c.height.value,
                schema::MAX_PIXELS
            ),
        ));
    }
    if !(c.angle.value > 0.0 && c.angle.value < 180.0) {
        return Err(Problem::at(
            c.angle.span,
            format!("field of view {} is out of range", c.angle.value),
        )
        .help("`angle` is the full vertical angle in degrees, strictly between 0 and 180"));
    }
    let d = c.direction.value;
    if is_zero(d) {
        return Err(
            Problem::at(c.direction.span, "the camera direction is the zero vector")
                .help("give the direction the camera looks in, e.g. 0 0 -1"),
        );
    }
    let look_at = [
        c.center.value[0] + d[0],
        c.center.value[1] + d[1],
        c.center.value[2] + d[2],
    ];
    if look_at == c.center.value {
        return Err(Problem::at(
            c.direction.span,
            "the camera direction is too short to be represented next to the camera position",
        )
        .help("scale the direction up (its length does not matter)"));
    }
    let u = c.up.value;
    let cross = [
        d[1] * u[2] - d[2] * u[1],
        d[2] * u[0] - d[0] * u[2],
        d[0] * u[1] - d[1] * u[0],
    ];
    if is_zero(u) || len(cross) <= 1e-6 * len(d) * len(u) {
        return Err(Problem::at(
            c.up.span,
            "the up vector is zero or parallel to the direction, so the image's roll is undefined",
        )
        .help("use an up vector that is not along the direction, e.g. 0 1 0"));
    }
    let mut camera = Camera {
        position: c.center.value,
        look_at,
        up: u,
        fov_y_deg: c.angle.value,
        aperture_radius: 0.0,
        focus_distance: None,
    };
    if let Some((focus, aperture)) = &c.lens {
        if aperture.value.is_nan() || aperture.value < 0.0 {
            return Err(Problem::at(
                aperture.span,
                format!("aperture {} must be ≥ 0", aperture.value),
            )
            .help("the aperture is the lens radius in scene units; 0 is a pinhole"));
        }
        if aperture.value == 0.0 {
            ctx.warn(
                aperture.span,
                "aperture 0 is a pinhole camera: the focal length is ignored",
            );
        } else {
            if focus.value.is_nan() || focus.value <= 0.0 {
                return Err(Problem::at(
                    focus.span,
                    format!("focus distance {} must be > 0", focus.value),
                ));
            }
            camera.aperture_radius = aperture.value;
            camera.focus_distance = Some(focus.value);
        }
    }
    Ok((
        camera,
        schema::Image {
            width: c.width.value as u32,
            height: c.height.value as u32,
        },
    ))
}

pub(super) fn check_color(c: &Located<V3>, what: &str, max: Option<f32>) -> Result<(), Problem> {
    if c.value.iter().any(|x| *x < 0.0) {
        return Err(Problem::at(
            c.span,
            format!("{what} {} has a negative channel", fmt3(c.value)),
        ));
    }
    if let Some(m) = max {
        if c.value.iter().any(|x| *x > m) {
            return Err(Problem::at(
                c.span,
                format!(
                    "{what} {} is above {m}: the surface would reflect more light than it receives",
                    fmt3(c.value)
                ),
            )
            .help("lumo needs reflectances in [0, 1]; scale the colour down"));
        }
    }
    Ok(())
}

/// Resolves a file named in the scene; returns where it is and how the JSON names it
/// (relative to the output folder).
pub(super) fn ctx_file(
    ctx: &Context<'_>,
    name: &Located<String>,
    what: &str,
) -> Result<(PathBuf, String), Problem> {
    let given = Path::new(&name.value);
    let candidates: Vec<PathBuf> = if given.is_absolute() {
        vec![given.to_path_buf()]
    } else {
        ctx.search.iter().map(|d| d.join(given)).collect()
    };
    let Some(found) = candidates.iter().find(|p| p.is_file()) else {
        let looked: Vec<String> = candidates.iter().map(|p| p.display().to_string()).collect();
        return Err(Problem::at(name.span, format!("{what} `{}` not found", name.value))
            .help(format!("looked for {}; paths are relative to the scene's folder (or the folder above `testcases/`)", looked.join(" and "))));
    };
    Ok((found.clone(), portable(found, &ctx.out_dir)))
}

/// Placement accumulated from the enclosing Transform blocks.
#[derive(Debug, Clone)]
struct Chain {
    /// Steps in lumo order (first acts first): innermost block's steps first.
    ops: Vec<TransformOp>,
    /// The same placement as one matrix (outer · inner), legacy rule.
    matrix: M4,
    /// Some enclosing block used Matrix4f: the leaf gets the single composed matrix.
    has_matrix: bool,
}

impl Default for Chain {
    fn default() -> Self {
        Chain {
            ops: Vec::new(),
            matrix: M4::IDENTITY,
            has_matrix: false,
        }
    }
}

impl Chain {
    fn transform(&self) -> Vec<TransformOp> {
        if self.has_matrix {
            vec![TransformOp::Matrix(
                to_rows(&self.matrix).map(|row| row.map(|x| x as f32)),
            )]
        } else {
            self.ops.clone()
        }
    }
}

struct Walker<'a, 'b> {
    ctx: &'a mut Context<'b>,
    objects: &'a mut Vec<Object>,
    spans: &'a mut Vec<Span>,
    default_material: &'a mut Option<String>,
    n_materials: usize,
}

impl Walker<'_, '_> {
    fn material(&mut self, node: &ObjectNode) -> String {
        match node.material {
            Some(i) => material_name(i),
            None => {
                if self.default_material.is_none() {
                    self.ctx.warn(node.span, "this object comes before any MaterialIndex, so it has no material: using a white diffuse default material");
                    *self.default_material = Some(material_name(self.n_materials));
                }
                self.default_material.clone().unwrap_or_default()
            }
        }
    }

    fn node(&mut self, node: &ObjectNode, chain: &Chain) -> Result<(), Problem> {
        let transform = chain.transform();
        let obj = match &node.kind {
            ObjectKind::Group(items) => {
                for item in items {
                    self.node(item, chain)?;
                }
                return Ok(());
            }
            ObjectKind::Transform(ops, child) => {
                let inner = transform_block(ops)?;
                // The child's placement is outer · block; in lumo order the block's steps act
                // first, reversed from file order (the last step listed acts first).
                let mut ops_list = inner.0;
                ops_list.extend(chain.ops.iter().cloned());
                let next = Chain {
                    ops: ops_list,
                    matrix: chain.matrix * inner.1,
                    has_matrix: chain.has_matrix || inner.2,
                };
                return self.node(child, &next);
            }
            ObjectKind::Curve(c) => {
                curve_profile(c, false)?;
                self.ctx.warn(c.span, "a bare curve is not a surface and is not rendered (the course viewer only drew it); it is left out");
                return Ok(());
            }
            ObjectKind::Sphere { center, radius } => {
                if radius.value.is_nan() || radius.value <= 0.0 {
                    return Err(Problem::at(
                        radius.span,
                        format!("sphere radius {} must be > 0", radius.value),
                    ));
                }
                Object::Sphere(Sphere {
                    name: None,
                    material: self.material(node),
                    transform,
                    center: center.value,
                    radius: radius.value,
                })
            }
            ObjectKind::Plane { normal, offset } => {
                if is_zero(normal.value) {
                    return Err(Problem::at(normal.span, "plane normal is the zero vector")
                        .help("e.g. 0 1 0 for a floor"));
                }
                let l = len(normal.value);
                if (l - 1.0).abs() > 1e-4 {
                    self.ctx.warn(normal.span, format!(
                        "plane normal {} is not unit length (ambiguous in the format): read as the plane at distance {} along the normalised normal, as most student code does",
                        fmt3(normal.value),
                        offset.value
                    ));
                }
                Object::Plane(Plane {
                    name: None,
                    material: self.material(node),
                    transform,
                    normal: normal.value,
                    offset: offset.value,
                })
            }
            ObjectKind::Triangle(v) => {
                let [a, b, c] = [v[0].value, v[1].value, v[2].value];
                let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let n = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                if is_zero(n) {
                    self.ctx.warn(
                        node.span,
                        "degenerate triangle (zero area): it is invisible",
                    );
                }
                Object::Triangle(Triangle {
                    name: None,
                    material: self.material(node),
                    transform,
                    vertices: [a, b, c],
                })
            }
            ObjectKind::Mesh(file) => {
                let (resolved, rel) = ctx_file(self.ctx, file, "OBJ mesh")?;
                match crate::obj::scan_file(&resolved) {
                    Ok(summary) => {
                        if summary.polygons > 0 {
                            self.ctx.warn(file.span, format!("{}: {} face(s) have more than 3 corners; lumo fan-triangulates them (the legacy loader kept only the first triangle)", file.value, summary.polygons));
                        }
                        if summary.full_corners > 0 {
                            self.ctx.warn(file.span, format!("{}: faces with v/vt/vn corners are read correctly here (the legacy loader misread them)", file.value));
                        }
                        if summary.unterminated_last_line {
                            self.ctx.warn(file.span, format!("{}: the last line has no newline; lumo reads it (the legacy loader dropped it)", file.value));
                        }
                    }
                    Err(e) => {
                        return Err(Problem::at(
                            file.span,
                            format!("mesh `{}` is not a usable OBJ file: {e}", file.value),
                        ));
                    }
                }
                Object::Mesh(Mesh {
                    name: None,
                    material: self.material(node),
                    transform,
                    source: MeshSource::Obj(rel),
                    smooth: false,
                })
            }
            ObjectKind::RevSurface(c) => {
                let profile = curve_profile(c, true)?;
                if c.kind == CurveKind::Bezier && c.points.len() > 4 {
                    self.ctx.warn(c.span, format!(
                        "a Bézier profile with {} points is read as one curve of degree {} (the format is ambiguous: some students used piecewise cubics)",
                        c.points.len(),
                        c.points.len() - 1
                    ));
                }
                Object::Lathe(Lathe {
                    name: None,
                    material: self.material(node),
                    transform,
                    profile,
                })
            }
        };
        self.objects.push(obj);
        self.spans.push(node.span);
        Ok(())
    }
}

/// One Transform block: (steps in lumo order, the block's legacy matrix, uses Matrix4f).
fn transform_block(ops: &[Located<Op>]) -> Result<(Vec<TransformOp>, M4, bool), Problem> {
    let mut out = Vec::with_capacity(ops.len());
    let mut has_matrix = false;
    for op in ops.iter().rev() {
        let converted = match op.value {
            Op::Scale(s) => {
                if s.contains(&0.0) {
                    return Err(Problem::at(
                        op.span,
                        format!(
                            "scale {} has a zero factor, which flattens the object",
                            fmt3(s)
                        ),
                    ));
                }
                TransformOp::Scale(Scale::PerAxis(s))
            }
            Op::UniformScale(s) => {
                if s == 0.0 {
                    return Err(Problem::at(
                        op.span,
                        "UniformScale 0 shrinks the object to a point",
                    ));
                }
                TransformOp::Scale(Scale::Uniform(s))
            }
            Op::Translate(t) => TransformOp::Translate(t),
            Op::XRotate(d) => TransformOp::Rotate(Rotation {
                axis: [1.0, 0.0, 0.0],
                degrees: d,
            }),
            Op::YRotate(d) => TransformOp::Rotate(Rotation {
                axis: [0.0, 1.0, 0.0],
                degrees: d,
            }),
            Op::ZRotate(d) => TransformOp::Rotate(Rotation {
                axis: [0.0, 0.0, 1.0],
                degrees: d,
            }),
            Op::Rotate(axis, d) => {
                if is_zero(axis) {
                    return Err(Problem::at(op.span, "rotation axis is the zero vector"));
                }
                TransformOp::Rotate(Rotation { axis, degrees: d })
            }
            Op::Matrix4f(ref v) => {
                let m = to_rows(&math::matrix4f(v));
                if m[3] != [0.0, 0.0, 0.0, 1.0] {
                    return Err(Problem::at(op.span, format!(
                        "Matrix4f is not affine: its last row is {} {} {} {} (the 4th, 8th, 12th and 16th numbers, as the file lists the matrix column by column)",
                        m[3][0], m[3][1], m[3][2], m[3][3]
                    ))
                    .help("the last row must be 0 0 0 1; if you wrote the matrix row by row, transpose it"));
                }
                let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                    - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                    + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
                if det == 0.0 {
                    return Err(Problem::at(
                        op.span,
                        "Matrix4f is singular: it flattens the object",
                    ));
                }
                has_matrix = true;
                continue;
            }
        };
        out.push(converted);
    }
    let values: Vec<Op> = ops.iter().map(|o| o.value).collect();
    Ok((out, math::legacy_block_matrix(&values), has_matrix))
}

/// The lumo profile of a legacy curve; `flat` requires z = 0 (RevSurface profiles).
fn curve_profile(c: &CurveDef, flat: bool) -> Result<Profile, Problem> {
    if flat {
        if let Some(p) = c.points.iter().find(|p| p.value[2] != 0.0) {
            return Err(Problem::at(p.span, format!("the RevSurface profile must be flat on the xy-plane, but this control point has z = {}", p.value[2]))
                .help("profile control points are [ x y 0 ]; the curve is revolved about the y axis"));
        }
    }
    let points: Vec<[f32; 2]> = c.points.iter().map(|p| [p.value[0], p.value[1]]).collect();
    Ok(match c.kind {
        CurveKind::Bezier => Profile::Bezier(BezierProfile { points }),
        CurveKind::Bspline => {
            let knots = uniform_knots(points.len());
            Profile::Bspline(BsplineProfile {
                degree: 3,
                points,
                knots: Some(knots),
            })
        }
    })
}

/// The legacy B-spline's knots: uniform and unclamped, t_i = i / (N + 3) for i = 0 … N + 3
/// (N control points, degree 3). lumo traces \[knots\[3\], knots\[N\]\] = \[3/(N+3), N/(N+3)\], exactly
/// the legacy parameter range.
pub fn uniform_knots(n: usize) -> Vec<f32> {
    (0..n + 4)
        .map(|i| (i as f64 / (n + 3) as f64) as f32)
        .collect()
}

fn light(l: &LightDef, scene: &Scene, ctx: &mut Context<'_>) -> Result<(Light, Span), Problem> {
    Ok(match l {
        LightDef::Directional {
            span,
            direction,
            color,
        } => {
            if is_zero(direction.value) {
                return Err(
                    Problem::at(direction.span, "light direction is the zero vector")
                        .help("give the direction the light travels, e.g. 0 -1 0"),
                );
            }
            check_color(color, "light colour", None)?;
            let irradiance = color.value.map(|c| math::legacy_to_radiometric(c, 1.0));
            (
                Light::Directional(schema::DirectionalLight {
                    direction: direction.value,
                    irradiance,
                }),
                *span,
            )
        }
        LightDef::Point {
            span,
            position,
            color,
        } => {
            check_color(color, "light colour", None)?;
            let d = math::point_light_reference_distance(scene, position.value, &ctx.out_dir);
            let intensity = color.value.map(|c| math::legacy_to_radiometric(c, d * d));
            ctx.warn(*span, format!(
                "PointLight has no falloff in the legacy format; lumo's point light falls off with the squared distance, so its intensity is set to match the legacy brightness {d:.4} units away (at the centre of the scene's objects)"
            ));
            (
                Light::Point(schema::PointLight {
                    position: position.value,
                    intensity,
                }),
                *span,
            )
        }
    })
}
