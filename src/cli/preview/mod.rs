//! `lumo preview`: a live, progressive render in the browser that follows the scene file.
//!
//! Three parts, one thread each (plus the render's worker pool):
//! - the **reload loop** (this file) loads the scene with the render command's overrides, renders a
//!   quick ray-cast pass at a quarter of the resolution, then path traces pass by pass, publishing
//!   every pass into [`Shared`]; it waits for the watcher's next trigger when done, and shows a
//!   load error (or a caught panic) instead of an image when the scene does not load;
//! - the **watcher** (`watch.rs`) watches the folders of every file the scene read and, on a
//!   change, cancels the render at once and triggers a reload once the files are quiet;
//! - the **server** (`server.rs`) serves the embedded page, a server-sent event stream of the
//!   status, the latest frame as linear floats (the beauty, its standard error, the render
//!   passes asked for with `--aov`, and the beauty denoised on demand), and the save button's
//!   POST;
//! - a short-lived **denoiser loader** finds Open Image Denoise at start (as `lumo render
//!   --denoise` does) without delaying the first frame; the page's denoised view is enabled
//!   once it is found, and says how to install it when it is not.
//!
//! # Denoising
//!
//! The denoised view is computed lazily, when the page asks for it, on a blocking thread of the
//! server, and cached per frame number: the render threads never wait for it, no work is done
//! while nobody looks at it, and when passes arrive faster than OIDN filters, the page's fetch
//! loop asks only for the latest one (the frames in between are never denoised). It uses the
//! albedo and normal passes as guides when they are rendered (`--aov albedo,normal`), without
//! prefiltering them ([`Prefilter::None`], OIDN's fast path for previews).
//!
//! # The quick pass has no render passes
//!
//! The quick ray-cast frame (a quarter of the resolution, one sample, shown until the path
//! tracer's first pass: tens of milliseconds for the Cornell box) carries the beauty only: the
//! page says that the passes come with the first path-traced pass. Filling the cheap ones there
//! would mean a second, ray-cast definition of albedo and normal (the path tracer takes them at
//! the first non-delta vertex, from the BSDF sample the path continues with, which the ray-cast
//! integrator does not draw), and changes to the render loop, for a frame at a quarter of the
//! resolution that the first pass replaces.

mod server;
mod watch;

use std::net::SocketAddr;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use lumo::aov::{Aov, AovSet, PassImage};
use lumo::denoise::{Oidn, Prefilter};
use lumo::job::{Hooks, JobSettings, RenderJob};
use lumo::multilayer::ChannelGroup;
use lumo::output::ToneMap;
use lumo::render::{Film, Image};
use serde::Serialize;

use super::{keyword, load_overridden, load_warnings, CliError, SceneOverrides};

/// Arguments of `lumo preview`.
#[derive(Debug, clap::Args)]
pub struct PreviewArgs {
    /// The scene to preview (.json, legacy .txt, .gltf, .glb).
    pub scene: PathBuf,
    /// Port to serve the page on (0: any free port; the address is printed).
    #[arg(long, default_value_t = 8000)]
    pub port: u16,
    /// Address to listen on. The default serves this machine only; another address exposes the
    /// preview (and the save button) to the network.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: std::net::IpAddr,
    /// Where the page's save button writes the image (default: the scene's path with `.png`).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Samples per pixel to refine to (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(lumo_schema::MAX_SPP)))]
    pub spp: Option<u32>,
    /// Changes to the scene, as for `lumo render`.
    #[command(flatten)]
    pub overrides: SceneOverrides,
    /// Worker threads for rendering (default: all cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub threads: Option<u32>,
    /// The page's initial tone mapping (the save button writes what the page shows).
    #[arg(long, value_parser = keyword::<ToneMap>(), default_value = "clamp")]
    pub tonemap: ToneMap,
    /// Render passes to show besides the beauty, comma-separated, as for `lumo render --aov`
    /// (albedo, normal, depth, position, uv, object_id, material_id, std_error), with those of
    /// the scene's `render.aov`. The page's selector switches between them and its readout
    /// shows each under the cursor; albedo and normal also guide the denoised view.
    #[arg(long, value_name = "PASSES", value_parser = super::parse_aovs)]
    pub aov: Option<AovSet>,
}

/// What the page shows besides the image, pushed to it on every change.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Status {
    /// The scene file, as given on the command line.
    scene: String,
    /// `loading`, `rendering`, `done`, `invalid` (the scene does not load: see `error`) or
    /// `failed` (an I/O error or a bug).
    state: &'static str,
    /// Loads started so far (1 for the first).
    renders: u64,
    /// Number of the latest frame (0: none yet); the page fetches `/frame` when it changes.
    frame: u64,
    /// Whether the latest frame is the quick ray-cast pass.
    quick: bool,
    /// Size of the latest frame.
    width: u32,
    /// Size of the latest frame.
    height: u32,
    /// Full image size of the scene being rendered.
    image_width: u32,
    /// Full image size of the scene being rendered.
    image_height: u32,
    /// Samples per pixel in the latest frame.
    spp: u32,
    /// Samples per pixel the render refines to.
    target_spp: u32,
    /// Seconds since the render (after loading) started.
    elapsed_s: f64,
    /// Samples per second of the path tracer so far.
    samples_per_s: f64,
    /// Estimated relative error of the latest frame (from the samples' variance).
    rel_error: f64,
    /// The located report when the scene does not load (as `lumo validate` prints it).
    error: Option<String>,
    /// Warnings of the last load.
    warnings: Vec<String>,
    /// Where the save button writes.
    output: String,
    /// The page's initial tone mapping.
    tonemap: &'static str,
    /// Render passes the path-traced frames carry (`/frame?kind=pass&name=…`), by their
    /// `--aov` names in [`Aov::ALL`]'s order; the standard error, which every frame has
    /// (`kind=error`), is not listed.
    passes: Vec<&'static str>,
    /// The denoised view: `loading` (Open Image Denoise is being looked for), `ready` or
    /// `missing`.
    denoiser: &'static str,
    /// With `ready`, the library's path; with `missing`, why and how to install it.
    denoiser_note: Option<String>,
}

/// The latest frame: linear radiance, its per-pixel standard error and the render passes,
/// row-major.
pub(crate) struct Frame {
    /// The frame's number ([`Status::frame`] when it was published).
    pub number: u64,
    /// Mean radiance per pixel (its size is the frame's).
    pub image: Image,
    /// Standard error of each pixel's mean.
    pub std_error: Image,
    /// The render passes (none for the quick pass), in [`Aov::ALL`]'s order, without the
    /// standard error.
    pub passes: Vec<PassImage>,
    /// Whether this is the quick ray-cast pass (not saved by the save button).
    pub quick: bool,
    /// Every pass asked for, the standard error included: what the save button writes beside
    /// the image, as `lumo render` would.
    pub asked: AovSet,
}

impl Frame {
    /// The pass `aov`, when the frame carries it.
    pub fn pass(&self, aov: Aov) -> Option<&PassImage> {
        self.passes.iter().find(|p| p.aov == aov)
    }

    /// The pass `aov` as an RGB image, when the frame carries it with three float channels
    /// (albedo, normal).
    fn pass_rgb(&self, aov: Aov) -> Option<Image> {
        self.pass(aov)
            .and_then(|p| ChannelGroup::from_pass(p).to_rgb(self.image.width, self.image.height))
    }
}

/// Open Image Denoise as the preview finds it at start.
pub(crate) enum DenoiserState {
    /// Still being looked for.
    Loading,
    /// Found and loaded.
    Ready(Box<Oidn>),
    /// Not found: why, and how to install it.
    Missing(String),
}

/// The denoiser and the denoised beauty of the last frame asked for.
pub(crate) struct Denoiser {
    state: DenoiserState,
    /// The number of the frame denoised last, and its denoised beauty.
    cached: Option<(u64, Arc<Image>)>,
}

/// Why the denoised view of a frame is not available.
pub(crate) enum NotDenoised {
    /// OIDN is still being looked for.
    Loading,
    /// OIDN was not found (the message says how to install it).
    Missing(String),
    /// The frame is the quick ray-cast pass.
    Quick,
    /// OIDN failed.
    Failed(String),
}

/// State shared by the reload loop, the watcher and the server.
pub(crate) struct Shared {
    status: Mutex<Status>,
    frame: Mutex<Option<Arc<Frame>>>,
    /// Locked for the whole of a denoise: one filter at a time, and a second request for the
    /// same frame finds the first's result.
    denoiser: Mutex<Denoiser>,
    /// Bumped on every status change; the event streams follow it.
    changed: tokio::sync::watch::Sender<u64>,
    /// Set when a watched file changes: the render stops taking tiles.
    cancel: AtomicBool,
    /// Changes seen so far (the reload loop compares it before and after resetting `cancel`).
    changes: AtomicU64,
    /// Where the save button writes.
    output: PathBuf,
}

/// Locks a mutex, recovering the data if a thread panicked while holding it (the status is
/// plain data, always consistent between statements).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Shared {
    /// Changes the status and tells the event streams.
    fn update(&self, change: impl FnOnce(&mut Status)) {
        change(&mut lock(&self.status));
        self.changed.send_modify(|n| *n += 1);
    }

    /// The status as JSON.
    pub(crate) fn status_json(&self) -> String {
        serde_json::to_string(&*lock(&self.status)).unwrap_or_else(|_| "{}".to_string())
    }

    /// The latest frame.
    pub(crate) fn frame(&self) -> Option<Arc<Frame>> {
        lock(&self.frame).clone()
    }

    /// A file changed: stop the render now (the reload waits until the files are quiet).
    pub(crate) fn note_change(&self) {
        self.changes.fetch_add(1, Ordering::SeqCst);
        self.cancel.store(true, Ordering::SeqCst);
    }

    /// Publishes a frame (its number is set here).
    fn publish(&self, mut frame: Frame, stats: impl FnOnce(&mut Status)) {
        {
            // The status is locked while the frame is stored, so that a frame's number and the
            // status that announces it agree.
            let mut s = lock(&self.status);
            s.frame += 1;
            frame.number = s.frame;
            s.width = frame.image.width;
            s.height = frame.image.height;
            s.quick = frame.quick;
            stats(&mut s);
            *lock(&self.frame) = Some(Arc::new(frame));
        }
        self.changed.send_modify(|n| *n += 1);
    }

    /// Loads Open Image Denoise (as `lumo render --denoise` finds it) and tells the page.
    fn load_denoiser(&self) {
        let (state, name, note) = match Oidn::load() {
            Ok(oidn) => {
                let path = oidn.path.display().to_string();
                (DenoiserState::Ready(Box::new(oidn)), "ready", path)
            }
            Err(e) => {
                let why = e.to_string();
                (DenoiserState::Missing(why.clone()), "missing", why)
            }
        };
        lock(&self.denoiser).state = state;
        self.update(|s| {
            s.denoiser = name;
            s.denoiser_note = Some(note);
        });
    }

    /// The beauty of `frame` denoised (guided by its albedo and normal passes when it has
    /// them), from the cache when it is of this frame; blocks while OIDN filters.
    pub(crate) fn denoised(&self, frame: &Frame) -> Result<Arc<Image>, NotDenoised> {
        if frame.quick {
            return Err(NotDenoised::Quick);
        }
        let mut d = lock(&self.denoiser);
        if let Some((n, image)) = &d.cached {
            if *n == frame.number {
                return Ok(Arc::clone(image));
            }
        }
        let oidn = match &mut d.state {
            DenoiserState::Ready(oidn) => oidn,
            DenoiserState::Loading => return Err(NotDenoised::Loading),
            DenoiserState::Missing(why) => return Err(NotDenoised::Missing(why.clone())),
        };
        let albedo = frame.pass_rgb(Aov::Albedo);
        let normal = frame.pass_rgb(Aov::Normal);
        let image = oidn
            .denoise(
                &frame.image,
                albedo.as_ref(),
                normal.as_ref(),
                Prefilter::None,
            )
            .map_err(|e| NotDenoised::Failed(e.to_string()))?;
        let image = Arc::new(image);
        d.cached = Some((frame.number, Arc::clone(&image)));
        Ok(image)
    }

    /// Where the save button writes.
    pub(crate) fn output(&self) -> &Path {
        &self.output
    }
}

/// Runs `lumo preview` until the process is stopped.
pub fn preview_cmd(args: &PreviewArgs) -> Result<(), CliError> {
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| args.scene.with_extension("png"));
    lumo::output::format_of(&output).map_err(|e| CliError::invalid(e.to_string()))?;
    super::split::check_writable(&output, "output")?;
    let (changed, _) = tokio::sync::watch::channel(0u64);
    let shared = Arc::new(Shared {
        status: Mutex::new(Status {
            scene: args.scene.display().to_string(),
            state: "loading",
            renders: 0,
            frame: 0,
            quick: false,
            width: 0,
            height: 0,
            image_width: 0,
            image_height: 0,
            spp: 0,
            target_spp: 0,
            elapsed_s: 0.0,
            samples_per_s: 0.0,
            rel_error: 0.0,
            error: None,
            warnings: Vec::new(),
            output: output.display().to_string(),
            tonemap: lumo_schema::Keyword::keyword(args.tonemap),
            passes: args.aov.unwrap_or(AovSet::NONE).recorded().names(),
            denoiser: "loading",
            denoiser_note: None,
        }),
        frame: Mutex::new(None),
        denoiser: Mutex::new(Denoiser {
            state: DenoiserState::Loading,
            cached: None,
        }),
        changed,
        cancel: AtomicBool::new(false),
        changes: AtomicU64::new(0),
        output,
    });
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0) as usize)
        .build()
        .map_err(|e| CliError::failure(format!("cannot start worker threads: {e}")))?;
    let own_files: Vec<PathBuf> = std::iter::once(args.scene.clone())
        .chain(args.overrides.compose.patch.clone())
        .collect();
    let watcher = watch::Watcher::start(Arc::clone(&shared), &own_files)
        .map_err(|e| CliError::failure(format!("cannot watch files: {e}")))?;
    let address = SocketAddr::new(args.bind, args.port);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("cannot start the server: {e}")))?;
    let listener = runtime
        .block_on(tokio::net::TcpListener::bind(address))
        .map_err(|e| CliError::failure(format!("cannot listen on {address}: {e}")))?;
    let bound = listener
        .local_addr()
        .map_err(|e| CliError::failure(e.to_string()))?;
    eprintln!(
        "lumo preview: serving {} on http://{bound}/ (Ctrl-C to stop)",
        args.scene.display()
    );
    // Loading OIDN (tens to hundreds of milliseconds) does not delay the first frame.
    let denoiser_shared = Arc::clone(&shared);
    std::thread::Builder::new()
        .name("lumo-preview-denoiser".into())
        .spawn(move || denoiser_shared.load_denoiser())
        .map_err(|e| CliError::failure(format!("cannot start a thread: {e}")))?;
    let loop_shared = Arc::clone(&shared);
    let triggers = watcher.triggers;
    let files = watcher.files;
    let loop_args = ReloadArgs {
        scene: args.scene.clone(),
        spp: args.spp,
        overrides: args.overrides.clone(),
        aovs: args.aov.unwrap_or(AovSet::NONE),
    };
    std::thread::Builder::new()
        .name("lumo-preview-reload".into())
        .spawn(move || reload_loop(loop_args, &pool, &loop_shared, &triggers, &files))
        .map_err(|e| CliError::failure(format!("cannot start the render thread: {e}")))?;
    runtime
        .block_on(server::serve(listener, shared))
        .map_err(|e| CliError::failure(format!("the server stopped: {e}")))
}

/// What the reload thread needs of the arguments (the thread outlives the borrow).
struct ReloadArgs {
    scene: PathBuf,
    spp: Option<u32>,
    overrides: SceneOverrides,
    /// `--aov`'s passes (the scene's own are added per load).
    aovs: AovSet,
}

/// How one load and render ended.
enum Outcome {
    /// All samples taken.
    Done,
    /// A file changed during the render.
    Interrupted,
    /// A file changed during the load, unseen by the watcher: load again now.
    Stale,
}

/// Loads and renders, then waits for the watcher's trigger, forever.
fn reload_loop(
    args: ReloadArgs,
    pool: &rayon::ThreadPool,
    shared: &Shared,
    triggers: &Receiver<()>,
    files: &Mutex<watch::Files>,
) {
    loop {
        let seen = shared.changes.load(Ordering::SeqCst);
        shared.cancel.store(false, Ordering::SeqCst);
        // A change between reading `seen` and the reset must still stop this render.
        if shared.changes.load(Ordering::SeqCst) != seen {
            shared.cancel.store(true, Ordering::SeqCst);
        }
        shared.update(|s| {
            s.renders += 1;
            s.state = "loading";
        });
        let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| {
            pool.install(|| load_and_render(&args, shared, files))
        }));
        match outcome {
            Ok(Ok(Outcome::Done)) => shared.update(|s| s.state = "done"),
            Ok(Ok(Outcome::Interrupted)) => {}
            Ok(Ok(Outcome::Stale)) => continue,
            Ok(Err(e)) => shared.update(|s| {
                s.state = if e.code == super::EXIT_INVALID {
                    "invalid"
                } else {
                    "failed"
                };
                s.error = Some(e.message);
            }),
            Err(panic) => {
                let what = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_string()))
                    .unwrap_or_else(|| "unknown panic".to_string());
                shared.update(|s| {
                    s.state = "failed";
                    s.error = Some(format!(
                        "internal error (a bug in lumo, please report it): {what}"
                    ));
                });
            }
        }
        // Wait for the next change; a burst of triggers is one reload.
        if triggers.recv().is_err() {
            return;
        }
        while triggers.try_recv().is_ok() {}
    }
}

/// Loads the scene, renders the quick pass, then path traces pass by pass.
fn load_and_render(
    args: &ReloadArgs,
    shared: &Shared,
    files: &Mutex<watch::Files>,
) -> Result<Outcome, CliError> {
    let loaded_at = std::time::SystemTime::now();
    let loaded = match load_overridden(&args.scene, &args.overrides) {
        Ok(l) => l,
        Err(e) => {
            lock(files).load_failed();
            return Err(e);
        }
    };
    // The scene, its fragments and assets, and the `--patch` file: a change to any of them
    // renders again.
    let mut read = loaded.files();
    read.extend(args.overrides.compose.patch.clone());
    if lock(files).set(read, loaded_at) {
        // A file changed while it was being read, before its folder was watched.
        return Ok(Outcome::Stale);
    }
    let mut loaded = loaded;
    loaded.edit(|s| {
        if let Some(spp) = args.spp {
            s.render.spp = spp;
        }
        // A preview refines to a sample count: a time budget would stop it early for no one.
        s.render.time_budget_s = None;
    })?;
    let mut render_job = RenderJob::new(
        &loaded,
        JobSettings {
            aovs: args.aovs,
            ..JobSettings::default()
        },
    )?;
    // `--aov`'s passes and the scene's; the standard error is in every frame anyway.
    let asked = render_job.settings().aovs;
    let passes = asked.recorded();
    let all_warnings: Vec<String> = load_warnings(&loaded, &args.overrides)
        .chain(render_job.warnings())
        .cloned()
        .collect();
    let full = render_job.scene().settings;
    shared.update(|s| {
        s.state = "rendering";
        s.error = None;
        s.warnings = all_warnings;
        s.image_width = full.width;
        s.image_height = full.height;
        s.target_spp = full.spp;
        s.spp = 0;
        s.elapsed_s = 0.0;
        s.samples_per_s = 0.0;
        s.passes = passes.names();
    });
    let cancelled = || shared.cancel.load(Ordering::SeqCst);
    let quick = render_job.quick_look(Some(&shared.cancel));
    if quick.interrupted || cancelled() {
        return Ok(Outcome::Interrupted);
    }
    shared.publish(
        Frame {
            number: 0,
            image: quick.image,
            std_error: quick.std_error,
            passes: Vec::new(),
            quick: true,
            asked: AovSet::NONE,
        },
        |_| {},
    );
    // The path tracer at full resolution, pass by pass.
    let start = Instant::now();
    let on_pass = |film: &Film| {
        let estimate = film.estimate();
        let samples = film.samples_taken();
        let pixels = film.pixels().len().max(1) as u64;
        let elapsed = start.elapsed().as_secs_f64();
        shared.publish(
            Frame {
                number: 0,
                image: film.image(),
                std_error: film.std_error(),
                passes: film.passes(passes),
                quick: false,
                asked,
            },
            |s| {
                s.spp = (samples / pixels) as u32;
                s.elapsed_s = elapsed;
                s.samples_per_s = samples as f64 / elapsed.max(1e-9);
                s.rel_error = estimate.rel_error;
            },
        );
    };
    let finished = render_job.run(&Hooks {
        cancel: Some(&shared.cancel),
        on_pass: Some(&on_pass),
        ..Hooks::default()
    })?;
    if finished.interrupted {
        return Ok(Outcome::Interrupted);
    }
    Ok(Outcome::Done)
}
