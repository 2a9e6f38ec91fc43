//! Ray queries over the scene's triangles. obvhs builds a binary tree;
//! bvh_collapse.rs makes it 8-wide, and wide_bvh.rs lays it out with
//! full-precision boxes and traverses it. Triangle data is stored in BVH
//! leaf order so a leaf's triangles sit together in memory.
//!
//! Traversing obvhs 0.4.0's own compressed wide BVH (CWBVH) directly had
//! three pitfalls (`glint render --traversal` still compares against it,
//! as a yardstick): it misses hits for rays with a `-0.0` direction
//! component; its
//! `Triangle::compute_barycentric` is wrong (hits here are computed by our
//! own Möller–Trumbore test); and its node test ignores the ray's tmin and
//! culls every node the ray leaves within 1e-4 (a fixed `EPSILON` in
//! cwbvh/node.rs and simd.rs), which loses every hit closer than 0.1 mm —
//! contact shadows, corners, and a whole scene modelled at 1e-4 scale.
//! wide_bvh.rs' boxes start at t = 0 and are widened against rounding.

use crate::scene::Triangle;
use crate::triangle_pack::{PackRay, TrianglePack};
use crate::wide_bvh::WideBvh;
use crate::Vec3;
use crate::bvh_collapse::Plan;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ploc::PlocBuilder;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::BvhBuildParams;
use std::time::Duration;

/// Build preset: the medium PLOC build with reinsertion — close to Embree's
/// build time with faster traversal (obvhs' own description). Its binary
/// tree is what Glint collapses; its CWBVH settings serve the yardstick.
pub const BUILD_PARAMS: BvhBuildParams = BvhBuildParams::medium_build();

#[derive(Clone, Copy, Debug)]
pub(crate) struct RtTriangle {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

impl From<&Triangle> for RtTriangle {
    fn from(t: &Triangle) -> Self {
        let [v0, v1, v2] = t.p();
        RtTriangle::from(&[v0, v1, v2])
    }
}

impl From<&[Vec3; 3]> for RtTriangle {
    fn from(&[v0, v1, v2]: &[Vec3; 3]) -> Self {
        RtTriangle { v0, e1: v1 - v0, e2: v2 - v0 }
    }
}

/// A closest hit: distance along the (unit) ray, the scene triangle and the
/// barycentrics of vertices 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    pub b1: f32,
    pub b2: f32,
}

pub struct Accel {
    bvh: WideBvh,
    /// Leaf n's triangles, and the scene triangle of each lane (u32::MAX
    /// for an empty one).
    packs: Vec<TrianglePack>,
    pack_ids: Vec<[u32; 4]>,
    /// Scene triangles in BVH order.
    ids: Vec<u32>,
}

/// Möller–Trumbore: (t, b1, b2) when the ray hits inside (tmin, tmax).
#[inline(always)]
pub(crate) fn intersect(tri: &RtTriangle, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
    let p = d.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - tri.v0;
    let b1 = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(tri.e1);
    let b2 = d.dot(q) * inv;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t > tmin && t < tmax).then_some((t, b1, b2))
}

fn obvhs_triangles(triangles: &[Triangle], subset: &[u32]) -> Vec<obvhs::triangle::Triangle> {
    subset.iter().map(|&i| triangles[i as usize].p()).map(|[v0, v1, v2]| obvhs::triangle::Triangle { v0, v1, v2 }).collect()
}

/// obvhs's CWBVH over the given triangles.
pub(crate) fn build_cwbvh(triangles: &[Triangle], subset: &[u32]) -> CwBvh {
    build_cwbvh_from_tris(&obvhs_triangles(triangles, subset), BUILD_PARAMS, &mut Duration::default())
}

/// obvhs' binary tree over the given triangles, one a leaf.
pub(crate) fn binary_tree(triangles: &[Triangle], subset: &[u32]) -> Bvh2 {
    let tris = obvhs_triangles(triangles, subset);
    let p = BUILD_PARAMS;
    let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(p.ploc_search_distance, &tris, (0..tris.len() as u32).collect(), p.sort_precision, p.search_depth_threshold);
    drop(tris);
    ReinsertionOptimizer::default().run(&mut bvh2, p.reinsertion_batch_ratio, None);
    bvh2
}

/// The wide BVH over the given triangles, and their places in `subset`
/// in leaf order: obvhs' binary tree (`BUILD_PARAMS`' PLOC and
/// reinsertion, as its CWBVH builder makes it), collapsed by
/// bvh_collapse.rs.
pub(crate) fn build_wide(triangles: &[Triangle], subset: &[u32]) -> (WideBvh, Vec<u32>) {
    let bvh2 = binary_tree(triangles, subset);
    let plan = Plan::new(&bvh2);
    let corners: Vec<[Vec3; 3]> = subset.iter().map(|&i| triangles[i as usize].p()).collect();
    WideBvh::from_bvh2(&bvh2, &plan, &corners)
}

impl Accel {
    /// Triangles must be finite and of non-zero area (the loader drops the
    /// rest): obvhs can panic on NaN bounds.
    pub fn build(triangles: &[Triangle]) -> (Self, Duration) {
        let all: Vec<u32> = (0..triangles.len() as u32).collect();
        Self::build_subset(triangles, &all)
    }

    /// Over the scene triangles `subset` only; hits name scene triangles.
    pub fn build_subset(triangles: &[Triangle], subset: &[u32]) -> (Self, Duration) {
        let start = std::time::Instant::now();
        if subset.is_empty() {
            return (Accel { bvh: WideBvh::empty(), packs: Vec::new(), pack_ids: Vec::new(), ids: Vec::new() }, start.elapsed());
        }
        let (bvh, order) = build_wide(triangles, subset);
        let ids: Vec<u32> = order.iter().map(|&i| subset[i as usize]).collect();
        let (mut packs, mut pack_ids) = (Vec::with_capacity(bvh.leaves.len()), Vec::with_capacity(bvh.leaves.len()));
        for &(first, count) in &bvh.leaves {
            let leaf = &ids[first as usize..(first + count) as usize];
            let mut corners = [[Vec3::ZERO; 3]; 4];
            leaf.iter().zip(&mut corners).for_each(|(&i, c)| *c = triangles[i as usize].p());
            packs.push(TrianglePack::new(&corners[..leaf.len()]));
            let mut lanes = [u32::MAX; 4];
            lanes[..leaf.len()].copy_from_slice(leaf);
            pack_ids.push(lanes);
        }
        (Accel { bvh, packs, pack_ids, ids }, start.elapsed())
    }

    /// Closest hit along a unit-direction ray within (0, tmax).
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        self.intersect_where(origin, dir, tmax, |_, _, _, _| true)
    }

    /// Closest hit that `stops(triangle, t, b1, b2)` accepts: surfaces with
    /// alpha let some rays through, decided as the traversal meets them,
    /// and a camera ray passes what lies before Clip Start.
    /// Always inlined: where the compiler called it instead, the render took
    /// 0.6–0.8% more instructions and the replayed camera rays (`--traversal`)
    /// ran at 15.6 Mrays/s against 16.9.
    #[inline(always)]
    pub fn intersect_where(&self, origin: Vec3, dir: Vec3, tmax: f32, mut stops: impl FnMut(u32, f32, f32, f32) -> bool) -> Option<Hit> {
        let ray = PackRay::new(origin, dir);
        let mut best: Option<Hit> = None;
        self.bvh.closest(origin, dir, tmax, |leaf, limit| self.nearest_in_leaf(&ray, leaf, limit, &mut stops, &mut best));
        best
    }

    /// `intersect` for a set of a few triangles, the lamps: where they fit
    /// in one leaf (a square or rectangular Blender area light is two
    /// triangles), its lanes are tested without the walk through the
    /// BVH's one node, which had cost a 1-spp gold sphere's bounce rays
    /// 1.7% of its instructions for its single lamp.
    #[inline]
    pub fn intersect_few(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        if self.packs.len() != 1 {
            return self.intersect(origin, dir, tmax);
        }
        let mut best: Option<Hit> = None;
        self.nearest_in_leaf(&PackRay::new(origin, dir), 0, tmax, &mut |_, _, _, _| true, &mut best);
        best
    }

    /// The nearest hit in leaf `leaf` before `limit` that `stops` accepts,
    /// into `best`; returns the limit for the leaves after it.
    #[inline(always)]
    fn nearest_in_leaf(&self, ray: &PackRay, leaf: u32, limit: f32, stops: &mut impl FnMut(u32, f32, f32, f32) -> bool, best: &mut Option<Hit>) -> f32 {
        let hits = self.packs[leaf as usize].intersect(ray, limit);
        // Nearest first: a surface the ray passes through (alpha) lets
        // the next one be tried.
        let mut mask = hits.mask;
        while mask != 0 {
            let lane = hits.nearest(mask);
            let triangle = self.pack_ids[leaf as usize][lane];
            if stops(triangle, hits.t[lane], hits.b1[lane], hits.b2[lane]) {
                *best = Some(Hit { t: hits.t[lane], triangle, b1: hits.b1[lane], b2: hits.b2[lane] });
                return hits.t[lane];
            }
            mask &= !(1 << lane);
        }
        limit
    }

    /// The triangles of the leaves in `leaves` (of `leaf_count`) as (slot,
    /// scene triangle): a slot names the leaf and lane the traversal tests
    /// it in (`hit_in_slot`).
    pub fn slots(&self, leaves: std::ops::Range<usize>) -> impl Iterator<Item = (u32, u32)> + '_ {
        // Leaves are filled from lane 0: a leaf's lanes up to its count.
        let first = leaves.start;
        self.bvh.leaves[leaves.clone()].iter().zip(&self.pack_ids[leaves]).enumerate().flat_map(move |(i, (&(_, count), lanes))| lanes[..count as usize].iter().enumerate().map(move |(lane, &t)| (((first + i) * 4 + lane) as u32, t)))
    }

    pub fn leaf_count(&self) -> usize {
        self.packs.len()
    }

    /// Triangles in this BVH.
    pub fn triangle_count(&self) -> usize {
        self.ids.len()
    }

    /// The hit on the triangle in `slot` alone, by the very test (and so
    /// to the bit the numbers) the traversal would make of it.
    #[inline]
    pub fn hit_in_slot(&self, slot: u32, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let (leaf, lane) = ((slot / 4) as usize, (slot % 4) as usize);
        let hits = self.packs[leaf].intersect(&PackRay::new(origin, dir), f32::INFINITY);
        (hits.mask & (1 << lane) != 0).then(|| Hit { t: hits.t[lane], triangle: self.pack_ids[leaf][lane], b1: hits.b1[lane], b2: hits.b2[lane] })
    }

    /// Whether anything blocks the segment origin + t·dir, t in (0, tmax).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        self.occluded_except(origin, dir, tmax, u32::MAX)
    }

    /// `occluded`, not counting scene triangle `skip`: a shadow ray to a
    /// point on an emitter need not stop short of that emitter by a guessed
    /// epsilon (which lets walls closer than it leak light) — a flat
    /// triangle cannot shadow its own points.
    #[inline]
    pub fn occluded_except(&self, origin: Vec3, dir: Vec3, tmax: f32, skip: u32) -> bool {
        self.occluded_except_where(origin, dir, tmax, skip, |_, _, _| true)
    }

    /// `occluded_except`, counting only hits that `stops` accepts.
    #[inline]
    pub fn occluded_except_where(&self, origin: Vec3, dir: Vec3, tmax: f32, skip: u32, mut stops: impl FnMut(u32, f32, f32) -> bool) -> bool {
        let ray = PackRay::new(origin, dir);
        self.bvh.any(origin, dir, tmax, |leaf| {
            let hits = self.packs[leaf as usize].intersect(&ray, tmax);
            let ids = &self.pack_ids[leaf as usize];
            let mut mask = hits.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if ids[lane] != skip && stops(ids[lane], hits.b1[lane], hits.b2[lane]) {
                    return true;
                }
            }
            false
        })
    }

    /// The same BVH queried as obvhs's own examples do, with its triangle
    /// test and none of the fixes above: the yardstick of `glint render
    /// --traversal`. None without triangles.
    pub fn obvhs_alone(&self, triangles: &[Triangle]) -> Option<ObvhsAlone> {
        if self.ids.is_empty() {
            return None;
        }
        let bvh = build_cwbvh(triangles, &self.ids);
        let tris = bvh.primitive_indices.iter().map(|&k| triangles[self.ids[k as usize] as usize].p()).map(|[a, b, c]| obvhs::rt_triangle::RtTriangle::new(a, b, c)).collect();
        Some(ObvhsAlone { bvh, tris })
    }

    /// Reference closest hit by testing every triangle (for tests).
    pub fn intersect_brute_force(triangles: &[Triangle], origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for (i, t) in triangles.iter().enumerate() {
            let rt = RtTriangle::from(t);
            let limit = best.map_or(tmax, |b| b.t);
            if let Some((t, b1, b2)) = intersect(&rt, origin, dir, 0.0, limit) {
                best = Some(Hit { t, triangle: i as u32, b1, b2 });
            }
        }
        best
    }
}

/// See `Accel::obvhs_alone`.
pub struct ObvhsAlone {
    bvh: CwBvh,
    tris: Vec<obvhs::rt_triangle::RtTriangle>,
}

impl ObvhsAlone {
    /// Distance to the closest hit within (0, tmax), if any.
    #[inline]
    pub fn closest(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<f32> {
        let mut hit = RayHit::none();
        let ray = Ray::new(o, d, 0.0, tmax);
        self.bvh.ray_traverse(ray, &mut hit, |ray, id| self.tris[id].intersect(ray)).then_some(hit.t)
    }

    /// Whether anything lies within (0, tmax).
    #[inline]
    pub fn blocked(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let ray = Ray::new(o, d, 0.0, tmax);
        !self.bvh.ray_traverse_miss(ray, |ray, id| self.tris[id].intersect(ray))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
        Triangle::new([a, b, c], [Vec3::Z; 3], 0)
    }

    fn random_soup(n: usize, rng: &mut Rng) -> Vec<Triangle> {
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        (0..n)
            .map(|_| {
                let c = v();
                tri(c, c + v() * 0.2, c + v() * 0.2)
            })
            .filter(|t| t.area() > 1e-6)
            .collect()
    }

    /// An axis-aligned box of unit quads, like a Cornell box.
    fn axis_aligned_scene() -> Vec<Triangle> {
        let mut out = Vec::new();
        for i in -3..=3 {
            for j in -3..=3 {
                let (x, y) = (i as f32, j as f32);
                for z in [-4.0f32, 4.0] {
                    out.push(tri(Vec3::new(x, y, z), Vec3::new(x + 1.0, y, z), Vec3::new(x + 1.0, y + 1.0, z)));
                    out.push(tri(Vec3::new(x, y, z), Vec3::new(x + 1.0, y + 1.0, z), Vec3::new(x, y + 1.0, z)));
                    out.push(tri(Vec3::new(z, x, y), Vec3::new(z, x + 1.0, y), Vec3::new(z, x + 1.0, y + 1.0)));
                    out.push(tri(Vec3::new(x, z, y), Vec3::new(x + 1.0, z, y), Vec3::new(x + 1.0, z, y + 1.0)));
                }
            }
        }
        out
    }

    fn check_against_brute_force(scene: &[Triangle], rays: &[(Vec3, Vec3)]) {
        let (accel, _) = Accel::build(scene);
        for &(o, d) in rays {
            let a = accel.intersect(o, d, f32::INFINITY);
            let b = Accel::intersect_brute_force(scene, o, d, f32::INFINITY);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert!((a.t - b.t).abs() <= 1e-5 * b.t, "t {} vs {} for {o} {d}", a.t, b.t);
                    if a.triangle == b.triangle {
                        assert!((a.b1 - b.b1).abs() < 1e-5 && (a.b2 - b.b2).abs() < 1e-5);
                    }
                }
                (None, None) => {}
                _ => panic!("BVH {a:?} vs brute force {b:?} for ray {o} {d}"),
            }
            assert_eq!(accel.occluded(o, d, f32::INFINITY), b.is_some());
            if let Some(b) = b {
                assert!(!accel.occluded(o, d, b.t * 0.999), "occluded before the first hit");
            }
        }
    }

    /// The lamps' test without the BVH answers as the BVH does, to the
    /// bit: a quad lamp (one leaf) seen from all around, edges and corners
    /// included, and a set of more than one leaf, which takes the BVH.
    #[test]
    fn intersect_few_is_the_bvh_hit() {
        let (a, b, c, d) = (Vec3::new(-0.5, 1.0, -0.5), Vec3::new(0.5, 1.0, -0.5), Vec3::new(0.5, 1.0, 0.5), Vec3::new(-0.5, 1.0, 0.5));
        let quad = vec![tri(a, b, c), tri(a, c, d)];
        let mut rng = Rng::new(7, 1);
        let mut soup = random_soup(12, &mut rng);
        soup.extend(quad.iter().cloned());
        for triangles in [quad, soup] {
            let (accel, _) = Accel::build(&triangles);
            let mut hits = 0;
            for i in 0..20_000 {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
                // Every fourth ray aimed at a corner or along the diagonal.
                let target = match i % 4 {
                    0 => [a, b, c, d][i / 4 % 4],
                    1 => a.lerp(c, rng.next_f32()),
                    _ => Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5),
                };
                let dir = (target - o).normalize();
                let few = accel.intersect_few(o, dir, f32::INFINITY);
                let bvh = accel.intersect(o, dir, f32::INFINITY);
                assert_eq!(few.map(|h| (h.t.to_bits(), h.triangle, h.b1.to_bits(), h.b2.to_bits())), bvh.map(|h| (h.t.to_bits(), h.triangle, h.b1.to_bits(), h.b2.to_bits())), "ray {o} {dir}");
                hits += few.is_some() as u32;
            }
            assert!(hits > 5_000, "{hits} hits");
        }
    }

    #[test]
    fn matches_brute_force_on_random_rays() {
        let mut rng = Rng::new(1, 2);
        let scene = random_soup(2000, &mut rng);
        let rays: Vec<_> = (0..3000)
            .map(|_| {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
                let d = crate::sampling::cosine_hemisphere(rng.next_2d());
                let d = if rng.next_f32() < 0.5 { -d } else { d };
                (o, Vec3::new(d.z, d.x, d.y))
            })
            .collect();
        check_against_brute_force(&scene, &rays);
    }

    /// obvhs alone culls nodes the ray leaves within 1e-4: at these scales
    /// every hit was lost before `TraversalRay`.
    #[test]
    fn matches_brute_force_at_every_scale_and_offset() {
        for (scale, shift) in [(1e-6f32, 0.0f32), (1e-4, 0.0), (1e-4, 1.0), (1.0, 0.0), (1e4, 0.0), (1.0, 1e5)] {
            let mut rng = Rng::new(3, 4);
            let scene: Vec<Triangle> = random_soup(500, &mut rng)
                .into_iter()
                .map(|t| t.p().map(|p| p * scale + Vec3::splat(shift)))
                .map(|[a, b, c]| tri(a, b, c))
                .collect();
            let rays: Vec<_> = (0..1000)
                .map(|_| {
                    let o = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0) * scale + Vec3::splat(shift);
                    let d = crate::sampling::cosine_hemisphere(rng.next_2d());
                    (o, if rng.next_f32() < 0.5 { -d } else { d })
                })
                .collect();
            check_against_brute_force(&scene, &rays);
        }
    }

    #[test]
    fn matches_brute_force_on_axis_aligned_rays_with_negative_zeros() {
        let scene = axis_aligned_scene();
        let mut rays = Vec::new();
        for d in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(-0.0, -0.0, -1.0), Vec3::new(0.6, -0.0, -0.8)] {
            for k in 0..20 {
                let o = Vec3::new(0.13 + 0.27 * k as f32 - 2.7, 0.31 - 0.11 * k as f32, 0.05 * k as f32);
                rays.push((o, d));
            }
        }
        check_against_brute_force(&scene, &rays);
    }

    /// Degenerate input for the builder and the wide layout: 500 copies of
    /// one triangle, a fan of needles about one vertex, a flat grid (every
    /// box of zero height) and a mix of 1e-5 and 1e5 sizes, traversed by
    /// rays from all sides and along the grid's plane.
    #[test]
    fn matches_brute_force_on_degenerate_input() {
        let mut scene = Vec::new();
        let base = tri(Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.6, 0.2, 0.3), Vec3::new(0.1, 0.7, 0.35));
        scene.extend(std::iter::repeat_n(base.clone(), 500));
        for k in 0..300 {
            let a = k as f32 * 0.021;
            scene.push(tri(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(-1.0 + a.cos(), -1.0 + a.sin(), 1e-3), Vec3::new(-1.0 + (a + 1e-4).cos(), -1.0 + (a + 1e-4).sin(), 1e-3)));
        }
        for i in 0..20 {
            for j in 0..20 {
                let (x, z) = (i as f32 * 0.1 - 1.0, j as f32 * 0.1 - 1.0);
                scene.push(tri(Vec3::new(x, -0.5, z), Vec3::new(x + 0.1, -0.5, z), Vec3::new(x, -0.5, z + 0.1)));
            }
        }
        scene.push(tri(Vec3::splat(1e5), Vec3::new(-1e5, 1e5, 1e5), Vec3::new(1e5, -1e5, 1e5)));
        scene.push(tri(Vec3::new(0.5, 0.5, 0.5), Vec3::new(0.5 + 1e-5, 0.5, 0.5), Vec3::new(0.5, 0.5 + 1e-5, 0.5)));
        let scene: Vec<Triangle> = scene.into_iter().filter(|t| t.area() > 0.0).collect();
        let mut rng = Rng::new(8, 9);
        let mut rays = Vec::new();
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
            let d = crate::sampling::cosine_hemisphere(rng.next_2d());
            rays.push((o, if rng.next_f32() < 0.5 { -d } else { d }));
        }
        // Along the grid's plane and just above it.
        for k in 0..200 {
            let o = Vec3::new(-1.5, -0.5 + (k % 2) as f32 * 1e-4, k as f32 * 0.01 - 1.0);
            rays.push((o, Vec3::new(1.0, 0.0, 0.0)));
            rays.push((o, Vec3::new(1.0, -1e-3, 0.2).normalize()));
        }
        // Straight at the copies and the tiny triangle.
        rays.push((Vec3::new(0.2, 0.3, -1.0), Vec3::Z));
        rays.push((Vec3::new(0.500001, 0.500001, 0.0), Vec3::Z));
        check_against_brute_force(&scene, &rays);
    }

    #[test]
    fn empty_and_single_triangle_scenes() {
        let (empty, _) = Accel::build(&[]);
        assert!(empty.intersect(Vec3::ZERO, Vec3::Z, f32::INFINITY).is_none());
        assert!(!empty.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
        let one = [tri(Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, -1.0, 2.0), Vec3::new(0.0, 1.0, 2.0))];
        let (accel, _) = Accel::build(&one);
        let h = accel.intersect(Vec3::ZERO, Vec3::Z, f32::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6 && h.triangle == 0);
        assert!(accel.occluded(Vec3::ZERO, Vec3::Z, 3.0));
        assert!(!accel.occluded(Vec3::ZERO, Vec3::Z, 1.5));
    }
}
