//! BVH build time and traversal throughput: lumo's triangle BVH (the [`TriangleBvh`] every
//! scene's world-space triangles go into: binned SAH collapsed to a 4-wide BVH with 4-triangle
//! SIMD leaves) against the `obvhs` crate (PLOC build, CWBVH traversal, lumo's scalar watertight
//! test in its leaves), on the same triangles and the same rays.
//!
//! Meshes: `../shared/meshes/bunny_small.obj` and `teapot.obj` (skipped loudly when
//! `../shared` is missing), and an icosphere of 327,680 triangles generated here; builds also of
//! a 1,310,720-triangle icosphere. Rays: 1M coherent camera rays and 1M incoherent random rays
//! per mesh (see `common::coherent` / `common::incoherent`), closest-hit and any-hit, on one
//! thread and on all cores (rayon). Criterion reports throughput in elements/s = rays/s.
//!
//! With `LUMO_RAYS_DIR` pointing at the folder written by `benches/peers/embree_rays.py`, the
//! exact meshes and rays Embree was measured on are traced as well, and the hit counts and
//! agreement with Embree's hit triangles are printed.
//!
//! Run: `cargo bench --bench bvh` (filter with e.g. `-- traverse/icosphere7`).

mod common;

use std::time::{Duration, Instant};

use common::{Rays, Soup};
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use glam::{Vec3, Vec3A};
use lumo::geometry::{mesh::icosphere, TriRay, TriangleBvh};
use rayon::prelude::*;

const RAYS: usize = 1_000_000;

fn lumo_bvh(soup: &Soup) -> TriangleBvh {
    let corners = soup.tris.iter().map(|t| t.map(Vec3A::from)).collect();
    let ids = (0..soup.tris.len() as u32).map(|i| [0, i]).collect();
    TriangleBvh::new(corners, ids)
}

/// Closest-hit over a range of rays; returns (hits, sum of hit triangle ids) so that nothing
/// is optimised away and results can be compared.
fn lumo_closest(bvh: &TriangleBvh, o: &[Vec3], d: &[Vec3]) -> (u64, Vec<i32>) {
    let mut hits = 0;
    let mut prims = Vec::with_capacity(o.len());
    for (o, d) in o.iter().zip(d) {
        match bvh.intersect(&TriRay::new(*o, *d), 0.0, f32::INFINITY) {
            Some((id, _)) => {
                hits += 1;
                prims.push(id[1] as i32);
            }
            None => prims.push(-1),
        }
    }
    (hits, prims)
}

fn lumo_any(bvh: &TriangleBvh, o: &[Vec3], d: &[Vec3]) -> u64 {
    o.iter()
        .zip(d)
        .filter(|(o, d)| bvh.occluded(&TriRay::new(**o, **d), 0.0, f32::INFINITY))
        .count() as u64
}

mod obv {
    //! The `obvhs` side: its PLOC + CWBVH build, its SIMD traversal, and lumo's watertight
    //! triangle test on corners reordered to its leaf order (as lumo stores them), so the two
    //! differ only in the hierarchy.
    use glam::{Vec3, Vec3A};
    use lumo::geometry::triangle::{intersect_a, RayShear};
    use obvhs::{
        cwbvh::{builder::build_cwbvh_from_tris, CwBvh},
        ray::{Ray, RayHit},
        triangle::Triangle,
        BvhBuildParams,
    };

    pub struct Obvhs {
        pub bvh: CwBvh,
        /// Corners in the BVH's primitive order.
        pub corners: Vec<[Vec3A; 3]>,
    }

    pub fn tris(soup: &super::Soup) -> Vec<Triangle> {
        soup.tris
            .iter()
            .map(|t| Triangle {
                v0: t[0].into(),
                v1: t[1].into(),
                v2: t[2].into(),
            })
            .collect()
    }

    pub fn build(tris: &[Triangle]) -> CwBvh {
        build_cwbvh_from_tris(
            tris,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        )
    }

    pub fn new(soup: &super::Soup) -> Obvhs {
        let tris = tris(soup);
        let bvh = build(&tris);
        let corners = bvh
            .primitive_indices
            .iter()
            .map(|&i| soup.tris[i as usize].map(Vec3A::from))
            .collect();
        Obvhs { bvh, corners }
    }

    pub fn closest(b: &Obvhs, o: &[Vec3], d: &[Vec3]) -> u64 {
        let mut hits = 0;
        for (o, d) in o.iter().zip(d) {
            let shear = RayShear::new(*o, *d);
            let mut hit = RayHit::none();
            let found =
                b.bvh
                    .ray_traverse(Ray::new_inf((*o).into(), (*d).into()), &mut hit, |r, id| {
                        intersect_a(&shear, &b.corners[id], r.tmin, r.tmax)
                            .map_or(f32::INFINITY, |h| h.t)
                    });
            hits += found as u64;
        }
        hits
    }

    pub fn any(b: &Obvhs, o: &[Vec3], d: &[Vec3]) -> u64 {
        let mut hits = 0;
        for (o, d) in o.iter().zip(d) {
            let shear = RayShear::new(*o, *d);
            let miss = b
                .bvh
                .ray_traverse_miss(Ray::new_inf((*o).into(), (*d).into()), |r, id| {
                    intersect_a(&shear, &b.corners[id], r.tmin, r.tmax)
                        .map_or(f32::INFINITY, |h| h.t)
                });
            hits += !miss as u64;
        }
        hits
    }
}

const CHUNK: usize = 4096;

fn par<F: Fn(&[Vec3], &[Vec3]) -> u64 + Sync>(rays: &Rays, f: F) -> u64 {
    rays.o
        .par_chunks(CHUNK)
        .zip(rays.d.par_chunks(CHUNK))
        .map(|(o, d)| f(o, d))
        .sum()
}

fn meshes() -> Vec<Soup> {
    let mut out = Vec::new();
    if let Some(shared) = common::shared_dir() {
        out.push(common::load_obj(&shared.join("meshes/bunny_small.obj")));
        out.push(common::load_obj(&shared.join("meshes/teapot.obj")));
    }
    let (p, t) = icosphere(7);
    out.push(Soup::indexed("icosphere7", &p, &t));
    out
}

fn build_benches(c: &mut Criterion) {
    let mut soups = meshes();
    let (p, t) = icosphere(8);
    soups.push(Soup::indexed("icosphere8", &p, &t));
    let mut g = c.benchmark_group("build");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(4));
    for soup in &soups {
        g.throughput(Throughput::Elements(soup.tris.len() as u64));
        let corners: Vec<[Vec3A; 3]> = soup.tris.iter().map(|t| t.map(Vec3A::from)).collect();
        let ids: Vec<[u32; 2]> = (0..soup.tris.len() as u32).map(|i| [0, i]).collect();
        g.bench_function(format!("{}/lumo", soup.name), |b| {
            b.iter_batched(
                || (corners.clone(), ids.clone()),
                |(c, i)| TriangleBvh::new(c, i),
                BatchSize::LargeInput,
            )
        });
        let tris = obv::tris(soup);
        g.bench_function(format!("{}/obvhs", soup.name), |b| {
            b.iter(|| obv::build(&tris))
        });
        // One-line build times on one thread too (the lumo build parallelises big nodes).
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("thread pool");
        let t0 = Instant::now();
        pool.install(|| TriangleBvh::new(corners.clone(), ids.clone()));
        let lumo1 = t0.elapsed();
        let t0 = Instant::now();
        pool.install(|| obv::build(&tris));
        let obv1 = t0.elapsed();
        eprintln!(
            "build {} ({} triangles) on 1 thread: lumo {:.1} ms, obvhs {:.1} ms",
            soup.name,
            soup.tris.len(),
            lumo1.as_secs_f64() * 1e3,
            obv1.as_secs_f64() * 1e3
        );
    }
    g.finish();
}

fn traverse_set(c: &mut Criterion, soup: &Soup, sets: &[(String, Rays, Option<Vec<i32>>)]) {
    let lumo = lumo_bvh(soup);
    let obvhs = obv::new(soup);
    let mut g = c.benchmark_group(format!("traverse/{}", soup.name));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for (kind, rays, reference) in sets {
        g.throughput(Throughput::Elements(rays.o.len() as u64));
        // Hit counts: the two BVHs (and Embree, when its answers are given) must agree.
        let (hits, prims) = lumo_closest(&lumo, &rays.o, &rays.d);
        let obv_hits = obv::closest(&obvhs, &rays.o, &rays.d);
        let any = lumo_any(&lumo, &rays.o, &rays.d);
        eprintln!(
            "{} {kind}: {} rays, lumo hits {hits} (any-hit {any}), obvhs hits {obv_hits}",
            soup.name,
            rays.o.len()
        );
        if let Some(r) = reference {
            let embree_hits = r.iter().filter(|&&p| p >= 0).count();
            let same = r.iter().zip(&prims).filter(|(a, b)| a == b).count();
            eprintln!("  Embree: hits {embree_hits}; same triangle as lumo for {same} of {} rays ({:.4}%)", r.len(), 100.0 * same as f64 / r.len() as f64);
        }
        assert_eq!(
            hits, any,
            "closest-hit and any-hit disagree on whether rays hit"
        );
        g.bench_function(format!("{kind}/closest/1t/lumo"), |b| {
            b.iter(|| lumo_closest(&lumo, &rays.o, &rays.d).0)
        });
        g.bench_function(format!("{kind}/closest/1t/obvhs"), |b| {
            b.iter(|| obv::closest(&obvhs, &rays.o, &rays.d))
        });
        g.bench_function(format!("{kind}/any/1t/lumo"), |b| {
            b.iter(|| lumo_any(&lumo, &rays.o, &rays.d))
        });
        g.bench_function(format!("{kind}/any/1t/obvhs"), |b| {
            b.iter(|| obv::any(&obvhs, &rays.o, &rays.d))
        });
        g.bench_function(format!("{kind}/closest/all/lumo"), |b| {
            b.iter(|| par(rays, |o, d| lumo_closest(&lumo, o, d).0))
        });
        g.bench_function(format!("{kind}/closest/all/obvhs"), |b| {
            b.iter(|| par(rays, |o, d| obv::closest(&obvhs, o, d)))
        });
        g.bench_function(format!("{kind}/any/all/lumo"), |b| {
            b.iter(|| par(rays, |o, d| lumo_any(&lumo, o, d)))
        });
        g.bench_function(format!("{kind}/any/all/obvhs"), |b| {
            b.iter(|| par(rays, |o, d| obv::any(&obvhs, o, d)))
        });
    }
    g.finish();
}

fn traverse_benches(c: &mut Criterion) {
    for soup in meshes() {
        let side = (RAYS as f64).sqrt() as usize;
        let sets = vec![
            ("coherent".to_string(), common::coherent(&soup, side), None),
            (
                "incoherent".to_string(),
                common::incoherent(&soup, RAYS, 20261123),
                None,
            ),
        ];
        traverse_set(c, &soup, &sets);
    }
    // Embree's exact rays, when available.
    for mesh in ["bunny", "icosphere"] {
        if let Some((mut soup, sets)) = common::embree_rays(mesh) {
            soup.name = format!("embree-rays-{mesh}");
            let sets: Vec<_> = sets.into_iter().map(|(k, r, p)| (k, r, Some(p))).collect();
            traverse_set(c, &soup, &sets);
        }
    }
}

criterion_group!(benches, build_benches, traverse_benches);
criterion_main!(benches);
