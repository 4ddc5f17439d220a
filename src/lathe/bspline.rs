//! B-spline → Bézier decomposition by knot insertion (Boehm 1980, "Inserting new knots into
//! B-spline curves", CAD 12(4)): inserting every knot of the traced domain until it has
//! multiplicity ≥ p makes the control polygon of each non-empty knot span the Bézier control
//! polygon of that span (Piegl & Tiller, The NURBS Book, §5.6).

use glam::DVec2;

/// Inserts the knot value `u` once into the degree-`p` B-spline (`knots`, `points`), in place.
/// Requires knots[p] ≤ u ≤ knots[points.len()].
fn insert_knot(p: usize, knots: &mut Vec<f64>, points: &mut Vec<DVec2>, u: f64) {
    let n = points.len();
    // k: the span index with knots[k] ≤ u < knots[k+1], restricted to [p, n−1] so that the
    // curve end (u = knots[n]) uses the last non-empty span.
    let mut k = p;
    while k + 1 < n && knots[k + 1] <= u {
        k += 1;
    }
    let mut new_points = Vec::with_capacity(n + 1);
    for i in 0..=n {
        if i + p <= k {
            new_points.push(points[i]);
        } else if i > k {
            new_points.push(points[i - 1]);
        } else {
            let denom = knots[i + p] - knots[i];
            let alpha = if denom > 0.0 {
                (u - knots[i]) / denom
            } else {
                0.0
            };
            new_points.push((1.0 - alpha) * points[i - 1] + alpha * points[i]);
        }
    }
    knots.insert(k + 1, u);
    *points = new_points;
}

/// One Bézier piece of a decomposed B-spline: its control points (degree `points.len() − 1`)
/// and the knot interval it covers.
#[derive(Debug, Clone)]
pub struct BezierSpan {
    /// Bézier control points.
    pub points: Vec<DVec2>,
    /// Knot value at the start of the span.
    pub u0: f64,
    /// Knot value at the end of the span.
    pub u1: f64,
}

/// Decomposes a validated B-spline (degree `p`, `points`, `knots` of length n + p + 1,
/// non-decreasing, knots\[p\] < knots\[n\]) into Bézier spans covering \[knots\[p\], knots\[n\]\].
pub fn decompose(p: usize, points: &[DVec2], knots: &[f64]) -> Vec<BezierSpan> {
    let n = points.len();
    let (start, end) = (knots[p], knots[n]);
    let mut k: Vec<f64> = knots.to_vec();
    let mut pts: Vec<DVec2> = points.to_vec();
    // Distinct knot values inside the traced domain (ends included).
    let mut values: Vec<f64> = knots
        .iter()
        .copied()
        .filter(|&u| u >= start && u <= end)
        .collect();
    values.dedup();
    for &u in &values {
        loop {
            let mult = k.iter().filter(|&&x| x == u).count();
            if mult >= p {
                break;
            }
            insert_knot(p, &mut k, &mut pts, u);
        }
    }
    let mut spans = Vec::new();
    let n2 = pts.len();
    for s in p..n2 {
        if k[s + 1] > k[s] && k[s] >= start && k[s + 1] <= end {
            spans.push(BezierSpan {
                points: pts[s - p..=s].to_vec(),
                u0: k[s],
                u1: k[s + 1],
            });
        }
    }
    spans
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cox–de Boor evaluation (de Boor 1972), independent of the decomposition.
    fn de_boor(p: usize, points: &[DVec2], knots: &[f64], u: f64) -> DVec2 {
        let n = points.len();
        let mut k = p;
        while k + 1 < n && knots[k + 1] <= u {
            k += 1;
        }
        let mut d: Vec<DVec2> = (0..=p).map(|j| points[j + k - p]).collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = j + k - p;
                let denom = knots[i + p + 1 - r] - knots[i];
                let a = if denom > 0.0 {
                    (u - knots[i]) / denom
                } else {
                    0.0
                };
                d[j] = (1.0 - a) * d[j - 1] + a * d[j];
            }
        }
        d[p]
    }

    #[test]
    fn spans_reproduce_the_spline_including_unclamped_and_repeated_knots() {
        let pts: Vec<DVec2> = [
            (0.0, 0.0),
            (1.0, 0.2),
            (1.4, 1.0),
            (0.6, 1.8),
            (0.9, 2.5),
            (0.0, 3.0),
        ]
        .iter()
        .map(|&(x, y)| DVec2::new(x, y))
        .collect();
        for knots in [
            vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.7, 1.0, 1.0, 1.0, 1.0],
            vec![0.0, 0.1, 0.2, 0.3, 0.5, 0.5, 0.8, 0.9, 1.0, 1.2],
            vec![0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0],
        ] {
            let spans = decompose(3, &pts, &knots);
            assert!(!spans.is_empty());
            assert_eq!(spans[0].u0, knots[3]);
            assert_eq!(spans.last().unwrap().u1, knots[6]);
            for s in &spans {
                for j in 0..=10 {
                    let t = j as f64 / 10.0;
                    let u = s.u0 + t * (s.u1 - s.u0);
                    let want = de_boor(3, &pts, &knots, u);
                    let got = crate::lathe::bernstein::eval_curve(&s.points, t);
                    assert!(
                        (want - got).length() < 1e-12,
                        "{knots:?} u={u} {want} {got}"
                    );
                }
            }
        }
    }
}
