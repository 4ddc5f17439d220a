//! One pass of a render: given how many more samples each pixel takes, the image is cut into
//! square tiles that rayon spreads over threads; the pass's samples come back as a film of their
//! own, to be merged into the total.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::film::{Film, PixelSum, Sink};
use super::wave::PixelWork;
use crate::aov::{AovSet, AovSums};
use crate::integrator::TraceStats;

/// Side of the square tiles work is split into.
pub const TILE: u32 = 16;

/// What every pass of a render shares: how to sample a pixel, whom to tell about progress, and
/// the counters summed over all passes.
pub(super) struct PassContext<'a, F> {
    /// `sample(work, sums, stats)`: the sums of the samples `work` lists (pixels given in the
    /// film's window), one per entry, into `sums`.
    sample: F,
    /// The render passes the films sum.
    aovs: AovSet,
    /// Called with the number of samples finished so far.
    progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Whether to record the wall time each pixel's samples take.
    timed: bool,
    /// Index of every pixel's first sample.
    first_sample: u32,
    /// When set, tiles not yet started are skipped and the pass is dropped.
    cancel: Option<&'a AtomicBool>,
    /// Rays cast so far.
    rays: AtomicU64,
    /// Samples finished so far.
    samples_done: AtomicU64,
}

/// The new samples' sums of a tile's pixels, row by row: the beauty's and the passes'.
type TileSums = (Vec<PixelSum>, Option<AovSums>);

/// A tile's pixels: x in `x0..x1`, y in `y0..y1`.
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Tile {
    /// Tile number `index` of a `width` × `height` image with `tiles_x` tiles per row.
    fn new(index: u32, tiles_x: u32, width: u32, height: u32) -> Tile {
        let (x0, y0) = ((index % tiles_x) * TILE, (index / tiles_x) * TILE);
        Tile {
            x0,
            y0,
            x1: (x0 + TILE).min(width),
            y1: (y0 + TILE).min(height),
        }
    }

    /// The tile's pixels, row by row.
    fn pixels(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (self.y0..self.y1).flat_map(move |y| (self.x0..self.x1).map(move |x| (x, y)))
    }
}

impl<'a, F> PassContext<'a, F>
where
    F: Fn(&[PixelWork], &mut Sink, &mut TraceStats) + Sync,
{
    /// A context whose passes sample pixels with `sample`, report to `progress`, and with
    /// `timed` record the wall time of each pixel's samples.
    pub(super) fn new(
        sample: F,
        progress: Option<&'a (dyn Fn(u64) + Sync)>,
        timed: bool,
        first_sample: u32,
        cancel: Option<&'a AtomicBool>,
        aovs: AovSet,
    ) -> PassContext<'a, F> {
        PassContext {
            sample,
            aovs: aovs.recorded(),
            progress,
            timed,
            first_sample,
            cancel,
            rays: AtomicU64::new(0),
            samples_done: AtomicU64::new(0),
        }
    }

    /// Rays cast by all passes so far.
    pub(super) fn rays(&self) -> u64 {
        self.rays.load(Ordering::Relaxed)
    }

    /// Whether the render was asked to stop.
    fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }

    /// Takes `counts[i]` more samples of pixel i, tile by tile in parallel, continuing each
    /// pixel's sample indices after those already in `film`, and adds them to `film` once every
    /// tile is done; returns `false`, leaving `film` as it was, when the render was cancelled
    /// before (each thread finishes at most the tile it is on). The tiles' sums go straight
    /// into `film` (exact integer sums, so in any order), not through a film of the pass: a
    /// 256² film is 7 MB, which would be freshly mapped and zeroed pass after pass.
    pub(super) fn render(&self, film: &mut Film, counts: &[u32]) -> bool {
        let (w, h) = (film.width(), film.height());
        let tiles_x = w.div_ceil(TILE);
        let tiles_y = h.div_ceil(TILE);
        let results: Vec<Option<(Tile, TileSums)>> = (0..tiles_x * tiles_y)
            .into_par_iter()
            .with_max_len(1)
            .map(|index| {
                if self.cancelled() {
                    return None;
                }
                let tile = Tile::new(index, tiles_x, w, h);
                let sums = self.render_tile(film, counts, &tile);
                Some((tile, sums))
            })
            .collect();
        if self.cancelled() {
            return false;
        }
        for (tile, (sums, aov)) in results.into_iter().flatten() {
            for (i, ((x, y), sums)) in tile.pixels().zip(sums).enumerate() {
                film.pixel_mut(x, y).merge(&sums);
                if let (Some(to), Some(from)) = (film.sums_mut().1, &aov) {
                    to.merge_pixel((y * w + x) as usize, from, i);
                }
            }
        }
        true
    }

    /// The new samples of one tile's pixels, row by row: all in one call, or, when timed, a
    /// call per pixel.
    fn render_tile(&self, film: &Film, counts: &[u32], tile: &Tile) -> TileSums {
        let mut stats = TraceStats::default();
        let work: Vec<PixelWork> = tile
            .pixels()
            .map(|(x, y)| {
                let count = counts[(y * film.width() + x) as usize];
                let first = self.first_sample + film.pixel(x, y).taken();
                PixelWork {
                    x,
                    y,
                    indices: first..first + count,
                }
            })
            .collect();
        let mut sums = vec![PixelSum::default(); work.len()];
        let mut aov = self
            .aovs
            .needs_samples()
            .then(|| AovSums::new(self.aovs, work.len()));
        if self.timed {
            for (i, (pixel, sum)) in work.iter().zip(&mut sums).enumerate() {
                if pixel.indices.is_empty() {
                    continue;
                }
                let mut one = aov.as_ref().map(|_| AovSums::new(self.aovs, 1));
                let start = Instant::now();
                (self.sample)(
                    std::slice::from_ref(pixel),
                    &mut Sink {
                        beauty: std::slice::from_mut(sum),
                        aov: one.as_mut(),
                    },
                    &mut stats,
                );
                sum.set_time(start.elapsed());
                if let (Some(to), Some(from)) = (&mut aov, &one) {
                    to.merge_pixel(i, from, 0);
                }
            }
        } else {
            (self.sample)(
                &work,
                &mut Sink {
                    beauty: &mut sums,
                    aov: aov.as_mut(),
                },
                &mut stats,
            );
        }
        let sums = (sums, aov);
        if self.cancelled() {
            // Stopped part-way: the pass is dropped, and its samples were never taken.
            return sums;
        }
        let samples: u64 = work.iter().map(|w| u64::from(w.indices.len() as u32)).sum();
        self.rays.fetch_add(stats.rays, Ordering::Relaxed);
        let total = self.samples_done.fetch_add(samples, Ordering::Relaxed) + samples;
        if let Some(progress) = self.progress {
            progress(total);
        }
        sums
    }
}
