//! Images in linear radiance and the error metrics between them.

use glam::DVec3;

use crate::math::{Rgb, Vec3};

/// ε in relative errors (x − r)² / (r² + ε), so that dark pixels do not dominate
/// (the usual choice in rendering papers, e.g. Rousselle et al. 2011).
pub const REL_EPSILON: f64 = 1e-2;

/// A rendered image in linear radiance.
#[derive(Debug, Clone)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, row-major, top row first.
    pub pixels: Vec<Rgb>,
}

impl Image {
    fn squared_errors<'a>(&'a self, other: &'a Image) -> impl Iterator<Item = (DVec3, DVec3)> + 'a {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "images differ in size"
        );
        self.pixels.iter().zip(&other.pixels).map(|(a, b)| {
            let d = (*a - *b).as_dvec3();
            (d * d, b.as_dvec3())
        })
    }

    /// Root-mean-square difference over all pixels and channels.
    pub fn rmse(&self, other: &Image) -> f64 {
        let sum: f64 = self
            .squared_errors(other)
            .map(|(d2, _)| d2.element_sum())
            .sum();
        (sum / (3.0 * self.pixels.len() as f64)).sqrt()
    }

    /// Relative mean squared error against a reference: mean of (x − r)² / (r² + ε).
    pub fn rel_mse(&self, reference: &Image) -> f64 {
        let sum: f64 = self
            .squared_errors(reference)
            .map(|(d2, r)| (d2 / (r * r + DVec3::splat(REL_EPSILON))).element_sum())
            .sum();
        sum / (3.0 * self.pixels.len() as f64)
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let sum = self
            .pixels
            .iter()
            .fold(DVec3::ZERO, |a, p| a + p.as_dvec3());
        (sum / self.pixels.len() as f64).as_vec3()
    }
}
