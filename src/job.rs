//! A render job: one loaded scene rendered with one set of job settings (samples or a sample
//! range, window, budgets, a checkpoint to resume, checkpoints to keep), with everything that
//! makes its output a *partial film* that merges: the film header and the rule that decides
//! which films and checkpoints belong to one render.
//!
//! `lumo render`, `lumo preview`'s saves, the Dask driver (through `lumo render --samples`) and
//! the Python package all render through [`RenderJob`], so a film written by any of them merges
//! with the others of the same build, and a checkpoint resumes into the bytes of an
//! uninterrupted render.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use lumo::job::{Hooks, JobSettings, RenderJob};
//! let loaded = lumo::load("scenes/cornell.json", &lumo::LoadOptions::default())?;
//! let job = RenderJob::new(&loaded, JobSettings { spp: Some(64), ..Default::default() })?;
//! let finished = job.run(&Hooks::default())?;
//! finished.write_image("cornell.exr".as_ref(), lumo::output::ToneMap::Clamp, None)?;
//! # Ok(())
//! # }
//! ```

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use lumo_schema as schema;

use crate::aov::{Aov, AovSet, PassImage, PassPixels};
use crate::denoise::{DenoiseError, Oidn, Prefilter};
use crate::image::Image;
use crate::light_sampler::{LightSampler, LightSamplerKind};
use crate::load::{HashInputs, LoadError, Loaded};
use crate::multilayer::ChannelGroup;
use crate::output::{write_image, ToneMap};
use crate::partial_film::{self, FilmHeader, PartialFilm};
use crate::render::{render_with_error, Film, RenderOptions, Rendered, Stats, Window};
use crate::scene::{IntegratorKind, Scene};

/// How next-event estimation chooses a light.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightChoice {
    /// The light tree from [`LightSampler::TREE_MIN_LIGHTS`] finite lights on, else by power.
    #[default]
    Auto,
    /// By power alone.
    Power,
    /// By the light tree.
    Tree,
}

/// Checkpoints written while a job renders.
#[derive(Debug, Clone)]
pub struct Checkpointing {
    /// The checkpoint file (a partial film, `.npz`).
    pub path: PathBuf,
    /// How often to write it.
    pub every: Duration,
}

/// What a job renders besides the scene: how many samples, where, for how long, from where on.
#[derive(Debug, Clone, Default)]
pub struct JobSettings {
    /// Samples per pixel (default: the scene's; with a time budget or an error target and no
    /// sample count, as many as the budget allows).
    pub spp: Option<u32>,
    /// Render exactly sample indices `a..b` of every pixel (a part of a render split by sample
    /// ranges); excludes `spp`.
    pub samples: Option<(u32, u32)>,
    /// Render only this window of the image (the film records where it sits).
    pub crop: Option<Window>,
    /// Render progressive passes for this many seconds (`spp`, when given, still caps).
    pub time_s: Option<f32>,
    /// Stop when the estimated relative error falls below this.
    pub target_error: Option<f64>,
    /// Distribute samples by per-pixel error estimates.
    pub adaptive: bool,
    /// How next-event estimation chooses a light.
    pub light_sampler: LightChoice,
    /// Worker threads, in a pool of the job's own (default: the current rayon pool, which is
    /// all cores unless the caller installed another). The image does not depend on it.
    pub threads: Option<usize>,
    /// Paths each thread runs at once in SIMD lanes: 1, 4, 8 or 16 (default: this CPU's widest,
    /// or `LUMO_SIMD`). The image does not depend on it.
    pub lane_width: Option<usize>,
    /// Continue the render saved in this checkpoint: to `spp`, else to its own target.
    pub resume: Option<PartialFilm>,
    /// Keep a checkpoint while rendering.
    pub checkpoint: Option<Checkpointing>,
    /// What checkpoints record as the command that renders this scene
    /// ([`FilmHeader::command`]).
    pub command: Option<Vec<String>>,
    /// Render passes besides the beauty ([`crate::aov`]).
    pub aovs: AovSet,
    /// Take the scene's content hash (the `scene_hash` of the job's films) only when a film or
    /// checkpoint is first made, not while the job is set up: for jobs that make one only if
    /// interrupted (`lumo render` without `--film`, `--checkpoint` or `--resume`), which then
    /// spend no start time on it (a 31 MB glTF: about 20 ms of a core, beside a scene build
    /// that wants every core). A hash taken late is of the files as they are then: when one
    /// of them changed since the scene was loaded (its length or time of last change), the
    /// films carry no hash that any other film matches, and no checkpoint is made. Not with
    /// `resume` or `checkpoint`, which need the hash from the start.
    pub defer_scene_hash: bool,
}

/// Why a job could not be set up or finished.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The scene, after the job's settings were applied, is invalid.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The settings are invalid (a window outside the image, settings that exclude each other).
    #[error("{0}")]
    Invalid(String),
    /// The checkpoint to resume from does not belong to this render; the message says what
    /// differs (it does not name the checkpoint's file, which the caller knows).
    #[error("{0}")]
    Resume(String),
    /// A file could not be read or written, or the machine refused a resource.
    #[error("{0}")]
    Io(String),
}

impl JobError {
    /// Whether the failure is the machine's (I/O), not the input's.
    pub fn is_io(&self) -> bool {
        match self {
            JobError::Load(e) => e.is_io(),
            JobError::Io(_) => true,
            JobError::Invalid(_) | JobError::Resume(_) => false,
        }
    }
}

/// Why sample ranges, windows and films exclude adaptive, time-budgeted and error-targeted
/// renders.
pub const SPLIT_EXCLUDES_BUDGETS: &str =
    "--samples, --crop and --film render fixed sample ranges; --adaptive, --target-error \
     and --time decide samples from the whole image as it renders, so they cannot be \
     split (render without them, or drive the passes yourself with lumo merge)";

/// A scene ready to render with a job's settings: built, checked against the checkpoint it
/// resumes, with the header its films carry.
pub struct RenderJob {
    scene: Scene,
    settings: JobSettings,
    scene_hash: Arc<SceneHash>,
    sampler: String,
    window: Window,
    first_sample: u32,
    notes: Vec<String>,
}

/// What a running job reports to, and listens to.
#[derive(Default)]
pub struct Hooks<'a> {
    /// Called with the number of samples finished so far.
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// When set, the job takes no new work: threads stop within a step of their wave of paths, the pass in flight is
    /// dropped, and the whole passes done so far are returned, marked interrupted.
    pub cancel: Option<&'a AtomicBool>,
    /// Called with a warning while rendering (a checkpoint that could not be written).
    pub warn: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Called after every finished pass with the film so far (a live preview). Setting it
    /// makes the render progressive, with the same image bits.
    pub on_pass: Option<&'a (dyn Fn(&Film) + Sync)>,
}

/// A finished (or interrupted) job.
#[derive(Debug, Clone)]
pub struct Finished {
    /// Mean radiance per pixel of the job's window.
    pub image: Image,
    /// Standard error of each pixel's mean, per channel, of the window.
    pub std_error: Image,
    /// Counters.
    pub stats: Stats,
    /// The job's exact per-pixel sums over its window.
    pub sums: Film,
    /// Whether the cancel flag stopped the job before its budget was spent.
    pub interrupted: bool,
    /// Whether every pixel holds the same samples (false for adaptive renders): only such a
    /// film can be resumed or merged.
    pub uniform: bool,
    /// Samples taken by this run (a resumed job's checkpoint brought the others).
    pub new_samples: u64,
    /// Seconds of a time budget left when the job stopped.
    time_left_s: Option<f64>,
    /// [`JobSettings::command`].
    command: Option<Vec<String>>,
    /// Samples per pixel of the checkpoint the job resumed.
    resumed_spp: Option<u64>,
    /// What the film is of, but its build id, which hashes the running program and is only
    /// worth its time (tens of milliseconds) when a film is asked for, and the scene's hash.
    header: FilmHeader,
    /// The scene's content hash, perhaps still to be taken.
    scene_hash: Arc<SceneHash>,
    /// The partial film, made on first use.
    film: std::sync::OnceLock<PartialFilm>,
    /// The render passes asked for.
    aovs: AovSet,
}

/// A job's scene content hash ([`Loaded::content_hash`]): taken as the job was set up, or
/// deferred to the first film ([`JobSettings::defer_scene_hash`]).
#[derive(Debug)]
enum SceneHash {
    Taken(String),
    /// What to hash, and once taken, the hash or why it could not be.
    Deferred(Box<HashInputs>, OnceLock<Result<String, String>>),
}

/// How a deferred scene hash that could not be taken begins (no SHA-256 hash does).
const UNKNOWN: &str = "unknown: ";

impl SceneHash {
    /// The hash, taken now if it was deferred; where it cannot be, a value that names why and
    /// that no other film's hash matches.
    fn get(&self) -> &str {
        match self {
            SceneHash::Taken(hash) => hash,
            SceneHash::Deferred(inputs, hash) => match Self::take(inputs, hash) {
                Ok(hash) | Err(hash) => hash,
            },
        }
    }

    /// Why a deferred hash could not be taken (the hash value without its `unknown: `).
    fn failure(&self) -> Option<&str> {
        match self {
            SceneHash::Taken(_) => None,
            SceneHash::Deferred(inputs, hash) => Self::take(inputs, hash)
                .as_ref()
                .err()
                .map(|why| why.trim_start_matches(UNKNOWN)),
        }
    }

    /// The deferred hash, taken on the first call.
    fn take<'a>(
        inputs: &HashInputs,
        hash: &'a OnceLock<Result<String, String>>,
    ) -> &'a Result<String, String> {
        hash.get_or_init(|| {
            if let Some(changed) = inputs.changed_file() {
                return Err(format!(
                    "{UNKNOWN}{} changed after the scene was loaded",
                    changed.display()
                ));
            }
            inputs
                .content_hash()
                .map_err(|e| format!("{UNKNOWN}the scene's files could not be read again: {e}"))
        })
    }
}

impl RenderJob {
    /// Applies the settings to the scene, builds it and checks the settings against it (and
    /// against the checkpoint to resume from).
    pub fn new(loaded: &Loaded, settings: JobSettings) -> Result<RenderJob, JobError> {
        let s = &settings;
        if (s.samples.is_some() || s.crop.is_some())
            && (s.adaptive || s.target_error.is_some() || s.time_s.is_some())
        {
            return Err(JobError::Invalid(SPLIT_EXCLUDES_BUDGETS.into()));
        }
        if s.spp.is_some() && s.samples.is_some() {
            return Err(JobError::Invalid(
                "a job takes a sample count or a sample range, not both".into(),
            ));
        }
        if s.resume.is_some() && s.samples.is_some() {
            return Err(JobError::Invalid(
                "a resumed render continues its checkpoint's samples; it takes no sample range"
                    .into(),
            ));
        }
        if let Some((a, b)) = s.samples {
            if a >= b {
                return Err(JobError::Invalid(format!(
                    "the sample range {a}..{b} is empty"
                )));
            }
        }
        let resumed = s.resume.as_ref().map(|r| &r.header);
        if let Some(r) = resumed {
            if r.samples.len() != 1 {
                return Err(JobError::Resume(format!(
                    "a checkpoint holds one range of samples, this film holds {}",
                    partial_film::ranges_text(&r.samples)
                )));
            }
        }
        let mut loaded = loaded.clone();
        loaded.edit(|scene| {
            if let Some(v) = s.spp {
                scene.render.spp = v;
            } else if let Some((a, b)) = s.samples {
                scene.render.spp = b - a;
            } else if let Some(t) = resumed.and_then(|r| r.target_spp) {
                scene.render.spp = t;
            }
            if let Some(t) = s.time_s {
                scene.render.time_budget_s = Some(t);
            }
            if (s.time_s.is_some() || s.target_error.is_some()) && s.spp.is_none() {
                // Asked for a time or an error, not a sample count: let the budget decide.
                scene.render.spp = schema::MAX_SPP;
            }
            if let Some(left) = resumed.and_then(|r| r.time_left_s) {
                if s.time_s.is_none() {
                    scene.render.time_budget_s = Some(left as f32);
                }
            }
        })?;
        let defer = s.defer_scene_hash && s.resume.is_none() && s.checkpoint.is_none();
        let (scene_hash, built) = if defer {
            let inputs = Box::new(loaded.hash_inputs());
            (SceneHash::Deferred(inputs, OnceLock::new()), loaded.build())
        } else {
            // The content hash reads and hashes every file again (a 31 MB glTF: ~25 ms): on a
            // thread of its own, while the scene is built (whose start is mostly serial).
            let (hash, built) = std::thread::scope(|s| {
                let hashing = s.spawn(|| loaded.content_hash());
                let built = loaded.build();
                let hash = hashing
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
                (hash, built)
            });
            let hash = hash.map_err(|e| JobError::Io(e.to_string()))?;
            (SceneHash::Taken(hash), built)
        };
        let scene_hash = Arc::new(scene_hash);
        let sampler_kind = loaded.description.scene.render.sampler;
        let (mut scene, notes) = built.map_err(|e| {
            JobError::Invalid(format!("{}: {e}", loaded.description.file.display()))
        })?;
        match s.light_sampler {
            LightChoice::Auto => {}
            LightChoice::Power => {
                scene.light_sampler = LightSampler::new(&scene.lights, LightSamplerKind::Power);
            }
            LightChoice::Tree => {
                scene.light_sampler = LightSampler::new(&scene.lights, LightSamplerKind::Tree);
            }
        }
        // The light choice is part of how samples are drawn: films made with the light tree
        // and by power must not be merged or resumed into each other.
        let sampler = format!(
            "{}{}",
            schema::Keyword::keyword(sampler_kind),
            if matches!(scene.light_sampler, LightSampler::Power(_)) {
                ""
            } else {
                ", light tree"
            }
        );
        let (width, height) = (scene.settings.width, scene.settings.height);
        let window = s.crop.unwrap_or(Window::full(width, height));
        if window.x1 > width || window.y1 > height {
            return Err(JobError::Invalid(format!(
                "--crop {},{},{},{} is not inside the {width}×{height} image",
                window.x0, window.y0, window.x1, window.y1
            )));
        }
        let first_sample = match (resumed, s.samples) {
            (Some(r), _) => r.samples[0][0],
            (None, Some((a, _))) => a,
            (None, None) => 0,
        };
        // Passes the scene asks for, with the job's.
        let mut settings = settings;
        let names: Vec<&str> = loaded
            .description
            .scene
            .render
            .aov
            .iter()
            .map(|p| p.name())
            .collect();
        let scene_aovs: AovSet = names.join(",").parse().map_err(JobError::Invalid)?;
        settings.aovs = settings.aovs.union(scene_aovs);
        let mut job = RenderJob {
            scene,
            settings,
            scene_hash,
            sampler,
            window,
            first_sample,
            notes,
        };
        if let Some(r) = &job.settings.resume {
            let here = job.header(r.header.samples.clone(), None);
            if let Some(m) = here.mismatch(&r.header) {
                return Err(JobError::Resume(format!(
                    "cannot resume this render from it: {m} (\"here\" is this render's scene)"
                )));
            }
            if r.header.crop != here.crop {
                return Err(JobError::Resume(format!(
                    "the checkpoint covers pixels {:?}, this render {:?} (give the same --crop)",
                    r.header.crop, here.crop
                )));
            }
            let target = job.scene.settings.spp;
            if r.header.spp() >= u64::from(target) && job.scene.settings.time_budget_s.is_none() {
                job.notes.push(format!(
                    "the checkpoint already holds {} samples per pixel; nothing left to render \
                     to {target}",
                    r.header.spp()
                ));
            }
        }
        Ok(job)
    }

    /// The scene as the job renders it (settings applied).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// A quick look at the scene, in a few milliseconds: primary rays and direct light
    /// ([`IntegratorKind::Raycast`]), one sample per pixel, at a quarter of the resolution (a
    /// live preview shows it while the path tracer starts). Stops early when `cancel` is set.
    pub fn quick_look(&mut self, cancel: Option<&AtomicBool>) -> Rendered {
        let full = self.scene.settings;
        let s = &mut self.scene.settings;
        s.width = full.width.div_ceil(4);
        s.height = full.height.div_ceil(4);
        s.integrator = IntegratorKind::Raycast;
        s.spp = 1;
        s.time_budget_s = None;
        let quick = render_with_error(
            &self.scene,
            &RenderOptions {
                cancel,
                ..RenderOptions::default()
            },
        );
        self.scene.settings = full;
        quick
    }

    /// The job's settings.
    pub fn settings(&self) -> &JobSettings {
        &self.settings
    }

    /// Warnings about what the scene build dropped or approximated, and notes about the job
    /// (a checkpoint that already holds every sample asked for).
    pub fn warnings(&self) -> &[String] {
        &self.notes
    }

    /// Full image width in pixels.
    pub fn width(&self) -> u32 {
        self.scene.settings.width
    }

    /// Full image height in pixels.
    pub fn height(&self) -> u32 {
        self.scene.settings.height
    }

    /// The window of the image the job renders.
    pub fn window(&self) -> Window {
        self.window
    }

    /// Index of every pixel's first sample.
    pub fn first_sample(&self) -> u32 {
        self.first_sample
    }

    /// Samples the job takes in all (the window's pixels times the samples per pixel, a
    /// resumed checkpoint's included), or `None` when a time budget or an error target
    /// decides.
    pub fn total_samples(&self) -> Option<u64> {
        let open_ended =
            self.scene.settings.time_budget_s.is_some() || self.settings.target_error.is_some();
        (!open_ended).then(|| {
            u64::from(self.window.width())
                * u64::from(self.window.height())
                * u64::from(self.scene.settings.spp)
        })
    }

    /// The header of a film of this job holding `samples`: everything that must agree for two
    /// films to merge (the scene's content hash, build, size, seed, sampler and light choice),
    /// and for checkpoints, the target and the time budget left.
    pub fn header(&self, samples: Vec<[u32; 2]>, time_left_s: Option<f64>) -> FilmHeader {
        FilmHeader {
            build_id: partial_film::build_id(),
            scene_hash: self.scene_hash.get().to_string(),
            ..self.header_without_ids(samples, time_left_s)
        }
    }

    /// [`RenderJob::header`] with an empty build id and scene hash (both taken when a film
    /// is made).
    fn header_without_ids(&self, samples: Vec<[u32; 2]>, time_left_s: Option<f64>) -> FilmHeader {
        let w = self.window;
        FilmHeader {
            format: partial_film::FORMAT.to_string(),
            format_version: partial_film::FORMAT_VERSION,
            lumo_version: env!("CARGO_PKG_VERSION").to_string(),
            build_id: String::new(),
            scene_hash: String::new(),
            width: self.width(),
            height: self.height(),
            crop: [w.x0, w.y0, w.x1, w.y1],
            seed: self.scene.settings.seed,
            sampler: self.sampler.clone(),
            samples,
            target_spp: Some(self.scene.settings.spp),
            time_left_s,
            command: None,
            // Every pass asked for, `std_error` too (derived from the beauty's sums, it is not
            // recorded per sample, but a merge of the films writes what the header lists).
            aovs: self
                .settings
                .aovs
                .names()
                .into_iter()
                .map(String::from)
                .collect(),
        }
    }

    /// Renders on the calling thread with its rayon pool (or one of [`JobSettings::threads`]
    /// workers): calls the hooks, writes
    /// the checkpoint every [`Checkpointing::every`] (uniform renders; a failure is a warning),
    /// stops early when `hooks.cancel` is set.
    pub fn run(&self, hooks: &Hooks) -> Result<Finished, JobError> {
        let start = Instant::now();
        let budget = self.scene.settings.time_budget_s.map(f64::from);
        let time_left = || budget.map(|b| (b - start.elapsed().as_secs_f64()).max(0.0));
        let first = self.first_sample;
        let uniform_film = !self.settings.adaptive;
        let last_checkpoint = Mutex::new(Instant::now());
        let periodic = |film: &Film| {
            if let Some(on_pass) = hooks.on_pass {
                on_pass(film);
            }
            let Some(ck) = &self.settings.checkpoint else {
                return;
            };
            if !uniform_film {
                return;
            }
            let Ok(mut last) = last_checkpoint.lock() else {
                return;
            };
            let taken = film.pixel(0, 0).taken();
            if last.elapsed() < ck.every || taken == 0 {
                return;
            }
            let mut header = self.header(vec![[first, first + taken]], time_left());
            header.command.clone_from(&self.settings.command);
            let part = PartialFilm {
                header,
                film: film.clone(),
            };
            match part.write(&ck.path) {
                Ok(()) => *last = Instant::now(),
                Err(e) => {
                    if let Some(warn) = hooks.warn {
                        warn(&format!("checkpoint not written: {e}"));
                    }
                }
            }
        };
        let options = RenderOptions {
            progress: hooks.progress,
            target_rel_error: self.settings.target_error,
            adaptive: self.settings.adaptive,
            crop: self.settings.crop,
            first_sample: first,
            resume: self.settings.resume.as_ref().map(|r| &r.film),
            cancel: hooks.cancel,
            on_pass: ((self.settings.checkpoint.is_some() && uniform_film)
                || hooks.on_pass.is_some())
            .then_some(&periodic as &(dyn Fn(&Film) + Sync)),
            lane_width: self.settings.lane_width,
            aovs: self.settings.aovs,
        };
        let rendered = match self.settings.threads {
            None => render_with_error(&self.scene, &options),
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| JobError::Io(format!("cannot start worker threads: {e}")))?
                .install(|| render_with_error(&self.scene, &options)),
        };
        let taken = rendered.film.pixel(0, 0).taken();
        let uniform = uniform_film && rendered.film.counts().iter().all(|&c| c == taken);
        let resumed_samples = self
            .settings
            .resume
            .as_ref()
            .map_or(0, |r| r.film.samples_taken());
        Ok(Finished {
            image: rendered.image,
            std_error: rendered.std_error,
            stats: rendered.stats,
            sums: rendered.film,
            interrupted: rendered.interrupted,
            uniform,
            new_samples: rendered.stats.samples - resumed_samples,
            time_left_s: time_left(),
            command: self.settings.command.clone(),
            resumed_spp: self.settings.resume.as_ref().map(|r| r.header.spp()),
            header: self.header_without_ids(vec![[first, first + taken]], None),
            scene_hash: Arc::clone(&self.scene_hash),
            film: std::sync::OnceLock::new(),
            aovs: self.settings.aovs,
        })
    }
}

impl Finished {
    /// Samples per pixel the film holds (the same in every pixel of uniform renders).
    pub fn samples_per_pixel(&self) -> u32 {
        self.sums.pixel(0, 0).taken()
    }

    /// The job's samples as a partial film, whose header says what render they belong to (for
    /// `lumo merge`; made, and the program hashed for its build id, on first use, and the
    /// scene's files then too when [`JobSettings::defer_scene_hash`] deferred their hash).
    pub fn film(&self) -> &PartialFilm {
        self.film.get_or_init(|| PartialFilm {
            header: FilmHeader {
                build_id: partial_film::build_id(),
                scene_hash: self.scene_hash.get().to_string(),
                ..self.header.clone()
            },
            film: self.sums.clone(),
        })
    }

    /// Why the job's films carry no usable scene hash, when it was deferred
    /// ([`JobSettings::defer_scene_hash`]) and could not be taken: a file of the scene changed
    /// or could not be read since the scene was loaded. Such a job makes no
    /// [`checkpoint`](Self::checkpoint).
    pub fn scene_hash_failure(&self) -> Option<&str> {
        self.scene_hash.failure()
    }

    /// The window of the image the job rendered.
    pub fn window(&self) -> Window {
        self.header.window()
    }

    /// Full image width in pixels.
    pub fn width(&self) -> u32 {
        self.header.width
    }

    /// Full image height in pixels.
    pub fn height(&self) -> u32 {
        self.header.height
    }

    /// One line on what the job did: size, samples, time, throughput (of this run's samples),
    /// the estimated error and, given a reference image, the measured one.
    pub fn summary(&self, reference: Option<&Image>) -> String {
        let stats = &self.stats;
        let secs = stats.elapsed.as_secs_f64();
        let resumed = match self.resumed_spp {
            Some(spp) => format!(" (resumed from {spp} spp)"),
            None => String::new(),
        };
        let vs_reference = match reference {
            Some(r) => format!(
                ", RMSE {:.5}, relMSE {:.6} vs reference",
                self.image.rmse(r),
                self.image.rel_mse(r)
            ),
            None => String::new(),
        };
        let dropped = match stats.nan_samples {
            0 => String::new(),
            n => format!(", {n} NaN/Inf samples dropped"),
        };
        format!(
            "rendered {}×{} at {} spp{resumed} in {secs:.3} s: {:.2} M rays/s, {:.2} M samples/s, \
             estimated relative error {:.4}{vs_reference}{dropped}",
            self.image.width,
            self.image.height,
            stats.spp,
            stats.rays as f64 / secs / 1e6,
            self.new_samples as f64 / secs / 1e6,
            stats.estimated_rel_error,
        )
    }

    /// The image at the full size of the render, black outside the job's window.
    pub fn full_image(&self) -> Image {
        embed(&self.image, &self.window(), self.width(), self.height())
    }

    /// The checkpoint of this job, to resume it later: the film with the time budget left, or
    /// `None` when there is nothing to resume (no sample taken, or an adaptive render, whose
    /// pixels hold different samples).
    pub fn checkpoint(&self) -> Option<PartialFilm> {
        let resumable = self.uniform && self.samples_per_pixel() > 0;
        (resumable && self.scene_hash_failure().is_none()).then(|| {
            let mut ck = self.film().clone();
            ck.header.time_left_s = self.time_left_s;
            ck.header.command.clone_from(&self.command);
            ck
        })
    }

    /// Which render passes the job kept ([`JobSettings::aovs`] and the scene's).
    pub fn aovs(&self) -> AovSet {
        self.aovs
    }

    /// The render passes asked for ([`JobSettings::aovs`]), of the job's window.
    pub fn passes(&self) -> Vec<PassImage> {
        self.sums.passes(self.aovs)
    }

    /// The beauty denoised with Open Image Denoise, guided by the albedo and normal passes
    /// when the job rendered them ([`Prefilter::Clean`]: final-frame quality), of the job's
    /// window.
    pub fn denoised(&self, oidn: &mut Oidn) -> Result<Image, DenoiseError> {
        let guides = self
            .sums
            .passes(AovSet::NONE.with(Aov::Albedo).with(Aov::Normal));
        let group = |aov: Aov| {
            guides.iter().find(|p| p.aov == aov).and_then(|p| {
                ChannelGroup::from_pass(p).to_rgb(self.image.width, self.image.height)
            })
        };
        let (albedo, normal) = (group(Aov::Albedo), group(Aov::Normal));
        oidn.denoise(
            &self.image,
            albedo.as_ref(),
            normal.as_ref(),
            Prefilter::Clean,
        )
    }

    /// Writes the image (at full size) atomically. When it cannot be written, the samples are
    /// kept: as a checkpoint at `keep_at` (default: `OUT.checkpoint.npz` beside the output),
    /// else in the temporary folder, and the error says where.
    pub fn write_image(
        &self,
        path: &Path,
        tonemap: ToneMap,
        keep_at: Option<&Path>,
    ) -> Result<(), JobError> {
        self.write_output(path, tonemap, keep_at, None)
    }

    /// [`write_image`](Self::write_image) with the render passes, and with `denoised` (of the
    /// job's window) as the beauty when given, the noisy one kept as the pass `noisy`. EXR gets
    /// one multi-channel part ([`crate::multilayer`]); PNG and BMP get each pass as a file
    /// beside the image (`OUT.albedo.png`, …; PNG quick looks beside HDR images).
    pub fn write_output(
        &self,
        path: &Path,
        tonemap: ToneMap,
        keep_at: Option<&Path>,
        denoised: Option<&Image>,
    ) -> Result<(), JobError> {
        let Err(e) = self.write_all(path, tonemap, denoised) else {
            return Ok(());
        };
        let mut kept = String::new();
        if let Some(ck) = self.checkpoint() {
            let places = [
                keep_at.map_or_else(|| default_checkpoint(path), Path::to_path_buf),
                std::env::temp_dir().join(format!("lumo-{}.checkpoint.npz", std::process::id())),
            ];
            for place in places {
                if ck.write(&place).is_ok() {
                    kept = format!(
                        " (the samples are kept in {}: lumo merge it, or --resume from it)",
                        place.display()
                    );
                    break;
                }
            }
        }
        Err(JobError::Io(format!("{e}{kept}")))
    }
}

impl Finished {
    /// Writes the beauty and the passes (see [`Finished::write_output`]).
    fn write_all(
        &self,
        path: &Path,
        tonemap: ToneMap,
        denoised: Option<&Image>,
    ) -> Result<(), crate::output::ImageIoError> {
        let (w, h, window) = (self.width(), self.height(), self.window());
        write_with_passes(
            path,
            tonemap,
            &self.sums,
            self.aovs,
            (&window, w, h),
            denoised,
        )
    }
}

/// Writes the image of `film` (a `window` of a `width` × `height` render, placed in it) with
/// its render passes `aovs` to `path`, atomically; with `denoised` (of the window) as the
/// beauty, the film's own image then kept as the pass `noisy`. See [`write_image_with_passes`].
pub fn write_with_passes(
    path: &Path,
    tonemap: ToneMap,
    film: &Film,
    aovs: AovSet,
    (window, width, height): (&Window, u32, u32),
    denoised: Option<&Image>,
) -> Result<(), crate::output::ImageIoError> {
    let noisy = embed(&film.image(), window, width, height);
    let passes: Vec<PassImage> = film
        .passes(aovs)
        .into_iter()
        .map(|p| embed_pass(&p, window, width, height))
        .collect();
    match denoised {
        Some(d) => write_image_with_passes(
            path,
            tonemap,
            &embed(d, window, width, height),
            &passes,
            Some(&noisy),
        ),
        None => write_image_with_passes(path, tonemap, &noisy, &passes, None),
    }
}

/// Writes `beauty` with its render passes `passes` (of its size, in [`Aov::ALL`]'s order) to
/// `path`, atomically, and `noisy`, when the beauty was denoised, as the pass `noisy`. EXR gets
/// one multi-channel part ([`crate::multilayer`]); PNG and BMP get each pass as a file beside
/// the image (`OUT.albedo.png`, …), and HDR gets PNG quick looks beside it.
pub fn write_image_with_passes(
    path: &Path,
    tonemap: ToneMap,
    beauty: &Image,
    passes: &[PassImage],
    noisy: Option<&Image>,
) -> Result<(), crate::output::ImageIoError> {
    let exr = crate::output::format_of(path)? == image::ImageFormat::OpenExr;
    if exr && (!passes.is_empty() || noisy.is_some()) {
        let mut groups: Vec<ChannelGroup> = Vec::new();
        if let Some(noisy) = noisy {
            groups.push(ChannelGroup::from_rgb("noisy", noisy));
        }
        groups.extend(passes.iter().map(ChannelGroup::from_pass));
        return crate::multilayer::write_exr(path, beauty, &groups);
    }
    write_image(beauty, path, tonemap)?;
    let ext = lumo_schema::geometry::paths::lowercase_extension(path);
    let side_ext = if ext == "bmp" { "bmp" } else { "png" };
    let side = |name: &str| crate::multilayer::sidecar_path(&path.with_extension(side_ext), name);
    if let Some(noisy) = noisy {
        write_image(noisy, &side("noisy"), tonemap)?;
    }
    for pass in passes {
        crate::multilayer::write_pass_rgb8(
            &side(pass.aov.name()),
            beauty.width,
            beauty.height,
            pass,
        )?;
    }
    Ok(())
}

/// A pass of a window placed in a `width` × `height` image (zero outside the window).
fn embed_pass(pass: &PassImage, window: &Window, width: u32, height: u32) -> PassImage {
    if (window.width(), window.height()) == (width, height) {
        return pass.clone();
    }
    let c = pass.aov.channels().len();
    fn place<T: Copy + Default>(
        v: &[T],
        c: usize,
        window: &Window,
        width: u32,
        height: u32,
    ) -> Vec<T> {
        let mut out = vec![T::default(); (width * height) as usize * c];
        for y in 0..window.height() {
            for x in 0..window.width() {
                let from = (y * window.width() + x) as usize * c;
                let to = ((window.y0 + y) * width + window.x0 + x) as usize * c;
                out[to..to + c].copy_from_slice(&v[from..from + c]);
            }
        }
        out
    }
    PassImage {
        aov: pass.aov,
        pixels: match &pass.pixels {
            PassPixels::Float(v) => PassPixels::Float(place(v, c, window, width, height)),
            PassPixels::Id(v) => PassPixels::Id(place(v, c, window, width, height)),
        },
    }
}

/// The default checkpoint path of an output: `OUT.checkpoint.npz` beside it.
pub fn default_checkpoint(output: &Path) -> PathBuf {
    let mut name = output.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".checkpoint.{}", partial_film::EXTENSION));
    output.with_file_name(name)
}

/// Checks before rendering that a file can be written at `path`: its folder exists and a
/// temporary file can be created in it (the way every output is written). `what` names the
/// file in the message ("output", "error image").
pub fn check_writable(path: &Path, what: &str) -> Result<(), JobError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(JobError::Invalid(format!(
            "{}: the {what}'s folder {} does not exist (create it, or write elsewhere)",
            path.display(),
            dir.display()
        )));
    }
    crate::output::temp_file_in(dir).map_err(|e| {
        JobError::Invalid(format!(
            "{}: cannot write the {what} in {}: {e}",
            path.display(),
            dir.display()
        ))
    })?;
    Ok(())
}

/// Checks before rendering that an image can be written at `path`: a known format, and
/// [`check_writable`].
pub fn check_image_path(path: &Path, what: &str) -> Result<(), JobError> {
    crate::output::format_of(path).map_err(|e| JobError::Invalid(e.to_string()))?;
    check_writable(path, what)
}

/// Checks before rendering that a partial film can be written at `path`: the format's
/// extension, and [`check_writable`].
pub fn check_film_path(path: &Path, what: &str) -> Result<(), JobError> {
    let ext = schema::geometry::paths::lowercase_extension(path);
    if ext != partial_film::EXTENSION {
        return Err(JobError::Invalid(format!(
            "{}: a {what} is a partial film, written as .{} (NumPy archive); rename it to end in .{}",
            path.display(),
            partial_film::EXTENSION,
            partial_film::EXTENSION
        )));
    }
    check_writable(path, what)
}

/// The image of a window placed in a black `width` × `height` image (the image itself when the
/// window is all of it).
pub fn embed(image: &Image, window: &Window, width: u32, height: u32) -> Image {
    if (window.width(), window.height()) == (width, height) {
        return image.clone();
    }
    let mut pixels = vec![glam::Vec3::ZERO; (width * height) as usize];
    for y in 0..window.height() {
        for x in 0..window.width() {
            pixels[((window.y0 + y) * width + window.x0 + x) as usize] =
                image.pixels[(y * window.width() + x) as usize];
        }
    }
    Image {
        width,
        height,
        pixels,
    }
}
