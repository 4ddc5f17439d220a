//! Random numbers for rendering. Every (seed, pixel, sample) triple owns an independent stream,
//! so an image does not depend on how pixels are spread over threads.

/// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
/// Algorithms for Random Number Generation"): 64-bit LCG state, XSH-RR output.
#[derive(Debug, Clone)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator on stream `stream` starting from `seed`.
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 { state: 0, inc: (stream << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
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

/// The sample stream of one pixel sample.
#[derive(Debug, Clone)]
pub struct Sampler {
    rng: Pcg32,
}

impl Sampler {
    /// The stream for sample `sample` of pixel `pixel` under `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Sampler {
        let key = mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        Sampler { rng: Pcg32::new(mix64(key ^ sample), key) }
    }

    /// One uniform number in [0, 1).
    #[inline]
    pub fn get_1d(&mut self) -> f32 {
        self.rng.next_f32()
    }

    /// Two uniform numbers in [0, 1)².
    #[inline]
    pub fn get_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.rng.next_f32(), self.rng.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = (0..4).map(|_| 0.0).scan(Sampler::new(1, 2, 3), |s, _| Some(s.get_1d())).collect();
        let b: Vec<f32> = (0..4).map(|_| 0.0).scan(Sampler::new(1, 2, 3), |s, _| Some(s.get_1d())).collect();
        let c: Vec<f32> = (0..4).map(|_| 0.0).scan(Sampler::new(1, 2, 4), |s, _| Some(s.get_1d())).collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
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
