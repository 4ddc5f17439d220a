//! Choosing the light that next-event estimation samples: by power ([`PowerSampler`]), or by a
//! light tree over the finite lights ([`crate::light_tree::LightTree`]) with the infinite ones
//! chosen by power. The choice and its probability (for MIS) come from the same two functions,
//! so they agree.

use crate::lanes::{F32s, Mask};
use crate::light::Light;
use crate::light_tree::{LightBounds, LightTree};
use crate::math::Vec3;

/// Chooses lights with probability proportional to their power, whatever the shading point.
#[derive(Debug, Clone, Default)]
pub struct PowerSampler {
    cdf: Vec<f32>,
    total: f32,
}

impl PowerSampler {
    /// Builds the distribution over `lights`.
    pub fn new(lights: &[Light]) -> PowerSampler {
        Self::weighted(lights.iter().map(Light::power))
    }

    /// The distribution proportional to `weights` (non-finite and negative ones count as 0).
    fn weighted(weights: impl Iterator<Item = f32>) -> PowerSampler {
        let mut cdf = Vec::new();
        let mut acc = 0.0f64;
        for p in weights {
            acc += if p.is_finite() && p > 0.0 {
                f64::from(p)
            } else {
                0.0
            };
            cdf.push(acc as f32);
        }
        PowerSampler {
            total: acc as f32,
            cdf,
        }
    }

    /// Picks a light with `u`: its index, its selection probability, and `u` remapped to [0, 1)
    /// within the chosen light's share of the unit interval, a fresh uniform number for sampling
    /// that light (pbrt-v4's `SampleDiscrete`): one 2D sample point then covers the choice of
    /// light and a point on it, so stratification carries over to the union of all lights (the
    /// two triangles of a quad light are sampled like one rectangle).
    pub fn pick(&self, u: f32) -> Option<(usize, f32, f32)> {
        if self.total <= 0.0 {
            return None;
        }
        let target = u * self.total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let p = self.pmf(i);
        if p <= 0.0 {
            return None;
        }
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let remapped =
            ((u * self.total - lo) / (self.cdf[i] - lo)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        Some((i, p, remapped))
    }

    /// [`pick`](Self::pick) in every lane, with its operations in their order (so its bits):
    /// each lane's light index (as an exact `f32`), probability and remapped number, and the
    /// lanes that picked a light (the others' values mean nothing). The light's index is the
    /// count of cumulative weights at or below the target, which is what the binary search
    /// finds in a non-decreasing table; one comparison per light, so for few lights.
    #[inline(always)]
    pub fn pick_lanes<const W: usize>(&self, u: F32s<W>) -> PickLanes<W> {
        let none = PickLanes {
            light: F32s::splat(0.0),
            pmf: F32s::splat(0.0),
            u: F32s::splat(0.0),
            picked: Mask::splat(false),
        };
        if self.total <= 0.0 {
            return none;
        }
        let target = u * self.total;
        let mut count = F32s::splat(0.0);
        for &c in &self.cdf {
            count += F32s::select(
                F32s::splat(c).le(target),
                F32s::splat(1.0),
                F32s::splat(0.0),
            );
        }
        let last = (self.cdf.len() - 1) as f32;
        let light = F32s::select(count.gt(F32s::splat(last)), F32s::splat(last), count);
        // The chosen light's cumulative weight and the one before it.
        let (mut hi, mut lo) = (F32s::splat(0.0), F32s::splat(0.0));
        let mut before = 0.0;
        for (k, &c) in self.cdf.iter().enumerate() {
            let here = light.eq(F32s::splat(k as f32));
            hi = F32s::select(here, F32s::splat(c), hi);
            lo = F32s::select(here, F32s::splat(before), lo);
            before = c;
        }
        let pmf = (hi - lo) / self.total;
        let remapped = (target - lo) / (hi - lo);
        let remapped = F32s::select(remapped.lt(F32s::splat(0.0)), F32s::splat(0.0), remapped);
        let top = F32s::splat(1.0 - f32::EPSILON / 2.0);
        PickLanes {
            light,
            pmf,
            u: F32s::select(remapped.gt(top), top, remapped),
            // `p <= 0.0` refuses: a NaN probability is kept, as there.
            picked: !pmf.le(F32s::splat(0.0)),
        }
    }

    /// The number of lights it chooses among.
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// Whether it has no light to choose.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Probability of picking light `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        if self.total <= 0.0 || i >= self.cdf.len() {
            return 0.0;
        }
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (self.cdf[i] - lo) / self.total
    }
}

/// [`PowerSampler::pick_lanes`]' choices, lane by lane.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub struct PickLanes<const W: usize> {
    /// The light's index (an exact integer).
    pub light: F32s<W>,
    /// The probability of choosing it.
    pub pmf: F32s<W>,
    /// The number remapped within its share, for sampling it.
    pub u: F32s<W>,
    /// The lanes that chose a light.
    pub picked: Mask<W>,
}

/// Which light-selection strategy a [`LightSampler`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightSamplerKind {
    /// [`LightSampler::TREE_MIN_LIGHTS`] decides.
    Auto,
    /// In proportion to power alone ([`PowerSampler`]).
    Power,
    /// By a light tree ([`crate::light_tree::LightTree`]) for the finite lights.
    Tree,
}

/// Chooses the light that next-event estimation samples from a shading point, and gives the
/// probability of that choice for MIS. The same two functions serve both, so they agree.
#[derive(Debug, Clone)]
pub enum LightSampler {
    /// By power, whatever the shading point.
    Power(PowerSampler),
    /// By a light tree for the finite lights; the infinite ones are chosen with probability
    /// `p_infinite` (their share of the total power estimate, so that they are picked as often
    /// as the power sampler would), and among them by power.
    Tree {
        /// The finite lights.
        tree: LightTree,
        /// Probability of choosing an infinite light.
        p_infinite: f32,
        /// Among the infinite lights (indexed like all lights; finite ones weigh 0).
        infinite: PowerSampler,
    },
}

impl Default for LightSampler {
    fn default() -> Self {
        LightSampler::Power(PowerSampler::default())
    }
}

impl LightSampler {
    /// Fewest finite lights from which [`LightSamplerKind::Auto`] builds a tree: with fewer, the
    /// tree cannot tell lights apart better than their power does by enough to pay for its
    /// walk (measured in `docs/performance.md`, "Light tree").
    pub const TREE_MIN_LIGHTS: usize = 3;

    /// The sampler `kind` over `lights`.
    pub fn new(lights: &[Light], kind: LightSamplerKind) -> LightSampler {
        let finite = lights
            .iter()
            .filter(|l| LightBounds::of(l).is_some_and(|b| b.phi > 0.0))
            .count();
        let tree = match kind {
            LightSamplerKind::Auto => finite >= Self::TREE_MIN_LIGHTS,
            LightSamplerKind::Power => false,
            LightSamplerKind::Tree => true,
        };
        if !tree {
            return LightSampler::Power(PowerSampler::new(lights));
        }
        let tree = LightTree::new(lights);
        let infinite = PowerSampler::weighted(lights.iter().map(|l| {
            if l.at_infinity() {
                l.power()
            } else {
                0.0
            }
        }));
        let finite_power: f64 = lights
            .iter()
            .filter(|l| !l.at_infinity())
            .map(|l| f64::from(l.power()))
            .filter(|p| p.is_finite() && *p > 0.0)
            .sum();
        let p_infinite = if tree.is_empty() {
            1.0
        } else if infinite.total <= 0.0 {
            0.0
        } else {
            (f64::from(infinite.total) / (f64::from(infinite.total) + finite_power)) as f32
        };
        LightSampler::Tree {
            tree,
            p_infinite,
            infinite,
        }
    }

    /// Whether this sampler uses a light tree.
    pub fn is_tree(&self) -> bool {
        matches!(self, LightSampler::Tree { .. })
    }

    /// Picks a light for the shading point `p` with normal `n` (zero for points not on a
    /// surface) with the uniform number `u`: its index, its probability, and `u` remapped to a
    /// fresh uniform number in [0, 1) for sampling a point on the light (see
    /// [`PowerSampler::pick`]). `None` when no light can be picked.
    #[inline]
    pub fn pick(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        match self {
            LightSampler::Power(s) => s.pick(u),
            LightSampler::Tree {
                tree,
                p_infinite,
                infinite,
            } => {
                let p_inf = *p_infinite;
                if u < p_inf {
                    let (i, pmf, u) = infinite.pick((u / p_inf).min(1.0 - f32::EPSILON / 2.0))?;
                    Some((i, pmf * p_inf, u))
                } else {
                    let p_fin = 1.0 - p_inf;
                    let u = ((u - p_inf) / p_fin).min(1.0 - f32::EPSILON / 2.0);
                    let (i, pmf, u) = tree.pick(p, n, u)?;
                    Some((i, pmf * p_fin, u))
                }
            }
        }
    }

    /// The sampler by power, when that is how lights are chosen (whatever the shading point).
    pub fn by_power(&self) -> Option<&PowerSampler> {
        match self {
            LightSampler::Power(s) => Some(s),
            LightSampler::Tree { .. } => None,
        }
    }

    /// Probability that [`LightSampler::pick`] at `p`, `n` returns light `i`.
    #[inline]
    pub fn pmf(&self, p: Vec3, n: Vec3, i: usize) -> f32 {
        match self {
            LightSampler::Power(s) => s.pmf(i),
            LightSampler::Tree {
                tree,
                p_infinite,
                infinite,
            } => {
                let from_infinite = infinite.pmf(i);
                if from_infinite > 0.0 {
                    from_infinite * p_infinite
                } else {
                    tree.pmf(p, n, i) * (1.0 - p_infinite)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lane picks are the scalar picks, bit for bit, at every width: on tables with zero
    /// weights (first, inside, last), one light, and numbers at the shares' edges.
    #[test]
    fn lane_picks_are_scalar_picks() {
        fn check<const W: usize>(s: &PowerSampler, us: &[f32]) {
            for chunk in us.chunks_exact(W) {
                let lanes = s.pick_lanes(F32s::<W>(std::array::from_fn(|i| chunk[i])));
                for (i, &u) in chunk.iter().enumerate() {
                    match s.pick(u) {
                        Some((light, pmf, v)) => {
                            assert!(lanes.picked.lane(i), "u = {u}");
                            assert_eq!(lanes.light[i], light as f32, "u = {u}");
                            assert_eq!(lanes.pmf[i].to_bits(), pmf.to_bits(), "u = {u}");
                            assert_eq!(lanes.u[i].to_bits(), v.to_bits(), "u = {u}");
                        }
                        None => assert!(!lanes.picked.lane(i), "u = {u}"),
                    }
                }
            }
        }
        let tables: [&[f32]; 5] = [
            &[1.0, 0.0, 3.0],
            &[0.0, 2.0, 0.0, 0.0, 5.0, 0.0],
            &[7.5],
            &[1.0, 1.0],
            &[0.0, 0.0],
        ];
        let mut state = 1u64;
        let mut us: Vec<f32> = (0..4096)
            .map(|_| crate::sampler::test_lcg(&mut state))
            .collect();
        us.extend([0.0, 0.125, 0.25, 0.5, 0.75, 1.0 - f32::EPSILON / 2.0]);
        us.extend((0..10).map(|k| k as f32 / 9.0));
        while !us.len().is_multiple_of(16) {
            us.push(0.5);
        }
        for weights in tables {
            let s = PowerSampler::weighted(weights.iter().copied());
            check::<1>(&s, &us);
            check::<4>(&s, &us);
            check::<8>(&s, &us);
            check::<16>(&s, &us);
        }
    }

    #[test]
    fn selection_follows_power() {
        let lights = vec![
            Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::ONE,
            },
            Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::ZERO,
            },
            Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::splat(3.0),
            },
        ];
        let s = PowerSampler::new(&lights);
        assert!(
            (s.pmf(0) - 0.25).abs() < 1e-6 && s.pmf(1) == 0.0 && (s.pmf(2) - 0.75).abs() < 1e-6
        );
        assert_eq!(s.pick(0.1).unwrap().0, 0);
        assert_eq!(s.pick(0.3).unwrap().0, 2);
        // The remapped number is uniform within the chosen light's share: u = 0.25 + 0.75·v
        // picks light 2 with v back, for v across [0, 1).
        for k in 0..100 {
            let v = k as f32 / 100.0;
            let (i, p, r) = s.pick(0.25 + 0.75 * v).unwrap();
            assert_eq!((i, p), (2, 0.75));
            assert!((r - v).abs() < 1e-5 && (0.0..1.0).contains(&r), "{v} → {r}");
        }
        assert_eq!(s.pick(0.999_999_9).unwrap().0, 2);
        assert!(s.pick(0.999_999_9).unwrap().2 < 1.0);
    }
}
