//! True axis-aligned bounds of scene objects, in world space (under the object's transform).
//!
//! - Sphere: the exact box of the transformed ellipsoid. For x ↦ M x + t the sphere |x − c| ≤ r
//!   spans, along axis i, (M c + t)ᵢ ± r ‖row i of M‖ (the support function of an ellipsoid).
//! - Plane: unbounded (`None`).
//! - Triangle, inline mesh, positions read from a file: the box of the transformed vertices
//!   (exact: a polytope's extremes are at vertices).
//! - Lathe: the exact box of the transformed surface, from the curve itself (not its control
//!   points): see [`lathe_bounds`] and [`profile_support`] (sampling, then golden-section
//!   refinement of every sampled maximum).

use glam::{DMat4, DVec3};

use super::profile::{domain, eval};
use super::transform::ops_matrix;
use crate::{MeshSource, Object, Profile};

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: DVec3,
    /// Largest corner.
    pub max: DVec3,
}

impl Aabb {
    /// The box of one point.
    pub fn point(p: DVec3) -> Aabb {
        Aabb { min: p, max: p }
    }

    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The centre.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) / 2.0
    }

    /// True when every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }
}

/// The box of the points `positions` under `m`; `None` when there are none or one is not
/// finite. For meshes read from files, pass their positions and the object's matrix.
pub fn points_bounds(positions: impl IntoIterator<Item = DVec3>, m: &DMat4) -> Option<Aabb> {
    let mut b: Option<Aabb> = None;
    for p in positions {
        let w = Aabb::point(m.transform_point3(p));
        b = Some(b.map_or(w, |b| b.union(&w)));
    }
    b.filter(Aabb::is_finite)
}

/// The exact box of the sphere of `center` and `radius` under `m` (an ellipsoid).
pub fn sphere_bounds(center: DVec3, radius: f64, m: &DMat4) -> Option<Aabb> {
    let c = m.transform_point3(center);
    let rows = super::transform::to_rows(m);
    let h = DVec3::from_array(
        [0, 1, 2].map(|i| radius.abs() * DVec3::new(rows[i][0], rows[i][1], rows[i][2]).length()),
    );
    Some(Aabb {
        min: c - h,
        max: c + h,
    })
    .filter(Aabb::is_finite)
}

/// The exact box, under `m`, of the solid cylinder of radius `radius` about the y axis between
/// heights `y0` and `y1`.
pub fn cylinder_bounds(radius: f64, y0: f64, y1: f64, m: &DMat4) -> Option<Aabb> {
    let rows = super::transform::to_rows(m);
    let h = DVec3::from_array(
        [0, 1, 2]
            .map(|i| radius.abs() * (rows[i][0] * rows[i][0] + rows[i][2] * rows[i][2]).sqrt()),
    );
    let disc = |y: f64| {
        let c = m.transform_point3(DVec3::new(0.0, y, 0.0));
        Aabb {
            min: c - h,
            max: c + h,
        }
    };
    Some(disc(y0).union(&disc(y1))).filter(Aabb::is_finite)
}

/// The true extent of a profile curve: (largest |x|, smallest y, largest y) over its traced
/// domain, or `None` for an empty or non-finite profile. See [`profile_support`].
pub fn profile_extent(profile: &Profile) -> Option<(f64, f64, f64)> {
    let r = profile_support(profile, 0.0, 1.0)?;
    let y0 = -profile_support(profile, -1.0, 0.0)?;
    let y1 = profile_support(profile, 1.0, 0.0)?;
    Some((r, y0, y1))
}

/// The largest value of a·y(t) + b·|x(t)| over the profile's traced domain (the support
/// function of the lathe's surface in a direction with axial part a and radial length b), or
/// `None` for an empty or non-finite profile.
///
/// Method: sample then refine. The curve is sampled at 64 parameters per Bézier degree or
/// B-spline knot span; each sampled local maximum (and each end) is refined by golden-section
/// search on the bracket of its two neighbouring samples to 10⁻¹³ of the domain. A polynomial
/// piece of degree n has at most 2n − 1 interior extrema of such a function, so 64 samples per
/// piece separate them for the degrees the schema accepts unless two lie within 1/64 of a
/// piece of each other, where the error is still below the curve's change over that distance.
pub fn profile_support(profile: &Profile, a: f64, b: f64) -> Option<f64> {
    let (pieces, n_points) = match profile {
        Profile::Bezier(p) => (p.points.len().saturating_sub(1).max(1), p.points.len()),
        Profile::Bspline(p) => (
            p.points.len().saturating_sub(p.degree as usize).max(1),
            p.points.len(),
        ),
    };
    if n_points == 0 {
        return None;
    }
    let (t0, t1) = domain(profile);
    let n = 64 * pieces;
    let at = |k: usize| t0 + (t1 - t0) * k as f64 / n as f64;
    let g = |t: f64| {
        let p = eval(profile, t).0;
        a * p[1] + b * p[0].abs()
    };
    let vals: Vec<f64> = (0..=n).map(|k| g(at(k))).collect();
    let mut best = f64::NEG_INFINITY;
    for k in 0..=n {
        let left = if k == 0 {
            f64::NEG_INFINITY
        } else {
            vals[k - 1]
        };
        let right = if k == n {
            f64::NEG_INFINITY
        } else {
            vals[k + 1]
        };
        if vals[k] >= left && vals[k] >= right {
            let (lo, hi) = (at(k.saturating_sub(1)), at((k + 1).min(n)));
            best = best
                .max(vals[k])
                .max(golden_max(&g, lo, hi, 1e-13 * (t1 - t0)));
        }
    }
    best.is_finite().then_some(best)
}

/// The exact box, under `m`, of the lathe of `profile`. Along world axis i the surface point
/// M·S(t, θ) has coordinate tᵢ + M_{i1} y + x (M_{i0} cos θ − M_{i2} sin θ), whose largest value
/// over θ is tᵢ + M_{i1} y + |x| √(M_{i0}² + M_{i2}²); its largest and smallest values over t
/// are [`profile_support`]s.
pub fn lathe_bounds(profile: &Profile, m: &DMat4) -> Option<Aabb> {
    let rows = super::transform::to_rows(m);
    let mut min = [0.0; 3];
    let mut max = [0.0; 3];
    for i in 0..3 {
        let radial = (rows[i][0] * rows[i][0] + rows[i][2] * rows[i][2]).sqrt();
        max[i] = rows[i][3] + profile_support(profile, rows[i][1], radial)?;
        min[i] = rows[i][3] - profile_support(profile, -rows[i][1], radial)?;
    }
    Some(Aabb {
        min: DVec3::from(min),
        max: DVec3::from(max),
    })
    .filter(Aabb::is_finite)
}

/// The largest value of `g` found by golden-section search on [a, b] (Kiefer 1953), including
/// the bracket's ends.
fn golden_max(g: &impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let mut best = g(a).max(g(b));
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut gc, mut gd) = (g(c), g(d));
    for _ in 0..200 {
        if (b - a).abs() <= tol {
            break;
        }
        if gc >= gd {
            b = d;
            d = c;
            gd = gc;
            c = b - ratio * (b - a);
            gc = g(c);
        } else {
            a = c;
            c = d;
            gc = gd;
            d = a + ratio * (b - a);
            gd = g(d);
        }
        best = best.max(gc).max(gd);
    }
    best
}

/// World-space bounds of an object. `None` for a plane (unbounded), for a mesh whose vertices
/// are in another file (read them and use [`points_bounds`]), and for degenerate or non-finite
/// data.
pub fn object_bounds(obj: &Object) -> Option<Aabb> {
    let m = ops_matrix(obj.transform());
    let v = |a: [f32; 3]| DVec3::from(a.map(f64::from));
    match obj {
        Object::Plane(_) => None,
        Object::Sphere(s) => sphere_bounds(v(s.center), f64::from(s.radius), &m),
        Object::Triangle(t) => points_bounds(t.vertices.map(v), &m),
        Object::Mesh(mesh) => match &mesh.source {
            MeshSource::Inline(i) => points_bounds(i.positions.iter().map(|p| v(*p)), &m),
            MeshSource::Obj(_) | MeshSource::Gltf(_) => None,
        },
        Object::Lathe(l) => lathe_bounds(&l.profile, &m),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BezierProfile, BsplineProfile};

    #[test]
    fn profile_extent_is_the_curve_not_its_control_points() {
        // x(t) = 2·3t(1−t)² + ... : the middle control points reach x = 2, the curve 1.5.
        let b = Profile::Bezier(BezierProfile {
            points: vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]],
        });
        let (r, y0, y1) = profile_extent(&b).unwrap();
        assert!(
            (r - 1.5).abs() < 1e-12 && y0 == 0.0 && y1 == 1.0,
            "{r} {y0} {y1}"
        );
        // A clamped cubic B-spline whose y overshoots nothing but whose x peaks inside a span.
        let s = Profile::Bspline(BsplineProfile {
            degree: 3,
            points: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]],
            knots: None,
        });
        let (r, _, _) = profile_extent(&s).unwrap();
        let dense = (0..=100_000)
            .map(|k| eval(&s, k as f64 / 100_000.0).0[0])
            .fold(0.0, f64::max);
        assert!(r >= dense && r - dense < 1e-9, "{r} {dense}");
    }

    #[test]
    fn sphere_box_is_the_transformed_ellipsoid() {
        // Scale x by 2, then turn 90° about z: the long axis ends up along y.
        let m = DMat4::from_rotation_z(std::f64::consts::FRAC_PI_2)
            * DMat4::from_scale(DVec3::new(2.0, 1.0, 1.0));
        let b = sphere_bounds(DVec3::new(1.0, 0.0, 0.0), 1.0, &m).unwrap();
        let want = Aabb {
            min: DVec3::new(-1.0, 0.0, -1.0),
            max: DVec3::new(1.0, 4.0, 1.0),
        };
        assert!((b.min - want.min).length() < 1e-12 && (b.max - want.max).length() < 1e-12);
        // 45° about z: half-width √(cos² + sin²) = 1 along x and y for a unit sphere.
        let b = sphere_bounds(DVec3::ZERO, 1.0, &DMat4::from_rotation_z(0.7)).unwrap();
        assert!((b.max - DVec3::ONE).length() < 1e-12);
    }

    #[test]
    fn cylinder_box_under_a_tilt() {
        // A cylinder of radius 1 from y = 0 to 2 tipped onto the x axis (−90° about z).
        let m = DMat4::from_rotation_z(-std::f64::consts::FRAC_PI_2);
        let b = cylinder_bounds(1.0, 0.0, 2.0, &m).unwrap();
        assert!(
            (b.min - DVec3::new(0.0, -1.0, -1.0)).length() < 1e-12,
            "{b:?}"
        );
        assert!(
            (b.max - DVec3::new(2.0, 1.0, 1.0)).length() < 1e-12,
            "{b:?}"
        );
    }

    #[test]
    fn lathe_box_matches_a_fine_tessellation_under_a_rotation() {
        let prof = Profile::Bspline(BsplineProfile {
            degree: 3,
            points: vec![[0.0, -1.0], [1.6, -1.0], [0.2, 0.0], [0.9, 1.2], [0.0, 1.5]],
            knots: None,
        });
        let m = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0)) * DMat4::from_rotation_z(0.3);
        let exact = lathe_bounds(&prof, &m).unwrap();
        let mesh = super::super::tessellate::lathe(&prof, 720, 2000);
        let fine = points_bounds(mesh.positions, &m).unwrap();
        // The mesh's vertices lie on the surface, inside the exact box and within its chord error.
        assert!(
            (exact.min - fine.min).max_element() <= 1e-12,
            "{exact:?} {fine:?}"
        );
        assert!(
            (fine.max - exact.max).max_element() <= 1e-12,
            "{exact:?} {fine:?}"
        );
        assert!((exact.min - fine.min).length() < 1e-4 && (exact.max - fine.max).length() < 1e-4);
    }
}
