//! Adaptive sampling, as Blender's Render › Sampling › Noise Threshold:
//! a pixel stops taking samples once its noise is below the threshold, and
//! the samples go where the noise is.
//!
//! Cycles' stopping rule (its "A hierarchical automatic stopping condition
//! for Monte Carlo global illumination", applied per pixel), so that one
//! threshold means the same in both renderers: besides the sum I of a
//! pixel's N samples, the film keeps the sum of the n of them in one half
//! (`rng::in_first_half`: each half spread over the pixel as the whole
//! is), and A = N/n · that sum is a second estimate of I from those alone
//! (Cycles' is 2 · the sum: its halves are equal).
//! The pixel's error is
//!
//!   Σ_rgb |I − A| / N  /  (10⁻⁴ + n),   n = √(Σ_rgb I/N) below 1, else Σ_rgb I/N,
//!
//! a difference of two half-estimates over a tone-mapping-like weight
//! (dark pixels' noise shows more, overexposed ones' less), and the pixel
//! has converged where it is below 5 × the threshold (Cycles' scale). The
//! check runs every `STEP` samples once the minimum is in; a pixel
//! that has not converged keeps its eight neighbours sampling too (Cycles'
//! filter in x then y), which catches the edge of a noisy patch whose own
//! estimate happened to agree.
//!
//! Stopping where an estimate says the noise is low is not unbiased: a
//! pixel whose rare bright paths (a caustic, a firefly) none of its first
//! samples met stops without them. The minimum samples bound that, as in
//! Cycles; a fixed sample count (threshold off) is the unbiased render.

use crate::Vec3;

/// Samples between two convergence checks, as Cycles'.
pub const STEP: u32 = 16;

/// Cycles' factor between the Noise Threshold a user sets and the error
/// bound the check applies.
const THRESHOLD_SCALE: f32 = 5.0;

/// The settings: Noise Threshold and Min Samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// Noise Threshold (> 0; Cycles' default is 0.01).
    pub threshold: f32,
    /// Samples every pixel takes before the first check; 0: from the
    /// threshold, as Cycles chooses them.
    pub min_samples: u32,
}

impl Adaptive {
    /// The samples before the first check: as set (at least 4), else
    /// Cycles' automatic choice, ⌈16 / threshold^0.3⌉ and at least 4
    /// (0.1 → 32, 0.01 → 64, 0.001 → 128).
    pub fn min_samples(&self) -> u32 {
        if self.min_samples > 0 {
            return self.min_samples.max(4);
        }
        let auto = (16.0 / self.threshold.powf(0.3)).ceil();
        if auto.is_finite() { (auto as u32).max(4) } else { 4 }
    }

    /// The sample count at which the next check after `done` samples
    /// runs: the multiples of `STEP` from the minimum on, as Cycles', so
    /// that the samples between two checks are an aligned block, which the
    /// two halves (`rng::in_first_half`) share evenly.
    pub fn next_check(&self, done: u32) -> u32 {
        // Saturating: a minimum near u32::MAX (a threshold of 1e-30, or
        // so many Min Samples) had wrapped to 0, and a pass of no samples
        // had left the render looping for ever.
        self.min_samples().max(done.saturating_add(1)).div_ceil(STEP).saturating_mul(STEP)
    }

    /// Whether a check runs once `done` samples are in.
    pub fn checks_at(&self, done: u32) -> bool {
        done >= self.min_samples() && done.is_multiple_of(STEP)
    }
}

/// What the film keeps beside its sums for adaptive sampling.
#[derive(Clone, Debug)]
pub struct Convergence {
    /// Per pixel, the sum of its samples of the first half
    /// (`rng::in_first_half`).
    pub half: Vec<Vec3>,
    /// Per pixel, how many samples of the first half it has.
    pub in_half: Vec<u32>,
    /// Per pixel, the samples it has taken.
    pub counts: Vec<u32>,
    /// Per pixel, whether it still takes samples.
    pub active: Vec<bool>,
}

impl Convergence {
    /// For a film of `pixels` that has `samples` samples of every pixel
    /// already (0 for a new one), whose halves it does not know.
    pub fn new(pixels: usize, samples: u32) -> Self {
        Convergence { half: crate::memory::zeroed_vec3s(pixels), in_half: vec![0; pixels], counts: vec![samples; pixels], active: vec![true; pixels] }
    }

    /// Checks every pixel against `threshold` (`Adaptive::threshold`),
    /// given the film's sums, and keeps sampling those that have not
    /// converged and their neighbours. Returns the pixels still sampling.
    pub fn check(&mut self, sum: &[Vec3], width: u32, height: u32, threshold: f32) -> usize {
        let (w, h) = (width as usize, height as usize);
        let bound = threshold * THRESHOLD_SCALE;
        let noisy: Vec<bool> = (0..w * h).map(|p| self.active[p] && pixel_error(sum[p], self.half[p], self.counts[p], self.in_half[p]) >= bound).collect();
        // A noisy pixel keeps its 3 × 3 neighbourhood sampling.
        let mut across = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                across[p] = noisy[p] || (x > 0 && noisy[p - 1]) || (x + 1 < w && noisy[p + 1]);
            }
        }
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                self.active[p] = across[p] || (y > 0 && across[p - w]) || (y + 1 < h && across[p + w]);
            }
        }
        self.active.iter().filter(|a| **a).count()
    }

    /// Samples taken over all pixels.
    pub fn total_samples(&self) -> u64 {
        self.counts.iter().map(|&c| c as u64).sum()
    }
}

/// A pixel's error by Cycles' rule (module docs): `sum` of its `n`
/// samples, `half` of the `n_half` of them in the first half. A pixel
/// whose samples are all in one half has no second estimate: it has not
/// converged.
pub fn pixel_error(sum: Vec3, half: Vec3, n: u32, n_half: u32) -> f32 {
    if n_half == 0 || n_half >= n {
        return f32::INFINITY;
    }
    let inv = 1.0 / n as f32;
    let difference = (sum - half * (n as f32 / n_half as f32)).abs().element_sum() * inv;
    let intensity = sum.element_sum() * inv;
    // Negative sums (none from a path tracer) would make the root NaN.
    let normalize = if intensity < 1.0 { intensity.max(0.0).sqrt() } else { intensity };
    difference / (1e-4 + normalize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_samples_follow_cycles() {
        let auto = |threshold| Adaptive { threshold, min_samples: 0 }.min_samples();
        assert_eq!((auto(0.1), auto(0.01), auto(0.001)), (32, 64, 128));
        assert_eq!(Adaptive { threshold: 0.01, min_samples: 2 }.min_samples(), 4);
        assert_eq!(Adaptive { threshold: 0.01, min_samples: 10 }.min_samples(), 10);
        assert_eq!(auto(1e-30), (16.0f32 / 1e-30f32.powf(0.3)).ceil() as u32);
    }

    #[test]
    fn checks_run_from_the_minimum_every_step() {
        let a = Adaptive { threshold: 0.01, min_samples: 10 };
        assert_eq!((a.next_check(0), a.next_check(9), a.next_check(15), a.next_check(16), a.next_check(31), a.next_check(32)), (16, 16, 16, 32, 32, 48));
        let checks: Vec<u32> = (0..70).filter(|&n| a.checks_at(n)).collect();
        assert_eq!(checks, [16, 32, 48, 64]);
        // 0.02: 52 samples first, the check at 64.
        let a = Adaptive { threshold: 0.02, min_samples: 0 };
        assert_eq!((a.min_samples(), a.next_check(0), a.next_check(64)), (52, 64, 80));
        assert!(!a.checks_at(48) && a.checks_at(64));
        // A minimum past the last multiple of STEP: the next check is
        // still ahead of every count done, never wrapped round to 0.
        for a in [Adaptive { threshold: 1e-30, min_samples: 0 }, Adaptive { threshold: 0.01, min_samples: u32::MAX }] {
            for done in [0, 1, 4096, u32::MAX - 17, u32::MAX - 1] {
                assert!(a.next_check(done) > done, "{a:?} after {done}: {}", a.next_check(done));
            }
        }
    }

    #[test]
    fn error_is_the_halves_difference_over_the_weight() {
        // Halves that agree: no error, whatever the brightness.
        assert_eq!(pixel_error(Vec3::splat(8.0), Vec3::splat(4.0), 8, 4), 0.0);
        // Unequal halves: each weighed by its count.
        assert_eq!(pixel_error(Vec3::splat(8.0), Vec3::splat(3.0), 8, 3), 0.0);
        // Dim: the difference over the root of the mean intensity.
        let e = pixel_error(Vec3::new(0.8, 0.0, 0.0), Vec3::new(0.3, 0.0, 0.0), 8, 4);
        let expected = (0.2 / 8.0) / (1e-4 + (0.1f32).sqrt());
        assert!((e - expected).abs() < 1e-6 * expected, "{e} vs {expected}");
        // Bright: over the mean intensity itself.
        let e = pixel_error(Vec3::splat(30.0), Vec3::new(16.0, 15.0, 15.0), 10, 5);
        assert!((e - 0.2 / (1e-4 + 9.0)).abs() < 1e-6, "{e}");
        for (n, n_half) in [(0, 0), (8, 0), (8, 8)] {
            assert_eq!(pixel_error(Vec3::ONE, Vec3::ONE, n, n_half), f32::INFINITY);
        }
        assert!(pixel_error(Vec3::splat(-1.0), Vec3::ZERO, 4, 2).is_finite());
    }

    #[test]
    fn a_noisy_pixel_keeps_its_neighbours_sampling() {
        let (w, h) = (5u32, 4u32);
        let mut c = Convergence::new((w * h) as usize, 0);
        c.counts.fill(8);
        c.in_half.fill(4);
        // Every pixel's halves agree but (3, 1)'s.
        let mut sum = vec![Vec3::splat(0.8); 20];
        c.half.fill(Vec3::splat(0.4));
        let noisy = 5 + 3; // (3, 1)
        sum[noisy] = Vec3::splat(1.6);
        assert_eq!(c.check(&sum, w, h, 0.01), 9);
        for y in 0..4 {
            for x in 0..5 {
                assert_eq!(c.active[y * 5 + x], (2..=4).contains(&x) && y <= 2, "({x}, {y})");
            }
        }
        // Once the noise is gone everything stops; a stopped pixel stays so.
        sum[noisy] = Vec3::splat(0.8);
        assert_eq!(c.check(&sum, w, h, 0.01), 0);
        sum[0] = Vec3::splat(5.0);
        assert_eq!(c.check(&sum, w, h, 0.01), 0);
    }
}
