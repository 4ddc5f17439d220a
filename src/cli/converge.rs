//! `lumo converge`: error against time over a ladder of sample counts, as a CSV and a log-log
//! plot with the ideal 1/√t slope.

use std::path::{Path, PathBuf};
use std::time::Instant;

use plotters::prelude::*;

use super::CliError;
use lumo::load::LoadOptions;
use lumo::output::{read_image, write_image, ToneMap};
use lumo::render::{render_with_error, RenderOptions};
use lumo::scene::Scene;

/// The bundled font for plot labels (DejaVu Sans, Bitstream Vera licence: `assets/fonts/`).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Seed of the reference rendered when none is given (the ladder's rungs use seed 1).
const REFERENCE_SEED: u64 = 0x5_eed0_f2ef;

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
    /// Reference image (linear EXR/HDR) of the scene at the size rendered. Without one, lumo
    /// first renders its own reference: the same scene and size (with `--width`/`--height` and
    /// `--sampler`), `--reference-spp` samples in every pixel (never adaptive), seed 0x5eed0f2ef
    /// (the ladder uses seed 1), saved as `reference.exr` in the output folder; its own noise
    /// is part of every RMSE.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the reference rendered when no `--reference` is given.
    #[arg(long, default_value_t = 4096)]
    pub reference_spp: u32,
    /// Image width in pixels (overrides the scene, as in `lumo render`).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(lumo_schema::MAX_IMAGE_SIDE)))]
    pub width: Option<u32>,
    /// Image height in pixels (overrides the scene, as in `lumo render`).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(lumo_schema::MAX_IMAGE_SIDE)))]
    pub height: Option<u32>,
    /// Comma-separated ladder of samples per pixel.
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
    pub spp: Vec<u32>,
    /// Sample sequence.
    #[arg(long, value_parser = super::keyword::<lumo_schema::SamplerKind>())]
    pub sampler: Option<lumo_schema::SamplerKind>,
    /// Distribute samples adaptively by per-pixel error.
    #[arg(long)]
    pub adaptive: bool,
    /// Output folder for `converge.csv`, `converge.png` and `converge.svg`.
    #[arg(short, long, default_value = "converge")]
    pub out_dir: PathBuf,
    /// Label of this run in the CSV (e.g. `lumo-sobol`).
    #[arg(long, default_value = "lumo")]
    pub label: String,
    /// Other runs to draw beside this one: CSV files whose header names a `seconds`, an `rmse`
    /// and a `peer` or `label` column (e.g. `benches/peers/results.csv`, or an earlier
    /// `converge.csv`); one line per label. Rows labelled like this run are left out.
    #[arg(long, value_name = "CSV")]
    pub compare: Vec<PathBuf>,
    /// Changes to the scene (`--set`, `--patch`), as in `lumo render`; `--width`, `--height`
    /// and `--sampler` are applied after them.
    #[command(flatten)]
    pub compose: super::ComposeArgs,
}

/// A labelled error-against-time series for the plot.
#[derive(Debug, Clone)]
pub struct Series {
    /// Name in the legend.
    pub label: String,
    /// (seconds, RMSE) points in ladder order.
    pub points: Vec<(f64, f64)>,
}

/// Reads the series of another run from a CSV file (see [`ConvergeArgs::compare`]).
pub fn read_series(path: &Path, skip_label: &str) -> Result<Vec<Series>, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::failure(format!("{}: {e}", path.display())))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(CliError::invalid(format!(
            "{}: empty file (expected a CSV header naming seconds, rmse and peer or label)",
            path.display()
        )));
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |wanted: &[&str]| {
        names
            .iter()
            .position(|n| wanted.contains(n))
            .ok_or_else(|| {
                CliError::invalid(format!(
                    "{}:1: the header has no `{}` column (it has: {})",
                    path.display(),
                    wanted.join("` or `"),
                    names.join(", ")
                ))
            })
    };
    let (label_at, seconds_at, rmse_at) = (
        column(&["peer", "label"])?,
        column(&["seconds"])?,
        column(&["rmse"])?,
    );
    let mut series: Vec<Series> = Vec::new();
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let field = |at: usize, what: &str| {
            fields.get(at).copied().ok_or_else(|| {
                CliError::invalid(format!(
                    "{}:{}: missing the `{what}` field",
                    path.display(),
                    i + 1
                ))
            })
        };
        let number = |at: usize, what: &str| -> Result<f64, CliError> {
            let f = field(at, what)?;
            f.parse().map_err(|_| {
                CliError::invalid(format!(
                    "{}:{}: `{what}` is `{f}`, expected a number",
                    path.display(),
                    i + 1
                ))
            })
        };
        let label = field(label_at, "label")?;
        if label == skip_label {
            continue;
        }
        let point = (number(seconds_at, "seconds")?, number(rmse_at, "rmse")?);
        match series.iter_mut().find(|s| s.label == label) {
            Some(s) => s.points.push(point),
            None => series.push(Series {
                label: label.to_string(),
                points: vec![point],
            }),
        }
    }
    Ok(series)
}

/// Runs the ladder and writes the CSV and plots.
pub fn run(args: &ConvergeArgs) -> Result<Vec<Rung>, CliError> {
    let mut others = Vec::new();
    for path in &args.compare {
        others.extend(read_series(path, &args.label)?);
    }
    let options = LoadOptions {
        composition: args.compose.composition(Vec::new())?,
        ..LoadOptions::default()
    };
    let mut loaded = lumo::load(&args.scene, &options)?;
    if args.sampler.is_some() || args.width.is_some() || args.height.is_some() {
        loaded.edit(|s| {
            if let Some(k) = args.sampler {
                s.render.sampler = k;
            }
            if let Some(w) = args.width {
                s.image.width = w;
            }
            if let Some(h) = args.height {
                s.image.height = h;
            }
        })?;
    }
    let (width, height) = (
        loaded.description.scene.image.width,
        loaded.description.scene.image.height,
    );
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| CliError::failure(format!("{}: {e}", args.out_dir.display())))?;
    let scene_at = |spp: u32, seed: u64| -> Result<Scene, CliError> {
        let mut rung = loaded.clone();
        rung.edit(|s| {
            s.render.spp = spp;
            s.render.seed = seed;
            s.render.time_budget_s = None;
        })?;
        rung.build()
            .map(|(s, _)| s)
            .map_err(|e| CliError::invalid(e.to_string()))
    };
    let reference = match &args.reference {
        Some(path) => read_image(path).map_err(|e| CliError::failure(e.to_string()))?,
        None => {
            eprintln!(
                "no --reference given: rendering one of this scene at {width}×{height}, {} spp, \
                 seed {REFERENCE_SEED:#x} (the ladder uses seed 1), to {}; its own noise is part \
                 of every RMSE below",
                args.reference_spp,
                args.out_dir.join("reference.exr").display()
            );
            let r = render_with_error(
                &scene_at(args.reference_spp, REFERENCE_SEED)?,
                &RenderOptions::default(),
            );
            write_image(
                &r.image,
                &args.out_dir.join("reference.exr"),
                ToneMap::Clamp,
            )
            .map_err(|e| CliError::failure(e.to_string()))?;
            r.image
        }
    };
    if (reference.width, reference.height) != (width, height) {
        return Err(CliError::invalid(format!(
            "reference is {}×{} but the scene renders {width}×{height} (--width and --height \
             set the size rendered)",
            reference.width, reference.height,
        )));
    }
    let options = RenderOptions {
        adaptive: args.adaptive,
        ..Default::default()
    };
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
    let mut csv =
        String::from("label,spp,seconds,samples_per_second,rmse,rel_mse,estimated_rmse\n");
    for r in &rungs {
        csv.push_str(&format!(
            "{},{},{:.6},{:.1},{:.6},{:.8},{:.6}\n",
            args.label, r.spp, r.seconds, r.samples_per_second, r.rmse, r.rel_mse, r.estimated_rmse
        ));
    }
    super::write_text_atomically(&args.out_dir.join("converge.csv"), &csv)?;
    let this = Series {
        label: args.label.clone(),
        points: rungs.iter().map(|r| (r.seconds, r.rmse)).collect(),
    };
    plot(
        &this,
        &others,
        &args.out_dir.join("converge.svg"),
        &args.out_dir.join("converge.png"),
    )?;
    eprintln!("wrote {}/converge.{{csv,svg,png}}", args.out_dir.display());
    Ok(rungs)
}

/// Log-log plot of RMSE against seconds of this run and the others, with the ideal slope −1/2
/// through this run's first rung.
fn plot(this: &Series, others: &[Series], svg: &Path, png: &Path) -> Result<(), CliError> {
    let fail = |e: String| CliError::failure(format!("plot: {e}"));
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| fail("cannot load the bundled font".into()))?;
    let positive = |s: &Series| Series {
        label: s.label.clone(),
        points: s
            .points
            .iter()
            .copied()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .collect(),
    };
    let series: Vec<Series> = std::iter::once(this)
        .chain(others)
        .map(positive)
        .filter(|s| !s.points.is_empty())
        .collect();
    if series.first().is_none_or(|s| s.label != this.label) {
        return Err(fail("no rung has a positive time and error".into()));
    }
    let all = || series.iter().flat_map(|s| s.points.iter().copied());
    let (t0, e0) = series[0].points[0];
    let tmin = all().map(|p| p.0).fold(f64::INFINITY, f64::min) / 1.5;
    let tmax = all().map(|p| p.0).fold(0.0, f64::max) * 1.5;
    let emin = all()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min)
        .min(e0 * (t0 / tmax).sqrt())
        / 1.5;
    let emax = all()
        .map(|p| p.1)
        .fold(0.0, f64::max)
        .max(e0 * (t0 / tmin).sqrt())
        * 1.5;
    fn draw<B: DrawingBackend>(
        root: DrawingArea<B, plotters::coord::Shift>,
        series: &[Series],
        x: (f64, f64),
        y: (f64, f64),
    ) -> Result<(), String> {
        const COLOURS: [RGBColor; 6] = [
            BLUE,
            RED,
            RGBColor(0, 140, 0),
            RGBColor(230, 120, 0),
            MAGENTA,
            RGBColor(0, 150, 160),
        ];
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (x_ticks, y_ticks) = (LogTicks::new(x.0, x.1), LogTicks::new(y.0, y.1));
        let mut chart = ChartBuilder::on(&root)
            .caption("Error against time", ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (x.0..x.1)
                    .log_scale()
                    .with_key_points(x_ticks.labelled)
                    .with_light_points(x_ticks.grid),
                (y.0..y.1)
                    .log_scale()
                    .with_key_points(y_ticks.labelled)
                    .with_light_points(y_ticks.grid),
            )
            .map_err(|e| e.to_string())?;
        let tick = |v: &f64| tick_label(*v);
        chart
            .configure_mesh()
            .x_desc("wall time (s)")
            .y_desc("RMSE vs reference")
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style(("sans-serif", 14))
            .bold_line_style(RGBColor(0, 0, 0).mix(0.14))
            .light_line_style(RGBColor(0, 0, 0).mix(0.05))
            .draw()
            .map_err(|e| e.to_string())?;
        let (t0, e0) = series[0].points[0];
        chart
            .draw_series(LineSeries::new(
                [x.0, x.1].map(|t| (t, e0 * (t0 / t).sqrt())),
                BLACK.mix(0.4).stroke_width(1),
            ))
            .map_err(|e| e.to_string())?
            .label("ideal 1/√t")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK.mix(0.4)));
        for (i, s) in series.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    colour.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?
                .label(s.label.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour));
            chart
                .draw_series(s.points.iter().map(|p| Circle::new(*p, 4, colour.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    }
    draw(
        SVGBackend::new(svg, (720, 480)).into_drawing_area(),
        &series,
        (tmin, tmax),
        (emin, emax),
    )
    .map_err(fail)?;
    let (w, h) = (720u32, 480u32);
    let mut buffer = vec![0u8; (w * h * 3) as usize];
    draw(
        BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area(),
        &series,
        (tmin, tmax),
        (emin, emax),
    )
    .map_err(fail)?;
    let img = image::RgbImage::from_raw(w, h, buffer)
        .ok_or_else(|| fail("bitmap size mismatch".into()))?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| fail(e.to_string()))?;
    let tmp = png.with_extension("png.tmp");
    std::fs::write(&tmp, bytes.into_inner())
        .and_then(|_| std::fs::rename(&tmp, png))
        .map_err(|e| fail(format!("{}: {e}", png.display())))?;
    Ok(())
}

/// The marks of a logarithmic axis: labelled values, each drawn with a grid line, and the
/// unlabelled grid lines between them.
#[derive(Debug, Clone, PartialEq)]
struct LogTicks {
    /// Labelled values, ascending: the decades; also 2 and 5 times each decade when the axis
    /// spans under two decades; every integer multiple of the decades when that still leaves
    /// fewer than two labels (a short axis inside one decade), and every half-integer one when
    /// even that does.
    labelled: Vec<f64>,
    /// Unlabelled grid lines, ascending: the other integer multiples of each decade when the
    /// axis spans at most three decades, else none (a longer axis would be striped with them).
    grid: Vec<f64>,
}

impl LogTicks {
    /// The most decades labelled; longer axes label every second (third, …) decade.
    const MAX_DECADE_LABELS: usize = 8;

    fn new(lo: f64, hi: f64) -> LogTicks {
        let empty = LogTicks {
            labelled: Vec::new(),
            grid: Vec::new(),
        };
        if !(lo > 0.0 && hi > lo && hi.is_finite()) {
            return empty;
        }
        let span = (hi / lo).log10();
        // n·10^(k−1) for n = 10…95 in steps of 5 (1, 1.5, 2, … 9.5 times the decade 10^k),
        // parsed from its decimal form: the double nearest the decimal, so that the labels
        // print exactly and no two marks round to the same text.
        let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        let marks: Vec<(u32, i32, f64)> = (k0..=k1)
            .flat_map(|k| (10..100u32).step_by(5).map(move |n| (n, k)))
            .filter_map(|(n, k)| {
                let v = format!("{n}e{}", k - 1).parse::<f64>().ok()?;
                (lo <= v && v <= hi).then_some((n, k, v))
            })
            .collect();
        let pick = |keep: &dyn Fn(u32, i32) -> bool| -> Vec<f64> {
            marks
                .iter()
                .filter(|&&(n, k, _)| keep(n, k))
                .map(|&(_, _, v)| v)
                .collect()
        };
        let decades = marks.iter().filter(|&&(n, _, _)| n == 10).count();
        let every = decades.div_ceil(Self::MAX_DECADE_LABELS).max(1) as i32;
        let mut labelled = pick(&|n, k| n == 10 && k.rem_euclid(every) == 0);
        if span < 2.0 {
            labelled = pick(&|n, _| matches!(n, 10 | 20 | 50));
        }
        if labelled.len() < 2 {
            labelled = pick(&|n, _| n % 10 == 0);
        }
        if labelled.len() < 2 {
            labelled = pick(&|_, _| true);
        }
        let grid = if span <= 3.0 {
            pick(&|n, _| n % 10 == 0)
        } else {
            pick(&|n, _| n == 10)
        }
        .into_iter()
        .filter(|v| !labelled.contains(v))
        .collect();
        LogTicks { labelled, grid }
    }
}

/// The text of a tick at m·10^k (m = 1, 1.5, 2, …, 9.5): the digits it needs and no more
/// (0.002, 0.5, 0.15, 20, 1.5).
fn tick_label(v: f64) -> String {
    let decimals = (1.0 - (v.abs().log10() + 1e-9).floor()).max(0.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(lo: f64, hi: f64) -> Vec<String> {
        LogTicks::new(lo, hi)
            .labelled
            .iter()
            .map(|&v| tick_label(v))
            .collect()
    }

    #[test]
    fn long_axes_label_decades_only() {
        assert_eq!(labels(0.03, 25.0), ["0.1", "1", "10"]);
        assert_eq!(labels(0.0031, 0.31), ["0.01", "0.1"]);
        let t = LogTicks::new(0.03, 25.0);
        assert!(t.grid.contains(&0.2) && t.grid.contains(&9.0) && !t.grid.contains(&1.0));
        // Beyond three decades the grid keeps no lines between the decades.
        let t = LogTicks::new(1e-4, 1.0);
        assert_eq!(t.grid, Vec::<f64>::new());
        assert_eq!(t.labelled, [1e-4, 1e-3, 1e-2, 1e-1, 1.0]);
    }

    #[test]
    fn short_axes_add_two_and_five_then_every_multiple() {
        assert_eq!(labels(0.035, 1.9), ["0.05", "0.1", "0.2", "0.5", "1"]);
        assert_eq!(labels(0.21, 0.47), ["0.3", "0.4"]);
        assert_eq!(labels(0.55, 1.24), ["0.6", "0.7", "0.8", "0.9", "1"]);
        assert_eq!(labels(1.3e-4, 2.99e-4), ["0.00015", "0.0002", "0.00025"]);
        assert_eq!(labels(13.0, 29.9), ["15", "20", "25"]);
    }

    #[test]
    fn very_long_axes_thin_the_decade_labels() {
        let t = LogTicks::new(1e-9, 1e9);
        assert!(t.labelled.len() <= LogTicks::MAX_DECADE_LABELS);
        assert!(t.labelled.len() >= 2);
    }

    #[test]
    fn no_label_is_printed_twice_and_labels_are_short() {
        let mut lo = 1.3e-4;
        while lo < 50.0 {
            for factor in [2.3, 4.0, 9.5, 30.0, 150.0, 1e3, 1e5] {
                let l = labels(lo, lo * factor);
                assert!(l.len() >= 2, "{lo} × {factor}: {l:?}");
                let mut unique = l.clone();
                unique.dedup();
                assert_eq!(unique, l, "{lo} × {factor}");
                assert!(l.iter().all(|s| s.len() <= 8), "{l:?}");
                assert!(
                    l.iter().all(|s| !s.ends_with('0') || !s.contains('.')),
                    "{l:?}"
                );
                let t = LogTicks::new(lo, lo * factor);
                assert!(t.grid.iter().all(|v| !t.labelled.contains(v)));
                assert!(
                    t.grid.len() <= 27,
                    "{lo} × {factor}: {} lines",
                    t.grid.len()
                );
            }
            lo *= 1.37;
        }
    }
}
