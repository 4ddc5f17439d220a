//! Image textures: texels as the file stores them (8-bit, decoded per lookup by a table) or as
//! linear floats, bilinear lookup, wrap modes.

use std::sync::Arc;

use crate::math::{Rgb, Vec2, Vec3};
use glam::Affine2;

/// What a lookup does outside [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// Tile.
    Repeat,
    /// Tile, mirroring every other copy.
    Mirror,
    /// Repeat the edge texels.
    Clamp,
}

/// The texels of an image, row-major, top row first.
#[derive(Debug, Clone)]
pub enum Texels {
    /// Linear floating-point RGB (HDR and EXR files, 16-bit images), with the alpha of each
    /// texel when the image has an alpha channel that is not everywhere 1.
    Float {
        /// Colour.
        rgb: Vec<Rgb>,
        /// Alpha, when not everywhere 1.
        alpha: Option<Vec<f32>>,
    },
    /// 8-bit RGBA as the file stores it (grey images replicated to RGB, alpha 255 where the file
    /// has none). A lookup decodes each colour byte k through `decode` (the sRGB transfer
    /// function's value at k/255, or k/255 itself) and alpha as k/255: the values a decoded float
    /// copy would hold, in a quarter of the memory (a 2048² texture: 16 MiB instead of 48 MiB
    /// plus 16 MiB of alpha), so that bilinear lookups on large textures miss the cache less.
    Rgba8 {
        /// The bytes, shared with the loaded image (one copy whatever the colour space).
        rgba: Arc<[[u8; 4]]>,
        /// Whether alpha is not everywhere 255.
        has_alpha: bool,
        /// Linear value of each colour byte.
        decode: &'static [f32; 256],
    },
}

/// A texture image in linear RGB, rows stored top first.
#[derive(Debug, Clone)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, row-major, top row first.
    pub texels: Texels,
    /// Wrap mode along u.
    pub wrap_s: Wrap,
    /// Wrap mode along v.
    pub wrap_t: Wrap,
}

/// A material's use of a texture: which one, and the affine map applied to the coordinates.
#[derive(Debug, Clone, Copy)]
pub struct TextureRef {
    /// Index into the scene's textures.
    pub texture: u32,
    /// uv' = transform · uv.
    pub transform: Affine2,
    /// Which texture coordinates of the hit: 0 or 1.
    pub tex_coord: u8,
}

impl TextureRef {
    /// The texture coordinates this use samples at a hit with coordinate sets `uv`, `uv1`.
    #[inline]
    pub fn coords(&self, uv: Vec2, uv1: Vec2) -> Vec2 {
        let uv = if self.tex_coord == 1 { uv1 } else { uv };
        self.transform.transform_point2(uv)
    }
}

impl Texture {
    /// A texture of linear float texels without alpha.
    pub fn from_rgb(width: u32, height: u32, rgb: Vec<Rgb>, wrap_s: Wrap, wrap_t: Wrap) -> Texture {
        Texture {
            width,
            height,
            texels: Texels::Float { rgb, alpha: None },
            wrap_s,
            wrap_t,
        }
    }

    /// Every texel, linear RGB, row-major (the float texels themselves, or the decoded bytes).
    pub fn decoded(&self) -> Vec<Rgb> {
        match &self.texels {
            Texels::Float { rgb, .. } => rgb.clone(),
            Texels::Rgba8 { rgba, .. } => (0..rgba.len()).map(|i| self.texel(i)).collect(),
        }
    }

    /// The texel at row-major index `i`, linear RGB.
    #[inline(always)]
    fn texel(&self, i: usize) -> Rgb {
        match &self.texels {
            Texels::Float { rgb, .. } => rgb[i],
            Texels::Rgba8 { rgba, decode, .. } => {
                let [r, g, b, _] = rgba[i];
                Vec3::new(decode[r as usize], decode[g as usize], decode[b as usize])
            }
        }
    }

    #[inline(always)]
    fn wrap_index(wrap: Wrap, i: i64, n: u32) -> usize {
        let n = i64::from(n);
        if (0..n).contains(&i) {
            // Inside the image every mode is the identity (and needs no division).
            return i as usize;
        }
        let k = match wrap {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        };
        k as usize
    }

    /// The four texels around `uv` (row-major indices) and the bilinear weights of the
    /// right column and bottom row; `None` for non-finite coordinates.
    #[inline(always)]
    fn footprint(&self, uv: Vec2) -> Option<([usize; 4], f32, f32)> {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (x0, y0, fx, fy) = if x.abs() < 8_388_608.0 && y.abs() < 8_388_608.0 {
            // The usual case: ⌊·⌋ (as `floor`) through 32-bit integers, without the saturating
            // conversions of the general case. SAFETY: |x|, |y| < 2²³ (neither is NaN).
            let (tx, ty) = unsafe { (x.to_int_unchecked::<i32>(), y.to_int_unchecked::<i32>()) };
            let (x0, y0) = (tx - i32::from(tx as f32 > x), ty - i32::from(ty as f32 > y));
            let (fx, fy) = (x - x0 as f32, y - y0 as f32);
            (i64::from(x0), i64::from(y0), fx, fy)
        } else if uv.is_finite() {
            let (x0, y0) = (floor(x), floor(y));
            (x0 as i64, y0 as i64, x - x0, y - y0)
        } else {
            return None;
        };
        let w = self.width as usize;
        let (ws, wt) = (self.wrap_s, self.wrap_t);
        let (xa, xb) = (
            Self::wrap_index(ws, x0, self.width),
            Self::wrap_index(ws, x0 + 1, self.width),
        );
        let (ya, yb) = (
            Self::wrap_index(wt, y0, self.height),
            Self::wrap_index(wt, y0 + 1, self.height),
        );
        Some(([ya * w + xa, ya * w + xb, yb * w + xa, yb * w + xb], fx, fy))
    }

    /// Bilinear lookup at texture coordinates `uv` ((0, 0) = bottom-left of the image).
    pub fn lookup(&self, uv: Vec2) -> Rgb {
        let Some(([a, b, c, d], fx, fy)) = self.footprint(uv) else {
            return Vec3::ZERO;
        };
        let top = self.texel(a) * (1.0 - fx) + self.texel(b) * fx;
        let bottom = self.texel(c) * (1.0 - fx) + self.texel(d) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Bilinear lookup of the alpha channel (1 for images without one).
    pub fn lookup_alpha(&self, uv: Vec2) -> f32 {
        let alpha = |i: usize| match &self.texels {
            Texels::Float { alpha, .. } => alpha.as_ref().map_or(1.0, |a| a[i]),
            Texels::Rgba8 { rgba, .. } => f32::from(rgba[i][3]) / 255.0,
        };
        let has_alpha = match &self.texels {
            Texels::Float { alpha, .. } => alpha.is_some(),
            Texels::Rgba8 { has_alpha, .. } => *has_alpha,
        };
        if !has_alpha {
            return 1.0;
        }
        let Some(([a, b, c, d], fx, fy)) = self.footprint(uv) else {
            return 0.0;
        };
        let top = alpha(a) * (1.0 - fx) + alpha(b) * fx;
        let bottom = alpha(c) * (1.0 - fx) + alpha(d) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// ⌊x⌋ without a library call (baseline x86-64 has no rounding instruction): truncation, one
/// lower for negative non-integers; the same value as `f32::floor` for every finite `x` (beyond
/// 2²³ every float is an integer and is returned as it is).
#[inline(always)]
fn floor(x: f32) -> f32 {
    if x.abs() >= 8_388_608.0 {
        return x;
    }
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_by_two(wrap: Wrap) -> Texture {
        // Top row: red, green; bottom row: blue, white.
        Texture::from_rgb(2, 2, vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE], wrap, wrap)
    }

    #[test]
    fn alpha_is_bilinear_and_one_without_a_channel() {
        let mut t = two_by_two(Wrap::Clamp);
        assert_eq!(t.lookup_alpha(Vec2::new(0.3, 0.3)), 1.0);
        if let Texels::Float { alpha, .. } = &mut t.texels {
            *alpha = Some(vec![0.0, 1.0, 0.0, 1.0]);
        }
        assert_eq!(t.lookup_alpha(Vec2::new(0.25, 0.75)), 0.0);
        assert!((t.lookup_alpha(Vec2::new(0.5, 0.5)) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn footprints_take_the_floor_of_the_texel_coordinates() {
        // The integer fast path against `f32::floor`, at integers, just off them and far out,
        // on both sides of zero, for each wrap mode.
        for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            let t = Texture::from_rgb(5, 3, vec![Vec3::ONE; 15], wrap, wrap);
            for k in -40_000i32..40_000 {
                let x = k as f32 / 64.0 + [0.0, 1e-6, -1e-6][k.rem_euclid(3) as usize];
                let uv = Vec2::new((x + 0.5) / 5.0, 1.0 - (0.37 * x + 0.5) / 3.0);
                let Some(([a, b, c, d], fx, fy)) = t.footprint(uv) else {
                    panic!("{uv}");
                };
                let (px, py) = (uv.x * 5.0 - 0.5, (1.0 - uv.y) * 3.0 - 0.5);
                let (x0, y0) = (px.floor(), py.floor());
                assert_eq!((fx, fy), (px - x0, py - y0), "{uv}");
                let col = |i: f32| Texture::wrap_index(wrap, i as i64, 5);
                let row = |i: f32| Texture::wrap_index(wrap, i as i64, 3);
                let (xa, xb, ya, yb) = (col(x0), col(x0 + 1.0), row(y0), row(y0 + 1.0));
                assert_eq!(
                    [a, b, c, d],
                    [ya * 5 + xa, ya * 5 + xb, yb * 5 + xa, yb * 5 + xb]
                );
            }
            assert!(t.footprint(Vec2::new(f32::NAN, 0.5)).is_none());
            assert!(t.footprint(Vec2::new(0.5, f32::INFINITY)).is_none());
        }
    }

    #[test]
    fn lookups_are_upright_and_bilinear() {
        let t = two_by_two(Wrap::Clamp);
        assert_eq!(t.lookup(Vec2::new(0.25, 0.75)), Vec3::X); // top-left texel centre
        assert_eq!(t.lookup(Vec2::new(0.25, 0.25)), Vec3::Z); // bottom-left
        let mid = t.lookup(Vec2::new(0.5, 0.75));
        assert!((mid - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
    }

    #[test]
    fn wrap_modes() {
        let r = two_by_two(Wrap::Repeat);
        assert!((r.lookup(Vec2::new(1.25, 0.75)) - Vec3::X).length() < 1e-6);
        let m = two_by_two(Wrap::Mirror);
        assert!((m.lookup(Vec2::new(1.25, 0.75)) - Vec3::Y).length() < 1e-6);
        let c = two_by_two(Wrap::Clamp);
        assert!((c.lookup(Vec2::new(5.0, 0.75)) - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn wrap_modes_apply_per_axis() {
        // Clamp along u, repeat along v: past the right edge stays in the right column, past
        // the top wraps to the bottom row.
        let t = Texture {
            wrap_t: Wrap::Repeat,
            ..two_by_two(Wrap::Clamp)
        };
        assert!((t.lookup(Vec2::new(5.0, 0.75)) - Vec3::Y).length() < 1e-6);
        assert!((t.lookup(Vec2::new(0.25, 1.25)) - Vec3::Z).length() < 1e-6);
        let c = two_by_two(Wrap::Clamp);
        assert!((c.lookup(Vec2::new(0.25, 1.25)) - Vec3::X).length() < 1e-6);
    }

    /// An 8-bit texture looked up through its decode table gives the same bits as the float
    /// texture of the decoded values, colour and alpha, for every wrap mode, inside and outside
    /// [0, 1] (renders do not change with the storage).
    #[test]
    fn byte_texels_look_up_exactly_as_their_decoded_floats() {
        let (w, h) = (7u32, 5u32);
        let mut state = 3u64;
        let mut byte = || (crate::sampler::test_lcg(&mut state) * 256.0) as u8;
        let rgba: Vec<[u8; 4]> = (0..w * h)
            .map(|_| [byte(), byte(), byte(), byte()])
            .collect();
        for decode in [crate::math::srgb8_table(), crate::math::unorm8_table()] {
            for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp] {
                let bytes = Texture {
                    width: w,
                    height: h,
                    texels: Texels::Rgba8 {
                        rgba: rgba.clone().into(),
                        has_alpha: true,
                        decode,
                    },
                    wrap_s: wrap,
                    wrap_t: wrap,
                };
                let floats = Texture {
                    texels: Texels::Float {
                        rgb: rgba
                            .iter()
                            .map(|t| {
                                Vec3::new(
                                    decode[t[0] as usize],
                                    decode[t[1] as usize],
                                    decode[t[2] as usize],
                                )
                            })
                            .collect(),
                        alpha: Some(rgba.iter().map(|t| f32::from(t[3]) / 255.0).collect()),
                    },
                    ..bytes.clone()
                };
                for i in 0..2000 {
                    let uv = Vec2::new(
                        crate::sampler::test_lcg(&mut state) * 5.0 - 2.0,
                        crate::sampler::test_lcg(&mut state) * 5.0 - 2.0,
                    );
                    let (a, b) = (bytes.lookup(uv), floats.lookup(uv));
                    assert_eq!(
                        a.to_array().map(f32::to_bits),
                        b.to_array().map(f32::to_bits),
                        "lookup {i} at {uv}"
                    );
                    assert_eq!(
                        bytes.lookup_alpha(uv).to_bits(),
                        floats.lookup_alpha(uv).to_bits()
                    );
                }
            }
        }
    }

    /// The library-free floor is `f32::floor` on integers, halves, tiny and huge values.
    #[test]
    fn floor_is_the_floor() {
        let mut state = 9u64;
        let mut xs = vec![
            0.0,
            -0.5,
            0.5,
            -1.0,
            1.0,
            1e-30,
            -1e-30,
            8_388_607.5,
            -8_388_607.5,
            1e20,
            -1e20,
        ];
        xs.extend((0..10_000).map(|_| (crate::sampler::test_lcg(&mut state) - 0.5) * 4096.0));
        for x in xs {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
    }
}
