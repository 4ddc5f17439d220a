//! Surfaces of revolution ("lathes") with exact, robust ray intersection.
//!
//! A profile curve (x(t), y(t)) in the xy-plane is revolved about the +y axis:
//! S(t, θ) = (x cos θ, y, −x sin θ). |x| is the radius, so a profile and its mirror image
//! (−x, y) give the same surface with the same orientation.
//!
//! * **Orientation.** The front (outside) normal is n = ∂S/∂θ × ∂S/∂t = x·(y′ cos θ, −x′,
//!   −y′ sin θ): a profile traversed upwards faces away from the axis, one traversed downwards
//!   faces the axis. At a pole (x = 0) the normal is the limit along the axis.
//! * **Texture coordinates.** u = θ / 2π, v = the curve parameter normalised to [0, 1] over the
//!   whole profile (for a B-spline: (τ − τ_p) / (τ_n − τ_p) over the traced knot domain).
//!
//! Representation: every profile becomes a list of Bézier segments (B-splines by Boehm knot
//! insertion, [`bspline`]), and every segment is split at the extrema of x(t) and y(t) and at
//! axis crossings into *pieces* on which x and y are monotone and x does not change sign. Each
//! piece is bounded by an annular cylinder (its height range × its radius range).
//! [`Lathe::intersect`] tests the pieces whose annuli the ray enters, nearest entry first
//! (every piece in turn when there are many); the whole lathe is one primitive of the scene's
//! BVH. The piece API ([`Lathe::segment_count`], [`Lathe::segment_bounds`],
//! [`Lathe::segment_annulus`], [`Lathe::intersect_segment`]) exposes the pieces one by one so
//! that a BVH can hold them as primitives instead (not done yet).
//!
//! Intersection (see `intersect.rs`) reduces the ray–piece problem to the roots of one
//! univariate polynomial in the curve parameter, in Bernstein form, isolates all of them by
//! subdivision with the convex-hull property and polishes them with safeguarded Newton.

pub mod bernstein;
pub mod bspline;
mod intersect;

#[cfg(test)]
mod reference;
#[cfg(test)]
mod tests;

use bernstein::{eval_curve_with_derivative, roots_in_unit_interval, split_curve, MAX_DEGREE};
use glam::{DVec2, DVec3};

/// Why a profile cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LatheError {
    /// Too few control points for the degree.
    #[error("profile has {got} control points but degree {degree} needs at least {need}; add points or lower the degree")]
    TooFewPoints {
        /// Points given.
        got: usize,
        /// Points needed.
        need: usize,
        /// The degree.
        degree: usize,
    },
    /// Degree outside 1..=16.
    #[error("profile degree {0} is not supported; use a degree from 1 to {MAX_DEGREE}")]
    BadDegree(usize),
    /// A control point or knot is NaN or infinite.
    #[error("profile {what} {index} is not a finite number; use finite coordinates")]
    NotFinite {
        /// "point" or "knot".
        what: &'static str,
        /// Its index.
        index: usize,
    },
    /// Wrong knot count.
    #[error("B-spline knot vector has {got} values but {points} points of degree {degree} need {need} (points + degree + 1)")]
    KnotCount {
        /// Knots given.
        got: usize,
        /// Knots needed.
        need: usize,
        /// Number of control points.
        points: usize,
        /// The degree.
        degree: usize,
    },
    /// Knots decrease.
    #[error("B-spline knots must be non-decreasing, but knot {index} ({value}) is smaller than the one before it")]
    KnotsDecrease {
        /// Index of the offending knot.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// Empty traced domain.
    #[error("B-spline traces nothing: knots[degree] = knots[points] = {0}; spread the knots out")]
    EmptyDomain(f64),
    /// Every control point is the same point.
    #[error("profile is a single point; move the control points apart")]
    Degenerate,
}

/// A Bézier segment of the whole profile, with the v range it covers.
#[derive(Debug, Clone)]
pub(crate) struct Segment {
    pub points: Vec<DVec2>,
    pub v0: f64,
    pub v1: f64,
}

/// How a piece is intersected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PieceKind {
    /// General curve piece.
    Curve,
    /// Constant height: a flat ring or disc (a plane intersection).
    Flat,
    /// Constant radius: a cylinder wall (a quadratic).
    Wall,
}

/// A monotone piece of the profile with x ≥ 0 (mirrored if the profile had x < 0 there).
#[derive(Debug, Clone)]
pub(crate) struct Piece {
    /// Control points with x ≥ 0.
    pub points: Vec<DVec2>,
    /// v at piece parameter 0 and 1 (v is affine in the piece parameter).
    pub v0: f64,
    pub v1: f64,
    /// True when the original profile had x < 0 here (u is then measured from θ + π).
    pub mirrored: bool,
    pub kind: PieceKind,
    /// Bounds of the control hull: radius [r_lo, r_hi], height [y_lo, y_hi].
    pub r_lo: f64,
    pub r_hi: f64,
    pub y_lo: f64,
    pub y_hi: f64,
}

/// A profile curve, independent of any file format: one Bézier curve or a B-spline, stored as
/// Bézier segments.
#[derive(Debug, Clone)]
pub struct Profile {
    pub(crate) segments: Vec<Segment>,
}

fn check_points(points: &[[f64; 2]]) -> Result<Vec<DVec2>, LatheError> {
    for (i, p) in points.iter().enumerate() {
        if !p[0].is_finite() || !p[1].is_finite() {
            return Err(LatheError::NotFinite {
                what: "point",
                index: i,
            });
        }
    }
    let pts: Vec<DVec2> = points.iter().map(|p| DVec2::new(p[0], p[1])).collect();
    if pts.iter().all(|p| *p == pts[0]) {
        return Err(LatheError::Degenerate);
    }
    Ok(pts)
}

impl Profile {
    /// One Bézier curve of degree `points.len() − 1` (2 to 17 points), parameter v = t ∈ [0, 1].
    pub fn bezier(points: &[[f64; 2]]) -> Result<Profile, LatheError> {
        if points.len() < 2 {
            return Err(LatheError::TooFewPoints {
                got: points.len(),
                need: 2,
                degree: 1,
            });
        }
        if points.len() - 1 > MAX_DEGREE {
            return Err(LatheError::BadDegree(points.len() - 1));
        }
        let pts = check_points(points)?;
        Ok(Profile {
            segments: vec![Segment {
                points: pts,
                v0: 0.0,
                v1: 1.0,
            }],
        })
    }

    /// A B-spline of the given degree. `knots`: `points.len() + degree + 1` non-decreasing
    /// values, or `None` for the clamped uniform vector on [0, 1]. The curve is traced over
    /// \[knots\[degree\], knots\[points.len()\]\], and v is that interval mapped to \[0, 1\].
    pub fn bspline(
        degree: usize,
        points: &[[f64; 2]],
        knots: Option<&[f64]>,
    ) -> Result<Profile, LatheError> {
        if degree == 0 || degree > MAX_DEGREE {
            return Err(LatheError::BadDegree(degree));
        }
        if points.len() < degree + 1 {
            return Err(LatheError::TooFewPoints {
                got: points.len(),
                need: degree + 1,
                degree,
            });
        }
        let pts = check_points(points)?;
        let n = pts.len();
        let knots: Vec<f64> = match knots {
            Some(k) => {
                if k.len() != n + degree + 1 {
                    return Err(LatheError::KnotCount {
                        got: k.len(),
                        need: n + degree + 1,
                        points: n,
                        degree,
                    });
                }
                for (i, v) in k.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(LatheError::NotFinite {
                            what: "knot",
                            index: i,
                        });
                    }
                    if i > 0 && *v < k[i - 1] {
                        return Err(LatheError::KnotsDecrease {
                            index: i,
                            value: *v,
                        });
                    }
                }
                k.to_vec()
            }
            None => clamped_uniform_knots(degree, n),
        };
        let (start, end) = (knots[degree], knots[n]);
        if end <= start {
            return Err(LatheError::EmptyDomain(start));
        }
        let spans = bspline::decompose(degree, &pts, &knots);
        let segments = spans
            .into_iter()
            .map(|s| Segment {
                points: s.points,
                v0: (s.u0 - start) / (end - start),
                v1: (s.u1 - start) / (end - start),
            })
            .collect();
        Ok(Profile { segments })
    }

    /// Evaluates the profile point and its derivative with respect to v at v ∈ [0, 1].
    pub fn eval(&self, v: f64) -> (DVec2, DVec2) {
        let v = v.clamp(0.0, 1.0);
        let seg = self.segments.iter().find(|s| v <= s.v1).unwrap_or_else(|| {
            self.segments
                .last()
                .expect("a profile has at least one segment")
        });
        let t = ((v - seg.v0) / (seg.v1 - seg.v0)).clamp(0.0, 1.0);
        let (p, dp) = eval_curve_with_derivative(&seg.points, t);
        (p, dp / (seg.v1 - seg.v0))
    }
}

/// The clamped uniform knot vector on [0, 1] (the schema's default).
pub fn clamped_uniform_knots(degree: usize, points: usize) -> Vec<f64> {
    let spans = points.saturating_sub(degree).max(1);
    let mut k = vec![0.0; degree + 1];
    for i in 1..spans {
        k.push(i as f64 / spans as f64);
    }
    k.extend(std::iter::repeat_n(1.0, degree + 1));
    k
}

/// A hit on a lathe, in the lathe's own (object) space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatheHit {
    /// Ray parameter: the hit point is origin + s·direction (direction as given, not normalised).
    pub s: f64,
    /// Hit point.
    pub point: DVec3,
    /// Unit geometric normal, oriented by the rule n = ∂S/∂θ × ∂S/∂t (not flipped towards the ray).
    pub normal: DVec3,
    /// Texture coordinates (u = θ/2π, v = normalised curve parameter).
    pub uv: DVec2,
    /// ∂p/∂u (= 2π ∂S/∂θ).
    pub dpdu: DVec3,
    /// ∂p/∂v.
    pub dpdv: DVec3,
    /// Index of the piece that was hit.
    pub segment: usize,
}

/// A surface of revolution ready for intersection.
#[derive(Debug, Clone)]
pub struct Lathe {
    pub(crate) profile: Profile,
    pub(crate) pieces: Vec<Piece>,
    /// Largest radius and height span: the length scale for tolerances.
    pub(crate) scale: f64,
    bounds: (DVec3, DVec3),
}

impl Lathe {
    /// Builds the lathe: splits the profile into monotone pieces and computes bounds.
    pub fn new(profile: Profile) -> Lathe {
        let mut pieces = Vec::new();
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for seg in &profile.segments {
            for p in &seg.points {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let scale = (hi - lo)
            .max_element()
            .max(lo.x.abs())
            .max(hi.x.abs())
            .max(f64::MIN_POSITIVE);
        for seg in &profile.segments {
            split_into_pieces(seg, scale, &mut pieces);
        }
        let r = pieces.iter().fold(0.0f64, |m, p| m.max(p.r_hi));
        let y_lo = pieces.iter().fold(f64::INFINITY, |m, p| m.min(p.y_lo));
        let y_hi = pieces.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.y_hi));
        Lathe {
            profile,
            pieces,
            scale,
            bounds: (DVec3::new(-r, y_lo, -r), DVec3::new(r, y_hi, r)),
        }
    }

    /// The profile.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Axis-aligned bounds of the whole lathe (object space).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.bounds
    }

    /// Number of independently intersectable pieces (monotone in x and y, one sign of x).
    pub fn segment_count(&self) -> usize {
        self.pieces.len()
    }

    /// Axis-aligned bounds of piece `i` (object space).
    pub fn segment_bounds(&self, i: usize) -> (DVec3, DVec3) {
        let p = &self.pieces[i];
        (
            DVec3::new(-p.r_hi, p.y_lo, -p.r_hi),
            DVec3::new(p.r_hi, p.y_hi, p.r_hi),
        )
    }

    /// The unit normal (orientation rule above) at profile parameter `v` for the surface point
    /// `point` (whose azimuth picks the direction); used to finish hits stored compactly.
    pub fn normal_at(&self, v: f64, point: DVec3) -> DVec3 {
        let (p, dp) = self.profile.eval(v);
        let r = (point.x * point.x + point.z * point.z).sqrt();
        let e_r = if r > 0.0 {
            DVec3::new(point.x / r, 0.0, point.z / r)
        } else {
            DVec3::X
        };
        // n ∝ x·(y′ cos θ, −x′, −y′ sin θ); with θ from the point (θ + π for x < 0) this is
        // y′ e_r − x′ ŷ for x > 0 and y′ e_r + x′ ŷ for x < 0.
        let xs = if p.x != 0.0 {
            p.x.signum()
        } else if dp.x != 0.0 {
            if v < 0.5 {
                dp.x.signum()
            } else {
                -dp.x.signum()
            }
        } else {
            1.0
        };
        let n = if r > 1e-12 * self.scale {
            dp.y * e_r - xs * dp.x * DVec3::Y
        } else {
            DVec3::ZERO
        };
        if n.length_squared() > 0.0 {
            n.normalize()
        } else {
            // On the axis: the limit along it, −sign(x·x′)·ŷ.
            if xs * dp.x > 0.0 {
                -DVec3::Y
            } else {
                DVec3::Y
            }
        }
    }

    /// The annulus bounding piece `i`: (radius range, height range).
    pub fn segment_annulus(&self, i: usize) -> ((f64, f64), (f64, f64)) {
        let p = &self.pieces[i];
        ((p.r_lo, p.r_hi), (p.y_lo, p.y_hi))
    }
}

/// Splits a Bézier segment at the interior roots of x′, y′ and x, and appends the pieces.
fn split_into_pieces(seg: &Segment, scale: f64, out: &mut Vec<Piece>) {
    let n = seg.points.len() - 1;
    let xs: Vec<f64> = seg.points.iter().map(|p| p.x).collect();
    let mut cuts: Vec<f64> = Vec::new();
    if n >= 2 {
        let dx: Vec<f64> = seg.points.windows(2).map(|w| w[1].x - w[0].x).collect();
        let dy: Vec<f64> = seg.points.windows(2).map(|w| w[1].y - w[0].y).collect();
        cuts.extend(roots_in_unit_interval(&dx, 1e-12 * scale));
        cuts.extend(roots_in_unit_interval(&dy, 1e-12 * scale));
    }
    cuts.extend(roots_in_unit_interval(&xs, 1e-12 * scale));
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let mut bounds = vec![0.0];
    bounds.extend(cuts.iter().copied().filter(|&t| t > 1e-9 && t < 1.0 - 1e-9));
    bounds.push(1.0);
    let mut rest: Vec<DVec2> = seg.points.clone();
    let mut rest_start = 0.0;
    for w in bounds.windows(2) {
        let (a, b) = (w[0], w[1]);
        let mut piece_pts = vec![DVec2::ZERO; n + 1];
        if b >= 1.0 {
            piece_pts.copy_from_slice(&rest);
        } else {
            let local = (b - rest_start) / (1.0 - rest_start);
            let mut right = vec![DVec2::ZERO; n + 1];
            split_curve(&rest, local, &mut piece_pts, &mut right);
            rest = right;
            rest_start = b;
        }
        let v0 = seg.v0 + a * (seg.v1 - seg.v0);
        let v1 = seg.v0 + b * (seg.v1 - seg.v0);
        if let Some(p) = make_piece(piece_pts, v0, v1, scale) {
            out.push(p);
        }
    }
}

fn make_piece(mut pts: Vec<DVec2>, v0: f64, v1: f64, scale: f64) -> Option<Piece> {
    let extent = pts
        .iter()
        .fold(0.0f64, |m, p| m.max((*p - pts[0]).abs().max_element()));
    if extent <= 1e-14 * scale {
        return None; // a point: no area
    }
    // Axis crossings were cut, so x has one sign on the piece; the mean decides it.
    let mean_x: f64 = pts.iter().map(|p| p.x).sum::<f64>() / pts.len() as f64;
    let mirrored = mean_x < 0.0;
    if mirrored {
        for p in &mut pts {
            p.x = -p.x;
        }
    }
    let tol = 1e-12 * scale;
    let flat = pts.iter().all(|p| (p.y - pts[0].y).abs() <= tol);
    let wall = pts.iter().all(|p| (p.x - pts[0].x).abs() <= tol);
    let kind = if flat {
        let y = pts[0].y;
        for p in &mut pts {
            p.y = y;
        }
        PieceKind::Flat
    } else if wall {
        let x = pts[0].x;
        for p in &mut pts {
            p.x = x;
        }
        PieceKind::Wall
    } else {
        PieceKind::Curve
    };
    let r_lo = pts.iter().fold(f64::INFINITY, |m, p| m.min(p.x)).max(0.0);
    let r_hi = pts.iter().fold(0.0f64, |m, p| m.max(p.x.abs()));
    let y_lo = pts.iter().fold(f64::INFINITY, |m, p| m.min(p.y));
    let y_hi = pts.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.y));
    Some(Piece {
        points: pts,
        v0,
        v1,
        mirrored,
        kind,
        r_lo,
        r_hi,
        y_lo,
        y_hi,
    })
}
