//! Traces one of the ray sets of `benches/peers/embree_rays.py` through a [`TriangleBvh`]
//! (closest hit, then any hit, once each), prints the hit counts, the agreement with Embree's
//! triangles and a hash of every hit's triangle, distance and barycentrics (equal hashes: equal
//! hits, bit for bit), then the speed of `REPEATS` further passes. Small enough to run under
//! `valgrind --tool=callgrind`: the instructions of the rays are those of a run with RAYS = N
//! minus those of a run with RAYS = 0 (loading and the build).
//!
//! ```text
//! LUMO_RAYS_DIR=benches/peers/rays cargo run --release --example embree_rays_count -- \
//!     icosphere incoherent [RAYS=1000000] [REPEATS=5] [THREADS=1]
//! ```
//!
//! With THREADS > 1 the timed passes split the rays into chunks of 4,096 traced on a rayon pool
//! of that many threads (as the `bvh` bench's "all cores" runs).
//!
//! `LUMO_BVH_NO_AVX2=1` runs the SSE fallback instead of the AVX2 box test;
//! `LUMO_BVH_LEAVES=indexed` builds the tree with indexed leaves (the soup's corners as a mesh
//! of three vertices per triangle) instead of leaf packets.
#[path = "../benches/common/mod.rs"]
mod common;
use glam::Vec3A;
use lumo::geometry::triangle_bvh::LEAVES_VARIABLE;
use lumo::geometry::triangle_source::{SourcePart, TriangleSource};
use lumo::geometry::{TriRay, TriangleBvh};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mesh = args.get(1).map(String::as_str).unwrap_or("icosphere");
    let kind = args.get(2).map(String::as_str).unwrap_or("incoherent");
    let n: usize = args.get(3).map_or(1_000_000, |s| s.parse().unwrap());
    let reps: usize = args.get(4).map_or(5, |s| s.parse().unwrap());
    let threads: usize = args.get(5).map_or(1, |s| s.parse().unwrap());
    let (soup, sets) = common::embree_rays(mesh).expect("rays");
    let corners: Vec<[Vec3A; 3]> = soup.tris.iter().map(|t| t.map(Vec3A::from)).collect();
    let ids = (0..soup.tris.len() as u32).map(|i| [0, i]).collect();
    let t0 = Instant::now();
    let bvh = if std::env::var(LEAVES_VARIABLE).is_ok_and(|v| v == "indexed") {
        let positions = soup.tris.iter().flatten().copied().collect();
        let triangles = (0..soup.tris.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        let source = TriangleSource::new(vec![SourcePart {
            first: 0,
            tag: 0,
            positions: Arc::new(positions),
            triangles: Arc::new(triangles),
            to_world: None,
        }]);
        TriangleBvh::build_indexed(source.len(), source, |i| i as u32)
    } else {
        TriangleBvh::new(corners, ids)
    };
    eprintln!("build {:.1} ms", t0.elapsed().as_secs_f64() * 1e3);
    let (_, rays, prim) = sets.into_iter().find(|s| s.0 == kind).unwrap();
    let (o, d) = (
        &rays.o[..n.min(rays.o.len())],
        &rays.d[..n.min(rays.d.len())],
    );
    let mut hash = 0u64;
    let mut hits = 0;
    let mut same = 0;
    for (i, (o, d)) in o.iter().zip(d).enumerate() {
        let h = bvh.intersect(&TriRay::new(*o, *d), 0.0, f32::INFINITY);
        let p = h.map_or(-1, |(id, _)| id[1] as i32);
        same += (p == prim[i]) as usize;
        if let Some((id, h)) = h {
            hits += 1;
            for x in [id[1], h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits()] {
                hash = (hash ^ x as u64).wrapping_mul(0x100000001b3);
            }
        }
    }
    let any = o
        .iter()
        .zip(d)
        .filter(|(o, d)| bvh.occluded(&TriRay::new(**o, **d), 0.0, f32::INFINITY))
        .count();
    println!(
        "{mesh} {kind}: {} rays, hits {hits}, any {any}, same as embree {same}, hash {hash:016x}",
        o.len()
    );
    if reps == 0 {
        return;
    }
    let closest = |o: &[glam::Vec3], d: &[glam::Vec3]| {
        o.iter()
            .zip(d)
            .filter(|(o, d)| {
                bvh.intersect(&TriRay::new(**o, **d), 0.0, f32::INFINITY)
                    .is_some()
            })
            .count()
    };
    let any_hit = |o: &[glam::Vec3], d: &[glam::Vec3]| {
        o.iter()
            .zip(d)
            .filter(|(o, d)| bvh.occluded(&TriRay::new(**o, **d), 0.0, f32::INFINITY))
            .count()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let traced = |f: &(dyn Fn(&[glam::Vec3], &[glam::Vec3]) -> usize + Sync)| -> usize {
        if threads <= 1 {
            return f(o, d);
        }
        pool.install(|| {
            o.par_chunks(4096)
                .zip(d.par_chunks(4096))
                .map(|(o, d)| f(o, d))
                .sum()
        })
    };
    let mut best = (f64::MAX, f64::MAX);
    let mut all = Vec::new();
    for _ in 0..reps {
        let t0 = Instant::now();
        let c = traced(&closest);
        let tc = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let a = traced(&any_hit);
        let ta = t0.elapsed().as_secs_f64();
        assert_eq!((c, a), (hits, any));
        all.push((o.len() as f64 / tc / 1e6, o.len() as f64 / ta / 1e6));
        best = (best.0.min(tc), best.1.min(ta));
    }
    let s: Vec<String> = all.iter().map(|(c, a)| format!("{c:.2}/{a:.2}")).collect();
    println!("  closest/any Mrays/s per rep: {}", s.join(" "));
}
