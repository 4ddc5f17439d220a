//! Ray–lathe intersection.
//!
//! # The equation
//! Let the ray be o + s·d with |d| = 1 (directions are normalised internally), and write
//! A = d_x² + d_z², B = o_x d_x + o_z d_z. The squared distance of the ray point from the y axis
//! is ρ²(s) = A (s − s₀)² + ρ₀², with s₀ = −B/A the closest approach and
//! ρ₀² = (o_x d_z − o_z d_x)²/A its squared distance (computed from the cross product, free of
//! cancellation). The ray is at height y_c = o_y + s₀ d_y there. A profile point (x(t), y(t))
//! is hit when the ray reaches height y(t) at radius |x(t)|; eliminating s with
//! y(t) − y_c = d_y (s − s₀) gives Kajiya's (1983, "New techniques for ray tracing procedurally
//! defined objects") surface-of-revolution condition x² = ρ²(y), here as
//!
//! ```text
//!     H(t) = a·(y(t) − y_c)² − c·(x(t)² − ρ₀²) = 0,   (a, c) = (A, d_y²) / max(A, d_y²),
//! ```
//!
//! a polynomial of degree 2n in the curve parameter of a degree-n Bézier piece. Its Bernstein
//! coefficients come from the piece's control points by the Bernstein product rule, so they
//! are recomputed from the *subdivided* control points at every node of the search: the terms
//! shrink with the node and the rounding error shrinks with them, which is what lets the
//! search separate the two nearby roots of nearly horizontal rays (d_y → 0), whose H dips
//! below zero by only c·(x² − ρ₀²) ~ d_y².
//!
//! # Root isolation
//! Every node carries a rigorous bound on the rounding error of each coefficient. A node is
//! discarded when all coefficients are beyond their error bound with one sign (the convex-hull
//! property: no root), accepted as holding exactly one root when the signs of its coefficients
//! are certain and vary exactly once (Descartes' rule of signs holds for the Bernstein basis) or
//! when the coefficient differences (the derivative's coefficients) all have one sign and the
//! end values do not share a sign,
//! and otherwise split at its midpoint by de Casteljau (Lane & Riesenfeld 1981; the same hull
//! test as Bézier clipping, Nishita, Sederberg & Kakimoto 1990). Nodes are visited nearest
//! first (by the entry distance of the ray into the node's bounding annulus) and nodes farther
//! than the best hit so far are skipped, so a ray pays only for the part of the curve near its
//! first hit. An isolated root is found by safeguarded Newton (bisection fallback) and then
//! polished with two-variable Newton on the original system (height and radius equations) in
//! f64. A node that is still ambiguous at width 2⁻⁴⁰ holds a double root (a tangency); it is
//! accepted only when the polished point lies on the surface.
//!
//! # Special cases, handled explicitly
//! * **Parallel to the axis** (A ≈ 0): H degenerates to x² = C; we solve x(t) = √C (degree n,
//!   simple roots; C = 0 is the ray along the axis, which hits the poles).
//! * **Perpendicular to the axis** (|d_y| ≲ 1e-8): the ray keeps its height; solve
//!   y(t) = y_c, then the two crossings s₀ ± √((x² − ρ₀²)/A) are polished on the full system.
//! * **Through the axis** (ρ₀ ≈ 0): H factors as (√a u − √c x)(√a u + √c x) with u = y − y_c,
//!   one factor per side of the axis. A ray through a pole makes H touch zero there (a double
//!   root of H) but gives a simple root of one factor.
//! * **Flat pieces** (constant y: rings, caps): a plane intersection. **Wall pieces**
//!   (constant x: cylinders): a quadratic in s, solved in the cancellation-free form.
//! * **Cusps, extrema and axis crossings** are piece boundaries (see [`super::Lathe::new`]),
//!   so each piece is monotone in x and y; tangencies give double roots handled as above.

use super::bernstein::{
    eval_curve_with_derivative, eval_with_derivative, solve_bracketed, solve_bracketed_from,
    split_curve, MAX_COEFFS, MAX_POINTS,
};
use super::{Lathe, LatheHit, Piece, PieceKind};
use glam::{DVec2, DVec3};
use std::f64::consts::TAU;

const EPS: f64 = f64::EPSILON;
/// Subdivision depth at which an unresolved node is treated as a tangency.
const MAX_DEPTH: u32 = 40;
/// Safety cap on nodes per piece and factor (only reached by rays lying in the surface).
const NODE_BUDGET: u32 = 4096;
/// Lathes with at most this many pieces visit them sorted by entry distance (no allocation);
/// larger ones (rare, and then usually inside a BVH per piece) visit them in order.
const SMALL: usize = 64;

thread_local! {
    /// Reused node stack of the subdivision search (no allocation per ray).
    static STACK: std::cell::RefCell<Vec<Node>> = const { std::cell::RefCell::new(Vec::new()) };
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    /// Direction (almost) parallel to the axis, at radius `r`.
    Parallel { r: f64 },
    /// Direction (almost) perpendicular to the axis.
    Horizontal,
    /// The ray passes (within 1e-9 of the lathe's size) through the axis.
    ThroughAxis,
    /// Everything else.
    General,
}

/// A ray expressed in the lathe's cylindrical terms.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    o: DVec3,
    d: DVec3,
    /// |direction| as given: hit distances are divided by it on output.
    len: f64,
    s_min: f64,
    s_max: f64,
    a_xz: f64,
    b_xz: f64,
    s0: f64,
    y_c: f64,
    rho0sq: f64,
    wa: f64,
    wc: f64,
    mode: Mode,
    /// Length scale for geometric tolerances (lathe size and distance from the origin).
    tol: f64,
}

impl Frame {
    pub(crate) fn new(
        origin: DVec3,
        dir: DVec3,
        s_min: f64,
        s_max: f64,
        scale: f64,
    ) -> Option<Frame> {
        let len = dir.length();
        if !(len > 0.0 && len.is_finite() && origin.is_finite()) || s_max.is_nan() || s_min.is_nan()
        {
            return None;
        }
        let d = dir / len;
        let a = d.x * d.x + d.z * d.z;
        let b = origin.x * d.x + origin.z * d.z;
        let c = origin.x * origin.x + origin.z * origin.z;
        let tol = 1e-9 * scale + 4e-15 * origin.length();
        let (s0, y_c, rho0sq, mode) = if a <= 1e-24 {
            (0.0, origin.y, c, Mode::Parallel { r: c.sqrt() })
        } else {
            let s0 = -b / a;
            let cross = origin.x * d.z - origin.z * d.x;
            let rho0sq = cross * cross / a;
            let y_c = origin.y + s0 * d.y;
            let mode = if d.y * d.y <= 1e-16 * a {
                Mode::Horizontal
            } else if rho0sq <= (1e-9 * scale) * (1e-9 * scale) {
                Mode::ThroughAxis
            } else {
                Mode::General
            };
            (s0, y_c, rho0sq, mode)
        };
        let m = a.max(d.y * d.y);
        Some(Frame {
            o: origin,
            d,
            len,
            s_min: s_min * len,
            s_max: s_max * len,
            a_xz: a,
            b_xz: b,
            s0,
            y_c,
            rho0sq: if mode == Mode::ThroughAxis {
                0.0
            } else {
                rho0sq
            },
            wa: a / m,
            wc: d.y * d.y / m,
            mode,
            tol,
        })
    }

    /// Squared distance of the ray point at s from the axis.
    #[inline]
    fn rho_sq(&self, s: f64) -> f64 {
        let p = self.o + s * self.d;
        p.x * p.x + p.z * p.z
    }

    /// Range [s_lo, s_hi] ⊂ [s_min, limit] of ray parameters inside the solid annulus
    /// {r ∈ [r_lo, r_hi], y ∈ [y_lo, y_hi]}, or None. Bounds are padded by the tolerance.
    fn annulus(
        &self,
        r_lo: f64,
        r_hi: f64,
        y_lo: f64,
        y_hi: f64,
        limit: f64,
    ) -> Option<(f64, f64)> {
        let pad = self.tol;
        let (r_lo, r_hi, y_lo, y_hi) = ((r_lo - pad).max(0.0), r_hi + pad, y_lo - pad, y_hi + pad);
        let (mut lo, mut hi) = (self.s_min, limit);
        if self.d.y != 0.0 {
            let t1 = (y_lo - self.o.y) / self.d.y;
            let t2 = (y_hi - self.o.y) / self.d.y;
            lo = lo.max(t1.min(t2));
            hi = hi.min(t1.max(t2));
        } else if self.o.y < y_lo || self.o.y > y_hi {
            return None;
        }
        if lo > hi {
            return None;
        }
        if let Mode::Parallel { r } = self.mode {
            return if r >= r_lo && r <= r_hi {
                Some((lo, hi))
            } else {
                None
            };
        }
        let r_hi2 = r_hi * r_hi;
        if self.rho0sq > r_hi2 {
            return None;
        }
        let h_hi = ((r_hi2 - self.rho0sq) / self.a_xz).sqrt();
        let h_lo = if r_lo * r_lo > self.rho0sq {
            ((r_lo * r_lo - self.rho0sq) / self.a_xz).sqrt()
        } else {
            0.0
        };
        let mut out: Option<(f64, f64)> = None;
        for (a, b) in [
            (self.s0 - h_hi, self.s0 - h_lo),
            (self.s0 + h_lo, self.s0 + h_hi),
        ] {
            let (a, b) = (a.max(lo), b.min(hi));
            if a <= b {
                out = Some(match out {
                    None => (a, b),
                    Some((x, y)) => (x.min(a), y.max(b)),
                });
            }
        }
        out
    }
}

/// The best hit found so far: ray parameter (normalised units), piece, piece parameter.
#[derive(Clone, Copy, Debug)]
struct Best {
    s: f64,
    piece: usize,
    t: f64,
}

/// Which univariate polynomial a node search solves.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Equation {
    /// H(t) (degree 2n).
    Full,
    /// √a·u − σ√c·x (degree n), the factor for one side of the axis.
    AxisFactor(f64),
    /// x − r (degree n).
    Radius(f64),
    /// u = y − y_c (degree n).
    Height,
}

#[derive(Clone, Copy)]
struct Node {
    pts: [DVec2; MAX_POINTS],
    a: f64,
    w: f64,
    depth: u32,
    s_lo: f64,
}

fn hull(pts: &[DVec2]) -> (f64, f64, f64, f64) {
    let mut lo = pts[0];
    let mut hi = pts[0];
    for p in &pts[1..] {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo.x.max(0.0), hi.x.abs().max(lo.x.abs()), lo.y, hi.y)
}

impl Lathe {
    /// Nearest hit of the ray origin + s·dir with s in (s_min, s_max) on the whole lathe.
    /// `dir` need not be normalised; `s` is returned in its units.
    pub fn intersect(&self, origin: DVec3, dir: DVec3, s_min: f64, s_max: f64) -> Option<LatheHit> {
        let f = Frame::new(origin, dir, s_min, s_max, self.scale)?;
        let (lo, hi) = self.bounds();
        let r = hi.x;
        f.annulus(0.0, r, lo.y, hi.y, f.s_max)?;
        // Visit pieces in the order the ray enters their annuli; stop once that entry is
        // beyond the best hit.
        let mut best: Option<Best> = None;
        if self.pieces.len() > SMALL {
            for i in 0..self.pieces.len() {
                self.piece_hits(i, &f, &mut best);
            }
            return best.map(|b| self.hit_record(&f, b));
        }
        let mut order = [(0.0f64, 0usize); SMALL];
        let mut count = 0;
        for (i, p) in self.pieces.iter().enumerate() {
            if let Some((s_lo, _)) = f.annulus(p.r_lo, p.r_hi, p.y_lo, p.y_hi, f.s_max) {
                order[count] = (s_lo, i);
                count += 1;
            }
        }
        let order = &mut order[..count];
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for &(s_lo, i) in order.iter() {
            if best.is_some_and(|b| s_lo >= b.s) {
                break;
            }
            self.piece_hits(i, &f, &mut best);
        }
        best.map(|b| self.hit_record(&f, b))
    }

    /// Nearest hit on piece `i` only (for a BVH that would hold pieces as primitives).
    pub fn intersect_segment(
        &self,
        i: usize,
        origin: DVec3,
        dir: DVec3,
        s_min: f64,
        s_max: f64,
    ) -> Option<LatheHit> {
        let f = Frame::new(origin, dir, s_min, s_max, self.scale)?;
        let mut best = None;
        self.piece_hits(i, &f, &mut best);
        best.map(|b| self.hit_record(&f, b))
    }

    fn piece_hits(&self, i: usize, f: &Frame, best: &mut Option<Best>) {
        let piece = &self.pieces[i];
        let limit = best.map_or(f.s_max, |b| b.s);
        let Some((s_lo, _)) = f.annulus(piece.r_lo, piece.r_hi, piece.y_lo, piece.y_hi, limit)
        else {
            return;
        };
        match piece.kind {
            PieceKind::Flat => self.flat_hit(i, f, best),
            PieceKind::Wall => self.wall_hit(i, f, best),
            PieceKind::Curve => match f.mode {
                Mode::General => self.search(i, f, Equation::Full, s_lo, best),
                Mode::ThroughAxis => {
                    self.search(i, f, Equation::AxisFactor(1.0), s_lo, best);
                    self.search(i, f, Equation::AxisFactor(-1.0), s_lo, best);
                }
                Mode::Parallel { r } => self.search(i, f, Equation::Radius(r), s_lo, best),
                Mode::Horizontal => self.search(i, f, Equation::Height, s_lo, best),
            },
        }
    }

    /// Plane intersection with a piece of constant height.
    fn flat_hit(&self, i: usize, f: &Frame, best: &mut Option<Best>) {
        let piece = &self.pieces[i];
        if f.d.y == 0.0 {
            return; // the ray lies in the plane of the ring or misses it: tangent, no hit
        }
        let y = piece.points[0].y;
        let s = (y - f.o.y) / f.d.y;
        if !(s > f.s_min && s < best.map_or(f.s_max, |b| b.s)) {
            return;
        }
        let r = f.rho_sq(s).sqrt();
        let mut buf = [0.0; MAX_POINTS];
        for (b, p) in buf.iter_mut().zip(&piece.points) {
            *b = p.x - r;
        }
        let xs = &buf[..piece.points.len()];
        let (x0, x1) = (xs[0], xs[xs.len() - 1]);
        let slack = f.tol;
        if x0.min(x1) > slack || x0.max(x1) < -slack {
            return;
        }
        let t = if x0 * x1 <= 0.0 {
            solve_bracketed(|t| eval_with_derivative(xs, t), 0.0, 1.0)
        } else if x0.abs() < x1.abs() {
            0.0
        } else {
            1.0
        };
        *best = Some(Best { s, piece: i, t });
    }

    /// Cylinder intersection with a piece of constant radius.
    fn wall_hit(&self, i: usize, f: &Frame, best: &mut Option<Best>) {
        let piece = &self.pieces[i];
        if matches!(f.mode, Mode::Parallel { .. }) {
            return; // parallel to the wall: inside it (tangent) or missing it
        }
        let rr = piece.points[0].x * piece.points[0].x;
        if f.rho0sq > rr {
            return;
        }
        // Roots of A s² + 2B s + (C − R²) = 0 without cancellation: the larger-magnitude root
        // from s₀ ± h, the other from the product of the roots (Vieta).
        let h = ((rr - f.rho0sq) / f.a_xz).sqrt();
        let far = if f.s0 >= 0.0 { f.s0 + h } else { f.s0 - h };
        let c = f.o.x * f.o.x + f.o.z * f.o.z - rr;
        let near = if far != 0.0 { c / f.a_xz / far } else { 0.0 };
        let (s1, s2) = if near < far { (near, far) } else { (far, near) };
        for s in [s1, s2] {
            if !(s > f.s_min && s < best.map_or(f.s_max, |b| b.s)) {
                continue;
            }
            let y = f.o.y + s * f.d.y;
            let mut buf = [0.0; MAX_POINTS];
            for (b, p) in buf.iter_mut().zip(&piece.points) {
                *b = p.y - y;
            }
            let ys = &buf[..piece.points.len()];
            let (y0, y1) = (ys[0], ys[ys.len() - 1]);
            if y0.min(y1) > f.tol || y0.max(y1) < -f.tol {
                continue;
            }
            let t = if y0 * y1 <= 0.0 {
                solve_bracketed(|t| eval_with_derivative(ys, t), 0.0, 1.0)
            } else if y0.abs() < y1.abs() {
                0.0
            } else {
                1.0
            };
            *best = Some(Best { s, piece: i, t });
            return;
        }
    }

    /// Coefficients of the node polynomial and a bound on each one's rounding error.
    fn coefficients(
        &self,
        f: &Frame,
        eq: Equation,
        pts: &[DVec2],
        c: &mut [f64; MAX_COEFFS],
        e: &mut [f64; MAX_COEFFS],
    ) -> usize {
        let n = pts.len() - 1;
        match eq {
            Equation::Full => {
                let bin = super::bernstein::binomials();
                let gamma = 4.0 * (2 * n + 4) as f64 * EPS;
                let mut u = [0.0; MAX_POINTS];
                let mut ub = [0.0; MAX_POINTS];
                for i in 0..=n {
                    u[i] = pts[i].y - f.y_c;
                    ub[i] = u[i].abs() + 2.0 * EPS * (pts[i].y.abs() + f.y_c.abs());
                }
                for k in 0..=2 * n {
                    let (mut uu, mut uu_up, mut uu_abs, mut xx, mut xx_abs) =
                        (0.0, 0.0, 0.0, 0.0, 0.0);
                    let lo = k.saturating_sub(n);
                    for i in lo..=k.min(n) {
                        let j = k - i;
                        let w = bin.c(n, i) * bin.c(n, j);
                        uu += w * u[i] * u[j];
                        uu_up += w * ub[i] * ub[j];
                        uu_abs += w * (u[i] * u[j]).abs();
                        let xp = pts[i].x * pts[j].x;
                        xx += w * xp;
                        xx_abs += w * xp.abs();
                    }
                    let inv = 1.0 / bin.c(2 * n, k);
                    let (uu, uu_up, uu_abs, xx, xx_abs) =
                        (uu * inv, uu_up * inv, uu_abs * inv, xx * inv, xx_abs * inv);
                    c[k] = f.wa * uu - f.wc * (xx - f.rho0sq);
                    e[k] = f.wa * ((uu_up - uu_abs) + gamma * uu_up)
                        + f.wc * gamma * (xx_abs + f.rho0sq)
                        + gamma * c[k].abs();
                }
                2 * n
            }
            Equation::AxisFactor(sigma) => {
                let (sa, sc) = (f.wa.sqrt(), f.wc.sqrt());
                for i in 0..=n {
                    let u = pts[i].y - f.y_c;
                    c[i] = sa * u - sigma * sc * pts[i].x;
                    e[i] = 4.0 * EPS * (sa * (pts[i].y.abs() + f.y_c.abs()) + sc * pts[i].x.abs());
                }
                n
            }
            Equation::Radius(r) => {
                for i in 0..=n {
                    c[i] = pts[i].x - r;
                    e[i] = 4.0 * EPS * (pts[i].x.abs() + r);
                }
                n
            }
            Equation::Height => {
                for i in 0..=n {
                    c[i] = pts[i].y - f.y_c;
                    e[i] = 4.0 * EPS * (pts[i].y.abs() + f.y_c.abs());
                }
                n
            }
        }
    }

    /// Nearest-first subdivision search for the roots of `eq` on piece `i`.
    fn search(&self, i: usize, f: &Frame, eq: Equation, s_lo: f64, best: &mut Option<Best>) {
        let piece = &self.pieces[i];
        let np = piece.points.len();
        let mut root = Node {
            pts: [DVec2::ZERO; MAX_POINTS],
            a: 0.0,
            w: 1.0,
            depth: 0,
            s_lo,
        };
        root.pts[..np].copy_from_slice(&piece.points);
        STACK.with(|cell| {
            let mut stack = cell.borrow_mut();
            stack.clear();
            stack.push(root);
            self.search_nodes(i, f, eq, &mut stack, best);
        });
    }

    fn search_nodes(
        &self,
        i: usize,
        f: &Frame,
        eq: Equation,
        stack: &mut Vec<Node>,
        best: &mut Option<Best>,
    ) {
        let np = self.pieces[i].points.len();
        let mut c = [0.0; MAX_COEFFS];
        let mut e = [0.0; MAX_COEFFS];
        let mut budget = NODE_BUDGET;
        while let Some(node) = stack.pop() {
            if budget == 0 {
                break;
            }
            budget -= 1;
            if best.is_some_and(|b| node.s_lo >= b.s) {
                continue;
            }
            let pts = &node.pts[..np];
            let m = self.coefficients(f, eq, pts, &mut c, &mut e);
            let (cs, es) = (&c[..=m], &e[..=m]);
            if cs.iter().zip(es).all(|(v, e)| *v > *e) || cs.iter().zip(es).all(|(v, e)| *v < -*e) {
                continue;
            }
            // Descartes' rule of signs in the Bernstein basis: with every coefficient's sign
            // certain, exactly one sign variation means exactly one root in the node.
            if cs.iter().zip(es).all(|(v, e)| v.abs() > *e) {
                let variations = cs
                    .windows(2)
                    .filter(|w| (w[0] < 0.0) != (w[1] < 0.0))
                    .count();
                if variations == 1 {
                    let tau = solve_bracketed_from(
                        |t| eval_with_derivative(cs, t),
                        0.0,
                        1.0,
                        cs[0],
                        cs[m],
                    );
                    self.candidate(i, f, eq, node.a + tau * node.w, best);
                    continue;
                }
            }
            let inc = (0..m).all(|j| c[j + 1] - c[j] > e[j] + e[j + 1]);
            let dec = (0..m).all(|j| c[j + 1] - c[j] < -(e[j] + e[j + 1]));
            if inc || dec {
                // Monotone: at most one root. Either a sign change (solve) or an end value
                // within its error bound (a root at the node's end, e.g. a pole).
                let (f0, f1) = (c[0], c[m]);
                let local = if f0 * f1 <= 0.0 {
                    Some(solve_bracketed_from(
                        |t| eval_with_derivative(cs, t),
                        0.0,
                        1.0,
                        cs[0],
                        cs[m],
                    ))
                } else if f0.abs() <= e[0] {
                    Some(0.0)
                } else if f1.abs() <= e[m] {
                    Some(1.0)
                } else {
                    None
                };
                if let Some(tau) = local {
                    self.candidate(i, f, eq, node.a + tau * node.w, best);
                }
                continue;
            }
            if node.depth >= MAX_DEPTH {
                // A double root (tangency) or a cluster narrower than 2⁻⁴⁰: try the point of
                // smallest |value|; `candidate` keeps it only if it lies on the surface.
                let emax = es.iter().fold(0.0f64, |a, b| a.max(*b));
                let mut pick = (f64::INFINITY, 0.5);
                for k in 0..=4 {
                    let tau = k as f64 / 4.0;
                    let v = eval_with_derivative(cs, tau).0.abs();
                    if v < pick.0 {
                        pick = (v, tau);
                    }
                }
                if pick.0 <= 4.0 * emax {
                    self.candidate(i, f, eq, node.a + pick.1 * node.w, best);
                }
                continue;
            }
            let mut l = node;
            let mut r = node;
            split_curve(pts, 0.5, &mut l.pts[..np], &mut r.pts[..np]);
            l.w = 0.5 * node.w;
            r.w = 0.5 * node.w;
            r.a = node.a + 0.5 * node.w;
            l.depth = node.depth + 1;
            r.depth = node.depth + 1;
            let limit = best.map_or(f.s_max, |b| b.s);
            let mut kids: [Option<Node>; 2] = [None, None];
            for (slot, mut kid) in kids.iter_mut().zip([l, r]) {
                let (rlo, rhi, ylo, yhi) = hull(&kid.pts[..np]);
                if let Some((s, _)) = f.annulus(rlo, rhi, ylo, yhi, limit) {
                    kid.s_lo = s;
                    *slot = Some(kid);
                }
            }
            match kids {
                [Some(a), Some(b)] => {
                    let (near, far) = if a.s_lo <= b.s_lo { (a, b) } else { (b, a) };
                    stack.push(far);
                    stack.push(near);
                }
                [Some(a), None] | [None, Some(a)] => stack.push(a),
                [None, None] => {}
            }
        }
    }

    /// Turns a root t of the node equation into a ray parameter, polishes (s, t) on the
    /// original system, checks that the point lies on the surface and keeps the nearest.
    fn candidate(&self, i: usize, f: &Frame, eq: Equation, t: f64, best: &mut Option<Best>) {
        let piece = &self.pieces[i];
        let t = t.clamp(0.0, 1.0);
        let (p, _) = eval_curve_with_derivative(&piece.points, t);
        let mut guesses = [f64::NAN; 2];
        match (eq, f.mode) {
            (Equation::Height, _) => {
                let h2 = (p.x * p.x - f.rho0sq) / f.a_xz;
                if h2 < -f.tol * f.tol {
                    return;
                }
                let h = h2.max(0.0).sqrt();
                guesses = [f.s0 - h, f.s0 + h];
            }
            (_, Mode::Parallel { .. }) => guesses[0] = (p.y - f.o.y) / f.d.y,
            _ => {
                if f.d.y.abs() >= 1e-3 {
                    guesses[0] = (p.y - f.o.y) / f.d.y;
                } else {
                    let h = ((p.x * p.x - f.rho0sq) / f.a_xz).max(0.0).sqrt();
                    let side = (p.y - f.y_c) * f.d.y;
                    guesses[0] = if side >= 0.0 { f.s0 + h } else { f.s0 - h };
                }
            }
        }
        for s in guesses {
            if s.is_nan() {
                continue;
            }
            let (s, t) = polish(piece, f, s, t);
            if !(s > f.s_min && s < best.map_or(f.s_max, |b| b.s)) {
                continue;
            }
            // On the surface? Height and radius residuals within the tolerance.
            let (p, _) = eval_curve_with_derivative(&piece.points, t);
            let q = f.o + s * f.d;
            let dr = (q.x * q.x + q.z * q.z).sqrt() - p.x.abs();
            let dh = q.y - p.y;
            let tol = 1e-7 * (piece.r_hi.max(piece.y_hi - piece.y_lo)) + f.tol + 1e-15 * s.abs();
            if dr.abs() <= tol && dh.abs() <= tol {
                *best = Some(Best { s, piece: i, t });
            }
        }
    }

    fn hit_record(&self, f: &Frame, b: Best) -> LatheHit {
        let piece = &self.pieces[b.piece];
        let (p, mut dp) = eval_curve_with_derivative(&piece.points, b.t);
        let cusp = 1e-12 * self.scale;
        if dp.length_squared() <= cusp * cusp {
            // A cusp (vanishing derivative): use the chord through nearby points instead.
            let h = 1e-6;
            let (lo, hi) = ((b.t - h).max(0.0), (b.t + h).min(1.0));
            dp = (eval_curve_with_derivative(&piece.points, hi).0
                - eval_curve_with_derivative(&piece.points, lo).0)
                / (hi - lo);
        }
        let q = f.o + b.s * f.d;
        let r = (q.x * q.x + q.z * q.z).sqrt();
        let phi = if r > 0.0 {
            crate::lanes::math::atan2_f64(-q.z, q.x)
        } else {
            0.0
        };
        let (sin, cos) = crate::lanes::math::sin_cos_f64(phi);
        let e_r = DVec3::new(cos, 0.0, -sin);
        let radius = p.x.max(0.0);
        let mut n = dp.y * e_r - dp.x * DVec3::Y;
        if r <= 1e-12 * self.scale || n.length_squared() == 0.0 {
            // At a pole: the limit along the axis, −sign(x′)·ŷ for x ≥ 0.
            n = if dp.x > 0.0 { -DVec3::Y } else { DVec3::Y };
        }
        let n = n.normalize();
        let theta = if piece.mirrored {
            phi + std::f64::consts::PI
        } else {
            phi
        };
        let u = theta.rem_euclid(TAU) / TAU;
        let dv = piece.v1 - piece.v0;
        LatheHit {
            s: b.s / f.len,
            point: q,
            normal: n,
            uv: DVec2::new(u, piece.v0 + b.t * dv),
            dpdu: TAU * DVec3::new(-radius * sin, 0.0, -radius * cos),
            dpdv: DVec3::new(dp.x * cos, dp.y, -dp.x * sin) / dv,
            segment: b.piece,
        }
    }
}

/// Two-variable Newton on height(s) = y(t), radius²(s) = x(t)², from (s, t); keeps a step only
/// when it lowers the residual, so a good start is never made worse.
fn polish(piece: &Piece, f: &Frame, mut s: f64, mut t: f64) -> (f64, f64) {
    let resid = |s: f64, t: f64| {
        let (p, dp) = eval_curve_with_derivative(&piece.points, t);
        let r1 = f.o.y + s * f.d.y - p.y;
        let rho2 = f.rho_sq(s);
        let r2 = rho2 - p.x * p.x;
        // Scale the radial equation to length units: divide by (ρ + x).
        let k = (rho2.sqrt() + p.x.abs()).max(1e-300);
        (r1, r2 / k, p, dp, k)
    };
    let (mut r1, mut r2, mut p, mut dp, mut k) = resid(s, t);
    for _ in 0..4 {
        let norm = r1.abs() + r2.abs();
        if norm == 0.0 {
            break;
        }
        // Jacobian of (r1, r2·k) with respect to (s, t), second row divided by k.
        let ds_rho2 = 2.0 * (f.a_xz * s + f.b_xz);
        let j = [[f.d.y, -dp.y], [ds_rho2 / k, -2.0 * p.x * dp.x / k]];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if det == 0.0 || !det.is_finite() {
            break;
        }
        let step_s = (r1 * j[1][1] - j[0][1] * r2) / det;
        let step_t = (j[0][0] * r2 - r1 * j[1][0]) / det;
        let (ns, nt) = (s - step_s, (t - step_t).clamp(0.0, 1.0));
        let (n1, n2, np, ndp, nk) = resid(ns, nt);
        let improved = n1.abs() + n2.abs() < norm; // false for NaN too
        if !improved {
            break;
        }
        (s, t, r1, r2, p, dp, k) = (ns, nt, n1, n2, np, ndp, nk);
    }
    (s, t)
}
