//! Writing images: the format follows the file extension; files are written to a temporary file
//! beside the target and renamed into place, so a failed or interrupted write never leaves a
//! half-written image where a good one was.

use std::io::BufWriter;
use std::path::Path;

use image::{ImageFormat, Rgb32FImage, RgbImage};

use crate::image::Image;
use crate::math::linear_to_srgb;

/// How linear radiance becomes 8-bit colour for PNG and BMP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ToneMap {
    /// Clamp to [0, 1] (default).
    #[default]
    Clamp,
    /// The ACES filmic curve fitted by Narkowicz (2015).
    Aces,
}

lumo_schema::keyword_enum!(ToneMap, "clamp" => ToneMap::Clamp, "aces" => ToneMap::Aces);

/// Why an image could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ImageIoError {
    /// Unknown extension.
    #[error("{path}: unsupported image format `{ext}` (use .png, .exr, .hdr or .bmp)")]
    Format {
        /// The path.
        path: String,
        /// Its extension.
        ext: String,
    },
    /// I/O or encoding failure.
    #[error("{path}: {message}")]
    Io {
        /// The path.
        path: String,
        /// What failed.
        message: String,
    },
}

fn aces(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

/// The output format for a path, by extension.
pub fn format_of(path: &Path) -> Result<ImageFormat, ImageIoError> {
    let ext = lumo_schema::geometry::paths::lowercase_extension(path);
    match ext.as_str() {
        "png" => Ok(ImageFormat::Png),
        "exr" => Ok(ImageFormat::OpenExr),
        "hdr" => Ok(ImageFormat::Hdr),
        "bmp" => Ok(ImageFormat::Bmp),
        _ => Err(ImageIoError::Format {
            path: path.display().to_string(),
            ext,
        }),
    }
}

/// Writes `img` to `path` atomically. PNG and BMP get 8-bit sRGB after tone mapping; EXR and HDR
/// keep linear floats untouched.
pub fn write_image(img: &Image, path: &Path, tone: ToneMap) -> Result<(), ImageIoError> {
    let format = format_of(path)?;
    let io = |message: String| ImageIoError::Io {
        path: path.display().to_string(),
        message,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp = temp_file_in(dir).map_err(|e| {
        io(format!(
            "cannot create a temporary file in {}: {e}",
            dir.display()
        ))
    })?;
    {
        let mut writer = BufWriter::new(tmp.as_file_mut());
        match format {
            ImageFormat::Png | ImageFormat::Bmp => {
                let map = |v: f32| -> u8 {
                    let v = match tone {
                        ToneMap::Clamp => v,
                        ToneMap::Aces => aces(v),
                    };
                    (linear_to_srgb(v) * 255.0 + 0.5) as u8
                };
                let buf = RgbImage::from_fn(img.width, img.height, |x, y| {
                    let p = img.pixels[(y * img.width + x) as usize];
                    image::Rgb([map(p.x), map(p.y), map(p.z)])
                });
                buf.write_to(&mut writer, format)
                    .map_err(|e| io(e.to_string()))?;
            }
            _ => {
                let buf = Rgb32FImage::from_fn(img.width, img.height, |x, y| {
                    let p = img.pixels[(y * img.width + x) as usize];
                    image::Rgb([p.x, p.y, p.z])
                });
                buf.write_to(&mut writer, format)
                    .map_err(|e| io(e.to_string()))?;
            }
        }
        std::io::Write::flush(&mut writer).map_err(|e| io(e.to_string()))?;
    }
    tmp.as_file().sync_all().map_err(|e| io(e.to_string()))?;
    tmp.persist(path).map_err(|e| {
        io(format!(
            "cannot move the finished image into place: {}",
            e.error
        ))
    })?;
    Ok(())
}

/// Reads a linear float image (EXR or HDR; 8-bit formats are decoded from sRGB).
pub fn read_image(path: &Path) -> Result<Image, ImageIoError> {
    let io = |message: String| ImageIoError::Io {
        path: path.display().to_string(),
        message,
    };
    let dynimg = image::open(path).map_err(|e| io(e.to_string()))?;
    let linear = matches!(
        dynimg,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    );
    let rgb = dynimg.to_rgb32f();
    let pixels = rgb
        .pixels()
        .map(|p| {
            let c = glam::Vec3::new(p[0], p[1], p[2]);
            if linear {
                c
            } else {
                c.map(crate::math::srgb_to_linear)
            }
        })
        .collect();
    Ok(Image {
        width: rgb.width(),
        height: rgb.height(),
        pixels,
    })
}

/// A temporary file in `dir` for an atomic write (named `.lumo-*.tmp`, renamed over the target
/// once complete), readable by everyone like a file written directly (0644 on Unix).
pub fn temp_file_in(dir: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".lumo-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    builder.tempfile_in(dir)
}
