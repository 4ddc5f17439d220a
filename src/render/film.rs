//! The film: per-pixel running sums of samples (sum, sum of squares, finite and dropped counts,
//! wall time), merged pass by pass; and what they give: the image, the error image and the
//! image's estimated error.
//!
//! Everything a render keeps about its samples lives here, so a film can be merged with another
//! one of the same size: a pass into the total, a checkpoint into a resumed render, partial films
//! rendered elsewhere (`lumo merge`).
//!
//! **Exact sums.** Floating-point addition is not associative, so f64 running sums would depend
//! on how samples were grouped (passes, checkpoints, sample ranges on other machines). Each
//! sample is therefore rounded once to fixed point and summed in integers, which is exact and
//! associative: any partition of the samples, merged in any order, gives the same bits as one
//! uninterrupted render. Sums are i128 with 64 fractional bits (resolution 5.4·10⁻²⁰, range
//! ±9.2·10¹⁸), squares i128 with 32 fractional bits (2.3·10⁻¹⁰, ±4·10²⁸). A sample with a
//! channel of magnitude ≥ [`MAX_SAMPLE`] (2³², 4.3·10⁹) is dropped like a NaN and counted, so that
//! up to 2³¹ samples per pixel can never overflow either sum.

use std::time::Duration;

use glam::DVec3;

use crate::image::{Image, REL_EPSILON};
use crate::math::Vec3;

/// Largest sample magnitude (exclusive) a film accumulates; larger ones are dropped and counted.
pub const MAX_SAMPLE: f64 = 4_294_967_296.0;
/// 2⁶⁴: fixed-point scale of the sums.
const SUM_SCALE: f64 = 18_446_744_073_709_551_616.0;
/// 2³²: fixed-point scale of the sums of squares.
const SQ_SCALE: f64 = 4_294_967_296.0;

/// `x.round() as i128` (rounding half away from zero) for |x| < 2¹²⁷, without the two library
/// calls that compiles to on baseline x86-64 (`round`, and `__fixdfti` for the conversion),
/// which cost a few per cent of a render's time at six per sample. A float of magnitude ≥ 2⁵² is
/// an integer, its mantissa shifted by its exponent; below that, truncation through i64 and the
/// exact remainder x − trunc(x) decide the rounding.
#[inline]
fn round_to_i128(x: f64) -> i128 {
    let bits = x.to_bits();
    // x = ±m · 2^shift with m the 53-bit significand (for normal x).
    let shift = ((bits >> 52) & 0x7ff) as i32 - 1075;
    if shift >= 0 {
        let m = (bits & ((1 << 52) - 1)) | (1 << 52);
        let v = i128::from(m) << shift;
        if x < 0.0 {
            -v
        } else {
            v
        }
    } else {
        // |x| < 2⁵³: the truncation and the remainder are exact.
        let t = x as i64;
        let r = x - t as f64;
        i128::from(if r >= 0.5 {
            t + 1
        } else if r <= -0.5 {
            t - 1
        } else {
            t
        })
    }
}

/// Running sums of one pixel's samples, exact (see the module doc).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PixelSum {
    /// Σ v per channel, in units of 2⁻⁶⁴.
    pub(crate) sum: [i128; 3],
    /// Σ v² per channel, in units of 2⁻³².
    pub(crate) sum_sq: [i128; 3],
    /// Finite samples (the ones in the sums).
    pub(crate) good: u32,
    /// Samples that were NaN, infinite or too large and dropped.
    pub(crate) bad: u32,
    /// Wall time these samples took, in nanoseconds: the cost model of time-budgeted adaptive
    /// passes (a render against the clock is not reproducible anyway). Not part of equality
    /// of what was rendered, and not saved in partial films.
    pub(crate) nanos: u64,
}

impl PixelSum {
    /// Adds one sample; a NaN or infinite one is counted and dropped.
    pub(super) fn add_sample(&mut self, value: DVec3) {
        if value.is_finite() && value.abs().max_element() < MAX_SAMPLE {
            for k in 0..3 {
                // Exact: scaling by a power of two, then one rounding to an integer (|·| < 2⁹⁶
                // and < 2⁹⁶ respectively, exactly representable as i128).
                self.sum[k] += round_to_i128(value[k] * SUM_SCALE);
                self.sum_sq[k] += round_to_i128(value[k] * value[k] * SQ_SCALE);
            }
            self.good += 1;
        } else {
            self.bad += 1;
        }
    }

    /// Σ v per channel, as f64 (one rounding).
    fn sum_f64(&self) -> DVec3 {
        DVec3::new(
            self.sum[0] as f64 / SUM_SCALE,
            self.sum[1] as f64 / SUM_SCALE,
            self.sum[2] as f64 / SUM_SCALE,
        )
    }

    /// Σ v² per channel, as f64 (one rounding).
    fn sum_sq_f64(&self) -> DVec3 {
        DVec3::new(
            self.sum_sq[0] as f64 / SQ_SCALE,
            self.sum_sq[1] as f64 / SQ_SCALE,
            self.sum_sq[2] as f64 / SQ_SCALE,
        )
    }

    /// Records the wall time the samples took.
    pub(super) fn set_time(&mut self, time: Duration) {
        self.nanos = time.as_nanos() as u64;
    }

    /// Adds another set of samples of the same pixel.
    pub fn merge(&mut self, other: &PixelSum) {
        for k in 0..3 {
            self.sum[k] += other.sum[k];
            self.sum_sq[k] += other.sum_sq[k];
        }
        self.good += other.good;
        self.bad += other.bad;
        self.nanos += other.nanos;
    }

    /// Samples taken, finite or not.
    pub fn taken(&self) -> u32 {
        self.good + self.bad
    }

    /// Finite samples taken (the ones the mean averages).
    #[cfg(test)]
    pub(super) fn finite_samples(&self) -> u32 {
        self.good
    }

    /// Sum of the finite samples.
    #[cfg(test)]
    pub(super) fn sum(&self) -> DVec3 {
        self.sum_f64()
    }

    /// Wall time per sample in nanoseconds, if these samples were timed.
    pub(super) fn nanos_per_sample(&self) -> Option<f64> {
        (self.taken() > 0 && self.nanos > 0).then(|| self.nanos as f64 / f64::from(self.taken()))
    }

    /// Mean of the finite samples (zero without any).
    pub(super) fn mean(&self) -> DVec3 {
        if self.good == 0 {
            DVec3::ZERO
        } else {
            self.sum_f64() / f64::from(self.good)
        }
    }

    /// Variance of the mean, per channel (∞ with fewer than two samples).
    pub(super) fn var_of_mean(&self) -> DVec3 {
        self.var_of_mean_and_mean().0
    }

    /// [`var_of_mean`](Self::var_of_mean) and [`mean`](Self::mean) from one conversion of the
    /// sums (an i128 → f64 conversion is a library call).
    fn var_of_mean_and_mean(&self) -> (DVec3, DVec3) {
        if self.good == 0 {
            return (DVec3::splat(f64::INFINITY), DVec3::ZERO);
        }
        let n = f64::from(self.good);
        let m = self.sum_f64() / n;
        if self.good < 2 {
            return (DVec3::splat(f64::INFINITY), m);
        }
        let var = ((self.sum_sq_f64() - m * m * n) / (n - 1.0)).max(DVec3::ZERO) / n;
        (var, m)
    }

    /// Relative variance of one sample, Σ var / (m² + ε) over channels / 3 (∞ with fewer
    /// than two samples): the aᵢ of the adaptive allocation.
    pub(super) fn rel_var_per_sample(&self) -> f64 {
        self.rel_var() * f64::from(self.good)
    }

    /// Relative variance of the mean: Σ var / (m² + ε) over channels / 3.
    pub(super) fn rel_var(&self) -> f64 {
        let (var, m) = self.var_of_mean_and_mean();
        Self::relative(var, m)
    }

    fn relative(var: DVec3, m: DVec3) -> f64 {
        (var / (m * m + DVec3::splat(REL_EPSILON))).element_sum() / 3.0
    }
}

/// The image's error as predicted from the per-pixel sample variances.
#[derive(Debug, Clone, Copy)]
pub struct ErrorEstimate {
    /// Estimated root-mean-square error over pixels and channels.
    pub rmse: f64,
    /// √(estimated relative MSE), the figure error targets are checked against.
    pub rel_error: f64,
}

/// The running sums of every pixel of an image (or of a window of it), row-major, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Film {
    width: u32,
    height: u32,
    pixels: Vec<PixelSum>,
}

impl Film {
    /// A film of `width` × `height` pixels with the given sums, or `None` when their number
    /// is not width × height.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<PixelSum>) -> Option<Film> {
        (pixels.len() as u64 == u64::from(width) * u64::from(height)).then_some(Film {
            width,
            height,
            pixels,
        })
    }

    /// A film without samples.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelSum::default(); (width * height) as usize],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels' sums, row-major, top row first.
    pub fn pixels(&self) -> &[PixelSum] {
        &self.pixels
    }

    /// The sums of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> &PixelSum {
        &self.pixels[(y * self.width + x) as usize]
    }

    /// The sums of pixel (x, y), to fill in.
    pub(crate) fn pixel_mut(&mut self, x: u32, y: u32) -> &mut PixelSum {
        &mut self.pixels[(y * self.width + x) as usize]
    }

    /// Adds the samples of another film of the same size (one pass's, for instance).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "films differ in size"
        );
        for (p, add) in self.pixels.iter_mut().zip(&other.pixels) {
            p.merge(add);
        }
    }

    /// Samples taken over all pixels, finite or not.
    pub fn samples_taken(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.taken())).sum()
    }

    /// Samples dropped as NaN or infinite over all pixels.
    pub fn dropped_samples(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.bad)).sum()
    }

    /// Samples taken per pixel, row-major, top row first.
    pub fn counts(&self) -> Vec<u32> {
        self.pixels.iter().map(PixelSum::taken).collect()
    }

    /// Mean radiance per pixel.
    pub fn image(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|p| p.mean().as_vec3()).collect(),
        }
    }

    /// Standard error of each pixel's mean, per channel (zero with fewer than two samples).
    pub fn std_error(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: self
                .pixels
                .iter()
                .map(|p| {
                    let v = p.var_of_mean();
                    if v.is_finite() {
                        v.map(f64::sqrt).as_vec3()
                    } else {
                        Vec3::ZERO
                    }
                })
                .collect(),
        }
    }

    /// The image's estimated error from its per-pixel variances.
    pub fn estimate(&self) -> ErrorEstimate {
        let n = self.pixels.len() as f64;
        // One pass, each pixel's sums converted once; the two sums add in pixel order.
        let (mut mse, mut rel) = (0.0f64, 0.0f64);
        for p in &self.pixels {
            let (var, m) = p.var_of_mean_and_mean();
            mse += var.element_sum() / 3.0;
            rel += PixelSum::relative(var, m);
        }
        let (mse, rel) = (mse / n, rel / n);
        ErrorEstimate {
            rmse: mse.sqrt(),
            rel_error: rel.sqrt(),
        }
    }
}

#[cfg(test)]
mod rounding_tests {
    use super::round_to_i128;

    /// The film's rounding is `round() as i128` on halves, integers, both sides of 2⁵², tiny,
    /// zero and the largest magnitudes a film accepts.
    #[test]
    fn round_to_i128_is_round_then_convert() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            0.49999999999999994,
            -0.49999999999999994,
            4503599627370495.5,
            -4503599627370495.5,
            4503599627370496.0,
            9007199254740993.0,
            f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            (super::MAX_SAMPLE - 1.0) * super::SUM_SCALE,
            -(super::MAX_SAMPLE - 1.0) * super::SUM_SCALE,
        ];
        let mut state = 1u64;
        for _ in 0..200_000 {
            state = crate::sampler::mix64(state);
            // Magnitudes from 2⁻⁴⁰ to 2⁹⁶ in every binade, both signs.
            let e = (state % 137) as i32 - 40;
            let m = (state >> 11) as f64 / (1u64 << 53) as f64 + 0.5;
            let s = if state & 1 == 0 { 1.0 } else { -1.0 };
            xs.push(s * m * 2f64.powi(e));
        }
        for x in xs {
            assert_eq!(round_to_i128(x), x.round() as i128, "{x:e}");
        }
    }
}
