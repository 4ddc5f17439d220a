//! Denoising at equal time on a textured asset: DamagedHelmet under `studio.exr` at 256², the
//! issue's metric (docs/passes.md, "Does it pay?").
//!
//! ```sh
//! LUMO_OIDN=$(ls -d tests/oidn/.venv/lib/python*/site-packages/pyoidn) cargo bench --bench denoise [-- SPP SEEDS [REFERENCE.exr]]
//! ```
//!
//! The renders take the reference's size; another reference (say 512²) is made as
//! `tests/reference/README.md` makes the committed one, with `--width`/`--height` changed.
//!
//! For each seed: an SPP-sample render with the albedo and normal passes, denoised, timed from
//! the job's start to the denoised image; then a render without denoising given that time
//! (`JobSettings::time_s`). Both are compared with the committed 1024-spp reference
//! (`tests/reference/damaged_helmet_studio_1024.exr`, its variance subtracted from the error)
//! by relMSE over the helmet's pixels (its object id), with the pixels that emit left out (the
//! helmet's emissive texture, found by a render of depth 1: above 10⁻³), as the Cornell box's
//! comparison leaves out its lamp. Printed per seed: the two errors and their ratio, over all
//! those pixels and with the worst 0.1 % left out (the rare bright samples that find the
//! studio's small lamps decide the first), and on the emitting pixels alone. Then the same
//! SPP-sample render denoised with other guide recipes (no timing involved): the guides as
//! rendered (the preview's recipe, no prefiltering), the albedo alone, and no guides.

use std::time::Instant;

use lumo::aov::{Aov, PassPixels};
use lumo::denoise::{Oidn, Prefilter};
use lumo::image::Image;
use lumo::job::Hooks;
use lumo::multilayer::ChannelGroup;

#[path = "common/mod.rs"]
mod common;
#[path = "../tests/support/helmet.rs"]
mod helmet;

use helmet::Helmet;

/// relMSE over `keep`, all kept pixels and with the worst 0.1 % left out.
fn rel_mse(helmet: &Helmet, x: &Image, keep: &[bool]) -> (f64, f64) {
    let mut per_pixel = helmet.rel_errors(x, keep);
    let n = per_pixel.len();
    let all = per_pixel.iter().sum::<f64>() / n as f64;
    per_pixel.sort_by(f64::total_cmp);
    let kept = n - n / 1000;
    (all, per_pixel[..kept].iter().sum::<f64>() / kept as f64)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let spp: u32 = args.first().and_then(|a| a.parse().ok()).unwrap_or(8);
    let seeds: u64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(3);
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let Some(oidn_dir) = std::env::var_os("LUMO_OIDN") else {
        eprintln!("SKIPPED: set LUMO_OIDN to Open Image Denoise (docs/passes.md)");
        return;
    };
    let mut oidn = Oidn::load_from(std::path::Path::new(&oidn_dir)).expect("OIDN loads");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let reference_file = args.get(2).map_or_else(
        || root.join("tests/reference/damaged_helmet_studio_1024.exr"),
        std::path::PathBuf::from,
    );
    let helmet = Helmet::new(&shared, &reference_file);
    let reference = &helmet.reference;
    let emission = helmet
        .job(Some(16), None, 5, "", 1)
        .run(&Hooks::default())
        .expect("renders")
        .image;
    let load = || {
        std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|s| s.split_whitespace().next().map(str::to_string))
            .unwrap_or_else(|| "?".into())
    };
    println!(
        "DamagedHelmet, studio.exr, {}², {spp} spp denoised against equal time; relMSE over the \
         helmet's non-emitting pixels (all | worst 0.1 % left out), then its emitting pixels",
        reference.width
    );
    println!("seed | s | equal-time spp | denoised | equal time | ratio | ratio, 0.1 % out | emitting: denoised, equal time | load");
    let mut recipes = Vec::new();
    for seed in 1..=seeds {
        let noisy_job = helmet.job(Some(spp), None, seed, "albedo,normal,object_id", 8);
        let start = Instant::now();
        let noisy = noisy_job.run(&Hooks::default()).expect("renders");
        let denoised = noisy.denoised(&mut oidn).expect("denoises");
        let spent = start.elapsed().as_secs_f32();
        let equal = helmet
            .job(None, Some(spent), seed + 100, "", 8)
            .run(&Hooks::default())
            .expect("renders");
        let passes = noisy.passes();
        let pass = |aov: Aov| passes.iter().find(|p| p.aov == aov);
        let ids = pass(Aov::ObjectId).expect("the object-id pass");
        let PassPixels::Id(ids) = &ids.pixels else {
            panic!("object ids are integers")
        };
        let emits: Vec<bool> = emission
            .pixels
            .iter()
            .zip(ids)
            .map(|(e, &id)| id != 0 && e.max_element() > 1e-3)
            .collect();
        let rest: Vec<bool> = ids
            .iter()
            .zip(&emits)
            .map(|(&id, &e)| id != 0 && !e)
            .collect();
        let d = rel_mse(&helmet, &denoised, &rest);
        let e = rel_mse(&helmet, &equal.image, &rest);
        let guide = |aov: Aov| {
            pass(aov)
                .and_then(|p| ChannelGroup::from_pass(p).to_rgb(reference.width, reference.height))
        };
        let (albedo, normal) = (guide(Aov::Albedo), guide(Aov::Normal));
        let mut recipe = |albedo: Option<&Image>, normal: Option<&Image>| {
            let out = oidn
                .denoise(&noisy.image, albedo, normal, Prefilter::None)
                .expect("denoises");
            rel_mse(&helmet, &out, &rest)
        };
        recipes.push((
            seed,
            d,
            recipe(albedo.as_ref(), normal.as_ref()),
            recipe(albedo.as_ref(), None),
            recipe(None, None),
            rel_mse(&helmet, &noisy.image, &rest),
        ));
        let de = rel_mse(&helmet, &denoised, &emits);
        let ee = rel_mse(&helmet, &equal.image, &emits);
        println!(
            "{seed} | {spent:.2} | {} | {:.4} {:.4} | {:.4} {:.4} | {:.2} | {:.2} | {:.4}, {:.4} | {}",
            equal.stats.spp,
            d.0,
            d.1,
            e.0,
            e.1,
            d.0 / e.0,
            d.1 / e.1,
            de.0,
            ee.0,
            load()
        );
    }
    println!(
        "\n{spp} spp, relMSE over the same pixels (all | worst 0.1 % left out), by guide recipe"
    );
    println!("seed | prefiltered albedo + normal | albedo + normal as rendered | albedo alone | no guides | not denoised");
    for (seed, clean, raw, albedo, none, noisy) in recipes {
        println!(
            "{seed} | {:.4} {:.4} | {:.4} {:.4} | {:.4} {:.4} | {:.4} {:.4} | {:.4} {:.4}",
            clean.0, clean.1, raw.0, raw.1, albedo.0, albedo.1, none.0, none.1, noisy.0, noisy.1
        );
    }
}
