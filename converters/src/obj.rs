//! The one Wavefront OBJ reader: geometry through `tobj` ([`load`]: all objects and groups,
//! `v/vt/vn` corners, negative indices, polygons fan-triangulated), and a line scan
//! ([`scan_file`]) that checks a referenced file before a scene is written and notices where the
//! legacy course loader would have read it differently.

use std::path::Path;

/// Largest OBJ file scanned, in bytes (1 GiB).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;

/// What a scan of an OBJ file found.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ObjSummary {
    /// Number of `v` lines.
    pub vertices: usize,
    /// Number of triangles after fan triangulation.
    pub triangles: usize,
    /// Faces with more than 3 corners (the legacy loader kept only their first triangle).
    pub polygons: usize,
    /// Faces whose corners have three fields `v/vt/vn` (the legacy loader misread these).
    pub full_corners: usize,
    /// Faces using negative (relative) indices (the legacy loader did not support them).
    pub relative_indices: usize,
    /// The last line has no newline (the legacy loader dropped it).
    pub unterminated_last_line: bool,
}

/// A problem in an OBJ file, with its 1-based line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ObjError {
    /// The file could not be read.
    #[error("cannot read: {0}")]
    Io(String),
    /// A line is malformed or an index is out of range.
    #[error("line {line}: {message}")]
    Invalid {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// The triangles of an OBJ file as plain f32 arrays, all objects and groups concatenated.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjMesh {
    /// Vertex positions (all finite).
    pub positions: Vec<[f32; 3]>,
    /// Triangles as indices into `positions`, in the file's winding.
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex normals as the file gives them (not normalised), when every object has them
    /// for every vertex.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates, when every object has them for every vertex.
    pub uvs: Option<Vec<[f32; 2]>>,
}

/// Why [`load`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ObjLoadError {
    /// `tobj` could not read or parse the file (its message).
    #[error("{0}")]
    Read(String),
    /// A vertex is NaN or infinite, or a face refers to a vertex its object does not have.
    #[error("object `{object}`: {message}")]
    Object {
        /// The OBJ object's name.
        object: String,
        /// What is wrong.
        message: String,
    },
    /// The file has no triangles.
    #[error("the file contains no faces")]
    NoFaces,
}

/// Reads the triangles of the OBJ file at `path` through `tobj` (polygons fan-triangulated,
/// one index per corner: a vertex is duplicated where its corners carry different normals or
/// texture coordinates).
pub fn load(path: &Path) -> Result<ObjMesh, ObjLoadError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) =
        tobj::load_obj(path, &options).map_err(|e| ObjLoadError::Read(e.to_string()))?;
    let mut out = ObjMesh::default();
    let (mut normals, mut uvs) = (Some(Vec::new()), Some(Vec::new()));
    for model in &models {
        let m = &model.mesh;
        let bad = |message: String| ObjLoadError::Object {
            object: model.name.clone(),
            message,
        };
        let base = out.positions.len() as u32;
        let n = m.positions.len() / 3;
        for (i, p) in m.positions.chunks_exact(3).enumerate() {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(bad(format!(
                    "vertex {} is not finite ([{}, {}, {}])",
                    i + 1,
                    p[0],
                    p[1],
                    p[2]
                )));
            }
            out.positions.push([p[0], p[1], p[2]]);
        }
        match &mut normals {
            Some(ns) if m.normals.len() == n * 3 => {
                ns.extend(m.normals.chunks_exact(3).map(|c| [c[0], c[1], c[2]]))
            }
            _ => normals = None,
        }
        match &mut uvs {
            Some(ts) if m.texcoords.len() == n * 2 => {
                ts.extend(m.texcoords.chunks_exact(2).map(|c| [c[0], c[1]]))
            }
            _ => uvs = None,
        }
        for (f, t) in m.indices.chunks_exact(3).enumerate() {
            if let Some(&i) = t.iter().find(|&&i| i as usize >= n) {
                return Err(bad(format!(
                    "face {} refers to vertex {} but there are {n}",
                    f + 1,
                    i + 1
                )));
            }
            out.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if out.triangles.is_empty() {
        return Err(ObjLoadError::NoFaces);
    }
    out.normals = normals.filter(|v| !v.is_empty());
    out.uvs = uvs.filter(|v| !v.is_empty());
    Ok(out)
}

/// Reads and checks the OBJ file at `path`.
pub fn scan_file(path: &Path) -> Result<ObjSummary, ObjError> {
    let meta = std::fs::metadata(path).map_err(|e| ObjError::Io(e.to_string()))?;
    if !meta.is_file() {
        return Err(ObjError::Io("not a regular file".into()));
    }
    if meta.len() > MAX_OBJ_BYTES {
        return Err(ObjError::Io(format!(
            "{} bytes is above the limit of {MAX_OBJ_BYTES}",
            meta.len()
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| ObjError::Io(e.to_string()))?;
    scan(&String::from_utf8_lossy(&bytes))
}

/// Checks OBJ text: `v` lines have three numbers, `f` lines have at least three corners whose
/// vertex indices (1-based, or negative = relative to the vertices so far) exist.
pub fn scan(text: &str) -> Result<ObjSummary, ObjError> {
    let mut s = ObjSummary {
        unterminated_last_line: !text.is_empty() && !text.ends_with('\n'),
        ..ObjSummary::default()
    };
    // Faces may in principle reference vertices defined later; check those at the end.
    let mut max_forward: Option<(usize, i64)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let bad = |message: String| ObjError::Invalid {
            line: line_no,
            message,
        };
        let line = raw.trim();
        let mut fields = line.split_whitespace();
        match fields.next() {
            Some("v") => {
                let coords: Vec<&str> = fields.collect();
                if coords.len() < 3
                    || coords[..3]
                        .iter()
                        .any(|c| c.parse::<f32>().map(|v| !v.is_finite()).unwrap_or(true))
                {
                    return Err(bad(format!(
                        "a vertex needs three finite numbers, found `{line}`"
                    )));
                }
                s.vertices += 1;
            }
            Some("f") => {
                let corners: Vec<&str> = fields.collect();
                if corners.len() < 3 {
                    return Err(bad(format!(
                        "a face needs at least 3 corners, found {}",
                        corners.len()
                    )));
                }
                for c in &corners {
                    let mut parts = c.split('/');
                    let v = parts.next().unwrap_or("");
                    let idx: i64 = v
                        .parse()
                        .map_err(|_| bad(format!("`{c}` is not a vertex index")))?;
                    if parts.count() == 2 && !c.contains("//") {
                        s.full_corners += 1;
                    }
                    if idx == 0 {
                        return Err(bad("vertex index 0: OBJ indices start at 1".into()));
                    } else if idx < 0 {
                        s.relative_indices += 1;
                        if idx.unsigned_abs() as usize > s.vertices {
                            return Err(bad(format!(
                                "relative index {idx} reaches before the first vertex ({} so far)",
                                s.vertices
                            )));
                        }
                    } else if idx as usize > s.vertices && max_forward.is_none_or(|(_, m)| idx > m)
                    {
                        max_forward = Some((line_no, idx));
                    }
                }
                if corners.len() > 3 {
                    s.polygons += 1;
                }
                s.triangles += corners.len() - 2;
            }
            _ => {}
        }
    }
    if let Some((line, idx)) = max_forward {
        if idx as usize > s.vertices {
            return Err(ObjError::Invalid {
                line,
                message: format!(
                    "vertex index {idx} is out of range: the file has {} vertices",
                    s.vertices
                ),
            });
        }
    }
    if s.triangles == 0 {
        return Err(ObjError::Invalid {
            line: text.lines().count().max(1),
            message: "the file has no faces".into(),
        });
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loads_triangles_and_reports_bad_files() {
        let dir = tempfile::tempdir().unwrap();
        let quad = dir.path().join("quad.obj");
        std::fs::write(
            &quad,
            "o q\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 2\nf 1//1 2//1 3//1 4//1\n",
        )
        .unwrap();
        let m = load(&quad).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.normals.as_ref().unwrap()[0], [0.0, 0.0, 2.0]);
        assert_eq!(m.uvs, None);
        let empty = dir.path().join("empty.obj");
        std::fs::write(&empty, "v 0 0 0\n").unwrap();
        assert_eq!(load(&empty), Err(ObjLoadError::NoFaces));
        assert!(matches!(
            load(&dir.path().join("missing.obj")),
            Err(ObjLoadError::Read(_))
        ));
    }

    #[test]
    fn counts_and_checks_faces() {
        let s =
            scan("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1/1/1 2/2/2 -1/3/3\n").unwrap();
        assert_eq!(
            (
                s.vertices,
                s.triangles,
                s.polygons,
                s.full_corners,
                s.relative_indices
            ),
            (4, 3, 1, 3, 1)
        );
        assert!(!s.unterminated_last_line);
        let e = scan("v 0 0 0\nv 1 0 0\nf 1 2 5").unwrap_err();
        assert_eq!(
            e,
            ObjError::Invalid {
                line: 3,
                message: "vertex index 5 is out of range: the file has 2 vertices".into()
            }
        );
        assert!(matches!(
            scan("v 0 0\n"),
            Err(ObjError::Invalid { line: 1, .. })
        ));
        assert!(matches!(
            scan("v 0 0 0\nf 1 1\n"),
            Err(ObjError::Invalid { line: 2, .. })
        ));
        assert!(
            scan("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3")
                .unwrap()
                .unterminated_last_line
        );
    }
}
