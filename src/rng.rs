//! Small, fast, reproducible random numbers (PCG32, O'Neill 2014).
//!
//! Every pixel sample gets its own generator seeded from (seed, pixel, sample
//! index), so an image does not depend on how work is split between threads
//! or passes.

use glam::Vec2;

#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

impl Rng {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Rng { state: 0, inc: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The generator for one sample of one pixel.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        Rng::new(mix64(seed ^ mix64(sample)), pixel)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1): 24 random bits, so 1.0 is never returned.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// SplitMix64 finaliser: decorrelates nearby seeds.
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_in_unit_interval_with_right_mean() {
        let mut rng = Rng::new(7, 3);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        // Standard error of the mean of U(0,1) is 1/sqrt(12 n) = 6.5e-4; allow 5 sigma.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * 6.5e-4);
    }

    #[test]
    fn same_inputs_same_stream_different_pixels_differ() {
        let a: Vec<u32> = (0..8).map({ let mut r = Rng::for_sample(1, 10, 0); move |_| r.next_u32() }).collect();
        let b: Vec<u32> = (0..8).map({ let mut r = Rng::for_sample(1, 10, 0); move |_| r.next_u32() }).collect();
        let c: Vec<u32> = (0..8).map({ let mut r = Rng::for_sample(1, 11, 0); move |_| r.next_u32() }).collect();
        let d: Vec<u32> = (0..8).map({ let mut r = Rng::for_sample(1, 10, 1); move |_| r.next_u32() }).collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
    }
}
