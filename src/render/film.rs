//! The film: per-pixel running sums of samples (sum, sum of squares, finite and dropped counts,
//! wall time), merged pass by pass; and what they give: the image, the error image and the
//! image's estimated error.
//!
//! Everything a render keeps about its samples lives here, so a film can be merged with another
//! one of the same size (a pass into the total today; later, films rendered elsewhere).

use std::time::Duration;

use glam::DVec3;

use crate::image::{Image, REL_EPSILON};
use crate::math::Vec3;

/// Running sums of one pixel's samples.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PixelSum {
    sum: DVec3,
    sum_sq: DVec3,
    /// Finite samples (the ones in the sums).
    good: u32,
    /// Samples that were NaN or infinite and dropped.
    bad: u32,
    /// Wall time these samples took, in nanoseconds: the cost model of time-budgeted adaptive
    /// passes (a render against the clock is not reproducible anyway).
    nanos: u64,
}

impl PixelSum {
    /// Adds one sample; a NaN or infinite one is counted and dropped.
    pub(super) fn add_sample(&mut self, value: DVec3) {
        if value.is_finite() {
            self.sum += value;
            self.sum_sq += value * value;
            self.good += 1;
        } else {
            self.bad += 1;
        }
    }

    /// Records the wall time the samples took.
    pub(super) fn set_time(&mut self, time: Duration) {
        self.nanos = time.as_nanos() as u64;
    }

    /// Adds another set of samples of the same pixel.
    pub(super) fn merge(&mut self, other: &PixelSum) {
        self.sum += other.sum;
        self.sum_sq += other.sum_sq;
        self.good += other.good;
        self.bad += other.bad;
        self.nanos += other.nanos;
    }

    /// Samples taken, finite or not.
    pub(super) fn taken(&self) -> u32 {
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
        self.sum
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
            self.sum / f64::from(self.good)
        }
    }

    /// Variance of the mean, per channel (∞ with fewer than two samples).
    pub(super) fn var_of_mean(&self) -> DVec3 {
        if self.good < 2 {
            return DVec3::splat(f64::INFINITY);
        }
        let n = f64::from(self.good);
        let m = self.sum / n;
        ((self.sum_sq - m * m * n) / (n - 1.0)).max(DVec3::ZERO) / n
    }

    /// Relative variance of one sample, Σ var / (m² + ε) over channels / 3 (∞ with fewer
    /// than two samples): the aᵢ of the adaptive allocation.
    pub(super) fn rel_var_per_sample(&self) -> f64 {
        self.rel_var() * f64::from(self.good)
    }

    /// Relative variance of the mean: Σ var / (m² + ε) over channels / 3.
    pub(super) fn rel_var(&self) -> f64 {
        let m = self.mean();
        (self.var_of_mean() / (m * m + DVec3::splat(REL_EPSILON))).element_sum() / 3.0
    }
}

/// The image's error as predicted from the per-pixel sample variances.
#[derive(Debug, Clone, Copy)]
pub(super) struct ErrorEstimate {
    /// Estimated root-mean-square error over pixels and channels.
    pub(super) rmse: f64,
    /// √(estimated relative MSE), the figure error targets are checked against.
    pub(super) rel_error: f64,
}

/// The running sums of every pixel of an image, row-major, top row first.
#[derive(Debug, Clone)]
pub(super) struct Film {
    width: u32,
    height: u32,
    pixels: Vec<PixelSum>,
}

impl Film {
    /// A film without samples.
    pub(super) fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelSum::default(); (width * height) as usize],
        }
    }

    /// Width in pixels.
    pub(super) fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub(super) fn height(&self) -> u32 {
        self.height
    }

    /// The pixels' sums, row-major, top row first.
    pub(super) fn pixels(&self) -> &[PixelSum] {
        &self.pixels
    }

    /// The sums of pixel (x, y).
    pub(super) fn pixel(&self, x: u32, y: u32) -> &PixelSum {
        &self.pixels[(y * self.width + x) as usize]
    }

    /// The sums of pixel (x, y), to fill in.
    pub(super) fn pixel_mut(&mut self, x: u32, y: u32) -> &mut PixelSum {
        &mut self.pixels[(y * self.width + x) as usize]
    }

    /// Adds the samples of another film of the same size (one pass's, for instance).
    pub(super) fn merge(&mut self, other: &Film) {
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
    pub(super) fn samples_taken(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.taken())).sum()
    }

    /// Samples dropped as NaN or infinite over all pixels.
    pub(super) fn dropped_samples(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.bad)).sum()
    }

    /// Samples taken per pixel, row-major, top row first.
    pub(super) fn counts(&self) -> Vec<u32> {
        self.pixels.iter().map(PixelSum::taken).collect()
    }

    /// Mean radiance per pixel.
    pub(super) fn image(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|p| p.mean().as_vec3()).collect(),
        }
    }

    /// Standard error of each pixel's mean, per channel (zero with fewer than two samples).
    pub(super) fn std_error(&self) -> Image {
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
    pub(super) fn estimate(&self) -> ErrorEstimate {
        let n = self.pixels.len() as f64;
        let mse = self
            .pixels
            .iter()
            .map(|p| p.var_of_mean().element_sum() / 3.0)
            .sum::<f64>()
            / n;
        let rel = self.pixels.iter().map(PixelSum::rel_var).sum::<f64>() / n;
        ErrorEstimate {
            rmse: mse.sqrt(),
            rel_error: rel.sqrt(),
        }
    }
}
