//! Bernstein-basis polynomials on [0, 1]: evaluation and splitting (de Casteljau), products,
//! and robust isolation of real roots by recursive subdivision with the convex-hull property.
//!
//! A polynomial of degree m in Bernstein form is f(t) = Σ bᵢ C(m,i) tⁱ (1−t)^(m−i). Its graph
//! lies in the convex hull of the control points (i/m, bᵢ), so when every bᵢ has the same strict
//! sign f has no root in [0, 1], and when the bᵢ are strictly monotone f is monotone (its
//! derivative has coefficients m(bᵢ₊₁ − bᵢ)). Subdividing with de Casteljau's algorithm shrinks
//! the hull towards the graph, which gives a root isolation that cannot skip a sign change
//! (Lane & Riesenfeld 1981, "Bounds on a polynomial"; the same hull argument underlies Bézier
//! clipping, Nishita, Sederberg & Kakimoto 1990, "Ray tracing trimmed rational surface
//! patches", SIGGRAPH '90).

use glam::DVec2;

/// Highest curve degree supported (the schema allows B-spline degrees up to 16).
pub const MAX_DEGREE: usize = 16;
/// Most control points of a curve segment.
pub const MAX_POINTS: usize = MAX_DEGREE + 1;
/// Most coefficients of a product of two segment polynomials (degree 2·16).
pub const MAX_COEFFS: usize = 2 * MAX_DEGREE + 1;

/// Binomial coefficient C(n, k) as f64 (exact for the small n used here).
pub fn binomial(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    let k = k.min(n - k);
    let mut r = 1.0f64;
    for i in 0..k {
        r = r * (n - i) as f64 / (i + 1) as f64;
    }
    r.round()
}

/// Table of binomial coefficients C(n, k) for n ≤ 2·MAX_DEGREE, built once.
pub struct Binomials {
    table: [[f64; MAX_COEFFS]; MAX_COEFFS],
}

impl Binomials {
    /// Builds the table.
    pub fn new() -> Self {
        let mut table = [[0.0; MAX_COEFFS]; MAX_COEFFS];
        for (n, row) in table.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate().take(n + 1) {
                *v = binomial(n, k);
            }
        }
        Binomials { table }
    }
    /// C(n, k).
    #[inline]
    pub fn c(&self, n: usize, k: usize) -> f64 {
        self.table[n][k]
    }
}

impl Default for Binomials {
    fn default() -> Self {
        Self::new()
    }
}

/// The shared binomial table.
pub fn binomials() -> &'static Binomials {
    static TABLE: std::sync::OnceLock<Binomials> = std::sync::OnceLock::new();
    TABLE.get_or_init(Binomials::new)
}

/// Evaluates a scalar Bernstein polynomial and its derivative at `t` (de Casteljau).
pub fn eval_with_derivative(b: &[f64], t: f64) -> (f64, f64) {
    value_and_derivative(b, t)
}

/// A Bernstein coefficient: a scalar (`f64`) or a point (`DVec2`), combined by de Casteljau's
/// affine steps.
trait Coefficient:
    Copy
    + Default
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<f64, Output = Self>
{
}

impl<T> Coefficient for T where
    T: Copy
        + Default
        + std::ops::Add<Output = T>
        + std::ops::Sub<Output = T>
        + std::ops::Mul<f64, Output = T>
{
}

/// Value and first derivative at `t` of Bernstein coefficients (points or scalars): de
/// Casteljau down to the last two points, whose lerp is the value and whose difference times the
/// degree is the derivative.
fn value_and_derivative<T: Coefficient>(c: &[T], t: f64) -> (T, T) {
    // The common sizes (a cubic profile's H has 7 coefficients) use a small work array: the
    // full one costs a 33-value fill and copy per evaluation, more than the arithmetic.
    if c.len() <= 8 {
        casteljau::<T, 8>(c, t)
    } else {
        casteljau::<T, MAX_COEFFS>(c, t)
    }
}

/// [`value_and_derivative`] with a work array of `N ≥ c.len()` values.
#[inline(always)]
fn casteljau<T: Coefficient, const N: usize>(c: &[T], t: f64) -> (T, T) {
    let m = c.len() - 1;
    let s = 1.0 - t;
    match m {
        0 => return (c[0], T::default()),
        1 => return (c[0] * s + c[1] * t, c[1] - c[0]),
        _ => {}
    }
    // The first level reads the coefficients (no copy), the next ones work in place over a
    // shrinking prefix with exclusive ranges (no bounds checks); the same operations in the
    // same order as a copy followed by the textbook loop.
    let mut buf = [T::default(); N];
    let w = &mut buf[..m];
    for i in 0..m {
        w[i] = c[i] * s + c[i + 1] * t;
    }
    for len in (3..=m).rev() {
        let w = &mut w[..len];
        for i in 0..len - 1 {
            w[i] = w[i] * s + w[i + 1] * t;
        }
    }
    (w[0] * s + w[1] * t, (w[1] - w[0]) * m as f64)
}

/// Evaluates a planar Bézier curve at `t` (de Casteljau).
pub fn eval_curve(p: &[DVec2], t: f64) -> DVec2 {
    eval_curve_with_derivative(p, t).0
}

/// Evaluates a planar Bézier curve and its first derivative at `t`.
pub fn eval_curve_with_derivative(p: &[DVec2], t: f64) -> (DVec2, DVec2) {
    value_and_derivative(p, t)
}

/// Splits Bernstein coefficients (points or scalars) at `t` into those of the pieces over
/// [0, t] and [t, 1] (de Casteljau). `left` and `right` must hold `c.len()` values.
fn split<T: Coefficient>(c: &[T], t: f64, left: &mut [T], right: &mut [T]) {
    let m = c.len() - 1;
    let mut w = [T::default(); MAX_COEFFS];
    w[..=m].copy_from_slice(c);
    let s = 1.0 - t;
    left[0] = w[0];
    right[m] = w[m];
    for level in 1..=m {
        for i in 0..=(m - level) {
            w[i] = w[i] * s + w[i + 1] * t;
        }
        left[level] = w[0];
        right[m - level] = w[m - level];
    }
}

/// Splits a planar Bézier curve at `t` into the control points of its pieces over [0, t] and
/// [t, 1] (de Casteljau). `left` and `right` must hold `p.len()` points.
pub fn split_curve(p: &[DVec2], t: f64, left: &mut [DVec2], right: &mut [DVec2]) {
    split(p, t, left, right);
}

/// Splits a scalar Bernstein polynomial at `t` (de Casteljau), like [`split_curve`].
pub fn split_scalar(b: &[f64], t: f64, left: &mut [f64], right: &mut [f64]) {
    split(b, t, left, right);
}

/// Solves f(t) = 0 on [lo, hi] where f changes sign (or vanishes at an end) and is monotone:
/// safeguarded Newton iteration that falls back to bisection whenever a Newton step leaves the
/// bracket or fails to halve the residual (the "rtsafe" strategy, Press et al., Numerical
/// Recipes §9.4). Converges to full f64 precision.
pub fn solve_bracketed(f: impl Fn(f64) -> (f64, f64), lo: f64, hi: f64) -> f64 {
    let (flo, _) = f(lo);
    let (fhi, _) = f(hi);
    solve_bracketed_from(f, lo, hi, flo, fhi)
}

/// [`solve_bracketed`] with the end values f(lo) and f(hi) already known (for a Bernstein
/// polynomial on [0, 1] they are its first and last coefficients, exactly what de Casteljau
/// would return there), saving two evaluations per root.
pub fn solve_bracketed_from(
    f: impl Fn(f64) -> (f64, f64),
    mut lo: f64,
    mut hi: f64,
    flo: f64,
    fhi: f64,
) -> f64 {
    if flo == 0.0 {
        return lo;
    }
    if fhi == 0.0 {
        return hi;
    }
    let lo_negative = flo < 0.0;
    // Start from the secant (regula falsi) point: exact for linear f and usually close.
    let mut t = lo + (hi - lo) * (flo / (flo - fhi));
    if !(t > lo && t < hi) {
        t = 0.5 * (lo + hi);
    }
    let mut last_abs = f64::INFINITY;
    for _ in 0..100 {
        let (v, dv) = f(t);
        if v == 0.0 {
            return t;
        }
        // Newton's step is below the resolution of t: converged. (Checked before the bracket
        // moves to t, after which a step landing on t itself counts as leaving the bracket and
        // bisection would take over down to a 4-ulp bracket: measured 26 evaluations per root
        // on the vase before this exit.)
        if dv != 0.0 && (v / dv).abs() <= 2.0 * f64::EPSILON * t.abs() {
            return t;
        }
        if (v < 0.0) == lo_negative {
            lo = t;
        } else {
            hi = t;
        }
        if hi - lo <= 4.0 * f64::EPSILON * hi.abs().max(lo.abs()).max(f64::MIN_POSITIVE) {
            return 0.5 * (lo + hi);
        }
        let newton = t - v / dv;
        let good = dv != 0.0 && newton > lo && newton < hi && v.abs() < 0.5 * last_abs;
        last_abs = v.abs();
        let next = if good { newton } else { 0.5 * (lo + hi) };
        if (next - t).abs() <= 2.0 * f64::EPSILON * t.abs() {
            return next;
        }
        t = next;
    }
    0.5 * (lo + hi)
}

/// The roots in the open interval (0, 1) where a Bernstein polynomial changes sign, found by
/// subdivision. Coefficients with |bᵢ| ≤ `zero_tol` count as zero. Roots where the polynomial
/// only touches zero are not reported (they do not change monotonicity or sign, which is what
/// the callers split curves at). Used while building a lathe, not per ray.
pub fn roots_in_unit_interval(b: &[f64], zero_tol: f64) -> Vec<f64> {
    let mut out = Vec::new();
    if b.len() < 2 {
        return out;
    }
    let snapped: Vec<f64> = b
        .iter()
        .map(|&v| if v.abs() <= zero_tol { 0.0 } else { v })
        .collect();
    let m = b.len() - 1;
    let mut stack: Vec<(Vec<f64>, f64, f64, u32)> = vec![(snapped, 0.0, 1.0, 0)];
    while let Some((c, a, w, depth)) = stack.pop() {
        let min = c.iter().fold(f64::INFINITY, |x, v| x.min(*v));
        let max = c.iter().fold(f64::NEG_INFINITY, |x, v| x.max(*v));
        if min >= 0.0 || max <= 0.0 {
            continue; // no sign change possible (convex-hull property)
        }
        let increasing = c.windows(2).all(|p| p[1] > p[0]);
        let decreasing = c.windows(2).all(|p| p[1] < p[0]);
        if (increasing || decreasing) && c[0] * c[m] < 0.0 {
            let local = solve_bracketed(|t| eval_with_derivative(&c, t), 0.0, 1.0);
            out.push(a + w * local);
            continue;
        }
        if depth >= 45 {
            if c[0] * c[m] < 0.0 {
                out.push(a + 0.5 * w);
            }
            continue;
        }
        let mut l = vec![0.0; m + 1];
        let mut r = vec![0.0; m + 1];
        split_scalar(&c, 0.5, &mut l, &mut r);
        stack.push((r, a + 0.5 * w, 0.5 * w, depth + 1));
        stack.push((l, a, 0.5 * w, depth + 1));
    }
    out.sort_by(f64::total_cmp);
    out.dedup_by(|x, y| (*x - *y).abs() < 1e-12);
    out.retain(|&t| t > 1e-12 && t < 1.0 - 1e-12);
    out
}

/// Product of two Bernstein polynomials of degrees m and n as one of degree m + n:
/// (fg)ₖ = Σᵢ₊ⱼ₌ₖ C(m,i) C(n,j) / C(m+n,k) · fᵢ gⱼ.
pub fn product(f: &[f64], g: &[f64], out: &mut [f64]) {
    let bin = binomials();
    let m = f.len() - 1;
    let n = g.len() - 1;
    for (k, o) in out.iter_mut().enumerate().take(m + n + 1) {
        let mut acc = 0.0;
        let lo = k.saturating_sub(n);
        let hi = k.min(m);
        for i in lo..=hi {
            acc += bin.c(m, i) * bin.c(n, k - i) * f[i] * g[k - i];
        }
        *o = acc / bin.c(m + n, k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn power_to_value(b: &[f64], t: f64) -> f64 {
        let m = b.len() - 1;
        (0..=m)
            .map(|i| b[i] * binomial(m, i) * t.powi(i as i32) * (1.0 - t).powi((m - i) as i32))
            .sum()
    }

    #[test]
    fn de_casteljau_matches_the_bernstein_sum() {
        let b = [0.3, -1.0, 2.0, 0.5, -0.25];
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let (v, _) = eval_with_derivative(&b, t);
            assert!((v - power_to_value(&b, t)).abs() < 1e-14);
        }
    }

    #[test]
    fn product_is_pointwise_product() {
        let f = [1.0, -2.0, 0.5];
        let g = [0.25, 3.0, -1.0, 2.0];
        let mut out = [0.0; 6];
        product(&f, &g, &mut out);
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let want = power_to_value(&f, t) * power_to_value(&g, t);
            assert!((power_to_value(&out, t) - want).abs() < 1e-13);
        }
    }

    #[test]
    fn roots_of_a_cubic_with_three_close_roots_are_all_found() {
        // (t − 0.3)(t − 0.3001)(t − 0.8) written in Bernstein form via sampling-free conversion:
        // build from linear factors with `product`.
        let lin = |r: f64| [-r, 1.0 - r];
        let mut q = [0.0; 3];
        product(&lin(0.3), &lin(0.3001), &mut q);
        let mut c = [0.0; 4];
        product(&q, &lin(0.8), &mut c);
        let roots = roots_in_unit_interval(&c, 0.0);
        assert_eq!(roots.len(), 3, "{roots:?}");
        for (got, want) in roots.iter().zip([0.3, 0.3001, 0.8]) {
            assert!((got - want).abs() < 1e-12);
        }
    }
}
