//! A rectangle as seen from a point, and directions drawn uniformly over
//! the solid angle it covers (Ureña, Fajardo and King 2013, "An
//! area-preserving parametrization for spherical rectangles"): one piece
//! where two spherical triangles would take two solid angles, a pick
//! between them and Arvo's construction in double precision. For portals
//! (portals.rs), whose windows are rectangles seen from a room.

use crate::Vec3;
use glam::{Vec2, Vec4};
use std::f32::consts::{FRAC_PI_2, PI};

#[derive(Clone, Copy, Debug)]
pub struct SphericalRectangle {
    /// The rectangle's frame: unit edges x and y, and z toward the point's
    /// side negated, so that the rectangle lies at local z = z0 < 0.
    x: Vec3,
    y: Vec3,
    z: Vec3,
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    z0: f32,
    b0: f32,
    /// 1 − b0², without the cancellation.
    one_minus_b0_sq: f32,
    b1: f32,
    /// g2 + g3, where the parametrisation's angle starts.
    k: f32,
    /// Solid angle (sr).
    pub solid_angle: f32,
}

/// The arc cosine of each lane of `x` (|x| ≤ 1) to within 2e-8 rad
/// (Abramowitz and Stegun 4.4.46): four at once where libm's `asinf`, one
/// at a time, had been half the time of seeing a rectangle.
fn acos4(x: Vec4) -> Vec4 {
    let a = x.abs().min(Vec4::ONE);
    // The book's coefficients as printed; f32 rounds a few of their digits.
    #[allow(clippy::excessive_precision)]
    let c = [-0.001_262_491_1, 0.006_670_090_1, -0.017_088_125_6, 0.030_891_881, -0.050_174_304_6, 0.088_978_987_4, -0.214_598_801_6, 1.570_796_305];
    let poly = c.iter().fold(Vec4::ZERO, |acc, &k| acc * a + Vec4::splat(k));
    let r = (Vec4::ONE - a).max(Vec4::ZERO).sqrt() * poly;
    Vec4::select(x.cmplt(Vec4::ZERO), Vec4::splat(PI) - r, r)
}

/// Angles in [0, π] from their cosines and (non-negative) sines: the arc
/// cosine where the angle is within 45° of a right angle, else the arc
/// sine, so that an angle near 0 or π keeps its digits (the arc cosine of
/// a cosine near ±1 loses half of them).
fn angles(cos: Vec4, sin: Vec4) -> Vec4 {
    let near_right = cos.abs().cmplt(sin);
    let a = acos4(Vec4::select(near_right, cos, sin));
    // Else a = acos(sin) = π/2 − asin(sin): the angle is π/2 − a or π/2 + a.
    let by_sin = Vec4::splat(FRAC_PI_2) + Vec4::select(cos.cmpgt(Vec4::ZERO), -a, a);
    Vec4::select(near_right, a, by_sin)
}

/// A rectangle in space: a corner, its unit edge directions and their
/// lengths, and their cross product. Made once per rectangle: seeing one
/// from a point then starts from its frame (two square roots and two
/// divisions fewer a vertex in a room lit through a window).
#[derive(Clone, Copy, Debug)]
pub struct Rectangle {
    corner: Vec3,
    x: Vec3,
    y: Vec3,
    z: Vec3,
    lx: f32,
    ly: f32,
}

impl Rectangle {
    /// The rectangle with corner `corner` and perpendicular edges `ex`, `ey`.
    pub fn new(corner: Vec3, ex: Vec3, ey: Vec3) -> Self {
        let (lx, ly) = (ex.length(), ey.length());
        Self::framed(corner, ex / lx, ey / ly, lx, ly)
    }

    /// The rectangle with corner `corner`, perpendicular unit edge
    /// directions `x` and `y`, and edge lengths `lx` and `ly`.
    pub fn framed(corner: Vec3, x: Vec3, y: Vec3, lx: f32, ly: f32) -> Self {
        Rectangle { corner, x, y, z: x.cross(y), lx, ly }
    }
}

impl SphericalRectangle {
    /// The rectangle with corner `corner` and perpendicular edges `ex`, `ey`
    /// seen from `p`; None where `p` lies in its plane or it covers less
    /// than `min_solid_angle`.
    pub fn new(p: Vec3, corner: Vec3, ex: Vec3, ey: Vec3, min_solid_angle: f32) -> Option<Self> {
        Self::seen(p, &Rectangle::new(corner, ex, ey), min_solid_angle)
    }

    /// `rectangle` seen from `p`, as `new`.
    #[inline]
    pub fn seen(p: Vec3, rectangle: &Rectangle, min_solid_angle: f32) -> Option<Self> {
        let Rectangle { corner, x, y, mut z, lx, ly } = *rectangle;
        let d = corner - p;
        let (x0, y0, mut z0) = (d.dot(x), d.dot(y), d.dot(z));
        if z0 > 0.0 {
            (z, z0) = (-z, -z0);
        }
        if !(z0 < 0.0) {
            return None;
        }
        let (x1, y1) = (x0 + lx, y0 + ly);
        // In this frame the planes through p and the edges v00–v10,
        // v10–v11, v11–v01 and v01–v00 have the normals (0, z0, −y0),
        // (−z0, 0, x1), (0, −z0, y1) and (z0, 0, −x0) over their lengths
        // `len`; the inner angle g at a corner v between two of them has
        // cos g = −n·n' and sin g = |z0|·|v| / (len·len').
        let z2 = z0 * z0;
        let len = (Vec4::new(y0 * y0, x1 * x1, y1 * y1, x0 * x0) + Vec4::splat(z2)).sqrt();
        let lens = len * Vec4::new(len.y, len.z, len.w, len.x);
        let cos = Vec4::new(y0 * x1, -x1 * y1, x0 * y1, -x0 * y0) / lens;
        let corners = (Vec4::new(x1 * x1 + y0 * y0, x1 * x1 + y1 * y1, x0 * x0 + y1 * y1, x0 * x0 + y0 * y0) + Vec4::splat(z2)).sqrt();
        let sin = corners * -z0 / lens;
        let g = angles(cos, sin);
        let solid_angle = g.element_sum() - 2.0 * PI;
        (solid_angle >= min_solid_angle && solid_angle.is_finite()).then_some(SphericalRectangle { x, y, z, x0, x1, y0, y1, z0, b0: -y0 / len.x, one_minus_b0_sq: z2 / (len.x * len.x), b1: y1 / len.z, k: g.z + g.w, solid_angle })
    }

    /// A unit direction uniform over the solid angle, 1/Ω its density:
    /// `u.x` picks the sub-rectangle's share of the solid angle along x,
    /// `u.y` the point along y. Ureña et al.'s steps folded together (the
    /// point at (xu, yv, z0) normalised is (xu·s/d, hv, z0·s/d), s =
    /// √(1 − hv²)): three divisions and three square roots in a row where
    /// there had been five and six.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let (sin, cos) = (u.x * self.solid_angle - self.k).sin_cos();
        // Their xu = −z0·cu/√(1 − cu²), cu = sign(fu)/√(fu² + b0²), fu =
        // q/sin, q = cos·b0 − b1; max/min rather than clamp, so that 0/0 at
        // the rectangle's rim takes x0.
        let q = cos * self.b0 - self.b1;
        let xu = (-self.z0 * sin * q.signum() / (q * q - sin * sin * self.one_minus_b0_sq).max(0.0).sqrt()).max(self.x0).min(self.x1);
        let d2 = xu * xu + self.z0 * self.z0;
        let h0 = self.y0 / (d2 + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d2 + self.y1 * self.y1).sqrt();
        let hv = h0 + u.y * (h1 - h0);
        let s_over_d = (1.0 - hv * hv).max(0.0).sqrt() / d2.sqrt();
        self.x * (xu * s_over_d) + self.y * hv + self.z * (self.z0 * s_over_d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::spherical_triangle;

    /// Rectangles seen from in front, behind, off to the side, near and
    /// far: the solid angle is that of its two triangles.
    #[test]
    fn the_solid_angle_is_its_two_triangles() {
        let (corner, ex, ey) = (Vec3::new(-0.5, -1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
        for p in [Vec3::new(0.0, 0.0, -0.7), Vec3::new(0.1, 0.2, 3.0), Vec3::new(4.0, -2.0, -0.3), Vec3::new(0.2, 0.1, -0.01), Vec3::new(-6.0, 2.0, -4.0)] {
            let r = SphericalRectangle::new(p, corner, ex, ey, 0.0).unwrap();
            let tri = |t: [Vec3; 3]| spherical_triangle::solid_angle(p, &t).unwrap_or(0.0);
            let two = tri([corner, corner + ex, corner + ex + ey]) + tri([corner, corner + ex + ey, corner + ey]);
            assert!((r.solid_angle - two).abs() < 2e-4 * two.max(1e-2), "{p}: {} vs {two}", r.solid_angle);
        }
        assert!(SphericalRectangle::new(Vec3::new(0.2, 0.3, 0.0), corner, ex, ey, 0.0).is_none(), "in its plane");
        assert!(SphericalRectangle::new(Vec3::new(0.0, 0.0, -1e4), corner, ex, ey, 1e-3).is_none(), "too far");
    }

    /// Against the closed form in double precision, Ω = Σ ±atan(xy / (z·r))
    /// over the corners, from points on its axis, beside it, grazing its
    /// plane (where some inner angles near 0 and π) and far off: within
    /// 2e-6 sr plus 1e-5 of Ω. The four arc cosines at once agree with
    /// libm's to 1e-6 rad over [−1, 1].
    #[test]
    fn the_solid_angle_is_the_closed_form_grazing_or_not() {
        let (corner, ex, ey) = (Vec3::new(-0.5, -1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
        let exact = |p: Vec3| {
            let z = p.z.abs() as f64;
            let f = |x: f64, y: f64| (x * y / (z * (x * x + y * y + z * z).sqrt())).atan();
            let (x0, x1, y0, y1) = (-0.5 - p.x as f64, 0.5 - p.x as f64, -1.0 - p.y as f64, 1.0 - p.y as f64);
            f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)
        };
        for p in [Vec3::new(0.0, 0.0, -0.7), Vec3::new(3.0, 0.5, -0.02), Vec3::new(0.2, 4.0, 0.01), Vec3::new(-0.6, -1.1, -0.003), Vec3::new(0.1, 0.0, -1e-4), Vec3::new(30.0, 20.0, 40.0)] {
            let r = SphericalRectangle::new(p, corner, ex, ey, 0.0).unwrap();
            let omega = exact(p);
            assert!((r.solid_angle as f64 - omega).abs() < 2e-6 + 1e-5 * omega, "{p}: {} vs {omega}", r.solid_angle);
            for u in [Vec2::new(0.0, 0.0), Vec2::new(0.5, 0.5), Vec2::new(0.999, 0.001)] {
                assert!((r.sample(u).length() - 1.0).abs() < 1e-5, "{p}");
            }
        }
        for i in 0..=2000 {
            let x = -1.0 + i as f32 / 1000.0;
            let a = acos4(Vec4::splat(x)).x;
            assert!((a as f64 - (x as f64).acos()).abs() < 1e-6, "{x}: {a}");
        }
    }

    /// Directions land in the rectangle, and uniformly over its solid
    /// angle: of 100,000, each of its 4 × 4 sub-rectangles receives its
    /// share of the solid angle (each share from its own spherical
    /// rectangle), within 4.5 standard deviations of a binomial count.
    #[test]
    fn directions_are_uniform_over_the_solid_angle() {
        let (corner, ex, ey) = (Vec3::new(-0.5, -1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
        for p in [Vec3::new(0.0, 0.0, -0.7), Vec3::new(1.5, -0.2, -0.4), Vec3::new(0.1, 0.3, 0.05)] {
            let r = SphericalRectangle::new(p, corner, ex, ey, 0.0).unwrap();
            let n = 100_000;
            let mut counts = [[0u32; 4]; 4];
            let mut rng = Rng::new(11, 0);
            for _ in 0..n {
                let d = r.sample(rng.next_2d());
                let hit = p + d * (-p.z / d.z);
                assert!((hit.x.abs() <= 0.5 + 1e-3) && (hit.y.abs() <= 1.0 + 1e-3), "{p}: {hit}");
                let (i, j) = (((hit.x + 0.5) * 4.0).clamp(0.0, 3.0) as usize, ((hit.y + 1.0) * 2.0).clamp(0.0, 3.0) as usize);
                counts[i][j] += 1;
            }
            for (i, row) in counts.iter().enumerate() {
                for (j, &count) in row.iter().enumerate() {
                    let sub = SphericalRectangle::new(p, corner + ex * (i as f32 / 4.0) + ey * (j as f32 / 4.0), ex / 4.0, ey / 4.0, 0.0).unwrap();
                    let share = (sub.solid_angle / r.solid_angle) as f64;
                    let sd = (n as f64 * share * (1.0 - share)).sqrt();
                    assert!((count as f64 - n as f64 * share).abs() < 4.5 * sd + 1.0, "{p}: cell {i} {j}: {count} vs {}", n as f64 * share);
                }
            }
        }
    }
}
