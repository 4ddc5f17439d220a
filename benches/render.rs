//! End-to-end render time: the Cornell box (`scenes/cornell.json`, 256×256) at 64 samples per
//! pixel with the path tracer, on all cores and on one thread, through the library exactly as
//! the CLI does it (load, build, render). Criterion reports throughput in samples/s; the rays/s
//! of one render are printed too. Also `scenes/glass_bunny.json` (a 327,680-triangle glass
//! blob in a diffuse room) at its own settings (256×256, 64 spp).
//!
//! Run: `cargo bench --bench render`.

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lumo::render::{render, RenderOptions};

fn load(name: &str, spp: u32) -> lumo::scene::Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let loaded = lumo::load(&path, &lumo::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut scene, _warnings) = loaded
        .build()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    scene.settings.spp = spp;
    scene
}

fn bench_scene(c: &mut Criterion, name: &str, spp: u32) {
    let scene = load(name, spp);
    let samples =
        u64::from(scene.settings.width) * u64::from(scene.settings.height) * u64::from(spp);
    let options = RenderOptions::default();
    let (_, stats) = render(&scene, &options);
    eprintln!(
        "{name} at {spp} spp: {:.2} s, {:.2} M rays/s, {:.2} M samples/s (all cores, one render)",
        stats.elapsed.as_secs_f64(),
        stats.rays as f64 / stats.elapsed.as_secs_f64() / 1e6,
        samples as f64 / stats.elapsed.as_secs_f64() / 1e6
    );
    let mut g = c.benchmark_group(format!("render/{}", name.trim_end_matches(".json")));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(10));
    g.throughput(Throughput::Elements(samples));
    g.bench_function(format!("{spp}spp/all"), |b| {
        b.iter(|| render(&scene, &options).1.rays)
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    g.bench_function(format!("{spp}spp/1t"), |b| {
        b.iter(|| one.install(|| render(&scene, &options).1.rays))
    });
    g.finish();
}

fn benches(c: &mut Criterion) {
    bench_scene(c, "cornell.json", 64);
    bench_scene(c, "glass_bunny.json", 64);
}

criterion_group!(render_benches, benches);
criterion_main!(render_benches);
