//! Pass scheduling: the shape and budget of a render.

use std::time::Duration;

/// The shape and budget of a render, independent of what is rendered.
pub(super) struct Plan {
    pub(super) width: u32,
    pub(super) height: u32,
    /// Samples per pixel (mean), the cap of the budget.
    pub(super) spp: u32,
    /// Wall-time budget.
    pub(super) budget: Option<Duration>,
    /// Seed of the render; also seeds the stochastic rounding of adaptive sample counts.
    pub(super) seed: u64,
}
