//! The `Materials` block and each `Material`/`PhongMaterial` in it (legacy-format.md §3, §6).

use super::super::ast::*;
use super::super::error::Problem;
use super::{check_count, shorten, suggestion, unsupported, Parser, MAX_COUNT};

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

impl Parser<'_> {
    pub(super) fn materials(&mut self) -> Result<MaterialsDef, Problem> {
        let kw = self.expect("Materials", "")?;
        let n = self.open_counted("Materials", "numMaterials")?;
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
        check_count(n, materials.len(), "numMaterials", "block", "material", "")?;
        self.close("Materials")?;
        Ok(MaterialsDef {
            span: kw,
            materials,
        })
    }

    pub(super) fn material(&mut self) -> Result<MaterialDef, Problem> {
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
}
