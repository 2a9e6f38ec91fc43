//! An 8-wide BVH with full-precision bounds, laid out from the binary tree
//! obvhs builds, and its traversal.
//!
//! obvhs builds the tree (PLOC, reinsertion); bvh_collapse.rs chooses its
//! 8-wide nodes and leaves of up to 4 triangles. obvhs' own CWBVH stores
//! each child's box in 8-bit quantised planes, made for GPUs, whose
//! decoding was the costliest part of a CPU query. Here each node keeps its
//! 8 children's boxes as f32 in structure-of-arrays form, two 4-lane halves
//! per plane, so one node test is 12 SIMD subtract-multiply pairs (glam's
//! Vec4: SSE2 or NEON) and the bounds are exact, computed from the
//! triangles.
//!
//! Closest-hit queries visit hit children nearest first and skip a stacked
//! child whose entry distance is past the closest hit found; any-hit
//! queries stop at the first hit. Entry and exit distances are computed
//! with the ray's tmin at 0 and the exit widened by 1 + 2γ(3) (Ize 2013),
//! so a hit exactly on a box face is never culled by rounding.

use glam::Vec4;
use crate::Vec3;
use std::mem::MaybeUninit;
use crate::bvh_collapse::{primitives_of, Plan, Slot};
use obvhs::bvh2::Bvh2;

/// A child that is a leaf: the high bit, then the leaf's number.
const LEAF: u32 = 1 << 31;
/// Stack entries a query keeps on the machine stack; a deeper tree (up to
/// 7 children per level wait, and a node pushes 8) gets a heap stack of its
/// own size.
const STACK: usize = 256;

/// Eight children's boxes: `planes[axis][0]` the minima, `[1]` the maxima,
/// each as two halves of 4 lanes. An empty slot has min +∞ and max −∞ and
/// is never entered.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    planes: [[[Vec4; 2]; 2]; 3],
    child: [u32; 8],
}

pub struct WideBvh {
    nodes: Vec<Node>,
    /// Leaf n's triangles: places first..first + count (at most 4) of the
    /// leaf order `from_bvh2` returns.
    pub leaves: Vec<(u32, u32)>,
    /// The most entries a query's stack can hold.
    stack_needed: usize,
    /// Whether queries load the next node ahead (`PREFETCH_ABOVE`).
    prefetch: bool,
}

/// Node bytes above which a query asks for the next node's cache lines
/// while it tests the leaves of the one before: where the tree does not
/// fit a core's L2 (1–2 MB on these machines). Replayed rays on spheres of
/// 250k, 500k and 1M triangles (4, 8 and 16 MB of nodes; medians of 6–8
/// runs): bounce and shadow rays 0–4%, 4–6% and 7–13% faster; on the
/// benchmark scenes (at most 0.2 MB) the prefetches cost the gold sphere
/// 2.0% ± 0.6 of its 1-spp time and gained nothing.
const PREFETCH_ABOVE: usize = 2 << 20;

/// What a query precomputes of its ray.
struct RayData {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// Per axis, 1 where the direction is negative: the near plane of a box
    /// is then its maximum.
    negative: [usize; 3],
}

/// 1 + 2γ(3): what the exit distance of a box is widened by.
const EXIT_WIDENING: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// A ray prepared for node tests: 4 lanes twice (SSE2, NEON), or 8 at
/// once where the CPU has AVX (`Avx`). Both compute the same numbers.
trait NodeTest {
    fn new(o: Vec3, d: Vec3) -> Self;
    /// Which of the node's children the ray enters before `t_max`, as a
    /// bit mask, and their entry distances.
    fn enter(&self, node: &Node, t_max: f32) -> (u32, [f32; 8]);
}

impl NodeTest for RayData {
    #[inline(always)]
    fn new(o: Vec3, d: Vec3) -> Self {
        // A ±0 component gives ±∞: a slab the ray runs along is then
        // (−∞, ∞) or empty, as it should be, except at an origin exactly
        // on its plane, where (plane − o)·∞ is NaN and the node test
        // ignores it (the box is entered: conservative).
        let inv = |x: f32| 1.0 / x;
        RayData {
            origin: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv_dir: [Vec4::splat(inv(d.x)), Vec4::splat(inv(d.y)), Vec4::splat(inv(d.z))],
            negative: [(d.x.is_sign_negative()) as usize, (d.y.is_sign_negative()) as usize, (d.z.is_sign_negative()) as usize],
        }
    }

    #[inline(always)]
    fn enter(&self, node: &Node, t_max: f32) -> (u32, [f32; 8]) {
        let mut mask = 0;
        // As an array: indexing a Vec4 by a variable lane is a branch.
        let mut entry = [0.0f32; 8];
        let t_max = Vec4::splat(t_max);
        for half in 0..2 {
            let mut near = Vec4::ZERO;
            let mut far = t_max;
            for axis in 0..3 {
                let planes = &node.planes[axis];
                let n = (planes[self.negative[axis]][half] - self.origin[axis]) * self.inv_dir[axis];
                let f = (planes[1 - self.negative[axis]][half] - self.origin[axis]) * self.inv_dir[axis];
                // SSE's max and min return their second operand when the
                // first is NaN: a NaN slab leaves near and far as they are.
                near = n.max(near);
                far = f.min(far);
            }
            mask |= near.cmple(far * EXIT_WIDENING).bitmask() << (4 * half);
            entry[4 * half..4 * half + 4].copy_from_slice(&near.to_array());
        }
        (mask, entry)
    }
}

/// The node test on 8 lanes at once (AVX), the same arithmetic as
/// `RayData`'s in the same order: the same masks and distances.
#[cfg(target_arch = "x86_64")]
struct Avx {
    origin: [std::arch::x86_64::__m256; 3],
    inv_dir: [std::arch::x86_64::__m256; 3],
    negative: [usize; 3],
}

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx {
    #[inline(always)]
    fn new(o: Vec3, d: Vec3) -> Self {
        use std::arch::x86_64::_mm256_set1_ps;
        let base = RayData::new(o, d);
        // SAFETY: built only inside `#[target_feature(enable = "avx")]`
        // functions, called after the CPU was found to have AVX.
        let splat = |v: Vec4| unsafe { _mm256_set1_ps(v.x) };
        Avx { origin: base.origin.map(splat), inv_dir: base.inv_dir.map(splat), negative: base.negative }
    }

    #[inline(always)]
    fn enter(&self, node: &Node, t_max: f32) -> (u32, [f32; 8]) {
        use std::arch::x86_64::*;
        // SAFETY: as in `new`; each load reads the 8 floats of one plane
        // (two adjacent Vec4 of `Node::planes`).
        unsafe {
            let mut near = _mm256_setzero_ps();
            let mut far = _mm256_set1_ps(t_max);
            for axis in 0..3 {
                let planes = &node.planes[axis];
                let lo = _mm256_loadu_ps(planes[self.negative[axis]].as_ptr() as *const f32);
                let hi = _mm256_loadu_ps(planes[1 - self.negative[axis]].as_ptr() as *const f32);
                let n = _mm256_mul_ps(_mm256_sub_ps(lo, self.origin[axis]), self.inv_dir[axis]);
                let f = _mm256_mul_ps(_mm256_sub_ps(hi, self.origin[axis]), self.inv_dir[axis]);
                // As SSE's: the second operand where the first is NaN.
                near = _mm256_max_ps(n, near);
                far = _mm256_min_ps(f, far);
            }
            let inside = _mm256_cmp_ps::<_CMP_LE_OQ>(near, _mm256_mul_ps(far, _mm256_set1_ps(EXIT_WIDENING)));
            let mut entry = [0.0f32; 8];
            _mm256_storeu_ps(entry.as_mut_ptr(), near);
            (_mm256_movemask_ps(inside) as u32, entry)
        }
    }
}

/// Whether this CPU runs the 8-lane node test (detected once, then a load).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn has_avx() -> bool {
    std::arch::is_x86_feature_detected!("avx")
}

impl WideBvh {
    /// No triangles: every query misses.
    pub fn empty() -> Self {
        WideBvh { nodes: Vec::new(), leaves: Vec::new(), stack_needed: 0, prefetch: false }
    }

    /// The wide tree `plan` makes of obvhs' binary tree `bvh`, every box
    /// computed from `triangles` (in obvhs' input order), and the input
    /// indices of the triangles in leaf order, which `leaves` index.
    pub fn from_bvh2(bvh: &Bvh2, plan: &Plan, triangles: &[[Vec3; 3]]) -> (Self, Vec<u32>) {
        let mut tree = WideBvh { nodes: Vec::new(), leaves: Vec::new(), stack_needed: 0, prefetch: false };
        let mut order = Vec::with_capacity(triangles.len());
        if bvh.nodes.is_empty() {
            return (tree, order);
        }
        let mut depth = 0;
        let root = if plan.root_is_leaf() { None } else { Some(0) };
        tree.lay_out(bvh, plan, root, triangles, &mut order, 1, &mut depth);
        tree.stack_needed = 7 * depth + 8;
        tree.prefetch = tree.nodes.len() * std::mem::size_of::<Node>() > PREFETCH_ABOVE;
        (tree, order)
    }

    /// Appends the wide node of binary node `inner` (None: a root whose
    /// one child is the whole tree as a leaf) and its subtree, depth first
    /// so that a node's children follow it; returns its place and bounds.
    #[allow(clippy::too_many_arguments)]
    fn lay_out(&mut self, bvh: &Bvh2, plan: &Plan, inner: Option<u32>, triangles: &[[Vec3; 3]], order: &mut Vec<u32>, level: usize, depth: &mut usize) -> (u32, Vec3, Vec3) {
        *depth = (*depth).max(level);
        let at = self.nodes.len();
        self.nodes.push(Node { planes: [[[Vec4::INFINITY; 2], [Vec4::NEG_INFINITY; 2]]; 3], child: [0; 8] });
        let mut slots = [Slot { node: 0, leaf: true }; 8];
        let count = match inner {
            Some(n) => plan.children(bvh, n, &mut slots),
            None => 1,
        };
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for (slot, s) in slots[..count].iter().enumerate() {
            let (child, clo, chi) = if s.leaf {
                let first = order.len();
                primitives_of(bvh, s.node, order);
                let (mut clo, mut chi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                for &i in &order[first..] {
                    for v in triangles[i as usize] {
                        (clo, chi) = (clo.min(v), chi.max(v));
                    }
                }
                self.leaves.push((first as u32, (order.len() - first) as u32));
                (LEAF | (self.leaves.len() - 1) as u32, clo, chi)
            } else {
                self.lay_out(bvh, plan, Some(s.node), triangles, order, level + 1, depth)
            };
            let node = &mut self.nodes[at];
            node.child[slot] = child;
            // One ulp outwards, so that a ray along a face (its origin on
            // the plane, its direction ±0 across it) is inside that slab
            // without falling back on the NaN rule.
            for axis in 0..3 {
                node.planes[axis][0][slot / 4][slot % 4] = clo[axis].next_down();
                node.planes[axis][1][slot / 4][slot % 4] = chi[axis].next_up();
            }
            (lo, hi) = (lo.min(clo), hi.max(chi));
        }
        (at as u32, lo, hi)
    }

    /// The closest hit: `hit(leaf, t_max)` tests a leaf's triangles and
    /// returns the closest distance it accepted below `t_max`, or `t_max`.
    #[inline(always)]
    pub fn closest(&self, o: Vec3, d: Vec3, t_max: f32, hit: impl FnMut(u32, f32) -> f32) {
        if self.nodes.is_empty() {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if has_avx() {
            // SAFETY: the CPU has AVX.
            return unsafe { self.closest_avx(o, d, t_max, hit) };
        }
        self.closest_on::<RayData>(o, d, t_max, hit)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn closest_avx(&self, o: Vec3, d: Vec3, t_max: f32, hit: impl FnMut(u32, f32) -> f32) {
        self.closest_on::<Avx>(o, d, t_max, hit)
    }

    /// The stack choice is written out here and in `any_on` rather than
    /// passed a closure: a closure inside the `#[target_feature]` callers
    /// is compiled without AVX, and its intrinsics become calls (a render
    /// took 2.4× as long).
    #[inline(always)]
    fn closest_on<T: NodeTest>(&self, o: Vec3, d: Vec3, t_max: f32, hit: impl FnMut(u32, f32) -> f32) {
        if self.stack_needed <= STACK {
            // Left uninitialised: a 2 KiB memset per query cost 1% of a render.
            self.closest_with::<T>(&mut [MaybeUninit::uninit(); STACK], o, d, t_max, hit)
        } else {
            self.closest_with::<T>(&mut vec![MaybeUninit::uninit(); self.stack_needed], o, d, t_max, hit)
        }
    }

    #[inline(always)]
    fn closest_with<T: NodeTest>(&self, stack: &mut [MaybeUninit<(u32, f32)>], o: Vec3, d: Vec3, mut t_max: f32, mut hit: impl FnMut(u32, f32) -> f32) {
        let ray = T::new(o, d);
        let mut top = 0;
        let mut node = 0u32;
        loop {
            let (mask, entry) = ray.enter(&self.nodes[node as usize], t_max);
            let children = &self.nodes[node as usize].child;
            // The entered children sorted farthest first.
            let mut order = [(0u32, 0.0f32); 8];
            let mut count = 0;
            let mut bits = mask;
            while bits != 0 {
                let slot = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let t = entry[slot];
                let mut i = count;
                while i > 0 && order[i - 1].1 < t {
                    order[i] = order[i - 1];
                    i -= 1;
                }
                order[i] = (children[slot], t);
                count += 1;
            }
            // Inner nodes go on the stack, the nearest on top; leaves are
            // tested now, nearest first, so their hits shorten t_max for
            // every stacked node.
            let mut nearest_inner = None;
            for &(child, t) in &order[..count] {
                if child & LEAF == 0 {
                    stack[top].write((child, t));
                    top += 1;
                    nearest_inner = Some(child);
                }
            }
            // The next node is the nearest one stacked: its 4 cache lines
            // start loading while the leaves are tested.
            if let Some(next) = nearest_inner.filter(|_| self.prefetch) {
                crate::memory::prefetch(&self.nodes[next as usize]);
            }
            for &(child, t) in order[..count].iter().rev() {
                if child & LEAF != 0 && t <= t_max * EXIT_WIDENING {
                    t_max = hit(child & !LEAF, t_max);
                }
            }
            // The next node: the nearest stacked one the ray still enters.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: entries below `top` were written above.
                let (next, t) = unsafe { stack[top].assume_init() };
                if t <= t_max * EXIT_WIDENING {
                    node = next;
                    break;
                }
            }
        }
    }

    /// Whether `hit(leaf)` accepts a triangle of some leaf the ray enters
    /// before `t_max`; stops at the first.
    #[inline(always)]
    pub fn any(&self, o: Vec3, d: Vec3, t_max: f32, hit: impl FnMut(u32) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if has_avx() {
            // SAFETY: the CPU has AVX.
            return unsafe { self.any_avx(o, d, t_max, hit) };
        }
        self.any_on::<RayData>(o, d, t_max, hit)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn any_avx(&self, o: Vec3, d: Vec3, t_max: f32, hit: impl FnMut(u32) -> bool) -> bool {
        self.any_on::<Avx>(o, d, t_max, hit)
    }

    #[inline(always)]
    fn any_on<T: NodeTest>(&self, o: Vec3, d: Vec3, t_max: f32, hit: impl FnMut(u32) -> bool) -> bool {
        if self.stack_needed <= STACK {
            self.any_with::<T>(&mut [MaybeUninit::uninit(); STACK], o, d, t_max, hit)
        } else {
            self.any_with::<T>(&mut vec![MaybeUninit::uninit(); self.stack_needed], o, d, t_max, hit)
        }
    }

    #[inline(always)]
    fn any_with<T: NodeTest>(&self, stack: &mut [MaybeUninit<u32>], o: Vec3, d: Vec3, t_max: f32, mut hit: impl FnMut(u32) -> bool) -> bool {
        let ray = T::new(o, d);
        let mut top = 0;
        let mut node = 0u32;
        loop {
            let (mask, _) = ray.enter(&self.nodes[node as usize], t_max);
            let children = &self.nodes[node as usize].child;
            // Inner children stacked first, so that the next node's
            // cache lines load while the leaves are tested (as in
            // `closest_with`).
            let (mut bits, mut leaves) = (mask, 0u32);
            let mut next = None;
            while bits != 0 {
                let slot = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let child = children[slot];
                if child & LEAF != 0 {
                    leaves |= 1 << slot;
                } else {
                    stack[top].write(child);
                    top += 1;
                    next = Some(child);
                }
            }
            if let Some(next) = next.filter(|_| self.prefetch) {
                crate::memory::prefetch(&self.nodes[next as usize]);
            }
            while leaves != 0 {
                let slot = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                if hit(children[slot] & !LEAF) {
                    return true;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            // SAFETY: entries below `top` were written above.
            node = unsafe { stack[top].assume_init() };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accel;
    use crate::rng::Rng;
    use crate::scene::Triangle;

    /// A deep tree's heap stack answers as the machine stack does, a tree
    /// that prefetches as one that does not, and all as testing every
    /// triangle: a long thin stack of slivers (every
    /// ray crosses many boxes) seen from many directions.
    #[test]
    fn the_heap_stack_answers_as_the_machine_stack() {
        let mut rng = Rng::new(5, 6);
        let triangles: Vec<Triangle> = (0..3000)
            .map(|i| {
                let z = i as f32 * 1e-3;
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), z);
                Triangle::new([c, c + Vec3::new(0.3, 0.01, 0.0), c + Vec3::new(0.0, 0.3, 1e-4)], [Vec3::Z; 3], 0)
            })
            .collect();
        let corners: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.p()).collect();
        let all: Vec<u32> = (0..triangles.len() as u32).collect();
        let (small, order) = crate::accel::build_wide(&triangles, &all);
        let (mut heap, _) = crate::accel::build_wide(&triangles, &all);
        heap.stack_needed = STACK + 1;
        // And with the prefetches a large tree makes, which change nothing.
        let (mut ahead, _) = crate::accel::build_wide(&triangles, &all);
        ahead.prefetch = true;
        let tris: Vec<[Vec3; 3]> = order.iter().map(|&i| corners[i as usize]).collect();
        let closest = |bvh: &WideBvh, o: Vec3, d: Vec3| {
            let mut best = f32::INFINITY;
            bvh.closest(o, d, f32::INFINITY, |leaf, mut limit| {
                let (first, count) = bvh.leaves[leaf as usize];
                for t in &tris[first as usize..(first + count) as usize] {
                    let one = [Triangle::new(*t, [Vec3::Z; 3], 0)];
                    if let Some(h) = Accel::intersect_brute_force(&one, o, d, limit) {
                        limit = h.t;
                        best = h.t;
                    }
                }
                limit
            });
            best
        };
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32() * 2.0 - 0.5, rng.next_f32() * 2.0 - 0.5, rng.next_f32() * 4.0 - 1.0);
            let d = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0).normalize();
            let expected = Accel::intersect_brute_force(&triangles, o, d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t);
            assert_eq!(closest(&small, o, d), expected);
            assert_eq!(closest(&heap, o, d), expected);
            assert_eq!(closest(&ahead, o, d), expected);
            let hits = |bvh: &WideBvh| bvh.any(o, d, f32::INFINITY, |_| true);
            assert_eq!(hits(&small), hits(&heap));
            assert_eq!(hits(&small), hits(&ahead));
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod avx_tests {
    use super::*;
    use crate::rng::Rng;

    /// The 8-lane node test gives the 4-lane one's masks and distances bit
    /// for bit, so an image does not depend on the CPU it renders on:
    /// random boxes (some empty, some flat, some behind the ray) and rays
    /// with ±0 components and origins on box planes.
    #[test]
    fn avx_and_sse_node_tests_agree_bit_for_bit() {
        if !has_avx() {
            eprintln!("no AVX on this CPU: nothing to compare");
            return;
        }
        let mut rng = Rng::new(21, 22);
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        for k in 0..2000 {
            let mut node = Node { planes: [[[Vec4::INFINITY; 2], [Vec4::NEG_INFINITY; 2]]; 3], child: [0; 8] };
            let mut corners = Vec::new();
            for slot in 0..8 {
                if (k + slot) % 5 == 0 {
                    continue; // an empty slot
                }
                let (a, b) = (v(), v());
                let (lo, mut hi) = (a.min(b), a.max(b));
                if slot == 3 {
                    hi.y = lo.y; // flat
                }
                corners.push(lo);
                for axis in 0..3 {
                    node.planes[axis][0][slot / 4][slot % 4] = lo[axis];
                    node.planes[axis][1][slot / 4][slot % 4] = hi[axis];
                }
            }
            let mut o = v();
            if let Some(c) = corners.first() {
                o.x = c.x; // on a plane
            }
            let mut d = v().normalize_or_zero();
            if k % 3 == 0 {
                d.y = if k % 2 == 0 { 0.0 } else { -0.0 };
            }
            let t_max = if k % 4 == 0 { f32::INFINITY } else { 3.0 };
            let sse = RayData::new(o, d).enter(&node, t_max);
            // SAFETY: the CPU has AVX.
            let avx = unsafe { enter_with_avx(o, d, &node, t_max) };
            assert_eq!(sse.0, avx.0, "masks for {o} {d}");
            for slot in 0..8 {
                if sse.0 & 1 << slot != 0 {
                    assert_eq!(sse.1[slot].to_bits(), avx.1[slot].to_bits(), "entry {slot} for {o} {d}");
                }
            }
        }
    }

    #[target_feature(enable = "avx")]
    unsafe fn enter_with_avx(o: Vec3, d: Vec3, node: &Node, t_max: f32) -> (u32, [f32; 8]) {
        Avx::new(o, d).enter(node, t_max)
    }
}
