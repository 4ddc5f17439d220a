//! Partial films: the exact per-pixel sums of a sample range of a render (or of a window of it),
//! saved so that renders can be split across processes and machines, checkpointed and resumed,
//! and merged bit for bit (`lumo render --samples A..B --film F`, `lumo merge`).
//!
//! # Format (version 1)
//!
//! A NumPy `.npz` archive (a zip file; every Python driver reads it with `numpy.load`), whose
//! members are `.npy` arrays (format 1.0, little-endian, C order):
//!
//! | member | dtype | shape | content |
//! |---|---|---|---|
//! | `header` | `uint8` | (n,) | UTF-8 JSON, the [`FilmHeader`] |
//! | `sum_hi`, `sum_lo` | `int64`, `uint64` | (h, w, 3) | Σ v per channel as the 128-bit integer hi·2⁶⁴ + lo, in units of 2⁻⁶⁴ |
//! | `sum_sq_hi`, `sum_sq_lo` | `int64`, `uint64` | (h, w, 3) | Σ v² per channel, the same way, in units of 2⁻³² |
//! | `finite` | `uint32` | (h, w) | samples in the sums |
//! | `dropped` | `uint32` | (h, w) | samples dropped (NaN, infinite, or a channel ≥ 2³²) |
//!
//! h × w is the crop window's size. A pixel's mean is sum / 2⁶⁴ / finite. The archive's comment
//! is `lumo-sha256:` and the SHA-256 (hex) of every byte before it, so that any change to the file
//! (not only to a member's data, which the zip's CRC-32s cover) is caught; every field is also
//! checked on reading, and a file that does not match gives an error naming the file and what is
//! wrong.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::aov::{AovSet, AovSums, IdRecord};
use crate::hash::{hex, sha256};
use crate::render::{Film, PixelSum, Window};

/// Sample indices `[start, end)`.
pub type SampleRange = [u32; 2];

/// The extension of partial-film files.
pub const EXTENSION: &str = "npz";
/// The `format` field of every header.
pub const FORMAT: &str = "lumo-partial-film";
/// The version of the format this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// What a partial film is of: everything that must agree for two films to merge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmHeader {
    /// Always [`FORMAT`].
    pub format: String,
    /// [`FORMAT_VERSION`] of the writer.
    pub format_version: u32,
    /// lumo's version (Cargo package version).
    pub lumo_version: String,
    /// The SHA-256 of the lumo executable that rendered it ([`build_id`]).
    pub build_id: String,
    /// Content hash of the loaded scene after command-line overrides, with the bytes of every
    /// file it reads ([`crate::load::Loaded::content_hash`]).
    pub scene_hash: String,
    /// Full image width in pixels.
    pub width: u32,
    /// Full image height in pixels.
    pub height: u32,
    /// The window of the image the film covers: `[x0, y0, x1, y1]`.
    pub crop: [u32; 4],
    /// The render's seed.
    pub seed: u64,
    /// The sample sequence (`sobol`, `independent`).
    pub sampler: String,
    /// The sample indices every pixel of the film holds: sorted, disjoint `[start, end)`.
    pub samples: Vec<[u32; 2]>,
    /// Checkpoints: the samples per pixel the render was going to take.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_spp: Option<u32>,
    /// Checkpoints of time-budgeted renders: seconds of the budget left.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_left_s: Option<f64>,
    /// Checkpoints written by `lumo render`: the arguments after `lumo render` that render the
    /// same scene (its absolute path and every flag that changes pixels), so that
    /// `lumo render --resume CK.npz -o OUT` needs nothing else. Not part of what must agree.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<Vec<String>>,
    /// The render passes the film sums besides the beauty ([`crate::aov`]), by name; films of
    /// different passes do not merge.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aovs: Vec<String>,
}

impl FilmHeader {
    /// The render passes the film sums.
    pub fn aov_set(&self) -> Result<AovSet, String> {
        self.aovs.join(",").parse()
    }

    /// The crop window.
    pub fn window(&self) -> Window {
        Window {
            x0: self.crop[0],
            y0: self.crop[1],
            x1: self.crop[2],
            y1: self.crop[3],
        }
    }

    /// Samples per pixel the film holds.
    pub fn spp(&self) -> u64 {
        self.samples
            .iter()
            .map(|r| u64::from(r[1].saturating_sub(r[0])))
            .sum()
    }

    /// The first mismatch between what two films are of, as a sentence naming what differs,
    /// or `None` when they can merge. What a user sets on the command line is compared first
    /// (resolution, seed, sampler), then the build, then the rest of the scene, whose hash
    /// also covers the resolution and seed: a film rendered at another `--width` is reported
    /// as another resolution, not as another scene.
    pub fn mismatch(&self, other: &FilmHeader) -> Option<String> {
        let field = |what: &str, a: &dyn std::fmt::Display, b: &dyn std::fmt::Display| {
            Some(format!("{what} differs: {a} here, {b} in the other"))
        };
        if (self.width, self.height) != (other.width, other.height) {
            return field(
                "the resolution",
                &format!("{}×{}", self.width, self.height),
                &format!("{}×{}", other.width, other.height),
            );
        }
        if self.seed != other.seed {
            return field("the seed", &self.seed, &other.seed);
        }
        if self.sampler != other.sampler {
            return field("the sampler", &self.sampler, &other.sampler);
        }
        if self.lumo_version != other.lumo_version {
            return field("lumo's version", &self.lumo_version, &other.lumo_version);
        }
        if self.build_id != other.build_id {
            return field("lumo's build", &self.build_id, &other.build_id);
        }
        if self.aovs != other.aovs {
            let names = |a: &[String]| {
                if a.is_empty() {
                    "none".to_string()
                } else {
                    a.join(",")
                }
            };
            return Some(format!(
                "the render passes differ: {} here, {} in the other (render every part with \
                 the same --aov)",
                names(&self.aovs),
                names(&other.aovs)
            ));
        }
        if self.scene_hash != other.scene_hash {
            return Some(format!(
                "the scene differs: its description after overrides (such as --max-depth, \
                 --integrator, --env) or a file it reads is not the same (content hash {} here, \
                 {} in the other)",
                self.scene_hash, other.scene_hash
            ));
        }
        None
    }
}

/// A partial film: what it is of, and the sums.
#[derive(Debug, Clone, PartialEq)]
pub struct PartialFilm {
    /// What the film is of.
    pub header: FilmHeader,
    /// The sums over the crop window.
    pub film: Film,
}

/// A partial film that could not be read or written.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", file.display())]
pub struct FilmError {
    /// The file.
    pub file: PathBuf,
    /// What went wrong.
    pub message: String,
    /// Whether it is an I/O failure (exit code 1) rather than a bad file (exit code 2).
    pub io: bool,
}

static BUILD_ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();

/// The SHA-256 of the running lumo executable, computed once: two processes with the same build
/// id run the same code, so their samples are the same bits. A host that embeds the library in
/// another program (the Python extension) names its own build first, with [`set_build_id`].
pub fn build_id() -> String {
    BUILD_ID
        .get_or_init(|| {
            std::env::current_exe()
                .map_err(|e| e.to_string())
                .and_then(|exe| file_build_id(&exe))
                .unwrap_or_else(|e| format!("unknown ({e})"))
        })
        .clone()
}

/// The build id of a binary: `sha256:` and the SHA-256 of its bytes.
pub fn file_build_id(binary: &Path) -> Result<String, String> {
    crate::hash::sha256_file(binary)
        .map(|h| format!("sha256:{}", hex(&h)))
        .map_err(|e| e.to_string())
}

/// Sets the build id films carry ([`build_id`]), for a library embedded in a program that is
/// not lumo's executable (the Python interpreter): the id of the module that holds lumo's code.
/// Returns false, changing nothing, when the id was already set or used.
pub fn set_build_id(id: String) -> bool {
    BUILD_ID.set(id).is_ok()
}

const NPY_MAGIC: &[u8] = b"\x93NUMPY";

/// A shape as the Python tuple .npy headers write, `(3,)` or `(h, w, 3)`, with `sep` between
/// dimensions.
fn shape_tuple(shape: &[usize], sep: &str) -> String {
    let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
    if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(sep))
    }
}

/// One `.npy` array: format 1.0 header (padded to a multiple of 64 bytes) and data.
fn npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let shape = shape_tuple(shape, ", ");
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    let unpadded = NPY_MAGIC.len() + 2 + 2 + dict.len() + 1;
    dict.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    dict.push('\n');
    let mut out = Vec::with_capacity(10 + dict.len() + data.len());
    out.extend_from_slice(NPY_MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out.extend_from_slice(data);
    out
}

/// The data of a `.npy` array, checked to have exactly this dtype and shape.
fn npy_data<'a>(bytes: &'a [u8], descr: &str, shape: &[usize]) -> Result<&'a [u8], String> {
    if bytes.len() < 10 || &bytes[..6] != NPY_MAGIC {
        return Err("not a .npy array".into());
    }
    let (header_len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10usize),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!(".npy format version {v} is not supported")),
    };
    let end = start
        .checked_add(header_len)
        .filter(|&e| e <= bytes.len())
        .ok_or("the .npy header is cut short")?;
    let dict =
        std::str::from_utf8(&bytes[start..end]).map_err(|_| "the .npy header is not text")?;
    let compact: String = dict.chars().filter(|c| !c.is_whitespace()).collect();
    let want_shape = shape_tuple(shape, ",");
    for (key, want) in [
        ("'descr':", format!("'{descr}'")),
        ("'fortran_order':", "False".to_string()),
        ("'shape':", want_shape),
    ] {
        let value = compact
            .find(key)
            .map(|i| &compact[i + key.len()..])
            .ok_or_else(|| format!("the .npy header has no {key}"))?;
        if !value.starts_with(&want) {
            let got: String = value.chars().take(want.len().max(8)).collect();
            return Err(format!("expected {key} {want}, found {got}…"));
        }
    }
    let items = shape
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .ok_or("its shape is too large")?;
    let size = descr[2..].parse::<usize>().map_err(|_| "bad dtype")?;
    let data = &bytes[end..];
    if Some(data.len()) != items.checked_mul(size) {
        return Err(format!(
            "holds {} bytes of data, expected {items} items of {size} bytes",
            data.len()
        ));
    }
    Ok(data)
}

impl PartialFilm {
    /// Writes the film atomically (a temporary file in the same folder, then a rename).
    pub fn write(&self, path: &Path) -> Result<(), FilmError> {
        let fail = |e: &dyn std::fmt::Display| FilmError {
            file: path.to_path_buf(),
            message: e.to_string(),
            io: true,
        };
        let (w, h) = (self.film.width() as usize, self.film.height() as usize);
        let pixels = self.film.pixels();
        let mut sum_hi = Vec::with_capacity(pixels.len() * 24);
        let mut sum_lo = Vec::with_capacity(pixels.len() * 24);
        let mut sq_hi = Vec::with_capacity(pixels.len() * 24);
        let mut sq_lo = Vec::with_capacity(pixels.len() * 24);
        let mut finite = Vec::with_capacity(pixels.len() * 4);
        let mut dropped = Vec::with_capacity(pixels.len() * 4);
        for p in pixels {
            for k in 0..3 {
                sum_hi.extend_from_slice(&((p.sum[k] >> 64) as i64).to_le_bytes());
                sum_lo.extend_from_slice(&(p.sum[k] as u64).to_le_bytes());
                sq_hi.extend_from_slice(&((p.sum_sq[k] >> 64) as i64).to_le_bytes());
                sq_lo.extend_from_slice(&(p.sum_sq[k] as u64).to_le_bytes());
            }
            finite.extend_from_slice(&p.good.to_le_bytes());
            dropped.extend_from_slice(&p.bad.to_le_bytes());
        }
        let header = serde_json::to_vec_pretty(&self.header).map_err(|e| fail(&e))?;
        let mut members: Vec<(&str, Vec<u8>)> = vec![
            ("header.npy", npy("|u1", &[header.len()], &header)),
            ("sum_hi.npy", npy("<i8", &[h, w, 3], &sum_hi)),
            ("sum_lo.npy", npy("<u8", &[h, w, 3], &sum_lo)),
            ("sum_sq_hi.npy", npy("<i8", &[h, w, 3], &sq_hi)),
            ("sum_sq_lo.npy", npy("<u8", &[h, w, 3], &sq_lo)),
            ("finite.npy", npy("<u4", &[h, w], &finite)),
            ("dropped.npy", npy("<u4", &[h, w], &dropped)),
        ];
        if let Some(aov) = self.film.aov_sums() {
            let stride = aov.stride();
            if stride > 0 {
                let mut hi = Vec::with_capacity(aov.sums().len() * 8);
                let mut lo = Vec::with_capacity(aov.sums().len() * 8);
                for v in aov.sums() {
                    hi.extend_from_slice(&((v >> 64) as i64).to_le_bytes());
                    lo.extend_from_slice(&(*v as u64).to_le_bytes());
                }
                members.push(("aov_sum_hi.npy", npy("<i8", &[h, w, stride], &hi)));
                members.push(("aov_sum_lo.npy", npy("<u8", &[h, w, stride], &lo)));
            }
            if !aov.ids().is_empty() {
                let mut ids = Vec::with_capacity(aov.ids().len() * 12);
                for r in aov.ids() {
                    for v in [r.sample, r.object, r.material] {
                        ids.extend_from_slice(&v.to_le_bytes());
                    }
                }
                members.push(("aov_ids.npy", npy("<u4", &[h, w, 3], &ids)));
            }
        }
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .compression_level(Some(1))
            .large_file(
                pixels.len() * 24.max(8 * self.film.aov_set().summed_channels())
                    > u32::MAX as usize / 2,
            );
        for (name, bytes) in &members {
            zip.start_file(*name, options).map_err(|e| fail(&e))?;
            zip.write_all(bytes).map_err(|e| fail(&e))?;
        }
        let mut bytes = zip.finish().map_err(|e| fail(&e))?.into_inner();
        seal(&mut bytes).map_err(|e| fail(&e))?;
        let mut tmp = crate::output::temp_file_in(dir).map_err(|e| fail(&e))?;
        tmp.write_all(&bytes).map_err(|e| fail(&e))?;
        tmp.as_file().sync_all().map_err(|e| fail(&e))?;
        tmp.persist(path).map_err(|e| fail(&e.error))?;
        Ok(())
    }

    /// Reads and checks a film: a truncated, corrupt or inconsistent file is an error naming
    /// the file and the problem, never a panic.
    pub fn read(path: &Path) -> Result<PartialFilm, FilmError> {
        let bytes = std::fs::read(path).map_err(|e| FilmError {
            file: path.to_path_buf(),
            message: e.to_string(),
            io: true,
        })?;
        Self::from_bytes(&bytes).map_err(|message| FilmError {
            file: path.to_path_buf(),
            message: format!("not a usable lumo partial film: {message}"),
            io: false,
        })
    }

    /// [`read`](Self::read) from the file's bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<PartialFilm, String> {
        Self::from_archive_bytes(unseal(bytes)?)
    }

    /// [`from_bytes`](Self::from_bytes) without the whole-file checksum: the archive's own
    /// checks only. For fuzzing the parser past the checksum, which random bytes never match.
    #[doc(hidden)]
    pub fn from_archive_bytes(bytes: &[u8]) -> Result<PartialFilm, String> {
        let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes))
            .map_err(|e| format!("not a readable .npz (zip) archive ({e})"))?;
        let header_npy = member(&mut zip, "header.npy", 1 << 20)?;
        let header_bytes = npy_header_payload(&header_npy)?;
        let header: FilmHeader = serde_json::from_slice(header_bytes)
            .map_err(|e| format!("its header is not valid: {e}"))?;
        if header.format != FORMAT {
            return Err(format!("its format is `{}`, not `{FORMAT}`", header.format));
        }
        if header.format_version != FORMAT_VERSION {
            return Err(format!(
                "format version {} (this lumo reads version {FORMAT_VERSION})",
                header.format_version
            ));
        }
        let max = lumo_schema::MAX_IMAGE_SIDE;
        if header.width > max || header.height > max {
            return Err(format!(
                "its image is {}×{}, larger than lumo renders ({max} per side)",
                header.width, header.height
            ));
        }
        let [x0, y0, x1, y1] = header.crop;
        if !(x0 < x1 && y0 < y1 && x1 <= header.width && y1 <= header.height) {
            return Err(format!(
                "its crop window {:?} is not inside the {}×{} image",
                header.crop, header.width, header.height
            ));
        }
        check_ranges(&header.samples)?;
        let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
        let n = w * h;
        let limit = (n as u64) * 24 + 4096;
        let sum_hi = array(&mut zip, limit, "sum_hi", "<i8", &[h, w, 3])?;
        let sum_lo = array(&mut zip, limit, "sum_lo", "<u8", &[h, w, 3])?;
        let sq_hi = array(&mut zip, limit, "sum_sq_hi", "<i8", &[h, w, 3])?;
        let sq_lo = array(&mut zip, limit, "sum_sq_lo", "<u8", &[h, w, 3])?;
        let finite = array(&mut zip, limit, "finite", "<u4", &[h, w])?;
        let dropped = array(&mut zip, limit, "dropped", "<u4", &[h, w])?;
        let word = |b: &[u8], i: usize| {
            u64::from_le_bytes(b[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]))
        };
        let count = |b: &[u8], i: usize| {
            u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap_or([0; 4]))
        };
        let spp = header.spp();
        let mut pixels = Vec::with_capacity(n);
        for i in 0..n {
            let mut p = PixelSum::default();
            for k in 0..3 {
                let j = 3 * i + k;
                p.sum[k] =
                    (i128::from(word(&sum_hi, j) as i64) << 64) | i128::from(word(&sum_lo, j));
                p.sum_sq[k] =
                    (i128::from(word(&sq_hi, j) as i64) << 64) | i128::from(word(&sq_lo, j));
            }
            p.good = count(&finite, i);
            p.bad = count(&dropped, i);
            if u64::from(p.good) + u64::from(p.bad) != spp {
                return Err(format!(
                    "pixel ({}, {}) holds {} samples but the header lists {spp} per pixel",
                    x0 as usize + i % w,
                    y0 as usize + i / w,
                    u64::from(p.good) + u64::from(p.bad)
                ));
            }
            pixels.push(p);
        }
        let film = Film::from_pixels(w as u32, h as u32, pixels).ok_or("inconsistent size")?;
        // The header lists every pass asked for; the film sums those recorded per sample.
        let set = header.aov_set()?.recorded();
        let aov = if set.needs_samples() {
            let stride = set.summed_channels();
            let mut sums = Vec::new();
            if stride > 0 {
                let shape = [h, w, stride];
                let hi = array(&mut zip, limit * 8, "aov_sum_hi", "<i8", &shape)?;
                let lo = array(&mut zip, limit * 8, "aov_sum_lo", "<u8", &shape)?;
                sums = (0..n * stride)
                    .map(|j| (i128::from(word(&hi, j) as i64) << 64) | i128::from(word(&lo, j)))
                    .collect();
            }
            let mut ids = Vec::new();
            if set.has_ids() {
                let raw = array(&mut zip, limit, "aov_ids", "<u4", &[h, w, 3])?;
                ids = (0..n)
                    .map(|i| IdRecord {
                        sample: count(&raw, 3 * i),
                        object: count(&raw, 3 * i + 1),
                        material: count(&raw, 3 * i + 2),
                    })
                    .collect();
            }
            Some(AovSums::from_parts(set, n, sums, ids).ok_or("inconsistent render passes")?)
        } else {
            None
        };
        let film = film
            .with_aov_sums(aov)
            .ok_or("inconsistent render passes")?;
        Ok(PartialFilm { header, film })
    }
}

/// The archive comment that seals a film: this prefix, then the SHA-256 of every byte before it.
const SEAL_PREFIX: &[u8] = b"lumo-sha256:";
const SEAL_LEN: usize = 12 + 64;

/// Appends the seal to a zip archive written without a comment: sets the end-of-central-directory
/// record's comment length (its last two bytes), then appends the comment.
fn seal(zip: &mut Vec<u8>) -> Result<(), String> {
    let n = zip.len();
    if n < 22 || zip[n - 22..n - 18] != [0x50, 0x4b, 0x05, 0x06] || zip[n - 2..] != [0, 0] {
        return Err("internal error: unexpected end of the zip archive".into());
    }
    zip[n - 2..].copy_from_slice(&(SEAL_LEN as u16).to_le_bytes());
    let digest = hex(&sha256(zip));
    zip.extend_from_slice(SEAL_PREFIX);
    zip.extend_from_slice(digest.as_bytes());
    Ok(())
}

/// Checks the seal and returns the archive.
fn unseal(bytes: &[u8]) -> Result<&[u8], String> {
    if bytes.len() < SEAL_LEN + 22 {
        return Err(format!(
            "not a readable .npz (zip) archive (only {} bytes: truncated?)",
            bytes.len()
        ));
    }
    let (body, comment) = bytes.split_at(bytes.len() - SEAL_LEN);
    if !comment.starts_with(SEAL_PREFIX) {
        if zip::ZipArchive::new(std::io::Cursor::new(bytes)).is_err() {
            return Err("not a readable .npz (zip) archive (truncated, or not a film)".into());
        }
        return Err("its lumo checksum is missing (truncated, or not written by lumo)".into());
    }
    if comment[SEAL_PREFIX.len()..] != *hex(&sha256(body)).as_bytes() {
        return Err("it is corrupt: its SHA-256 does not match the one it was written with".into());
    }
    Ok(bytes)
}

type Archive<'a> = zip::ZipArchive<std::io::Cursor<&'a [u8]>>;

/// The bytes of a member of at most `limit` bytes (a corrupt one fails its CRC-32).
fn member(zip: &mut Archive, name: &str, limit: u64) -> Result<Vec<u8>, String> {
    let file = zip
        .by_name(name)
        .map_err(|e| format!("member {name}: {e}"))?;
    if file.size() > limit {
        return Err(format!(
            "member {name} is too large ({} bytes)",
            file.size()
        ));
    }
    let mut out = Vec::with_capacity(file.size() as usize);
    file.take(limit + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("member {name} is corrupt ({e})"))?;
    Ok(out)
}

/// The data of the array member `name`.npy, checked to have this dtype and shape.
fn array(
    zip: &mut Archive,
    limit: u64,
    name: &str,
    descr: &str,
    shape: &[usize],
) -> Result<Vec<u8>, String> {
    let bytes = member(zip, &format!("{name}.npy"), limit)?;
    npy_data(&bytes, descr, shape)
        .map(<[u8]>::to_vec)
        .map_err(|e| format!("member {name}.npy: {e}"))
}

/// The payload of the `header` member (a `uint8` vector).
fn npy_header_payload(bytes: &[u8]) -> Result<&[u8], String> {
    let len = bytes.len();
    if len < 10 || &bytes[..6] != NPY_MAGIC || bytes[6] != 1 {
        return Err("member header.npy is not a .npy 1.0 array".into());
    }
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let payload = len
        .checked_sub(10 + header_len)
        .ok_or("member header.npy is cut short")?;
    npy_data(bytes, "|u1", &[payload]).map_err(|e| format!("member header.npy: {e}"))
}

/// Checks that sample ranges are sorted, disjoint and not empty.
fn check_ranges(ranges: &[[u32; 2]]) -> Result<(), String> {
    if ranges.is_empty() {
        return Err("it lists no samples".into());
    }
    for r in ranges {
        if r[0] >= r[1] {
            return Err(format!("its sample range {}..{} is empty", r[0], r[1]));
        }
    }
    for pair in ranges.windows(2) {
        if pair[0][1] > pair[1][0] {
            return Err(format!(
                "its sample ranges {}..{} and {}..{} are not sorted and disjoint",
                pair[0][0], pair[0][1], pair[1][0], pair[1][1]
            ));
        }
    }
    Ok(())
}

/// Sorted, coalesced union of sample ranges, or the first overlap found.
pub fn union_ranges(
    sets: &[&[SampleRange]],
) -> Result<Vec<SampleRange>, (SampleRange, SampleRange)> {
    let mut all: Vec<[u32; 2]> = sets.iter().flat_map(|s| s.iter().copied()).collect();
    all.sort_unstable();
    let mut out: Vec<[u32; 2]> = Vec::new();
    for r in all {
        match out.last_mut() {
            Some(last) if r[0] < last[1] => return Err((*last, r)),
            Some(last) if r[0] == last[1] => last[1] = r[1],
            _ => out.push(r),
        }
    }
    Ok(out)
}

/// `A..B` as written in headers and messages.
pub fn ranges_text(ranges: &[[u32; 2]]) -> String {
    ranges
        .iter()
        .map(|r| format!("{}..{}", r[0], r[1]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The result of merging partial films.
#[derive(Debug, Clone)]
pub struct Merged {
    /// What the merged film is of: the bounding window of the inputs and, when every pixel in
    /// it holds the same samples, those samples (else empty).
    pub header: FilmHeader,
    /// The sums over the header's window.
    pub film: Film,
    /// Whether every pixel of the window holds the same sample indices (a film can be written).
    pub uniform: bool,
    /// What is missing for a complete image: pixels without samples, pixels with fewer samples
    /// than others, or sample indices absent between the ranges (empty when complete).
    pub gaps: Vec<String>,
}

/// Merges partial films (sample ranges and/or crop windows of one render) by adding their exact
/// sums, in any order with the same bits. Errors (with the index of the film at fault): films of
/// another scene, build, size, seed or sampler, and films whose windows overlap with sample
/// ranges in common.
pub fn merge(films: &[PartialFilm]) -> Result<Merged, (usize, String)> {
    let first = films.first().ok_or((0, "no films to merge".to_string()))?;
    for (i, f) in films.iter().enumerate().skip(1) {
        if let Some(m) = f.header.mismatch(&first.header) {
            return Err((i, format!("cannot merge with the first film: {m}")));
        }
    }
    let windows: Vec<Window> = films.iter().map(|f| f.header.window()).collect();
    let mut xs: Vec<u32> = windows.iter().flat_map(|w| [w.x0, w.x1]).collect();
    let mut ys: Vec<u32> = windows.iter().flat_map(|w| [w.y0, w.y1]).collect();
    xs.sort_unstable();
    xs.dedup();
    ys.sort_unstable();
    ys.dedup();
    let bbox = Window {
        x0: xs[0],
        y0: ys[0],
        x1: xs[xs.len() - 1],
        y1: ys[ys.len() - 1],
    };
    // Every cell of the grid the windows' edges make is covered by the same films throughout.
    let mut cells: Vec<(Window, Vec<[u32; 2]>)> = Vec::new();
    for yy in ys.windows(2) {
        for xx in xs.windows(2) {
            let cell = Window {
                x0: xx[0],
                y0: yy[0],
                x1: xx[1],
                y1: yy[1],
            };
            let covering: Vec<usize> = (0..films.len())
                .filter(|&i| {
                    let w = windows[i];
                    w.x0 <= cell.x0 && cell.x1 <= w.x1 && w.y0 <= cell.y0 && cell.y1 <= w.y1
                })
                .collect();
            let mut union: Vec<[u32; 2]> = Vec::new();
            for &i in &covering {
                union = union_ranges(&[&union, &films[i].header.samples]).map_err(|(a, b)| {
                    (
                        i,
                        format!(
                            "its samples overlap another film's in pixels {}..{} × {}..{} \
                             ({}..{} and {}..{})",
                            cell.x0, cell.x1, cell.y0, cell.y1, a[0], a[1], b[0], b[1]
                        ),
                    )
                })?;
            }
            cells.push((cell, union));
        }
    }
    let reference = cells
        .iter()
        .map(|c| &c.1)
        .max_by_key(|r| r.iter().map(|r| r[1] - r[0]).sum::<u32>())
        .cloned()
        .unwrap_or_default();
    let mut gaps = Vec::new();
    let mut uniform = true;
    for (cell, union) in &cells {
        if *union != reference {
            uniform = false;
            gaps.push(if union.is_empty() {
                format!(
                    "pixels {}..{} × {}..{} have no samples",
                    cell.x0, cell.x1, cell.y0, cell.y1
                )
            } else {
                format!(
                    "pixels {}..{} × {}..{} have samples {} but others have {}",
                    cell.x0,
                    cell.x1,
                    cell.y0,
                    cell.y1,
                    ranges_text(union),
                    ranges_text(&reference)
                )
            });
        }
    }
    if bbox != Window::full(first.header.width, first.header.height) {
        gaps.push(format!(
            "the films cover pixels {}..{} × {}..{} of the {}×{} image",
            bbox.x0, bbox.x1, bbox.y0, bbox.y1, first.header.width, first.header.height
        ));
    }
    for pair in reference.windows(2) {
        gaps.push(format!(
            "samples {}..{} are missing",
            pair[0][1], pair[1][0]
        ));
    }
    let mut film = Film::with_aovs(bbox.width(), bbox.height(), first.film.aov_set());
    for (f, w) in films.iter().zip(&windows) {
        for y in 0..w.height() {
            for x in 0..w.width() {
                film.merge_pixel_from((w.x0 - bbox.x0 + x, w.y0 - bbox.y0 + y), &f.film, (x, y));
            }
        }
    }
    let header = FilmHeader {
        crop: [bbox.x0, bbox.y0, bbox.x1, bbox.y1],
        samples: if uniform { reference } else { Vec::new() },
        target_spp: None,
        time_left_s: None,
        command: None,
        ..first.header.clone()
    };
    Ok(Merged {
        header,
        film,
        uniform,
        gaps,
    })
}
