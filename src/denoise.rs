//! Denoising with Intel Open Image Denoise (OIDN 2.x), loaded at run time.
//!
//! lumo does not link OIDN: the library is opened when a denoise is asked for, so one binary
//! builds and runs everywhere (and `cargo test` needs no OIDN), and `--denoise` works wherever
//! the library can be found. It is looked for, in order:
//!
//! 1. `LUMO_OIDN`: the library file itself, a folder holding it (or holding `lib/` with it), or
//!    the folder of the `pyoidn` Python package (which bundles OIDN for Linux x86-64 in
//!    `oidn/lib/`);
//! 2. `OIDN_DIR`: an OIDN install (its `lib/`), as the `oidn` crate uses it;
//! 3. the system's loader path (`libOpenImageDenoise.so.2`, an OIDN installed system-wide).
//!
//! A render with `--denoise` checks this before it starts ([`Oidn::load`]) and fails with the
//! way to install the library when it is missing.
//!
//! # Filtering
//!
//! The `RT` filter (HDR colour) is guided by the albedo and normal passes ([`crate::aov`]). For
//! final frames the guides are noisy where the first non-delta hit is seen through glass or
//! varies within a pixel, so they are first denoised on their own and the colour is then
//! filtered with `cleanAux` set (OIDN's recommended "prefiltering" for final-frame quality);
//! [`Prefilter::None`] skips that for previews.

use std::ffi::{c_char, c_void, CStr, CString};
use std::path::{Path, PathBuf};

use libloading::Library;

use crate::image::Image;
use crate::math::Vec3;

/// How to install OIDN, for messages.
pub const INSTALL_HELP: &str = "install Intel Open Image Denoise 2.x: `pip install pyoidn` \
     (it bundles the library for Linux x86-64), then point LUMO_OIDN at the package's folder: \
     export LUMO_OIDN=\"$(python3 -c 'import os, pyoidn; print(os.path.dirname(pyoidn.__file__))')\" \
     (or set LUMO_OIDN to libOpenImageDenoise.so itself, or OIDN_DIR to an OIDN install)";

/// Why denoising could not run.
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    /// The library was not found or could not be loaded.
    #[error("Intel Open Image Denoise was not found ({tried}); {INSTALL_HELP}")]
    NotFound {
        /// Where it was looked for, and why each failed.
        tried: String,
    },
    /// OIDN reported an error.
    #[error("Open Image Denoise failed: {0}")]
    Oidn(String),
    /// The images given differ in size.
    #[error("the images to denoise differ in size")]
    Size,
}

impl DenoiseError {
    /// The error with where the library was looked for in front of its message.
    fn located(self, place: &str) -> DenoiseError {
        match self {
            DenoiseError::NotFound { tried } => DenoiseError::NotFound {
                tried: format!("{place}: {tried}"),
            },
            e => e,
        }
    }
}

type Handle = *mut c_void;

/// The OIDN functions lumo calls.
struct Api {
    new_device: unsafe extern "C" fn(i32) -> Handle,
    commit_device: unsafe extern "C" fn(Handle),
    release_device: unsafe extern "C" fn(Handle),
    get_device_error: unsafe extern "C" fn(Handle, *mut *const c_char) -> i32,
    new_filter: unsafe extern "C" fn(Handle, *const c_char) -> Handle,
    set_shared_filter_image: unsafe extern "C" fn(
        Handle,
        *const c_char,
        *mut c_void,
        i32,
        usize,
        usize,
        usize,
        usize,
        usize,
    ),
    set_filter_bool: unsafe extern "C" fn(Handle, *const c_char, bool),
    set_filter_int: unsafe extern "C" fn(Handle, *const c_char, i32),
    commit_filter: unsafe extern "C" fn(Handle),
    execute_filter: unsafe extern "C" fn(Handle),
    release_filter: unsafe extern "C" fn(Handle),
}

/// A loaded OIDN library with a committed CPU device.
pub struct Oidn {
    api: Api,
    device: Handle,
    /// Where the library was loaded from.
    pub path: PathBuf,
    // Kept loaded while the device lives (dropped after it); the first is the core library the
    // main one needs, loaded first by its full path.
    _libs: Vec<Library>,
}

// The device is used from one thread at a time (`&mut self` for filtering).
unsafe impl Send for Oidn {}

/// Whether and how the albedo and normal guides are denoised before the colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prefilter {
    /// Denoise albedo and normal first, then the colour with `cleanAux` (final frames).
    Clean,
    /// Use the guides as they are (previews).
    None,
}

/// OIDN's `OIDN_FORMAT_FLOAT3`.
const FORMAT_FLOAT3: i32 = 3;
/// OIDN's `OIDN_DEVICE_TYPE_CPU`.
const DEVICE_CPU: i32 = 1;
/// OIDN's `OIDN_QUALITY_HIGH`.
const QUALITY_HIGH: i32 = 6;

/// The file names of the library on this platform.
fn library_names() -> &'static [&'static str] {
    if cfg!(target_os = "macos") {
        &["libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib"]
    } else if cfg!(windows) {
        &["OpenImageDenoise.dll"]
    } else {
        &["libOpenImageDenoise.so.2", "libOpenImageDenoise.so"]
    }
}

/// Candidate library files under a folder given by the user.
fn candidates_in(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for sub in ["", "lib", "lib64", "oidn/lib"] {
        for name in library_names() {
            let p = dir.join(sub).join(name);
            if p.is_file() {
                out.push(p);
            }
        }
    }
    out
}

/// Loads the main library at `path`, with the core library beside it loaded first by its full
/// path (the main library finds it by name, and pyoidn's copy carries no search path).
fn open(path: &Path) -> Result<Vec<Library>, String> {
    let mut libs = Vec::new();
    if let Some(dir) = path.parent() {
        if let Ok(entries) = std::fs::read_dir(dir) {
            let mut cores: Vec<PathBuf> = entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| n.starts_with("libOpenImageDenoise_core"))
                })
                .collect();
            cores.sort();
            if let Some(core) = cores.last() {
                // SAFETY: loading OIDN's own core library runs its initialisers only.
                if let Ok(lib) = unsafe { Library::new(core) } {
                    libs.push(lib);
                }
            }
        }
    }
    // SAFETY: loading a shared library runs its initialisers; OIDN's have no preconditions.
    let main = unsafe { Library::new(path) }.map_err(|e| format!("{}: {e}", path.display()))?;
    libs.push(main);
    Ok(libs)
}

impl Oidn {
    /// Finds and loads OIDN (see the module doc) and creates a CPU device.
    pub fn load() -> Result<Oidn, DenoiseError> {
        for var in ["LUMO_OIDN", "OIDN_DIR"] {
            if let Some(value) = std::env::var_os(var).filter(|v| !v.is_empty()) {
                // Pointed somewhere on purpose: no quiet fallback to another copy.
                return Oidn::load_from(Path::new(&value))
                    .map_err(|e| e.located(&format!("{var}={}", Path::new(&value).display())));
            }
        }
        let mut tried = Vec::new();
        for name in library_names() {
            match open(Path::new(name)) {
                Ok(libs) => return Oidn::with_libs(libs, PathBuf::from(name)),
                Err(e) => tried.push(e),
            }
        }
        Err(DenoiseError::NotFound {
            tried: format!(
                "LUMO_OIDN and OIDN_DIR are unset, and the system's loader found none: {}",
                tried.join("; ")
            ),
        })
    }

    /// Loads OIDN from `path`: the library file, a folder holding it (or `lib/` with it), or
    /// the `pyoidn` package's folder; and creates a CPU device.
    pub fn load_from(path: &Path) -> Result<Oidn, DenoiseError> {
        let found = if path.is_file() {
            vec![path.to_path_buf()]
        } else {
            candidates_in(path)
        };
        let mut tried = Vec::new();
        for candidate in &found {
            match open(candidate) {
                Ok(libs) => return Oidn::with_libs(libs, candidate.clone()),
                Err(e) => tried.push(e),
            }
        }
        if found.is_empty() {
            tried.push(format!(
                "{} holds no {}",
                path.display(),
                library_names()[0]
            ));
        }
        Err(DenoiseError::NotFound {
            tried: tried.join("; "),
        })
    }

    fn with_libs(libs: Vec<Library>, path: PathBuf) -> Result<Oidn, DenoiseError> {
        let Some(main) = libs.last() else {
            return Err(DenoiseError::NotFound {
                tried: "no library".into(),
            });
        };
        let missing = |name: &str, e: libloading::Error| DenoiseError::NotFound {
            tried: format!(
                "{} lacks {name} ({e}): not Open Image Denoise 2.x",
                path.display()
            ),
        };
        macro_rules! sym {
            ($name:literal) => {
                // SAFETY: the symbol's type is that of OIDN 2.x's C API (OpenImageDenoise/oidn.h).
                *unsafe { main.get(concat!($name, "\0").as_bytes()) }
                    .map_err(|e| missing($name, e))?
            };
        }
        let api = Api {
            new_device: sym!("oidnNewDevice"),
            commit_device: sym!("oidnCommitDevice"),
            release_device: sym!("oidnReleaseDevice"),
            get_device_error: sym!("oidnGetDeviceError"),
            new_filter: sym!("oidnNewFilter"),
            set_shared_filter_image: sym!("oidnSetSharedFilterImage"),
            set_filter_bool: sym!("oidnSetFilterBool"),
            set_filter_int: sym!("oidnSetFilterInt"),
            commit_filter: sym!("oidnCommitFilter"),
            execute_filter: sym!("oidnExecuteFilter"),
            release_filter: sym!("oidnReleaseFilter"),
        };
        // SAFETY: the functions are OIDN's; a null device is checked.
        let device = unsafe { (api.new_device)(DEVICE_CPU) };
        if device.is_null() {
            return Err(DenoiseError::Oidn(format!(
                "{} could not create a CPU device",
                path.display()
            )));
        }
        let oidn = Oidn {
            api,
            device,
            path,
            _libs: libs,
        };
        // SAFETY: a valid device.
        unsafe { (oidn.api.commit_device)(oidn.device) };
        oidn.check()?;
        Ok(oidn)
    }

    /// The device's pending error, if any.
    fn check(&self) -> Result<(), DenoiseError> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: a valid device; the message, when set, is a C string owned by OIDN.
        let code = unsafe { (self.api.get_device_error)(self.device, &mut message) };
        if code == 0 {
            return Ok(());
        }
        let text = if message.is_null() {
            format!("error code {code}")
        } else {
            // SAFETY: OIDN returns a NUL-terminated string valid until the next call.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        Err(DenoiseError::Oidn(text))
    }

    /// Runs one `RT` filter on `inputs` (OIDN's image names `color`, `albedo`, `normal` with
    /// their pixels; an albedo or a normal alone is denoised on its own) into `out`; `hdr` and
    /// `cleanAux` are set when `color` is among the inputs.
    fn filter(
        &mut self,
        inputs: &mut [(&str, &mut [f32])],
        (width, height): (usize, usize),
        clean_aux: bool,
        out: &mut [f32],
    ) -> Result<(), DenoiseError> {
        let name = |s: &str| CString::new(s).unwrap_or_default();
        let n = width * height * 3;
        if out.len() != n || inputs.iter().any(|(_, d)| d.len() != n) {
            return Err(DenoiseError::Size);
        }
        let has_color = inputs.iter().any(|(what, _)| *what == "color");
        let api = &self.api;
        // SAFETY: the buffers live until the filter is executed and released below, hold
        // width × height × 3 floats (checked), and are not touched otherwise meanwhile.
        unsafe {
            let filter = (api.new_filter)(self.device, name("RT").as_ptr());
            if filter.is_null() {
                self.check()?;
                return Err(DenoiseError::Oidn("no RT filter".into()));
            }
            let set = |what: &str, data: *mut f32| {
                (api.set_shared_filter_image)(
                    filter,
                    name(what).as_ptr(),
                    data.cast(),
                    FORMAT_FLOAT3,
                    width,
                    height,
                    0,
                    0,
                    0,
                );
            };
            for (what, data) in inputs.iter_mut() {
                set(what, data.as_mut_ptr());
            }
            set("output", out.as_mut_ptr());
            if has_color {
                (api.set_filter_bool)(filter, name("hdr").as_ptr(), true);
                (api.set_filter_bool)(filter, name("cleanAux").as_ptr(), clean_aux);
            }
            (api.set_filter_int)(filter, name("quality").as_ptr(), QUALITY_HIGH);
            (api.commit_filter)(filter);
            let committed = self.check();
            if committed.is_ok() {
                (api.execute_filter)(filter);
            }
            (api.release_filter)(filter);
            committed?;
        }
        self.check()
    }

    /// Denoises `color` (linear HDR radiance) guided by `albedo` and `normal` (all of one
    /// size); with [`Prefilter::Clean`] the guides are denoised first.
    pub fn denoise(
        &mut self,
        color: &Image,
        albedo: Option<&Image>,
        normal: Option<&Image>,
        prefilter: Prefilter,
    ) -> Result<Image, DenoiseError> {
        let size = (color.width as usize, color.height as usize);
        let flat = |img: &Image| -> Result<Vec<f32>, DenoiseError> {
            if (img.width, img.height) != (color.width, color.height) {
                return Err(DenoiseError::Size);
            }
            Ok(img.pixels.iter().flat_map(|p| p.to_array()).collect())
        };
        let mut c = flat(color)?;
        let mut a = albedo.map(flat).transpose()?;
        // OIDN needs an albedo to use a normal.
        let mut nrm = match a {
            Some(_) => normal.map(flat).transpose()?,
            None => None,
        };
        let clean = prefilter == Prefilter::Clean;
        if clean {
            for (what, aux) in [("albedo", &mut a), ("normal", &mut nrm)] {
                if let Some(aux) = aux {
                    let mut out = vec![0.0; aux.len()];
                    self.filter(&mut [(what, aux.as_mut_slice())], size, false, &mut out)?;
                    *aux = out;
                }
            }
        }
        let mut out = vec![0.0; c.len()];
        let clean_aux = clean && a.is_some();
        let mut inputs: Vec<(&str, &mut [f32])> = vec![("color", c.as_mut_slice())];
        if let Some(a) = &mut a {
            inputs.push(("albedo", a.as_mut_slice()));
        }
        if let Some(nrm) = &mut nrm {
            inputs.push(("normal", nrm.as_mut_slice()));
        }
        self.filter(&mut inputs, size, clean_aux, &mut out)?;
        Ok(Image {
            width: color.width,
            height: color.height,
            pixels: out
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect(),
        })
    }
}

impl Drop for Oidn {
    fn drop(&mut self) {
        // SAFETY: the device was created by this library, which is still loaded.
        unsafe { (self.api.release_device)(self.device) };
    }
}
