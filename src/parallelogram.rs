//! Emitting quads: two emitting triangles that make a parallelogram (a
//! Blender area light, a quad of an emissive mesh) are sampled as one
//! shape, p = apex + u₁·e1 + u₂·e2, instead of a triangle picked by one number
//! and a point on it by two others.
//!
//! The density over the quad is the same as before — light picking weighs
//! triangles by power, so every point of an emitter of one radiance has one
//! area density — but a pixel's stratified (Sobol) light samples now cover
//! the whole lamp evenly: on a square area light's penumbra and glossy
//! highlight, direct light came out with half the error (lights.rs).

use crate::scene::Triangle;
use crate::Vec3;
use glam::Vec2;

/// One half of a pair: which of its vertices is the apex (role 0) and which
/// the shared corners s1 (1) and s2 (2).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Half {
    triangle: u32,
    roles: [u8; 3],
}

/// The pair: the first triangle holds the apex, the second the opposite
/// corner apex + e1 + e2 (e1, e2 the edges to the shared corners).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parallelogram {
    halves: [Half; 2],
}

impl Parallelogram {
    /// The parallelogram two triangles make, if they share an edge, face
    /// the same way, and their far corners and areas agree with a
    /// parallelogram's to 1e-5 (so the uniform density over it is theirs).
    pub fn of(ta: u32, a: &Triangle, tb: u32, b: &Triangle) -> Option<Self> {
        let (pa, pb) = (a.p(), b.p());
        let shared: Vec<(usize, usize)> = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).filter(|&(i, j)| pa[i] == pb[j]).collect();
        let &[(i1, j1), (i2, j2)] = shared.as_slice() else { return None };
        let ia = 3 - i1 - i2;
        let ib = 3 - j1 - j2;
        let (apex, s1, s2, far) = (pa[ia], pa[i1], pa[i2], pb[ib]);
        let (e1, e2) = (s1 - apex, s2 - apex);
        let area = e1.cross(e2).length();
        let scale = e1.length().max(e2.length());
        let parallel = (apex + e1 + e2 - far).length() <= 1e-5 * scale;
        let same_area = (area - (a.area() + b.area())).abs() <= 1e-5 * area;
        let same_facing = a.cross().dot(b.cross()) > 0.0;
        if !(parallel && same_area && same_facing && area > 0.0) {
            return None;
        }
        let mut roles_a = [0u8; 3];
        (roles_a[i1], roles_a[i2]) = (1, 2);
        let mut roles_b = [0u8; 3];
        (roles_b[j1], roles_b[j2]) = (1, 2);
        Some(Parallelogram { halves: [Half { triangle: ta, roles: roles_a }, Half { triangle: tb, roles: roles_b }] })
    }

    /// The other triangle of the pair.
    pub fn partner(&self, triangle: u32) -> u32 {
        if self.halves[0].triangle == triangle { self.halves[1].triangle } else { self.halves[0].triangle }
    }

    /// The corner where `sample`'s parameters are 0 and the edges along
    /// which they run, from the scene's `triangles`.
    pub fn frame(&self, triangles: &[Triangle]) -> (Vec3, Vec3, Vec3) {
        let half = &self.halves[0];
        let p = triangles[half.triangle as usize].p();
        let at = |role: u8| p[half.roles.iter().position(|&r| r == role).unwrap_or(0)];
        (at(0), at(1) - at(0), at(2) - at(0))
    }

    /// A uniform point: the scene triangle it lies in and its barycentrics
    /// (b1, b2) there. u.x + u.y ≤ 1 is the first triangle's half; the
    /// rest is the second's, reached from the far corner with
    /// (1 − u.y, 1 − u.x), which is the same point.
    pub fn sample(&self, u: Vec2) -> (u32, Vec2) {
        let (half, w) = if u.x + u.y <= 1.0 { (&self.halves[0], u) } else { (&self.halves[1], Vec2::new(1.0 - u.y, 1.0 - u.x)) };
        // Weights by role: apex, s1, s2.
        let weights = [1.0 - w.x - w.y, w.x, w.y];
        (half.triangle, Vec2::new(weights[half.roles[1] as usize], weights[half.roles[2] as usize]))
    }

}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
        Triangle::new([a, b, c], [Vec3::Z; 3], 0)
    }

    /// Samples land where one affine map of the unit square onto the quad
    /// puts them (so they are uniform over it), in the triangle they name;
    /// the map's corners are the quad's (and `frame`'s); the two halves get
    /// the share of their area; whatever the vertex order of each triangle.
    #[test]
    fn samples_are_uniform_over_the_quad_in_either_vertex_order() {
        let (p0, p1, p2, p3) = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0), Vec3::new(2.5, 1.0, 1.0), Vec3::new(0.5, 1.0, 1.0));
        for (a, b) in [
            (tri(p0, p1, p2), tri(p0, p2, p3)),
            (tri(p1, p2, p0), tri(p3, p0, p2)),
            (tri(p2, p0, p1), tri(p2, p3, p0)),
        ] {
            let quad = Parallelogram::of(7, &a, 9, &b).expect("a parallelogram");
            assert_eq!(quad.partner(7), 9);
            let point = |u: Vec2| {
                let (t, bary) = quad.sample(u);
                let tr = if t == 7 { &a } else { &b };
                assert!(bary.min_element() >= -1e-6 && bary.x + bary.y <= 1.0 + 1e-6);
                let [p0, p1, p2] = tr.p();
                p0 * (1.0 - bary.x - bary.y) + p1 * bary.x + p2 * bary.y
            };
            let (origin, x, y) = (point(Vec2::ZERO), point(Vec2::X), point(Vec2::Y));
            let mut triangles = vec![a.clone(); 10];
            triangles[9] = b.clone();
            let (corner, e1, e2) = quad.frame(&triangles);
            assert!((corner - origin).length() < 1e-6 && (e1 - (x - origin)).length() < 1e-6 && (e2 - (y - origin)).length() < 1e-6, "{corner} {e1} {e2}");
            let corners = [origin, x, y, point(Vec2::ONE)];
            for q in [p0, p1, p2, p3] {
                assert!(corners.iter().any(|c| (*c - q).length() < 1e-6), "corner {q} not among {corners:?}");
            }
            let mut first = 0;
            let n = 64;
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    first += (quad.sample(u).0 == 7) as usize;
                    let affine = origin + u.x * (x - origin) + u.y * (y - origin);
                    assert!((point(u) - affine).length() < 1e-5, "{} vs {affine}", point(u));
                }
            }
            // Equal halves: within the midpoint grid's diagonal.
            assert!((first as f32 / (n * n) as f32 - 0.5).abs() <= 1.0 / n as f32, "{first}");
        }
    }

    #[test]
    fn only_parallelograms_pair() {
        let (p0, p1, p2) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0));
        let a = tri(p0, p1, p2);
        // A kite (not a parallelogram), a triangle facing the other way,
        // triangles sharing one vertex only.
        assert!(Parallelogram::of(0, &a, 1, &tri(p0, p2, Vec3::new(0.0, 2.0, 0.0))).is_none());
        assert!(Parallelogram::of(0, &a, 1, &tri(p0, Vec3::Y, p2)).is_none());
        assert!(Parallelogram::of(0, &a, 1, &tri(p2, Vec3::new(2.0, 1.0, 0.0), Vec3::new(2.0, 2.0, 0.0))).is_none());
        assert!(Parallelogram::of(0, &a, 1, &tri(p0, p2, Vec3::Y)).is_some());
    }
}
