//! Multi-channel EXR: the beauty and its render passes in one part, as compositors read them
//! (OpenEXR, Blender's compositor, Mitsuba's `Bitmap`): the beauty as plain `R`, `G`, `B`, `A`
//! (alpha 1), then each pass as channels named `pass.channel` (`albedo.R`, `normal.X`,
//! `depth.Z`, `uv.U`, `object_id.I`, …), 32-bit float, or 32-bit unsigned for ids. Written
//! atomically (a temporary file beside the target, then a rename), ZIP-compressed (lossless).
//!
//! For PNG and BMP output each pass goes to a file of its own beside the image
//! ([`sidecar_path`]), mapped to colours for a quick look ([`pass_to_rgb8`]).

use std::io::BufWriter;
use std::path::{Path, PathBuf};

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image as ExrImage, Layer, LayerAttributes,
    ReadChannels, ReadLayers, SmallVec, WritableImage,
};

use crate::aov::{Aov, PassImage, PassPixels};
use crate::image::Image;
use crate::math::Vec3;
use crate::output::ImageIoError;

/// A group of channels beside the beauty: `name.suffix` for each suffix.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelGroup {
    /// The prefix (`albedo`, `noisy`).
    pub name: String,
    /// The suffixes (`R`, `G`, `B`), in the order of each pixel's values.
    pub suffixes: Vec<String>,
    /// The values, `suffixes.len()` per pixel, row-major, top row first.
    pub pixels: PassPixels,
}

impl ChannelGroup {
    /// A render pass as a channel group.
    pub fn from_pass(pass: &PassImage) -> ChannelGroup {
        ChannelGroup {
            name: pass.aov.name().to_string(),
            suffixes: pass.aov.channels().iter().map(|s| s.to_string()).collect(),
            pixels: pass.pixels.clone(),
        }
    }

    /// An RGB image as a channel group.
    pub fn from_rgb(name: &str, image: &Image) -> ChannelGroup {
        ChannelGroup {
            name: name.to_string(),
            suffixes: ["R", "G", "B"].map(String::from).to_vec(),
            pixels: PassPixels::Float(image.pixels.iter().flat_map(|p| p.to_array()).collect()),
        }
    }

    /// The group as an RGB image, when it has three float channels.
    pub fn to_rgb(&self, width: u32, height: u32) -> Option<Image> {
        let PassPixels::Float(values) = &self.pixels else {
            return None;
        };
        (self.suffixes.len() == 3 && values.len() == 3 * (width * height) as usize).then(|| Image {
            width,
            height,
            pixels: values
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect(),
        })
    }
}

/// An image with its channel groups, as read from a multi-channel EXR.
#[derive(Debug, Clone)]
pub struct Layered {
    /// The beauty (`R`, `G`, `B`).
    pub beauty: Image,
    /// The other channels, grouped by prefix, in the file's (alphabetical) order.
    pub groups: Vec<ChannelGroup>,
}

impl Layered {
    /// The group named `name`.
    pub fn group(&self, name: &str) -> Option<&ChannelGroup> {
        self.groups.iter().find(|g| g.name == name)
    }
}

/// Writes `beauty` and `groups` to `path` as one EXR part, atomically.
pub fn write_exr(path: &Path, beauty: &Image, groups: &[ChannelGroup]) -> Result<(), ImageIoError> {
    let io = |message: String| ImageIoError::Io {
        path: path.display().to_string(),
        message,
    };
    let (w, h) = (beauty.width as usize, beauty.height as usize);
    let n = w * h;
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (k, name) in ["R", "G", "B"].into_iter().enumerate() {
        let values = beauty.pixels.iter().map(|p| p[k]).collect();
        list.push(AnyChannel::new(name, FlatSamples::F32(values)));
    }
    list.push(AnyChannel::new("A", FlatSamples::F32(vec![1.0; n])));
    for g in groups {
        let c = g.suffixes.len();
        for (k, suffix) in g.suffixes.iter().enumerate() {
            let name = format!("{}.{suffix}", g.name);
            let samples = match &g.pixels {
                PassPixels::Float(v) if v.len() == n * c => {
                    FlatSamples::F32(v.iter().skip(k).step_by(c).copied().collect())
                }
                PassPixels::Id(v) if v.len() == n * c => {
                    FlatSamples::U32(v.iter().skip(k).step_by(c).copied().collect())
                }
                _ => {
                    return Err(io(format!(
                        "internal error: channel {name} has another size"
                    )))
                }
            };
            list.push(AnyChannel::new(name.as_str(), samples));
        }
    }
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = ExrImage::from_layer(layer);
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = crate::output::temp_file_in(dir).map_err(|e| {
        io(format!(
            "cannot create a temporary file in {}: {e}",
            dir.display()
        ))
    })?;
    {
        let mut writer = BufWriter::new(tmp.as_file());
        image
            .write()
            .to_buffered(&mut writer)
            .map_err(|e| io(e.to_string()))?;
        std::io::Write::flush(&mut writer).map_err(|e| io(e.to_string()))?;
    }
    tmp.as_file().sync_all().map_err(|e| io(e.to_string()))?;
    tmp.persist(path).map_err(|e| io(e.error.to_string()))?;
    Ok(())
}

/// Reads a multi-channel EXR's first part: the beauty (`R`, `G`, `B`, or `Y` as grey) and
/// every `prefix.suffix` channel grouped by prefix. A file without a beauty is an error that
/// says so.
pub fn read_exr(path: &Path) -> Result<Layered, ImageIoError> {
    let io = |message: String| ImageIoError::Io {
        path: path.display().to_string(),
        message,
    };
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| io(format!("not a readable OpenEXR image ({e})")))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let n = w * h;
    let mut rgb: [Option<Vec<f32>>; 3] = [None, None, None];
    let mut groups: Vec<ChannelGroup> = Vec::new();
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        let data = &channel.sample_data;
        if let Some(k) = ["R", "G", "B"].iter().position(|c| *c == name) {
            rgb[k] = Some(data.values_as_f32().collect());
            continue;
        }
        if name == "Y" && rgb.iter().all(Option::is_none) {
            let y: Vec<f32> = data.values_as_f32().collect();
            rgb = [Some(y.clone()), Some(y.clone()), Some(y)];
            continue;
        }
        let Some((prefix, suffix)) = name.rsplit_once('.') else {
            continue;
        };
        let ids = matches!(data, FlatSamples::U32(_));
        let index = match groups.iter().position(|g| g.name == prefix) {
            Some(i) => i,
            None => {
                groups.push(ChannelGroup {
                    name: prefix.to_string(),
                    suffixes: Vec::new(),
                    pixels: if ids {
                        PassPixels::Id(Vec::new())
                    } else {
                        PassPixels::Float(Vec::new())
                    },
                });
                groups.len() - 1
            }
        };
        let g = &mut groups[index];
        g.suffixes.push(suffix.to_string());
        match (&mut g.pixels, data) {
            (PassPixels::Id(v), FlatSamples::U32(d)) => v.extend_from_slice(d),
            (PassPixels::Float(v), d) => v.extend(d.values_as_f32()),
            (PassPixels::Id(v), d) => v.extend(d.values_as_f32().map(|x| x as u32)),
        }
    }
    // Channels were appended one after another: interleave them per pixel, in the order
    // passes list their channels (`X, Y, Z`, `R, G, B`, `U, V`).
    for g in &mut groups {
        let order: Vec<usize> = {
            let known = Aov::ALL
                .into_iter()
                .find(|a| a.name() == g.name)
                .map(|a| a.channels().to_vec())
                .or_else(|| {
                    let rgb = ["R", "G", "B"];
                    g.suffixes
                        .iter()
                        .all(|s| rgb.contains(&s.as_str()))
                        .then(|| rgb.to_vec())
                });
            match known {
                Some(list) if list.len() == g.suffixes.len() => list
                    .iter()
                    .filter_map(|s| g.suffixes.iter().position(|x| x == s))
                    .collect(),
                _ => (0..g.suffixes.len()).collect(),
            }
        };
        let c = g.suffixes.len();
        if order.len() != c {
            continue;
        }
        g.suffixes = order.iter().map(|&i| g.suffixes[i].clone()).collect();
        fn interleave<T: Copy>(v: &[T], order: &[usize], n: usize) -> Vec<T> {
            let mut out = Vec::with_capacity(v.len());
            for p in 0..n {
                for &k in order {
                    out.push(v[k * n + p]);
                }
            }
            out
        }
        g.pixels = match &g.pixels {
            PassPixels::Float(v) => PassPixels::Float(interleave(v, &order, n)),
            PassPixels::Id(v) => PassPixels::Id(interleave(v, &order, n)),
        };
    }
    let [Some(r), Some(g), Some(b)] = rgb else {
        return Err(io(
            "has no R, G, B channels (the beauty of a lumo render is plain R, G, B)".into(),
        ));
    };
    let beauty = Image {
        width: w as u32,
        height: h as u32,
        pixels: (0..n).map(|i| Vec3::new(r[i], g[i], b[i])).collect(),
    };
    Ok(Layered { beauty, groups })
}

/// Where a pass of a PNG or BMP image goes: `OUT.PASS.EXT` beside it (`cornell.albedo.png`).
pub fn sidecar_path(output: &Path, name: &str) -> PathBuf {
    let stem = output.file_stem().unwrap_or_default().to_string_lossy();
    let ext = output.extension().unwrap_or_default().to_string_lossy();
    output.with_file_name(format!("{stem}.{name}.{ext}"))
}

/// A pass mapped to 8-bit colours for a quick look: albedo and standard error in sRGB,
/// clamped; normals as n/2 + ½; depth as grey from near (white) to far (black) over the
/// pass's range; positions over their bounding box; uv as fract(u), fract(v), 0; ids as a
/// colour per id (black for none).
pub fn pass_to_rgb8(pass: &PassImage) -> Vec<[u8; 3]> {
    let to8 = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    let srgb = |x: f32| to8(crate::math::linear_to_srgb(x.max(0.0)));
    match &pass.pixels {
        PassPixels::Id(ids) => ids
            .iter()
            .map(|&id| {
                if id == 0 {
                    return [0, 0, 0];
                }
                let h = crate::sampler::mix64(u64::from(id));
                [
                    (h >> 8) as u8 | 0x30,
                    (h >> 16) as u8 | 0x30,
                    (h >> 24) as u8 | 0x30,
                ]
            })
            .collect(),
        PassPixels::Float(v) => {
            let c = pass.aov.channels().len();
            let px = v.chunks_exact(c);
            match pass.aov {
                Aov::Albedo | Aov::StdError => {
                    px.map(|p| [srgb(p[0]), srgb(p[1]), srgb(p[2])]).collect()
                }
                Aov::Normal => px
                    .map(|p| {
                        [
                            to8(p[0] * 0.5 + 0.5),
                            to8(p[1] * 0.5 + 0.5),
                            to8(p[2] * 0.5 + 0.5),
                        ]
                    })
                    .collect(),
                Aov::Depth => {
                    let (lo, hi) = v
                        .iter()
                        .filter(|d| **d > 0.0)
                        .fold((f32::MAX, 0.0f32), |(lo, hi), &d| (lo.min(d), hi.max(d)));
                    let span = (hi - lo).max(1e-6);
                    px.map(|p| {
                        let g = if p[0] > 0.0 {
                            to8(1.0 - 0.9 * (p[0] - lo) / span)
                        } else {
                            0
                        };
                        [g, g, g]
                    })
                    .collect()
                }
                Aov::Position => {
                    let mut lo = [f32::MAX; 3];
                    let mut hi = [f32::MIN; 3];
                    for p in v.chunks_exact(3) {
                        for k in 0..3 {
                            lo[k] = lo[k].min(p[k]);
                            hi[k] = hi[k].max(p[k]);
                        }
                    }
                    px.map(|p| {
                        std::array::from_fn(|k| to8((p[k] - lo[k]) / (hi[k] - lo[k]).max(1e-6)))
                    })
                    .collect()
                }
                Aov::Uv => px
                    .map(|p| [to8(p[0].rem_euclid(1.0)), to8(p[1].rem_euclid(1.0)), 0])
                    .collect(),
                Aov::ObjectId | Aov::MaterialId => px.map(|_| [0, 0, 0]).collect(),
            }
        }
    }
}

/// Writes a pass as an 8-bit image (PNG or BMP by extension) at `path`, atomically.
pub fn write_pass_rgb8(
    path: &Path,
    width: u32,
    height: u32,
    pass: &PassImage,
) -> Result<(), ImageIoError> {
    let bytes: Vec<u8> = pass_to_rgb8(pass).into_iter().flatten().collect();
    let io = |message: String| ImageIoError::Io {
        path: path.display().to_string(),
        message,
    };
    let img = image::RgbImage::from_raw(width, height, bytes)
        .ok_or_else(|| io("internal error: pass of another size".into()))?;
    let format = crate::output::format_of(path)?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = crate::output::temp_file_in(dir).map_err(|e| io(e.to_string()))?;
    {
        let mut writer = BufWriter::new(tmp.as_file());
        img.write_to(&mut writer, format)
            .map_err(|e| io(e.to_string()))?;
        std::io::Write::flush(&mut writer).map_err(|e| io(e.to_string()))?;
    }
    tmp.persist(path).map_err(|e| io(e.error.to_string()))?;
    Ok(())
}
