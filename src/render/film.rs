//! The film: per-pixel running sums of samples, and the image, error image and error estimate
//! they give.

use std::time::Duration;

use glam::DVec3;

use super::schedule::Plan;
use super::{Rendered, Stats};
use crate::image::{Image, REL_EPSILON};
use crate::math::Vec3;

/// Running sums of one pixel's samples.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PixelSum {
    pub(super) sum: DVec3,
    pub(super) sum_sq: DVec3,
    pub(super) good: u32,
    pub(super) bad: u32,
    /// Wall time these samples took, in nanoseconds: the cost model of time-budgeted adaptive
    /// passes (a render against the clock is not reproducible anyway).
    pub(super) nanos: u64,
}

impl PixelSum {
    pub(super) fn taken(&self) -> u32 {
        self.good + self.bad
    }

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

/// Image, error image and counters from the per-pixel sums.
pub(super) fn finish(plan: &Plan, sums: &[PixelSum], rays: u64, elapsed: Duration) -> Rendered {
    let (w, h) = (plan.width, plan.height);
    let image = Image {
        width: w,
        height: h,
        pixels: sums.iter().map(|p| p.mean().as_vec3()).collect(),
    };
    let std_error = Image {
        width: w,
        height: h,
        pixels: sums
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
    };
    let (estimated_rmse, estimated_rel_error) = estimate(sums);
    let samples: u64 = sums.iter().map(|p| u64::from(p.taken())).sum();
    let stats = Stats {
        spp: (samples as f64 / sums.len().max(1) as f64).round() as u32,
        samples,
        rays,
        nan_samples: sums.iter().map(|p| u64::from(p.bad)).sum(),
        elapsed,
        estimated_rmse,
        estimated_rel_error,
    };
    Rendered {
        image,
        std_error,
        counts: sums.iter().map(PixelSum::taken).collect(),
        stats,
    }
}

/// (estimated RMSE, estimated relative error) of the image from its per-pixel variances.
pub(super) fn estimate(sums: &[PixelSum]) -> (f64, f64) {
    let n = sums.len() as f64;
    let mse = sums
        .iter()
        .map(|p| p.var_of_mean().element_sum() / 3.0)
        .sum::<f64>()
        / n;
    let rel = sums.iter().map(PixelSum::rel_var).sum::<f64>() / n;
    (mse.sqrt(), rel.sqrt())
}
