//! Error measured against references and estimated from the samples themselves.

mod common;

use assert_cmd::Command;
use lumo::render::{render_with_error, RenderOptions};

use common::cornell;

#[test]
fn estimated_error_tracks_the_true_error_within_a_factor_of_one_and_a_half() {
    // True error: against a reference with 16× the samples (its own noise, a quarter of the
    // render's, is removed in quadrature).
    let independent = lumo_schema::SamplerKind::Independent;
    let reference = render_with_error(
        &cornell(48, 1024, 99, independent),
        &RenderOptions::default(),
    );
    for spp in [16, 64] {
        let r = render_with_error(&cornell(48, spp, 1, independent), &RenderOptions::default());
        let measured = r.image.rmse(&reference.image);
        let true_error = (measured.powi(2) - reference.stats.estimated_rmse.powi(2))
            .max(0.0)
            .sqrt();
        let ratio = r.stats.estimated_rmse / true_error;
        eprintln!(
            "{spp} spp: estimated RMSE {:.5}, true {true_error:.5}, ratio {ratio:.3}",
            r.stats.estimated_rmse
        );
        assert!(
            (1.0 / 1.5..1.5).contains(&ratio),
            "{spp} spp: estimate {} vs true {true_error}",
            r.stats.estimated_rmse
        );
    }
}

#[test]
fn target_error_stops_once_reached() {
    let mut scene = cornell(32, 4096, 1, lumo_schema::SamplerKind::Sobol);
    scene.settings.spp = 4096;
    let target = 0.05;
    let r = render_with_error(
        &scene,
        &RenderOptions {
            target_rel_error: Some(target),
            ..Default::default()
        },
    );
    assert!(
        r.stats.estimated_rel_error <= target,
        "{}",
        r.stats.estimated_rel_error
    );
    assert!(r.stats.spp < 4096, "stopped at {} spp", r.stats.spp);
    // The previous pass had not reached it (passes double, so at most twice the samples needed).
    let half = render_with_error(
        &cornell(32, r.stats.spp / 2, 1, lumo_schema::SamplerKind::Sobol),
        &RenderOptions::default(),
    );
    assert!(
        half.stats.estimated_rel_error > target * 0.9,
        "{} at {} spp",
        half.stats.estimated_rel_error,
        r.stats.spp / 2
    );
}

#[test]
fn adaptive_sampling_spends_the_same_budget_and_stays_unbiased() {
    let scene = cornell(48, 32, 3, lumo_schema::SamplerKind::Sobol);
    let reference =
        lumo::output::read_image(&common::root().join("tests/reference/cornell_mitsuba_4096.exr"))
            .unwrap()
            .mean();
    let uniform = render_with_error(&scene, &RenderOptions::default());
    let adaptive = render_with_error(
        &scene,
        &RenderOptions {
            adaptive: true,
            ..Default::default()
        },
    );
    let n = u64::from(48 * 48 * 32u32);
    assert!(
        adaptive.stats.samples <= n && adaptive.stats.samples >= n - n / 50,
        "{} samples",
        adaptive.stats.samples
    );
    for (name, r) in [("uniform", &uniform), ("adaptive", &adaptive)] {
        let m = r.image.mean();
        eprintln!("{name}: mean {m}, reference {reference}");
        assert!(
            ((m - reference) / reference).abs().max_element() < 0.02,
            "{name}: mean {m} vs reference {reference}"
        );
    }
    assert!(adaptive.image.pixels.iter().all(|p| p.is_finite()));
}

#[test]
fn cli_reports_error_against_a_reference_and_converge_writes_csv_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let root = common::root();
    let out = Command::cargo_bin("lumo")
        .unwrap()
        .current_dir(&root)
        .args([
            "render",
            "scenes/cornell.json",
            "--spp",
            "4",
            "-q",
            "--reference",
            "tests/reference/cornell_mitsuba_4096.exr",
            "-o",
        ])
        .arg(dir.path().join("c.exr"))
        .arg("--error-image")
        .arg(dir.path().join("err.exr"))
        .assert()
        .success();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("RMSE") && err.contains("relMSE") && err.contains("vs reference"),
        "{err}"
    );
    assert!(dir.path().join("err.exr").is_file());
    Command::cargo_bin("lumo")
        .unwrap()
        .current_dir(&root)
        .args([
            "converge",
            "scenes/cornell.json",
            "--reference",
            "tests/reference/cornell_mitsuba_4096.exr",
            "--spp",
            "1,2",
            "-o",
        ])
        .arg(dir.path().join("conv"))
        .assert()
        .success();
    let csv = std::fs::read_to_string(dir.path().join("conv/converge.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with("label,spp,seconds,samples_per_second,rmse,rel_mse,estimated_rmse"));
    let rmse: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
        .collect();
    assert!(
        rmse[1] < rmse[0],
        "error must fall with more samples: {rmse:?}"
    );
    assert!(image::open(dir.path().join("conv/converge.png")).is_ok());
    assert!(
        std::fs::read_to_string(dir.path().join("conv/converge.svg"))
            .unwrap()
            .contains("<svg")
    );

    // A second run drawn beside the first (`--compare`): both series are in the legend.
    Command::cargo_bin("lumo")
        .unwrap()
        .current_dir(&root)
        .args([
            "converge",
            "scenes/cornell.json",
            "--reference",
            "tests/reference/cornell_mitsuba_4096.exr",
            "--spp",
            "1,2",
            "--sampler",
            "independent",
            "--label",
            "lumo-independent",
            "--compare",
        ])
        .arg(dir.path().join("conv/converge.csv"))
        .arg("-o")
        .arg(dir.path().join("both"))
        .assert()
        .success();
    let svg = std::fs::read_to_string(dir.path().join("both/converge.svg")).unwrap();
    assert!(
        svg.contains("lumo-independent") && svg.matches("lumo").count() >= 2,
        "both labels must be in the legend"
    );

    // A comparison file without the needed columns is refused, naming the file and the column.
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "renderer,spp,time\nx,1,0.5\n").unwrap();
    let out = Command::cargo_bin("lumo")
        .unwrap()
        .current_dir(&root)
        .args([
            "converge",
            "scenes/cornell.json",
            "--reference",
            "tests/reference/cornell_mitsuba_4096.exr",
            "--spp",
            "1",
            "--compare",
        ])
        .arg(&bad)
        .arg("-o")
        .arg(dir.path().join("bad"))
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("bad.csv:1") && err.contains("`peer` or `label`"),
        "{err}"
    );
}
