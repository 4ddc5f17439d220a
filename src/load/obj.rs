//! Wavefront OBJ loading through `tobj`: all objects and groups, polygons fan-triangulated,
//! normals and texture coordinates from the file.

use std::path::Path;

use crate::math::{Vec2, Vec3};

/// Mesh arrays read from a file.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    /// Positions.
    pub positions: Vec<Vec3>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex normals, if the file has them for every vertex.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, if the file has them for every vertex.
    pub uvs: Option<Vec<Vec2>>,
}

/// Reads an OBJ file. Errors name the file; index and NaN problems name the object.
pub fn load_obj(path: &Path) -> Result<MeshData, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) =
        tobj::load_obj(path, &options).map_err(|e| format!("cannot read OBJ: {e}"))?;
    let mut out = MeshData::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    let (mut normals, mut uvs) = (Vec::new(), Vec::new());
    for model in &models {
        let m = &model.mesh;
        let base = out.positions.len() as u32;
        let n = m.positions.len() / 3;
        for (i, p) in m.positions.chunks_exact(3).enumerate() {
            let v = Vec3::new(p[0], p[1], p[2]);
            if !v.is_finite() {
                return Err(format!(
                    "object `{}`: vertex {} is not finite ({v})",
                    model.name,
                    i + 1
                ));
            }
            out.positions.push(v);
        }
        if m.normals.len() == m.positions.len() {
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|v| Vec3::new(v[0], v[1], v[2]).normalize_or_zero()),
            );
        } else {
            all_normals = false;
        }
        if m.texcoords.len() / 2 == n {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])));
        } else {
            all_uvs = false;
        }
        for (f, t) in m.indices.chunks_exact(3).enumerate() {
            if let Some(&bad) = t.iter().find(|&&i| i as usize >= n) {
                return Err(format!(
                    "object `{}`: face {} refers to vertex {} but there are {n}",
                    model.name,
                    f + 1,
                    bad + 1
                ));
            }
            out.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if out.triangles.is_empty() {
        return Err("the file contains no faces".into());
    }
    out.normals = (all_normals && !normals.is_empty()).then_some(normals);
    out.uvs = (all_uvs && !uvs.is_empty()).then_some(uvs);
    Ok(out)
}
