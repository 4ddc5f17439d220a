//! An independent, slow reference intersector for lathes, used only by tests and benchmarks.
//!
//! It shares no code with the production path: it evaluates the profile directly (Bernstein
//! sums for Bézier curves, Cox–de Boor for B-splines on the original knot vector), samples it
//! densely (knots included, so corners are samples) and intersects the ray in closed form with
//! every revolved chord between consecutive samples (a cone frustum: a quadratic in s). The
//! chords deviate from the curve by O(h²) (about 1e-8 of the size with the sample counts the
//! tests use), far inside the 1e-6 ambiguity band, so hit/miss decisions are reliable outside
//! it; the nearest chord hit is then refined by Newton's method on the true curve.

use glam::{DVec2, DVec3};

use crate::sampler::mix64;

/// Profile description, the same plain data the production constructors take.
#[derive(Clone, Debug)]
pub enum RefCurve {
    /// Bézier control points.
    Bezier(Vec<DVec2>),
    /// Degree, control points, knots.
    Bspline(usize, Vec<DVec2>, Vec<f64>),
}

/// A hit found by the reference.
#[derive(Clone, Copy, Debug)]
pub struct RefHit {
    /// Ray parameter (direction as given).
    pub s: f64,
    /// Normalised curve parameter.
    pub v: f64,
    /// Unit normal by the orientation rule.
    pub normal: DVec3,
    /// |profile derivative| at the hit (small at cusps, where normals are ill-defined).
    pub speed: f64,
    /// Radius of the hit point.
    pub radius: f64,
}

/// The reference intersector for one profile.
pub struct Reference {
    curve: RefCurve,
    domain: (f64, f64),
    samples: Vec<(f64, DVec2)>,
    /// Length scale of the profile.
    pub scale: f64,
}

/// Real roots of qa s² + 2 qb s + qc = 0 (NaN where absent), cancellation-free; `size` is the
/// magnitude below which qa counts as zero.
fn solve_quadratic(qa: f64, qb: f64, qc: f64, size: f64) -> [f64; 2] {
    if qa.abs() <= 1e-14 * size {
        return [
            if qb != 0.0 {
                -qc / (2.0 * qb)
            } else {
                f64::NAN
            },
            f64::NAN,
        ];
    }
    let disc = qb * qb - qa * qc;
    if disc < 0.0 {
        return [f64::NAN; 2];
    }
    let q = -(qb + disc.sqrt().copysign(qb));
    [q / qa, if q != 0.0 { qc / q } else { f64::NAN }]
}

fn binom(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

impl Reference {
    /// Samples the curve with `n` uniform parameters plus all knots.
    pub fn new(curve: RefCurve, n: usize) -> Reference {
        let domain = match &curve {
            RefCurve::Bezier(_) => (0.0, 1.0),
            RefCurve::Bspline(p, pts, k) => (k[*p], k[pts.len()]),
        };
        let mut params: Vec<f64> = (0..=n)
            .map(|i| domain.0 + (domain.1 - domain.0) * i as f64 / n as f64)
            .collect();
        if let RefCurve::Bspline(_, _, k) = &curve {
            params.extend(k.iter().copied().filter(|&u| u > domain.0 && u < domain.1));
        }
        params.sort_by(f64::total_cmp);
        params.dedup();
        let mut r = Reference {
            curve,
            domain,
            samples: Vec::new(),
            scale: 0.0,
        };
        r.samples = params.iter().map(|&u| (u, r.eval(u))).collect();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for (_, p) in &r.samples {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        r.scale = (hi - lo).max_element().max(hi.x.abs()).max(lo.x.abs());
        r
    }

    /// Curve point at parameter u.
    pub fn eval(&self, u: f64) -> DVec2 {
        match &self.curve {
            RefCurve::Bezier(p) => {
                let n = p.len() - 1;
                (0..=n)
                    .map(|i| p[i] * binom(n, i) * u.powi(i as i32) * (1.0 - u).powi((n - i) as i32))
                    .sum()
            }
            RefCurve::Bspline(deg, pts, knots) => {
                let p = *deg;
                let n = pts.len();
                let mut k = p;
                while k + 1 < n && knots[k + 1] <= u {
                    k += 1;
                }
                let mut d: Vec<DVec2> = (0..=p).map(|j| pts[j + k - p]).collect();
                for r in 1..=p {
                    for j in (r..=p).rev() {
                        let i = j + k - p;
                        let den = knots[i + p + 1 - r] - knots[i];
                        let a = if den > 0.0 { (u - knots[i]) / den } else { 0.0 };
                        d[j] = (1.0 - a) * d[j - 1] + a * d[j];
                    }
                }
                d[p]
            }
        }
    }

    /// One-sided derivative estimate that stays inside the knot span containing u.
    fn derivative(&self, u: f64) -> DVec2 {
        let h = 1e-7 * (self.domain.1 - self.domain.0);
        let (a, b) = ((u - h).max(self.domain.0), (u + h).min(self.domain.1));
        (self.eval(b) - self.eval(a)) / (b - a)
    }

    /// Nearest hit with s in (s_min, s_max): the ray against every revolved sample chord (a
    /// cone frustum, solved in closed form), then Newton on the true curve from that hit.
    pub fn intersect(&self, o: DVec3, dir: DVec3, s_min: f64, s_max: f64) -> Option<RefHit> {
        let len = dir.length();
        let d = dir / len;
        let a = d.x * d.x + d.z * d.z;
        let b = o.x * d.x + o.z * d.z;
        let c = o.x * o.x + o.z * o.z;
        let (lo, hi) = (s_min * len, s_max * len);
        let mut best: Option<(f64, f64)> = None; // (s, u)
        for w in self.samples.windows(2) {
            let ((u1, p1), (u2, p2)) = (w[0], w[1]);
            let (r1, r2) = (p1.x.abs(), p2.x.abs());
            let mut consider = |s: f64, frac: f64| {
                if s > lo
                    && s < hi
                    && (-1e-9..=1.0 + 1e-9).contains(&frac)
                    && best.is_none_or(|bb| s < bb.0)
                {
                    best = Some((s, u1 + frac.clamp(0.0, 1.0) * (u2 - u1)));
                }
            };
            if p1.y == p2.y {
                if d.y != 0.0 {
                    let s = (p1.y - o.y) / d.y;
                    let rho = (a * s * s + 2.0 * b * s + c).max(0.0).sqrt();
                    if r1 != r2 {
                        consider(s, (rho - r1) / (r2 - r1));
                    }
                }
                continue;
            }
            if d.y == 0.0 {
                // Constant height: the chord is crossed where y = o_y, at radius r.
                let frac = (o.y - p1.y) / (p2.y - p1.y);
                if !(-1e-9..=1.0 + 1e-9).contains(&frac) {
                    continue;
                }
                let r = r1 + frac * (r2 - r1);
                let s0 = -b / a;
                let h2 = (r * r - (c - b * b / a)) / a;
                if h2 >= 0.0 {
                    consider(s0 - h2.sqrt(), frac);
                    consider(s0 + h2.sqrt(), frac);
                }
                continue;
            }
            if (r2 - r1).abs() > (p2.y - p1.y).abs() {
                // A flat-ish chord: height as a function of radius, y = γ + δ r (|δ| < 1). The ray
                // is within the chord's radii on at most two s-intervals (from ρ(s) = r₁, r₂);
                // on each, φ(s) = o_y + s d_y − γ − δ ρ(s) is bisected where it changes sign. No
                // squaring, so no cancellation.
                let delta = (p2.y - p1.y) / (r2 - r1);
                let gamma = p1.y - delta * r1;
                let rho = |s: f64| (a * s * s + 2.0 * b * s + c).max(0.0).sqrt();
                let phi = |s: f64| o.y + s * d.y - gamma - delta * rho(s);
                let (rmin, rmax) = (r1.min(r2), r1.max(r2));
                let intervals: Vec<(f64, f64)> = if a < 1e-24 {
                    let r = c.sqrt();
                    if r >= rmin && r <= rmax && d.y != 0.0 {
                        let s = (gamma + delta * r - o.y) / d.y;
                        consider(s, (r - r1) / (r2 - r1));
                    }
                    Vec::new()
                } else {
                    let s0 = -b / a;
                    let cross = o.x * d.z - o.z * d.x;
                    let rho0sq = cross * cross / a;
                    let h = |r: f64| {
                        if r * r >= rho0sq {
                            Some(((r * r - rho0sq) / a).sqrt())
                        } else {
                            None
                        }
                    };
                    match (h(rmin), h(rmax)) {
                        (_, None) => Vec::new(),
                        (None, Some(hx)) => vec![(s0 - hx, s0 + hx)],
                        (Some(hn), Some(hx)) => vec![(s0 - hx, s0 - hn), (s0 + hn, s0 + hx)],
                    }
                };
                // φ is concave or convex (ρ is convex), so its one extremum splits each interval
                // into monotone parts: φ′ = 0 where d_y ρ(s) = δ a (s − s₀).
                let extremum = if a >= 1e-24 && delta * delta * a > d.y * d.y {
                    let s0 = -b / a;
                    let cross = o.x * d.z - o.z * d.x;
                    let rho0sq = cross * cross / a;
                    let w = (d.y * d.y * rho0sq / (a * (delta * delta * a - d.y * d.y))).sqrt();
                    Some(s0 + w.copysign(d.y * delta))
                } else {
                    None
                };
                let mut pieces: Vec<(f64, f64)> = Vec::new();
                for (l, r) in intervals {
                    match extremum {
                        Some(e) if e > l && e < r => {
                            pieces.push((l, e));
                            pieces.push((e, r));
                        }
                        _ => pieces.push((l, r)),
                    }
                }
                for (mut l, mut r) in pieces {
                    let (mut fl, fr) = (phi(l), phi(r));
                    if fl == 0.0 {
                        consider(l, (rho(l) - r1) / (r2 - r1));
                        continue;
                    }
                    if fl * fr > 0.0 {
                        continue;
                    }
                    for _ in 0..200 {
                        let m = 0.5 * (l + r);
                        if m <= l || m >= r {
                            break;
                        }
                        let fm = phi(m);
                        if (fm < 0.0) == (fl < 0.0) {
                            l = m;
                            fl = fm;
                        } else {
                            r = m;
                        }
                    }
                    let s = 0.5 * (l + r);
                    consider(s, (rho(s) - r1) / (r2 - r1));
                }
                continue;
            }
            // A steep chord: radius as a function of height, r = α + β s along the ray.
            let k = (r2 - r1) / (p2.y - p1.y);
            let alpha = r1 + k * (o.y - p1.y);
            let beta = k * d.y;
            let frac_of = |s: f64| (o.y + s * d.y - p1.y) / (p2.y - p1.y);
            let roots = if a < 1e-24 {
                // Parallel to the axis: constant radius √c, linear in s.
                [
                    if beta != 0.0 {
                        (c.sqrt() - alpha) / beta
                    } else {
                        f64::NAN
                    },
                    f64::NAN,
                ]
            } else {
                solve_quadratic(
                    a - beta * beta,
                    b - alpha * beta,
                    c - alpha * alpha,
                    a + beta * beta,
                )
            };
            for s in roots {
                if s.is_finite() && alpha + beta * s >= -1e-12 * self.scale {
                    consider(s, frac_of(s));
                }
            }
        }
        let (mut s, mut u) = best?;
        // Newton on height(s) = y(u), radius(s) = |x(u)|, derivatives by central differences.
        let span = self.domain.1 - self.domain.0;
        for _ in 0..12 {
            let p = self.eval(u);
            let q = o + s * d;
            let rho = (q.x * q.x + q.z * q.z).sqrt();
            let f1 = q.y - p.y;
            let f2 = rho - p.x.abs();
            if f1 == 0.0 && f2 == 0.0 {
                break;
            }
            let dp = self.derivative(u);
            let drho = if rho > 0.0 {
                (q.x * d.x + q.z * d.z) / rho
            } else {
                0.0
            };
            let dxabs = dp.x * p.x.signum();
            let det = d.y * (-dxabs) - (-dp.y) * drho;
            if det == 0.0 || !det.is_finite() {
                break;
            }
            let ds = (f1 * (-dxabs) - (-dp.y) * f2) / det;
            let du = (d.y * f2 - drho * f1) / det;
            let (ns, nu) = (s - ds, (u - du).clamp(self.domain.0, self.domain.1));
            if (nu - u).abs() > 1e-3 * span {
                break; // left the chord's neighbourhood: keep the chord hit
            }
            s = ns;
            u = nu;
        }
        if !(s > lo && s < hi) {
            return None;
        }
        let q = o + s * d;
        let p = self.eval(u);
        let dp = self.derivative(u);
        let phi = (-q.z).atan2(q.x);
        let theta = if p.x >= 0.0 {
            phi
        } else {
            phi + std::f64::consts::PI
        };
        let n = p.x * DVec3::new(dp.y * theta.cos(), -dp.x, -dp.y * theta.sin());
        Some(RefHit {
            s: s / len,
            v: (u - self.domain.0) / (self.domain.1 - self.domain.0),
            normal: n.normalize_or_zero(),
            speed: dp.length(),
            radius: p.x.abs(),
        })
    }
}

/// Small deterministic generator (SplitMix64) for the lathe tests and benchmark, so they need no
/// extra dependency and draw the same cases.
pub struct Rng(pub u64);
impl Rng {
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (mix64(self.0) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
    /// Uniform direction on the unit sphere.
    pub fn unit(&mut self) -> DVec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        DVec3::new(r * phi.cos(), z, r * phi.sin())
    }
}
