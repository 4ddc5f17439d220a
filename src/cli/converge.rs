//! `lumo converge`: error against time over a ladder of sample counts, as a CSV and a log-log
//! plot with the ideal 1/√t slope.

use std::path::{Path, PathBuf};
use std::time::Instant;

use plotters::prelude::*;

use super::{input, CliError};
use crate::output::{read_image, write_image, ToneMap};
use crate::render::{render_with_error, RenderOptions};
use crate::scene::build::{build, ExternalData};
use crate::scene::Scene;

/// The bundled font for plot labels (DejaVu Sans, Bitstream Vera licence: `assets/fonts/`).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// One rung of the ladder.
#[derive(Debug, Clone, Copy)]
pub struct Rung {
    /// Samples per pixel (mean).
    pub spp: u32,
    /// Wall time of the render in seconds.
    pub seconds: f64,
    /// Samples per second.
    pub samples_per_second: f64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// Relative MSE against the reference.
    pub rel_mse: f64,
    /// RMSE the render predicted from its own samples.
    pub estimated_rmse: f64,
}

/// Arguments of `lumo converge`.
#[derive(Debug, clap::Args)]
pub struct ConvergeArgs {
    /// The scene.
    pub scene: PathBuf,
    /// Reference image (linear EXR/HDR). Without one, a reference is rendered first at
    /// `--reference-spp` and saved as `reference.exr` in the output folder.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the rendered reference.
    #[arg(long, default_value_t = 4096)]
    pub reference_spp: u32,
    /// Comma-separated ladder of samples per pixel.
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
    pub spp: Vec<u32>,
    /// Sample sequence.
    #[arg(long, value_enum)]
    pub sampler: Option<super::SamplerArg>,
    /// Distribute samples adaptively by per-pixel error.
    #[arg(long)]
    pub adaptive: bool,
    /// Output folder for `converge.csv`, `converge.png` and `converge.svg`.
    #[arg(short, long, default_value = "converge")]
    pub out_dir: PathBuf,
    /// Label of this run in the CSV (e.g. `lumo-sobol`).
    #[arg(long, default_value = "lumo")]
    pub label: String,
}

/// Runs the ladder and writes the CSV and plots.
pub fn run(args: &ConvergeArgs, external: &dyn ExternalData) -> Result<Vec<Rung>, CliError> {
    let mut inp = input::load(&args.scene)?;
    if let Some(k) = args.sampler {
        inp.scene.render.sampler = k.into();
    }
    std::fs::create_dir_all(&args.out_dir).map_err(|e| CliError::failure(format!("{}: {e}", args.out_dir.display())))?;
    let scene_at = |spp: u32, seed: u64| -> Result<Scene, CliError> {
        let mut desc = inp.scene.clone();
        desc.render.spp = spp;
        desc.render.seed = seed;
        desc.render.time_budget_s = None;
        build(&desc, &inp.base_dir, external).map(|(s, _)| s).map_err(|e| CliError::invalid(e.to_string()))
    };
    let reference = match &args.reference {
        Some(path) => read_image(path).map_err(|e| CliError::failure(e.to_string()))?,
        None => {
            eprintln!("rendering a reference at {} spp…", args.reference_spp);
            let r = render_with_error(&scene_at(args.reference_spp, 0x5eed_0f_2ef)?, &RenderOptions::default());
            write_image(&r.image, &args.out_dir.join("reference.exr"), ToneMap::Clamp).map_err(|e| CliError::failure(e.to_string()))?;
            r.image
        }
    };
    if (reference.width, reference.height) != (inp.scene.image.width, inp.scene.image.height) {
        return Err(CliError::invalid(format!(
            "reference is {}×{} but the scene renders {}×{}",
            reference.width, reference.height, inp.scene.image.width, inp.scene.image.height
        )));
    }
    let options = RenderOptions { adaptive: args.adaptive, ..Default::default() };
    let mut rungs = Vec::new();
    for &spp in &args.spp {
        let scene = scene_at(spp, 1)?;
        let t = Instant::now();
        let r = render_with_error(&scene, &options);
        let seconds = t.elapsed().as_secs_f64();
        let rung = Rung {
            spp: r.stats.spp,
            seconds,
            samples_per_second: r.stats.samples as f64 / seconds,
            rmse: r.image.rmse(&reference),
            rel_mse: r.image.rel_mse(&reference),
            estimated_rmse: r.stats.estimated_rmse,
        };
        eprintln!("{:>6} spp  {:>8.3} s  {:>6.2} M samples/s  RMSE {:.5}  relMSE {:.6}  (estimated RMSE {:.5})", rung.spp, rung.seconds, rung.samples_per_second / 1e6, rung.rmse, rung.rel_mse, rung.estimated_rmse);
        rungs.push(rung);
    }
    let mut csv = String::from("label,spp,seconds,samples_per_second,rmse,rel_mse,estimated_rmse\n");
    for r in &rungs {
        csv.push_str(&format!("{},{},{:.6},{:.1},{:.6},{:.8},{:.6}\n", args.label, r.spp, r.seconds, r.samples_per_second, r.rmse, r.rel_mse, r.estimated_rmse));
    }
    super::write_text_atomically(&args.out_dir.join("converge.csv"), &csv)?;
    plot(&rungs, &args.out_dir.join("converge.svg"), &args.out_dir.join("converge.png"), &args.label)?;
    eprintln!("wrote {}/converge.{{csv,svg,png}}", args.out_dir.display());
    Ok(rungs)
}

/// Log-log plot of RMSE against seconds, with the ideal slope −1/2 through the first rung.
fn plot(rungs: &[Rung], svg: &Path, png: &Path, label: &str) -> Result<(), CliError> {
    let fail = |e: String| CliError::failure(format!("plot: {e}"));
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).map_err(|_| fail("cannot load the bundled font".into()))?;
    let pts: Vec<(f64, f64)> = rungs.iter().filter(|r| r.seconds > 0.0 && r.rmse > 0.0).map(|r| (r.seconds, r.rmse)).collect();
    if pts.is_empty() {
        return Err(fail("no rung has a positive time and error".into()));
    }
    let (t0, e0) = pts[0];
    let tmin = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min) / 1.5;
    let tmax = pts.iter().map(|p| p.0).fold(0.0, f64::max) * 1.5;
    let emin = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min).min(e0 * (t0 / tmax).sqrt()) / 1.5;
    let emax = pts.iter().map(|p| p.1).fold(0.0, f64::max).max(e0 * (t0 / tmin).sqrt()) * 1.5;
    fn draw<B: DrawingBackend>(root: DrawingArea<B, plotters::coord::Shift>, pts: &[(f64, f64)], x: (f64, f64), y: (f64, f64), label: &str) -> Result<(), String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = ChartBuilder::on(&root)
            .caption("Error against time", ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((x.0..x.1).log_scale(), (y.0..y.1).log_scale())
            .map_err(|e| e.to_string())?;
        chart.configure_mesh().x_desc("wall time (s)").y_desc("RMSE vs reference").label_style(("sans-serif", 14)).draw().map_err(|e| e.to_string())?;
        let (t0, e0) = pts[0];
        chart
            .draw_series(LineSeries::new([x.0, x.1].map(|t| (t, e0 * (t0 / t).sqrt())), BLACK.mix(0.4).stroke_width(1)))
            .map_err(|e| e.to_string())?
            .label("ideal 1/√t")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK.mix(0.4)));
        chart.draw_series(LineSeries::new(pts.iter().copied(), BLUE.stroke_width(2))).map_err(|e| e.to_string())?.label(label.to_string()).legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLUE));
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, BLUE.filled()))).map_err(|e| e.to_string())?;
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).label_font(("sans-serif", 14)).draw().map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    }
    draw(SVGBackend::new(svg, (720, 480)).into_drawing_area(), &pts, (tmin, tmax), (emin, emax), label).map_err(fail)?;
    let (w, h) = (720u32, 480u32);
    let mut buffer = vec![0u8; (w * h * 3) as usize];
    draw(BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area(), &pts, (tmin, tmax), (emin, emax), label).map_err(fail)?;
    let img = image::RgbImage::from_raw(w, h, buffer).ok_or_else(|| fail("bitmap size mismatch".into()))?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png).map_err(|e| fail(e.to_string()))?;
    let tmp = png.with_extension("png.tmp");
    std::fs::write(&tmp, bytes.into_inner()).and_then(|_| std::fs::rename(&tmp, png)).map_err(|e| fail(format!("{}: {e}", png.display())))?;
    Ok(())
}

