//! Triangle meshes in object space, each with its own BVH, shared between instances.

use crate::bvh::Bvh;
use crate::geometry::triangle::{self, RayShear};
use crate::math::{Aabb, Vec2, Vec3};

/// An indexed triangle mesh with optional per-vertex normals and texture coordinates.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles (counter-clockwise front), indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Unit vertex normals for smooth shading, when present.
    pub normals: Option<Vec<Vec3>>,
    /// Vertex texture coordinates, when present.
    pub uvs: Option<Vec<Vec2>>,
    bvh: Bvh,
}

/// Where a ray meets a mesh.
#[derive(Debug, Clone, Copy)]
pub struct MeshHit {
    /// Ray parameter.
    pub t: f32,
    /// Triangle index.
    pub prim: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub b1: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub b2: f32,
}

impl Mesh {
    /// Builds a mesh and its BVH. Degenerate (zero-area) triangles are removed; the number
    /// removed is returned alongside so the loader can warn once.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, normals: Option<Vec<Vec3>>, uvs: Option<Vec<Vec2>>) -> (Mesh, usize) {
        let before = triangles.len();
        let triangles: Vec<[u32; 3]> = triangles
            .into_iter()
            .filter(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                (b - a).cross(c - a).length_squared() > 0.0
            })
            .collect();
        let dropped = before - triangles.len();
        let boxes: Vec<Aabb> = triangles.iter().map(|t| Aabb::from_points(t.map(|i| positions[i as usize]))).collect();
        let bvh = Bvh::build(&boxes);
        (Mesh { positions, triangles, normals, uvs, bvh }, dropped)
    }

    /// Bounds in object space.
    pub fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    /// The three corners of triangle `prim`.
    #[inline]
    pub fn corners(&self, prim: u32) -> [Vec3; 3] {
        self.triangles[prim as usize].map(|i| self.positions[i as usize])
    }

    /// Closest hit within (t_min, t_max).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<MeshHit> {
        let shear = RayShear::new(o, d);
        let mut best = None;
        let mut t_max = t_max;
        self.bvh.traverse(o, d, t_min, &mut t_max, |p, t_max| {
            let [a, b, c] = self.corners(p);
            if let Some(h) = triangle::intersect(&shear, a, b, c, t_min, *t_max) {
                *t_max = h.t;
                best = Some(MeshHit { t: h.t, prim: p, b1: h.b1, b2: h.b2 });
            }
            false
        });
        best
    }

    /// Whether anything is hit within (t_min, t_max).
    pub fn occluded(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        let shear = RayShear::new(o, d);
        let mut t_max = t_max;
        self.bvh.traverse(o, d, t_min, &mut t_max, |p, t_max| {
            let [a, b, c] = self.corners(p);
            triangle::intersect(&shear, a, b, c, t_min, *t_max).is_some()
        })
    }

    /// Interpolated point, geometric normal, shading normal and texture coordinates of a hit.
    pub fn surface(&self, h: &MeshHit) -> (Vec3, Vec3, Vec3, Vec2) {
        let tri = self.triangles[h.prim as usize];
        let [a, b, c] = tri.map(|i| self.positions[i as usize]);
        let b0 = 1.0 - h.b1 - h.b2;
        let p = a * b0 + b * h.b1 + c * h.b2;
        let ng = (b - a).cross(c - a).normalize();
        let ns = match &self.normals {
            Some(n) => {
                let s = n[tri[0] as usize] * b0 + n[tri[1] as usize] * h.b1 + n[tri[2] as usize] * h.b2;
                let s = s.normalize_or_zero();
                if s == Vec3::ZERO { ng } else { s }
            }
            None => ng,
        };
        let uv = match &self.uvs {
            Some(t) => t[tri[0] as usize] * b0 + t[tri[1] as usize] * h.b1 + t[tri[2] as usize] * h.b2,
            None => Vec2::new(h.b1, h.b2),
        };
        (p, ng, ns, uv)
    }

    /// Angle-weighted vertex normals (Thürmer and Wüthrich 1998): each face contributes its
    /// normal weighted by its corner angle at the vertex, so the result does not depend on how
    /// a surface is split into triangles.
    pub fn angle_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
        let mut acc = vec![Vec3::ZERO; positions.len()];
        for t in triangles {
            let p = t.map(|i| positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            for k in 0..3 {
                let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                acc[t[k] as usize] += n * angle;
            }
        }
        acc.into_iter().map(|n| n.normalize_or_zero()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(state: &mut u64) -> f32 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*state >> 40) as f32) / (1u64 << 24) as f32
    }

    /// The BVH-accelerated mesh must agree with testing every triangle (the oracle).
    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut s = 3u64;
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for i in 0..3000u32 {
            let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0;
            for _ in 0..3 {
                positions.push(c + Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.2);
            }
            tris.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let (mesh, _) = Mesh::new(positions, tris, None, None);
        for _ in 0..3000 {
            let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 1.0;
            let d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let shear = RayShear::new(o, d);
            let brute = (0..mesh.triangles.len() as u32)
                .filter_map(|p| {
                    let [a, b, c] = mesh.corners(p);
                    triangle::intersect(&shear, a, b, c, 0.0, f32::INFINITY).map(|h| (h.t, p))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let fast = mesh.intersect(o, d, 0.0, f32::INFINITY).map(|h| (h.t, h.prim));
            assert_eq!(fast.map(|f| f.1), brute.map(|b| b.1));
            assert_eq!(mesh.occluded(o, d, 0.0, f32::INFINITY), brute.is_some());
        }
    }
}
