//! Profile curves of lathes: the traced parameter range and the point and first derivative at
//! a parameter, for Bézier (de Casteljau) and B-spline (de Boor, default knots applied) profiles.

use crate::{BsplineProfile, Profile, Vec2};

/// The parameter range of a profile.
pub fn domain(profile: &Profile) -> (f64, f64) {
    match profile {
        Profile::Bezier(_) => (0.0, 1.0),
        Profile::Bspline(b) => {
            let k = b.knots_or_default();
            let (p, n) = (b.degree as usize, b.points.len());
            match (k.get(p), k.get(n)) {
                (Some(a), Some(z)) => (f64::from(*a), f64::from(*z)),
                _ => (0.0, 1.0),
            }
        }
    }
}

/// The point and first derivative of a profile at parameter t.
pub fn eval(profile: &Profile, t: f64) -> ([f64; 2], [f64; 2]) {
    match profile {
        Profile::Bezier(b) => bezier(&b.points, t),
        Profile::Bspline(b) => bspline(b, t),
    }
}

/// De Casteljau's algorithm; the derivative is n times the difference of the last two
/// intermediate points.
fn bezier(points: &[Vec2], t: f64) -> ([f64; 2], [f64; 2]) {
    let mut pts: Vec<[f64; 2]> = points
        .iter()
        .map(|p| [f64::from(p[0]), f64::from(p[1])])
        .collect();
    let n = pts.len().saturating_sub(1);
    if n == 0 {
        return (pts.first().copied().unwrap_or([0.0; 2]), [0.0; 2]);
    }
    for level in 1..=n {
        if level == n {
            let (a, b) = (pts[0], pts[1]);
            let d = [n as f64 * (b[0] - a[0]), n as f64 * (b[1] - a[1])];
            let p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            return (p, d);
        }
        for i in 0..(pts.len() - 1) {
            pts[i] = [
                pts[i][0] + t * (pts[i + 1][0] - pts[i][0]),
                pts[i][1] + t * (pts[i + 1][1] - pts[i][1]),
            ];
        }
        pts.pop();
    }
    unreachable!("the loop returns at level n")
}

/// De Boor's algorithm (Piegl & Tiller, The NURBS Book, 2nd ed., A2.1 and A3.1); the
/// derivative from the derivative curve's control points Qᵢ = p (Pᵢ₊₁ − Pᵢ) / (uᵢ₊ₚ₊₁ − uᵢ₊₁)
/// (ibid. eq. 3.8).
fn bspline(b: &BsplineProfile, t: f64) -> ([f64; 2], [f64; 2]) {
    let knots: Vec<f64> = b.knots_or_default().iter().map(|k| f64::from(*k)).collect();
    let pts: Vec<[f64; 2]> = b
        .points
        .iter()
        .map(|p| [f64::from(p[0]), f64::from(p[1])])
        .collect();
    let p = b.degree as usize;
    let pos = de_boor(&pts, &knots, p, t);
    let der = if p == 0 {
        [0.0; 2]
    } else {
        let q: Vec<[f64; 2]> = (0..pts.len() - 1)
            .map(|i| {
                let den = knots[i + p + 1] - knots[i + 1];
                if den == 0.0 {
                    [0.0; 2]
                } else {
                    let f = p as f64 / den;
                    [
                        f * (pts[i + 1][0] - pts[i][0]),
                        f * (pts[i + 1][1] - pts[i][1]),
                    ]
                }
            })
            .collect();
        de_boor(&q, &knots[1..knots.len() - 1], p - 1, t)
    };
    (pos, der)
}

fn de_boor(pts: &[[f64; 2]], knots: &[f64], p: usize, t: f64) -> [f64; 2] {
    let n = pts.len();
    if n == 0 || knots.len() < n + p + 1 {
        return [0.0; 2];
    }
    // The span k with knots[k] ≤ t < knots[k+1], clamped to the last non-empty span at the end.
    let mut k = p;
    while k + 1 < n && knots[k + 1] <= t {
        k += 1;
    }
    let mut d: Vec<[f64; 2]> = (0..=p)
        .map(|j| pts[(j + k).saturating_sub(p).min(n - 1)])
        .collect();
    for r in 1..=p {
        for j in (r..=p).rev() {
            let i = j + k - p;
            let den = knots[i + p + 1 - r] - knots[i];
            let a = if den == 0.0 {
                0.0
            } else {
                (t - knots[i]) / den
            };
            d[j] = [
                (1.0 - a) * d[j - 1][0] + a * d[j][0],
                (1.0 - a) * d[j - 1][1] + a * d[j][1],
            ];
        }
    }
    d[p]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bspline_degree_one_is_the_polyline() {
        let b = BsplineProfile {
            degree: 1,
            points: vec![[1.0, 0.0], [2.0, 1.0], [2.0, 3.0]],
            knots: None,
        };
        let (p, d) = bspline(&b, 0.25);
        assert!(
            (p[0] - 1.5).abs() < 1e-12 && (p[1] - 0.5).abs() < 1e-12,
            "{p:?}"
        );
        assert!(
            (d[0] - 2.0).abs() < 1e-12 && (d[1] - 2.0).abs() < 1e-12,
            "{d:?}"
        );
        let (p, _) = bspline(&b, 1.0);
        assert_eq!(p, [2.0, 3.0]);
    }

    #[test]
    fn clamped_cubic_bspline_with_four_points_is_the_bezier() {
        let pts = vec![[0.0, 0.0], [1.0, 2.0], [3.0, 2.0], [4.0, 0.0]];
        let b = BsplineProfile {
            degree: 3,
            points: pts.clone(),
            knots: None,
        };
        for t in [0.0, 0.3, 0.7, 1.0] {
            let (p1, d1) = bspline(&b, t);
            let (p2, d2) = bezier(&pts, t);
            for k in 0..2 {
                assert!(
                    (p1[k] - p2[k]).abs() < 1e-9 && (d1[k] - d2[k]).abs() < 1e-9,
                    "t={t}: {p1:?} {p2:?} {d1:?} {d2:?}"
                );
            }
        }
    }
}
