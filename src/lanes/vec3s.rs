//! W lanes of 3D vectors, as three [`F32s`] (structure of arrays): the vector arithmetic of the
//! path tracer's stages that run over a wave's lanes.
//!
//! Every operation is written as `glam::Vec3`'s is, operand for operand (a dot product is
//! `(x·x′ + y·y′) + z·z′`, a quotient by a scalar divides each component), so a lane computes
//! the bits the scalar code computes for the same inputs, and a stage moved into lanes leaves
//! images unchanged.

use std::ops::{Add, Div, Mul, Neg, Sub};

use super::{F32s, Mask};
use glam::Vec3;

/// W lanes of a 3D vector.
#[derive(Clone, Copy, Debug, Default)]
pub struct V3s<const W: usize> {
    /// The x components.
    pub x: F32s<W>,
    /// The y components.
    pub y: F32s<W>,
    /// The z components.
    pub z: F32s<W>,
}

impl<const W: usize> V3s<W> {
    /// Lane `i` is `f(i)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> Vec3) -> Self {
        let mut out = Self::default();
        for i in 0..W {
            let v = f(i);
            out.x[i] = v.x;
            out.y[i] = v.y;
            out.z[i] = v.z;
        }
        out
    }

    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        V3s {
            x: F32s::splat(v.x),
            y: F32s::splat(v.y),
            z: F32s::splat(v.z),
        }
    }

    /// Lane `i`.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// Sets lane `i` to `v`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x[i] = v.x;
        self.y[i] = v.y;
        self.z[i] = v.z;
    }

    /// The dot product, `(x·x′ + y·y′) + z·z′` as `glam::Vec3::dot`.
    #[inline(always)]
    pub fn dot(self, rhs: Self) -> F32s<W> {
        self.x * rhs.x + self.y * rhs.y + self.z * rhs.z
    }

    /// The squared length (`self.dot(self)`).
    #[inline(always)]
    pub fn length_squared(self) -> F32s<W> {
        self.dot(self)
    }

    /// The largest component, `max(max(x, y), z)` with the lanes' maximum (as
    /// `glam::Vec3::max_element`).
    #[inline(always)]
    pub fn max_element(self) -> F32s<W> {
        self.x.max(self.y).max(self.z)
    }

    /// `if_true` in the lanes where `mask` holds, `if_false` in the others.
    #[inline(always)]
    pub fn select(mask: Mask<W>, if_true: Self, if_false: Self) -> Self {
        V3s {
            x: F32s::select(mask, if_true.x, if_false.x),
            y: F32s::select(mask, if_true.y, if_false.y),
            z: F32s::select(mask, if_true.z, if_false.z),
        }
    }

    /// The cross product, as `glam::Vec3::cross`: (y·z′ − y′·z, z·x′ − z′·x, x·y′ − x′·y).
    #[inline(always)]
    pub fn cross(self, rhs: Self) -> Self {
        V3s {
            x: self.y * rhs.z - rhs.y * self.z,
            y: self.z * rhs.x - rhs.z * self.x,
            z: self.x * rhs.y - rhs.x * self.y,
        }
    }

    /// The vector times 1 / √(self·self), as `glam::Vec3::normalize`.
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (F32s::splat(1.0) / self.dot(self).sqrt())
    }

    /// As `glam::Vec3::normalize_or_zero`: the normalised vector where 1 / √(self·self) is
    /// finite and positive, zero elsewhere.
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Self {
        let rcp = F32s::splat(1.0) / self.dot(self).sqrt();
        let ok = rcp.is_finite() & rcp.gt(F32s::splat(0.0));
        V3s::select(ok, self * rcp, V3s::default())
    }

    /// The lanes where every component equals `rhs`'s (`Vec3 == Vec3`: −0 equals +0, NaN
    /// nothing).
    #[inline(always)]
    pub fn eq(self, rhs: Self) -> Mask<W> {
        self.x.eq(rhs.x) & self.y.eq(rhs.y) & self.z.eq(rhs.z)
    }

    /// The lanes where every component is zero (`== Vec3::ZERO`: −0 counts, NaN does not).
    #[inline(always)]
    pub fn is_zero(self) -> Mask<W> {
        self.eq(V3s::default())
    }
}

impl<const W: usize> Add for V3s<W> {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        V3s {
            x: self.x + rhs.x,
            y: self.y + rhs.y,
            z: self.z + rhs.z,
        }
    }
}

impl<const W: usize> Sub for V3s<W> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: Self) -> Self {
        V3s {
            x: self.x - rhs.x,
            y: self.y - rhs.y,
            z: self.z - rhs.z,
        }
    }
}

impl<const W: usize> Neg for V3s<W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3s {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}

/// Component by component, as `Vec3 * Vec3`.
impl<const W: usize> Mul for V3s<W> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        V3s {
            x: self.x * rhs.x,
            y: self.y * rhs.y,
            z: self.z * rhs.z,
        }
    }
}

/// Each component times the lane's scalar, as `Vec3 * f32`.
impl<const W: usize> Mul<F32s<W>> for V3s<W> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: F32s<W>) -> Self {
        V3s {
            x: self.x * rhs,
            y: self.y * rhs,
            z: self.z * rhs,
        }
    }
}

/// Each component divided by the lane's scalar, as `Vec3 / f32` (a division per component,
/// not a product with the reciprocal).
impl<const W: usize> Div<F32s<W>> for V3s<W> {
    type Output = Self;
    #[inline(always)]
    fn div(self, rhs: F32s<W>) -> Self {
        V3s {
            x: self.x / rhs,
            y: self.y / rhs,
            z: self.z / rhs,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each lane's dot product, quotient and select are glam's bits.
    #[test]
    fn lanes_compute_what_glam_computes() {
        let a: [Vec3; 4] = [
            Vec3::new(0.1, -2.5, 3.75),
            Vec3::new(1e-20, 7.0, -0.3),
            Vec3::new(-1.0 / 3.0, 2.0 / 7.0, 5.0 / 11.0),
            Vec3::new(1e30, -1e30, 1e-30),
        ];
        let b: [Vec3; 4] = [
            Vec3::new(0.7, 0.2, -0.9),
            Vec3::new(-3.0, 1e-10, 0.5),
            Vec3::new(9.0, -4.0, 1.0 / 9.0),
            Vec3::new(2.0, 3.0, 4.0),
        ];
        let (va, vb) = (V3s::<4>::from_fn(|i| a[i]), V3s::<4>::from_fn(|i| b[i]));
        let dot = va.dot(vb);
        let quotient = va / vb.x;
        let mask = va.x.lt(vb.x);
        let chosen = V3s::select(mask, va, vb);
        for i in 0..4 {
            assert_eq!(dot[i].to_bits(), a[i].dot(b[i]).to_bits(), "lane {i}");
            let q = a[i] / b[i].x;
            assert_eq!(
                quotient.lane(i).to_array().map(f32::to_bits),
                q.to_array().map(f32::to_bits)
            );
            let c = if a[i].x < b[i].x { a[i] } else { b[i] };
            assert_eq!(chosen.lane(i), c);
        }
        assert!(V3s::<4>::splat(Vec3::new(-0.0, 0.0, 0.0)).is_zero().all());
    }
}
