//! Mapping a legacy `Material`/`PhongMaterial` onto a lumo [`Material`]: base colour, emission,
//! lobe weights, roughness, index of refraction and texture. Each rule is documented in
//! `docs/legacy.md`; the comments here say why.

use std::collections::BTreeMap;

use lumo_schema as schema;
use lumo_schema::{Material, Texture, TextureRef};

use super::ast::*;
use super::error::Problem;
use super::import::{check_color, ctx_file, fmt3, is_zero, Context};
use super::lexer::Span;
use super::math;

/// one-step-beh1nd's fixed GGX width for `glossy` materials (their D_GGX uses it as α).
pub const GLOSSY_ALPHA: f32 = 0.1;

/// Maps one legacy material; textures it names are added to `textures` (shared by file).
pub(super) fn material(
    m: &MaterialDef,
    ctx: &mut Context<'_>,
    textures: &mut BTreeMap<String, Texture>,
) -> Result<Material, Problem> {
    let mut out = Material {
        roughness: 0.0,
        ..Material::lambert([1.0; 3])
    };
    if let Some(c) = &m.color {
        check_color(c, "colour", Some(1.0))?;
    }
    out.base_color = m.color.map(|c| c.value).unwrap_or([1.0; 3]);
    if let Some(e) = &m.emission {
        check_color(e, "emission", None)?;
        out.emission = e.value;
        // The dialects add emission whichever side a ray hits (smallpt style).
        out.two_sided_emission = !is_zero(e.value);
    }

    let lobes = lobe_weights(m, out.base_color, ctx)?;
    let (Lobes { d, s, t, .. }, roughness) = specular_roughness(m, lobes, ctx)?;
    // The legacy renderers pick one lobe by weight: a metal (mirror or glossy) of weight s,
    // refracting glass of weight t, and a Lambertian diffuse of weight d with no specular
    // coat. In glTF's model: metallic s; the dielectric rest transmits t / (1 − s) through a
    // volume (glass refracts) and reflects the remainder diffusely; `specular` 0 removes the
    // coat (the glass keeps its own Fresnel reflection).
    out.roughness = roughness;
    out.metallic = s;
    out.specular = 0.0;
    if t > 0.0 {
        out.transmission = if s < 1.0 {
            (t / (1.0 - s)).min(1.0)
        } else {
            0.0
        };
        out.volume = Some(schema::Volume::default());
    }
    let rest = 1.0 - s - t;
    if d < rest - 1e-6 && s == 0.0 && t == 0.0 {
        // Absorbing diffuse: the weight becomes a darker albedo.
        out.base_color = out.base_color.map(|c| c * d);
    }
    if let Some(ior) = ior(m, t, ctx)? {
        out.ior = ior;
    }
    if let Some(tex) = &m.texture {
        out.base_color_texture = Some(texture(tex, ctx, textures)?);
    }
    Ok(out)
}

/// The diffuse, specular and refraction weights of a material, and whether they come from the
/// original Phong model (`specularColor`).
#[derive(Debug, Clone, Copy)]
struct Lobes {
    d: f32,
    s: f32,
    t: f32,
    phong: bool,
}

/// The lobe weights from whichever one way the material gives them (`type`, `reflection`,
/// `reflective`/`transmissive`, or a Phong `specularColor`); diffuse only when none.
fn lobe_weights(
    m: &MaterialDef,
    base_color: [f32; 3],
    ctx: &mut Context<'_>,
) -> Result<Lobes, Problem> {
    // Lobe weights: at most one way of giving them.
    let weight_sources: Vec<(Span, &str)> = [
        m.lobe_weights.map(|w| (w.span, "type")),
        m.reflection.map(|r| (r.span, "reflection")),
        m.reflective
            .map(|r| (r.span, "reflective"))
            .or(m.transmissive.map(|t| (t.0.span, "transmissive"))),
    ]
    .into_iter()
    .flatten()
    .collect();
    if weight_sources.len() > 1 {
        let (span, second) = weight_sources[1];
        return Err(Problem::at(
            span,
            format!(
                "`{second}` conflicts with `{}`: both set the lobe weights",
                weight_sources[0].1
            ),
        )
        .help("keep one of them"));
    }
    let mut phong = false;
    let (mut d, mut s, mut t) = (1.0f32, 0.0f32, 0.0f32);
    if let Some(w) = &m.lobe_weights {
        let v = w.value;
        if v.iter().any(|x| *x < 0.0) {
            return Err(Problem::at(
                w.span,
                format!("lobe weights `type {}` must not be negative", fmt3(v)),
            ));
        }
        let sum = v[0] + v[1] + v[2];
        if sum == 0.0 {
            return Err(
                Problem::at(w.span, "lobe weights `type 0 0 0` are all zero")
                    .help("give the (diffuse, specular, refraction) weights, e.g. `type 1 0 0`"),
            );
        }
        // Normalised to sum 1 as the dialects do; weights already summing to 1 (to f32
        // precision) are kept as written so that exported weights read back unchanged.
        (d, s, t) = if (sum as f64 - 1.0).abs() <= 1e-6 {
            (v[0], v[1], v[2])
        } else {
            (v[0] / sum, v[1] / sum, v[2] / sum)
        };
    } else if let Some(r) = &m.reflection {
        (d, s, t) = match r.value {
            0 => (1.0, 0.0, 0.0),
            1 => (0.0, 1.0, 0.0),
            2 => (0.0, 0.0, 1.0),
            k => {
                return Err(
                    Problem::at(r.span, format!("reflection kind {k} is unknown"))
                        .help("0 is diffuse, 1 mirror, 2 glass"),
                )
            }
        };
    } else if m.reflective.is_some() || m.transmissive.is_some() {
        let r = m.reflective.map(|r| r.value).unwrap_or(0.0);
        let w = m.transmissive.map(|t| t.0.value).unwrap_or(0.0);
        for (v, span) in [
            (r, m.reflective.map(|x| x.span)),
            (w, m.transmissive.map(|x| x.0.span)),
        ] {
            if let Some(span) = span {
                if !(0.0..=1.0).contains(&v) {
                    return Err(Problem::at(span, format!("weight {v} is outside [0, 1]")));
                }
            }
        }
        if r + w > 1.0 {
            return Err(Problem::at(
                m.span,
                format!("reflective {r} + transmissive {w} exceed 1"),
            ));
        }
        (d, s, t) = (1.0 - r - w, r, w);
    } else if let Some(sc) = m.specular_color.filter(|c| !is_zero(c.value)) {
        // Original Phong material: kd·diffuse + ks·highlight. lumo's weights must sum to at most
        // 1, so (1, ks) with ks = max channel of specularColor is normalised to sum 1.
        check_color(&sc, "specular colour", Some(1.0))?;
        let ks = sc.value.iter().fold(0.0f32, |a, b| a.max(*b));
        (d, s) = (1.0 / (1.0 + ks), ks / (1.0 + ks));
        phong = true;
        if sc.value != base_color {
            ctx.warn(sc.span, format!(
                "lumo tints the specular lobe with the base colour {}: the highlight colour {} is not kept",
                fmt3(base_color),
                fmt3(sc.value)
            ));
        }
    }
    if !phong {
        if let Some(sc) = m.specular_color.filter(|c| !is_zero(c.value)) {
            ctx.warn(sc.span, "specularColor is ignored: the lobe weights come from `type`/`reflective`, and lumo tints the specular lobe with the base colour");
        }
    }
    Ok(Lobes { d, s, t, phong })
}

/// Checks `shininess`, applies `glossy` (which may move diffuse weight to the specular lobe) and
/// returns the final weights with the specular lobe's roughness.
fn specular_roughness(
    m: &MaterialDef,
    lobes: Lobes,
    ctx: &mut Context<'_>,
) -> Result<(Lobes, f32), Problem> {
    let Lobes {
        mut d,
        mut s,
        t,
        phong,
    } = lobes;
    let mut roughness = 0.0f32;
    if let Some(sh) = &m.shininess {
        if sh.value.is_nan() || sh.value < 0.0 {
            return Err(Problem::at(
                sh.span,
                format!("shininess {} must be ≥ 0", sh.value),
            ));
        }
    }
    if let Some(g) = &m.glossy {
        if g.value != 0.0 {
            if s == 0.0 && d > 0.0 {
                // one-step-beh1nd: the diffuse branch of a glossy material becomes diffuse plus a
                // GGX highlight with α = 0.1. Approximated by giving half the diffuse weight to a
                // specular lobe with that width (lumo's α = roughness²).
                s = d / 2.0;
                d -= s;
                roughness = GLOSSY_ALPHA.sqrt();
                ctx.warn(g.span, format!("`glossy` is approximated: half of the diffuse weight becomes a GGX lobe with roughness {roughness} (their α = {GLOSSY_ALPHA})"));
            } else {
                ctx.warn(g.span, "`glossy` has no effect here: it only changes the diffuse lobe of a material that has one and no specular weight");
            }
        }
    }
    if s > 0.0 {
        if let Some(sh) = &m.shininess {
            roughness = math::shininess_to_roughness(sh.value);
        } else if phong {
            // The Phong default shininess 0 is a constant lobe: as rough as it gets.
            roughness = math::shininess_to_roughness(0.0);
        }
    }
    Ok((Lobes { d, s, t, phong }, roughness))
}

/// The index of refraction, when the material gives one or refracts (`t` > 0). The dialects
/// default to 1 (no bending) when `refr` is missing.
fn ior(m: &MaterialDef, t: f32, ctx: &mut Context<'_>) -> Result<Option<f32>, Problem> {
    let ior = m.refr.or(m.transmissive.map(|t| t.1));
    if let Some(ior) = ior {
        if ior.value.is_nan() || ior.value <= 0.0 {
            return Err(Problem::at(
                ior.span,
                format!("index of refraction {} must be > 0", ior.value),
            )
            .help("glass is about 1.5, water 1.33"));
        }
        Ok(Some(ior.value))
    } else if t > 0.0 {
        ctx.warn(m.span, "refracting material without `refr`: using the dialects' default index 1, which does not bend light (glass is `refr 1.5`)");
        Ok(Some(1.0))
    } else {
        Ok(None)
    }
}

/// The base colour texture reference for the image file `tex`; the texture is added to
/// `textures` unless one with the same file is there already.
fn texture(
    tex: &Located<String>,
    ctx: &mut Context<'_>,
    textures: &mut BTreeMap<String, Texture>,
) -> Result<TextureRef, Problem> {
    let (_, file) = ctx_file(ctx, tex, "texture image")?;
    let name = match textures.iter().find(|(_, t)| t.file == file) {
        Some((name, _)) => name.clone(),
        None => {
            let name = format!("texture{}", textures.len());
            textures.insert(
                name.clone(),
                Texture {
                    file,
                    gltf_image: None,
                    color_space: schema::ColorSpace::Srgb,
                    wrap_s: schema::Wrap::Repeat,
                    wrap_t: schema::Wrap::Repeat,
                },
            );
            name
        }
    };
    Ok(TextureRef {
        texture: name,
        offset: [0.0; 2],
        rotation_deg: 0.0,
        scale: [1.0; 2],
        tex_coord: 0,
    })
}
