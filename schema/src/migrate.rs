//! Reading files of older format versions: each is rewritten, as JSON, into the current
//! version before the typed parse, with a note per change a user should know about.
//!
//! Version 1 → 2: materials were a stochastic mix of lobes chosen by weight (`diffuse`,
//! `specular` = a metal lobe, `transmission` = smooth glass, `roughness` of the metal only,
//! `roughness_specular_texture`); version 2 is glTF's metallic-roughness model
//! ([`Material`](crate::Material)). The mapping keeps the look:
//!
//! | version 1 | version 2 |
//! |---|---|
//! | `specular` s (metal weight) | `metallic` s |
//! | `transmission` t | `transmission` t / (1 − s), with `volume: {}` (glass refracts) |
//! | diffuse (the rest) | `specular: 0` (version 1's diffuse had no specular coat) |
//! | explicit `diffuse` d below the rest | `base_color` × d when the material is only diffuse |
//! | `roughness` (default 0) | `roughness` (written out: version 2's default is 0.5) |
//! | `roughness_specular_texture` | `metallic_roughness_texture` (same channels) |
//! | texture `wrap` | `wrap_s` and `wrap_t` |
//!
//! What version 2 cannot say (version 1's glass was always smooth, its diffuse weight could
//! absorb beside a metal or glass lobe) is approximated, and the note says how.

use serde_json::{Map, Value};

use crate::scene::FORMAT_VERSION;

/// The `format_version` of a JSON document, when it is a number.
pub fn version_of(value: &Value) -> Option<u64> {
    value.get("format_version")?.as_u64()
}

/// Rewrites a document of an older format version into the current one, in place, and
/// returns the notes for the user (empty when the document was current or of an unknown
/// version, which validation then reports).
pub fn migrate(value: &mut Value) -> Vec<String> {
    if version_of(value) != Some(1) {
        return Vec::new();
    }
    let mut notes = vec![format!(
        "format_version 1 read and migrated to {FORMAT_VERSION} (materials are now glTF's \
         metallic-roughness model); upgrade the file with `lumo convert FILE -o NEW.json`"
    )];
    if let Some(Value::Object(textures)) = value.get_mut("textures") {
        for t in textures.values_mut() {
            if let Value::Object(t) = t {
                // Version 1's one wrap mode applied along both axes.
                if let Some(w) = t.remove("wrap") {
                    t.insert("wrap_s".into(), w.clone());
                    t.insert("wrap_t".into(), w);
                }
            }
        }
    }
    if let Some(Value::Object(materials)) = value.get_mut("materials") {
        for (name, m) in materials.iter_mut() {
            if let Value::Object(m) = m {
                material_v1(name, m, &mut notes);
            }
        }
    }
    value["format_version"] = Value::from(FORMAT_VERSION);
    notes
}

fn number(m: &Map<String, Value>, key: &str) -> Option<f64> {
    m.get(key).and_then(Value::as_f64)
}

/// Version 1 → 2 for one material object; a value of the wrong type is left in place for
/// the typed parse to report.
fn material_v1(name: &str, m: &mut Map<String, Value>, notes: &mut Vec<String>) {
    let s = number(m, "specular").unwrap_or(0.0);
    let t = number(m, "transmission").unwrap_or(0.0);
    let r = number(m, "roughness").unwrap_or(0.0);
    let rest = (1.0 - s - t).max(0.0);
    let d = match m.remove("diffuse") {
        Some(Value::Null) | None => rest,
        Some(v) => match v.as_f64() {
            Some(d) => d,
            None => {
                m.insert("diffuse".into(), v);
                return;
            }
        },
    };
    m.insert("metallic".into(), Value::from(s));
    m.remove("transmission");
    if t > 0.0 {
        let t2 = if s < 1.0 {
            (t / (1.0 - s)).min(1.0)
        } else {
            0.0
        };
        m.insert("transmission".into(), Value::from(t2));
        m.insert("volume".into(), Value::Object(Map::new()));
        if r > 0.0 {
            notes.push(format!(
                "materials.{name}: version 1's glass was smooth; with roughness {r} it is now \
                 rough glass"
            ));
        }
    }
    m.insert("roughness".into(), Value::from(r));
    m.insert("specular".into(), Value::from(0.0));
    if let Some(tex) = m.remove("roughness_specular_texture") {
        m.insert("metallic_roughness_texture".into(), tex);
        if t > 0.0 {
            notes.push(format!(
                "materials.{name}: the texture's blue channel now scales `metallic`; where it \
                 is below 1 the freed weight is split between diffuse and transmission"
            ));
        }
    }
    if d < rest - 1e-6 {
        if s == 0.0 && t == 0.0 {
            let base = m
                .get("base_color")
                .cloned()
                .unwrap_or(Value::from(vec![0.8, 0.8, 0.8]));
            if let Some(c) = base.as_array().filter(|c| c.len() == 3) {
                let scaled: Vec<Value> = c
                    .iter()
                    .map(|x| x.as_f64().map_or(x.clone(), |x| Value::from(x * d)))
                    .collect();
                m.insert("base_color".into(), Value::from(scaled));
            }
        } else {
            notes.push(format!(
                "materials.{name}: a diffuse weight {d} below the rest {rest} (absorption \
                 beside metal or glass) cannot be expressed; the diffuse part now has weight \
                 {rest}"
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn migrated(m: Value) -> (Value, Vec<String>) {
        let mut doc = json!({"format_version": 1, "materials": {"m": m}});
        let notes = migrate(&mut doc);
        assert_eq!(doc["format_version"], json!(FORMAT_VERSION));
        (doc["materials"]["m"].clone(), notes)
    }

    #[test]
    fn diffuse_stays_lambertian() {
        let (m, notes) = migrated(json!({"base_color": [0.5, 0.25, 1.0]}));
        assert_eq!(
            m,
            json!({"base_color": [0.5, 0.25, 1.0], "metallic": 0.0, "roughness": 0.0, "specular": 0.0})
        );
        assert_eq!(notes.len(), 1, "{notes:?}");
    }

    #[test]
    fn metal_and_glass_weights_become_metallic_and_transmission() {
        let (m, _) = migrated(json!({"specular": 0.5, "transmission": 0.25, "ior": 1.33}));
        assert_eq!(m["metallic"], json!(0.5));
        assert_eq!(m["transmission"], json!(0.5));
        assert_eq!(m["volume"], json!({}));
        assert_eq!(m["ior"], json!(1.33));
        assert_eq!(m["specular"], json!(0.0));
    }

    #[test]
    fn absorbing_diffuse_scales_the_base_colour() {
        let (m, _) = migrated(json!({"diffuse": 0.5, "base_color": [1.0, 0.5, 0.0]}));
        assert_eq!(m["base_color"], json!([0.5, 0.25, 0.0]));
        let (m, notes) = migrated(json!({"diffuse": 0.25, "specular": 0.5}));
        assert_eq!(m["metallic"], json!(0.5));
        assert!(
            notes.iter().any(|n| n.contains("cannot be expressed")),
            "{notes:?}"
        );
    }

    #[test]
    fn current_documents_are_untouched() {
        let mut doc =
            json!({"format_version": FORMAT_VERSION, "materials": {"m": {"specular": 0.5}}});
        let before = doc.clone();
        assert!(migrate(&mut doc).is_empty());
        assert_eq!(doc, before);
    }
}
