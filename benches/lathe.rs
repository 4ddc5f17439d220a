//! Lathe benchmark: robustness (exact vs a single-guess Newton intersector, both against the
//! independent reference) and speed (exact intersector vs the same lathe tessellated to equal
//! visual error behind a small BVH). Prints both tables, then runs the divan benchmarks.
//!
//! Run: `cargo bench --bench lathe`

#[path = "../src/lathe/reference.rs"]
#[allow(dead_code)]
mod reference;
/// `reference.rs` is shared with the library's tests, where the sampler is `crate::sampler`.
mod sampler {
    pub use lumo::sampler::mix64;
}

use glam::{DVec2, DVec3};
use lumo::lathe::{Lathe, Profile};
use reference::{RefCurve, Reference, Rng};
use std::time::Instant;

fn vase() -> (Lathe, RefCurve) {
    let pts = [
        [0.0, 0.0],
        [0.5, 0.0],
        [0.9, 0.0],
        [1.0, 0.3],
        [0.5, 1.2],
        [0.35, 1.8],
        [0.6, 2.2],
    ];
    let knots = [0.0, 0.0, 0.0, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0, 1.0, 1.0];
    let lathe = Lathe::new(Profile::bspline(3, &pts, Some(&knots)).expect("valid"));
    let curve = RefCurve::Bspline(
        3,
        pts.iter().map(|p| DVec2::new(p[0], p[1])).collect(),
        knots.to_vec(),
    );
    (lathe, curve)
}

fn egg() -> (Lathe, RefCurve) {
    let pts = [[0.0, -1.0], [1.4, -1.0], [1.4, 1.2], [0.0, 1.2]];
    let lathe = Lathe::new(Profile::bezier(&pts).expect("valid"));
    (
        lathe,
        RefCurve::Bezier(pts.iter().map(|p| DVec2::new(p[0], p[1])).collect()),
    )
}

/// The profile as a scene stores it (f32 data), for the shared tessellation.
fn schema_profile(curve: &RefCurve) -> lumo_schema::Profile {
    let arr = |v: &Vec<DVec2>| v.iter().map(|p| [p.x as f32, p.y as f32]).collect();
    match curve {
        RefCurve::Bezier(p) => {
            lumo_schema::Profile::Bezier(lumo_schema::BezierProfile { points: arr(p) })
        }
        RefCurve::Bspline(d, p, kn) => lumo_schema::Profile::Bspline(lumo_schema::BsplineProfile {
            degree: *d as u32,
            points: arr(p),
            knots: Some(kn.iter().map(|&k| k as f32).collect()),
        }),
    }
}

/// The seed's approach: Newton on (s, v) from one initial guess (entry into the bounding box,
/// middle of the profile), no bracketing, no root isolation.
fn newton_single_guess(lathe: &Lathe, o: DVec3, d: DVec3) -> Option<f64> {
    let (lo, hi) = lathe.bounds();
    let inv = d.recip();
    let t1 = (lo - o) * inv;
    let t2 = (hi - o) * inv;
    let enter = t1.min(t2).max_element().max(0.0);
    let exit = t1.max(t2).min_element();
    if enter > exit {
        return None;
    }
    let size = (hi - lo).max_element();
    let (mut s, mut v) = (enter, 0.5);
    for _ in 0..30 {
        let (p, dp) = lathe.profile().eval(v);
        let q = o + s * d;
        let rho = (q.x * q.x + q.z * q.z).sqrt().max(1e-300);
        let f1 = q.y - p.y;
        let f2 = rho - p.x.abs();
        if f1.abs() + f2.abs() < 1e-9 * size {
            return (s > 0.0 && (0.0..=1.0).contains(&v)).then_some(s);
        }
        let drho = (q.x * d.x + q.z * d.z) / rho;
        let dxa = dp.x * p.x.signum();
        let det = d.y * (-dxa) + dp.y * drho;
        if det == 0.0 {
            return None;
        }
        s -= (f1 * (-dxa) + dp.y * f2) / det;
        v -= (d.y * f2 - drho * f1) / det;
        v = v.clamp(0.0, 1.0);
    }
    None
}

#[derive(Default, Clone, Copy)]
struct Tally {
    rays: usize,
    decided: usize,
    false_miss: usize,
    false_hit: usize,
    wrong_hit: usize,
    max_rel: f64,
}

fn reference_answer(r: &Reference, o: DVec3, d: DVec3) -> Option<Option<f64>> {
    let base = r.intersect(o, d, 0.0, f64::INFINITY).map(|h| h.s);
    let e1 = d.normalize().any_orthonormal_vector();
    let e2 = d.normalize().cross(e1);
    for off in [e1, -e1, e2, -e2] {
        let p = r
            .intersect(o + 1e-6 * r.scale * off, d, 0.0, f64::INFINITY)
            .map(|h| h.s);
        match (base, p) {
            (None, None) => {}
            (Some(a), Some(b)) if (a - b).abs() * d.length() <= 1e-3 * r.scale => {}
            _ => return None,
        }
    }
    Some(base)
}

fn tally(t: &mut Tally, got: Option<f64>, want: Option<f64>) {
    t.decided += 1;
    match (got, want) {
        (None, Some(_)) => t.false_miss += 1,
        (Some(_), None) => t.false_hit += 1,
        (Some(g), Some(w)) => {
            let rel = (g - w).abs() / w;
            if rel > 1e-6 {
                t.wrong_hit += 1;
            }
            t.max_rel = t.max_rel.max(rel);
        }
        (None, None) => {}
    }
}

/// Ray families: (name, rays).
fn ray_sets(lathe: &Lathe, seed: u64, n: usize) -> Vec<(&'static str, Vec<(DVec3, DVec3)>)> {
    let (lo, hi) = lathe.bounds();
    let c = 0.5 * (lo + hi);
    let size = (hi - lo).max_element();
    let far = 3.0 * size;
    let mut rng = Rng(seed);
    let random = (0..n)
        .map(|_| {
            let o = c + far * rng.unit();
            let t = DVec3::new(
                rng.range(lo.x, hi.x),
                rng.range(lo.y, hi.y),
                rng.range(lo.z, hi.z),
            );
            (o, t - o)
        })
        .collect();
    let axis = (0..n)
        .map(|_| {
            let a = DVec3::new(0.0, rng.range(lo.y, hi.y), 0.0);
            let d = rng.unit();
            (a - far * d, d)
        })
        .collect();
    let horizontal = (0..n)
        .map(|i| {
            let phi = rng.range(0.0, 6.3);
            let d = DVec3::new(phi.cos(), [0.0, 1e-9, -1e-6, 1e-3][i % 4], phi.sin());
            let side = DVec3::new(-phi.sin(), 0.0, phi.cos());
            let o = DVec3::new(0.0, rng.range(lo.y, hi.y), 0.0)
                + rng.range(-1.0, 1.0) * hi.x * side
                - far * d;
            (o, d)
        })
        .collect();
    let mut grazing = Vec::new();
    while grazing.len() < n {
        let v = rng.range(0.02, 0.98);
        let (p, dp) = lathe.profile().eval(v);
        if p.x.abs() < 0.05 * size {
            continue;
        }
        let th = rng.range(0.0, 6.3);
        let (s, co) = th.sin_cos();
        let nrm = (p.x * DVec3::new(dp.y * co, -dp.x, -dp.y * s)).normalize();
        if nrm.y.abs() > 0.95 {
            continue;
        }
        let e_t = DVec3::new(-s, 0.0, -co);
        let d = (e_t + rng.range(-0.5, 0.5) * nrm.cross(e_t)).normalize();
        let delta = [1e-5, -1e-5, 1e-3, -1e-3][grazing.len() % 4] * size;
        grazing.push((
            DVec3::new(p.x * co, p.y, -p.x * s) + delta * nrm - far * d,
            d,
        ));
    }
    vec![
        ("random", random),
        ("through axis", axis),
        ("horizontal", horizontal),
        ("grazing", grazing),
    ]
}

// ---- A small BVH over the tessellation, for the speed comparison only ----

struct Tri {
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
}

enum Node {
    Leaf {
        lo: DVec3,
        hi: DVec3,
        first: usize,
        count: usize,
    },
    Inner {
        lo: DVec3,
        hi: DVec3,
        left: usize,
        right: usize,
    },
}

struct MeshBvh {
    tris: Vec<Tri>,
    nodes: Vec<Node>,
}

impl MeshBvh {
    fn new(positions: &[DVec3], indices: &[[u32; 3]]) -> MeshBvh {
        let mut items: Vec<(DVec3, [DVec3; 3])> = indices
            .iter()
            .map(|t| {
                let v = [
                    positions[t[0] as usize],
                    positions[t[1] as usize],
                    positions[t[2] as usize],
                ];
                ((v[0] + v[1] + v[2]) / 3.0, v)
            })
            .collect();
        let mut nodes = Vec::new();
        Self::build(&mut items, 0, &mut nodes);
        let tris = items
            .iter()
            .map(|(_, v)| Tri {
                v0: v[0],
                e1: v[1] - v[0],
                e2: v[2] - v[0],
            })
            .collect();
        MeshBvh { tris, nodes }
    }

    fn build(items: &mut [(DVec3, [DVec3; 3])], first: usize, nodes: &mut Vec<Node>) -> usize {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for (_, v) in items.iter() {
            for p in v {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let id = nodes.len();
        if items.len() <= 4 {
            nodes.push(Node::Leaf {
                lo,
                hi,
                first,
                count: items.len(),
            });
            return id;
        }
        nodes.push(Node::Leaf {
            lo,
            hi,
            first,
            count: 0,
        });
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        items.sort_by(|a, b| a.0[axis].total_cmp(&b.0[axis]));
        let mid = items.len() / 2;
        let (l, r) = items.split_at_mut(mid);
        let left = Self::build(l, first, nodes);
        let right = Self::build(r, first + mid, nodes);
        nodes[id] = Node::Inner {
            lo,
            hi,
            left,
            right,
        };
        id
    }

    fn intersect(&self, o: DVec3, d: DVec3) -> Option<f64> {
        let inv = d.recip();
        let slab = |lo: DVec3, hi: DVec3, tmax: f64| {
            let t1 = (lo - o) * inv;
            let t2 = (hi - o) * inv;
            let a = t1.min(t2).max_element().max(0.0);
            let b = t1.max(t2).min_element().min(tmax);
            a <= b
        };
        let mut best = f64::INFINITY;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            match &self.nodes[i] {
                Node::Leaf {
                    lo,
                    hi,
                    first,
                    count,
                } => {
                    if !slab(*lo, *hi, best) {
                        continue;
                    }
                    for t in &self.tris[*first..first + count] {
                        // Möller–Trumbore.
                        let p = d.cross(t.e2);
                        let det = t.e1.dot(p);
                        if det.abs() < 1e-300 {
                            continue;
                        }
                        let inv_det = 1.0 / det;
                        let s = o - t.v0;
                        let u = s.dot(p) * inv_det;
                        if !(0.0..=1.0).contains(&u) {
                            continue;
                        }
                        let q = s.cross(t.e1);
                        let v = d.dot(q) * inv_det;
                        if v < 0.0 || u + v > 1.0 {
                            continue;
                        }
                        let dist = t.e2.dot(q) * inv_det;
                        if dist > 1e-9 && dist < best {
                            best = dist;
                        }
                    }
                }
                Node::Inner {
                    lo,
                    hi,
                    left,
                    right,
                } => {
                    if slab(*lo, *hi, best) {
                        stack.push(*right);
                        stack.push(*left);
                    }
                }
            }
        }
        best.is_finite().then_some(best)
    }
}

/// Tessellation resolution whose chords stay within `tol` of the surface (radially and along
/// the profile, measured at chord midpoints).
fn tessellation_for(lathe: &Lathe, tol: f64) -> (usize, usize) {
    let r = lathe.bounds().1.x;
    let angular = (std::f64::consts::PI / (1.0 - tol / r).acos()).ceil() as usize;
    let mut samples = 16;
    loop {
        let mut worst: f64 = 0.0;
        for j in 0..samples - 1 {
            let (v0, v1) = (
                j as f64 / (samples - 1) as f64,
                (j + 1) as f64 / (samples - 1) as f64,
            );
            let (a, b) = (lathe.profile().eval(v0).0, lathe.profile().eval(v1).0);
            let m = lathe.profile().eval(0.5 * (v0 + v1)).0;
            worst = worst.max((m - 0.5 * (a + b)).length());
        }
        if worst <= tol || samples > 1 << 16 {
            return (angular, samples);
        }
        samples *= 2;
    }
}

fn time_per_ray(rays: &[(DVec3, DVec3)], mut f: impl FnMut(DVec3, DVec3) -> bool) -> (f64, usize) {
    let mut hits = 0;
    let reps = 5;
    let start = Instant::now();
    for _ in 0..reps {
        for (o, d) in rays {
            hits += f(*o, *d) as usize;
        }
    }
    (
        start.elapsed().as_nanos() as f64 / (reps * rays.len()) as f64,
        hits / reps,
    )
}

fn main() {
    println!("## Robustness: decided rays (reference stable under 1e-6·size perturbation)\n");
    println!("| profile | rays | decided | exact: false miss / false hit / wrong distance | Newton (single guess): false miss / false hit / wrong distance |");
    println!("|---|---|---|---|---|");
    for (name, (lathe, curve)) in [
        ("vase (cubic B-spline)", vase()),
        ("egg (cubic Bézier)", egg()),
    ] {
        let r = Reference::new(curve, 6000);
        for (set, rays) in ray_sets(&lathe, 7, 1000) {
            let (mut ex, mut nw) = (Tally::default(), Tally::default());
            for (o, d) in &rays {
                ex.rays += 1;
                let Some(want) = reference_answer(&r, *o, *d) else {
                    continue;
                };
                let got = lathe.intersect(*o, *d, 0.0, f64::INFINITY).map(|h| h.s);
                if let (Some(g), Some(w)) = (got, want) {
                    if (g - w).abs() > 1e-6 * w {
                        eprintln!("exact disagrees: o={o:?} d={d:?} got {g} want {w}");
                    }
                }
                tally(&mut ex, got, want);
                tally(&mut nw, newton_single_guess(&lathe, *o, *d), want);
            }
            println!(
                "| {name}, {set} | {} | {} | {} / {} / {} (max rel. err {:.1e}) | {} / {} / {} |",
                ex.rays,
                ex.decided,
                ex.false_miss,
                ex.false_hit,
                ex.wrong_hit,
                ex.max_rel,
                nw.false_miss,
                nw.false_hit,
                nw.wrong_hit
            );
        }
    }

    println!("\n## Speed: ns per ray (single thread, random rays at the object)\n");
    println!("| profile | exact | tessellated (tol 1e-3·size: segments × samples, triangles) | BVH over mesh |");
    println!("|---|---|---|---|");
    for (name, (lathe, curve)) in [
        ("vase (cubic B-spline)", vase()),
        ("egg (cubic Bézier)", egg()),
    ] {
        let schema_profile = schema_profile(&curve);
        let rays = ray_sets(&lathe, 11, 20000).remove(0).1;
        let size = (lathe.bounds().1 - lathe.bounds().0).max_element();
        let (seg, samples) = tessellation_for(&lathe, 1e-3 * size);
        let mesh = lumo_schema::geometry::tessellate::lathe(
            &schema_profile,
            seg as u32,
            samples as u32 - 1,
        );
        let bvh = MeshBvh::new(&mesh.positions, &mesh.indices);
        let (t_exact, h1) = time_per_ray(&rays, |o, d| {
            lathe.intersect(o, d, 0.0, f64::INFINITY).is_some()
        });
        let (t_mesh, h2) = time_per_ray(&rays, |o, d| bvh.intersect(o, d).is_some());
        println!(
            "| {name} | {t_exact:.0} ns ({h1} hits) | {seg} × {samples}, {} triangles | {t_mesh:.0} ns ({h2} hits) |",
            mesh.indices.len()
        );
    }
    println!();
    divan::main();
}

#[divan::bench]
fn exact_vase_random_rays(bencher: divan::Bencher) {
    let (lathe, _) = vase();
    let rays = ray_sets(&lathe, 3, 1000).remove(0).1;
    bencher.bench(|| {
        rays.iter()
            .filter(|(o, d)| lathe.intersect(*o, *d, 0.0, f64::INFINITY).is_some())
            .count()
    });
}
