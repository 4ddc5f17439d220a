//! Reading a glTF file: parsing (JSON or GLB), loading its buffers, and reading accessors with
//! every offset checked, so malformed files give located errors instead of panics.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use gltf::accessor::{DataType, Dimensions};

use super::error::GltfError;

/// Largest glTF/GLB file or external buffer we read: 2 GiB.
pub const MAX_FILE_BYTES: u64 = 2 << 30;

/// A parsed glTF file with its buffers in memory.
pub struct Loaded {
    /// The file, as given.
    pub file: PathBuf,
    /// The parsed and structurally validated document.
    pub doc: gltf::Document,
    /// Buffer contents by index.
    pub buffers: Vec<BufferBytes>,
    /// The external buffer files that were read (not the glTF file itself).
    pub buffer_files: Vec<PathBuf>,
}

/// One buffer's bytes: `data[range]`. The GLB binary chunk keeps the whole file's bytes and
/// its range in them, so that the geometry of a big `.glb` is never copied (a copy of a
/// 31 MB chunk cost a few milliseconds and as many fresh pages at every start).
#[derive(Debug)]
pub struct BufferBytes {
    data: Vec<u8>,
    range: std::ops::Range<usize>,
}

impl BufferBytes {
    /// A buffer that is all of `data`.
    fn whole(data: Vec<u8>) -> BufferBytes {
        let range = 0..data.len();
        BufferBytes { data, range }
    }

    /// The buffer's bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.data[self.range.clone()]
    }
}

/// Reads a file with a size limit.
pub fn read_file(file: &Path) -> Result<Vec<u8>, GltfError> {
    let meta = std::fs::metadata(file).map_err(|source| GltfError::Io {
        file: file.to_path_buf(),
        action: "cannot read",
        source,
    })?;
    if meta.len() > MAX_FILE_BYTES {
        return Err(GltfError::invalid(
            file,
            "file",
            format!(
                "{} bytes is above the {MAX_FILE_BYTES}-byte limit",
                meta.len()
            ),
        ));
    }
    std::fs::read(file).map_err(|source| GltfError::Io {
        file: file.to_path_buf(),
        action: "cannot read",
        source,
    })
}

/// Decodes `%XX` escapes of a URI path (glTF URIs are RFC 3986 URI references).
pub fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            if let Some(v) = hex {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Encodes a relative path as a URI reference: unreserved characters and `/` stay, the rest is
/// `%XX`-escaped.
pub fn percent_encode(path: &str) -> String {
    let mut out = String::new();
    for &c in path.as_bytes() {
        if c.is_ascii_alphanumeric() || b"-._~/".contains(&c) {
            out.push(c as char);
        } else {
            out.push_str(&format!("%{c:02X}"));
        }
    }
    out
}

/// Bytes with their MIME type when known.
pub type TypedBytes = (Vec<u8>, Option<String>);

/// Decodes a `data:` URI's payload (base64 only, as glTF requires). `None` when `uri` is not a
/// data URI.
pub fn decode_data_uri(
    file: &Path,
    element: &str,
    uri: &str,
) -> Option<Result<TypedBytes, GltfError>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((meta, payload)) = rest.split_once(',') else {
        return Some(Err(GltfError::invalid(
            file,
            element,
            "data URI without a comma",
        )));
    };
    let Some(mime) = meta.strip_suffix(";base64") else {
        return Some(Err(GltfError::invalid(
            file,
            element,
            "data URI is not base64-encoded (glTF requires `;base64,`)",
        )));
    };
    let mime = (!mime.is_empty()).then(|| mime.to_string());
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map(|bytes| (bytes, mime))
            .map_err(|e| GltfError::invalid(file, element, format!("invalid base64 data: {e}"))),
    )
}

/// Extensions lumo implements: a file may require (`extensionsRequired`) only these.
pub const HANDLED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_unlit",
    "KHR_texture_transform",
    INSTANCING,
];

/// The extension that gives a node's mesh many instances, each with its own transform.
pub const INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// Whether every validation error is an `extensionsRequired` entry the gltf crate does not
/// support but lumo does.
fn only_handled_required(
    errors: &[(gltf::json::Path, gltf::json::validation::Error)],
    bytes: &[u8],
) -> bool {
    let Ok(raw) = gltf::Gltf::from_slice_without_validation(bytes) else {
        return false;
    };
    let required: Vec<&str> = raw.document.extensions_required().collect();
    !errors.is_empty()
        && errors.iter().all(|(path, err)| {
            let p = path.to_string();
            let index = p
                .strip_prefix("extensionsRequired[")
                .and_then(|r| r.split(']').next())
                .and_then(|i| i.parse::<usize>().ok());
            matches!(err, gltf::json::validation::Error::Unsupported)
                && index
                    .and_then(|i| required.get(i))
                    .is_some_and(|name| HANDLED_EXTENSIONS.contains(name))
        })
}

/// Maps the gltf crate's parse error to ours.
fn parse_error(file: &Path, e: gltf::Error) -> GltfError {
    match e {
        gltf::Error::Validation(errors) => {
            for (path, err) in &errors {
                let p = path.to_string();
                if matches!(err, gltf::json::validation::Error::Unsupported)
                    && p.starts_with("extensionsRequired[")
                {
                    // The path reads `extensionsRequired[1] = "NAME"`: the index is up to `]`.
                    let index = p
                        .trim_start_matches("extensionsRequired[")
                        .split(']')
                        .next()
                        .and_then(|i| i.parse().ok())
                        .unwrap_or(0);
                    return GltfError::UnsupportedExtension {
                        file: file.to_path_buf(),
                        index,
                        extension: String::new(),
                    };
                }
            }
            let element = errors
                .first()
                .map(|(p, _)| p.to_string())
                .unwrap_or_default();
            let message = errors
                .iter()
                .map(|(p, e)| format!("{p}: {e}"))
                .collect::<Vec<_>>()
                .join("; ");
            GltfError::invalid(
                file,
                element,
                format!("invalid glTF ({message}); fix or re-export the file"),
            )
        }
        gltf::Error::Deserialize(e) => GltfError::invalid(
            file,
            format!("JSON line {} column {}", e.line(), e.column()),
            format!("not valid glTF JSON: {e}"),
        ),
        gltf::Error::Binary(e) => GltfError::invalid(
            file,
            "GLB",
            format!("broken binary glTF: {e:?} (the file is truncated or not a .glb)"),
        ),
        other => GltfError::invalid(file, "file", other.to_string()),
    }
}

impl Loaded {
    /// Reads, parses and validates a .gltf or .glb file and loads all its buffers.
    pub fn open(file: &Path) -> Result<Loaded, GltfError> {
        Self::from_file_bytes(file, read_file(file)?, true)
    }

    /// Parses bytes as the file `file` (used for messages and to resolve relative URIs).
    /// With `external` false, external buffer files are not read (an error names them).
    pub fn from_bytes(file: &Path, bytes: &[u8], external: bool) -> Result<Loaded, GltfError> {
        Self::from_file_bytes(file, bytes.to_vec(), external)
    }

    /// [`Loaded::from_bytes`] taking the file's bytes, which a GLB's binary chunk then keeps.
    fn from_file_bytes(file: &Path, bytes: Vec<u8>, external: bool) -> Result<Loaded, GltfError> {
        precheck(file, &bytes)?;
        // A GLB's JSON chunk is parsed alone and its binary chunk located, not copied out (as
        // `gltf::Gltf::from_slice` would); the gltf crate parses a GLB just so otherwise.
        let (json, bin_range) = if bytes.starts_with(b"glTF") {
            let glb = gltf::Glb::from_slice(&bytes).map_err(|e| parse_error(file, e))?;
            let bin_range = glb.bin.as_deref().map(|bin| {
                let start = bin.as_ptr() as usize - bytes.as_ptr() as usize;
                start..start + bin.len()
            });
            (glb.json, bin_range)
        } else {
            (std::borrow::Cow::Borrowed(&bytes[..]), None)
        };
        let parsed = match gltf::Gltf::from_slice(&json) {
            // The gltf crate refuses required extensions it does not parse itself (clearcoat,
            // sheen); when those are the only complaints and lumo implements them, take the
            // document as parsed (the importer reads those extensions from the raw JSON).
            Err(gltf::Error::Validation(errors)) if only_handled_required(&errors, &json) => {
                gltf::Gltf::from_slice_without_validation(&json)
            }
            other => other,
        };
        let gltf = parsed.map_err(|e| {
            let mut err = parse_error(file, e);
            if let GltfError::UnsupportedExtension {
                index, extension, ..
            } = &mut err
            {
                // Recover the extension's name from the raw JSON for the message.
                if let Ok(raw) = gltf::Gltf::from_slice_without_validation(&json) {
                    if let Some(name) = raw.document.extensions_required().nth(*index) {
                        *extension = name.to_string();
                    }
                }
            }
            err
        })?;
        drop(json);
        let document = gltf.document;
        let mut blob = bin_range.map(|range| BufferBytes { data: bytes, range });
        // The GLB binary chunk moves into the one buffer that refers to it (a second such
        // buffer, which glTF does not allow, gets a copy).
        let bin_users = document
            .buffers()
            .filter(|b| matches!(b.source(), gltf::buffer::Source::Bin))
            .count();
        let dir = file.parent().unwrap_or(Path::new(""));
        let mut buffers = Vec::new();
        let mut buffer_files = Vec::new();
        for buffer in document.buffers() {
            let element = format!("buffers[{}]", buffer.index());
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => match &mut blob {
                    Some(b) if bin_users == 1 => {
                        std::mem::replace(b, BufferBytes::whole(Vec::new()))
                    }
                    Some(b) => BufferBytes::whole(b.bytes().to_vec()),
                    None => {
                        return Err(GltfError::invalid(
                            file,
                            element,
                            "refers to the GLB binary chunk, but the file has none",
                        ))
                    }
                },
                gltf::buffer::Source::Uri(uri) => match decode_data_uri(file, &element, uri) {
                    Some(r) => BufferBytes::whole(r?.0),
                    None => {
                        let path = dir.join(percent_decode(uri));
                        if !external {
                            return Err(GltfError::invalid(
                                file,
                                element,
                                format!("external buffer `{uri}` cannot be read here"),
                            ));
                        }
                        if !path.is_file() {
                            return Err(GltfError::invalid(
                                file,
                                format!("{element}.uri"),
                                format!("buffer file `{uri}` not found (looked for {}); copy it next to the glTF file", path.display()),
                            ));
                        }
                        let data = read_file(&path)?;
                        buffer_files.push(path);
                        BufferBytes::whole(data)
                    }
                },
            };
            if data.bytes().len() < buffer.length() {
                return Err(GltfError::invalid(
                    file,
                    element,
                    format!(
                        "holds {} bytes but its byteLength is {}: the buffer is truncated",
                        data.bytes().len(),
                        buffer.length()
                    ),
                ));
            }
            buffers.push(data);
        }
        Ok(Loaded {
            file: file.to_path_buf(),
            doc: document,
            buffers,
            buffer_files,
        })
    }

    /// The bytes of a buffer view, checked against its buffer.
    pub fn view_bytes(&self, view: &gltf::buffer::View, element: &str) -> Result<&[u8], GltfError> {
        let buf = self.buffers[view.buffer().index()].bytes();
        let declared = view.buffer().length().min(buf.len());
        let end = view.offset().checked_add(view.length());
        match end {
            Some(end) if end <= declared => Ok(&buf[view.offset()..end]),
            _ => Err(GltfError::invalid(
                &self.file,
                format!("bufferViews[{}]", view.index()),
                format!(
                    "byteOffset {} + byteLength {} runs past the end of buffers[{}] ({} bytes) (needed by {element})",
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    declared
                ),
            )),
        }
    }

    /// Reads an accessor as f64 components (count × components), applying the normalisation
    /// of integer types when `normalized` is set, and sparse substitution. `element` names the
    /// user (e.g. `meshes[0].primitives[1].attributes.POSITION`) for messages.
    pub fn read_accessor(
        &self,
        acc: &gltf::Accessor,
        element: &str,
    ) -> Result<Vec<f64>, GltfError> {
        let n = match acc.dimensions() {
            Dimensions::Scalar => 1,
            Dimensions::Vec2 => 2,
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            other => {
                return Err(self.acc_err(
                    acc,
                    element,
                    format!("has type {other:?}; lumo reads only SCALAR and VEC2..4 here"),
                ));
            }
        };
        let dt = acc.data_type();
        let csize = dt.size();
        let count = acc.count();
        let total = count
            .checked_mul(n)
            .filter(|t| *t <= (MAX_FILE_BYTES as usize) / csize.max(1));
        let Some(total) = total else {
            return Err(self.acc_err(acc, element, format!("count {count} is impossibly large")));
        };
        let norm = acc.normalized();
        let mut out = vec![0.0f64; total];
        if let Some((bytes, stride)) = self.dense_bytes(acc, element, n)? {
            for i in 0..count {
                let base = i * stride;
                for c in 0..n {
                    out[i * n + c] = component(&bytes[base + c * csize..], dt, norm);
                }
            }
        }
        if let Some(sparse) = acc.sparse() {
            let se = format!("accessors[{}].sparse", acc.index());
            let k = sparse.count();
            let idx_view = sparse.indices().view();
            let idx_bytes = self.view_bytes(&idx_view, &se)?;
            let it = match sparse.indices().index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let val_view = sparse.values().view();
            let val_bytes = self.view_bytes(&val_view, &se)?;
            let (io, vo) = (sparse.indices().offset(), sparse.values().offset());
            let need_i = io as u128 + k as u128 * it.size() as u128;
            let need_v = vo as u128 + k as u128 * (csize * n) as u128;
            if need_i > idx_bytes.len() as u128 || need_v > val_bytes.len() as u128 {
                return Err(GltfError::invalid(&self.file, se, format!("{k} sparse entries run past the end of their buffer views: the buffer is too short")));
            }
            for j in 0..k {
                let target = component(&idx_bytes[io + j * it.size()..], it, false) as usize;
                if target >= count {
                    return Err(GltfError::invalid(
                        &self.file,
                        format!("{se}.indices"),
                        format!("entry {j} is index {target}, out of range for an accessor of {count} elements"),
                    ));
                }
                for c in 0..n {
                    out[target * n + c] =
                        component(&val_bytes[vo + (j * n + c) * csize..], dt, norm);
                }
            }
        }
        Ok(out)
    }

    /// The bytes of an accessor's dense data (from its buffer view, which must hold all
    /// `count` elements of `n` components at the view's stride) and that stride; `None` when
    /// the accessor has no buffer view (all zeros, or sparse only).
    fn dense_bytes(
        &self,
        acc: &gltf::Accessor,
        element: &str,
        n: usize,
    ) -> Result<Option<(&[u8], usize)>, GltfError> {
        let Some(view) = acc.view() else {
            return Ok(None);
        };
        let count = acc.count();
        let bytes = self.view_bytes(&view, element)?;
        let elem = acc.data_type().size() * n;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.acc_err(acc, element, format!("bufferViews[{}].byteStride {stride} is smaller than one element ({elem} bytes)", view.index())));
        }
        if count > 0 {
            let need = acc.offset() as u128 + (count as u128 - 1) * stride as u128 + elem as u128;
            if need > bytes.len() as u128 {
                return Err(self.acc_err(
                    acc,
                    element,
                    format!(
                        "needs {need} bytes of bufferViews[{}] (byteOffset {} + {count} elements × stride {stride}) but the view has {}: the buffer is shorter than the accessor",
                        view.index(),
                        acc.offset(),
                        bytes.len()
                    ),
                ));
            }
        }
        Ok(Some((&bytes[acc.offset()..], stride)))
    }

    /// A VEC3 accessor of plain (not normalized) FLOATs without sparse substitution, read
    /// straight into `f32` triples (the common case of positions and normals, without the f64
    /// round trip of [`Loaded::read_accessor`], which gives the same values); `None` for any
    /// other accessor.
    pub fn read_f32x3(
        &self,
        acc: &gltf::Accessor,
        element: &str,
    ) -> Result<Option<Vec<[f32; 3]>>, GltfError> {
        if acc.dimensions() != Dimensions::Vec3
            || acc.data_type() != DataType::F32
            || acc.normalized()
            || acc.sparse().is_some()
        {
            return Ok(None);
        }
        let Some((bytes, stride)) = self.dense_bytes(acc, element, 3)? else {
            return Ok(None);
        };
        let f = |b: &[u8], k: usize| f32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
        Ok(Some(
            (0..acc.count())
                .map(|i| {
                    let b = &bytes[i * stride..];
                    [f(b, 0), f(b, 4), f(b, 8)]
                })
                .collect(),
        ))
    }

    /// A SCALAR accessor of unsigned integers without sparse substitution (the common case of
    /// triangle indices), read straight into groups of `N` `u32`s (no f64 round trip, no flat
    /// copy regrouped afterwards; the same values as [`Loaded::read_accessor`]); `None` for any
    /// other accessor, or when its count is not a multiple of `N`.
    pub fn read_u32s<const N: usize>(
        &self,
        acc: &gltf::Accessor,
        element: &str,
    ) -> Result<Option<Vec<[u32; N]>>, GltfError> {
        let dt = acc.data_type();
        if acc.dimensions() != Dimensions::Scalar
            || !matches!(dt, DataType::U8 | DataType::U16 | DataType::U32)
            || acc.sparse().is_some()
            || !acc.count().is_multiple_of(N)
        {
            return Ok(None);
        }
        let Some((bytes, stride)) = self.dense_bytes(acc, element, 1)? else {
            return Ok(None);
        };
        // Each element type its own loop (`one` reads the element at the start of a slice).
        fn groups<const N: usize>(
            bytes: &[u8],
            stride: usize,
            count: usize,
            one: impl Fn(&[u8]) -> u32,
        ) -> Vec<[u32; N]> {
            (0..count / N)
                .map(|g| std::array::from_fn(|k| one(&bytes[(g * N + k) * stride..])))
                .collect()
        }
        let count = acc.count();
        Ok(Some(match dt {
            DataType::U8 => groups(bytes, stride, count, |b| u32::from(b[0])),
            DataType::U16 => groups(bytes, stride, count, |b| {
                u32::from(u16::from_le_bytes([b[0], b[1]]))
            }),
            _ => groups(bytes, stride, count, |b| {
                u32::from_le_bytes([b[0], b[1], b[2], b[3]])
            }),
        }))
    }

    fn acc_err(&self, acc: &gltf::Accessor, element: &str, msg: String) -> GltfError {
        GltfError::invalid(
            &self.file,
            format!("{element} (accessors[{}])", acc.index()),
            msg,
        )
    }

    /// The encoded bytes of an image and its MIME type when known.
    pub fn image_bytes(&self, image: &gltf::Image) -> Result<(Vec<u8>, Option<String>), GltfError> {
        let element = format!("images[{}]", image.index());
        match image.source() {
            gltf::image::Source::View { view, mime_type } => Ok((
                self.view_bytes(&view, &element)?.to_vec(),
                Some(mime_type.to_string()),
            )),
            gltf::image::Source::Uri { uri, mime_type } => {
                match decode_data_uri(&self.file, &element, uri) {
                    Some(r) => r.map(|(b, m)| (b, m.or(mime_type.map(str::to_string)))),
                    None => {
                        let path = self.resolve_uri(uri);
                        if !path.is_file() {
                            return Err(GltfError::invalid(
                            &self.file,
                            format!("{element}.uri"),
                            format!("texture image `{uri}` not found (looked for {}); copy it next to the glTF file", path.display()),
                        ));
                        }
                        Ok((
                            read_file(&path)?,
                            mime_type.map(str::to_string).or_else(|| mime_of_name(uri)),
                        ))
                    }
                }
            }
        }
    }

    /// The file an image is read from when its URI names an external file (not a data URI,
    /// not a buffer view).
    pub fn image_file(&self, image: &gltf::Image) -> Option<PathBuf> {
        match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                Some(self.resolve_uri(uri))
            }
            _ => None,
        }
    }

    /// The file a relative (non-data) URI names: percent-decoded, against [`Loaded::dir`].
    pub fn resolve_uri(&self, uri: &str) -> PathBuf {
        self.dir().join(percent_decode(uri))
    }

    /// The folder relative URIs resolve against.
    pub fn dir(&self) -> &Path {
        self.file.parent().unwrap_or(Path::new(""))
    }
}

/// The MIME type guessed from a file name's extension.
pub fn mime_of_name(name: &str) -> Option<String> {
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".png") {
        Some("image/png".into())
    } else if lower.ends_with(".jpg") || lower.ends_with(".jpeg") {
        Some("image/jpeg".into())
    } else {
        None
    }
}

/// The MIME type of encoded image bytes from their signature, for the two formats glTF allows.
pub fn mime_of_bytes(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else {
        None
    }
}

/// One little-endian component as f64; normalised integers map to [0, 1] or [−1, 1] as the
/// glTF specification (§3.11) defines. The caller guarantees `b` holds the component.
fn component(b: &[u8], dt: DataType, normalized: bool) -> f64 {
    match dt {
        DataType::I8 => {
            let v = f64::from(b[0] as i8);
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U8 => {
            let v = f64::from(b[0]);
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = f64::from(i16::from_le_bytes([b[0], b[1]]));
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    }
}

/// Checks what the gltf crate's validation dereferences without checking (found by fuzzing:
/// a POSITION attribute naming a missing accessor panics inside `gltf-json` 1.4), so those
/// files get an error instead.
fn precheck(file: &Path, bytes: &[u8]) -> Result<(), GltfError> {
    // GLB framing: the gltf crate subtracts the header size from the declared length
    // unchecked (found by cargo-fuzz: a declared length below 12 panics in debug builds).
    if bytes.starts_with(b"glTF") {
        if bytes.len() < 20 {
            return Err(GltfError::invalid(file, "GLB", format!("the file is {} bytes, shorter than a GLB header and chunk header: it is truncated", bytes.len())));
        }
        let declared = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
        if declared < 20 || declared > bytes.len() {
            return Err(GltfError::invalid(
                file,
                "GLB header",
                format!("declares a length of {declared} bytes but the file has {}: the file is truncated or corrupt", bytes.len()),
            ));
        }
    }
    // Parse errors are reported by the validating parse that follows. Only the JSON is read
    // here: the GLB's binary chunk (most of a big file) is left where it is, not copied.
    let json = if bytes.starts_with(b"glTF") {
        match gltf::Glb::from_slice(bytes) {
            Ok(glb) => glb.json,
            Err(_) => return Ok(()),
        }
    } else {
        std::borrow::Cow::Borrowed(bytes)
    };
    let Ok(root) = gltf::json::Root::from_slice(&json) else {
        return Ok(());
    };
    let n = root.accessors.len();
    for (i, m) in root.meshes.iter().enumerate() {
        for (j, p) in m.primitives.iter().enumerate() {
            for (sem, acc) in &p.attributes {
                if acc.value() >= n {
                    let name = match sem {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "?".into(),
                    };
                    return Err(GltfError::invalid(
                        file,
                        format!("meshes[{i}].primitives[{j}].attributes.{name}"),
                        format!(
                            "accessor index {} is out of range: the file has {n} accessors",
                            acc.value()
                        ),
                    ));
                }
            }
        }
    }
    for (i, img) in root.images.iter().enumerate() {
        let el = format!("images[{i}]");
        match (&img.uri, &img.buffer_view, &img.mime_type) {
            (None, None, _) => {
                return Err(GltfError::invalid(
                    file,
                    el,
                    "has neither `uri` nor `bufferView`",
                ))
            }
            (_, Some(_), None) => {
                return Err(GltfError::invalid(
                    file,
                    format!("{el}.mimeType"),
                    "is required with `bufferView`",
                ))
            }
            _ => {}
        }
    }
    for (i, c) in root.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        use gltf::json::validation::Checked;
        let missing = match c.type_ {
            Checked::Valid(Type::Perspective) => c.perspective.is_none().then_some("perspective"),
            Checked::Valid(Type::Orthographic) => {
                c.orthographic.is_none().then_some("orthographic")
            }
            Checked::Invalid => None,
        };
        if let Some(key) = missing {
            return Err(GltfError::invalid(
                file,
                format!("cameras[{i}].{key}"),
                "is missing for a camera of this type",
            ));
        }
    }
    let lights = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map(|k| k.lights.as_slice())
        .unwrap_or(&[]);
    for (i, l) in lights.iter().enumerate() {
        use gltf::json::extensions::scene::khr_lights_punctual::Type;
        if matches!(l.type_, gltf::json::validation::Checked::Valid(Type::Spot)) && l.spot.is_none()
        {
            return Err(GltfError::invalid(
                file,
                format!("extensions.KHR_lights_punctual.lights[{i}].spot"),
                "is missing for a spot light",
            ));
        }
    }
    for (i, n) in root.nodes.iter().enumerate() {
        if let Some(k) = n
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
        {
            if k.light.value() >= lights.len() {
                return Err(GltfError::invalid(
                    file,
                    format!("nodes[{i}].extensions.KHR_lights_punctual.light"),
                    format!(
                        "light index {} is out of range: the file has {} lights",
                        k.light.value(),
                        lights.len()
                    ),
                ));
            }
        }
    }
    Ok(())
}
