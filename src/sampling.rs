//! Warping functions: uniform numbers in [0, 1)² mapped to points and directions with known
//! densities, and the weights that combine two sampling strategies (pbrt-v4 ch. A.5, 2.4).

use crate::math::{Vec2, Vec3};

/// Shirley–Chiu concentric map of the unit square to the unit disk (area-preserving).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    let (sin, cos) = crate::lanes::math::sin_cos(theta);
    Vec2::new(r * cos, r * sin)
}

/// Cosine-weighted hemisphere direction (Malley's method); pdf = cos θ / π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    Vec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// Power heuristic with β = 2 (Veach 1997).
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a == 0.0 {
        0.0
    } else if a.is_infinite() {
        1.0
    } else {
        a / (a + b)
    }
}

/// A piecewise-constant distribution on [0, 1) with one cell per weight (pbrt-v4
/// `PiecewiseConstant1D`), sampled by inverting its CDF continuously inside the cell.
///
/// The cell of u is found through a guide table (the cutpoint method of Chen and Asau 1974):
/// `guide[k]` is the cell of u = k/G for G a power of two, so the cell of any u lies between
/// `guide[⌊uG⌋]` and `guide[⌊uG⌋ + 1]` and is searched for only there — usually among a cell
/// or two instead of a binary search over the whole CDF (an environment map's rows have 1024
/// cells). Both k/G and ⌊uG⌋ are exact in floating point, so the cell is exactly the one the
/// full search finds.
#[derive(Debug, Clone)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    guide: Vec<u32>,
    integral: f32,
}

impl Distribution1D {
    /// The distribution proportional to the (non-negative) `weights`; uniform when they are
    /// all zero.
    pub fn new(weights: &[f32]) -> Distribution1D {
        let n = weights.len().max(1);
        let func: Vec<f32> = weights.iter().map(|w| w.max(0.0)).collect();
        let mut cdf = vec![0.0f32; n + 1];
        let mut sum = 0.0f64;
        for (i, f) in func.iter().enumerate() {
            sum += f64::from(*f) / n as f64;
            cdf[i + 1] = sum as f32;
        }
        let integral = sum as f32;
        if integral > 0.0 {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        cdf[n] = 1.0;
        let g = n.next_power_of_two();
        // One merge-like walk: the cell of k/G never decreases with k.
        let mut cell = 0;
        let guide = (0..=g)
            .map(|k| {
                let u = k as f32 / g as f32;
                while cell + 1 < n && cdf[cell + 1] <= u {
                    cell += 1;
                }
                cell as u32
            })
            .collect();
        Distribution1D {
            func,
            cdf,
            guide,
            integral,
        }
    }

    /// The last cell whose CDF start is ≤ u (cell 0 for u below every start), by binary search.
    fn cell_by_search(cdf: &[f32], u: f32) -> usize {
        let n = cdf.len() - 1;
        cdf[..n].partition_point(|&c| c <= u).saturating_sub(1)
    }

    /// [`Distribution1D::cell_by_search`] through the guide table.
    #[inline]
    fn cell(&self, u: f32) -> usize {
        if u.is_nan() || u < 0.0 {
            return Self::cell_by_search(&self.cdf, u);
        }
        let g = self.guide.len() - 1;
        // u ∈ [k/G, (k+1)/G), exactly (G is a power of two).
        let k = ((u * g as f32) as usize).min(g - 1);
        let (lo, hi) = (self.guide[k] as usize, self.guide[k + 1] as usize);
        // cdf[lo] ≤ k/G ≤ u, and the cell of u is at most hi.
        lo + self.cdf[lo + 1..=hi].partition_point(|&c| c <= u)
    }

    /// The integral of the weights over [0, 1) (their mean).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    fn cells(&self) -> usize {
        self.cdf.len() - 1
    }

    /// Samples x ∈ [0, 1): returns x, its density and its cell.
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.cells();
        let i = self.cell(u);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = ((i as f32 + du) / n as f32).min(1.0 - f32::EPSILON);
        (x, self.pdf_of_cell(i), i)
    }

    fn pdf_of_cell(&self, i: usize) -> f32 {
        if self.integral > 0.0 {
            self.func.get(i).map_or(0.0, |f| f / self.integral)
        } else {
            1.0
        }
    }

    /// The density at x ∈ [0, 1).
    pub fn pdf(&self, x: f32) -> f32 {
        let n = self.cells();
        self.pdf_of_cell(((x * n as f32) as usize).min(n - 1))
    }
}

/// A piecewise-constant distribution on [0, 1)² over a w × h grid of weights (row-major, row 0
/// at y = 0): the marginal over rows, then the conditional of the chosen row (pbrt-v4
/// `PiecewiseConstant2D`).
#[derive(Debug, Clone)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// The distribution proportional to `weights` (w × h, row-major).
    pub fn new(weights: &[f32], w: usize, h: usize) -> Distribution2D {
        let rows: Vec<Distribution1D> = (0..h)
            .map(|r| Distribution1D::new(&weights[r * w..(r + 1) * w]))
            .collect();
        let marginal = Distribution1D::new(&rows.iter().map(|r| r.integral()).collect::<Vec<_>>());
        Distribution2D { rows, marginal }
    }

    /// The integral of the weights over [0, 1)² (their mean).
    pub fn integral(&self) -> f32 {
        self.marginal.integral()
    }

    /// Samples (x, y) ∈ [0, 1)² from `u` (u.y picks the row, u.x the column): the point and
    /// its density; `None` where the density is zero.
    pub fn sample(&self, u: Vec2) -> Option<(Vec2, f32)> {
        let (y, pdf_y, row) = self.marginal.sample(u.y);
        let (x, pdf_x, _) = self.rows[row].sample(u.x);
        let pdf = pdf_x * pdf_y;
        (pdf > 0.0).then_some((Vec2::new(x, y), pdf))
    }

    /// The density at (x, y).
    pub fn pdf(&self, p: Vec2) -> f32 {
        let h = self.rows.len();
        let row = ((p.y * h as f32) as usize).min(h - 1);
        self.rows[row].pdf(p.x) * self.marginal.pdf(p.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The guide table finds exactly the cell the binary search finds: for weights with runs of
    /// zeros (flat CDF stretches), a spike, sizes that are and are not powers of two, at random
    /// u, at every CDF value and the floats next to it, and at 0 and just below 1.
    #[test]
    fn the_guide_table_finds_the_searched_cell() {
        let mut state = 5u64;
        for n in [1usize, 2, 3, 7, 64, 100, 1024, 1000] {
            let weights: Vec<f32> = (0..n)
                .map(|i| {
                    let r = crate::sampler::test_lcg(&mut state);
                    if r < 0.3 {
                        0.0
                    } else if i == n / 2 {
                        1e5
                    } else {
                        r
                    }
                })
                .collect();
            let d = Distribution1D::new(&weights);
            let mut us: Vec<f32> = (0..20_000)
                .map(|_| crate::sampler::test_lcg(&mut state))
                .collect();
            for &c in &d.cdf {
                us.extend([
                    c,
                    f32::from_bits(c.to_bits().saturating_sub(1)),
                    f32::from_bits(c.to_bits() + 1),
                ]);
            }
            us.extend([0.0, 1.0 - f32::EPSILON / 2.0, -1.0, 1.5]);
            for u in us {
                assert_eq!(
                    d.cell(u),
                    Distribution1D::cell_by_search(&d.cdf, u),
                    "n {n}, u {u}"
                );
            }
            let g = d.guide.len() - 1;
            for (k, &cell) in d.guide.iter().enumerate() {
                let u = k as f32 / g as f32;
                assert_eq!(
                    cell as usize,
                    Distribution1D::cell_by_search(&d.cdf, u),
                    "guide {k}"
                );
            }
        }
    }
}
