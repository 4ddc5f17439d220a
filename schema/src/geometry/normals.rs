//! Smooth vertex normals of triangle meshes.

use std::ops::{Add, Mul, Sub};

use glam::{DVec3, Vec3};

/// A 3-vector type the normal computation runs on: [`glam::Vec3`] (f32, what the renderer
/// stores) or [`glam::DVec3`] (f64). The arithmetic is glam's own for each, so the f32 result
/// is bit for bit what the same formula gives on `Vec3` directly.
pub trait NormalVector:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Self::Scalar, Output = Self>
{
    /// The scalar type.
    type Scalar: Copy;
    /// The zero vector.
    const ZERO: Self;
    /// Cross product.
    fn cross(self, other: Self) -> Self;
    /// The unit vector along `self`, or zero for a zero or non-finite vector.
    fn normalize_or_zero(self) -> Self;
    /// The angle between two unit vectors: acos of their dot product clamped to [−1, 1].
    fn angle_between_units(self, other: Self) -> Self::Scalar;
}

macro_rules! normal_vector {
    ($v:ty, $s:ty) => {
        impl NormalVector for $v {
            type Scalar = $s;
            const ZERO: Self = <$v>::ZERO;
            fn cross(self, other: Self) -> Self {
                <$v>::cross(self, other)
            }
            fn normalize_or_zero(self) -> Self {
                <$v>::normalize_or_zero(self)
            }
            fn angle_between_units(self, other: Self) -> $s {
                self.dot(other).clamp(-1.0, 1.0).acos()
            }
        }
    };
}
normal_vector!(Vec3, f32);
normal_vector!(DVec3, f64);

/// Angle-weighted vertex normals (G. Thürmer and C. A. Wüthrich, "Computing vertex normals
/// from polygonal facets", JGT 3(1), 1998): each face's unit normal weighted by its corner
/// angle at the vertex, so the result does not depend on how a surface is split into
/// triangles. Degenerate faces contribute nothing; a vertex with no non-degenerate face gets
/// the zero vector (callers pick their fallback). Every index must be below
/// `positions.len()`.
pub fn angle_weighted_normals<V: NormalVector>(positions: &[V], triangles: &[[u32; 3]]) -> Vec<V> {
    let mut acc = vec![V::ZERO; positions.len()];
    for t in triangles {
        let p = t.map(|i| positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for k in 0..3 {
            let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
            let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
            let angle = e1.angle_between_units(e2);
            acc[t[k] as usize] = acc[t[k] as usize] + n * angle;
        }
    }
    acc.into_iter().map(V::normalize_or_zero).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cube_corner_gets_the_diagonal_whatever_the_split() {
        // Three faces of a cube meeting at the origin, one of them split into two triangles:
        // angle weighting makes the split irrelevant, so the corner normal is −(1, 1, 1)/√3.
        let p = [
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(1.0, 1.0, 0.0),
        ];
        let tris = [[0, 2, 4], [0, 4, 1], [0, 1, 3], [0, 3, 2]];
        let n = angle_weighted_normals(&p, &tris);
        assert!(
            (n[0] + DVec3::ONE / 3f64.sqrt()).length() < 1e-12,
            "{}",
            n[0]
        );
        // f32 runs the same formula.
        let p32: Vec<Vec3> = p.iter().map(|v| v.as_vec3()).collect();
        let n32 = angle_weighted_normals(&p32, &tris);
        assert!((n32[0].as_dvec3() - n[0]).length() < 1e-6);
    }
}
