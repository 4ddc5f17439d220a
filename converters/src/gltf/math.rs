//! glTF's side of transforms: row-major 4×4 affine matrices in f64 (points as columns:
//! p' = M · p), quaternions, TRS and column-major conversion. The matrix of lumo transform steps
//! and Rodrigues' rotation are [`lumo_schema::geometry::transform`]'s.
//!
//! Everything is computed in f64 and rounded to f32 once at the end, so the same input always
//! gives the same f32 matrix on export and on import (that is what makes round trips exact).

use lumo_schema::geometry::glam::{DMat4, DVec3};
use lumo_schema::geometry::transform::{self as shared, from_rows, to_rows};
use lumo_schema::{Transform, TransformOp};

/// Row-major 4×4 matrix.
pub type Mat4 = [[f64; 4]; 4];

/// The identity matrix.
pub const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// a · b.
pub fn mul(a: &Mat4, b: &Mat4) -> Mat4 {
    to_rows(&(from_rows(a) * from_rows(b)))
}

/// Rotation matrix of a unit quaternion (x, y, z, w) as glTF stores it.
pub fn rotation_quat(q: [f64; 4]) -> Mat4 {
    let [x, y, z, w] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
            0.0,
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
            0.0,
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
            0.0,
        ],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// The unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method, choosing the
/// largest diagonal term for stability: S. W. Shepperd, "Quaternion from rotation matrix",
/// J. Guidance and Control 1(3), 1978).
pub fn quat_from_rotation(m: &Mat4) -> [f64; 4] {
    let tr = m[0][0] + m[1][1] + m[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
            0.25 * s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[2][1] - m[1][2]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
            (m[0][2] - m[2][0]) / s,
        ]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
            (m[1][0] - m[0][1]) / s,
        ]
    };
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
}

/// The matrix of lumo transform steps (the first step acts first), row-major.
pub fn ops_matrix(ops: &Transform) -> Mat4 {
    to_rows(&shared::ops_matrix(ops))
}

/// Rounds to the f32 row-major matrix lumo's `matrix` step holds (last row forced to 0 0 0 1).
pub fn to_f32(m: &Mat4) -> [[f32; 4]; 4] {
    let mut r = m.map(|row| row.map(|x| x as f32));
    r[3] = [0.0, 0.0, 0.0, 1.0];
    r
}

/// Widens an f32 row-major matrix.
pub fn from_f32(m: &[[f32; 4]; 4]) -> Mat4 {
    m.map(|r| r.map(f64::from))
}

/// The transform steps the importer writes for a world matrix: none for the identity, otherwise
/// one `matrix` step (exact: it is the f32 matrix itself).
pub fn ops_of_world(m: &[[f32; 4]; 4]) -> Transform {
    if from_f32(m) == IDENTITY {
        Vec::new()
    } else {
        vec![TransformOp::Matrix(*m)]
    }
}

/// Column-major 16 floats as glTF's `node.matrix` stores them.
pub fn to_column_major(m: &[[f32; 4]; 4]) -> [f32; 16] {
    let mut out = [0.0; 16];
    for c in 0..4 {
        for r in 0..4 {
            out[c * 4 + r] = m[r][c];
        }
    }
    out
}

/// Row-major matrix from glTF's column-major 16 floats.
pub fn from_column_major(a: &[f32; 16]) -> [[f32; 4]; 4] {
    let mut m = [[0.0; 4]; 4];
    for c in 0..4 {
        for r in 0..4 {
            m[r][c] = a[c * 4 + r];
        }
    }
    m
}

/// The node matrix T · R · S of glTF's decomposed transform.
pub fn trs(t: [f32; 3], r: [f32; 4], s: [f32; 3]) -> Mat4 {
    let rs = from_rows(&rotation_quat(r.map(f64::from))) * DMat4::from_scale(DVec3::from(f64x3(s)));
    to_rows(&(DMat4::from_translation(DVec3::from(f64x3(t))) * rs))
}

/// Decomposes an affine matrix into translation, rotation and scale when it is one (its
/// upper-left 3×3 block has orthogonal columns); `None` when it shears. A negative
/// determinant is folded into a negative x scale.
pub fn decompose_trs(m: &Mat4) -> Option<([f64; 3], [f64; 4], [f64; 3])> {
    let col = |j: usize| [m[0][j], m[1][j], m[2][j]];
    let (c0, c1, c2) = (col(0), col(1), col(2));
    let mut s = [len(c0), len(c1), len(c2)];
    if s.iter().any(|x| *x == 0.0 || !x.is_finite()) {
        return None;
    }
    // Columns must be mutually orthogonal to a relative tolerance well below what glTF
    // validators accept (they recompose and compare at about 1e-5).
    for (a, b) in [(c0, c1), (c0, c2), (c1, c2)] {
        if dot(a, b).abs() > 1e-7 * len(a) * len(b) {
            return None;
        }
    }
    if det3(m) < 0.0 {
        s[0] = -s[0];
    }
    let mut r = IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = m[i][j] / s[j];
        }
    }
    Some(([m[0][3], m[1][3], m[2][3]], quat_from_rotation(&r), s))
}

/// Determinant of the upper-left 3×3 block.
pub fn det3(m: &Mat4) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Transforms a point.
pub fn point(m: &Mat4, p: [f64; 3]) -> [f64; 3] {
    let mut o = [0.0; 3];
    for (i, x) in o.iter_mut().enumerate() {
        *x = m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3];
    }
    o
}

/// Determinant of the 3×3 linear block (negative for a mirroring transform).
pub fn determinant3(m: &Mat4) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Transforms a direction (ignores the translation).
pub fn vector(m: &Mat4, v: [f64; 3]) -> [f64; 3] {
    let mut o = [0.0; 3];
    for (i, x) in o.iter_mut().enumerate() {
        *x = m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2];
    }
    o
}

/// Transforms a normal with the inverse transpose of the 3×3 block (as the cofactor matrix,
/// which differs from it only by the positive or negative factor det; the sign is kept so a
/// mirroring transform flips normals consistently with the winding).
pub fn normal(m: &Mat4, n: [f64; 3]) -> [f64; 3] {
    let c = |r: usize, k: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let mut o = [0.0; 3];
    for (i, x) in o.iter_mut().enumerate() {
        *x = c(i, 0) * n[0] + c(i, 1) * n[1] + c(i, 2) * n[2];
    }
    o
}

/// Widens a 3-vector.
pub fn f64x3(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}

/// Dot product.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length.
pub fn len(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The unit vector along `a`, or `None` for a zero or non-finite vector.
pub fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = len(a);
    (l > 0.0 && l.is_finite()).then(|| [a[0] / l, a[1] / l, a[2] / l])
}

/// a − b.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
