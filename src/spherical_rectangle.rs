//! A rectangle as seen from a point, and directions drawn uniformly over
//! the solid angle it covers (Ureña, Fajardo and King 2013, "An
//! area-preserving parametrization for spherical rectangles"): one piece
//! where two spherical triangles would take two solid angles, a pick
//! between them and Arvo's construction in double precision. For portals
//! (portals.rs), whose windows are rectangles seen from a room.

use crate::Vec3;
use glam::Vec2;
use std::f32::consts::PI;

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
    b1: f32,
    /// g2 + g3, where the parametrisation's angle starts.
    k: f32,
    /// Solid angle (sr).
    pub solid_angle: f32,
}

/// The angle between unit vectors, accurate near 0 and π (the arc sine of
/// half the chord; acos of the dot product loses half the digits there).
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 { PI - 2.0 * ((a + b).length() * 0.5).min(1.0).asin() } else { 2.0 * ((b - a).length() * 0.5).min(1.0).asin() }
}

impl SphericalRectangle {
    /// The rectangle with corner `corner` and perpendicular edges `ex`, `ey`
    /// seen from `p`; None where `p` lies in its plane or it covers less
    /// than `min_solid_angle`.
    pub fn new(p: Vec3, corner: Vec3, ex: Vec3, ey: Vec3, min_solid_angle: f32) -> Option<Self> {
        let (lx, ly) = (ex.length(), ey.length());
        let (x, y) = (ex / lx, ey / ly);
        let mut z = x.cross(y);
        let d = corner - p;
        let (x0, y0, mut z0) = (d.dot(x), d.dot(y), d.dot(z));
        if z0 > 0.0 {
            (z, z0) = (-z, -z0);
        }
        if !(z0 < 0.0) {
            return None;
        }
        let (x1, y1) = (x0 + lx, y0 + ly);
        let v00 = Vec3::new(x0, y0, z0);
        let v01 = Vec3::new(x0, y1, z0);
        let v10 = Vec3::new(x1, y0, z0);
        let v11 = Vec3::new(x1, y1, z0);
        // The normals of the planes through p and each edge.
        let n0 = v00.cross(v10).normalize_or_zero();
        let n1 = v10.cross(v11).normalize_or_zero();
        let n2 = v11.cross(v01).normalize_or_zero();
        let n3 = v01.cross(v00).normalize_or_zero();
        let (g0, g1, g2, g3) = (angle_between(-n0, n1), angle_between(-n1, n2), angle_between(-n2, n3), angle_between(-n3, n0));
        let solid_angle = g0 + g1 + g2 + g3 - 2.0 * PI;
        (solid_angle >= min_solid_angle && solid_angle.is_finite()).then_some(SphericalRectangle { x, y, z, x0, x1, y0, y1, z0, b0: n0.z, b1: n2.z, k: g2 + g3, solid_angle })
    }

    /// A unit direction uniform over the solid angle, 1/Ω its density:
    /// `u.x` picks the sub-rectangle's share of the solid angle along x,
    /// `u.y` the point along y.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let au = u.x * self.solid_angle - self.k;
        let fu = (au.cos() * self.b0 - self.b1) / au.sin();
        let cu = (1.0 / (fu * fu + self.b0 * self.b0).sqrt()).copysign(fu).clamp(-1.0, 1.0);
        let xu = (-(cu * self.z0) / (1.0 - cu * cu).max(0.0).sqrt()).clamp(self.x0, self.x1);
        let d = (xu * xu + self.z0 * self.z0).sqrt();
        let h0 = self.y0 / (d * d + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d * d + self.y1 * self.y1).sqrt();
        let hv = h0 + u.y * (h1 - h0);
        let yv = if hv * hv < 1.0 - 1e-6 { hv * d / (1.0 - hv * hv).sqrt() } else { self.y1 };
        (self.x * xu + self.y * yv + self.z * self.z0).normalize_or_zero()
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
