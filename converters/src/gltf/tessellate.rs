//! Triangle meshes of lumo's exact shapes, for export (glTF carries only triangles).
//! Parameterisations, texture coordinates and front faces follow `lumo_schema`'s definitions.

use lumo_schema::geometry::profile::{domain, eval};
use lumo_schema::Profile;

use super::math::normalize;
use super::mesh::MeshData;

/// Sphere tessellation used by the exporter: divisions around the y axis and pole to pole.
pub const SPHERE_SEGMENTS: u32 = 64;
/// See [`SPHERE_SEGMENTS`].
pub const SPHERE_RINGS: u32 = 32;
/// Lathe tessellation: divisions around the axis.
pub const LATHE_SEGMENTS: u32 = 64;
/// Lathe tessellation: samples along the profile (uniform in the curve parameter).
pub const LATHE_RINGS: u32 = 64;

/// A UV sphere. Vertex (ring i, segment j): polar angle α = π i / rings from −y, azimuth
/// φ = 2π j / segments from +x towards −z; u = φ / 2π, v = α / π. The seam column is duplicated
/// so texture coordinates do not wrap.
pub fn sphere(center: [f32; 3], radius: f32, segments: u32, rings: u32) -> MeshData {
    let (c, r) = (center.map(f64::from), f64::from(radius));
    let mut m = empty();
    for i in 0..=rings {
        let alpha = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        let (sa, ca) = alpha.sin_cos();
        for j in 0..=segments {
            let phi = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
            let (sp, cp) = phi.sin_cos();
            let d = [sa * cp, -ca, -sa * sp];
            m.positions.push([
                (c[0] + r * d[0]) as f32,
                (c[1] + r * d[1]) as f32,
                (c[2] + r * d[2]) as f32,
            ]);
            push_normal(&mut m, d);
            push_uv(
                &mut m,
                f64::from(j) / f64::from(segments),
                f64::from(i) / f64::from(rings),
            );
        }
    }
    grid_triangles(&mut m, rings, segments, |i, j| i * (segments + 1) + j);
    m
}

/// A square of side 2·`half_size` on the plane dot(n, p) = offset, centred on the point of the
/// plane nearest the origin. Tangent frame (t, b, n̂) from Duff et al., "Building an
/// Orthonormal Basis, Revisited", JCGT 6(1), 2017; texture coordinates are the coordinates
/// along t and b in scene units.
pub fn plane(normal: [f32; 3], offset: f32, half_size: f32) -> MeshData {
    let n = normalize(normal.map(f64::from)).unwrap_or([0.0, 1.0, 0.0]);
    let (t, b) = onb(n);
    let o = [
        n[0] * f64::from(offset),
        n[1] * f64::from(offset),
        n[2] * f64::from(offset),
    ];
    let h = f64::from(half_size);
    let mut m = empty();
    for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let p = [0, 1, 2].map(|k| o[k] + su * h * t[k] + sv * h * b[k]);
        m.positions.push(p.map(|x| x as f32));
        push_normal(&mut m, n);
        push_uv(&mut m, su * h, sv * h);
    }
    // t × b = n, so (−t−b) → (t−b) → (t+b) is counter-clockwise seen from the normal's side.
    m.indices = vec![[0, 1, 2], [0, 2, 3]];
    m
}

/// The orthonormal tangents (t, b) with t × b = n of a unit normal (Duff et al. 2017).
pub fn onb(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let bb = n[0] * n[1] * a;
    let t = [1.0 + sign * n[0] * n[0] * a, sign * bb, -sign * n[0]];
    let b = [bb, sign + n[1] * n[1] * a, -n[1]];
    (t, b)
}

/// A lathe: the profile sampled at `rings` + 1 uniform parameter values and revolved in
/// `segments` steps: S(t, θ) = (x cos θ, y, −x sin θ). Vertices are in three.js LatheGeometry
/// order (for each angle, every profile sample); u = θ / 2π, v = the normalised parameter.
/// Normals are n = ∂S/∂θ × ∂S/∂t normalised (the schema's front side); where x = 0 (a pole)
/// the normal is taken slightly inside the parameter range.
pub fn lathe(profile: &Profile, segments: u32, rings: u32) -> MeshData {
    let (t0, t1) = domain(profile);
    let mut samples = Vec::new();
    for i in 0..=rings {
        let s = f64::from(i) / f64::from(rings);
        let t = t0 + (t1 - t0) * s;
        let (p, d) = eval(profile, t);
        // At a pole (x = 0) ∂S/∂θ vanishes: use the limit from a nearby parameter inside the
        // range, whose normal points along the axis.
        let (pn, dn) = if p[0] == 0.0 {
            let eps = (t1 - t0) * 1e-4;
            let tn = if i == rings { t - eps } else { t + eps };
            eval(profile, tn)
        } else {
            (p, d)
        };
        samples.push((p, pn, dn, s));
    }
    let mut m = empty();
    let rows = rings + 1;
    for j in 0..=segments {
        let theta = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
        let (st, ct) = theta.sin_cos();
        for &(p, pn, dn, s) in &samples {
            m.positions
                .push([(p[0] * ct) as f32, p[1] as f32, (-p[0] * st) as f32]);
            // n = x · (y′ cos θ, −x′, −y′ sin θ), using the pole-safe sample for its direction.
            let n = [pn[0] * dn[1] * ct, -pn[0] * dn[0], -pn[0] * dn[1] * st];
            let n = normalize(n).unwrap_or([0.0, 1.0, 0.0]);
            push_normal(&mut m, n);
            push_uv(&mut m, f64::from(j) / f64::from(segments), s);
        }
    }
    // Vertex (ring i, segment j) is at j·rows + i. Quad corners p00 = (i, j), p10 = (i, j+1)
    // (along θ), p01 = (i+1, j) (along t): (p10 − p00) × (p01 − p00) ≈ ∂S/∂θ × ∂S/∂t, the front.
    grid_triangles(&mut m, rings, segments, |i, j| j * rows + i);
    m
}

fn empty() -> MeshData {
    MeshData {
        positions: Vec::new(),
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        indices: Vec::new(),
    }
}

fn push_normal(m: &mut MeshData, n: [f64; 3]) {
    if let Some(ns) = &mut m.normals {
        ns.push(n.map(|x| x as f32));
    }
}

fn push_uv(m: &mut MeshData, u: f64, v: f64) {
    if let Some(uv) = &mut m.uvs {
        uv.push([u as f32, v as f32]);
    }
}

/// Two triangles per grid cell, (p00, p10, p01) and (p10, p11, p01) with p10 one step in the
/// second (segment) direction; triangles with two identical corners (at poles) are skipped.
fn grid_triangles(m: &mut MeshData, rings: u32, segments: u32, at: impl Fn(u32, u32) -> u32) {
    for i in 0..rings {
        for j in 0..segments {
            let (p00, p10, p01, p11) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
            for tri in [[p00, p10, p01], [p10, p11, p01]] {
                let [a, b, c] = tri.map(|k| m.positions[k as usize]);
                if a != b && b != c && a != c {
                    m.indices.push(tri);
                }
            }
        }
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
