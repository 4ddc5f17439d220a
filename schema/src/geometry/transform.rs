//! Transform steps as one f64 matrix.
//!
//! Matrices are [`glam::DMat4`] acting on column vectors, p′ = M · (x, y, z, 1). A scene's
//! [`Transform`](crate::Transform) lists steps with the first acting first, so its matrix is M = Opₙ ⋯ Op₁.

use glam::{Affine3A, DMat4, DVec3, Mat4, Vec3};

use crate::{Scale, TransformOp};

/// Right-handed rotation by `radians` about `axis` (Rodrigues' rotation formula,
/// R = cos θ I + sin θ \[k\]ₓ + (1 − cos θ) k kᵀ for the unit axis k): positive angles turn
/// counter-clockwise when looking down the axis towards the origin. A zero or non-finite axis
/// gives the identity.
pub fn rotation_axis_angle(axis: DVec3, radians: f64) -> DMat4 {
    let len = (axis.x * axis.x + axis.y * axis.y + axis.z * axis.z).sqrt();
    if len == 0.0 || !len.is_finite() {
        return DMat4::IDENTITY;
    }
    let [x, y, z] = [axis.x / len, axis.y / len, axis.z / len];
    let (s, c) = radians.sin_cos();
    let t = 1.0 - c;
    from_rows(&[
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y, 0.0],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x, 0.0],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ])
}

/// A matrix type transform steps compose in. The meaning of a step (its order, degrees, the
/// row-major matrix) is written once, in [`step`]; the type says only how each kind of step is
/// built: f64 [`DMat4`] for the converters (exact round trips), f32 [`Affine3A`] for the
/// renderer (its instances' own type, rounded per step as renders always were).
pub trait StepMatrix: Copy + std::ops::Mul<Output = Self> {
    /// The identity map.
    const IDENTITY: Self;
    /// Translation by `t`.
    fn translation(t: [f32; 3]) -> Self;
    /// Right-handed rotation by `degrees` about `axis` (any length but zero).
    fn rotation(axis: [f32; 3], degrees: f32) -> Self;
    /// Scaling by `s` per axis.
    fn scaling(s: [f32; 3]) -> Self;
    /// The affine map of a row-major 4×4 matrix (last row 0 0 0 1).
    fn from_rows_f32(rows: &[[f32; 4]; 4]) -> Self;
}

impl StepMatrix for DMat4 {
    const IDENTITY: Self = DMat4::IDENTITY;
    fn translation(t: [f32; 3]) -> Self {
        DMat4::from_translation(DVec3::from(t.map(f64::from)))
    }
    fn rotation(axis: [f32; 3], degrees: f32) -> Self {
        rotation_axis_angle(
            DVec3::from(axis.map(f64::from)),
            f64::from(degrees).to_radians(),
        )
    }
    fn scaling(s: [f32; 3]) -> Self {
        DMat4::from_scale(DVec3::from(s.map(f64::from)))
    }
    fn from_rows_f32(rows: &[[f32; 4]; 4]) -> Self {
        from_rows(&rows.map(|r| r.map(f64::from)))
    }
}

impl StepMatrix for Affine3A {
    const IDENTITY: Self = Affine3A::IDENTITY;
    fn translation(t: [f32; 3]) -> Self {
        Affine3A::from_translation(Vec3::from(t))
    }
    fn rotation(axis: [f32; 3], degrees: f32) -> Self {
        Affine3A::from_axis_angle(Vec3::from(axis).normalize(), degrees.to_radians())
    }
    fn scaling(s: [f32; 3]) -> Self {
        Affine3A::from_scale(Vec3::from(s))
    }
    fn from_rows_f32(rows: &[[f32; 4]; 4]) -> Self {
        Affine3A::from_mat4(Mat4::from_cols_array_2d(rows).transpose())
    }
}

/// The matrix of one transform step.
pub fn step<M: StepMatrix>(op: &TransformOp) -> M {
    match op {
        TransformOp::Translate(t) => M::translation(*t),
        TransformOp::Rotate(r) => M::rotation(r.axis, r.degrees),
        TransformOp::Scale(Scale::Uniform(k)) => M::scaling([*k; 3]),
        TransformOp::Scale(Scale::PerAxis(s)) => M::scaling(*s),
        TransformOp::Matrix(rows) => M::from_rows_f32(rows),
    }
}

/// The map of a list of transform steps in the matrix type `M`: the first step acts first,
/// M = Opₙ ⋯ Op₁; the identity for an empty list.
pub fn compose<M: StepMatrix>(ops: &[TransformOp]) -> M {
    ops.iter().fold(M::IDENTITY, |m, op| step::<M>(op) * m)
}

/// The f64 matrix of one transform step (f32 values widened exactly to f64).
pub fn op_matrix(op: &TransformOp) -> DMat4 {
    step(op)
}

/// The f64 matrix of a list of transform steps (see [`compose`]).
pub fn ops_matrix(ops: &[TransformOp]) -> DMat4 {
    compose(ops)
}

/// The matrix whose rows are `rows` (`rows[r][c]` is the entry in row r, column c).
pub fn from_rows(rows: &[[f64; 4]; 4]) -> DMat4 {
    DMat4::from_cols_array_2d(rows).transpose()
}

/// The rows of a matrix: the inverse of [`from_rows`].
pub fn to_rows(m: &DMat4) -> [[f64; 4]; 4] {
    m.transpose().to_cols_array_2d()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rotation;

    #[test]
    fn rotation_is_right_handed() {
        let p = rotation_axis_angle(DVec3::Z, 90f64.to_radians()).transform_point3(DVec3::X);
        assert!(p.x.abs() < 1e-12 && (p.y - 1.0).abs() < 1e-12);
        let p = rotation_axis_angle(DVec3::X, 90f64.to_radians()).transform_point3(DVec3::Y);
        assert!((p.z - 1.0).abs() < 1e-12);
        assert_eq!(rotation_axis_angle(DVec3::ZERO, 1.0), DMat4::IDENTITY);
    }

    #[test]
    fn the_first_step_acts_first() {
        let ops = vec![
            TransformOp::Scale(Scale::Uniform(2.0)),
            TransformOp::Translate([1.0, 0.0, 0.0]),
            TransformOp::Rotate(Rotation {
                axis: [0.0, 0.0, 1.0],
                degrees: 90.0,
            }),
        ];
        // (1, 0, 0) → scaled (2, 0, 0) → moved (3, 0, 0) → turned (0, 3, 0).
        let p = ops_matrix(&ops).transform_point3(DVec3::X);
        assert!((p - DVec3::new(0.0, 3.0, 0.0)).length() < 1e-12, "{p}");
        let rows = [
            [1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0],
            [9.0, 10.0, 11.0, 12.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        assert_eq!(to_rows(&from_rows(&rows)), rows);
        assert_eq!(
            from_rows(&rows).transform_point3(DVec3::ZERO),
            DVec3::new(4.0, 8.0, 12.0)
        );
    }
}
