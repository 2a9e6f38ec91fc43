//! Sampling routines and the local shading frame. Local frame: the normal is +z.

use glam::Vec2;
use crate::Vec3;
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};

/// An orthonormal basis (t, b, n) around a unit normal n (Duff et al.
/// 2017, branchless), kept as the rows of the matrix whose columns are t,
/// b and n: a shading point turns directions into its frame several times
/// (light sample, connections, reverse pdfs) and out of it once, and with
/// rows `to_local` is three lane-wise products and two sums instead of
/// three dot products, with the same sums in the same order.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    rows: [Vec3; 3],
}

impl Frame {
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        // t = (1 + s·x²·a, s·b, −s·x), b = (b, s + y²·a, −y).
        Frame {
            rows: [
                Vec3::new(1.0 + sign * n.x * n.x * a, b, n.x),
                Vec3::new(sign * b, sign + n.y * n.y * a, n.y),
                Vec3::new(-sign * n.x, -n.y, n.z),
            ],
        }
    }

    /// (v·t, v·b, v·n).
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        let [x, y, z] = self.rows;
        x * v.x + y * v.y + z * v.z
    }

    /// t·v.x + b·v.y + n·v.z.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        let [x, y, z] = self.rows;
        Vec3::new(x.dot(v), y.dot(v), z.dot(v))
    }
}

/// Shirley-Chiu concentric map from the unit square to the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // θ = φ or π/2 − φ with |φ| ≤ π/4, where cos and sin swap.
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// A point uniform on the disk of radius `r` about `centre`, square to
/// unit `axis` (a sized light's, or a sun's disk of starts).
pub fn disk_point(centre: Vec3, axis: Vec3, r: f32, u: Vec2) -> Vec3 {
    centre + Frame::from_normal(axis).to_world(Vec3::from((concentric_disk(u) * r).extend(0.0)))
}

/// sin and cos of |x| ≤ π/4 to within 1e-7, by polynomials fitted on that
/// interval: libm's `sincosf` reduces any angle first, which was 1.5% of a
/// render's time by perf's clock samples (every diffuse bounce draws a
/// disk point).
#[inline]
fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = x + x * z * (-1.666_666_4e-1 + z * (8.332_748e-3 + z * -1.958_786_6e-4));
    let cos = 1.0 - 0.5 * z + z * z * (4.166_660_5e-2 + z * (-1.388_447_6e-3 + z * 2.405_160_2e-5));
    (sin, cos)
}

/// Cosine-weighted direction on the +z hemisphere; pdf = cos θ / π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// 1 − cosθ (a cone's solid angle / 2π), formed as 2 sin²(θ/2) so that a
/// cone of 0.01° is not lost to rounding.
pub fn one_minus_cos(theta: f32) -> f32 {
    let h = (0.5 * theta).sin();
    2.0 * h * h
}

/// Solid-angle density of a direction drawn uniformly in a cone whose
/// 1 − cosθmax is `one_minus_cos`.
pub fn cone_pdf(one_minus_cos: f32) -> f32 {
    1.0 / (2.0 * std::f32::consts::PI * one_minus_cos)
}

/// A direction uniformly in the cone about unit `axis` whose 1 − cosθmax
/// is `one_minus_cos`: its sine from 1 − cosθ, which keeps a narrow
/// cone's.
pub fn cone_sample_within(axis: Vec3, one_minus_cos: f32, u: Vec2) -> Vec3 {
    cone_sample_in(&Frame::from_normal(axis), one_minus_cos, u)
}

/// `cone_sample_within` about the normal of `frame`, where the frame is
/// kept (a sun's, `SunDisk`).
pub fn cone_sample_in(frame: &Frame, one_minus_cos: f32, u: Vec2) -> Vec3 {
    frame.to_world(cone_local(one_minus_cos, u)).normalize()
}

/// `cone_sample_in` about the opposite of `frame`'s normal. The frame
/// `from_normal` makes about −n is the one about n with its second and
/// third axes negated, to the bit (each of its numbers is formed from
/// −n's by the same operations, signs aside), so the direction is the one
/// `cone_sample_within(−n, …)` draws.
pub fn cone_sample_opposite(frame: &Frame, one_minus_cos: f32, u: Vec2) -> Vec3 {
    frame.to_world(cone_local(one_minus_cos, u) * Vec3::new(1.0, -1.0, -1.0)).normalize()
}

/// A direction uniformly in the cone about +z whose 1 − cosθmax is
/// `one_minus_cos`.
#[inline]
fn cone_local(one_minus_cos: f32, u: Vec2) -> Vec3 {
    // 1 − cosθ uniform in [0, 1 − cosθmax].
    let omc = u.x * one_minus_cos;
    let sin_t = (omc * (2.0 - omc)).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - omc)
}

/// Uniform direction on the unit sphere; pdf = 1/(4π).
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = (2.0 * std::f32::consts::PI * u.y).sin_cos();
    Vec3::new(r * cos, r * sin, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    // Times 1/π: a division by π is not folded into a product (its
    // rounding differs), and a diffuse bounce's pdf waited on it.
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform barycentrics (b1, b2) on a triangle; b0 = 1 − b1 − b2.
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// A discrete distribution over items by weight, sampled by binary search of
/// the cumulative sum; over many items the search starts from a guide
/// table (the cutpoint method), which finds the same item.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    cdf: Vec<f64>,
    total: f64,
    /// guide[k], k = 0..=M: the first item whose cumulative sum passes
    /// k/M of the total, M = guide.len() − 1 a power of two, so that u in
    /// [k/M, (k+1)/M) picks an item in guide[k]..=guide[k+1]. Empty below
    /// `GUIDED_FROM` items. A sun's 4,096 cells took 12 steps of a search
    /// that missed the cache: 2.6% of perf's samples of a sunlit 1-spp
    /// render, 0.7–1.3% with the guide.
    guide: Vec<u32>,
}

/// Items from which a distribution keeps a guide table.
const GUIDED_FROM: usize = 64;
/// Items per guide entry: the search left after the guide is over a few.
const ITEMS_PER_GUIDE: usize = 4;

impl Distribution1D {
    /// Weights must be finite and non-negative; the caller filters others out.
    pub fn new(weights: impl IntoIterator<Item = f64>) -> Self {
        let weights = weights.into_iter();
        let mut cdf = Vec::with_capacity(weights.size_hint().0);
        let mut total = 0.0;
        for w in weights {
            debug_assert!(w.is_finite() && w >= 0.0);
            total += w;
            cdf.push(total);
        }
        let guide = if cdf.len() >= GUIDED_FROM && total > 0.0 && cdf.len() < u32::MAX as usize {
            let m = (cdf.len() / ITEMS_PER_GUIDE).next_power_of_two();
            // k/M·total as `sample` forms u·total, so that both round alike.
            (0..=m).map(|k| cdf.partition_point(|&c| c <= (k as f64 / m as f64) * total) as u32).collect()
        } else {
            Vec::new()
        };
        Distribution1D { cdf, total, guide }
    }

    pub fn total(&self) -> f64 {
        self.total
    }

    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty() || self.total <= 0.0
    }

    /// Index whose interval contains u·total; never an item of zero weight.
    pub fn sample(&self, u: f32) -> usize {
        let target = u as f64 * self.total;
        let i = if self.guide.is_empty() {
            self.cdf.partition_point(|&c| c <= target)
        } else {
            // u·M is exact (M a power of two); u ≥ 1 falls in the last part.
            let m = self.guide.len() - 1;
            let k = ((u * m as f32) as usize).min(m - 1);
            // The item is in lo..=hi, and hi where none before it is past u.
            let (lo, hi) = (self.guide[k] as usize, self.guide[k + 1] as usize);
            lo + self.cdf[lo..hi].partition_point(|&c| c <= target)
        };
        i.min(self.cdf.len() - 1)
    }

    /// `sample`, and where u fell inside the picked item's interval,
    /// rescaled to [0, 1): a fresh uniform number for the next choice.
    pub fn sample_remapped(&self, u: f32) -> (usize, f32) {
        let i = self.sample(u);
        let prev = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let width = self.cdf[i] - prev;
        let rest = if width > 0.0 { ((u as f64 * self.total - prev) / width) as f32 } else { 0.5 };
        (i, rest.clamp(0.0, 1.0 - f32::EPSILON))
    }

    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    pub fn probability(&self, i: usize) -> f64 {
        let prev = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (self.cdf[i] - prev) / self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn the_opposite_cone_is_the_cone_about_the_negated_axis_to_the_bit() {
        // A sun's subpaths leave along the cone its light samples' frame
        // faces away from (`SunDisk::leaving`); its images rest on this.
        let mut rng = Rng::new(7, 0);
        let mut axes = vec![Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::Y, Vec3::new(1e-30, 0.0, 1.0).normalize(), Vec3::new(0.6, 0.8, 0.0), Vec3::new(0.6, -0.8, -0.0)];
        axes.extend((0..2000).map(|_| uniform_sphere(rng.next_2d())));
        for (k, n) in axes.into_iter().enumerate() {
            for omc in [1e-7, one_minus_cos(0.0465), 0.3, 2.0] {
                let u = rng.next_2d();
                let (a, b) = (cone_sample_opposite(&Frame::from_normal(n), omc, u), cone_sample_within(-n, omc, u));
                assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "axis {k} {n:?}, 1 − cos {omc}");
            }
        }
    }

    #[test]
    fn frame_is_orthonormal_for_awkward_normals() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.0, -1e-8, -1.0).normalize(), Vec3::new(1.0, 2.0, -3.0).normalize()] {
            let f = Frame::from_normal(n);
            let (t, b) = (f.to_world(Vec3::X), f.to_world(Vec3::Y));
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5 && (f.to_world(Vec3::Z) - n).length() < 1e-6);
            assert!(t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5);
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn quarter_sin_cos_match_libm_over_their_interval() {
        let n = 1_000_000;
        for i in 0..=n {
            let x = std::f32::consts::FRAC_PI_4 * (2.0 * i as f32 / n as f32 - 1.0);
            let (s, c) = sin_cos_quarter(x);
            assert!((s as f64 - (x as f64).sin()).abs() < 1e-7 && (c as f64 - (x as f64).cos()).abs() < 1e-7, "{x}: {s} {c}");
        }
        assert_eq!(sin_cos_quarter(0.0), (0.0, 1.0));
    }

    #[test]
    fn concentric_disk_keeps_radius_and_quadrant() {
        let mut rng = Rng::new(3, 1);
        for _ in 0..100_000 {
            let u = rng.next_2d();
            let (o, d) = (2.0 * u - Vec2::ONE, concentric_disk(u));
            // The square's ring max(|x|, |y|) maps to the circle of that radius.
            assert!((d.length() - o.x.abs().max(o.y.abs())).abs() < 1e-6, "{u}: {d}");
            assert!(d.x * o.x >= 0.0 && d.y * o.y >= 0.0, "{u}: {d}");
        }
    }

    #[test]
    fn cosine_hemisphere_mean_cosine_is_two_thirds() {
        let mut rng = Rng::new(1, 1);
        let n = 100_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let w = cosine_hemisphere(rng.next_2d());
            assert!(w.z >= 0.0 && (w.length() - 1.0).abs() < 1e-4);
            sum += w.z as f64;
        }
        // E[cos] under cos/π is 2/3; its std is 0.236, so the std error is 7.5e-4.
        assert!((sum / n as f64 - 2.0 / 3.0).abs() < 4e-3);
    }

    #[test]
    fn distribution_never_picks_zero_weight_and_matches_probabilities() {
        let d = Distribution1D::new([0.0, 1.0, 0.0, 3.0, 0.0]);
        assert_eq!(d.sample(0.0), 1);
        assert_eq!(d.sample(0.2499), 1);
        assert_eq!(d.sample(0.25), 3);
        assert_eq!(d.sample(0.99999), 3);
        assert!((d.probability(3) - 0.75).abs() < 1e-12);
    }

    #[test]
    fn the_guide_table_picks_what_the_binary_search_picks() {
        let mut rng = Rng::new(7, 0);
        // Runs of zero weight, one huge item, tiny ones, and sizes on
        // either side of a power of two.
        for n in [64usize, 65, 100, 1000, 4096, 5000] {
            let weights: Vec<f64> = (0..n)
                .map(|i| match i % 11 {
                    0..=2 => 0.0,
                    3 if i == 3 => 1e6,
                    4 => 1e-9,
                    _ => rng.next_f32() as f64,
                })
                .collect();
            let d = Distribution1D::new(weights.iter().copied());
            assert!(d.guide.len() > 2, "{n} items keep a guide");
            let plain = |u: f32| d.cdf.partition_point(|&c| c <= u as f64 * d.total).min(n - 1);
            let m = (d.guide.len() - 1) as f32;
            let edges = (0..=d.guide.len()).flat_map(|k| {
                let u = k as f32 / m;
                [u, f32::from_bits(u.to_bits().saturating_sub(1)), f32::from_bits(u.to_bits() + 1)]
            });
            for u in (0..20_000).map(|_| rng.next_f32()).chain(edges).chain([0.0, 1.0 - f32::EPSILON, 1.0]) {
                let i = d.sample(u);
                assert_eq!(i, plain(u), "{n} items, u = {u}");
                assert!(u >= 1.0 || weights[i] > 0.0, "{n} items, u = {u}: picked a zero weight");
            }
        }
    }
}
