//! MikkTSpace tangents for mesh primitives that have a normal texture but no TANGENT attribute
//! (glTF 2.0 §3.7.2.1: "client implementations SHOULD calculate tangents using default
//! MikkTSpace algorithms with the specified vertex positions, normals, and texture
//! coordinates associated with the normal texture").
//!
//! The algorithm is `bevy_mikktspace`, a byte-identical rewrite of the reference C code that
//! Blender and other exporters run, so computed tangents equal those such a tool would write.

use bevy_mikktspace::{generate_tangents, Geometry, TangentSpace};

/// Per-vertex MikkTSpace tangents `[x, y, z, w]` of an indexed triangle mesh: xyz is unit
/// length and orthogonal to the vertex normal, w = ±1 is the bitangent's handedness as glTF
/// defines it, B = cross(N, T.xyz) · w.
///
/// `uvs` must have v pointing *up* the image: lumo's convention (v = 1 − v_glTF) or any
/// translate of it such as (u, −v_glTF). MikkTSpace's bitangent follows +v; glTF's normal
/// textures have +Y up the image, so with v up the sign MikkTSpace reports is glTF's w (fed
/// glTF's own v, which points down, every w would come out negated).
///
/// Tangents are per vertex, as glTF stores them: the mesh is not welded or split here. Where
/// MikkTSpace gives one vertex different tangents in different triangles (a seam that a tool
/// would have split), the first triangle's tangent is kept. A vertex that gets no tangent
/// (used by no triangle, or only by degenerate ones with no neighbour to borrow from) gets an
/// arbitrary unit tangent orthogonal to its normal, with w = 1.
///
/// `normals` and `uvs` have one entry per position and every index is in range (as
/// [`super::GltfFile::mesh_primitive`] guarantees); entries beyond that are ignored.
pub fn mikktspace(
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    uvs: &[[f32; 2]],
    indices: &[[u32; 3]],
) -> Vec<[f32; 4]> {
    let n = positions.len().min(normals.len()).min(uvs.len());
    // Only triangles whose corners all exist; the rest are skipped (never an out-of-range read).
    let triangles: Vec<[u32; 3]> = indices
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&k| (k as usize) < n))
        .collect();
    let mut mesh = Mesh {
        positions,
        normals,
        uvs,
        triangles: &triangles,
        out: vec![None; n],
    };
    // The error type has no variants (the crate reserves it); nothing to handle.
    let _ = generate_tangents(&mut mesh);
    mesh.out
        .iter()
        .zip(normals)
        .map(|(t, normal)| match t {
            Some(t) if is_unit_and_finite(t) => *t,
            _ => any_tangent(*normal),
        })
        .collect()
}

/// The geometry as `bevy_mikktspace` reads it, and where it writes the tangents.
struct Mesh<'a> {
    positions: &'a [[f32; 3]],
    normals: &'a [[f32; 3]],
    uvs: &'a [[f32; 2]],
    triangles: &'a [[u32; 3]],
    out: Vec<Option<[f32; 4]>>,
}

impl Mesh<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.triangles[face][vert] as usize
    }
}

impl Geometry for Mesh<'_> {
    fn num_faces(&self) -> usize {
        self.triangles.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.vertex(face, vert)]
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.vertex(face, vert)]
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.vertex(face, vert)]
    }

    fn set_tangent(&mut self, tangent_space: Option<TangentSpace>, face: usize, vert: usize) {
        let v = self.vertex(face, vert);
        if let (Some(ts), None) = (tangent_space, self.out[v]) {
            self.out[v] = Some(ts.tangent_encoded());
        }
    }
}

fn is_unit_and_finite(t: &[f32; 4]) -> bool {
    let l2 = t[0] * t[0] + t[1] * t[1] + t[2] * t[2];
    t.iter().all(|x| x.is_finite()) && (l2 - 1.0).abs() < 1e-3
}

/// A unit vector orthogonal to `n` (unit length), with w = 1: the tangent of a vertex that
/// MikkTSpace could not give one.
fn any_tangent(n: [f32; 3]) -> [f32; 4] {
    // Cross with the axis least aligned with n.
    let a = if n[0].abs() <= n[1].abs() && n[0].abs() <= n[2].abs() {
        [1.0, 0.0, 0.0]
    } else if n[1].abs() <= n[2].abs() {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let t = [
        a[1] * n[2] - a[2] * n[1],
        a[2] * n[0] - a[0] * n[2],
        a[0] * n[1] - a[1] * n[0],
    ];
    let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    if l.is_finite() && l > 0.0 {
        [t[0] / l, t[1] / l, t[2] / l, 1.0]
    } else {
        [1.0, 0.0, 0.0, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit quad in the xy plane facing +z, u along +x and v (up) along +y: T = +x, w = +1;
    /// its mirror image in u (u along −x) gives T = −x, w = −1.
    #[test]
    fn quad_and_its_mirror() {
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let normals = [[0.0, 0.0, 1.0]; 4];
        let indices = [[0, 1, 2], [0, 2, 3]];
        let uvs = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        for t in mikktspace(&positions, &normals, &uvs, &indices) {
            assert!((t[0] - 1.0).abs() < 1e-6 && t[3] == 1.0, "{t:?}");
        }
        let mirrored = uvs.map(|[u, v]| [1.0 - u, v]);
        for t in mikktspace(&positions, &normals, &mirrored, &indices) {
            assert!((t[0] + 1.0).abs() < 1e-6 && t[3] == -1.0, "{t:?}");
        }
    }

    #[test]
    fn unused_and_degenerate_vertices_get_an_orthogonal_unit_tangent() {
        let positions = [[0.0; 3]; 4];
        let normals = [[0.0, 1.0, 0.0]; 4];
        let uvs = [[0.0; 2]; 4];
        for t in mikktspace(&positions, &normals, &uvs, &[[0, 1, 2], [0, 1, 9]]) {
            assert!(
                t[1].abs() < 1e-6 && is_unit_and_finite(&t) && t[3] == 1.0,
                "{t:?}"
            );
        }
    }
}
