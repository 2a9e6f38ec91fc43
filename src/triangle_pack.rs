//! The triangles of one BVH leaf (at most 4, bvh_collapse.rs' leaf size)
//! as four SIMD lanes, tested against a ray at once by Möller–Trumbore.
//!
//! An unused lane has a zero edge: its determinant is 0 and it never hits.

use glam::Vec4;
use crate::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct TrianglePack {
    /// v0, e1 = v1 − v0, e2 = v2 − v0, each as x, y, z lanes.
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
}

/// The lanes a ray hits within (0, t_max), and their distances and
/// barycentrics of vertices 1 and 2.
pub struct PackHits {
    pub mask: u32,
    // Arrays: indexing a Vec4 by a variable lane is a branch.
    pub t: [f32; 4],
    pub b1: [f32; 4],
    pub b2: [f32; 4],
}

impl PackHits {
    /// The nearest hit lane among `mask`.
    #[inline(always)]
    pub fn nearest(&self, mask: u32) -> usize {
        let mut best = mask.trailing_zeros() as usize;
        let mut rest = mask & (mask - 1);
        while rest != 0 {
            let lane = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if self.t[lane] < self.t[best] {
                best = lane;
            }
        }
        best
    }
}

/// A ray's origin and direction splatted once per query.
pub struct PackRay {
    o: [Vec4; 3],
    d: [Vec4; 3],
}

impl PackRay {
    #[inline(always)]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        PackRay { o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)], d: [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)] }
    }
}

#[inline(always)]
fn cross(a: &[Vec4; 3], b: &[Vec4; 3]) -> [Vec4; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[inline(always)]
fn dot(a: &[Vec4; 3], b: &[Vec4; 3]) -> Vec4 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl TrianglePack {
    /// Up to four triangles given by their corners.
    pub fn new(triangles: &[[Vec3; 3]]) -> Self {
        assert!(triangles.len() <= 4, "a pack holds four triangles");
        let mut pack = TrianglePack { v0: [Vec4::ZERO; 3], e1: [Vec4::ZERO; 3], e2: [Vec4::ZERO; 3] };
        for (lane, [a, b, c]) in triangles.iter().enumerate() {
            let (e1, e2) = (*b - *a, *c - *a);
            for axis in 0..3 {
                pack.v0[axis][lane] = a[axis];
                pack.e1[axis][lane] = e1[axis];
                pack.e2[axis][lane] = e2[axis];
            }
        }
        pack
    }

    #[inline(always)]
    pub fn intersect(&self, ray: &PackRay, t_max: f32) -> PackHits {
        let p = cross(&ray.d, &self.e2);
        let det = dot(&self.e1, &p);
        let inv = Vec4::ONE / det;
        let s = [ray.o[0] - self.v0[0], ray.o[1] - self.v0[1], ray.o[2] - self.v0[2]];
        let b1 = dot(&s, &p) * inv;
        let q = cross(&s, &self.e1);
        let b2 = dot(&ray.d, &q) * inv;
        let t = dot(&self.e2, &q) * inv;
        // NaN fails every comparison: a zero or non-finite determinant
        // never hits.
        let ok = det.cmpne(Vec4::ZERO)
            & det.abs().cmplt(Vec4::INFINITY)
            & b1.cmpge(Vec4::ZERO)
            & b1.cmple(Vec4::ONE)
            & b2.cmpge(Vec4::ZERO)
            & (b1 + b2).cmple(Vec4::ONE)
            & t.cmpgt(Vec4::ZERO)
            & t.cmplt(Vec4::splat(t_max));
        PackHits { mask: ok.bitmask(), t: t.to_array(), b1: b1.to_array(), b2: b2.to_array() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accel;
    use crate::rng::Rng;
    use crate::scene::Triangle;

    /// Each lane answers as the scalar test of its triangle, empty lanes
    /// never hit, and degenerate triangles neither.
    #[test]
    fn lanes_answer_as_the_scalar_test() {
        let mut rng = Rng::new(11, 12);
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        for count in 0..=4 {
            for _ in 0..200 {
                let mut corners: Vec<[Vec3; 3]> = (0..count).map(|_| [v(), v(), v()]).collect();
                if count == 3 {
                    // A sliver of zero area.
                    let a = v();
                    corners[2] = [a, a * 2.0, a * 3.0];
                }
                let pack = TrianglePack::new(&corners);
                for _ in 0..20 {
                    let o = v() * 3.0;
                    let d = (v() - o * 0.2).normalize();
                    let hits = pack.intersect(&PackRay::new(o, d), 10.0);
                    for lane in 0..4 {
                        let scalar = corners.get(lane).and_then(|c| Accel::intersect_brute_force(&[Triangle::new(*c, [Vec3::Z; 3], 0)], o, d, 10.0));
                        match scalar {
                            Some(h) => {
                                assert!(hits.mask & 1 << lane != 0, "lane {lane} missed");
                                assert!((hits.t[lane] - h.t).abs() <= 1e-5 * h.t.max(1.0));
                                assert!((hits.b1[lane] - h.b1).abs() < 1e-4 && (hits.b2[lane] - h.b2).abs() < 1e-4);
                            }
                            // The two may differ only on an edge, to rounding.
                            None => assert!(hits.mask & 1 << lane == 0 || hits.b1[lane].min(hits.b2[lane]).min(1.0 - hits.b1[lane] - hits.b2[lane]) < 1e-5, "lane {lane} hit"),
                        }
                    }
                }
            }
        }
    }
}
