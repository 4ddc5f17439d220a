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

use crate::aov::{Aov, AovSample, AovSet, AovSums, PassImage, PassPixels};
use crate::image::{Image, REL_EPSILON};
use crate::math::Vec3;

/// Largest sample magnitude (exclusive) a film accumulates; larger ones are dropped and counted.
pub const MAX_SAMPLE: f64 = 4_294_967_296.0;
/// 2⁶⁴: fixed-point scale of the sums.
const SUM_SCALE: f64 = 18_446_744_073_709_551_616.0;

/// 2³²: fixed-point scale of the sums of squares.
const SQ_SCALE: f64 = 4_294_967_296.0;

/// The fixed-point terms of a sample channel given as f32 bits `bits` (finite, below
/// [`MAX_SAMPLE`]): x · 2⁶⁴ and x² · 2³² rounded half away from zero to integers (the sums'
/// units, [`SUM_SCALE`] and [`SQ_SCALE`]), computed on integers. With x = ±m · 2^(e − 150) (m the
/// 24-bit significand, e the biased exponent, 1 for subnormals), x · 2⁶⁴ = ±m · 2^(e − 86) and
/// x² · 2³² = m² · 2^(2e − 268), m² < 2⁴⁸ exact in a u64; a negative power is a right shift
/// rounding half away from zero. The same integers as rounding the (exact) f64 products, with
/// shifts instead of float ↔ integer conversions, whose latency made the film 6.7 % of a
/// GlassVaseFlowers render's time; this way its renders are 4–5 % faster.
#[inline(always)]
fn fixed_point_f32(bits: u32) -> (i128, i128) {
    let exp = ((bits >> 23) & 0xff) as i32;
    let m = if exp == 0 {
        bits & 0x7f_ffff
    } else {
        (bits & 0x7f_ffff) | 0x80_0000
    };
    let e = exp.max(1);
    // Right shift by k ≥ 1, half away from zero; 0 once 2^(k − 1) exceeds every v < 2⁴⁸.
    let round_shift = |v: u64, k: i32| -> i128 {
        if k > 48 {
            0
        } else {
            i128::from((v + (1u64 << (k - 1))) >> k)
        }
    };
    let s = e - 86;
    let sum = if s >= 0 {
        i128::from(m) << s
    } else {
        round_shift(u64::from(m), -s)
    };
    let m2 = u64::from(m) * u64::from(m);
    let q = 2 * e - 268;
    let sum_sq = if q >= 0 {
        i128::from(m2) << q
    } else {
        round_shift(m2, -q)
    };
    (if bits >> 31 != 0 { -sum } else { sum }, sum_sq)
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

    /// Adds one sample; one with a NaN, infinite or too large channel (≥ [`MAX_SAMPLE`]) is
    /// counted and dropped.
    #[inline]
    pub(super) fn add_sample(&mut self, value: Vec3) {
        let bits = value.to_array().map(f32::to_bits);
        // Finite and below MAX_SAMPLE (2³²): a biased exponent below 127 + 32.
        if bits.iter().all(|b| (b >> 23) & 0xff < 159) {
            for (k, b) in bits.into_iter().enumerate() {
                let (sum, sum_sq) = fixed_point_f32(b);
                self.sum[k] += sum;
                self.sum_sq[k] += sum_sq;
            }
            self.good += 1;
        } else {
            self.bad += 1;
        }
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

/// Where the render loop puts finished samples: the beauty's sums of a run of pixels and, when
/// render passes are asked for, theirs.
pub(crate) struct Sink<'a> {
    /// The beauty's sums.
    pub beauty: &'a mut [PixelSum],
    /// The passes' sums, of as many pixels.
    pub aov: Option<&'a mut AovSums>,
}

impl Sink<'_> {
    /// Whether the paths are to record render passes.
    pub fn wants_aovs(&self) -> bool {
        self.aov.is_some()
    }

    /// Adds sample number `index` of pixel `pixel`: its radiance, and what it saw for the
    /// passes (all zero when it recorded nothing: ray-cast previews, depth 0).
    #[inline]
    pub fn add(&mut self, pixel: usize, index: u32, value: Vec3, aov: Option<&AovSample>) {
        self.beauty[pixel].add_sample(value);
        if let Some(sums) = &mut self.aov {
            sums.add(pixel, index, aov.unwrap_or(&AovSample::default()));
        }
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
    /// The render passes' sums ([`crate::aov`]), when passes are asked for.
    aov: Option<AovSums>,
}

impl Film {
    /// A film of `width` × `height` pixels with the given sums, or `None` when their number
    /// is not width × height.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<PixelSum>) -> Option<Film> {
        (pixels.len() as u64 == u64::from(width) * u64::from(height)).then_some(Film {
            width,
            height,
            pixels,
            aov: None,
        })
    }

    /// The film with these pass sums (of as many pixels), or `None` when their size differs.
    pub fn with_aov_sums(mut self, aov: Option<AovSums>) -> Option<Film> {
        if let Some(a) = &aov {
            if AovSums::new(a.set(), self.pixels.len()).sums().len() != a.sums().len() {
                return None;
            }
        }
        self.aov = aov;
        Some(self)
    }

    /// A film without samples that also sums the render passes `set` (those that need
    /// per-sample records; none when `set` holds none of them).
    pub fn with_aovs(width: u32, height: u32, set: AovSet) -> Film {
        let mut film = Film::new(width, height);
        if set.needs_samples() {
            film.aov = Some(AovSums::new(set.recorded(), film.pixels.len()));
        }
        film
    }

    /// The render passes summed in this film ([`AovSet::NONE`] when none).
    pub fn aov_set(&self) -> AovSet {
        self.aov.as_ref().map_or(AovSet::NONE, AovSums::set)
    }

    /// The render passes' sums, if any.
    pub fn aov_sums(&self) -> Option<&AovSums> {
        self.aov.as_ref()
    }

    /// The sums of pixel (x, y) of the beauty and of the passes, to fill in.
    pub(crate) fn sums_mut(&mut self) -> (&mut [PixelSum], Option<&mut AovSums>) {
        (&mut self.pixels, self.aov.as_mut())
    }

    /// Adds pixel (ox, oy) of `other` (with the same passes) into pixel (x, y).
    pub fn merge_pixel_from(&mut self, (x, y): (u32, u32), other: &Film, (ox, oy): (u32, u32)) {
        let to = (y * self.width + x) as usize;
        let from = (oy * other.width + ox) as usize;
        self.pixels[to].merge(&other.pixels[from]);
        if let (Some(a), Some(b)) = (&mut self.aov, &other.aov) {
            a.merge_pixel(to, b, from);
        }
    }

    /// The render passes `set` as images of the film's pixels (those of `set` the film holds,
    /// and `std_error`, which every film can give), in [`Aov::ALL`]'s order.
    pub fn passes(&self, set: AovSet) -> Vec<PassImage> {
        let mut out = Vec::new();
        for aov in set.iter() {
            let pixels = match (aov, &self.aov) {
                (Aov::StdError, _) => {
                    out.push(PassImage::std_error(&self.std_error()));
                    continue;
                }
                (Aov::ObjectId | Aov::MaterialId, Some(a)) if a.set().contains(aov) => {
                    PassPixels::Id(
                        a.ids()
                            .iter()
                            .map(|r| {
                                if aov == Aov::ObjectId {
                                    r.object
                                } else {
                                    r.material
                                }
                            })
                            .collect(),
                    )
                }
                (_, Some(a)) => {
                    let Some(offset) = a.set().offset(aov) else {
                        continue;
                    };
                    let n = aov.channels().len();
                    let mut values = Vec::with_capacity(self.pixels.len() * n);
                    for (i, p) in self.pixels.iter().enumerate() {
                        for k in 0..n {
                            values.push(a.mean(i, offset + k, p.taken()));
                        }
                    }
                    PassPixels::Float(values)
                }
                (_, None) => continue,
            };
            out.push(PassImage { aov, pixels });
        }
        out
    }

    /// A film without samples.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelSum::default(); (width * height) as usize],
            aov: None,
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
        if let (Some(a), Some(b)) = (&mut self.aov, &other.aov) {
            for i in 0..self.pixels.len() {
                a.merge_pixel(i, b, i);
            }
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
    use super::{fixed_point_f32, PixelSum, MAX_SAMPLE, SQ_SCALE, SUM_SCALE};
    use crate::math::Vec3;

    /// The film's fixed-point terms are the f64 products rounded half away from zero
    /// (`f64::round`), exactly: every exponent (subnormals, the smallest normals, the tiny values
    /// whose terms round to 0 or 1, up to just below `MAX_SAMPLE`), both signs, random and
    /// extreme significands; and whole samples keep or drop as the bound says (NaN, ±∞ and
    /// 2³² dropped).
    #[test]
    fn fixed_point_terms_are_the_rounded_products() {
        let mut state = 7u64;
        let mut values = vec![
            0.0f32,
            -0.0,
            f32::MIN_POSITIVE,
            1e-45,
            0.5,
            1.0,
            4294967040.0,
        ];
        for exp in 0..159u32 {
            for _ in 0..400 {
                state = crate::sampler::mix64(state);
                let mantissa = match state % 4 {
                    0 => 0,
                    1 => 0x7f_ffff,
                    _ => (state >> 20) as u32 & 0x7f_ffff,
                };
                let sign = ((state >> 8) & 1) as u32;
                values.push(f32::from_bits(sign << 31 | exp << 23 | mantissa));
            }
        }
        for &x in &values {
            let v = f64::from(x);
            assert!(v.abs() < MAX_SAMPLE);
            let want = (
                (v * SUM_SCALE).round() as i128,
                (v * v * SQ_SCALE).round() as i128,
            );
            assert_eq!(fixed_point_f32(x.to_bits()), want, "{x:e}");
        }
        for (x, kept) in [
            (f32::NAN, false),
            (f32::INFINITY, false),
            (-f32::INFINITY, false),
            (4294967296.0, false),
            (-4294967296.0, false),
            (4294967040.0, true),
            (-1e-40, true),
        ] {
            let mut sum = PixelSum::default();
            sum.add_sample(Vec3::new(0.25, x, 1.0));
            assert_eq!(
                (sum.good, sum.bad),
                (u32::from(kept), u32::from(!kept)),
                "{x}"
            );
        }
    }
}
