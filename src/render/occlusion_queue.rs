//! Shadow rays of several waves, tested W at a time.
//!
//! At each step only some of a wave's lanes have a shadow ray (about 58 % on the Cornell box),
//! while the small set's occlusion kernel costs the same however many of its lanes carry a
//! segment. So a thread keeps several waves in flight ([`super::wave`]) which take turns, a
//! step each: a step queues its shadow rays here and scatters its paths without waiting for
//! the answers, and the light samples' terms are added at the start of the wave's next turn,
//! before anything that step adds (the same sums in the same order). Meanwhile the other waves
//! queue theirs, and the queue runs the kernel whenever W rays wait, on fewer only when a wave
//! needs its answers.
//!
//! A wave's answers are one bit per lane: the queue changes which rays share a kernel call,
//! never a ray's answer, and no image changes by a bit.

use crate::geometry::SegmentLanes;
use crate::integrator::TraceStats;
use crate::lanes::{F32s, Mask, V3s};
use crate::scene::Scene;

/// Room for the waiting rays: they are read from a head that moves on by each call and moved
/// back to the start when fewer than 32 places are left behind the last (fewer than W wait
/// after the queue has run its full calls, a wave adds at most W, and the 16-lane path stores
/// whole vectors; W ≤ 16).
const CAPACITY: usize = 256;

/// The fields of a queued ray: origin (x, y, z), direction (x, y, z) and the segment's end.
const FIELDS: usize = 7;

/// The waiting shadow rays of `N` waves of W lanes, and the answers they got.
pub(super) struct OcclusionQueue<const W: usize, const N: usize> {
    /// The waiting rays in queue order from `head` on, structure of arrays ([`FIELDS`]).
    fields: [[f32; CAPACITY]; FIELDS],
    /// Where the oldest waiting ray is.
    head: usize,
    /// How many rays wait.
    len: usize,
    /// The waves whose rays wait, oldest first: the wave and its lanes (as bits) whose rays
    /// wait, in lane order (at most one entry per wave).
    batches: [(usize, u64); N],
    /// Where the oldest batch is in `batches` (a ring), and how many there are.
    first_batch: usize,
    batch_count: usize,
    /// Each wave's answers so far: bit i set where lane i's segment is blocked.
    blocked: [u64; N],
    /// How many of each wave's rays wait.
    waiting: [u32; N],
    /// Whether the CPU has AVX-512 (W = 16 compresses in registers) and BMI2 (`pdep`), found
    /// once: the run-time checks cost as much as what they choose between.
    has_avx512: bool,
    has_bmi2: bool,
}

impl<const W: usize, const N: usize> OcclusionQueue<W, N> {
    /// An empty queue.
    pub fn new() -> Self {
        const { assert!(W <= 16 && N > 0) };
        OcclusionQueue {
            fields: [[0.0; CAPACITY]; FIELDS],
            head: 0,
            len: 0,
            batches: [(0, 0); N],
            first_batch: 0,
            batch_count: 0,
            blocked: [0; N],
            waiting: [0; N],
            has_avx512: {
                #[cfg(target_arch = "x86_64")]
                let avx512 = W == 16 && crate::lanes::has_avx512();
                #[cfg(not(target_arch = "x86_64"))]
                let avx512 = false;
                avx512
            },
            has_bmi2: crate::lanes::has_bmi2(),
        }
    }

    /// Queues the segments of wave `wave` (whose earlier answers must have been taken).
    #[inline(always)]
    pub fn push(&mut self, wave: usize, segments: &SegmentLanes<W>) {
        debug_assert_eq!(self.waiting[wave], 0);
        let lanes = segments.live.bits();
        self.blocked[wave] = 0;
        if lanes == 0 {
            return;
        }
        let columns = [
            &segments.o.x.0,
            &segments.o.y.0,
            &segments.o.z.0,
            &segments.d.x.0,
            &segments.d.y.0,
            &segments.d.z.0,
            &segments.t_max.0,
        ];
        self.append(lanes, columns);
        let count = lanes.count_ones();
        self.len += count as usize;
        self.waiting[wave] = count;
        let slot = (self.first_batch + self.batch_count) % N;
        self.batches[slot] = (wave, lanes);
        self.batch_count += 1;
    }

    /// Whether W rays wait (a full call's worth).
    #[inline(always)]
    pub fn is_full(&self) -> bool {
        self.len >= W
    }

    /// Wave `wave`'s answers, the lanes whose segments are blocked, once the queue has run
    /// until none of its rays waits.
    #[inline(always)]
    pub fn answers(&mut self, wave: usize, scene: &Scene, stats: &mut TraceStats) -> Mask<W> {
        while self.waiting[wave] != 0 {
            self.run(scene, stats);
        }
        Mask::from_bits(self.blocked[wave])
    }

    /// Tests the oldest W waiting rays (or all, if fewer wait) and hands their answers to
    /// their waves.
    #[inline(always)]
    pub fn run(&mut self, scene: &Scene, stats: &mut TraceStats) {
        let n = self.len.min(W);
        if n == 0 {
            return;
        }
        let head = self.head;
        let column = |field: usize| {
            let mut lanes = F32s::<W>::default();
            lanes.0.copy_from_slice(&self.fields[field][head..head + W]);
            lanes
        };
        let segments = SegmentLanes::<W> {
            live: Mask::from_bits((1u64 << n) - 1),
            o: V3s {
                x: column(0),
                y: column(1),
                z: column(2),
            },
            d: V3s {
                x: column(3),
                y: column(4),
                z: column(5),
            },
            t_max: column(6),
        };
        stats.rays += n as u64;
        let mut answers = Mask::from_bools(&scene.shadowed_lanes(&segments)).bits();
        let mut left = n as u32;
        while left > 0 {
            let (wave, lanes) = self.batches[self.first_batch];
            let count = lanes.count_ones().min(left);
            let taken = deposit((1u64 << count) - 1, lanes, self.has_bmi2);
            self.blocked[wave] |= deposit(answers, lanes, self.has_bmi2) & taken;
            self.waiting[wave] -= count;
            answers >>= count;
            left -= count;
            if taken == lanes {
                self.first_batch = (self.first_batch + 1) % N;
                self.batch_count -= 1;
            } else {
                self.batches[self.first_batch].1 = lanes & !taken;
            }
        }
        self.head += n;
        self.len -= n;
    }

    /// Appends the `lanes` (bits) of the W-lane `columns` to the fields, in lane order.
    #[inline(always)]
    fn append(&mut self, lanes: u64, columns: [&[f32; W]; FIELDS]) {
        if self.head + self.len + 2 * 16 > CAPACITY {
            for field in &mut self.fields {
                field.copy_within(self.head..self.head + self.len, 0);
            }
            self.head = 0;
        }
        let start = self.head + self.len;
        #[cfg(target_arch = "x86_64")]
        if self.has_avx512 {
            // SAFETY: the CPU has AVX-512 F, each column holds 16 lanes, and every field has
            // room for 16 values after `start`.
            unsafe { compress_16(&mut self.fields, start, lanes as u16, &columns) };
            return;
        }
        let mut bits = lanes;
        let mut k = start;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            for (field, column) in self.fields.iter_mut().zip(&columns) {
                field[k] = column[i];
            }
            bits &= bits - 1;
            k += 1;
        }
    }
}

/// The low bits of `bits` placed, in order, at the set bits of `mask`: the BMI2 `pdep`
/// instruction where the CPU has it (`bmi2`), else the same computed bit by bit.
#[inline(always)]
fn deposit(bits: u64, mask: u64, bmi2: bool) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if bmi2 {
        // SAFETY: the caller found BMI2.
        return unsafe { std::arch::x86_64::_pdep_u64(bits, mask) };
    }
    let (mut out, mut rest, mut k) = (0, mask, 0);
    while rest != 0 {
        let low = rest & rest.wrapping_neg();
        out |= low & 0u64.wrapping_sub((bits >> k) & 1);
        rest ^= low;
        k += 1;
    }
    out
}

/// Appends the `lanes` (bits) of the 16-lane `columns` to `fields` from `start` on, in lane
/// order: each column compressed in a register and stored whole (a compressing store to
/// memory is microcoded on AMD's cores, dozens of times slower).
///
/// # Safety
/// The CPU must have AVX-512 F, and every field room for 16 values from `start` on.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn compress_16<const W: usize>(
    fields: &mut [[f32; CAPACITY]; FIELDS],
    start: usize,
    lanes: u16,
    columns: &[&[f32; W]; FIELDS],
) {
    use std::arch::x86_64::*;
    for (field, column) in fields.iter_mut().zip(columns) {
        debug_assert!(W == 16 && start + 16 <= CAPACITY);
        // SAFETY: the caller's.
        unsafe {
            let v = _mm512_loadu_ps(column.as_ptr());
            let packed = _mm512_maskz_compress_ps(lanes, v);
            _mm512_storeu_ps(field.as_mut_ptr().add(start), packed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{deposit, OcclusionQueue};
    use crate::geometry::SegmentLanes;
    use crate::integrator::TraceStats;
    use crate::math::{Ray, Vec3};
    use crate::sampler::test_lcg;
    use crate::scene::Scene;

    #[test]
    fn deposit_places_bits_at_the_mask() {
        for bmi2 in [false, crate::lanes::has_bmi2()] {
            assert_eq!(deposit(0b1011, 0b1111_0000, bmi2), 0b1011_0000);
            assert_eq!(deposit(0b101, 0b1010_1000, bmi2), 0b1000_1000);
            assert_eq!(deposit(!0, 0b1001, bmi2), 0b1001);
            assert_eq!(deposit(0, 0xffff, bmi2), 0);
        }
    }

    /// Waves push segments from random points of the box towards random points (some lanes
    /// idle), take their turns as the render loop does, and every answer they get is what the
    /// scene says of their own segment.
    fn answers_are_each_waves_own<const W: usize>(scene: &Scene) {
        const N: usize = 3;
        let mut state = 7;
        let mut point = || {
            Vec3::new(
                2.0 * test_lcg(&mut state) - 1.0,
                2.0 * test_lcg(&mut state) - 1.0,
                2.0 * test_lcg(&mut state) - 1.0,
            )
        };
        let mut queue = OcclusionQueue::<W, N>::new();
        let mut stats = TraceStats::default();
        let mut pending: [Option<[Option<bool>; W]>; N] = [None; N];
        let (mut blocked_seen, mut clear_seen) = (0, 0);
        for turn in 0..600 {
            let w = turn % N;
            let got = queue.answers(w, scene, &mut stats);
            if let Some(expected) = pending[w].take() {
                for (i, e) in expected.iter().enumerate() {
                    if let Some(e) = e {
                        assert_eq!(got.lane(i), *e, "W = {W}, turn {turn}, lane {i}");
                        if *e {
                            blocked_seen += 1;
                        } else {
                            clear_seen += 1;
                        }
                    }
                }
            }
            let mut segments = SegmentLanes::<W>::new();
            let mut expected = [None; W];
            for (i, e) in expected.iter_mut().enumerate() {
                let (from, to) = (point(), point());
                // About a fifth of the lanes idle, a different fifth each turn.
                if (i + turn) % 5 == 0 || to == from {
                    continue;
                }
                let ray = Ray::new(from, to - from);
                segments.set(i, &ray, 1.0);
                *e = Some(scene.shadowed(&ray, 1.0));
            }
            queue.push(w, &segments);
            pending[w] = Some(expected);
            while queue.is_full() {
                queue.run(scene, &mut stats);
            }
        }
        assert!(
            blocked_seen > 100 && clear_seen > 100,
            "{blocked_seen} {clear_seen}"
        );
    }

    #[test]
    fn waves_get_the_answers_to_their_own_segments() {
        let scene = crate::load::test_cornell();
        answers_are_each_waves_own::<16>(&scene);
        answers_are_each_waves_own::<8>(&scene);
        answers_are_each_waves_own::<4>(&scene);
        answers_are_each_waves_own::<1>(&scene);
    }
}
