//! Triangle meshes of the exact shapes (sphere, plane, lathe), in f64: for exporters (glTF
//! carries only triangles), previews and the renderer's exact-vs-mesh checks.
//! Parameterisations, texture coordinates and front faces follow the scene types' definitions.
//!
//! Sphere and lathe meshes are full grids: two triangles per cell, including the cells at a
//! pole, whose triangles have two coincident corners (zero area). Callers that cannot take
//! degenerate triangles drop them.

use glam::{DVec2, DVec3};

use super::profile::{domain, eval};
use crate::Profile;

/// An indexed triangle mesh with per-vertex unit normals and texture coordinates.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Unit vertex normals (the shape's front side).
    pub normals: Vec<DVec3>,
    /// Vertex texture coordinates.
    pub uvs: Vec<DVec2>,
    /// Triangles as vertex indices, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
}

impl TriMesh {
    /// The mesh as a scene's inline mesh, rounded to f32, with its normals and texture
    /// coordinates (a smooth mesh object of it shades like the exact shape).
    pub fn to_inline(&self) -> crate::InlineMesh {
        let f = |v: DVec3| v.to_array().map(|x| x as f32);
        crate::InlineMesh {
            positions: self.positions.iter().map(|p| f(*p)).collect(),
            indices: self.indices.clone(),
            normals: Some(self.normals.iter().map(|n| f(*n)).collect()),
            uvs: Some(
                self.uvs
                    .iter()
                    .map(|uv| uv.to_array().map(|x| x as f32))
                    .collect(),
            ),
        }
    }
}

/// A UV sphere with `segments` divisions around the y axis and `rings` pole to pole.
/// Vertex (ring i, segment j) has index i·(segments + 1) + j, polar angle α = π i / rings from
/// −y and azimuth φ = 2π j / segments from +x towards −z; u = φ / 2π, v = α / π. The seam
/// column is duplicated so texture coordinates do not wrap.
pub fn sphere(center: [f32; 3], radius: f32, segments: u32, rings: u32) -> TriMesh {
    let (c, r) = (DVec3::from(center.map(f64::from)), f64::from(radius));
    let mut m = TriMesh::default();
    for i in 0..=rings {
        let alpha = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        let (sa, ca) = alpha.sin_cos();
        for j in 0..=segments {
            let phi = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
            let (sp, cp) = phi.sin_cos();
            let d = DVec3::new(sa * cp, -ca, -sa * sp);
            m.positions.push(c + r * d);
            m.normals.push(d);
            m.uvs.push(DVec2::new(
                f64::from(j) / f64::from(segments),
                f64::from(i) / f64::from(rings),
            ));
        }
    }
    grid_triangles(&mut m, rings, segments, |i, j| i * (segments + 1) + j);
    m
}

/// A square of side 2·`half_size` on the plane dot(n, p) = offset, centred on the point of the
/// plane nearest the origin, as two triangles. Tangent frame from [`onb`]; texture coordinates
/// are the coordinates along its t and b in scene units. A zero normal is taken as +y.
pub fn plane(normal: [f32; 3], offset: f32, half_size: f32) -> TriMesh {
    let n = unit(DVec3::from(normal.map(f64::from))).unwrap_or(DVec3::Y);
    let (t, b) = onb(n);
    let o = n * f64::from(offset);
    let h = f64::from(half_size);
    let mut m = TriMesh::default();
    for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        m.positions.push(o + su * h * t + sv * h * b);
        m.normals.push(n);
        m.uvs.push(DVec2::new(su * h, sv * h));
    }
    // t × b = n, so (−t−b) → (t−b) → (t+b) is counter-clockwise seen from the normal's side.
    m.indices = vec![[0, 1, 2], [0, 2, 3]];
    m
}

/// The orthonormal tangents (t, b) with t × b = n of a unit normal n (Duff et al., "Building
/// an Orthonormal Basis, Revisited", JCGT 6(1), 2017).
pub fn onb(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let bb = n.x * n.y * a;
    let t = DVec3::new(1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    let b = DVec3::new(bb, sign + n.y * n.y * a, -n.y);
    (t, b)
}

/// A lathe: the profile sampled at `rings` + 1 uniform parameter values over its traced
/// domain and revolved in `segments` steps: S(t, θ) = (x cos θ, y, −x sin θ). Vertices are in
/// three.js `LatheGeometry` order: vertex (sample i, angle step j) has index j·(rings + 1) + i;
/// u = θ / 2π = j / segments, v = the normalised parameter i / rings. Normals are
/// n = ∂S/∂θ × ∂S/∂t normalised (the schema's front side); where x = 0 (a pole) the normal is
/// taken 10⁻⁴ of the domain inside the parameter range. Triangles (p₀₀, p₁₀, p₀₁) and
/// (p₁₀, p₁₁, p₀₁), with p₁₀ one step along θ and p₀₁ one along t, face along ∂S/∂θ × ∂S/∂t.
pub fn lathe(profile: &Profile, segments: u32, rings: u32) -> TriMesh {
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
    let mut m = TriMesh::default();
    let rows = rings + 1;
    for j in 0..=segments {
        let theta = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
        let (st, ct) = theta.sin_cos();
        for &(p, pn, dn, s) in &samples {
            m.positions.push(DVec3::new(p[0] * ct, p[1], -p[0] * st));
            // n = x · (y′ cos θ, −x′, −y′ sin θ), using the pole-safe sample for its direction.
            let n = DVec3::new(pn[0] * dn[1] * ct, -pn[0] * dn[0], -pn[0] * dn[1] * st);
            m.normals.push(unit(n).unwrap_or(DVec3::Y));
            m.uvs
                .push(DVec2::new(f64::from(j) / f64::from(segments), s));
        }
    }
    grid_triangles(&mut m, rings, segments, |i, j| j * rows + i);
    m
}

/// The unit vector along `a` (divided by its length), or `None` for a zero or non-finite one.
fn unit(a: DVec3) -> Option<DVec3> {
    let l = a.dot(a).sqrt();
    (l > 0.0 && l.is_finite()).then(|| a / l)
}

/// Two triangles per grid cell, (p00, p10, p01) and (p10, p11, p01) with p10 one step in the
/// second (segment) direction.
fn grid_triangles(m: &mut TriMesh, rings: u32, segments: u32, at: impl Fn(u32, u32) -> u32) {
    for i in 0..rings {
        for j in 0..segments {
            let (p00, p10, p01, p11) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
            m.indices.push([p00, p10, p01]);
            m.indices.push([p10, p11, p01]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BsplineProfile;

    #[test]
    fn lathe_grid_lies_on_the_profile_and_faces_its_normals() {
        let prof = Profile::Bspline(BsplineProfile {
            degree: 3,
            points: vec![[0.0, 0.0], [1.0, 0.0], [1.5, 1.0], [0.5, 2.0], [0.0, 2.0]],
            knots: None,
        });
        let m = lathe(&prof, 12, 20);
        assert_eq!(m.positions.len(), 13 * 21);
        assert_eq!(m.indices.len(), 2 * 12 * 20);
        for (k, p) in m.positions.iter().enumerate() {
            let (c, _) = eval(&prof, m.uvs[k].y);
            let r = (p.x * p.x + p.z * p.z).sqrt();
            assert!((r - c[0].abs()).abs() < 1e-12 && (p.y - c[1]).abs() < 1e-12);
            assert!((m.normals[k].length() - 1.0).abs() < 1e-12);
        }
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let f = (b - a).cross(c - a);
            if f.length() > 1e-12 {
                let n: DVec3 = t.iter().map(|&i| m.normals[i as usize]).sum();
                assert!(f.dot(n) > 0.0, "{t:?}");
            }
        }
    }
}
