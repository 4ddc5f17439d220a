//! Recursive-descent parser for the legacy grammar (shared/legacy-format.md §2–§6).
//!
//! Fixed-order blocks (camera, lights, geometry) are strict; `Material` and `Background` are
//! loose. Every deviation is a [`Problem`] with the span of the offending token, what was
//! expected and what was found, and a did-you-mean suggestion for misspelt keywords.

use lumo_schema::did_you_mean;

use super::ast::*;
use super::error::Problem;
use super::lexer::{parse_float, parse_int, Lexer, Span, Token};

/// Deepest nesting of groups, transforms and curves accepted (the original has no limit; a
/// limit keeps hostile input from overflowing the stack).
pub const MAX_DEPTH: usize = 64;
/// Largest `numObjects`, `numMaterials` or `numLights`, and most objects in one file.
pub const MAX_COUNT: i64 = 1_000_000;
/// Most control points in one curve.
pub const MAX_CONTROL_POINTS: usize = 100_000;

const TOP_BLOCKS: &[&str] = &[
    "PerspectiveCamera",
    "DepthCamera",
    "LensCamera",
    "Background",
    "Lights",
    "Materials",
    "Group",
];
const LIGHT_KINDS: &[&str] = &["DirectionalLight", "PointLight"];
const MATERIAL_KINDS: &[&str] = &["Material", "PhongMaterial"];
const MATERIAL_FIELDS: &[&str] = &[
    "diffuseColor",
    "color",
    "specularColor",
    "shininess",
    "texture",
    "emission",
    "emissionColor",
    "type",
    "refr",
    "refractiveIndex",
    "glossy",
    "reflective",
    "transmissive",
    "reflection",
    "refractiveColor",
    "reflectIntensity",
    "refractIntensity",
];
const OBJECT_KINDS: &[&str] = &[
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

/// Keywords some student dialects added that lumo cannot represent, with the reason.
fn unsupported(word: &str) -> Option<&'static str> {
    Some(match word {
        "DiskLight" => "`DiskLight` (zhanglbthu's disk area light) cannot be represented: lumo has no disk primitive; model the light as an emissive Sphere or Triangle instead",
        "AreaLight" | "SpotLight" => "this light of Chenyu-Yang-2000's dialect is not supported; use an emissive object (area light) instead",
        "FinitePlane" => "`FinitePlane` (Chenyu-Yang-2000) is not supported; use two Triangles",
        "SphereMoving" => "`SphereMoving` (motion blur, 1unx1) cannot be represented: lumo renders a single instant",
        "BRDF" => "`BRDF` (Chenyu-Yang-2000's 7-number material) is not supported; use `type`, `shininess` and `refr`",
        "bump" => "bump maps cannot be represented in lumo",
        "time1" | "time2" => "the shutter interval (`time1`/`time2`, motion blur) cannot be represented: lumo renders a single instant",
        _ => return None,
    })
}

/// Parses a whole legacy file. Returns the document or the first problem.
pub fn parse_document(src: &str) -> Result<Document, Problem> {
    let mut p = Parser {
        lx: Lexer::new(src),
        depth: 0,
        current_material: None,
        num_materials: None,
        material_index_used: false,
        objects: 0,
        doc: Document::default(),
    };
    p.document()?;
    Ok(p.doc)
}

struct Parser<'a> {
    lx: Lexer<'a>,
    depth: usize,
    /// The global "current material" set by `MaterialIndex` (parse order, no scoping).
    current_material: Option<usize>,
    /// Number of materials in the current `Materials` block.
    num_materials: Option<usize>,
    material_index_used: bool,
    objects: i64,
    doc: Document,
}

fn describe(t: Option<Token<'_>>) -> String {
    match t {
        Some(t) => format!("`{}`", shorten(t.text)),
        None => "the end of the file".to_string(),
    }
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        let head: String = s.chars().take(37).collect();
        format!("{head}...")
    } else {
        s.to_string()
    }
}

fn suggestion(word: &str, candidates: &[&'static str]) -> Option<String> {
    did_you_mean(word, candidates.iter().copied()).map(|s| format!("did you mean `{s}`?"))
}

impl<'a> Parser<'a> {
    /// The next token's span; at the end of the file, the last token's (so the excerpt shows
    /// where the text stops).
    fn here(&mut self) -> Span {
        match self.lx.peek() {
            Some(t) => t.span,
            None => self.lx.last_span(),
        }
    }

    fn unexpected(&mut self, expected: &str) -> Problem {
        let found = self.lx.peek();
        let span = self.here();
        let after = if found.is_none() && span.end > span.start {
            " after this"
        } else {
            ""
        };
        Problem::at(
            span,
            format!("expected {expected}, found {}{after}", describe(found)),
        )
    }

    fn warn(&mut self, span: Span, msg: impl Into<String>) {
        self.doc.warnings.push((span, msg.into()));
    }

    /// Consumes the exact token `word`.
    fn expect(&mut self, word: &str, context: &str) -> Result<Span, Problem> {
        match self.lx.peek() {
            Some(t) if t.text == word => {
                self.lx.next();
                Ok(t.span)
            }
            found => {
                let mut p = self.unexpected(&format!("`{word}` {context}"));
                if let Some(t) = found {
                    if t.text != word && did_you_mean(t.text, [word]).is_some() {
                        p = p.help(format!(
                            "did you mean `{word}`? (keywords are case-sensitive)"
                        ));
                    }
                }
                Err(p)
            }
        }
    }

    fn open(&mut self, block: &str) -> Result<Span, Problem> {
        self.expect("{", &format!("to open the {block} block"))
    }

    fn close(&mut self, block: &str) -> Result<Span, Problem> {
        self.expect("}", &format!("to close the {block} block"))
    }

    fn float(&mut self, what: &str) -> Result<Located<f32>, Problem> {
        match self.lx.peek() {
            Some(t) => match parse_float(t.text) {
                Some(v) => {
                    self.lx.next();
                    Ok(Located {
                        value: v,
                        span: t.span,
                    })
                }
                None => {
                    let mut p = Problem::at(
                        t.span,
                        format!("expected a number ({what}), found `{}`", shorten(t.text)),
                    );
                    if t.text.contains(',') {
                        p = p.help("numbers are separated by spaces, not commas");
                    } else if matches!(
                        t.text.to_ascii_lowercase().as_str(),
                        "inf" | "nan" | "infinity" | "-inf"
                    ) {
                        p = p.help("write a finite number");
                    }
                    Err(p)
                }
            },
            None => Err(self.unexpected(&format!("a number ({what})"))),
        }
    }

    fn int(&mut self, what: &str) -> Result<Located<i64>, Problem> {
        match self.lx.peek() {
            Some(t) => match parse_int(t.text) {
                Some(v) => {
                    self.lx.next();
                    Ok(Located {
                        value: v,
                        span: t.span,
                    })
                }
                None => {
                    let mut p = Problem::at(
                        t.span,
                        format!("expected an integer ({what}), found `{}`", shorten(t.text)),
                    );
                    if parse_float(t.text).is_some() {
                        p = p.help("write a whole number without a decimal point");
                    }
                    Err(p)
                }
            },
            None => Err(self.unexpected(&format!("an integer ({what})"))),
        }
    }

    fn count(&mut self, what: &str) -> Result<Located<i64>, Problem> {
        let n = self.int(what)?;
        if n.value < 0 || n.value > MAX_COUNT {
            return Err(
                Problem::at(n.span, format!("{what} {} is out of range", n.value))
                    .help(format!("use 0 to {MAX_COUNT}")),
            );
        }
        Ok(n)
    }

    fn vec3(&mut self, what: &str) -> Result<Located<V3>, Problem> {
        let x = self.float(&format!("x of {what}"))?;
        let y = self.float(&format!("y of {what}"))?;
        let z = self.float(&format!("z of {what}"))?;
        Ok(Located {
            value: [x.value, y.value, z.value],
            span: x.span.to(z.span),
        })
    }

    /// `keyword Vec3` in a fixed position.
    fn field_vec3(&mut self, key: &str, block: &str) -> Result<Located<V3>, Problem> {
        self.expect(key, &format!("in {block}"))?;
        self.vec3(&format!("{block} {key}"))
    }

    fn field_float(&mut self, key: &str, block: &str) -> Result<Located<f32>, Problem> {
        self.expect(key, &format!("in {block}"))?;
        self.float(&format!("{block} {key}"))
    }

    fn path_token(&mut self, what: &str) -> Result<Located<String>, Problem> {
        match self.lx.peek() {
            Some(t) if !matches!(t.text, "{" | "}" | "[" | "]") => {
                self.lx.next();
                Ok(Located {
                    value: t.text.to_string(),
                    span: t.span,
                })
            }
            _ => Err(self.unexpected(&format!("a file name ({what})"))),
        }
    }

    fn enter(&mut self, span: Span) -> Result<(), Problem> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(
                Problem::at(span, format!("nesting deeper than {MAX_DEPTH} levels"))
                    .help("flatten the groups and transforms"),
            );
        }
        Ok(())
    }

    fn leave(&mut self) {
        self.depth -= 1;
    }

    fn document(&mut self) -> Result<(), Problem> {
        while let Some(t) = self.lx.peek() {
            match t.text {
                "PerspectiveCamera" | "DepthCamera" | "LensCamera" => {
                    if self.doc.camera.is_some() {
                        self.warn(
                            t.span,
                            "a second camera block replaces the first (later blocks win)",
                        );
                    }
                    let cam = self.camera()?;
                    self.doc.camera = Some(cam);
                }
                "Background" => {
                    if self.doc.background.is_some() {
                        self.warn(
                            t.span,
                            "a second Background block replaces the first (later blocks win)",
                        );
                    }
                    let bg = self.background()?;
                    self.doc.background = Some(bg);
                }
                "Lights" => {
                    if self.doc.lights.is_some() {
                        self.warn(
                            t.span,
                            "a second Lights block replaces the first (later blocks win)",
                        );
                    }
                    let l = self.lights()?;
                    self.doc.lights = Some(l);
                }
                "Materials" => {
                    if self.material_index_used {
                        return Err(Problem::at(t.span, "a Materials block after a MaterialIndex is not supported")
                            .help("the original keeps pointers into the replaced block; define all materials once, before the first Group"));
                    }
                    if self.doc.materials.is_some() {
                        self.warn(
                            t.span,
                            "a second Materials block replaces the first (later blocks win)",
                        );
                    }
                    let m = self.materials()?;
                    self.num_materials = Some(m.materials.len());
                    self.doc.materials = Some(m);
                }
                "Group" => {
                    if self.doc.root.is_some() {
                        self.warn(t.span, "a second top-level Group replaces the first as the scene root (later blocks win)");
                    }
                    let g = self.object()?;
                    self.doc.root = Some(g);
                }
                word => {
                    let mut p = Problem::at(t.span, format!("expected a top-level block (a camera, Background, Lights, Materials or Group), found `{}`", shorten(word)));
                    if let Some(s) = suggestion(word, TOP_BLOCKS) {
                        p = p.help(s);
                    } else if word.starts_with('#') || word.starts_with("//") {
                        p = p.help("the legacy format has no comments");
                    } else if let Some(why) = unsupported(word) {
                        p = p.help(why);
                    }
                    return Err(p);
                }
            }
        }
        Ok(())
    }

    fn camera(&mut self) -> Result<CameraDef, Problem> {
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

    fn background(&mut self) -> Result<(Option<Located<V3>>, Span), Problem> {
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

    fn lights(&mut self) -> Result<LightsDef, Problem> {
        let kw = self.expect("Lights", "")?;
        self.open("Lights")?;
        self.expect("numLights", "as the first field of Lights")?;
        let n = self.count("numLights")?;
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
        if lights.len() as i64 != n.value {
            return Err(Problem::at(
                n.span,
                format!(
                    "numLights is {} but the block has {} light{}",
                    n.value,
                    lights.len(),
                    plural(lights.len())
                ),
            )
            .help(format!("write `numLights {}`", lights.len())));
        }
        self.close("Lights")?;
        Ok(LightsDef { span: kw, lights })
    }

    fn materials(&mut self) -> Result<MaterialsDef, Problem> {
        let kw = self.expect("Materials", "")?;
        self.open("Materials")?;
        self.expect("numMaterials", "as the first field of Materials")?;
        let n = self.count("numMaterials")?;
        let mut materials = Vec::new();
        loop {
            let Some(t) = self.lx.peek() else {
                return Err(self.unexpected("a material or `}`"));
            };
            match t.text {
                "}" => break,
                "Material" | "PhongMaterial" => {
                    let m = self.material()?;
                    materials.push(m);
                }
                word => {
                    let mut p = Problem::at(
                        t.span,
                        format!(
                            "expected a material (Material or PhongMaterial) or `}}`, found `{}`",
                            shorten(word)
                        ),
                    );
                    if let Some(s) = suggestion(word, MATERIAL_KINDS) {
                        p = p.help(s);
                    }
                    return Err(p);
                }
            }
            if materials.len() as i64 > MAX_COUNT {
                return Err(Problem::at(
                    t.span,
                    format!("more than {MAX_COUNT} materials"),
                ));
            }
        }
        if materials.len() as i64 != n.value {
            return Err(Problem::at(
                n.span,
                format!(
                    "numMaterials is {} but the block has {} material{}",
                    n.value,
                    materials.len(),
                    plural(materials.len())
                ),
            )
            .help(format!("write `numMaterials {}`", materials.len())));
        }
        self.close("Materials")?;
        Ok(MaterialsDef {
            span: kw,
            materials,
        })
    }

    fn material(&mut self) -> Result<MaterialDef, Problem> {
        let Some(kw) = self.lx.next() else {
            return Err(self.unexpected("a material"));
        };
        self.open(kw.text)?;
        let mut m = MaterialDef {
            span: kw.span,
            ..MaterialDef::default()
        };
        loop {
            let Some(t) = self.lx.peek() else {
                return Err(self.unexpected("a material field or `}`"));
            };
            if t.text == "}" {
                break;
            }
            self.lx.next();
            let key = t.text;
            match key {
                "diffuseColor" | "color" => {
                    if let Some(prev) = m.color {
                        self.warn(t.span, format!("`{key}` overrides the colour given at {}:{} (`color` and `diffuseColor` are the same field)", prev.span.line, prev.span.col));
                    }
                    m.color = Some(self.vec3(key)?);
                }
                "specularColor" => m.specular_color = Some(self.vec3(key)?),
                "shininess" => m.shininess = Some(self.float(key)?),
                "texture" => m.texture = Some(self.path_token("texture image")?),
                "emission" | "emissionColor" => m.emission = Some(self.vec3(key)?),
                "type" => {
                    m.lobe_weights =
                        Some(self.vec3("lobe weights (diffuse, specular, refraction)")?)
                }
                "refr" | "refractiveIndex" => m.refr = Some(self.float("index of refraction")?),
                "glossy" => m.glossy = Some(self.float("glossy flag")?),
                "reflective" => m.reflective = Some(self.float("mirror weight")?),
                "transmissive" => {
                    let w = self.float("transmission weight")?;
                    let ior = self.float("index of refraction")?;
                    m.transmissive = Some((w, ior));
                }
                "reflection" => {
                    m.reflection = Some(self.int("reflection kind (0 diffuse, 1 mirror, 2 glass)")?)
                }
                "refractiveColor" => {
                    let c = self.vec3(key)?;
                    if c.value != [1.0, 1.0, 1.0] {
                        return Err(Problem::at(c.span, "a transmission tint (`refractiveColor`) other than 1 1 1 cannot be represented")
                            .help("lumo's dielectric lobe is untinted; remove refractiveColor or set it to 1 1 1"));
                    }
                }
                "reflectIntensity" | "refractIntensity" => {
                    self.float(key)?;
                    self.warn(
                        t.span,
                        format!(
                            "`{key}` is ignored (zhanglbthu's dialect parses it but never uses it)"
                        ),
                    );
                }
                "diffusecolor" => {
                    self.vec3(key)?;
                    self.warn(t.span, "`diffusecolor` (lower-case c) is ignored, as in zhanglbthu's dialect; did you mean `diffuseColor`?");
                }
                _ => {
                    let mut p =
                        Problem::at(t.span, format!("unknown material field `{}`", shorten(key)));
                    if let Some(why) = unsupported(key) {
                        p = p.help(why);
                    } else if let Some(s) = suggestion(key, MATERIAL_FIELDS) {
                        p = p.help(s);
                    } else {
                        p = p.help(format!("known fields: {}", MATERIAL_FIELDS.join(", ")));
                    }
                    return Err(p);
                }
            }
        }
        self.close("material")?;
        Ok(m)
    }

    /// One object (or a nested Group) at an object position.
    fn object(&mut self) -> Result<ObjectNode, Problem> {
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

    /// After `Group`: `{ numObjects N (MaterialIndex k | object)* }`.
    fn group_body(&mut self) -> Result<Vec<ObjectNode>, Problem> {
        self.open("Group")?;
        self.expect("numObjects", "as the first field of Group")?;
        let n = self.count("numObjects")?;
        let mut items = Vec::new();
        loop {
            let Some(t) = self.lx.peek() else {
                return Err(self.unexpected("an object, `MaterialIndex` or `}`"));
            };
            match t.text {
                "}" => break,
                "MaterialIndex" => {
                    self.lx.next();
                    let k = self.int("material index")?;
                    let count = self.num_materials.unwrap_or(0);
                    if k.value < 0 || k.value as u64 >= count as u64 {
                        let help = if self.num_materials.is_none() {
                            "there is no Materials block before this Group; materials must be defined first".to_string()
                        } else {
                            format!("indices are 0-based: use 0 to {}", count.saturating_sub(1))
                        };
                        return Err(Problem::at(
                            k.span,
                            format!(
                                "MaterialIndex {} is out of range: there {} {count} material{}",
                                k.value,
                                if count == 1 { "is" } else { "are" },
                                plural(count)
                            ),
                        )
                        .help(help));
                    }
                    self.material_index_used = true;
                    self.current_material = Some(k.value as usize);
                }
                "numObjects" => {
                    return Err(Problem::at(t.span, "`numObjects` given twice in one Group"));
                }
                _ => items.push(self.object()?),
            }
        }
        if items.len() as i64 != n.value {
            return Err(Problem::at(
                n.span,
                format!(
                    "numObjects is {} but the group has {} object{}",
                    n.value,
                    items.len(),
                    plural(items.len())
                ),
            )
            .help(format!(
                "write `numObjects {}` (MaterialIndex lines are not counted)",
                items.len()
            )));
        }
        self.close("Group")?;
        Ok(items)
    }

    /// After `Transform`: `{ op* object }`.
    fn transform(&mut self) -> Result<ObjectKind, Problem> {
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

    /// `BezierCurve|BsplineCurve { controls [ x y z ]* }`.
    fn curve(&mut self) -> Result<CurveDef, Problem> {
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

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}
