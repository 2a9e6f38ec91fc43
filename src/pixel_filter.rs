//! The pixel filter: Blender's Film › Pixel Filter (Cycles' Box, Gaussian
//! and Blackman-Harris, and their Width in pixels), by importance sampling
//! as Cycles does it. A pixel's value is ∫ F(u) L(c + u) du over offsets u
//! from its centre c, with F the filter normalised to integrate to 1; each
//! of its camera rays goes through c + u with u drawn from F, so every
//! sample counts for its own pixel alone with weight 1. Separable: F(u) =
//! f(u.x) f(u.y), each axis drawn on its own.
//!
//! The one-dimensional shapes, of Cycles' Width w (the support in
//! brackets):
//! * Box: 1/w on [−w/2, w/2]. At w = 1, Glint's jitter as it was.
//! * Gaussian: ∝ exp(−8 x²/w²), a standard deviation of w/4, on [−1.5w, 1.5w].
//! * Blackman-Harris: ∝ 0.35875 + 0.48829 cos(πx/w) + 0.14128 cos(2πx/w)
//!   + 0.01168 cos(3πx/w) on [−w, w] (Cycles' window over twice the width).
//!
//! Light tracing, which lands on the film at a point x rather than in a
//! pixel, adds to every pixel p within reach F(x − c_p) of its light
//! (light_tracing.rs), and both sides weigh their MIS by the camera's
//! density scaled by F at the sample's offset, so the strategies estimate
//! the same pixel integral.

use glam::Vec2;
use std::f32::consts::PI;

/// Entries of the inverse-CDF table (Cycles uses 1,024 too).
const TABLE: usize = 1024;
/// Steps of the grid that finds an offset's interval of the table: finer
/// than its narrowest interval (the centre's, about 1/(TABLE·F(0))).
const GRID: usize = 4 * TABLE;

/// The most pixels a filter reaches on each side of a point along an
/// axis: Gaussian's 1.5 × Blender's largest Width, 10, rounded up.
const MAX_REACH: usize = 16;

/// Cycles' three filters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FilterKind {
    Box,
    Gaussian,
    BlackmanHarris,
}

/// A filter as a render request names it: its kind and Cycles' Width in
/// pixels (Blender's bounds: 0.01 to 10).
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterRequest {
    #[serde(rename = "type")]
    pub kind: FilterKind,
    pub width: f32,
}

/// The filter of a render, ready to draw offsets and to weigh film points.
#[derive(Clone, Debug)]
pub struct PixelFilter {
    kind: FilterKind,
    width: f32,
    /// Half the support, in pixels.
    radius: f32,
    /// The inverse CDF on a uniform grid of [0, 1]: offsets in pixels.
    /// Empty for the box, which needs none.
    inverse_cdf: Vec<f32>,
    /// The density between each two entries of the table, and for each of
    /// `GRID` equal steps of [−radius, radius] the interval its start lies
    /// in: `density_1d` finds x's interval in a step or two.
    interval_density: Vec<f32>,
    interval_at: Vec<u16>,
    /// The box's density, 1/w (the others' is their table's).
    norm: f32,
}

impl Default for PixelFilter {
    /// Glint's own: a one-pixel box.
    fn default() -> Self {
        PixelFilter::new(FilterKind::Box, 1.0).expect("a one-pixel box is a filter")
    }
}

impl PixelFilter {
    /// None for a width outside Blender's bounds, 0.01 to 10 pixels.
    pub fn new(kind: FilterKind, width: f32) -> Option<Self> {
        if !((0.01..=10.0).contains(&width)) {
            return None;
        }
        let radius = match kind {
            FilterKind::Box => 0.5 * width,
            FilterKind::Gaussian => 1.5 * width,
            FilterKind::BlackmanHarris => width,
        };
        let mut filter = PixelFilter { kind, width, radius, inverse_cdf: Vec::new(), interval_density: Vec::new(), interval_at: Vec::new(), norm: 1.0 / width };
        if kind != FilterKind::Box {
            filter.tabulate();
        }
        Some(filter)
    }

    pub fn from_request(r: &FilterRequest) -> Option<Self> {
        Self::new(r.kind, r.width)
    }

    /// The one-pixel box: camera rays jittered uniformly in their pixel,
    /// light tracing adding to the one pixel it lands in.
    pub fn is_unit_box(&self) -> bool {
        self.kind == FilterKind::Box && self.width == 1.0
    }

    /// How far from a pixel's centre its samples reach, in pixels.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The unnormalised shape f(x).
    fn shape(&self, x: f32) -> f32 {
        if !(x.abs() <= self.radius) {
            return 0.0;
        }
        match self.kind {
            FilterKind::Box => 1.0,
            FilterKind::Gaussian => {
                let v = x * 2.0 / self.width;
                (-2.0 * v * v).exp()
            }
            FilterKind::BlackmanHarris => {
                let v = PI * x / self.width;
                (0.35875 + 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() + 0.01168 * (3.0 * v).cos()).max(0.0)
            }
        }
    }

    /// The inverse CDF of f over [−radius, radius] on `TABLE` entries, from
    /// the CDF by the trapezoid rule on a grid eight times finer.
    fn tabulate(&mut self) {
        let n = TABLE * 8;
        let step = 2.0 * self.radius as f64 / n as f64;
        let mut cdf = Vec::with_capacity(n + 1);
        let mut sum = 0.0f64;
        cdf.push(0.0);
        for i in 0..n {
            let (a, b) = (-self.radius as f64 + i as f64 * step, -self.radius as f64 + (i + 1) as f64 * step);
            sum += 0.5 * (self.shape(a as f32) as f64 + self.shape(b as f32) as f64) * step;
            cdf.push(sum);
        }
        let mut k = 0;
        self.inverse_cdf = (0..TABLE)
            .map(|j| {
                let target = j as f64 / (TABLE - 1) as f64 * sum;
                while k + 1 < n && cdf[k + 1] < target {
                    k += 1;
                }
                let (c0, c1) = (cdf[k], cdf[k + 1]);
                let t = if c1 > c0 { ((target - c0) / (c1 - c0)).clamp(0.0, 1.0) } else { 0.0 };
                (-self.radius as f64 + (k as f64 + t) * step) as f32
            })
            .collect();
        let t = &self.inverse_cdf;
        self.interval_density = t.windows(2).map(|w| if w[1] > w[0] { 1.0 / ((TABLE - 1) as f32 * (w[1] - w[0])) } else { 0.0 }).collect();
        self.interval_at = (0..GRID)
            .map(|g| {
                let x = -self.radius + 2.0 * self.radius * g as f32 / GRID as f32;
                (t.partition_point(|&v| v <= x).clamp(1, TABLE - 1) - 1) as u16
            })
            .collect();
    }

    /// An offset from the centre along one axis, u uniform in [0, 1).
    #[cfg(test)]
    fn offset(&self, u: f32) -> f32 {
        self.offset_and_density(u).0
    }

    /// `offset`, and `density_1d` there, read off the interval u drew it
    /// from rather than searched for.
    #[inline]
    fn offset_and_density(&self, u: f32) -> (f32, f32) {
        if self.kind == FilterKind::Box {
            return ((u - 0.5) * self.width, self.norm);
        }
        let x = u.clamp(0.0, 1.0) * (TABLE - 1) as f32;
        let i = (x as usize).min(TABLE - 2);
        let t = x - i as f32;
        (self.inverse_cdf[i] * (1.0 - t) + self.inverse_cdf[i + 1] * t, self.interval_density[i])
    }

    /// Where in the image a sample of pixel (x, y) looks, from two uniform
    /// numbers: (x, y) + u for the one-pixel box, bit for bit as before.
    #[cfg(test)]
    fn sample(&self, pixel: Vec2, u: Vec2) -> Vec2 {
        self.sample_with_density(pixel, u).0
    }

    /// `sample`, and `density_for` the point it gives (the density of the
    /// interval each axis drew from: the same as `density_1d` finds but
    /// where the point falls on an interval's end, which rounding alone
    /// can make it do).
    #[inline]
    pub fn sample_with_density(&self, pixel: Vec2, u: Vec2) -> (Vec2, f32) {
        if self.is_unit_box() {
            return (pixel + u, 1.0);
        }
        let ((x, fx), (y, fy)) = (self.offset_and_density(u.x), self.offset_and_density(u.y));
        (pixel + Vec2::splat(0.5) + Vec2::new(x, y), fx * fy)
    }

    /// The density, per pixel, with which `offset` draws x: the table's
    /// own, constant between its entries (an inverse CDF on a uniform grid
    /// puts 1/(TABLE − 1) of the samples in each interval), so that light
    /// tracing weighs its light by exactly the density the camera's rays
    /// are drawn with. It departs from the filter's shape only in the two
    /// outermost intervals, 0.1% of the samples each
    /// (`the_tables_density_is_the_filters`), as Cycles' table does.
    fn density_1d(&self, x: f32) -> f32 {
        if !(x.abs() <= self.radius) {
            return 0.0;
        }
        if self.kind == FilterKind::Box {
            return self.norm;
        }
        let t = &self.inverse_cdf;
        let g = (((x + self.radius) / (2.0 * self.radius) * GRID as f32) as usize).min(GRID - 1);
        let mut i = self.interval_at[g] as usize;
        while i + 2 < TABLE && t[i + 1] <= x {
            i += 1;
        }
        self.interval_density[i]
    }

    /// F at an offset from a pixel's centre: the density, per pixel², of
    /// its samples there (1 inside the pixel for the one-pixel box).
    #[cfg(test)]
    fn density(&self, offset: Vec2) -> f32 {
        self.density_1d(offset.x) * self.density_1d(offset.y)
    }

    /// The density of a sample drawn at image point `at` by pixel (x, y),
    /// as `sample` draws it (what light tracing's `reach` weighs it by).
    #[cfg(test)]
    fn density_for(&self, pixel: Vec2, at: Vec2) -> f32 {
        if self.is_unit_box() {
            return 1.0;
        }
        self.density(at - pixel - Vec2::splat(0.5))
    }

    /// The pixels of a `width` × `height` image whose samples reach image
    /// point `at`, each with F there: what light tracing adds its light to.
    pub fn reach(&self, at: Vec2, width: u32, height: u32, mut add: impl FnMut(u32, f32)) {
        let r = self.radius;
        let (x0, x1) = (((at.x - 0.5 - r).ceil().max(0.0)) as i64, ((at.x - 0.5 + r).floor()).min(width as f32 - 1.0) as i64);
        let (y0, y1) = (((at.y - 0.5 - r).ceil().max(0.0)) as i64, ((at.y - 0.5 + r).floor()).min(height as f32 - 1.0) as i64);
        // The filter is separable: each column's and row's factor once.
        let mut columns = [0.0f32; 2 * MAX_REACH];
        let n = (x1 - x0 + 1).clamp(0, 2 * MAX_REACH as i64) as usize;
        for (k, f) in columns[..n].iter_mut().enumerate() {
            *f = self.density_1d(at.x - (x0 + k as i64) as f32 - 0.5);
        }
        for y in y0..=y1 {
            let fy = self.density_1d(at.y - y as f32 - 0.5);
            if fy <= 0.0 {
                continue;
            }
            for (k, fx) in columns[..n].iter().enumerate() {
                if *fx > 0.0 {
                    add(y as u32 * width + (x0 + k as i64) as u32, fx * fy);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filters() -> Vec<PixelFilter> {
        vec![
            PixelFilter::new(FilterKind::BlackmanHarris, 1.5).unwrap(),
            PixelFilter::new(FilterKind::Gaussian, 1.5).unwrap(),
            PixelFilter::new(FilterKind::Box, 2.0).unwrap(),
            PixelFilter::new(FilterKind::BlackmanHarris, 0.3).unwrap(),
        ]
    }

    /// Offsets drawn from the table follow the density `density` states: a
    /// histogram of 400,000 draws against its integral over each bin
    /// (chi-square), and within the support.
    #[test]
    fn offsets_follow_the_filter() {
        let n = 400_000;
        for f in filters() {
            let bins = 40;
            let mut counts = vec![0u32; bins];
            let mut rng = crate::rng::Rng::new(3, 7);
            for _ in 0..n {
                let x = f.offset(rng.next_f32());
                assert!(x.abs() <= f.radius * 1.0001, "{f:?}: {x}");
                let b = (((x + f.radius) / (2.0 * f.radius)) * bins as f32) as usize;
                counts[b.min(bins - 1)] += 1;
            }
            let mut chi2 = 0.0f64;
            let mut dof = 0;
            for (b, &c) in counts.iter().enumerate() {
                let (lo, hi) = (-f.radius + 2.0 * f.radius * b as f32 / bins as f32, -f.radius + 2.0 * f.radius * (b + 1) as f32 / bins as f32);
                let steps = 2000;
                let mass: f32 = (0..steps).map(|k| f.density_1d(lo + (hi - lo) * (k as f32 + 0.5) / steps as f32)).sum::<f32>() * (hi - lo) / steps as f32;
                let expected = mass as f64 * n as f64;
                if expected > 20.0 {
                    chi2 += (c as f64 - expected).powi(2) / expected;
                    dof += 1;
                }
            }
            // 99.99th percentile of chi-square with ≤ 40 degrees of freedom
            // is below 80.
            assert!(chi2 < 80.0, "{f:?}: chi² {chi2} over {dof} bins");
        }
    }

    /// The table's density is the filter's shape, normalised, but for its
    /// outermost intervals, which hold 1/1,023 of the samples each, spread
    /// evenly: their L1 distance is below 1% (4/1,023 from those two,
    /// measured 0.3–0.5%).
    #[test]
    fn the_tables_density_is_the_filters() {
        for f in filters() {
            let steps = 20_000;
            let h = 2.0 * f.radius / steps as f32;
            let (mut shape, mut l1) = (0.0f64, 0.0f64);
            for i in 0..steps {
                shape += (f.shape(-f.radius + (i as f32 + 0.5) * h) * h) as f64;
            }
            for i in 0..steps {
                let x = -f.radius + (i as f32 + 0.5) * h;
                l1 += ((f.density_1d(x) as f64 - f.shape(x) as f64 / shape) * h as f64).abs();
            }
            assert!(l1 < 1e-2, "{f:?}: {l1}");
        }
    }

    /// F integrates to 1 over the plane, peaks at the centre, is symmetric,
    /// and the one-pixel box is Glint's old jitter bit for bit.
    #[test]
    fn the_density_is_normalised_and_the_unit_box_is_the_old_jitter() {
        for f in filters() {
            let steps = 400;
            let h = 2.0 * f.radius / steps as f32;
            let mut total = 0.0f64;
            for i in 0..steps {
                for j in 0..steps {
                    let u = Vec2::new(-f.radius + (i as f32 + 0.5) * h, -f.radius + (j as f32 + 0.5) * h);
                    total += (f.density(u) * h * h) as f64;
                }
            }
            assert!((total - 1.0).abs() < 2e-3, "{f:?}: {total}");
            assert!(f.density(Vec2::ZERO) >= f.density(Vec2::new(0.3 * f.radius, 0.1)));
            assert_eq!(f.density(Vec2::new(0.2, -0.1)), f.density(Vec2::new(-0.2, 0.1)));
        }
        let unit = PixelFilter::default();
        for u in [Vec2::ZERO, Vec2::new(0.3, 0.999_999_94), Vec2::new(0.5, 0.25)] {
            assert_eq!(unit.sample(Vec2::new(7.0, 3.0), u), Vec2::new(7.0, 3.0) + u);
        }
        assert_eq!(unit.density_for(Vec2::new(7.0, 3.0), Vec2::new(7.4, 3.9)), 1.0);
        // The density a sample is drawn with is the one light tracing
        // weighs that point by, but where rounding the point moves it
        // across an interval's end (a neighbour's density, a few per
        // 10,000).
        let mut rng = crate::rng::Rng::new(5, 1);
        for f in filters() {
            let differ = (0..10_000)
                .filter(|_| {
                    let (at, density) = f.sample_with_density(Vec2::new(4.0, 2.0), rng.next_2d());
                    density != f.density_for(Vec2::new(4.0, 2.0), at)
                })
                .count();
            assert!(differ <= 20, "{f:?}: {differ} of 10,000");
        }
        assert!(PixelFilter::new(FilterKind::Gaussian, 0.0).is_none() && PixelFilter::new(FilterKind::Box, f32::NAN).is_none() && PixelFilter::new(FilterKind::Box, 10.5).is_none());
        // The widest reaches every pixel it covers.
        let widest = PixelFilter::new(FilterKind::Gaussian, 10.0).unwrap();
        let mut n = 0;
        widest.reach(Vec2::new(40.0, 40.0), 80, 80, |_, _| n += 1);
        assert_eq!(n, 30 * 30);
    }

    /// A film point reaches the pixels whose filters cover it, with F's
    /// values there: one pixel with weight 1 for the one-pixel box; for a
    /// wider filter, summing to about 1 (the pixels' filters overlap), and
    /// none outside the image.
    #[test]
    fn a_film_point_reaches_the_pixels_that_see_it() {
        let mut reached = Vec::new();
        PixelFilter::default().reach(Vec2::new(3.25, 1.75), 8, 4, |p, f| reached.push((p, f)));
        assert_eq!(reached, vec![(8 + 3, 1.0)]);
        let bh = PixelFilter::new(FilterKind::BlackmanHarris, 1.5).unwrap();
        for at in [Vec2::new(3.25, 1.75), Vec2::new(4.0, 2.0), Vec2::new(0.1, 0.2)] {
            let (mut sum, mut n) = (0.0, 0);
            bh.reach(at, 8, 4, |p, f| {
                assert!(p < 32 && f > 0.0);
                sum += f;
                n += 1;
            });
            assert!((4..=16).contains(&n), "{at}: {n}");
            if at.x > 2.0 {
                assert!((sum - 1.0).abs() < 0.1, "{at}: {sum}");
            }
        }
    }
}
