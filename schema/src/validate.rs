//! Semantic checks that a well-typed scene must also pass. All problems are collected, not
//! only the first.

use std::path::Path;

use crate::diagnostic::{did_you_mean, Diagnostic};
use crate::locate::JsonPath;
use crate::scene::*;

/// Largest accepted image, in pixels (width × height): 64 megapixels.
pub const MAX_PIXELS: u64 = 1 << 26;
/// Largest accepted image side, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest accepted samples per pixel.
pub const MAX_SPP: u32 = 1 << 20;

/// Checks everything serde cannot: ranges, references between names, geometry that makes
/// sense, files that exist. `base_dir` is the folder relative paths resolve against; when
/// `None`, file existence is not checked.
pub fn validate(scene: &Scene, base_dir: Option<&Path>) -> Vec<Diagnostic> {
    let mut v = Validator {
        scene,
        base_dir,
        out: Vec::new(),
    };
    v.scene();
    v.out
}

struct Validator<'a> {
    scene: &'a Scene,
    base_dir: Option<&'a Path>,
    out: Vec<Diagnostic>,
}

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn length(v: Vec3) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn is_gltf(file: &str) -> bool {
    let lower = file.to_ascii_lowercase();
    lower.ends_with(".gltf") || lower.ends_with(".glb")
}

impl Validator<'_> {
    fn err(&mut self, path: JsonPath, message: impl Into<String>) {
        self.out.push(Diagnostic::new(path, message));
    }

    fn err_help(&mut self, path: JsonPath, message: impl Into<String>, help: impl Into<String>) {
        self.out
            .push(Diagnostic::new(path, message).with_help(help));
    }

    fn scene(&mut self) {
        let root = JsonPath::root();
        let s = self.scene;
        if s.format_version != FORMAT_VERSION {
            self.err_help(
                root.key("format_version"),
                format!("unsupported format version {}", s.format_version),
                format!("this lumo reads format_version {FORMAT_VERSION}"),
            );
        }
        self.image(&root.key("image"));
        self.render(&root.key("render"));
        self.camera(&root.key("camera"));
        self.background(&root.key("background"), &s.background);
        for (name, tex) in &s.textures {
            self.texture(&root.key("textures").key(name), tex);
        }
        for (name, mat) in &s.materials {
            self.material(&root.key("materials").key(name), mat);
        }
        for (i, obj) in s.objects.iter().enumerate() {
            self.object(&root.key("objects").index(i), obj);
        }
        for (i, light) in s.lights.iter().enumerate() {
            self.light(&root.key("lights").index(i), light);
        }
    }

    fn image(&mut self, p: &JsonPath) {
        let img = self.scene.image;
        for (key, side) in [("width", img.width), ("height", img.height)] {
            if side == 0 || side > MAX_IMAGE_SIDE {
                self.err_help(
                    p.key(key),
                    format!("{key} {side} is out of range"),
                    format!("use 1 to {MAX_IMAGE_SIDE} pixels"),
                );
            }
        }
        let pixels = u64::from(img.width) * u64::from(img.height);
        if pixels > MAX_PIXELS {
            self.err_help(
                p.clone(),
                format!(
                    "{}×{} = {pixels} pixels is above the limit of {MAX_PIXELS}",
                    img.width, img.height
                ),
                "render a smaller image",
            );
        }
    }

    fn render(&mut self, p: &JsonPath) {
        let r = self.scene.render.clone();
        if r.spp == 0 || r.spp > MAX_SPP {
            self.err_help(
                p.key("spp"),
                format!("spp {} is out of range", r.spp),
                format!("use 1 to {MAX_SPP}"),
            );
        }
        if r.max_depth == 0 || r.max_depth > 1024 {
            self.err_help(
                p.key("max_depth"),
                format!("max_depth {} is out of range", r.max_depth),
                "use 1 (emitters only) to 1024",
            );
        }
        if let Some(t) = r.time_budget_s {
            if !(t.is_finite() && t > 0.0) {
                self.err(
                    p.key("time_budget_s"),
                    format!("time budget must be a positive number of seconds, found {t}"),
                );
            }
        }
    }

    fn camera(&mut self, p: &JsonPath) {
        let c = self.scene.camera;
        let mut ok = true;
        for (key, v) in [
            ("position", c.position),
            ("look_at", c.look_at),
            ("up", c.up),
        ] {
            if !finite(&v) {
                self.err(p.key(key), "contains NaN or infinity");
                ok = false;
            }
        }
        let dir = [
            c.look_at[0] - c.position[0],
            c.look_at[1] - c.position[1],
            c.look_at[2] - c.position[2],
        ];
        if ok && length(dir) == 0.0 {
            self.err_help(
                p.key("look_at"),
                "look_at equals position: no view direction",
                "move look_at in front of the camera",
            );
            ok = false;
        }
        if ok && length(c.up) == 0.0 {
            self.err_help(p.key("up"), "up is the zero vector", "use [0, 1, 0]");
            ok = false;
        }
        if ok {
            let (d, u) = (length(dir), length(c.up));
            let cross = [
                dir[1] * c.up[2] - dir[2] * c.up[1],
                dir[2] * c.up[0] - dir[0] * c.up[2],
                dir[0] * c.up[1] - dir[1] * c.up[0],
            ];
            if length(cross) <= 1e-6 * d * u {
                self.err_help(
                    p.key("up"),
                    "up is parallel to the view direction, so the image's roll is undefined",
                    "choose an up vector that is not along look_at − position",
                );
            }
        }
        if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
            self.err_help(
                p.key("fov_y_deg"),
                format!("field of view {} is out of range", c.fov_y_deg),
                "use a value strictly between 0 and 180 degrees",
            );
        }
        if !(c.aperture_radius >= 0.0 && c.aperture_radius.is_finite()) {
            self.err(
                p.key("aperture_radius"),
                format!("aperture radius must be ≥ 0, found {}", c.aperture_radius),
            );
        }
        if let Some(f) = c.focus_distance {
            if !(f > 0.0 && f.is_finite()) {
                self.err(
                    p.key("focus_distance"),
                    format!("focus distance must be > 0, found {f}"),
                );
            } else if c.aperture_radius == 0.0 {
                self.err_help(
                    p.key("focus_distance"),
                    "focus_distance has no effect on a pinhole camera",
                    "set aperture_radius > 0 for depth of field, or remove focus_distance",
                );
            }
        }
    }

    /// A colour: finite, non-negative, and at most `max` per channel when given.
    fn color(&mut self, p: &JsonPath, c: Rgb, max: Option<f32>) {
        if !finite(&c) || c.iter().any(|x| *x < 0.0) {
            self.err(
                p.clone(),
                format!("colour {c:?} must be finite and non-negative"),
            );
        } else if let Some(m) = max {
            if c.iter().any(|x| *x > m) {
                self.err_help(
                    p.clone(),
                    format!("reflectance {c:?} is above {m}: the surface would create energy"),
                    "keep each channel in [0, 1]",
                );
            }
        }
    }

    fn file(&mut self, p: &JsonPath, file: &str, what: &str) {
        let Some(base) = self.base_dir else { return };
        if file.is_empty() {
            self.err(p.clone(), format!("empty {what} file name"));
            return;
        }
        let resolved = base.join(file);
        if !resolved.is_file() {
            self.err_help(
                p.clone(),
                format!(
                    "{what} file `{file}` not found (looked for {})",
                    resolved.display()
                ),
                "paths are relative to the scene file's folder",
            );
        }
    }

    fn texture(&mut self, p: &JsonPath, t: &Texture) {
        self.file(&p.key("file"), &t.file, "texture");
        match (is_gltf(&t.file), t.gltf_image) {
            (true, None) => self.err_help(
                p.key("gltf_image"),
                "a texture from a glTF file needs the index of the image",
                "add \"gltf_image\": 0 (an index into the file's `images`)",
            ),
            (false, Some(_)) => self.err_help(
                p.key("gltf_image"),
                "gltf_image is only meaningful when `file` is a .gltf or .glb file",
                "remove gltf_image",
            ),
            _ => {}
        }
    }

    fn texture_ref(&mut self, p: &JsonPath, r: &TextureRef) {
        if !self.scene.textures.contains_key(&r.texture) {
            let names = self.scene.textures.keys().map(String::as_str);
            let help = match did_you_mean(&r.texture, names) {
                Some(s) => format!("did you mean `{s}`?"),
                None => "define it under `textures`".to_string(),
            };
            self.err_help(
                p.key("texture"),
                format!("unknown texture `{}`", r.texture),
                help,
            );
        }
        if !finite(&r.offset) || !finite(&r.scale) || !r.rotation_deg.is_finite() {
            self.err(p.clone(), "texture transform contains NaN or infinity");
        }
        if r.tex_coord > 1 {
            self.err_help(
                p.key("tex_coord"),
                format!("texture coordinate set {} does not exist", r.tex_coord),
                "meshes have sets 0 and 1 (glTF TEXCOORD_0 and TEXCOORD_1)",
            );
        }
    }

    fn background(&mut self, p: &JsonPath, b: &Background) {
        self.color(&p.key("color"), b.color, None);
        if !(b.strength >= 0.0 && b.strength.is_finite()) {
            self.err_help(
                p.key("strength"),
                format!("strength {} must be finite and ≥ 0", b.strength),
                "1 keeps the image's own radiance",
            );
        }
        if !b.rotation_deg.is_finite() {
            self.err(p.key("rotation_deg"), "rotation_deg must be finite");
        }
        match &b.image {
            Some(file) => {
                if b.color != [0.0; 3] {
                    self.err_help(
                        p.key("color"),
                        "color is not used with an image",
                        "remove color (scale the image with strength)",
                    );
                }
                let ext = crate::geometry::paths::lowercase_extension(Path::new(file));
                if !matches!(ext.as_str(), "exr" | "hdr") {
                    self.err_help(
                        p.key("image"),
                        format!("`{file}` is not an HDR image"),
                        "use an equirectangular .exr or .hdr file",
                    );
                }
                self.file(&p.key("image"), file, "environment image");
            }
            None => {
                if b.rotation_deg != 0.0 {
                    self.err_help(
                        p.key("rotation_deg"),
                        "rotation_deg only applies to an image",
                        "add an image or remove rotation_deg",
                    );
                }
            }
        }
    }

    fn material(&mut self, p: &JsonPath, m: &Material) {
        self.color(&p.key("base_color"), m.base_color, Some(1.0));
        self.color(&p.key("emission"), m.emission, None);
        self.color(&p.key("specular_color"), m.specular_color, None);
        self.color(&p.key("sheen_color"), m.sheen_color, Some(1.0));
        for (key, w) in [
            ("alpha", m.alpha),
            ("alpha_cutoff", m.alpha_cutoff),
            ("metallic", m.metallic),
            ("roughness", m.roughness),
            ("clearcoat", m.clearcoat),
            ("clearcoat_roughness", m.clearcoat_roughness),
            ("sheen_roughness", m.sheen_roughness),
            ("specular", m.specular),
            ("transmission", m.transmission),
        ] {
            if !(0.0..=1.0).contains(&w) {
                self.err_help(
                    p.key(key),
                    format!("{key} {w} is outside [0, 1]"),
                    "use a fraction between 0 and 1",
                );
            }
        }
        if !m.normal_scale.is_finite() {
            self.err(p.key("normal_scale"), "normal_scale must be finite");
        }
        if m.normal_texture.is_none() && m.normal_scale != 1.0 {
            self.err_help(
                p.key("normal_scale"),
                "normal_scale without a normal_texture has no effect",
                "add a normal_texture or remove normal_scale",
            );
        }
        if !m.clearcoat_normal_scale.is_finite()
            || (m.clearcoat_normal_texture.is_none() && m.clearcoat_normal_scale != 1.0)
        {
            self.err_help(
                p.key("clearcoat_normal_scale"),
                "clearcoat_normal_scale must be finite and needs a clearcoat_normal_texture",
                "add a clearcoat_normal_texture or remove clearcoat_normal_scale",
            );
        }
        if m.alpha_mode != AlphaMode::Mask && m.alpha_cutoff != 0.5 {
            self.err_help(
                p.key("alpha_cutoff"),
                "alpha_cutoff only applies to alpha_mode `mask`",
                "set \"alpha_mode\": \"mask\" or remove alpha_cutoff",
            );
        }
        if !(m.ior > 0.0 && m.ior.is_finite()) {
            self.err_help(
                p.key("ior"),
                format!("index of refraction {} must be > 0", m.ior),
                "glass is about 1.5, water 1.33",
            );
        }
        if let Some(v) = &m.volume {
            let q = p.key("volume");
            if v.attenuation_color.iter().any(|&c| !(c > 0.0 && c <= 1.0)) {
                self.err_help(
                    q.key("attenuation_color"),
                    format!(
                        "attenuation colour {:?} must have each channel in (0, 1]",
                        v.attenuation_color
                    ),
                    "it is the colour white light takes after `attenuation_distance` inside",
                );
            }
            if let Some(d) = v.attenuation_distance {
                if !(d > 0.0 && d.is_finite()) {
                    self.err_help(
                        q.key("attenuation_distance"),
                        format!("attenuation distance {d} must be > 0"),
                        "leave it out for a clear medium",
                    );
                }
            }
        }
        for (key, r) in m.texture_refs() {
            if let Some(r) = r {
                self.texture_ref(&p.key(key), r);
            }
        }
    }

    fn material_ref(&mut self, p: &JsonPath, name: &str) {
        if !self.scene.materials.contains_key(name) {
            let names = self.scene.materials.keys().map(String::as_str);
            let help = match did_you_mean(name, names) {
                Some(s) => format!("did you mean `{s}`?"),
                None => "define it under `materials`".to_string(),
            };
            self.err_help(p.clone(), format!("unknown material `{name}`"), help);
        }
    }

    fn transform(&mut self, p: &JsonPath, t: &Transform) {
        for (i, op) in t.iter().enumerate() {
            let q = p.index(i);
            match op {
                TransformOp::Translate(v) => {
                    if !finite(v) {
                        self.err(q.key("translate"), "translation contains NaN or infinity");
                    }
                }
                TransformOp::Rotate(r) => {
                    if !finite(&r.axis) || !r.degrees.is_finite() {
                        self.err(q.key("rotate"), "rotation contains NaN or infinity");
                    } else if length(r.axis) == 0.0 {
                        self.err_help(
                            q.key("rotate").key("axis"),
                            "rotation axis is the zero vector",
                            "e.g. [0, 1, 0] for the y axis",
                        );
                    }
                }
                TransformOp::Scale(s) => {
                    let v = match s {
                        Scale::Uniform(k) => [*k; 3],
                        Scale::PerAxis(v) => *v,
                    };
                    if !finite(&v) || v.contains(&0.0) {
                        self.err_help(
                            q.key("scale"),
                            format!("scale {v:?} must be finite and non-zero"),
                            "a zero scale flattens the object; remove it instead",
                        );
                    }
                }
                TransformOp::Matrix(m) => {
                    let flat: Vec<f32> = m.iter().flatten().copied().collect();
                    if !finite(&flat) {
                        self.err(q.key("matrix"), "matrix contains NaN or infinity");
                    } else if m[3] != [0.0, 0.0, 0.0, 1.0] {
                        self.err_help(
                            q.key("matrix").index(3),
                            "the last row must be [0, 0, 0, 1] (an affine map)",
                            "projective matrices are not supported",
                        );
                    } else {
                        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
                        if det == 0.0 || !det.is_finite() {
                            self.err(
                                q.key("matrix"),
                                "matrix is singular (it flattens the object)",
                            );
                        }
                    }
                }
            }
        }
    }

    fn object(&mut self, p: &JsonPath, o: &Object) {
        let q = p.key(o.kind());
        self.material_ref(&q.key("material"), o.material());
        self.transform(&q.key("transform"), o.transform());
        match o {
            Object::Sphere(s) => {
                if !finite(&s.center) {
                    self.err(q.key("center"), "center contains NaN or infinity");
                }
                if !(s.radius > 0.0 && s.radius.is_finite()) {
                    self.err_help(
                        q.key("radius"),
                        format!("radius must be > 0, found {}", s.radius),
                        "use a positive radius in scene units",
                    );
                }
            }
            Object::Plane(pl) => {
                if !finite(&pl.normal) || length(pl.normal) == 0.0 {
                    self.err_help(
                        q.key("normal"),
                        format!("normal {:?} must be finite and non-zero", pl.normal),
                        "e.g. [0, 1, 0] for a floor",
                    );
                }
                if !pl.offset.is_finite() {
                    self.err(q.key("offset"), "offset must be finite");
                }
            }
            Object::Triangle(t) => {
                let flat: Vec<f32> = t.vertices.iter().flatten().copied().collect();
                if !finite(&flat) {
                    self.err(q.key("vertices"), "vertices contain NaN or infinity");
                }
            }
            Object::Mesh(m) => self.mesh(&q, m),
            Object::Lathe(l) => self.profile(&q.key("profile"), &l.profile),
        }
    }

    fn mesh(&mut self, q: &JsonPath, m: &Mesh) {
        let src = q.key("source");
        match &m.source {
            MeshSource::Obj(file) => {
                self.file(&src.key("obj"), file, "OBJ");
                if !file.to_ascii_lowercase().ends_with(".obj") {
                    self.err_help(
                        src.key("obj"),
                        format!("`{file}` is not an .obj file"),
                        "use {\"gltf\": {...}} for glTF meshes",
                    );
                }
            }
            MeshSource::Gltf(g) => {
                self.file(&src.key("gltf").key("file"), &g.file, "glTF");
                if !is_gltf(&g.file) {
                    self.err_help(
                        src.key("gltf").key("file"),
                        format!("`{}` is not a .gltf or .glb file", g.file),
                        "use {\"obj\": \"file.obj\"} for OBJ meshes",
                    );
                }
            }
            MeshSource::Inline(mesh) => {
                let p = src.key("inline");
                let n = mesh.positions.len();
                if n == 0 || mesh.indices.is_empty() {
                    self.err(p.clone(), "an inline mesh needs at least one triangle");
                }
                if let Some(i) = mesh.positions.iter().position(|v| !finite(v)) {
                    self.err(
                        p.key("positions").index(i),
                        "position contains NaN or infinity",
                    );
                }
                if let Some((i, t)) = mesh
                    .indices
                    .iter()
                    .enumerate()
                    .find(|(_, t)| t.iter().any(|&k| k as usize >= n))
                {
                    self.err_help(
                        p.key("indices").index(i),
                        format!("index out of range in {t:?}: there are {n} positions"),
                        "indices are 0-based",
                    );
                }
                for (key, len) in [
                    ("normals", mesh.normals.as_ref().map(Vec::len)),
                    ("uvs", mesh.uvs.as_ref().map(Vec::len)),
                ] {
                    if let Some(len) = len {
                        if len != n {
                            self.err(
                                p.key(key),
                                format!("{len} {key} for {n} positions: give one per position"),
                            );
                        }
                    }
                }
                if let Some(normals) = &mesh.normals {
                    if let Some(i) = normals.iter().position(|v| !finite(v) || length(*v) == 0.0) {
                        self.err(
                            p.key("normals").index(i),
                            "normal must be finite and non-zero",
                        );
                    }
                }
                if let Some(uvs) = &mesh.uvs {
                    if let Some(i) = uvs.iter().position(|v| !finite(v)) {
                        self.err(
                            p.key("uvs").index(i),
                            "texture coordinate contains NaN or infinity",
                        );
                    }
                }
            }
        }
    }

    fn profile(&mut self, p: &JsonPath, profile: &Profile) {
        match profile {
            Profile::Bezier(b) => {
                let q = p.key("bezier").key("points");
                if b.points.len() < 2 {
                    self.err_help(
                        q.clone(),
                        format!(
                            "a Bézier profile needs at least 2 control points, found {}",
                            b.points.len()
                        ),
                        "2 points make a line, 4 a cubic",
                    );
                }
                self.points(&q, &b.points);
            }
            Profile::Bspline(b) => {
                let q = p.key("bspline");
                let (n, deg) = (b.points.len(), b.degree as usize);
                if b.degree == 0 {
                    self.err(q.key("degree"), "degree must be at least 1");
                } else if n < deg + 1 {
                    self.err_help(
                        q.key("points"),
                        format!(
                            "a degree-{deg} B-spline needs at least {} control points, found {n}",
                            deg + 1
                        ),
                        "add control points or lower the degree",
                    );
                }
                self.points(&q.key("points"), &b.points);
                if let Some(knots) = &b.knots {
                    let want = n + deg + 1;
                    if knots.len() != want {
                        self.err_help(
                            q.key("knots"),
                            format!("{} knots given, a degree-{deg} B-spline with {n} control points needs {want}", knots.len()),
                            "knots = control points + degree + 1, or leave `knots` out for a clamped uniform vector",
                        );
                    } else if !finite(knots) {
                        self.err(q.key("knots"), "knots contain NaN or infinity");
                    } else if let Some(i) = knots.windows(2).position(|w| w[1] < w[0]) {
                        self.err_help(
                            q.key("knots").index(i + 1),
                            format!(
                                "knot {} is smaller than the one before ({})",
                                knots[i + 1],
                                knots[i]
                            ),
                            "knots must be non-decreasing",
                        );
                    } else if n > deg && knots[deg] >= knots[n] {
                        self.err(
                            q.key("knots"),
                            format!(
                                "the curve's parameter range [knots[{deg}], knots[{n}]] is empty"
                            ),
                        );
                    }
                }
            }
        }
    }

    fn points(&mut self, p: &JsonPath, points: &[Vec2]) {
        if let Some(i) = points.iter().position(|v| !finite(v)) {
            self.err(p.index(i), "control point contains NaN or infinity");
        }
    }

    fn light(&mut self, p: &JsonPath, l: &Light) {
        match l {
            Light::Point(pt) => {
                let q = p.key("point");
                if !finite(&pt.position) {
                    self.err(q.key("position"), "position contains NaN or infinity");
                }
                self.color(&q.key("intensity"), pt.intensity, None);
            }
            Light::Directional(d) => {
                let q = p.key("directional");
                self.direction(&q.key("direction"), d.direction);
                self.color(&q.key("irradiance"), d.irradiance, None);
            }
            Light::Spot(s) => {
                let q = p.key("spot");
                if !finite(&s.position) {
                    self.err(q.key("position"), "position contains NaN or infinity");
                }
                self.direction(&q.key("direction"), s.direction);
                self.color(&q.key("intensity"), s.intensity, None);
                if !(0.0..=90.0).contains(&s.inner_angle_deg) {
                    self.err(
                        q.key("inner_angle_deg"),
                        format!(
                            "inner angle {} is outside [0, 90] degrees",
                            s.inner_angle_deg
                        ),
                    );
                }
                if !(s.outer_angle_deg > 0.0 && s.outer_angle_deg <= 90.0) {
                    self.err(
                        q.key("outer_angle_deg"),
                        format!(
                            "outer angle {} is outside (0, 90] degrees",
                            s.outer_angle_deg
                        ),
                    );
                } else if s.outer_angle_deg < s.inner_angle_deg {
                    self.err_help(
                        q.key("outer_angle_deg"),
                        "outer angle is smaller than the inner angle",
                        "the outer angle bounds the cone; make it ≥ inner_angle_deg",
                    );
                }
            }
        }
    }

    fn direction(&mut self, p: &JsonPath, d: Vec3) {
        if !finite(&d) || length(d) == 0.0 {
            self.err(
                p.clone(),
                format!("direction {d:?} must be finite and non-zero"),
            );
        }
    }
}
