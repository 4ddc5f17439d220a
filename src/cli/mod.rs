//! The command-line interface: argument parsing and the subcommands.

pub mod bundle;
pub mod converge;
pub mod preview;
pub mod split;

use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::builder::TypedValueParser as _;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lumo_converters::legacy::LightsPolicy;
use lumo_schema as schema;
use lumo_schema::Keyword;

use lumo::job::{self, Finished, Hooks, JobError, JobSettings, LightChoice, RenderJob};
use lumo::load::{LoadError, LoadOptions};
use lumo::output::{write_image, ToneMap};
use lumo::partial_film::PartialFilm;

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
        CliError {
            code: EXIT_INVALID,
            message: message.into(),
        }
    }

    /// I/O or internal failure (exit code 1).
    pub fn failure(message: impl Into<String>) -> Self {
        CliError {
            code: EXIT_FAILURE,
            message: message.into(),
        }
    }
}

impl From<LoadError> for CliError {
    fn from(e: LoadError) -> Self {
        CliError {
            code: if e.is_io() {
                EXIT_FAILURE
            } else {
                EXIT_INVALID
            },
            message: e.to_string(),
        }
    }
}

impl From<JobError> for CliError {
    fn from(e: JobError) -> Self {
        CliError {
            code: if e.is_io() {
                EXIT_FAILURE
            } else {
                EXIT_INVALID
            },
            message: e.to_string(),
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

/// A value parser for a keyword enum of the scene (or the converters, or the output): `--help`
/// lists its keywords and the value parses into the enum itself, so the CLI keeps no copy.
fn keyword<T: Keyword + Send + Sync>() -> impl clap::builder::TypedValueParser<Value = T> {
    clap::builder::PossibleValuesParser::new(T::keywords()).try_map(|s| T::from_keyword(&s))
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to an image (PNG, EXR, HDR or BMP, by extension).
    #[command(
        after_help = "Example:\n  lumo render scenes/cornell.json -o cornell.png --spp 256\nContinue an interrupted render (its checkpoint knows the scene and flags):\n  lumo render --resume cornell.png.checkpoint.npz -o cornell.png",
        args_override_self = true
    )]
    Render(Box<RenderArgs>),
    /// Check scene files and report every problem found (exit code 0 valid, 2 invalid, 1 I/O error).
    #[command(after_help = "Example:\n  lumo validate scenes/*.json")]
    Validate {
        /// Scene files to check.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Changes applied to every file before it is checked.
        #[command(flatten)]
        compose: ComposeArgs,
    },
    /// Render at a ladder of sample counts and report error against time (CSV and log-log plot).
    #[command(
        after_help = "Example:\n  lumo converge scenes/cornell.json --reference tests/reference/cornell_mitsuba_4096.exr --spp 1,4,16,64,256 -o converge"
    )]
    Converge(converge::ConvergeArgs),
    /// Convert a scene between formats, by extension: lumo JSON, legacy text (.txt), glTF (.gltf
    /// with a .bin beside it, or .glb).
    #[command(
        after_help = "Examples:\n  lumo convert legacy.txt -o scene.json\n  lumo convert model.glb -o scene.json --camera 0\n  lumo convert scenes/cornell.json -o cornell.glb"
    )]
    Convert {
        /// Input scene (.json, .gltf, .glb).
        input: PathBuf,
        /// Output file (.json, .gltf, .glb).
        #[arg(short, long)]
        output: PathBuf,
        /// glTF input: the camera to use, by name or index into `cameras` (default: the first).
        #[arg(long, value_name = "NAME|INDEX")]
        camera: Option<String>,
        /// Legacy input: keep or drop the `Lights` block, or decide per scene (see docs/legacy.md).
        #[arg(long, value_parser = keyword::<LightsPolicy>(), default_value = "auto")]
        lights: LightsPolicy,
        /// Changes written into the converted scene.
        #[command(flatten)]
        compose: ComposeArgs,
    },
    /// Merge partial films (`lumo render --samples A..B --film F`, checkpoints) into an image or
    /// a bigger partial film, bit for bit as one render taking all their samples.
    #[command(
        after_help = "Examples:\n  lumo merge a.npz b.npz c.npz -o out.exr\n  lumo merge a.npz b.npz --film ab.npz"
    )]
    Merge {
        /// Partial films (.npz) of one render: sample ranges and/or crop windows.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output image (.png, .exr, .hdr, .bmp).
        #[arg(short, long, required_unless_present = "film")]
        output: Option<PathBuf>,
        /// Write the merged partial film (.npz).
        #[arg(long)]
        film: Option<PathBuf>,
        /// Merge even when pixels or sample indices are missing (each pixel averages what it has).
        #[arg(long)]
        allow_partial: bool,
        /// Tone mapping for 8-bit outputs.
        #[arg(long, value_parser = keyword::<ToneMap>(), default_value = "clamp")]
        tonemap: ToneMap,
    },
    /// Denoise an existing image with Intel Open Image Denoise: a multi-channel EXR (a lumo
    /// render with `--aov albedo,normal`, or a merge of such films), guided by its albedo and
    /// normal channels when it has them. EXR output keeps every channel and the input's beauty
    /// as `noisy.R/G/B`.
    #[command(after_help = "Example:\n  lumo denoise merged.exr -o denoised.exr")]
    Denoise {
        /// The image to denoise (.exr, linear).
        input: PathBuf,
        /// Output image (.exr keeps the channels; .png, .hdr, .bmp get the beauty).
        #[arg(short, long)]
        output: PathBuf,
        /// Tone mapping for 8-bit outputs.
        #[arg(long, value_parser = keyword::<ToneMap>(), default_value = "clamp")]
        tonemap: ToneMap,
    },
    /// Pack a scene (any input kind, with render overrides baked in) and every file it reads into
    /// one zip, for machines that share no filesystem; prints its content hash as JSON.
    #[command(
        after_help = "Example:\n  lumo bundle DamagedHelmet.glb --env ../shared/hdri/studio.exr -o helmet.zip"
    )]
    Bundle(BundleArgs),
    /// Serve a live, progressive render of a scene on a local web page that follows the scene's
    /// files: edit the scene (or a texture) and the page shows the new render.
    #[command(
        after_help = "Example:\n  lumo preview scenes/cornell.json        # then open http://127.0.0.1:8000/"
    )]
    Preview(Box<preview::PreviewArgs>),
    /// Print lumo's version and build id (SHA-256 of the executable) as JSON.
    Version,
    /// Run the language server for scene files over standard input and output (diagnostics
    /// as you type, completion of material and texture names, hover, go to definition).
    #[command(after_help = "Editors start it themselves: see docs/editors.md")]
    Lsp,
    /// Print the JSON Schema of scene files (draft 2020-12).
    #[command(
        after_help = "Example:\n  lumo schema -o schema/scene.schema.json\n  lumo schema --fragment -o schema/scene-fragment.schema.json"
    )]
    Schema {
        /// Write to this file instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// The schema of scene fragments (files a scene includes): every top-level member
        /// optional.
        #[arg(long)]
        fragment: bool,
    },
}

/// Changes to any value of a scene from the command line, shared by every command that loads
/// one (see `lumo_schema::compose`): a merge patch, then each `--set` in order.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ComposeArgs {
    /// Set the value at a JSON path, as lumo's messages print paths (repeatable; a later one
    /// wins): `--set materials.red.base_color=[0.2,0.2,0.8]`, `--set objects[2].sphere.radius=0.5`.
    #[arg(long = "set", value_name = "PATH=JSON")]
    pub set: Vec<String>,
    /// Apply a JSON merge patch (RFC 7396) to the scene before the `--set`s: an object shaped
    /// like the part of the scene it changes, `null` removing a member.
    #[arg(long, value_name = "FILE.json")]
    pub patch: Option<PathBuf>,
}

impl ComposeArgs {
    /// The changes these arguments ask for (every `--set` that does not parse is an error placed
    /// in it), with `shorthands` (from flags such as `--width`) applied after the patch and
    /// before the `--set`s.
    pub fn composition(
        &self,
        shorthands: Vec<schema::compose::Set>,
    ) -> Result<schema::compose::Composition, CliError> {
        let mut c = schema::compose::Composition::from_args(&self.set, self.patch.as_deref())
            .map_err(lumo::load::from_schema)?;
        c.sets.splice(0..0, shorthands);
        Ok(c)
    }
}

/// Command-line changes to a scene that change its pixels (besides the sample count and time
/// budget), shared by `lumo render`, `lumo preview` and `lumo bundle`.
#[derive(Debug, Clone, clap::Args)]
pub struct SceneOverrides {
    /// Any value of the scene (`--set`, `--patch`); the flags below are shorthands of `--set`.
    #[command(flatten)]
    pub compose: ComposeArgs,
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
    /// Light-transport algorithm (overrides the scene).
    #[arg(long, value_parser = keyword::<schema::Integrator>())]
    pub integrator: Option<schema::Integrator>,
    /// Sample sequence (overrides the scene).
    #[arg(long, value_parser = keyword::<schema::SamplerKind>())]
    pub sampler: Option<schema::SamplerKind>,
    /// Legacy `.txt` scenes: keep, drop, or decide per scene (keep when nothing emits) whether
    /// to use the file's Lights block.
    #[arg(long, value_parser = keyword::<LightsPolicy>(), default_value = "auto")]
    pub lights: LightsPolicy,
    /// glTF input: the camera to use, by name or index into `cameras` (default: the first).
    #[arg(long, value_name = "NAME|INDEX")]
    pub camera: Option<String>,
    /// Light the scene with this equirectangular HDR image (.exr, .hdr) instead of its own
    /// background, whatever the input kind.
    #[arg(long, value_name = "FILE.exr")]
    pub env: Option<PathBuf>,
    /// Multiplies the environment's radiance (with --env, or the scene's own background).
    #[arg(long, value_name = "S")]
    pub env_strength: Option<f32>,
    /// Rotates the --env image about +y, in degrees, counter-clockwise seen from above.
    #[arg(long, value_name = "DEG", requires = "env")]
    pub env_rotation: Option<f32>,
}

/// Arguments of `lumo bundle`.
#[derive(Debug, clap::Args)]
pub struct BundleArgs {
    /// The scene to pack.
    pub scene: PathBuf,
    /// The bundle to write (.zip).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Changes to the scene, baked into the bundle.
    #[command(flatten)]
    pub overrides: SceneOverrides,
}

/// Arguments of `lumo render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The scene to render (with `--resume`, default: the one the checkpoint records).
    #[arg(required_unless_present = "resume")]
    pub scene: Option<PathBuf>,
    /// Output image; the format follows the extension (.png, .exr, .hdr, .bmp).
    #[arg(short, long, required_unless_present = "film")]
    pub output: Option<PathBuf>,
    /// Samples per pixel (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(schema::MAX_SPP)))]
    pub spp: Option<u32>,
    /// Render exactly sample indices A to B−1 of every pixel (for `--film`; excludes `--spp`).
    #[arg(long, value_name = "A..B", value_parser = split::parse_samples, conflicts_with = "spp")]
    pub samples: Option<(u32, u32)>,
    /// Render only pixels x0..x1 × y0..y1 of the image (the film records where they sit).
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = split::parse_crop)]
    pub crop: Option<lumo::render::Window>,
    /// Write the render's exact sums as a partial film (.npz), for `lumo merge`.
    #[arg(long, value_name = "PART.npz")]
    pub film: Option<PathBuf>,
    /// Keep a checkpoint (a partial film, .npz) to resume from; written every
    /// `--checkpoint-every` and when the render is interrupted.
    #[arg(long, value_name = "CK.npz")]
    pub checkpoint: Option<PathBuf>,
    /// How often to write the checkpoint (default 5m).
    #[arg(long, value_parser = parse_duration, requires = "checkpoint")]
    pub checkpoint_every: Option<f32>,
    /// Continue the render saved in this checkpoint, to `--spp` or else to its own target; the
    /// result is bit-identical to an uninterrupted render.
    #[arg(long, value_name = "CK.npz", conflicts_with = "samples")]
    pub resume: Option<PathBuf>,
    /// Changes to the scene (size, seed, depth, integrator, sampler, input choices,
    /// environment).
    #[command(flatten)]
    pub overrides: SceneOverrides,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub threads: Option<u32>,
    /// Tone mapping for 8-bit outputs (PNG, BMP); EXR and HDR stay linear.
    #[arg(long, value_parser = keyword::<ToneMap>(), default_value = "clamp")]
    pub tonemap: ToneMap,
    /// Render progressive passes for this long (e.g. `30s`, `2m`, `500ms`); `--spp`, when
    /// given, still caps the samples.
    #[arg(long, value_parser = parse_duration)]
    pub time: Option<f32>,
    /// Stop when the estimated relative error (from the samples' variance) falls below this.
    /// The estimate treats samples as independent: right for `--sampler independent`,
    /// conservative for Sobol points, whose true error is lower (about half on the Cornell box).
    #[arg(long)]
    pub target_error: Option<f64>,
    /// Distribute samples by per-pixel error estimates.
    #[arg(long)]
    pub adaptive: bool,
    /// Print RMSE and relative MSE against this reference image (linear EXR/HDR).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// How next-event estimation chooses a light: `auto` (a light tree from
    /// 3 finite lights on), `power` (by power alone), `tree` (by the light tree). For comparing
    /// them: the image is unbiased either way, its noise differs.
    #[arg(long, value_enum, default_value = "auto")]
    pub light_sampler: LightSamplerArg,
    /// Also write the per-pixel standard-error image (linear, EXR/HDR by extension).
    #[arg(long)]
    pub error_image: Option<PathBuf>,
    /// Render passes besides the beauty, comma-separated: albedo, normal, depth, position, uv,
    /// object_id, material_id, std_error. EXR output holds them as channels of one part
    /// (`albedo.R`, `normal.X`, `depth.Z`, …); PNG output gets each as a file beside the image
    /// (`OUT.albedo.png`). Definitions: docs/passes.md.
    #[arg(long, value_name = "PASSES", value_parser = parse_aovs)]
    pub aov: Option<lumo::aov::AovSet>,
    /// Denoise the beauty with Intel Open Image Denoise, guided by the albedo and normal passes
    /// (rendered for it); the noisy beauty is kept as the pass `noisy` (EXR) or `OUT.noisy.png`.
    /// OIDN is loaded at run time from LUMO_OIDN (see `pip install pyoidn`), OIDN_DIR or the
    /// system's library path.
    #[arg(long)]
    pub denoise: bool,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Parses `--aov`'s list of passes.
fn parse_aovs(text: &str) -> Result<lumo::aov::AovSet, String> {
    text.parse()
}

/// `--light-sampler`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LightSamplerArg {
    /// The tree from [`lumo::light_sampler::LightSampler::TREE_MIN_LIGHTS`] finite lights on.
    Auto,
    /// By power alone.
    Power,
    /// By the light tree.
    Tree,
}

/// Parses `30s`, `2m`, `1.5h`, `500ms` or a plain number of seconds.
fn parse_duration(text: &str) -> Result<f32, String> {
    let t = text.trim();
    let (num, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('h') {
        (n, 3600.0)
    } else {
        (t, 1.0)
    };
    match num.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v * scale),
        _ => Err(format!(
            "`{text}` is not a duration (examples: 30s, 2m, 500ms)"
        )),
    }
}

/// Runs the CLI; returns the process exit code.
pub fn run(cli: Cli) -> Result<(), CliError> {
    lumo::lanes::width_from_env().map_err(CliError::invalid)?;
    match cli.command {
        Command::Render(args) => render_cmd(&args),
        Command::Convert {
            input,
            output,
            camera,
            lights,
            compose,
        } => convert_cmd(&input, &output, camera.as_deref(), lights, &compose),
        Command::Validate { files, compose } => validate_cmd(&files, &compose),
        Command::Schema { output, fragment } => schema_cmd(output.as_deref(), fragment),
        Command::Version => bundle::version_cmd(),
        Command::Lsp => {
            lumo::lsp::run_stdio().map_err(|e| CliError::failure(format!("lumo lsp: {e}")))
        }
        Command::Preview(args) => preview::preview_cmd(&args),
        Command::Bundle(a) => bundle::bundle_cmd(&a.scene, &a.overrides, &a.output),
        Command::Merge {
            parts,
            output,
            film,
            allow_partial,
            tonemap,
        } => split::merge_cmd(
            &parts,
            output.as_deref(),
            film.as_deref(),
            allow_partial,
            tonemap,
        ),
        Command::Converge(args) => converge::run(&args).map(|_| ()),
        Command::Denoise {
            input,
            output,
            tonemap,
        } => denoise_cmd(&input, &output, tonemap),
    }
}

/// `lumo denoise`: reads a multi-channel EXR, denoises its beauty guided by its albedo and
/// normal channels, writes the result (with every channel and the noisy beauty, for EXR).
fn denoise_cmd(input: &Path, output: &Path, tonemap: ToneMap) -> Result<(), CliError> {
    use lumo::multilayer::{read_exr, write_exr, ChannelGroup};
    job::check_image_path(output, "output")?;
    let mut oidn = lumo::denoise::Oidn::load().map_err(|e| CliError::invalid(e.to_string()))?;
    if lumo_schema::geometry::paths::lowercase_extension(input) != "exr" {
        return Err(CliError::invalid(format!(
            "{}: lumo denoise reads linear OpenEXR images (.exr), such as `lumo render … --aov \
             albedo,normal -o IN.exr` writes",
            input.display()
        )));
    }
    let layered = read_exr(input).map_err(|e| CliError::invalid(e.to_string()))?;
    let (w, h) = (layered.beauty.width, layered.beauty.height);
    let guide = |name: &str| layered.group(name).and_then(|g| g.to_rgb(w, h));
    let (albedo, normal) = (guide("albedo"), guide("normal"));
    if albedo.is_none() {
        eprintln!(
            "warning: {}: no albedo.R/G/B channels: denoising the colour alone (render with \
             --aov albedo,normal for guides that keep texture and edges)",
            input.display()
        );
    }
    let denoised = oidn
        .denoise(
            &layered.beauty,
            albedo.as_ref(),
            normal.as_ref(),
            lumo::denoise::Prefilter::Clean,
        )
        .map_err(|e| CliError::failure(e.to_string()))?;
    let result = if lumo_schema::geometry::paths::lowercase_extension(output) == "exr" {
        let mut groups: Vec<ChannelGroup> = Vec::new();
        if layered.group("noisy").is_none() {
            groups.push(ChannelGroup::from_rgb("noisy", &layered.beauty));
        }
        groups.extend(layered.groups.iter().cloned());
        write_exr(output, &denoised, &groups)
    } else {
        write_image(&denoised, output, tonemap)
    };
    result.map_err(|e| CliError::failure(e.to_string()))?;
    eprintln!("denoised {} → {}", input.display(), output.display());
    Ok(())
}

fn camera_choice(s: &str) -> lumo_converters::gltf::CameraChoice {
    match s.parse() {
        Ok(c) => c,
        Err(never) => match never {},
    }
}

fn convert_cmd(
    input_path: &Path,
    output: &Path,
    camera: Option<&str>,
    lights: LightsPolicy,
    compose: &ComposeArgs,
) -> Result<(), CliError> {
    let ext = lumo_schema::geometry::paths::lowercase_extension(output);
    let out_dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !out_dir.is_dir() {
        return Err(CliError::failure(format!(
            "{}: the output folder does not exist",
            output.display()
        )));
    }
    let (json_out, legacy_out) = match ext.as_str() {
        "json" => (true, false),
        "txt" => (false, true),
        "gltf" | "glb" => (false, false),
        _ => {
            return Err(CliError::invalid(format!(
            "{}: cannot tell the output format from `{ext}` (expected .json, .txt, .gltf or .glb)",
            output.display()
        )))
        }
    };
    // A converted scene's paths are written relative to the output's folder.
    let options = LoadOptions {
        lights,
        camera: camera.map(camera_choice),
        scene_dir: json_out.then(|| out_dir.clone()),
        composition: compose.composition(Vec::new())?,
        defer_input_hash: false,
    };
    let inp = lumo::load::read_scene(input_path, &options)?;
    let base_dir = inp.base_dir;
    let mut scene = inp.scene.into_inner();
    for w in &inp.warnings {
        eprintln!("warning: {}: {w}", input_path.display());
    }
    if json_out {
        rebase_paths(&mut scene, &base_dir, &out_dir);
        scene.schema = Some(schema::SCENE_SCHEMA.into());
        write_text_atomically(output, &schema::to_json(&scene))?;
        write_schema_beside(&out_dir)?;
    } else if legacy_out {
        rebase_paths(&mut scene, &base_dir, &out_dir);
        let text = lumo_converters::legacy::export(&scene, &out_dir)
            .map_err(|e| CliError::invalid(format!("{}: {e}", output.display())))?;
        write_text_atomically(output, &text)?;
    } else {
        let warnings =
            lumo_converters::gltf::export(&scene, &base_dir, output).map_err(|e| match e {
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

/// Writes the scene schema ([`schema::SCENE_SCHEMA`]) into `dir`, where a scene written by
/// `lumo convert` finds it, unless it is there already; an older lumo's schema is brought up
/// to date, a file of that name that is not lumo's is left alone with a warning.
fn write_schema_beside(dir: &Path) -> Result<(), CliError> {
    let path = dir.join(schema::SCENE_SCHEMA);
    let text = schema::json_schema();
    match std::fs::read_to_string(&path) {
        Ok(existing) if existing == text => Ok(()),
        Ok(existing) => {
            let title = serde_json::from_str::<serde_json::Value>(&existing)
                .ok()
                .and_then(|v| v.get("title")?.as_str().map(str::to_string));
            if title.as_deref() == Some("lumo scene") {
                write_text_atomically(&path, &text)?;
                eprintln!("updated {}", path.display());
            } else {
                eprintln!(
                    "warning: {}: not lumo's scene schema, left as it is (editors will check \
                     the scene against it; `lumo schema -o FILE` writes lumo's)",
                    path.display()
                );
            }
            Ok(())
        }
        Err(_) => {
            write_text_atomically(&path, &text)?;
            eprintln!("wrote {}", path.display());
            Ok(())
        }
    }
}

/// Rewrites the scene's file paths (relative to `from`) as a file in `to` stores them:
/// relative when near, absolute otherwise ([`lumo_schema::geometry::paths::portable`]).
fn rebase_paths(scene: &mut schema::Scene, from: &Path, to: &Path) {
    use lumo_schema::geometry::paths::portable;
    let rel = |f: &mut String| {
        if !Path::new(f.as_str()).is_absolute() {
            *f = portable(&from.join(&*f), to);
        }
    };
    if lumo_converters::gltf::relative_path(from, to) == "." {
        return;
    }
    if let Some(image) = &mut scene.background.image {
        rel(image);
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

fn schema_cmd(output: Option<&Path>, fragment: bool) -> Result<(), CliError> {
    let text = if fragment {
        schema::json_fragment_schema()
    } else {
        schema::json_schema()
    };
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
    let mut tmp = lumo::output::temp_file_in(dir).map_err(fail)?;
    std::io::Write::write_all(&mut tmp, text.as_bytes()).map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

fn validate_cmd(files: &[PathBuf], compose: &ComposeArgs) -> Result<(), CliError> {
    let mut worst = 0;
    let mut report = String::new();
    let options = LoadOptions {
        composition: compose.composition(Vec::new())?,
        ..LoadOptions::default()
    };
    for f in files {
        if lumo::load::is_fragment_file(f) {
            match schema::check_fragment_file(f) {
                Ok(_) => println!("{}: ok (a scene fragment)", f.display()),
                Err(e) => {
                    let e = CliError::from(lumo::load::from_schema(e));
                    worst = worst.max(e.code);
                    report.push_str(&e.message);
                    report.push('\n');
                }
            }
            continue;
        }
        match lumo::load::read_scene(f, &options) {
            Ok(inp) => {
                for w in &inp.warnings {
                    eprintln!("warning: {}: {w}", f.display());
                }
                println!("{}: ok", f.display());
            }
            Err(e) => {
                // 2 (invalid) outranks 1 (I/O) when files fail in different ways.
                let e = CliError::from(e);
                worst = worst.max(e.code);
                report.push_str(&e.message);
                report.push('\n');
            }
        }
    }
    if worst == 0 {
        Ok(())
    } else {
        Err(CliError {
            code: worst,
            message: report.trim_end().to_string(),
        })
    }
}

/// Loads a scene of any input kind and applies the overrides.
pub fn load_overridden(scene: &Path, o: &SceneOverrides) -> Result<lumo::load::Loaded, CliError> {
    load_with(scene, o, false)
}

/// [`load_overridden`], with the input not hashed while it is parsed when `defer_input_hash`
/// ([`LoadOptions::defer_input_hash`]).
fn load_with(
    scene: &Path,
    o: &SceneOverrides,
    defer_input_hash: bool,
) -> Result<lumo::load::Loaded, CliError> {
    let options = LoadOptions {
        lights: o.lights,
        camera: o.camera.as_deref().map(camera_choice),
        scene_dir: None,
        composition: o.compose.composition(shorthands(o)?)?,
        defer_input_hash,
    };
    Ok(lumo::load(scene, &options)?)
}

/// The flags that are shorthands of `--set`, as overrides.
fn shorthands(o: &SceneOverrides) -> Result<Vec<schema::compose::Set>, CliError> {
    use schema::compose::Set;
    use serde_json::json;
    let mut sets = Vec::new();
    let mut add = |flag: &str, path: &str, value: Option<serde_json::Value>| {
        if let Some(v) = value {
            sets.push(Set::shorthand(flag, path, v));
        }
    };
    add("--width", "image.width", o.width.map(|v| json!(v)));
    add("--height", "image.height", o.height.map(|v| json!(v)));
    add("--seed", "render.seed", o.seed.map(|v| json!(v)));
    add(
        "--max-depth",
        "render.max_depth",
        o.max_depth.map(|v| json!(v)),
    );
    add(
        "--integrator",
        "render.integrator",
        o.integrator.map(|v| json!(v.keyword())),
    );
    add(
        "--sampler",
        "render.sampler",
        o.sampler.map(|v| json!(v.keyword())),
    );
    // The environment file is named relative to the working directory; the scene's paths are
    // relative to its folder, so it goes in as an absolute path.
    if let Some(p) = &o.env {
        let file = std::path::absolute(p)
            .map_err(|e| CliError::invalid(format!("{}: {e}", p.display())))?
            .to_string_lossy()
            .into_owned();
        let mut background = json!({ "image": file });
        if let Some(r) = o.env_rotation {
            background["rotation_deg"] = json!(r);
        }
        add("--env", "background", Some(background));
    }
    add(
        "--env-strength",
        "background.strength",
        o.env_strength.map(|v| json!(v)),
    );
    Ok(sets)
}

/// The warnings of loading a scene that still hold after the overrides: with `--env`, the
/// glTF default environment that one warning talks about is gone.
pub fn load_warnings<'a>(
    loaded: &'a lumo::load::Loaded,
    o: &SceneOverrides,
) -> impl Iterator<Item = &'a String> {
    let env_replaced = o.env.is_some();
    loaded.description.warnings.iter().filter(move |w| {
        !(env_replaced && w.starts_with(lumo_converters::gltf::DEFAULT_ENVIRONMENT_WARNING))
    })
}

/// `lumo render --resume CK` without a scene: the scene and flags the checkpoint records, then
/// this command's own flags (which win).
fn resume_recorded(ck: &Path) -> Result<(), CliError> {
    let film = split::read_film(ck)?;
    let Some(command) = film.header.command else {
        return Err(CliError::invalid(format!(
            "{}: this checkpoint does not record the scene it renders (it was written by \
             `lumo merge` or another program): name the scene, as in \
             lumo render SCENE --resume {} -o OUT",
            ck.display(),
            ck.display()
        )));
    };
    let mut argv: Vec<std::ffi::OsString> = vec!["lumo".into(), "render".into()];
    argv.extend(command.into_iter().map(Into::into));
    argv.extend(std::env::args_os().skip(2));
    let parsed = Cli::try_parse_from(argv).map_err(|e| {
        CliError::invalid(format!(
            "{}: the command it records does not parse with this lumo: {e}",
            ck.display()
        ))
    })?;
    match parsed.command {
        Command::Render(args) if args.scene.is_some() => render_cmd(&args),
        _ => Err(CliError::invalid(format!(
            "{}: the command it records names no scene",
            ck.display()
        ))),
    }
}

/// The arguments after `lumo render` that render the same scene as `args` (its absolute path
/// and every flag that changes pixels): what checkpoints record for `--resume` alone.
fn recorded_command(args: &RenderArgs, scene: &Path) -> Vec<String> {
    let absolute = |p: &Path| {
        std::path::absolute(p)
            .unwrap_or_else(|_| p.to_path_buf())
            .to_string_lossy()
            .into_owned()
    };
    let mut c = vec![absolute(scene)];
    let mut flag = |name: &str, value: Option<String>| {
        if let Some(v) = value {
            c.push(format!("--{name}"));
            c.push(v);
        }
    };
    let o = &args.overrides;
    flag("patch", o.compose.patch.as_deref().map(absolute));
    for set in &o.compose.set {
        flag("set", Some(set.clone()));
    }
    flag("width", o.width.map(|v| v.to_string()));
    flag("height", o.height.map(|v| v.to_string()));
    flag("seed", o.seed.map(|v| v.to_string()));
    flag("max-depth", o.max_depth.map(|v| v.to_string()));
    flag("integrator", o.integrator.map(|v| v.keyword().to_string()));
    flag("sampler", o.sampler.map(|v| v.keyword().to_string()));
    flag("lights", Some(o.lights.keyword().to_string()));
    flag("camera", o.camera.clone());
    flag("env", o.env.as_deref().map(absolute));
    flag("env-strength", o.env_strength.map(|v| v.to_string()));
    flag("env-rotation", o.env_rotation.map(|v| v.to_string()));
    flag(
        "light-sampler",
        clap::ValueEnum::to_possible_value(&args.light_sampler).map(|v| v.get_name().to_string()),
    );
    flag(
        "crop",
        args.crop
            .map(|w| format!("{},{},{},{}", w.x0, w.y0, w.x1, w.y1)),
    );
    flag("target-error", args.target_error.map(|v| v.to_string()));
    let aovs = render_aovs(args);
    flag("aov", (!aovs.is_empty()).then(|| aovs.to_string()));
    c
}

/// A command line as a shell would take it back: arguments with spaces or quotes in single
/// quotes.
fn shell_words(words: &[String]) -> String {
    words
        .iter()
        .map(|w| {
            if !w.is_empty()
                && w.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./,:=+@%".contains(c))
            {
                w.clone()
            } else {
                format!("'{}'", w.replace('\'', "'\\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Checks every output path of `lumo render` before anything is rendered; returns where the
/// checkpoint goes if the render is interrupted.
fn check_render_outputs(args: &RenderArgs) -> Result<Option<PathBuf>, CliError> {
    if let Some(o) = &args.output {
        job::check_image_path(o, "output")?;
    }
    if let Some(p) = &args.error_image {
        job::check_image_path(p, "error image")?;
    }
    if let Some(f) = &args.film {
        job::check_film_path(f, "film")?;
    }
    if let Some(c) = &args.checkpoint {
        job::check_film_path(c, "checkpoint")?;
    }
    if args.film.is_some() && (args.adaptive || args.target_error.is_some() || args.time.is_some())
    {
        return Err(CliError::invalid(job::SPLIT_EXCLUDES_BUDGETS));
    }
    Ok(match (&args.checkpoint, &args.output) {
        (Some(c), _) => Some(c.clone()),
        (None, Some(o)) => Some(job::default_checkpoint(o)),
        // A sample range rendered for `lumo merge`: beside the film.
        (None, None) => args.film.as_deref().map(job::default_checkpoint),
    })
}

/// The job settings `lumo render`'s arguments ask for.
fn job_settings(args: &RenderArgs, scene: &Path, resume: Option<PartialFilm>) -> JobSettings {
    JobSettings {
        spp: args.spp,
        samples: args.samples,
        crop: args.crop,
        time_s: args.time,
        target_error: args.target_error,
        adaptive: args.adaptive,
        light_sampler: match args.light_sampler {
            LightSamplerArg::Auto => LightChoice::Auto,
            LightSamplerArg::Power => LightChoice::Power,
            LightSamplerArg::Tree => LightChoice::Tree,
        },
        threads: args.threads.map(|t| t as usize),
        lane_width: None,
        resume,
        checkpoint: args.checkpoint.clone().map(|path| job::Checkpointing {
            path,
            every: args
                .checkpoint_every
                .map_or(Duration::from_secs(300), Duration::from_secs_f32),
        }),
        command: Some(recorded_command(args, scene)),
        aovs: render_aovs(args),
        defer_scene_hash: defers_scene_hash(args),
    }
}

/// Whether a render's films are only a possibility (the checkpoint kept when it is
/// interrupted), so that the scene's content hash is taken only if one is written: not with
/// `--film`, `--checkpoint` or `--resume`, whose films are the point of the render.
fn defers_scene_hash(args: &RenderArgs) -> bool {
    args.film.is_none() && args.checkpoint.is_none() && args.resume.is_none()
}

/// The passes a render keeps: `--aov`'s, with albedo and normal for `--denoise`.
fn render_aovs(args: &RenderArgs) -> lumo::aov::AovSet {
    use lumo::aov::{Aov, AovSet};
    let asked = args.aov.unwrap_or(AovSet::NONE);
    if args.denoise {
        asked.with(Aov::Albedo).with(Aov::Normal)
    } else {
        asked
    }
}

/// A progress bar over `total` samples (spinning when open-ended), hidden with `--quiet`.
fn progress_bar(quiet: bool, total: Option<u64>) -> ProgressBar {
    let bar = match (quiet, total) {
        (true, _) => ProgressBar::hidden(),
        (false, Some(total)) => ProgressBar::new(total),
        (false, None) => ProgressBar::no_length(),
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {percent}% {human_pos}/{human_len} samples, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// After an interruption: writes the image of the samples taken and the checkpoint, and says
/// so in the error that carries the signal's exit code.
fn keep_interrupted(
    args: &RenderArgs,
    finished: &Finished,
    checkpoint: Option<&Path>,
    code: i32,
) -> CliError {
    let taken = finished.samples_per_pixel();
    let mut said = format!(
        "interrupted after {taken} samples per pixel ({} in all)",
        finished.stats.samples
    );
    if let (Some(o), true) = (&args.output, taken > 0) {
        // With its passes, as an uninterrupted render writes it (not denoised: a stopped
        // render is for a look or a resume, and the noisy beauty is what resumes continue).
        if let Err(e) = finished.write_output(o, args.tonemap, checkpoint, None) {
            return CliError::failure(e.to_string());
        }
        said += &format!("; wrote {}", o.display());
    }
    match (checkpoint, finished.checkpoint()) {
        (Some(c), Some(ck)) => {
            if let Err(e) = split::write_film(&ck, c) {
                return e;
            }
            said += &format!(
                "; checkpoint {} (resume with --resume {})",
                c.display(),
                c.display()
            );
        }
        _ if !finished.uniform => said += "; adaptive renders keep no checkpoint",
        (Some(_), None) => {
            if let Some(why) = finished.scene_hash_failure() {
                said += &format!("; no checkpoint: {why}");
            }
        }
        _ => {}
    }
    CliError {
        code,
        message: said,
    }
}

/// `lumo render`: the arguments as a [`RenderJob`], a progress bar, and messages.
fn render_cmd(args: &RenderArgs) -> Result<(), CliError> {
    let Some(scene_path) = args.scene.as_deref() else {
        return match &args.resume {
            Some(ck) => resume_recorded(ck),
            None => Err(CliError::invalid("give the scene to render")),
        };
    };
    // From here on, Ctrl-C stops the render and keeps what it has (nothing, while loading).
    let signals = split::Signals::install()?;
    let checkpoint = check_render_outputs(args)?;
    // The denoiser is found before rendering, so a missing library costs no render.
    let mut oidn = if args.denoise {
        if args.output.is_none() {
            return Err(CliError::invalid(
                "--denoise denoises the output image; give -o OUT",
            ));
        }
        Some(lumo::denoise::Oidn::load().map_err(|e| CliError::invalid(e.to_string()))?)
    } else {
        None
    };
    let resume = match &args.resume {
        Some(p) => Some(split::read_film(p)?),
        None => None,
    };
    let loaded = load_with(scene_path, &args.overrides, defers_scene_hash(args))?;
    let reference = match &args.reference {
        Some(p) => Some(lumo::output::read_image(p).map_err(|e| CliError::failure(e.to_string()))?),
        None => None,
    };
    for w in load_warnings(&loaded, &args.overrides) {
        eprintln!("warning: {}: {w}", scene_path.display());
    }
    let recorded = resume.as_ref().and_then(|r| r.header.command.clone());
    let settings = job_settings(args, scene_path, resume);
    let render_job = RenderJob::new(&loaded, settings).map_err(|e| match (e, &args.resume) {
        (JobError::Resume(m), Some(ck)) => {
            let rerun = match &recorded {
                Some(c) => format!(
                    "\n  the checkpoint's render: lumo render {} --resume {}",
                    shell_words(c),
                    shell_words(&[ck.display().to_string()])
                ),
                None => String::new(),
            };
            CliError::invalid(format!("{}: {m}{rerun}", ck.display()))
        }
        (e, _) => e.into(),
    })?;
    if let (Some(r), Some(path)) = (&reference, &args.reference) {
        let (w, h) = (render_job.width(), render_job.height());
        if (r.width, r.height) != (w, h) {
            return Err(CliError::invalid(format!(
                "{}: reference is {}×{} but the render is {w}×{h}",
                path.display(),
                r.width,
                r.height,
            )));
        }
    }
    for w in render_job.warnings() {
        eprintln!("warning: {}: {w}", scene_path.display());
    }
    let bar = progress_bar(args.quiet, render_job.total_samples());
    let progress = |n: u64| bar.set_position(n);
    let warn = |w: &str| bar.suspend(|| eprintln!("warning: {w}"));
    let finished = render_job.run(&Hooks {
        progress: Some(&progress),
        cancel: Some(&signals.cancel),
        warn: Some(&warn),
        on_pass: None,
    })?;
    bar.finish_and_clear();
    if finished.interrupted {
        let code = signals.exit_code();
        return Err(keep_interrupted(
            args,
            &finished,
            checkpoint.as_deref(),
            code,
        ));
    }
    if let Some(f) = &args.film {
        split::write_film(finished.film(), f)?;
        if args.output.is_none() {
            let (first, w) = (render_job.first_sample(), render_job.window());
            eprintln!(
                "rendered samples {first}..{} of pixels {}..{} × {}..{} in {:.2} s → {}",
                first + finished.samples_per_pixel(),
                w.x0,
                w.x1,
                w.y0,
                w.y1,
                finished.stats.elapsed.as_secs_f64(),
                f.display()
            );
            return Ok(());
        }
    }
    let Some(output) = &args.output else {
        return Ok(());
    };
    let denoised = match &mut oidn {
        Some(oidn) => {
            let start = std::time::Instant::now();
            let image = finished
                .denoised(oidn)
                .map_err(|e| CliError::failure(e.to_string()))?;
            if !args.quiet {
                eprintln!(
                    "denoised in {:.3} s with {}",
                    start.elapsed().as_secs_f64(),
                    oidn.path.display()
                );
            }
            Some(image)
        }
        None => None,
    };
    finished.write_output(
        output,
        args.tonemap,
        checkpoint.as_deref(),
        denoised.as_ref(),
    )?;
    if let Some(path) = &args.error_image {
        write_image(&finished.std_error, path, ToneMap::Clamp)
            .map_err(|e| CliError::failure(e.to_string()))?;
    }
    eprintln!(
        "{} → {}",
        finished.summary(reference.as_ref()),
        output.display()
    );
    Ok(())
}
