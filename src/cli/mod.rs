//! The command-line interface: argument parsing and the subcommands.

pub mod gltf;
pub mod input;

use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use lumo_schema as schema;

use crate::output::{write_image, ToneMap};
use crate::render::{render, RenderOptions};
use crate::scene::build::{build, ExternalData};

/// Exit code for invalid input.
pub const EXIT_INVALID: i32 = 2;
/// Exit code for I/O or internal failures.
pub const EXIT_FAILURE: i32 = 1;

/// An error for the user, with the exit code it maps to.
#[derive(Debug)]
pub struct CliError {
    /// Process exit code.
    pub code: i32,
    /// The full message (may span lines).
    pub message: String,
}

impl CliError {
    /// Invalid input (exit code 2).
    pub fn invalid(message: impl Into<String>) -> Self {
        CliError { code: EXIT_INVALID, message: message.into() }
    }

    /// I/O or internal failure (exit code 1).
    pub fn failure(message: impl Into<String>) -> Self {
        CliError { code: EXIT_FAILURE, message: message.into() }
    }

    /// Maps a scene loading error to its exit code.
    pub fn from_load(e: schema::LoadError) -> Self {
        match e {
            schema::LoadError::Io { .. } => CliError::failure(e.to_string()),
            schema::LoadError::Invalid { .. } => CliError::invalid(e.to_string().trim_end().to_string()),
        }
    }
}

/// lumo: a physically based renderer and scene toolchain.
#[derive(Debug, Parser)]
#[command(name = "lumo", version, about, long_about = None)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// Integrator choice on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum IntegratorArg {
    /// Path tracing (NEE + MIS).
    Path,
    /// Fast ray-casting preview.
    Raycast,
}

/// Sampler choice on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SamplerArg {
    /// Owen-scrambled Sobol.
    Sobol,
    /// Independent random numbers.
    Independent,
}

/// Tone mapping choice on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ToneMapArg {
    /// Clamp to [0, 1].
    Clamp,
    /// ACES filmic curve.
    Aces,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to an image (PNG, EXR, HDR or BMP, by extension).
    #[command(after_help = "Example:\n  lumo render scenes/cornell.json -o cornell.png --spp 256")]
    Render(RenderArgs),
    /// Check scene files and report every problem found (exit code 0 valid, 2 invalid, 1 I/O error).
    #[command(after_help = "Example:\n  lumo validate scenes/*.json")]
    Validate {
        /// Scene files to check.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Convert a scene between formats, by extension: lumo JSON, glTF (.gltf with a .bin beside
    /// it, or .glb).
    #[command(after_help = "Examples:\n  lumo convert model.glb -o scene.json --camera 0\n  lumo convert scenes/cornell.json -o cornell.glb")]
    Convert {
        /// Input scene (.json, .gltf, .glb).
        input: PathBuf,
        /// Output file (.json, .gltf, .glb).
        #[arg(short, long)]
        output: PathBuf,
        /// glTF input: the camera to use, by name or index into `cameras` (default: the first).
        #[arg(long, value_name = "NAME|INDEX")]
        camera: Option<String>,
    },
    /// Print the JSON Schema of scene files (draft 2020-12).
    #[command(after_help = "Example:\n  lumo schema -o schema/scene.schema.json")]
    Schema {
        /// Write to this file instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

/// Arguments of `lumo render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The scene to render.
    pub scene: PathBuf,
    /// Output image; the format follows the extension (.png, .exr, .hdr, .bmp).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(schema::MAX_SPP)))]
    pub spp: Option<u32>,
    /// Image width in pixels (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(schema::MAX_IMAGE_SIDE)))]
    pub width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(schema::MAX_IMAGE_SIDE)))]
    pub height: Option<u32>,
    /// Random seed (overrides the scene).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Maximum path depth (overrides the scene; 1 = emitters only, 2 = direct light).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub max_depth: Option<u32>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub threads: Option<u32>,
    /// Light-transport algorithm (overrides the scene).
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorArg>,
    /// Sample sequence (overrides the scene).
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerArg>,
    /// Tone mapping for 8-bit outputs (PNG, BMP); EXR and HDR stay linear.
    #[arg(long, value_enum, default_value = "clamp")]
    pub tonemap: ToneMapArg,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
    /// glTF input: the camera to use, by name or index into `cameras` (default: the first).
    #[arg(long, value_name = "NAME|INDEX")]
    pub camera: Option<String>,
}

/// Runs the CLI; returns the process exit code.
pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Render(args) => render_cmd(&args, &gltf::GltfData::default()),
        Command::Convert { input, output, camera } => convert_cmd(&input, &output, camera.as_deref()),
        Command::Validate { files } => validate_cmd(&files),
        Command::Schema { output } => schema_cmd(output.as_deref()),
    }
}

fn camera_choice(s: &str) -> lumo_converters::gltf::CameraChoice {
    match s.parse() {
        Ok(c) => c,
        Err(never) => match never {},
    }
}

fn convert_cmd(input_path: &Path, output: &Path, camera: Option<&str>) -> Result<(), CliError> {
    let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let out_dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !out_dir.is_dir() {
        return Err(CliError::failure(format!("{}: the output folder does not exist", output.display())));
    }
    let json_out = match ext.as_str() {
        "json" => true,
        "gltf" | "glb" => false,
        _ => return Err(CliError::invalid(format!("{}: cannot tell the output format from `{ext}` (expected .json, .gltf or .glb)", output.display()))),
    };
    // A converted scene's paths are written relative to the output's folder.
    let options = input::LoadOptions { camera: camera.map(camera_choice), scene_dir: json_out.then(|| out_dir.clone()) };
    let mut inp = input::load_with(input_path, &options)?;
    for w in &inp.warnings {
        eprintln!("warning: {}: {w}", input_path.display());
    }
    if json_out {
        rebase_paths(&mut inp.scene, &inp.base_dir, &out_dir);
        write_text_atomically(output, &schema::to_json(&inp.scene))?;
    } else {
        let warnings = lumo_converters::gltf::export(&inp.scene, &inp.base_dir, output).map_err(|e| match e {
            lumo_converters::gltf::GltfError::Io { .. } => CliError::failure(e.to_string()),
            _ => CliError::invalid(e.to_string()),
        })?;
        for w in warnings {
            eprintln!("warning: {}: {w}", output.display());
        }
    }
    eprintln!("wrote {}", output.display());
    Ok(())
}

/// Rewrites the scene's file paths (relative to `from`) to be relative to `to`.
fn rebase_paths(scene: &mut schema::Scene, from: &Path, to: &Path) {
    let rel = |f: &mut String| *f = lumo_converters::gltf::relative_path(&from.join(&*f), to);
    if lumo_converters::gltf::relative_path(from, to) == "." {
        return;
    }
    for t in scene.textures.values_mut() {
        rel(&mut t.file);
    }
    for o in &mut scene.objects {
        if let schema::Object::Mesh(m) = o {
            match &mut m.source {
                schema::MeshSource::Obj(f) => rel(f),
                schema::MeshSource::Gltf(g) => rel(&mut g.file),
                schema::MeshSource::Inline(_) => {}
            }
        }
    }
}

fn schema_cmd(output: Option<&Path>) -> Result<(), CliError> {
    let text = schema::json_schema();
    match output {
        None => {
            print!("{text}");
            Ok(())
        }
        Some(path) => write_text_atomically(path, &text),
    }
}

/// Writes a text file via a temporary file and rename.
pub fn write_text_atomically(path: &Path, text: &str) -> Result<(), CliError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let fail = |e: std::io::Error| CliError::failure(format!("{}: {e}", path.display()));
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(fail)?;
    std::io::Write::write_all(&mut tmp, text.as_bytes()).map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

fn validate_cmd(files: &[PathBuf]) -> Result<(), CliError> {
    let mut worst = 0;
    let mut report = String::new();
    for f in files {
        match input::load(f) {
            Ok(inp) => {
                for w in &inp.warnings {
                    eprintln!("warning: {}: {w}", f.display());
                }
                println!("{}: ok", f.display());
            }
            Err(e) => {
                // 2 (invalid) outranks 1 (I/O) when files fail in different ways.
                worst = worst.max(e.code);
                report.push_str(&e.message);
                report.push('\n');
            }
        }
    }
    if worst == 0 {
        Ok(())
    } else {
        Err(CliError { code: worst, message: report.trim_end().to_string() })
    }
}

fn render_cmd(args: &RenderArgs, external: &dyn ExternalData) -> Result<(), CliError> {
    crate::output::format_of(&args.output).map_err(|e| CliError::invalid(e.to_string()))?;
    let options = input::LoadOptions { camera: args.camera.as_deref().map(camera_choice), scene_dir: None };
    let mut inp = input::load_with(&args.scene, &options)?;
    let s = &mut inp.scene;
    if let Some(v) = args.spp {
        s.render.spp = v;
    }
    if let Some(v) = args.width {
        s.image.width = v;
    }
    if let Some(v) = args.height {
        s.image.height = v;
    }
    if let Some(v) = args.seed {
        s.render.seed = v;
    }
    if let Some(v) = args.max_depth {
        s.render.max_depth = v;
    }
    if let Some(i) = args.integrator {
        s.render.integrator = match i {
            IntegratorArg::Path => schema::Integrator::Path,
            IntegratorArg::Raycast => schema::Integrator::Raycast,
        };
    }
    if let Some(k) = args.sampler {
        s.render.sampler = match k {
            SamplerArg::Sobol => schema::SamplerKind::Sobol,
            SamplerArg::Independent => schema::SamplerKind::Independent,
        };
    }
    let pixels = u64::from(s.image.width) * u64::from(s.image.height);
    if pixels > schema::MAX_PIXELS {
        return Err(CliError::invalid(format!("{}×{} is above the limit of {} pixels", s.image.width, s.image.height, schema::MAX_PIXELS)));
    }
    for w in &inp.warnings {
        eprintln!("warning: {}: {w}", args.scene.display());
    }
    let (scene, warnings) = build(&inp.scene, &inp.base_dir, external).map_err(|e| CliError::invalid(format!("{}: {e}", args.scene.display())))?;
    for w in warnings {
        eprintln!("warning: {}: {w}", args.scene.display());
    }
    let total = u64::from(scene.settings.width) * u64::from(scene.settings.height) * u64::from(scene.settings.spp);
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(total) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {percent}% {human_pos}/{human_len} samples, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let progress = |n: u64| bar.set_position(n);
    let options = RenderOptions { progress: Some(&progress) };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0) as usize)
        .build()
        .map_err(|e| CliError::failure(format!("cannot start worker threads: {e}")))?;
    let (image, stats) = pool.install(|| render(&scene, &options));
    bar.finish_and_clear();
    let tone = match args.tonemap {
        ToneMapArg::Clamp => ToneMap::Clamp,
        ToneMapArg::Aces => ToneMap::Aces,
    };
    write_image(&image, &args.output, tone).map_err(|e| CliError::failure(e.to_string()))?;
    let secs = stats.elapsed.as_secs_f64();
    let nan = if stats.nan_samples > 0 { format!(", {} NaN/Inf samples dropped", stats.nan_samples) } else { String::new() };
    eprintln!(
        "rendered {}×{} at {} spp in {:.2} s: {:.2} M rays/s, {:.2} M samples/s{nan} → {}",
        image.width,
        image.height,
        stats.spp,
        secs,
        stats.rays as f64 / secs / 1e6,
        total as f64 / secs / 1e6,
        args.output.display()
    );
    Ok(())
}
