//! Random numbers for rendering. Every (seed, pixel, sample) triple owns an independent stream,
//! so an image does not depend on how pixels are spread over threads.

use crate::lanes::{F32s, Mask, U32s, U64s};

/// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
/// Algorithms for Random Number Generation"): 64-bit LCG state, XSH-RR output.
#[derive(Debug, Clone, Copy)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator on stream `stream` starting from `seed`.
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        // 24 random mantissa bits: exactly representable, never 1.0.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// SplitMix64 finaliser (Steele et al. 2014): a strong 64-bit mix for deriving seeds.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A tiny LCG for the oracle tests' random scenes and rays (fixed, reproducible cases).
#[cfg(test)]
pub(crate) fn test_lcg(state: &mut u64) -> f32 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 40) as f32) / (1u64 << 24) as f32
}

/// Which sample sequence the renderer draws from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Owen-scrambled Sobol points (lower error at equal sample counts).
    #[default]
    Sobol,
    /// Independent uniform random numbers.
    Independent,
}

/// The sample stream of one pixel sample. Deterministic in (seed, pixel, sample index), so the
/// image does not depend on scheduling.
#[derive(Debug, Clone, Copy)]
pub struct Sampler {
    kind: SamplerKind,
    rng: Pcg32,
    /// Seed of this pixel's scrambles.
    pixel_seed: u32,
    /// Sample index within the pixel, bit-reversed (the form the index scramble works on).
    reversed_index: u32,
    /// Next dimension pair.
    dimension: u32,
}

impl Sampler {
    /// The independent-random-numbers stream for sample `sample` of pixel `pixel` under `seed`
    /// (renders default to Sobol points: see [`Sampler::with_kind`]).
    pub fn independent(seed: u64, pixel: u64, sample: u64) -> Sampler {
        Sampler::with_kind(SamplerKind::Independent, seed, pixel, sample)
    }

    /// The stream of the given kind for sample `sample` of pixel `pixel` under `seed`.
    pub fn with_kind(kind: SamplerKind, seed: u64, pixel: u64, sample: u64) -> Sampler {
        Sampler::with_key(kind, Sampler::pixel_key(seed, pixel), sample)
    }

    /// What [`with_kind`](Self::with_kind) derives from the seed and the pixel, the same for
    /// all of the pixel's samples (a caller starting many of them computes it once).
    #[inline]
    pub fn pixel_key(seed: u64, pixel: u64) -> u64 {
        mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15)))
    }

    /// [`with_kind`](Self::with_kind) given the pixel's [`pixel_key`](Self::pixel_key).
    #[inline]
    pub fn with_key(kind: SamplerKind, key: u64, sample: u64) -> Sampler {
        Sampler {
            kind,
            // Only independent numbers follow the generator.
            rng: match kind {
                SamplerKind::Independent => Pcg32::new(mix64(key ^ sample), key),
                SamplerKind::Sobol => Pcg32 { state: 0, inc: 1 },
            },
            pixel_seed: (key >> 32) as u32 ^ key as u32,
            reversed_index: (sample as u32).reverse_bits(),
            dimension: 0,
        }
    }

    /// One uniform number in [0, 1).
    #[inline]
    pub fn get_1d(&mut self) -> f32 {
        match self.kind {
            SamplerKind::Independent => self.rng.next_f32(),
            SamplerKind::Sobol => {
                let hash = self.next_dimension_hash();
                to_unit(owen_sobol_x(
                    shuffled_index(self.reversed_index, hash),
                    hash,
                ))
            }
        }
    }

    /// Two uniform numbers in [0, 1)².
    #[inline]
    pub fn get_2d(&mut self) -> glam::Vec2 {
        match self.kind {
            SamplerKind::Independent => glam::Vec2::new(self.rng.next_f32(), self.rng.next_f32()),
            SamplerKind::Sobol => {
                owen_sobol_2d_reversed(self.reversed_index, self.next_dimension_hash())
            }
        }
    }

    /// Leaves out the next 2D point, unused where it falls (a pinhole camera's lens point, the
    /// light sample of a vertex that only scatters by delta lobes): the numbers after it are
    /// those they would have been had it been drawn, at none of the cost (a scrambled Sobol
    /// point is about 140 instructions).
    #[inline]
    pub fn skip_2d(&mut self) {
        match self.kind {
            SamplerKind::Independent => {
                self.rng.next_u32();
                self.rng.next_u32();
            }
            SamplerKind::Sobol => self.dimension += 1,
        }
    }

    /// A number for choosing among lobes and a 2D point for sampling within the chosen one,
    /// jointly stratified: with Sobol points, dimensions 0–2 of one Owen-scrambled Sobol point
    /// (the 2D point is that dimension pair, exactly what [`get_2d`](Self::get_2d) would give in
    /// its place; the choice its third dimension), so the samples that pick a lobe are spread
    /// over its 2D domain instead of being a random subset of the pixel's points (Cycles draws
    /// the lobe choice and the direction from one 3D Sobol point the same way). Takes the
    /// dimensions of a `get_1d` and a `get_2d`, in that order, and with independent numbers
    /// gives what those two calls would.
    #[inline]
    pub fn get_choice_2d(&mut self) -> (f32, glam::Vec2) {
        match self.kind {
            SamplerKind::Independent => {
                let choice = self.rng.next_f32();
                (choice, self.get_2d())
            }
            SamplerKind::Sobol => {
                self.dimension += 1;
                let hash = self.next_dimension_hash();
                owen_sobol_3d_shuffled(shuffled_index(self.reversed_index, hash), hash)
            }
        }
    }

    /// As many lobe choices and 2D points as `out` holds (a power of two, n), drawn together as
    /// [`get_choice_2d`](Self::get_choice_2d) draws one: points n·i … n·i + n − 1 (i this
    /// pixel sample's index) of one Owen-scrambled 3D Sobol sequence (padding), so that over a
    /// pixel's N samples the n·N points form one stratified set rather than n sets of N. Takes
    /// the dimensions of one `get_choice_2d` (with independent numbers, 3n numbers).
    pub fn get_choice_2d_padded(&mut self, out: &mut [(f32, glam::Vec2)]) {
        let n = out.len() as u32;
        debug_assert!(n.is_power_of_two());
        match self.kind {
            SamplerKind::Independent => out.fill_with(|| self.get_choice_2d()),
            SamplerKind::Sobol => {
                self.dimension += 1;
                let hash = self.next_dimension_hash();
                let first = self.reversed_index.reverse_bits().wrapping_mul(n);
                for (j, o) in (0u32..).zip(out.iter_mut()) {
                    *o = owen_sobol_3d_shuffled(
                        shuffled_index((first + j).reverse_bits(), hash),
                        hash,
                    );
                }
            }
        }
    }

    /// The scrambling hash of the next dimension (pair) of this pixel.
    #[inline]
    fn next_dimension_hash(&mut self) -> u64 {
        let hash = mix64(u64::from(self.pixel_seed) << 32 | u64::from(self.dimension));
        self.dimension += 1;
        hash
    }
}

/// The samplers of a wave, one per lane, as a structure of arrays: a lane's next numbers are
/// those its [`Sampler`] would give, bit for bit, and the wave draws the same dimension of every
/// lane's stream at once, scrambled Sobol points in SIMD lanes (independent numbers, which follow
/// a sequential generator, one lane at a time). A lane's sampler is [`set`](Self::set) when its
/// sample starts and [`get`](Self::get) out for the steps that run one lane at a time.
#[repr(C, align(64))]
pub struct SamplerLanes<const W: usize> {
    pixel_seed: U32s<W>,
    reversed_index: U32s<W>,
    dimension: U32s<W>,
    /// Each lane's sequence.
    kinds: [SamplerKind; W],
    /// How many lanes draw independent numbers (mostly none: then every draw runs in lanes
    /// without looking at the lanes' kinds).
    independent_lanes: u32,
    rng: [Pcg32; W],
}

impl<const W: usize> SamplerLanes<W> {
    /// Lanes of samplers that draw nothing yet (each lane is [`set`](Self::set) before use).
    pub fn new() -> Self {
        SamplerLanes {
            kinds: [SamplerKind::Sobol; W],
            independent_lanes: 0,
            rng: [Pcg32 { state: 0, inc: 1 }; W],
            pixel_seed: U32s::default(),
            reversed_index: U32s::default(),
            dimension: U32s::default(),
        }
    }

    /// Lane `i`'s sampler, as it stands.
    #[inline]
    pub fn get(&self, i: usize) -> Sampler {
        Sampler {
            kind: self.kinds[i],
            rng: self.rng[i],
            pixel_seed: self.pixel_seed[i],
            reversed_index: self.reversed_index[i],
            dimension: self.dimension[i],
        }
    }

    /// Makes `sampler` lane `i`'s.
    #[inline]
    pub fn set(&mut self, i: usize, sampler: Sampler) {
        let independent = |kind| u32::from(kind == SamplerKind::Independent);
        self.independent_lanes =
            self.independent_lanes - independent(self.kinds[i]) + independent(sampler.kind);
        self.kinds[i] = sampler.kind;
        self.rng[i] = sampler.rng;
        self.pixel_seed[i] = sampler.pixel_seed;
        self.reversed_index[i] = sampler.reversed_index;
        self.dimension[i] = sampler.dimension;
    }

    /// `draw` on lane `i`'s sampler, which then moves on as `draw` moved it.
    #[inline]
    pub fn with<T>(&mut self, i: usize, draw: impl FnOnce(&mut Sampler) -> T) -> T {
        let mut sampler = self.get(i);
        let out = draw(&mut sampler);
        self.set(i, sampler);
        out
    }

    /// The next 2D point of the samplers of the `live` lanes ([`Sampler::get_2d`]; the others
    /// draw nothing and get numbers that mean nothing).
    #[inline(always)]
    pub fn get_2d(&mut self, live: Mask<W>) -> (F32s<W>, F32s<W>) {
        if !self.all_sobol(live) {
            let mut out = (F32s::default(), F32s::default());
            for i in live.iter() {
                let u = self.with(i, Sampler::get_2d);
                (out.0[i], out.1[i]) = (u.x, u.y);
            }
            return out;
        }
        crate::lanes::widest!(
            gfni;
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>) => (F32s<W>, F32s<W>),
            (self, live),
            {
                let out = SobolLanes::at(lanes, 0).point_2d();
                lanes.advance(live, 1);
                out
            }
        )
    }

    /// [`get_2d`](Self::get_2d) of the `live` lanes and, computed in the same pass, the 2D
    /// point their following [`get_choice_2d`](Self::get_choice_2d) will give: a
    /// [`ScatterPoint`] to hand to [`get_choice_2d_from`](Self::get_choice_2d_from) in its place.
    /// The same numbers as the two calls; the two points' chains of multiplications run side by
    /// side instead of one after the other (each is some 80 cycles of latency), and the wave
    /// reads the second after the light samples' work. Lanes of independent numbers draw
    /// theirs in order then (their generator is sequential).
    #[inline(always)]
    pub fn get_2d_and_scatter_point(
        &mut self,
        live: Mask<W>,
    ) -> ((F32s<W>, F32s<W>), ScatterPoint<W>) {
        if !self.all_sobol(live) {
            return (self.get_2d(live), ScatterPoint(None));
        }
        let (light, scatter) = self.light_and_scatter_points(live);
        (light, ScatterPoint(Some(scatter)))
    }

    /// The two points of [`get_2d_and_scatter_point`](Self::get_2d_and_scatter_point), every
    /// lane drawing Sobol points.
    #[inline(always)]
    fn light_and_scatter_points(
        &mut self,
        live: Mask<W>,
    ) -> ((F32s<W>, F32s<W>), (F32s<W>, F32s<W>)) {
        crate::lanes::widest!(
            gfni;
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>)
                => ((F32s<W>, F32s<W>), (F32s<W>, F32s<W>)),
            (self, live),
            {
                let light = SobolLanes::at(lanes, 0).point_2d();
                // After this draw, `get_choice_2d` skips the choice's dimension.
                let scatter = SobolLanes::at(lanes, 2).point_2d();
                lanes.advance(live, 1);
                (light, scatter)
            }
        )
    }

    /// [`get_choice_2d`](Self::get_choice_2d) of the `live` lanes, whose 2D point `point` holds
    /// when it was drawn ahead ([`get_2d_and_scatter_point`](Self::get_2d_and_scatter_point),
    /// with nothing drawn between); the lobe choice only `with_choice` (else zeros, as
    /// [`get_choice_2d_point`](Self::get_choice_2d_point) leaves it).
    #[inline(always)]
    pub fn get_choice_2d_from(
        &mut self,
        live: Mask<W>,
        point: ScatterPoint<W>,
        with_choice: bool,
    ) -> (F32s<W>, F32s<W>, F32s<W>) {
        let Some((x, y)) = point.0 else {
            return if with_choice {
                self.get_choice_2d(live)
            } else {
                let (x, y) = self.get_choice_2d_point(live);
                (F32s::default(), x, y)
            };
        };
        if !with_choice {
            self.advance_lanes(live, 2);
            return (F32s::default(), x, y);
        }
        (self.choice_alone(live), x, y)
    }

    /// The lobe choice of the next [`get_choice_2d`](Self::get_choice_2d) of the `live` lanes
    /// (every one drawing Sobol points), which then move on as it moves them.
    #[inline(always)]
    fn choice_alone(&mut self, live: Mask<W>) -> F32s<W> {
        crate::lanes::widest!(
            gfni;
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>) => F32s<W>,
            (self, live),
            {
                let out = SobolLanes::at(lanes, 1).choice();
                lanes.advance(live, 2);
                out
            }
        )
    }

    /// [`advance`](Self::advance) compiled for the widest vectors the CPU has.
    fn advance_lanes(&mut self, live: Mask<W>, by: u32) {
        crate::lanes::widest!(
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>, by: u32) => (),
            (self, live, by),
            lanes.advance(live, by)
        )
    }

    /// The next number of the samplers of the `live` lanes ([`Sampler::get_1d`]; the others
    /// draw nothing and get numbers that mean nothing).
    #[inline(always)]
    pub fn get_1d(&mut self, live: Mask<W>) -> F32s<W> {
        if !self.all_sobol(live) {
            let mut out = F32s::default();
            for i in live.iter() {
                out[i] = self.with(i, Sampler::get_1d);
            }
            return out;
        }
        crate::lanes::widest!(
            gfni;
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>) => F32s<W>,
            (self, live),
            {
                let out = SobolLanes::at(lanes, 0).point_1d();
                lanes.advance(live, 1);
                out
            }
        )
    }

    /// Leaves out the next 2D point of the samplers of the `live` lanes
    /// ([`Sampler::skip_2d`]).
    pub fn skip_2d(&mut self, live: Mask<W>) {
        if !self.all_sobol(live) {
            for i in live.iter() {
                self.with(i, Sampler::skip_2d);
            }
            return;
        }
        self.advance_lanes(live, 1);
    }

    /// The next lobe choice and 2D point of the samplers of the `live` lanes
    /// ([`Sampler::get_choice_2d`]; the others draw nothing and get numbers that mean nothing).
    #[inline(always)]
    pub fn get_choice_2d(&mut self, live: Mask<W>) -> (F32s<W>, F32s<W>, F32s<W>) {
        if !self.all_sobol(live) {
            let mut out = (F32s::default(), F32s::default(), F32s::default());
            for i in live.iter() {
                let (choice, u) = self.with(i, Sampler::get_choice_2d);
                (out.0[i], out.1[i], out.2[i]) = (choice, u.x, u.y);
            }
            return out;
        }
        crate::lanes::widest!(
            gfni;
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>) => (F32s<W>, F32s<W>, F32s<W>),
            (self, live),
            {
                let out = SobolLanes::at(lanes, 1).choice_2d();
                lanes.advance(live, 2);
                out
            }
        )
    }

    /// The 2D point of the next [`get_choice_2d`](Self::get_choice_2d) of the `live` lanes, its
    /// lobe choice left undrawn (for lanes whose surfaces have one lobe): the same numbers, and
    /// the samplers move on as they would, without the choice's share of the work (a third
    /// scramble and four table lookups per lane).
    #[inline(always)]
    pub fn get_choice_2d_point(&mut self, live: Mask<W>) -> (F32s<W>, F32s<W>) {
        if !self.all_sobol(live) {
            // Lanes of independent numbers draw the choice too: their generator is sequential.
            let (_, x, y) = self.get_choice_2d(live);
            return (x, y);
        }
        crate::lanes::widest!(
            gfni;
            W,
            (lanes: &mut SamplerLanes<W>, live: Mask<W>) => (F32s<W>, F32s<W>),
            (self, live),
            {
                let out = SobolLanes::at(lanes, 1).point_2d();
                lanes.advance(live, 2);
                out
            }
        )
    }

    /// Whether every `live` lane draws scrambled Sobol points.
    #[inline]
    fn all_sobol(&self, live: Mask<W>) -> bool {
        self.independent_lanes == 0 || live.iter().all(|i| self.kinds[i] == SamplerKind::Sobol)
    }

    /// Moves the `live` lanes `by` dimensions on, in SIMD lanes (the dimensions are then
    /// stored whole, and the next draw loads them whole: a load that spans several narrower
    /// stores waits for them to reach the cache).
    #[inline(always)]
    fn advance(&mut self, live: Mask<W>, by: u32) {
        self.dimension = U32s::select(live, self.dimension + U32s::splat(by), self.dimension);
    }
}

impl<const W: usize> Default for SamplerLanes<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// A wave's 2D points for scattering, drawn ahead by
/// [`SamplerLanes::get_2d_and_scatter_point`] (`None` where lanes draw independent numbers,
/// which are drawn in order when they are needed).
#[derive(Clone, Copy)]
pub struct ScatterPoint<const W: usize>(Option<(F32s<W>, F32s<W>)>);

/// The scrambled Sobol streams of a wave's lanes, at one dimension (pair) each: the values
/// [`Sampler`] computes for one lane, computed for W lanes at once with the same integer
/// operations (so with the same bits).
#[repr(C, align(64))]
struct SobolLanes<const W: usize> {
    /// [`Sampler::next_dimension_hash`] of each lane.
    hash: U64s<W>,
    /// Each lane's reversed sample index.
    reversed_index: U32s<W>,
}

impl<const W: usize> SobolLanes<W> {
    /// Every lane's Sobol stream of `lanes` at its next dimension + `skip`.
    #[inline(always)]
    fn at(lanes: &SamplerLanes<W>, skip: u32) -> Self {
        // A loop, not `from_fn`'s closure, which would not inline into the kernels compiled
        // for wider vectors.
        let dimension = lanes.dimension + U32s::splat(skip);
        let mut hash = U64s([0; W]);
        for ((h, &seed), &d) in hash.0.iter_mut().zip(&lanes.pixel_seed.0).zip(&dimension.0) {
            *h = u64::from(seed) << 32 | u64::from(d);
        }
        SobolLanes {
            hash,
            reversed_index: lanes.reversed_index,
        }
    }

    /// [`owen_sobol_2d_reversed`] in every lane.
    #[inline(always)]
    fn point_2d(&self) -> (F32s<W>, F32s<W>) {
        let (hash, shuffled) = self.hash_and_shuffled();
        owen_sobol_2d_lanes(shuffled, hash)
    }

    /// [`owen_sobol_x`] of the shuffled index in every lane: the number of
    /// [`Sampler::get_1d`].
    #[inline(always)]
    fn point_1d(&self) -> F32s<W> {
        let (hash, shuffled) = self.hash_and_shuffled();
        let x = laine_karras_lanes(shuffled, (hash >> 32).low_u32());
        to_unit_lanes(x.reverse_bits())
    }

    /// The lobe choice of [`choice_2d`](Self::choice_2d) alone.
    #[inline(always)]
    fn choice(&self) -> F32s<W> {
        let (hash, shuffled) = self.hash_and_shuffled();
        lobe_choice_lanes(shuffled, hash)
    }

    /// [`owen_sobol_3d_shuffled`] of the shuffled index in every lane: the lobe choice and the
    /// 2D point of [`Sampler::get_choice_2d`].
    #[inline(always)]
    fn choice_2d(&self) -> (F32s<W>, F32s<W>, F32s<W>) {
        let (hash, shuffled) = self.hash_and_shuffled();
        let (x, y) = owen_sobol_2d_lanes(shuffled, hash);
        (lobe_choice_lanes(shuffled, hash), x, y)
    }

    /// Every lane's dimension hash ([`mix64`] of its key) and its sample index shuffled by that
    /// hash (bits in natural order): what each of the points above starts from.
    #[inline(always)]
    fn hash_and_shuffled(&self) -> (U64s<W>, U32s<W>) {
        let hash = mix64_lanes(self.hash);
        let shuffled = laine_karras_lanes(self.reversed_index, hash.low_u32()).reverse_bits();
        (hash, shuffled)
    }
}

/// The lobe choice (third Sobol dimension, scrambled) of [`owen_sobol_3d_shuffled`] in every
/// lane, from the lanes' shuffled indices and dimension hashes.
#[inline(always)]
fn lobe_choice_lanes<const W: usize>(shuffled: U32s<W>, hash: U64s<W>) -> F32s<W> {
    let seed_z = lowbias32_lanes(scramble_seed_y_lanes(hash) ^ U32s::splat(0x9e37_79b9));
    to_unit_lanes(laine_karras_lanes(sobol_dim2_reversed_lanes(shuffled), seed_z).reverse_bits())
}

/// [`mix64`] in every lane.
#[inline(always)]
fn mix64_lanes<const W: usize>(z: U64s<W>) -> U64s<W> {
    let z = (z ^ (z >> 30)) * U64s::splat(0xbf58_476d_1ce4_e5b9);
    let z = (z ^ (z >> 27)) * U64s::splat(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// [`laine_karras`] in every lane.
#[inline(always)]
fn laine_karras_lanes<const W: usize>(v: U32s<W>, seed: U32s<W>) -> U32s<W> {
    let mut v = v ^ (v * U32s::splat(0x3d20_adea));
    v += seed;
    v *= (seed >> 16) | U32s::splat(1);
    v = v ^ (v * U32s::splat(0x0552_6c56));
    v ^ (v * U32s::splat(0x53a2_2864))
}

/// The integer hash of [`scramble_seed_y`] ("lowbias32") in every lane.
#[inline(always)]
fn lowbias32_lanes<const W: usize>(mut x: U32s<W>) -> U32s<W> {
    x = x ^ (x >> 16);
    x *= U32s::splat(0x7feb_352d);
    x = x ^ (x >> 15);
    x *= U32s::splat(0x846c_a68b);
    x ^ (x >> 16)
}

/// [`scramble_seed_y`] in every lane.
#[inline(always)]
fn scramble_seed_y_lanes<const W: usize>(hash: U64s<W>) -> U32s<W> {
    let high = (hash >> 32).low_u32();
    lowbias32_lanes(hash.low_u32() ^ ((high << 16) | (high >> 16)) ^ U32s::splat(0x63d8_3595))
}

/// [`owen_sobol_2d_shuffled`] in every lane.
#[inline(always)]
fn owen_sobol_2d_lanes<const W: usize>(shuffled: U32s<W>, hash: U64s<W>) -> (F32s<W>, F32s<W>) {
    let x = laine_karras_lanes(shuffled, (hash >> 32).low_u32());
    let y = laine_karras_lanes(
        sobol_dim1_reversed_lanes(shuffled),
        scramble_seed_y_lanes(hash),
    );
    (
        to_unit_lanes(x.reverse_bits()),
        to_unit_lanes(y.reverse_bits()),
    )
}

/// [`sobol_dim2_reversed`] in every lane.
#[inline(always)]
fn sobol_dim2_reversed_lanes<const W: usize>(i: U32s<W>) -> U32s<W> {
    // A loop, not `from_fn`'s closure, which would not inline into the kernels compiled for
    // wider vectors (closures do not inherit their target features).
    let mut out = U32s([0; W]);
    for (o, &i) in out.0.iter_mut().zip(&i.0) {
        *o = sobol_dim2_reversed(i);
    }
    out
}

/// [`to_unit`] in every lane.
#[inline(always)]
fn to_unit_lanes<const W: usize>(v: U32s<W>) -> F32s<W> {
    (v >> 8).cast_i32().to_f32() * F32s::splat(1.0 / 16_777_216.0)
}

/// The first two dimensions of the Sobol sequence (a (0, 2)-sequence in base 2), each
/// Owen-scrambled, with the sample order itself scrambled so that successive dimension pairs are
/// decorrelated: the construction of Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4),
/// 2020, with the Laine–Karras style hash permutation. `hash` (64 random bits) seeds the three
/// scrambles: of the index, of x and of y.
pub fn owen_sobol_2d(index: u32, hash: u64) -> glam::Vec2 {
    owen_sobol_2d_reversed(index.reverse_bits(), hash)
}

/// [`owen_sobol_2d`] given the bit-reversed index (a sampler reverses it once for all its
/// dimensions).
///
/// Bit reversals are the main cost here (x86-64 has no instruction for them), so the terms are
/// arranged to need three: the index scramble works on reversed bits and yields the shuffled
/// index reversed, which is reversed once; x = rev(LK(shuffled)) because dimension 0 is the
/// bit reversal of the index and the scramble works on reversed bits, so those two cancel; and
/// y = rev(LK(rev(sobol₁(shuffled)))) where the tables produce rev(sobol₁(·)) directly (the
/// reversal of an XOR of direction numbers is the XOR of the reversed numbers).
#[inline]
fn owen_sobol_2d_reversed(reversed_index: u32, hash: u64) -> glam::Vec2 {
    owen_sobol_2d_shuffled(shuffled_index(reversed_index, hash), hash)
}

/// [`owen_sobol_2d_reversed`] given the shuffled index.
#[inline(always)]
fn owen_sobol_2d_shuffled(shuffled: u32, hash: u64) -> glam::Vec2 {
    let x = laine_karras(shuffled, scramble_seed_x(hash));
    let y = laine_karras(sobol_dim1_reversed(shuffled), scramble_seed_y(hash));
    // Both reversed by one 64-bit reversal (which costs what a 32-bit one does): reversing
    // x·2³² + y gives rev(y)·2³² + rev(x).
    let both = (u64::from(x) << 32 | u64::from(y)).reverse_bits();
    glam::Vec2::new(to_unit(both as u32), to_unit((both >> 32) as u32))
}

/// Dimensions 2, 0 and 1 of the shuffled index, each Owen-scrambled (the third seeded by
/// [`scramble_seed_z`]): a lobe choice and a 2D point, [`Sampler::get_choice_2d`].
#[inline(always)]
fn owen_sobol_3d_shuffled(shuffled: u32, hash: u64) -> (f32, glam::Vec2) {
    let choice = laine_karras(sobol_dim2_reversed(shuffled), scramble_seed_z(hash)).reverse_bits();
    (to_unit(choice), owen_sobol_2d_shuffled(shuffled, hash))
}

/// The Owen-scrambled sample index (its nested uniform scramble, seeded by the low half of
/// `hash`), from the reversed index.
#[inline(always)]
fn shuffled_index(reversed_index: u32, hash: u64) -> u32 {
    laine_karras(reversed_index, hash as u32).reverse_bits()
}

/// Scrambled dimension 0 of the shuffled index (seeded by [`scramble_seed_x`]).
#[inline(always)]
fn owen_sobol_x(shuffled: u32, hash: u64) -> u32 {
    laine_karras(shuffled, scramble_seed_x(hash)).reverse_bits()
}

/// The seed of dimension 0's scramble: the high half of the hash (the low half seeds the index
/// scramble).
#[inline(always)]
fn scramble_seed_x(hash: u64) -> u32 {
    (hash >> 32) as u32
}

/// The seed of dimension 1's scramble: a third 32-bit value from the 64-bit hash (a bijective
/// integer hash, "lowbias32" of C. Wellons, of its two halves combined).
#[inline(always)]
fn scramble_seed_y(hash: u64) -> u32 {
    let mut x = (hash as u32) ^ ((hash >> 32) as u32).rotate_left(16) ^ 0x63d8_3595;
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The seed of dimension 2's scramble ([`Sampler::get_choice_2d`]): a fourth 32-bit value from
/// the hash, the same integer hash applied to dimension 1's seed.
#[inline(always)]
fn scramble_seed_z(hash: u64) -> u32 {
    let mut x = scramble_seed_y(hash) ^ 0x9e37_79b9;
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The top 24 bits of a 32-bit fixed-point value as a float in [0, 1) (exact, never 1).
#[inline(always)]
fn to_unit(v: u32) -> f32 {
    (v >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Sobol dimension 1, bit-reversed: rev(sobol₁(i)). Dimension 1 has the direction numbers
/// vₖ = vₖ₋₁ ⊕ (vₖ₋₁ ≫ 1), v₀ = 2³¹, so reversed they are the rows of Pascal's triangle mod 2
/// (bit j of rev vₖ is C(k, j) mod 2), and the XOR over the index's set bits is the product
/// with Pascal's matrix mod 2. By Lucas' theorem that matrix is, in halves, [[P, P], [0, P]]:
/// the low half of the result is the half-size matrix applied to low ⊕ high, the high half to
/// high. Five shift-and-XOR steps apply every level at once (the bit loop,
/// [`sobol_dim1_loop`], reversed, is the definition it is tested against).
#[inline]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let mut x = i;
    x ^= x >> 16;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 2) & 0x3333_3333;
    x ^ ((x >> 1) & 0x5555_5555)
}

/// [`sobol_dim1_reversed`] in every lane.
#[inline(always)]
fn sobol_dim1_reversed_lanes<const W: usize>(i: U32s<W>) -> U32s<W> {
    let mut x = i;
    x = x ^ (x >> 16);
    x = x ^ ((x >> 8) & U32s::splat(0x00ff_00ff));
    x = x ^ ((x >> 4) & U32s::splat(0x0f0f_0f0f));
    x = x ^ ((x >> 2) & U32s::splat(0x3333_3333));
    x ^ ((x >> 1) & U32s::splat(0x5555_5555))
}

/// Sobol dimension 2, bit-reversed: the XOR over the index's set bits of the reversed direction
/// numbers, a byte at a time by precomputed tables (identical to the bit loop at a fraction of
/// the cost for 32-bit scrambled indices).
#[inline]
fn sobol_dim2_reversed(i: u32) -> u32 {
    SOBOL2_TABLES[0][(i & 0xff) as usize]
        ^ SOBOL2_TABLES[1][((i >> 8) & 0xff) as usize]
        ^ SOBOL2_TABLES[2][((i >> 16) & 0xff) as usize]
        ^ SOBOL2_TABLES[3][(i >> 24) as usize]
}

/// The direction numbers of Sobol dimension 2, by index bit: primitive polynomial x² + x + 1
/// with initial numbers m = 1, 3 (Joe and Kuo 2008, the third dimension), so v₀ = 2³¹,
/// v₁ = 3·2³⁰ and vₖ = vₖ₋₁ ⊕ vₖ₋₂ ⊕ (vₖ₋₂ ≫ 2).
const fn sobol2_directions() -> [u32; 32] {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    v[1] = 3 << 30;
    let mut k = 2;
    while k < 32 {
        v[k] = v[k - 1] ^ v[k - 2] ^ (v[k - 2] >> 2);
        k += 1;
    }
    v
}

/// `SOBOL2_TABLES[b][x]`: XOR of the reversed direction numbers of dimension 2 of the set bits
/// of byte `x` at byte `b`.
static SOBOL2_TABLES: [[u32; 256]; 4] = reversed_byte_tables(&sobol2_directions());

/// For direction numbers `v` (index bit k ↦ v[k]): `[b][x]` = XOR of the reversed direction
/// numbers of the set bits of byte `x` at byte `b`, so a dimension's value for a 32-bit index is
/// four lookups.
const fn reversed_byte_tables(v: &[u32; 32]) -> [[u32; 256]; 4] {
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut x = 0;
        while x < 256 {
            let mut out = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if x & (1 << bit) != 0 {
                    out ^= v[8 * b + bit].reverse_bits();
                }
                bit += 1;
            }
            t[b][x] = out;
            x += 1;
        }
        b += 1;
    }
    t
}

/// Bit-by-bit Sobol dimension 1 (the definition; kept to test the tables against).
#[cfg(test)]
fn sobol_dim1_loop(mut i: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut out = 0;
    while i != 0 {
        if i & 1 != 0 {
            out ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    out
}

/// The hash permutation of Laine and Karras (2011) on bit-reversed values: each output bit
/// depends only on the same and lower input bits, so applied to reversed bits it is a nested
/// uniform (Owen) scramble — a random permutation of each subinterval that depends on all
/// higher bits.
#[inline]
fn laine_karras(mut v: u32, seed: u32) -> u32 {
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wave's samplers draw, lane by lane, what each lane's own sampler draws, bit for bit,
    /// and lanes left out of a draw neither draw nor move on.
    fn check_lanes<const W: usize>(kind: SamplerKind) {
        let mut lanes = SamplerLanes::<W>::new();
        let mut single: [Sampler; W] =
            std::array::from_fn(|i| Sampler::with_kind(kind, 7, 1000 + i as u64, 3 * i as u64));
        for (i, s) in single.iter().enumerate() {
            lanes.set(i, *s);
        }
        for step in 0..24 {
            let live: [bool; W] = std::array::from_fn(|i| (i + step) % 3 != 0);
            let (x, y) = lanes.get_2d(Mask::from_bools(&live));
            let (c, cx, cy) = lanes.get_choice_2d(Mask::from_bools(&live));
            for i in (0..W).filter(|&i| live[i]) {
                let u = single[i].get_2d();
                let (choice, v) = single[i].get_choice_2d();
                let bits = |a: f32, b: f32| assert_eq!(a.to_bits(), b.to_bits(), "lane {i}");
                bits(x[i], u.x);
                bits(y[i], u.y);
                bits(c[i], choice);
                bits(cx[i], v.x);
                bits(cy[i], v.y);
            }
            let drawn: [bool; W] = std::array::from_fn(|i| (i + 2 * step) % 5 < 3);
            let r = lanes.get_1d(Mask::from_bools(&drawn));
            for i in (0..W).filter(|&i| drawn[i]) {
                assert_eq!(r[i].to_bits(), single[i].get_1d().to_bits(), "lane {i}");
            }
            let pointing: [bool; W] = std::array::from_fn(|i| (i + 3 * step) % 4 != 0);
            let (px, py) = lanes.get_choice_2d_point(Mask::from_bools(&pointing));
            for i in (0..W).filter(|&i| pointing[i]) {
                let (_, v) = single[i].get_choice_2d();
                assert_eq!(px[i].to_bits(), v.x.to_bits(), "lane {i}");
                assert_eq!(py[i].to_bits(), v.y.to_bits(), "lane {i}");
            }
            // A light point and the scatter point drawn ahead, then the scatter draw of some
            // of those lanes, with and without the lobe choice.
            let ((lx, ly), ahead) = lanes.get_2d_and_scatter_point(Mask::from_bools(&live));
            let scattering: [bool; W] = std::array::from_fn(|i| live[i] && (i + step) % 2 == 0);
            let with_choice = step % 3 != 1;
            let (c, sx, sy) =
                lanes.get_choice_2d_from(Mask::from_bools(&scattering), ahead, with_choice);
            for i in (0..W).filter(|&i| live[i]) {
                let u = single[i].get_2d();
                assert_eq!(
                    (lx[i].to_bits(), ly[i].to_bits()),
                    (u.x.to_bits(), u.y.to_bits())
                );
                if scattering[i] {
                    let (choice, v) = single[i].get_choice_2d();
                    let choice = if with_choice { choice } else { 0.0 };
                    assert_eq!(c[i].to_bits(), choice.to_bits(), "lane {i}");
                    assert_eq!(
                        (sx[i].to_bits(), sy[i].to_bits()),
                        (v.x.to_bits(), v.y.to_bits())
                    );
                }
            }
            let skipping: [bool; W] = std::array::from_fn(|i| (i + step) % 4 == 1);
            lanes.skip_2d(Mask::from_bools(&skipping));
            for i in (0..W).filter(|&i| skipping[i]) {
                single[i].skip_2d();
            }
            let rr = step % W;
            let u = lanes.with(rr, Sampler::get_1d);
            assert_eq!(u.to_bits(), single[rr].get_1d().to_bits());
            for (i, s) in single.iter_mut().enumerate() {
                assert_eq!(
                    lanes.get(i).get_1d().to_bits(),
                    {
                        let mut copy = *s;
                        copy.get_1d()
                    }
                    .to_bits()
                );
            }
        }
    }

    /// A wave whose lanes draw from both kinds of stream, lanes changing kind as new samples
    /// take them, still gives each lane its own stream's numbers.
    fn check_mixed_lanes<const W: usize>() {
        let kind = |n: usize| {
            if n.is_multiple_of(3) {
                SamplerKind::Independent
            } else {
                SamplerKind::Sobol
            }
        };
        let mut lanes = SamplerLanes::<W>::new();
        let mut single: [Sampler; W] =
            std::array::from_fn(|i| Sampler::with_kind(kind(i), 5, 40 + i as u64, i as u64));
        for (i, s) in single.iter().enumerate() {
            lanes.set(i, *s);
        }
        let all = Mask::splat(true);
        for step in 0..3 * W {
            // A new sample in one lane, of the other kind every third step.
            let i = step % W;
            single[i] = Sampler::with_kind(kind(i + step / W), 5, 40 + i as u64, step as u64);
            lanes.set(i, single[i]);
            let (x, _) = lanes.get_2d(all);
            let r = lanes.get_1d(all);
            for (i, s) in single.iter_mut().enumerate() {
                assert_eq!(
                    x[i].to_bits(),
                    s.get_2d().x.to_bits(),
                    "step {step}, lane {i}"
                );
                assert_eq!(
                    r[i].to_bits(),
                    s.get_1d().to_bits(),
                    "step {step}, lane {i}"
                );
            }
        }
    }

    #[test]
    fn sampler_lanes_of_mixed_kinds_draw_each_lanes_numbers() {
        check_mixed_lanes::<4>();
        check_mixed_lanes::<8>();
        check_mixed_lanes::<16>();
    }

    /// On a CPU with GFNI the other tests' 16-lane draws run the copies that use it (unless
    /// this test has already run in the process); the copies without it draw the same numbers.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn sampler_lanes_without_gfni_draw_each_lanes_numbers() {
        crate::lanes::forget_gfni();
        assert!(!crate::lanes::has_gfni());
        for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
            check_lanes::<16>(kind);
        }
        check_mixed_lanes::<16>();
    }

    #[test]
    fn sampler_lanes_draw_each_lanes_numbers() {
        for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
            check_lanes::<1>(kind);
            check_lanes::<4>(kind);
            check_lanes::<8>(kind);
            check_lanes::<16>(kind);
        }
    }

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::independent(1, 2, 3), |s, _| Some(s.get_1d()))
            .collect();
        let b: Vec<f32> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::independent(1, 2, 3), |s, _| Some(s.get_1d()))
            .collect();
        let c: Vec<f32> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::independent(1, 2, 4), |s, _| Some(s.get_1d()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn a_skipped_point_leaves_the_later_numbers_as_they_were() {
        for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
            for sample in 0..64 {
                let mut drawn = Sampler::with_kind(kind, 7, 11, sample);
                let mut skipped = drawn;
                let first = drawn.get_2d();
                let later = (drawn.get_2d(), drawn.get_choice_2d(), drawn.get_1d());
                skipped.skip_2d();
                assert_eq!(
                    (skipped.get_2d(), skipped.get_choice_2d(), skipped.get_1d()),
                    later,
                    "{kind:?}, sample {sample}"
                );
                assert_ne!(first, later.0);
            }
        }
    }

    /// Owen-scrambled Sobol points are stratified: any 2^k points of a power-of-two prefix put
    /// exactly one point in each cell of every 2^a × 2^b grid with a + b = k (elementary
    /// intervals), and integrate a smooth function far better than random points.
    #[test]
    fn sobol_points_are_stratified_and_integrate_well() {
        let n = 256u32;
        for seed in [1u64, 99, 12345] {
            let pts: Vec<glam::Vec2> = (0..n).map(|i| owen_sobol_2d(i, mix64(seed))).collect();
            for a in 0..=8 {
                let (nx, ny) = (1u32 << a, 1u32 << (8 - a));
                let mut cells = vec![0u32; (nx * ny) as usize];
                for p in &pts {
                    cells[((p.y * ny as f32) as u32 * nx + (p.x * nx as f32) as u32) as usize] += 1;
                }
                assert!(
                    cells.iter().all(|&c| c == 1),
                    "seed {seed}: {nx}×{ny} grid not stratified"
                );
            }
            let f = |p: &glam::Vec2| (p.x * 3.0).sin() * (p.y * 2.0).cos() + p.x * p.y;
            let exact = (1.0 - 3f32.cos()) / 3.0 * (2f32.sin() / 2.0) + 0.25;
            let est: f32 = pts.iter().map(f).sum::<f32>() / n as f32;
            assert!((est - exact).abs() < 2e-3, "seed {seed}: {est} vs {exact}");
        }
    }

    /// Through the sampler, a pixel's samples are stratified in every 1D and 2D dimension the
    /// integrator draws (one stream per sample index, dimensions in order).
    #[test]
    fn sampler_dimensions_are_stratified_across_a_pixels_samples() {
        let n = 256u64;
        let mut samplers: Vec<Sampler> = (0..n)
            .map(|i| Sampler::with_kind(SamplerKind::Sobol, 3, 41, i))
            .collect();
        for dim in 0..6 {
            if dim % 2 == 0 {
                let mut cells = vec![0u32; n as usize];
                for s in &mut samplers {
                    cells[(s.get_1d() * n as f32) as usize] += 1;
                }
                assert!(
                    cells.iter().all(|&c| c == 1),
                    "1D dimension {dim} not stratified"
                );
            } else {
                let mut cells = vec![0u32; n as usize];
                for s in &mut samplers {
                    let p = s.get_2d();
                    cells[(p.y * 16.0) as usize * 16 + (p.x * 16.0) as usize] += 1;
                }
                assert!(
                    cells.iter().all(|&c| c == 1),
                    "2D dimension {dim} not stratified"
                );
            }
        }
    }

    /// Dimension 1 by shifts equals the definition: on every single-bit index (it is linear
    /// over GF(2), so these decide every index), random ones, and in lanes.
    #[test]
    fn sobol_dimension_1_equals_the_definition() {
        let mut r = Pcg32::new(4, 4);
        let indices: Vec<u32> = (0..32)
            .map(|k| 1u32 << k)
            .chain((0..5000).map(|_| r.next_u32()))
            .chain([0, 3, u32::MAX])
            .collect();
        for &i in &indices {
            assert_eq!(
                sobol_dim1_reversed(i),
                sobol_dim1_loop(i).reverse_bits(),
                "index {i}"
            );
        }
        for chunk in indices.chunks_exact(16) {
            let lanes = sobol_dim1_reversed_lanes(U32s::<16>(std::array::from_fn(|l| chunk[l])));
            for (l, &i) in chunk.iter().enumerate() {
                assert_eq!(lanes.0[l], sobol_dim1_reversed(i), "index {i}");
            }
        }
    }

    /// A pixel's (choice, 2D point) draws are one Owen-scrambled 3D Sobol point per sample:
    /// 1,024 samples form a (1, 3)-net (every box of 2^a × 2^b × 2^c cells with a + b + c = 9
    /// holds exactly two points; dimension 2's direction numbers are those of x² + x + 1), the
    /// 2D part is exactly what `get_2d` gives after a `get_1d`, and with independent numbers the
    /// three are those of `get_1d` and `get_2d`.
    /// 1,024 points (choice, 2D point) stratified as a (1, 3)-net in base 2 is: every box
    /// of 2ᵃ × 2ᵇ × 2ᶜ cells, a + b + c = 9, holds two.
    fn assert_stratified_1024(pts: &[(f32, glam::Vec2)], what: &str) {
        assert_eq!(pts.len(), 1024);
        for a in 0..=9 {
            for b in 0..=9 - a {
                let c = 9 - a - b;
                let (na, nb, nc) = (1usize << a, 1usize << b, 1usize << c);
                let mut cells = vec![0u32; 512];
                for (z, p) in pts {
                    let (i, j, k) = (
                        (p.x * na as f32) as usize,
                        (p.y * nb as f32) as usize,
                        (z * nc as f32) as usize,
                    );
                    cells[(k * nb + j) * na + i] += 1;
                }
                assert!(
                    cells.iter().all(|&c| c == 2),
                    "{what}: {na}×{nb}×{nc} boxes not stratified"
                );
            }
        }
    }

    #[test]
    fn choice_and_direction_are_one_3d_sobol_point() {
        let n = 1024u64;
        for pixel in [7u64, 4242] {
            let pts: Vec<(f32, glam::Vec2)> = (0..n)
                .map(|i| Sampler::with_kind(SamplerKind::Sobol, 3, pixel, i).get_choice_2d())
                .collect();
            assert_stratified_1024(&pts, &format!("pixel {pixel}"));
            for i in 0..64 {
                let mut old = Sampler::with_kind(SamplerKind::Sobol, 3, pixel, i);
                old.get_1d();
                assert_eq!(old.get_2d(), pts[i as usize].1);
                let (mut a, mut b) = (
                    Sampler::independent(3, pixel, i),
                    Sampler::independent(3, pixel, i),
                );
                let (choice, p) = a.get_choice_2d();
                assert_eq!((choice, p), (b.get_1d(), b.get_2d()));
            }
        }
    }

    /// Padded draws: over N pixel samples the n·N points of `get_choice_2d_padded` (n = 4, 8)
    /// are stratified as 1,024 consecutive points of the 3D sequence are (every box of volume
    /// 2⁻⁹ holds two), and with independent numbers they are the next 3n numbers.
    #[test]
    fn padded_choices_are_one_stratified_set() {
        for (count, n) in [(4usize, 256u64), (8, 128)] {
            for pixel in [7u64, 4242] {
                let mut pts = Vec::new();
                for i in 0..n {
                    let mut out = vec![(0.0f32, glam::Vec2::ZERO); count];
                    Sampler::with_kind(SamplerKind::Sobol, 3, pixel, i)
                        .get_choice_2d_padded(&mut out);
                    pts.extend(out);
                }
                assert_stratified_1024(&pts, &format!("{count} per sample, pixel {pixel}"));
            }
            let (mut a, mut b) = (Sampler::independent(3, 9, 5), Sampler::independent(3, 9, 5));
            let mut out = vec![(0.0f32, glam::Vec2::ZERO); count];
            a.get_choice_2d_padded(&mut out);
            for o in out {
                assert_eq!(o, (b.get_1d(), b.get_2d()));
            }
        }
    }

    #[test]
    fn sobol_dimension_2_tables_equal_the_definition() {
        let loop_def = |mut i: u32| {
            let mut out = 0u32;
            let mut k = 0;
            while i != 0 {
                if i & 1 != 0 {
                    out ^= sobol2_directions()[k];
                }
                i >>= 1;
                k += 1;
            }
            out
        };
        // The first points of the unscrambled dimension: 0, 1/2, 3/4, 1/4, 3/8.
        let first: Vec<u32> = (0..5).map(loop_def).collect();
        assert_eq!(first, [0, 1 << 31, 3 << 30, 1 << 30, 3 << 29]);
        let mut r = Pcg32::new(4, 5);
        for i in (0..5000).map(|_| r.next_u32()).chain([0, 1, u32::MAX]) {
            assert_eq!(
                sobol_dim2_reversed(i),
                loop_def(i).reverse_bits(),
                "index {i}"
            );
        }
    }

    #[test]
    fn sobol_streams_are_decorrelated_across_dimensions() {
        // Successive dimension pairs of one pixel must not repeat the same points.
        let mut s = Sampler::with_kind(SamplerKind::Sobol, 5, 17, 3);
        let a = s.get_2d();
        let b = s.get_2d();
        assert_ne!(a, b);
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Pcg32::new(9, 1);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += f64::from(x);
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
    }
}
