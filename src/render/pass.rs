//! One pass of a render: tiles spread over threads with rayon.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::film::PixelSum;
use super::schedule::Plan;
use super::RenderOptions;
use crate::integrator::TraceStats;

/// Side of the square tiles work is split into.
pub const TILE: u32 = 16;

/// Adds `counts[i]` more samples to pixel i, tile by tile in parallel; with `timed`, also
/// records the wall time each pixel's samples took.
#[allow(clippy::too_many_arguments)]
pub(super) fn render_pass<F>(
    plan: &Plan,
    sums: &mut [PixelSum],
    counts: &[u32],
    rays: &AtomicU64,
    done: &AtomicU64,
    options: &RenderOptions,
    timed: bool,
    sample: &F,
) where
    F: Fn(u32, u32, Range<u32>, &mut TraceStats) -> PixelSum + Sync,
{
    let (w, h) = (plan.width, plan.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let results: Vec<(u32, Vec<PixelSum>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .with_max_len(1)
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let mut stats = TraceStats::default();
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            let mut n = 0u64;
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * w + x) as usize;
                    let first = sums[i].taken();
                    out.push(if counts[i] == 0 {
                        PixelSum::default()
                    } else if timed {
                        let t = Instant::now();
                        let mut add = sample(x, y, first..first + counts[i], &mut stats);
                        add.nanos = t.elapsed().as_nanos() as u64;
                        add
                    } else {
                        sample(x, y, first..first + counts[i], &mut stats)
                    });
                    n += u64::from(counts[i]);
                }
            }
            rays.fetch_add(stats.rays, Ordering::Relaxed);
            let total = done.fetch_add(n, Ordering::Relaxed) + n;
            if let Some(p) = options.progress {
                p(total);
            }
            (tile, out)
        })
        .collect();
    for (tile, out) in results {
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let x1 = (x0 + TILE).min(w);
        for (i, add) in out.into_iter().enumerate() {
            let (dx, dy) = (i as u32 % (x1 - x0), i as u32 / (x1 - x0));
            let p = &mut sums[((y0 + dy) * w + x0 + dx) as usize];
            p.sum += add.sum;
            p.sum_sq += add.sum_sq;
            p.good += add.good;
            p.bad += add.bad;
            p.nanos += add.nanos;
        }
    }
}
