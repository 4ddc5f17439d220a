//! Triangle meshes of lumo's exact shapes, for export (glTF carries only triangles): the
//! shared tessellation of [`lumo_schema::geometry::tessellate`] at the exporter's resolution,
//! rounded to f32.

use lumo_schema::geometry::tessellate::{self as shared, TriMesh};
use lumo_schema::Profile;

use super::mesh::MeshData;

/// Sphere tessellation used by the exporter: divisions around the y axis and pole to pole.
pub const SPHERE_SEGMENTS: u32 = 64;
/// See [`SPHERE_SEGMENTS`].
pub const SPHERE_RINGS: u32 = 32;
/// Lathe tessellation: divisions around the axis.
pub const LATHE_SEGMENTS: u32 = 64;
/// Lathe tessellation: samples along the profile (uniform in the curve parameter).
pub const LATHE_RINGS: u32 = 64;

/// A UV sphere ([`lumo_schema::geometry::tessellate::sphere`]) as export data.
pub fn sphere(center: [f32; 3], radius: f32, segments: u32, rings: u32) -> MeshData {
    export_data(shared::sphere(center, radius, segments, rings))
}

/// A square on a plane ([`lumo_schema::geometry::tessellate::plane`]) as export data.
pub fn plane(normal: [f32; 3], offset: f32, half_size: f32) -> MeshData {
    export_data(shared::plane(normal, offset, half_size))
}

/// A lathe ([`lumo_schema::geometry::tessellate::lathe`]) as export data.
pub fn lathe(profile: &Profile, segments: u32, rings: u32) -> MeshData {
    export_data(shared::lathe(profile, segments, rings))
}

/// Rounds a mesh to f32 and drops the triangles with two identical corners after rounding (at
/// poles), which glTF validators reject.
fn export_data(m: TriMesh) -> MeshData {
    let positions: Vec<[f32; 3]> = m
        .positions
        .iter()
        .map(|p| p.to_array().map(|x| x as f32))
        .collect();
    let indices = m
        .indices
        .into_iter()
        .filter(|t| {
            let [a, b, c] = t.map(|k| positions[k as usize]);
            a != b && b != c && a != c
        })
        .collect();
    MeshData {
        normals: Some(
            m.normals
                .iter()
                .map(|n| n.to_array().map(|x| x as f32))
                .collect(),
        ),
        uvs: Some(
            m.uvs
                .iter()
                .map(|t| t.to_array().map(|x| x as f32))
                .collect(),
        ),
        tangents: None,
        texcoords_1: None,
        colors: None,
        positions,
        indices,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gltf::math::cross;
    use lumo_schema::BezierProfile;

    #[test]
    fn lathe_of_an_upward_line_faces_away_from_the_axis() {
        let prof = Profile::Bezier(BezierProfile {
            points: vec![[1.0, 0.0], [1.0, 1.0]],
        });
        let m = lathe(&prof, 8, 2);
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            let radial = p[0] * n[0] + p[2] * n[2];
            assert!(radial > 0.99, "p {p:?} n {n:?}");
        }
        // Every triangle's winding agrees with its vertices' normals.
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize].map(f64::from));
            let f = cross(
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let n = m.normals.as_ref().unwrap()[t[0] as usize].map(f64::from);
            assert!(f[0] * n[0] + f[1] * n[1] + f[2] * n[2] > 0.0);
        }
    }

    #[test]
    fn sphere_winding_faces_outwards_and_uvs_follow_the_schema() {
        let m = sphere([0.0; 3], 2.0, 16, 8);
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize].map(f64::from));
            let f = cross(
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let centroid = [
                (a[0] + b[0] + c[0]) / 3.0,
                (a[1] + b[1] + c[1]) / 3.0,
                (a[2] + b[2] + c[2]) / 3.0,
            ];
            assert!(f[0] * centroid[0] + f[1] * centroid[1] + f[2] * centroid[2] > 0.0);
        }
        // v = 1 at the north pole (+y), u = 0.25 at azimuth 90° from +x towards −z.
        let uvs = m.uvs.as_ref().unwrap();
        let top = m.positions.iter().position(|p| p[1] == 2.0).unwrap();
        assert_eq!(uvs[top][1], 1.0);
        let (i, j) = (4u32, 4u32);
        let k = (i * 17 + j) as usize;
        assert!(
            m.positions[k][2] < -1.9 && uvs[k][0] == 0.25,
            "{:?} {:?}",
            m.positions[k],
            uvs[k]
        );
    }

    #[test]
    fn plane_quad_faces_its_normal() {
        let m = plane([0.0, 0.0, 2.0], 3.0, 10.0);
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize].map(f64::from));
            let f = cross(
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            assert!(f[2] > 0.0);
            assert!(a[2] == 3.0 && b[2] == 3.0 && c[2] == 3.0);
        }
    }
}
