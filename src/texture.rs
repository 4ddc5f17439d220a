//! Image textures: linear float texels, bilinear lookup, wrap modes.

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

/// A texture image in linear RGB, rows stored top first.
#[derive(Debug, Clone)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, row-major, top row first.
    pub texels: Vec<Rgb>,
    /// Alpha of each texel (same layout), when the image has an alpha channel; 1 otherwise.
    pub alpha: Option<Vec<f32>>,
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
    fn wrap_index(wrap: Wrap, i: i64, n: u32) -> usize {
        let n = i64::from(n);
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
    fn footprint(&self, uv: Vec2) -> Option<([usize; 4], f32, f32)> {
        if !uv.is_finite() {
            return None;
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
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
        let t = &self.texels;
        let top = t[a] * (1.0 - fx) + t[b] * fx;
        let bottom = t[c] * (1.0 - fx) + t[d] * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Bilinear lookup of the alpha channel (1 for images without one).
    pub fn lookup_alpha(&self, uv: Vec2) -> f32 {
        let Some(alpha) = &self.alpha else {
            return 1.0;
        };
        let Some(([a, b, c, d], fx, fy)) = self.footprint(uv) else {
            return 0.0;
        };
        let top = alpha[a] * (1.0 - fx) + alpha[b] * fx;
        let bottom = alpha[c] * (1.0 - fx) + alpha[d] * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_by_two(wrap: Wrap) -> Texture {
        // Top row: red, green; bottom row: blue, white.
        Texture {
            width: 2,
            height: 2,
            texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
            alpha: None,
            wrap_s: wrap,
            wrap_t: wrap,
        }
    }

    #[test]
    fn alpha_is_bilinear_and_one_without_a_channel() {
        let mut t = two_by_two(Wrap::Clamp);
        assert_eq!(t.lookup_alpha(Vec2::new(0.3, 0.3)), 1.0);
        t.alpha = Some(vec![0.0, 1.0, 0.0, 1.0]);
        assert_eq!(t.lookup_alpha(Vec2::new(0.25, 0.75)), 0.0);
        assert!((t.lookup_alpha(Vec2::new(0.5, 0.5)) - 0.5).abs() < 1e-6);
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
}
