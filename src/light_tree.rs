//! A light tree (Conty Estevez & Kulla 2018; Cycles' and pbrt-v4's
//! many-light samplers): the local lights in a tree whose nodes bound
//! their lights' place, facing and power. A light is picked by walking
//! down from the root, taking each child with its share of the children's
//! irradiance bounds at the shading point, so the lamps near a point and
//! facing it get its light samples. Picking by power alone gives a lamp at
//! the far end of a hall as many as the one above.
//!
//! The build makes a binary tree (bucketed splits), which is then opened
//! into nodes of up to eight children, as a BVH is collapsed for wide
//! traversal: a node's children are its binary node's descendants about
//! three levels down, and their bounds sit lane by lane so that the eight
//! shares are computed together in SIMD registers. Against walking the
//! binary tree, in the benchmark's hall of 32 lamps (128² and 256²,
//! 17 bounces): 13% less time per sample, and 12–17% less error at 1–16
//! spp, since a grandchild's share now comes from its own, tighter bound
//! rather than from its ancestors' shares.
//!
//! A lamp with a Spread emits only within its cone: a node of such lamps
//! gets no share where every one's cone misses the point (`cos_spread`).
//!
//! A light's probability is the product of the shares on its way down;
//! MIS recomputes it from the leaf up (every node knows its parent).
//! It depends on the point and on the receiver's normal (zero where the
//! BSDF transmits), so every caller for a vertex passes the same normal:
//! its light sample, the MIS density of a BSDF ray's hit from it
//! (`Previous::light_side`) and a light subpath's reverse density at y1.

use crate::light_cache::{LightCache, Site};
use crate::Vec3;

/// Which way some emitters shine: their normals lie within `cos_o` of
/// `axis` (and of −axis too where they are two-sided).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cone {
    pub axis: Vec3,
    pub cos_o: f32,
    pub sin_o: f32,
    pub both_ways: bool,
}

impl Cone {
    /// The cone about the weighted mean of unit `normals` (normal,
    /// two-sided, weight) that holds them all, each two-sided one taken on
    /// the first one's side; None where they are not all one- or all
    /// two-sided, one is not finite, or they spread over a hemisphere or
    /// more (the bound would then be no bound).
    pub fn around<I: Iterator<Item = (Vec3, bool, f32)> + Clone>(normals: I) -> Option<Cone> {
        let (first, both_ways, _) = normals.clone().next()?;
        if normals.clone().any(|(n, two, _)| two != both_ways || !n.is_finite()) {
            return None;
        }
        let side = |n: Vec3| if both_ways && n.dot(first) < 0.0 { -n } else { n };
        let axis = normals.clone().fold(Vec3::ZERO, |a, (n, _, w)| a + side(n) * w).normalize_or_zero();
        let cos_o = normals.map(|(n, _, _)| side(n).dot(axis)).fold(1.0f32, f32::min);
        (axis != Vec3::ZERO && cos_o > 0.0).then(|| Cone { axis, cos_o, sin_o: (1.0 - cos_o * cos_o).max(0.0).sqrt(), both_ways })
    }

    /// The largest cosine between an emitter's normal in the cone and the
    /// direction to a point at offset `v` (squared length `dist2`) from the
    /// centre of a sphere of squared radius `radius2` holding the
    /// emitters: cos(max(θ − θo − θu, 0)), θu the sphere's angular radius
    /// seen from the point; 1 inside the sphere.
    pub fn cos_bound(&self, v: Vec3, dist2: f32, radius2: f32) -> f32 {
        if dist2 <= radius2 {
            return 1.0;
        }
        let cos_t = self.axis.dot(v) / dist2.sqrt();
        let cos_t = if self.both_ways { cos_t.abs() } else { cos_t };
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let sin_u2 = radius2 / dist2;
        let (sin_u, cos_u) = (sin_u2.sqrt(), (1.0 - sin_u2).max(0.0).sqrt());
        let (cos_phi, sin_phi) = (self.cos_o * cos_u - self.sin_o * sin_u, self.sin_o * cos_u + self.cos_o * sin_u);
        if cos_t >= cos_phi { 1.0 } else { (cos_t * cos_phi + sin_t * sin_phi).max(0.0) }
    }
}

/// What the tree knows of one light.
#[derive(Clone, Copy, Debug)]
pub struct TreeLight {
    /// W such that W·cos/(π d²) bounds its irradiance at distance d: an
    /// emitter's power from one face (π·A·lum(Le)), π·I for a point or
    /// spot of luminous intensity I.
    pub weight: f32,
    /// A box holding it.
    pub lo: Vec3,
    pub hi: Vec3,
    /// Its unit normal and whether it emits from both faces; None where
    /// it shines every way.
    pub facing: Option<(Vec3, bool)>,
    /// The cosine of the widest angle to its normal at which it emits: 0
    /// (90°) but for a lamp with a Spread, cos h (h half the spread).
    pub cos_spread: f32,
}

/// A leaf's child field: the high bit, then its light.
const LEAF: u32 = 1 << 31;
/// Whether this CPU runs the walk compiled for AVX-512 (detected once,
/// then a load).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn has_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
}
/// An f32's sign bit.
const SIGN: u32 = 1 << 31;
/// An unused lane's child field.
const EMPTY: u32 = u32::MAX;
/// Below this depth a node is split where the cost says; deeper (lights
/// bunched so that each split peels off one) at the median, so no walk is
/// longer than this plus log₂ of the light count.
const MAX_COST_DEPTH: u32 = 32;
/// Candidate split planes per node.
const BUCKETS: usize = 12;
/// Children of a node of the tree that is walked: three levels of the
/// binary tree the build makes, whose shares are computed together in SIMD
/// lanes. The binary walk's importance evaluations, two per level with
/// four square roots each, were a fifth of the lamp hall's time.
pub(crate) const WIDTH: usize = 8;

/// A node of the binary tree the build makes.
struct Node {
    weight: f32,
    centre: Vec3,
    radius2: f32,
    cone: Option<Cone>,
    /// Its lights' least `TreeLight::cos_spread` where it has a cone, else 0.
    cos_spread: f32,
    /// The first of two children (the second follows it), or LEAF | light.
    child: u32,
}

/// Up to `WIDTH` children's bounds, a lane each (a structure of arrays,
/// so that a node's importances load without gathering). A child without
/// a cone has a zero axis and cos θo = −1, whose bound is 1 everywhere;
/// an empty lane has weight 0.
#[derive(Clone, Debug)]
struct WideNode {
    x: [f32; WIDTH],
    y: [f32; WIDTH],
    z: [f32; WIDTH],
    radius2: [f32; WIDTH],
    radius: [f32; WIDTH],
    weight: [f32; WIDTH],
    axis_x: [f32; WIDTH],
    axis_y: [f32; WIDTH],
    axis_z: [f32; WIDTH],
    cos_o: [f32; WIDTH],
    sin_o: [f32; WIDTH],
    /// The bits of a lane's d·cos θ that count: all, or all but the sign
    /// where its emitters are two-sided (|d·cos θ|). A mask rather than a
    /// bool, which took a byte load, a compare and a blend a lane.
    dot_bits: [u32; WIDTH],
    /// A wide node's index, LEAF | light, or EMPTY.
    child: [u32; WIDTH],
    /// Where this node hangs: `slot(parent, lane)`; u32::MAX at the root.
    parent: u32,
}

/// A node's lane as one number (a node index times `WIDTH` plus the lane).
fn slot(node: usize, lane: usize) -> u32 {
    (node * WIDTH + lane) as u32
}

impl WideNode {
    fn empty(parent: u32) -> Self {
        let zero = [0.0; WIDTH];
        WideNode {
            x: zero,
            y: zero,
            z: zero,
            radius2: zero,
            radius: zero,
            weight: zero,
            axis_x: zero,
            axis_y: zero,
            axis_z: zero,
            cos_o: [-1.0; WIDTH],
            sin_o: zero,
            dot_bits: [u32::MAX; WIDTH],
            child: [EMPTY; WIDTH],
            parent,
        }
    }

    fn set(&mut self, lane: usize, node: &Node, child: u32) {
        (self.x[lane], self.y[lane], self.z[lane]) = (node.centre.x, node.centre.y, node.centre.z);
        (self.radius2[lane], self.weight[lane], self.child[lane]) = (node.radius2, node.weight, child);
        self.radius[lane] = node.radius2.sqrt();
        if let Some(cone) = node.cone {
            (self.axis_x[lane], self.axis_y[lane], self.axis_z[lane]) = (cone.axis.x, cone.axis.y, cone.axis.z);
            (self.cos_o[lane], self.sin_o[lane]) = (cone.cos_o, cone.sin_o);
            self.dot_bits[lane] = if cone.both_ways { !SIGN } else { u32::MAX };
        }
    }

    /// Each child's upper bound of its irradiance at `p`, up to the
    /// constant 1/π: W·cos·cos'/d², d no less than the bounding sphere's
    /// radius, cos the bound of `Cone::cos_bound` and cos' that of the
    /// receiver's, lane by lane and without branches, so that the compiler
    /// keeps the lanes in SIMD registers.
    /// Every term of cos(θ − θo − θu) and cos(ψ − θu) is carried times d,
    /// which needs no √(d²): three square roots, independent of each
    /// other, and two divisions a lane, where `cos_bound` alone chains four
    /// and three (the latency of that chain was most of a pick's time).
    ///
    /// `n` is the receiver's normal: light that reaches `p` from below its
    /// plane counts for nothing there (an opaque surface reflects only
    /// what lands on the side it is seen from), so a child gets at most
    /// cos(ψ − θu) of its bound, ψ the angle from `n` to the child's centre
    /// and θu the half-angle its sphere subtends. A zero `n` bounds
    /// nothing: light counts from every side (a BSDF that transmits). A
    /// lamp 20 m down a hall, 3 m above the floor, gets cos' ≈ 0.15 of the
    /// bound it had without the receiver's.
    ///
    /// With `SPREAD`, lamps with a Spread emit only within cos θe
    /// (`cos_spread`, a lane's `Node::cos_spread`) of their normals: a
    /// child gets nothing where
    /// θ − θo − θu > θe, as in Cycles' light tree, where a softbox aimed
    /// elsewhere had taken light samples that its grid then left dark.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into a dozen lanes
    fn importances<const LANES: usize, const SPREAD: bool>(&self, p: Vec3, n: Vec3, cos_spread: &[f32; WIDTH]) -> [f32; WIDTH] {
        let mut out = [0.0; WIDTH];
        let receiver = n != Vec3::ZERO;
        for i in 0..LANES {
            let (vx, vy, vz) = (p.x - self.x[i], p.y - self.y[i], p.z - self.z[i]);
            let dist2 = vx * vx + vy * vy + vz * vz;
            let (r, r2) = (self.radius[i], self.radius2[i]);
            // d·cos θ, d·sin θ, d·cos θu.
            let dot = self.axis_x[i] * vx + self.axis_y[i] * vy + self.axis_z[i] * vz;
            let dot = f32::from_bits(dot.to_bits() & self.dot_bits[i]);
            let sin = (dist2 - dot * dot).max(0.0).sqrt();
            let cos_u = (dist2 - r2).max(0.0).sqrt();
            // d·cos φ and d·sin φ, φ = θo + θu.
            let (cos_o, sin_o) = (self.cos_o[i], self.sin_o[i]);
            let (cos_phi, sin_phi) = (cos_o * cos_u - sin_o * r, sin_o * cos_u + cos_o * r);
            // Inside the sphere or the widened cone the bound is W/d²;
            // outside, W·cos(θ − φ)/d², d²·cos(θ − φ) ≤ d² on top. `inv`
            // is 1/d² (1/r² inside the sphere, where the receiver's bound,
            // the other user of 1/d², is 1): one division for both.
            let within = dist2 <= r2 || dot >= cos_phi;
            let inv = 1.0 / dist2.max(r2).max(f32::MIN_POSITIVE);
            let cos = if within { 1.0 } else { (dot * cos_phi + sin * sin_phi).max(0.0) * inv };
            // d²·cos(θ − φ) against d²·cos θe.
            let cos = if SPREAD && !(within || dot * cos_phi + sin * sin_phi >= cos_spread[i] * dist2) { 0.0 } else { cos };
            // d·cos ψ and d·sin ψ; d²·cos(ψ − θu) = d cos ψ·d cos θu +
            // d sin ψ·d sin θu, and 1 where the sphere holds the normal.
            let toward = -(n.x * vx + n.y * vy + n.z * vz);
            let across = (dist2 - toward * toward).max(0.0).sqrt();
            let open = !receiver || dist2 <= r2 || toward >= cos_u;
            let facing = if open { 1.0 } else { (toward * cos_u + across * r).max(0.0) * inv };
            out[i] = self.weight[i] * cos * facing.min(1.0) * inv;
        }
        out
    }

    /// What each child's share of the picks at `p` is proportional to,
    /// and their sum (positive and finite): the importance, or, where no
    /// child has any (a point behind every lamp) or it overflows, the
    /// weight, or else 1 for each child. A child's share is its part
    /// over the sum, computed only for the child taken: dividing all eight
    /// had lengthened the walk's chain of dependent operations.
    #[inline(always)]
    fn parts<const SPREAD: bool>(&self, p: Vec3, n: Vec3, cos_spread: &[f32; WIDTH]) -> ([f32; WIDTH], f32) {
        // Lanes fill from the first, so a node of four children or fewer
        // (a hall of 32 lamps has eight) computes half the lanes; the rest
        // are 0, as an empty lane's importance is.
        let importance = if self.child[WIDTH / 2] == EMPTY { self.importances::<{ WIDTH / 2 }, SPREAD>(p, n, cos_spread) } else { self.importances::<WIDTH, SPREAD>(p, n, cos_spread) };
        let total = sum(&importance);
        // Positive and finite (NaN fails both), in two compares.
        if total > 0.0 && total < f32::INFINITY {
            return (importance, total);
        }
        let total = sum(&self.weight);
        if total > 0.0 && total < f32::INFINITY {
            return (self.weight, total);
        }
        let used = self.child.map(|c| if c != EMPTY { 1.0 } else { 0.0 });
        (used, sum(&used))
    }
}

/// A node's lanes summed as a binary tree: pairs, quads, both halves.
#[inline(always)]
fn sum(values: &[f32; WIDTH]) -> f32 {
    starts(values).1
}

/// Where each lane's interval of [0, total) starts, and the total, all
/// from the sums of a binary tree over the lanes, three additions deep,
/// where running sums left to right had been a chain of eight dependent
/// ones before a pick could start. Rounding is monotone, so the starts
/// never decrease, and a lane whose part is zero starts where the next one
/// does (x + 0 = x): it is never picked but as the last lane (`pick`).
/// So does a part below the rounding of the sum before it, as with
/// running sums: a share under 1e-7 of its neighbour's, never picked.
#[inline(always)]
pub(crate) fn starts(v: &[f32; WIDTH]) -> ([f32; WIDTH], f32) {
    let pairs = [v[0] + v[1], v[2] + v[3], v[4] + v[5], v[6] + v[7]];
    let quads = [pairs[0] + pairs[1], pairs[2] + pairs[3]];
    let six = quads[0] + pairs[2];
    ([0.0, v[0], pairs[0], pairs[0] + v[2], quads[0], quads[0] + v[4], six, six + v[6]], quads[0] + quads[1])
}

/// The lane of `parts` whose interval holds `target` in [0, total), and
/// target's offset into it: the count of starts after the first at or
/// below it, compares side by side.
#[inline(always)]
pub(crate) fn pick<const N: usize>(parts: &[f32; N], starts: &[f32; N], target: f32) -> (usize, f32) {
    let mut lane = starts[1..].iter().map(|&s| (s <= target) as usize).sum::<usize>();
    if parts[lane] <= 0.0 {
        // Past the last lane with a part (the total is added in another
        // order than the last start): that lane.
        lane = parts.iter().rposition(|&w| w > 0.0).unwrap_or(0);
    }
    (lane, target - starts[lane])
}

pub struct LightTree {
    nodes: Vec<WideNode>,
    /// Each light's leaf: `slot(node, lane)`.
    leaf_of: Vec<u32>,
    /// Each wide node's lanes' `Node::cos_spread` where a light has a
    /// Spread, else empty: only then does the walk bound each child by its
    /// emission cone (`WideNode::importances`). Apart from the nodes, which
    /// a 32-byte lane more had made 3% slower to walk in the lamp hall,
    /// without a Spread.
    cos_spread: Vec<[f32; WIDTH]>,
    /// Picks from a grid where one was asked for (`cache_over`).
    cache: Option<LightCache>,
}

impl LightTree {
    /// The tree over `lights` (indices into it are what `sample` returns);
    /// None without lights.
    pub fn new(lights: &[TreeLight]) -> Option<Self> {
        let binary = binary_tree(lights)?;
        let mut tree = LightTree { nodes: vec![WideNode::empty(u32::MAX)], leaf_of: vec![0; lights.len()], cos_spread: vec![[0.0; WIDTH]], cache: None };
        // (wide node, the binary node it opens): a stack, as in the build.
        let mut work = vec![(0usize, 0usize)];
        while let Some((wide, node)) = work.pop() {
            for (lane, kid) in open(&binary, node).into_iter().enumerate() {
                let child = if binary[kid].child & LEAF != 0 {
                    tree.leaf_of[(binary[kid].child & !LEAF) as usize] = slot(wide, lane);
                    binary[kid].child
                } else {
                    tree.nodes.push(WideNode::empty(slot(wide, lane)));
                    tree.cos_spread.push([0.0; WIDTH]);
                    work.push((tree.nodes.len() - 1, kid));
                    (tree.nodes.len() - 1) as u32
                };
                tree.nodes[wide].set(lane, &binary[kid], child);
                tree.cos_spread[wide][lane] = binary[kid].cos_spread;
            }
        }
        if !lights.iter().any(|l| l.facing.is_some() && l.cos_spread > 0.0) {
            tree.cos_spread = Vec::new();
        }
        Some(tree)
    }

    /// Picks at points within `lo`..`hi` from a grid (light_cache.rs),
    /// where the tree walks more than one node, the cache holds every
    /// light and none has a Spread (whose cone the tree bounds a child by,
    /// and a grid's cell would not); elsewhere, and at points outside the
    /// grid, the tree's.
    ///
    /// `along_axes`: whether some surface lies along an axis, where the
    /// grid keeps parts by axis (light_cache.rs); asked only for a grid
    /// that is made.
    pub fn cache_over(&mut self, lights: &[TreeLight], lo: Vec3, hi: Vec3, along_axes: impl FnOnce() -> bool) {
        if lights.len() > WIDTH && !self.spread() {
            self.cache = LightCache::new(lights, lo, hi, along_axes);
        }
    }

    /// Whether picks come from a grid where they can (`cache_over`).
    pub fn cached(&self) -> bool {
        self.cache.is_some()
    }

    /// Whether a light has a Spread.
    #[inline(always)]
    fn spread(&self) -> bool {
        !self.cos_spread.is_empty()
    }

    /// Wide node `node`'s lanes' `Node::cos_spread`, read by the walk
    /// with `SPREAD` alone.
    #[inline(always)]
    fn spread_lanes<const SPREAD: bool>(&self, node: usize) -> &[f32; WIDTH] {
        if SPREAD { &self.cos_spread[node] } else { &[0.0; WIDTH] }
    }

    /// A light for a point at `p` whose light counts from above the plane
    /// of normal `n` only (zero: from every side), from `u` in [0, 1): its
    /// index, the probability of picking it, and u rescaled within the pick
    /// to a fresh number in [0, 1).
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> (usize, f32, f32) {
        self.sample_at(None, p, n, u)
    }

    /// Where a pick at `p` and `n` reads the grid, if there is one, with
    /// its lines asked for (`LightCache::site_fetched`).
    #[inline]
    pub fn site_fetched(&self, p: Vec3, n: Vec3) -> Option<Site> {
        self.cache.as_ref().map(|c| c.site_fetched(p, n))
    }

    /// `sample`, with the grid's `site` for `p` and `n` where the caller
    /// has it.
    pub fn sample_at(&self, site: Option<Site>, p: Vec3, n: Vec3, u: f32) -> (usize, f32, f32) {
        if let Some(picked) = self.cache.as_ref().and_then(|c| c.sample_at(site.unwrap_or_else(|| c.site(p, n)), p, n, u)) {
            return picked;
        }
        if self.spread() {
            return self.sample_spread(p, n, u);
        }
        #[cfg(target_arch = "x86_64")]
        if has_avx512() {
            // SAFETY: the CPU has AVX-512 F and VL.
            return unsafe { self.sample_avx512::<false>(p, n, u) };
        }
        self.sample_on::<false>(p, n, u)
    }

    /// `sample` where a light has a Spread, apart: inlined beside the walk
    /// without it, the two had made the baseline build's walk 2.6 times
    /// the instructions (the compiler no longer kept its lanes in SIMD
    /// registers).
    #[inline(never)]
    fn sample_spread(&self, p: Vec3, n: Vec3, u: f32) -> (usize, f32, f32) {
        #[cfg(target_arch = "x86_64")]
        if has_avx512() {
            // SAFETY: the CPU has AVX-512 F and VL.
            return unsafe { self.sample_avx512::<true>(p, n, u) };
        }
        self.sample_on::<true>(p, n, u)
    }

    /// `sample` compiled for AVX-512, where a node's eight lanes sit in
    /// one register and its compares write mask registers, which replace
    /// SSE's blends: the same operations in the same order (Rust fuses no
    /// multiply-adds), so the same bits (tested). 15% less time a pick and
    /// 30% a probability at 1,000 lights (light_tree_cost), the lamp hall
    /// 3–4% less time per sample (8 spp, least and median of 10 runs).
    /// AVX alone (2a87021's notes) had not paid; the BVH's traversal
    /// compiled for AVX-512 was 5% slower.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn sample_avx512<const SPREAD: bool>(&self, p: Vec3, n: Vec3, u: f32) -> (usize, f32, f32) {
        self.sample_on::<SPREAD>(p, n, u)
    }

    #[inline(always)]
    fn sample_on<const SPREAD: bool>(&self, p: Vec3, n: Vec3, u: f32) -> (usize, f32, f32) {
        let mut u = u.clamp(0.0, ONE_BELOW);
        let (mut index, mut probability) = (0, 1.0f32);
        loop {
            let node = &self.nodes[index];
            let (parts, total) = node.parts::<SPREAD>(p, n, self.spread_lanes::<SPREAD>(index));
            let (lane, offset) = pick(&parts, &starts(&parts).0, u * total);
            let part = parts[lane];
            u = (offset / part).clamp(0.0, ONE_BELOW);
            probability *= part / total;
            let child = node.child[lane];
            if child & LEAF != 0 {
                return ((child & !LEAF) as usize, probability, u);
            }
            index = child as usize;
        }
    }

    /// The probability with which `sample` picks `light` for a point at
    /// `p` and normal `n`.
    pub fn probability(&self, light: usize, p: Vec3, n: Vec3) -> f32 {
        if let Some(probability) = self.cache.as_ref().and_then(|c| c.probability(light, p, n)) {
            return probability;
        }
        if self.spread() {
            return self.probability_spread(light, p, n);
        }
        #[cfg(target_arch = "x86_64")]
        if has_avx512() {
            // SAFETY: the CPU has AVX-512 F and VL.
            return unsafe { self.probability_avx512::<false>(light, p, n) };
        }
        self.probability_on::<false>(light, p, n)
    }

    /// `probability` where a light has a Spread, apart (`sample_spread`).
    #[inline(never)]
    fn probability_spread(&self, light: usize, p: Vec3, n: Vec3) -> f32 {
        #[cfg(target_arch = "x86_64")]
        if has_avx512() {
            // SAFETY: the CPU has AVX-512 F and VL.
            return unsafe { self.probability_avx512::<true>(light, p, n) };
        }
        self.probability_on::<true>(light, p, n)
    }

    /// `probability` compiled as `sample_avx512` is.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    unsafe fn probability_avx512<const SPREAD: bool>(&self, light: usize, p: Vec3, n: Vec3) -> f32 {
        self.probability_on::<SPREAD>(light, p, n)
    }

    #[inline(always)]
    fn probability_on<const SPREAD: bool>(&self, light: usize, p: Vec3, n: Vec3) -> f32 {
        let mut at = self.leaf_of[light] as usize;
        let mut probability = 1.0f32;
        loop {
            let node = &self.nodes[at / WIDTH];
            let (parts, total) = node.parts::<SPREAD>(p, n, self.spread_lanes::<SPREAD>(at / WIDTH));
            probability *= parts[at % WIDTH] / total;
            if node.parent == u32::MAX {
                return probability;
            }
            at = node.parent as usize;
        }
    }

    pub fn len(&self) -> usize {
        self.leaf_of.len()
    }

    pub fn is_empty(&self) -> bool {
        self.leaf_of.is_empty()
    }
}

/// The binary tree over `lights`, root first; None without lights.
fn binary_tree(lights: &[TreeLight]) -> Option<Vec<Node>> {
    if lights.is_empty() {
        return None;
    }
    let mut order: Vec<u32> = (0..lights.len() as u32).collect();
    let mut nodes = Vec::with_capacity(2 * lights.len() - 1);
    nodes.push(bound(lights, &order));
    // (node, its lights' range in `order`, depth): a stack, as a
    // recursion as deep as a degenerate tree could overflow.
    let mut work = vec![(0usize, 0..lights.len(), 0u32)];
    while let Some((node, range, depth)) = work.pop() {
        if range.len() == 1 {
            nodes[node].child = LEAF | order[range.start];
            continue;
        }
        let mid = range.start + split(lights, &mut order[range.clone()], depth);
        let first = nodes.len();
        nodes[node].child = first as u32;
        nodes.push(bound(lights, &order[range.start..mid]));
        nodes.push(bound(lights, &order[mid..range.end]));
        work.push((first, range.start..mid, depth + 1));
        work.push((first + 1, mid..range.end, depth + 1));
    }
    Some(nodes)
}

/// The binary nodes a wide node over binary node `node` holds: its
/// children, then, while there are fewer than `WIDTH`, each time the inner
/// one of most weight × squared radius (the split cost's measure; of
/// equals, the shallowest, so that equal lights open level by level)
/// replaced by its two. A leaf alone (a tree of one light) is its own only
/// child.
fn open(binary: &[Node], node: usize) -> Vec<usize> {
    if binary[node].child & LEAF != 0 {
        return vec![node];
    }
    let first = binary[node].child as usize;
    // (binary node, depth below `node`)
    let mut kids = vec![(first, 1u32), (first + 1, 1)];
    let spread = |k: usize| binary[k].weight * binary[k].radius2;
    while kids.len() < WIDTH {
        let mut best: Option<usize> = None;
        for (i, &(k, depth)) in kids.iter().enumerate() {
            let better = |b: usize| {
                let (kb, db) = kids[b];
                spread(k) > spread(kb) || (spread(k) == spread(kb) && depth < db)
            };
            if binary[k].child & LEAF == 0 && best.is_none_or(better) {
                best = Some(i);
            }
        }
        let Some(i) = best else { break };
        let (k, depth) = kids[i];
        let first = binary[k].child as usize;
        kids[i] = (first, depth + 1);
        kids.insert(i + 1, (first + 1, depth + 1));
    }
    kids.into_iter().map(|(k, _)| k).collect()
}

pub(crate) const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// The binary node bounding `lights[order]`.
fn bound(lights: &[TreeLight], order: &[u32]) -> Node {
    let (mut lo, mut hi, mut weight) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0.0f32);
    for &i in order {
        let l = &lights[i as usize];
        (lo, hi, weight) = (lo.min(l.lo), hi.max(l.hi), weight + l.weight);
    }
    let facing = order.iter().map(|&i| &lights[i as usize]).filter_map(|l| l.facing.map(|(n, two_sided)| (n, two_sided, l.weight)));
    let cone = if facing.clone().count() == order.len() { Cone::around(facing) } else { None };
    let cos_spread = if cone.is_some() { order.iter().map(|&i| lights[i as usize].cos_spread.max(0.0)).fold(1.0, f32::min) } else { 0.0 };
    let (centre, radius2) = if lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z { (0.5 * (lo + hi), (0.5 * (hi - lo)).length_squared()) } else { (Vec3::ZERO, f32::INFINITY) };
    Node { weight, centre, radius2, cone, cos_spread, child: 0 }
}

/// Reorders `order` into two non-empty halves and returns the first's
/// length: at the bucket boundary along the centres' widest axis that
/// minimises Σ weight × squared diagonal of each half's box (how much
/// light each child spreads over how wide a region), or at the median
/// where the centres coincide or the tree is already deep.
fn split(lights: &[TreeLight], order: &mut [u32], depth: u32) -> usize {
    let centre = |i: u32| 0.5 * (lights[i as usize].lo + lights[i as usize].hi);
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for &i in order.iter() {
        (lo, hi) = (lo.min(centre(i)), hi.max(centre(i)));
    }
    let extent = hi - lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z { 0 } else if extent.y >= extent.z { 1 } else { 2 };
    let (start, width) = (lo[axis], extent[axis]);
    if depth < MAX_COST_DEPTH && width > 0.0 && width.is_finite() {
        let bucket = |i: u32| (((centre(i)[axis] - start) / width * BUCKETS as f32) as usize).min(BUCKETS - 1);
        let mut buckets = [(Vec3::INFINITY, Vec3::NEG_INFINITY, 0.0f32, 0usize); BUCKETS];
        for &i in order.iter() {
            let (b, l) = (&mut buckets[bucket(i)], &lights[i as usize]);
            *b = (b.0.min(l.lo), b.1.max(l.hi), b.2 + l.weight, b.3 + 1);
        }
        let cost = |bs: &[(Vec3, Vec3, f32, usize)]| {
            let (lo, hi, w) = bs.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY, 0.0f32), |(lo, hi, w), b| (lo.min(b.0), hi.max(b.1), w + b.2));
            w * (hi - lo).length_squared()
        };
        let best = (1..BUCKETS)
            .filter(|&s| buckets[..s].iter().any(|b| b.3 > 0) && buckets[s..].iter().any(|b| b.3 > 0))
            .map(|s| (s, cost(&buckets[..s]) + cost(&buckets[s..])))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((s, _)) = best {
            let mut first = 0;
            for k in 0..order.len() {
                if bucket(order[k]) < s {
                    order.swap(first, k);
                    first += 1;
                }
            }
            return first;
        }
    }
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]));
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn point(p: Vec3, weight: f32) -> TreeLight {
        TreeLight { weight, lo: p, hi: p, facing: None, cos_spread: 0.0 }
    }

    /// A small square lamp at `p` facing `n`.
    fn panel(p: Vec3, n: Vec3, weight: f32) -> TreeLight {
        TreeLight { weight, lo: p - Vec3::splat(0.05), hi: p + Vec3::splat(0.05), facing: Some((n, false)), cos_spread: 0.0 }
    }

    /// Stratified numbers down the tree land on each light as often as
    /// its probability says (a light's numbers are one interval, so the
    /// count is within one of n·p), and the probabilities sum to 1.
    fn assert_consistent(tree: &LightTree, p: Vec3, normal: Vec3, what: &str) {
        let n = 20_000;
        let mut counts = vec![0u32; tree.len()];
        for k in 0..n {
            let (light, probability, rest) = tree.sample(p, normal, (k as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&rest), "{what}: u rescaled to {rest}");
            // The same shares, multiplied top-down here and bottom-up there.
            let again = tree.probability(light, p, normal);
            assert!((probability - again).abs() <= 1e-5 * again, "{what}: light {light}: {probability} {again}");
            counts[light] += 1;
        }
        let total: f32 = (0..tree.len()).map(|i| tree.probability(i, p, normal)).sum();
        assert!((total - 1.0).abs() < 1e-4, "{what}: probabilities sum to {total}");
        for (i, &c) in counts.iter().enumerate() {
            let expected = n as f32 * tree.probability(i, p, normal);
            assert!((c as f32 - expected).abs() <= 2.0 + 1e-3 * expected, "{what}: light {i} picked {c} times for {expected}");
        }
    }

    /// `count` lights in a 20 m cube, of powers from 0.01 to 100, a share
    /// `points` of them points and the rest panels facing about down.
    fn random_lights(rng: &mut Rng, count: usize, points: f32) -> Vec<TreeLight> {
        (0..count)
            .map(|_| {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0 - 10.0;
                let w = 0.01 + 100.0 * rng.next_f32() * rng.next_f32();
                if rng.next_f32() < points { point(c, w) } else { panel(c, Vec3::new(rng.next_f32() - 0.5, -1.0, rng.next_f32() - 0.5).normalize(), w) }
            })
            .collect()
    }

    #[test]
    fn picks_match_probabilities_for_random_lights() {
        let mut rng = Rng::new(7, 1);
        for case in 0..20 {
            let count = 1 + case * 7;
            let lights = random_lights(&mut rng, count, 0.5);
            let tree = LightTree::new(&lights).unwrap();
            for k in 0..4 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 30.0 - 15.0;
                let n = if k % 2 == 0 { Vec3::ZERO } else { Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y) };
                assert_consistent(&tree, p, n, &format!("{count} lights at {p}, normal {n}"));
            }
        }
    }

    /// Picks from a grid over a box match their probabilities at points
    /// inside it and outside it (the tree's there), with and without a
    /// receiver's normal; a grid is made for 9 to 32 lights without a
    /// Spread only.
    #[test]
    fn grid_picks_match_probabilities() {
        let mut rng = Rng::new(9, 1);
        for count in [9, 20, 32] {
            let lights = random_lights(&mut rng, count, 0.3);
            let plain = LightTree::new(&lights).unwrap();
            let mut tree = LightTree::new(&lights).unwrap();
            tree.cache_over(&lights, Vec3::splat(-12.0), Vec3::splat(12.0), || true);
            assert!(tree.cached());
            for k in 0..12 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 24.0 - 12.0;
                let n = match k % 3 {
                    0 => Vec3::ZERO,
                    1 => Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y),
                    // Along an axis: the cell's parts for it.
                    _ => AXES[k % 6],
                };
                assert_consistent(&tree, p, n, &format!("{count} lights, grid, at {p}, normal {n}"));
            }
            let outside = Vec3::new(30.0, 0.0, 0.0);
            assert_consistent(&tree, outside, Vec3::X, "outside the grid");
            assert_eq!(tree.probability(3, outside, Vec3::X), plain.probability(3, outside, Vec3::X));
        }
        for count in [8, 33] {
            let lights: Vec<TreeLight> = (0..count).map(|i| point(Vec3::new(i as f32, 0.0, 0.0), 1.0)).collect();
            let mut tree = LightTree::new(&lights).unwrap();
            tree.cache_over(&lights, Vec3::splat(-1.0), Vec3::splat(40.0), || true);
            assert!(!tree.cached(), "{count} lights");
        }
        let mut spread = random_lights(&mut rng, 12, 0.0);
        spread[4].cos_spread = 0.9;
        let mut tree = LightTree::new(&spread).unwrap();
        tree.cache_over(&spread, Vec3::splat(-12.0), Vec3::splat(12.0), || true);
        assert!(!tree.cached(), "a light with a Spread");
    }

    const AXES: [Vec3; 6] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];

    /// Where no surface lies along an axis the grid keeps no parts by
    /// axis, and a normal along one picks by the point's own facing; where
    /// one does, by the cell's, which beside a lamp differ.
    #[test]
    fn parts_by_axis_only_where_surfaces_lie_along_one() {
        let mut rng = Rng::new(21, 1);
        let lights = random_lights(&mut rng, 16, 0.0);
        let (mut by_axis, mut own) = (LightTree::new(&lights).unwrap(), LightTree::new(&lights).unwrap());
        by_axis.cache_over(&lights, Vec3::splat(-12.0), Vec3::splat(12.0), || true);
        own.cache_over(&lights, Vec3::splat(-12.0), Vec3::splat(12.0), || false);
        let mut differ = 0;
        for (k, l) in lights.iter().enumerate() {
            let p = 0.5 * (l.lo + l.hi) + Vec3::new(0.05, -0.3, 0.02);
            let n = AXES[k % 6];
            assert_consistent(&by_axis, p, n, &format!("by axis at {p}, {n}"));
            assert_consistent(&own, p, n, &format!("own at {p}, {n}"));
            differ += (0..lights.len()).any(|i| by_axis.probability(i, p, n) != own.probability(i, p, n)) as usize;
        }
        assert!(differ > lights.len() / 2, "{differ}");
    }

    /// A grid never takes every pick from a light that can light the
    /// point: wherever some point of a lamp lies above the receiver's
    /// plane and in front of the lamp, the lamp keeps a probability, at
    /// points all over the grid, next to the lamps and in their planes.
    #[test]
    fn a_grid_keeps_every_light_that_reaches_the_point() {
        let mut rng = Rng::new(13, 2);
        let lights: Vec<TreeLight> = (0..24)
            .map(|i| {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 8.0 - 4.0;
                let n = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y);
                if i % 6 == 0 { point(c, 1.0) } else { panel(c, n, 0.1 + rng.next_f32()) }
            })
            .collect();
        let mut tree = LightTree::new(&lights).unwrap();
        tree.cache_over(&lights, Vec3::splat(-5.0), Vec3::splat(5.0), || true);
        let mut checked = 0;
        for k in 0..3000 {
            // Every third point next to a lamp, within its box's reach.
            let p = if k % 3 == 0 {
                let l = &lights[k % lights.len()];
                0.5 * (l.lo + l.hi) + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.3
            } else {
                Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0 - 5.0
            };
            // Every other normal along an axis, exactly or to within 0.8°
            // (the parts by axis), or a little further (the point's own).
            let n = if k % 2 == 0 {
                let tilt = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5) * 0.02;
                (AXES[k % 6] + if k % 4 == 0 { tilt } else { Vec3::ZERO }).normalize()
            } else {
                Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y)
            };
            for (i, l) in lights.iter().enumerate() {
                let reaches = (0..64).any(|_| {
                    let y = l.lo + (l.hi - l.lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                    let front = l.facing.is_none_or(|(normal, both)| both || normal.dot(p - y) > 0.0);
                    n.dot(y - p) > 0.0 && front
                });
                if reaches {
                    checked += 1;
                    assert!(tree.probability(i, p, n) > 0.0, "light {i} at {p}, normal {n}");
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }

    /// The walk as this CPU runs it (compiled for AVX-512 where it has
    /// it) gives the bits of the walk compiled for the baseline: images do
    /// not depend on the machine's vector extensions.
    #[test]
    fn the_dispatched_walk_has_the_baseline_bits() {
        let mut rng = Rng::new(5, 3);
        for count in [2, 7, 32, 33, 300] {
            let lights: Vec<TreeLight> = (0..count)
                .map(|i| {
                    let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 40.0 - 20.0;
                    let w = 0.01 + 100.0 * rng.next_f32();
                    match i % 3 {
                        0 => point(c, w),
                        // Every other panel a softbox, in the trees of 32 or more.
                        1 => TreeLight { cos_spread: if count >= 32 && i % 2 == 1 { 0.9 } else { 0.0 }, ..panel(c, Vec3::new(rng.next_f32() - 0.5, -1.0, rng.next_f32() - 0.5).normalize(), w) },
                        _ => TreeLight { weight: w, lo: c - Vec3::splat(0.3), hi: c + Vec3::splat(0.3), facing: Some((Vec3::X, true)), cos_spread: 0.0 },
                    }
                })
                .collect();
            let tree = LightTree::new(&lights).unwrap();
            assert_eq!(tree.spread(), count >= 32);
            for k in 0..200 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 50.0 - 25.0;
                let n = if k % 3 == 0 { Vec3::ZERO } else { Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y) };
                let u = rng.next_f32();
                let (light, pick, rest) = tree.sample(p, n, u);
                let (base_light, base_pick, base_rest) = if tree.spread() { tree.sample_on::<true>(p, n, u) } else { tree.sample_on::<false>(p, n, u) };
                assert_eq!((light, pick.to_bits(), rest.to_bits()), (base_light, base_pick.to_bits(), base_rest.to_bits()), "{count} lights at {p}, normal {n}, u {u}");
                for i in [light, k % count] {
                    let base = if tree.spread() { tree.probability_on::<true>(i, p, n) } else { tree.probability_on::<false>(i, p, n) };
                    assert_eq!(tree.probability(i, p, n).to_bits(), base.to_bits(), "light {i} of {count} at {p}");
                }
            }
        }
    }

    /// The lanes' bound, carried times d, is `Cone::cos_bound`'s
    /// W·cos/max(d², r²) for nodes with and without cones, one- and
    /// two-sided, near, inside and far from their spheres.
    #[test]
    fn the_lanes_bound_is_the_cones() {
        let mut rng = Rng::new(3, 9);
        let mut r = |s: f32| (rng.next_f32() * 2.0 - 1.0) * s;
        for case in 0..2000 {
            let centre = Vec3::new(r(5.0), r(5.0), r(5.0));
            let radius2 = [0.0, 0.01, 1.0, 9.0][case % 4];
            let axis = Vec3::new(r(1.0), r(1.0), r(1.0)).normalize_or(Vec3::Z);
            let cos_o = [1.0, 0.9, 0.3, 0.01][case / 4 % 4];
            let cone = (case % 3 != 0).then(|| Cone { axis, cos_o, sin_o: (1.0f32 - cos_o * cos_o).sqrt(), both_ways: case % 5 == 0 });
            let node = Node { weight: 2.0, centre, radius2, cone, cos_spread: 0.0, child: LEAF };
            let mut wide = WideNode::empty(u32::MAX);
            wide.set(3, &node, LEAF);
            let p = centre + Vec3::new(r(1.0), r(1.0), r(1.0)).normalize_or(Vec3::X) * [0.0, 0.05, 0.5, 1.01, 3.0, 40.0][case % 6];
            let v = p - centre;
            let cos = cone.map_or(1.0, |c| c.cos_bound(v, v.length_squared(), radius2));
            let expected = 2.0 * cos / v.length_squared().max(radius2).max(f32::MIN_POSITIVE);
            let lanes = wide.importances::<WIDTH, false>(p, Vec3::ZERO, &[0.0; WIDTH]);
            assert!((lanes[3] - expected).abs() <= 1e-4 * expected + 1e-6, "case {case}: {} against {expected}", lanes[3]);
            assert!(lanes.iter().enumerate().all(|(i, &l)| i == 3 || l == 0.0), "case {case}: empty lanes {lanes:?}");
            // Lane 3 is in the first half, which is all a node of four
            // children or fewer computes: the same bits.
            assert_eq!(wide.importances::<{ WIDTH / 2 }, false>(p, Vec3::ZERO, &[0.0; WIDTH]), lanes, "case {case}");
            // A cone that reaches 90° bounds as a Lambertian one.
            assert_eq!(wide.importances::<WIDTH, true>(p, Vec3::ZERO, &[0.0; WIDTH]), lanes, "case {case}");
        }
    }

    /// Lamps with a Spread (here 60°, 20° and 6°) emit within h of their
    /// normals: a child whose every emitter point and normal (normals
    /// within θo of the axis, points in its sphere) sends light to p only
    /// at more than h from the normal gets nothing, and every other keeps
    /// a share; a bound that missed a point would bias the image where its
    /// light lands.
    #[test]
    fn a_softbox_child_has_no_share_where_its_grid_sends_no_light() {
        let mut rng = Rng::new(8, 1);
        let mut r = |s: f32| (rng.next_f32() * 2.0 - 1.0) * s;
        let mut rng2 = Rng::new(9, 4);
        let (mut dark, mut lit) = (0, 0);
        for case in 0..3000 {
            let centre = Vec3::new(r(5.0), r(5.0), r(5.0));
            let radius = [0.05, 0.5, 2.0][case % 3];
            let axis = Vec3::new(r(1.0), r(1.0), r(1.0)).normalize_or(Vec3::Z);
            let cos_o = [1.0, 0.95, 0.6][case / 3 % 3];
            let half = [30f32, 10.0, 3.0][case / 9 % 3].to_radians();
            let cone = Cone { axis, cos_o, sin_o: (1.0f32 - cos_o * cos_o).sqrt(), both_ways: false };
            let node = Node { weight: 1.0, centre, radius2: radius * radius, cone: Some(cone), cos_spread: half.cos(), child: LEAF };
            let mut wide = WideNode::empty(u32::MAX);
            wide.set(0, &node, LEAF);
            let p = centre + Vec3::new(r(1.0), r(1.0), r(1.0)).normalize_or(Vec3::X) * [1.01, 2.0, 5.0, 40.0][case % 4] * radius.max(0.3);
            let share = wide.importances::<WIDTH, true>(p, Vec3::ZERO, &[half.cos(); WIDTH])[0];
            assert!(share <= wide.importances::<WIDTH, false>(p, Vec3::ZERO, &[0.0; WIDTH])[0], "case {case}");
            if share > 0.0 {
                lit += 1;
                continue;
            }
            dark += 1;
            for _ in 0..200 {
                let x = centre + Vec3::new(rng2.next_f32() - 0.5, rng2.next_f32() - 0.5, rng2.next_f32() - 0.5).normalize_or(Vec3::Z) * radius * rng2.next_f32().cbrt();
                // A normal within θo of the axis.
                let tilt = Vec3::new(rng2.next_f32() - 0.5, rng2.next_f32() - 0.5, rng2.next_f32() - 0.5);
                let side = (tilt - axis * tilt.dot(axis)).normalize_or_zero();
                let sin_t = (1.0 - cos_o * cos_o).sqrt() * rng2.next_f32();
                let n = (axis * (1.0 - sin_t * sin_t).sqrt() + side * sin_t).normalize();
                let cos_out = n.dot((p - x).normalize_or_zero());
                assert!(cos_out <= half.cos() + 1e-4, "case {case}: light leaves at {}° toward p, within the {}° cone", cos_out.acos().to_degrees(), half.to_degrees());
            }
        }
        assert!(dark > 300 && lit > 300, "{dark} dark, {lit} lit");
    }

    /// The receiver's factor (the lane's importance with a normal over
    /// that without) is at least the cosine from the normal to every point
    /// of the child's sphere, 1 where the sphere holds the normal, 0 where
    /// the sphere lies wholly below the plane; a receiver bound that
    /// missed a point would bias the image wherever light lands there.
    #[test]
    fn the_receivers_bound_holds_for_every_point_of_the_sphere() {
        let mut rng = Rng::new(5, 2);
        let mut r = |s: f32| (rng.next_f32() * 2.0 - 1.0) * s;
        let mut rng2 = Rng::new(6, 3);
        for case in 0..2000 {
            let centre = Vec3::new(r(5.0), r(5.0), r(5.0));
            let radius = [0.0, 0.1, 1.0, 3.0][case % 4];
            let node = Node { weight: 1.0, centre, radius2: radius * radius, cone: None, cos_spread: 0.0, child: LEAF };
            let mut wide = WideNode::empty(u32::MAX);
            wide.set(0, &node, LEAF);
            let p = centre + Vec3::new(r(1.0), r(1.0), r(1.0)).normalize_or(Vec3::X) * [0.5, 1.01, 1.5, 4.0, 40.0][case % 5];
            let n = Vec3::new(r(1.0), r(1.0), r(1.0)).normalize_or(Vec3::Y);
            let (with, without) = (wide.importances::<WIDTH, false>(p, n, &[0.0; WIDTH])[0], wide.importances::<WIDTH, false>(p, Vec3::ZERO, &[0.0; WIDTH])[0]);
            let factor = with / without;
            assert!((0.0..=1.0).contains(&factor), "case {case}: {factor}");
            let to_centre = centre - p;
            if to_centre.length() <= radius {
                assert_eq!(factor, 1.0, "case {case}: inside the sphere");
            }
            if n.dot(to_centre) < -radius {
                assert_eq!(factor, 0.0, "case {case}: below the plane");
            }
            for _ in 0..50 {
                let q = centre + Vec3::new(rng2.next_f32() - 0.5, rng2.next_f32() - 0.5, rng2.next_f32() - 0.5).normalize_or(Vec3::Z) * radius * rng2.next_f32().sqrt();
                let cos = n.dot((q - p).normalize_or_zero());
                assert!(cos <= factor + 1e-4, "case {case}: a point at cos {cos} over the bound {factor}");
            }
        }
    }

    /// Light from below a receiver's plane counts for nothing there: a
    /// lamp under a floor gets none of its picks, and picks with a normal
    /// still match their probabilities.
    #[test]
    fn a_light_below_the_receivers_plane_gets_no_picks() {
        let tree = LightTree::new(&[point(Vec3::new(0.0, 3.0, 0.0), 1.0), point(Vec3::new(0.5, -3.0, 0.0), 10.0), point(Vec3::new(20.0, 3.0, 0.0), 1.0)]).unwrap();
        let floor = Vec3::ZERO;
        assert_eq!(tree.probability(1, floor, Vec3::Y), 0.0);
        assert!(tree.probability(1, floor, Vec3::ZERO) > 0.5, "without a normal the bright one below leads");
        // The far lamp is seen at a grazing 8.5°: its share shrinks by cos.
        let far = (tree.probability(2, floor, Vec3::Y), tree.probability(2, floor, Vec3::ZERO) / (1.0 - tree.probability(1, floor, Vec3::ZERO)));
        assert!(far.0 < 0.5 * far.1, "{far:?}");
        assert_consistent(&tree, floor, Vec3::Y, "a floor");
        assert_consistent(&tree, Vec3::new(10.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0).normalize(), "a slope");
    }

    /// Two equal lamps 100 m apart: beside one, it gets nearly every pick;
    /// half-way, each gets half.
    #[test]
    fn the_near_lamp_gets_the_samples() {
        let (a, b) = (Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0));
        let tree = LightTree::new(&[point(a, 1.0), point(b, 1.0)]).unwrap();
        let near_a = Vec3::new(0.0, 1.0, 0.0);
        assert!(tree.probability(0, near_a, Vec3::ZERO) > 0.999, "{}", tree.probability(0, near_a, Vec3::ZERO));
        assert!((tree.probability(1, Vec3::new(50.0, 3.0, 0.0), Vec3::ZERO) - 0.5).abs() < 1e-6);
    }

    /// A one-sided lamp facing away from a point gets none of its picks
    /// while another lamp lights it; behind every lamp, they share by
    /// weight.
    #[test]
    fn a_lamp_facing_away_gets_no_picks() {
        let lights = [panel(Vec3::ZERO, -Vec3::Y, 1.0), panel(Vec3::new(3.0, 0.0, 0.0), Vec3::Y, 3.0)];
        let tree = LightTree::new(&lights).unwrap();
        let above = Vec3::new(1.5, 5.0, 0.0);
        assert_eq!(tree.probability(0, above, Vec3::ZERO), 0.0);
        assert_eq!(tree.probability(1, above, Vec3::ZERO), 1.0);
        let (light, probability, _) = tree.sample(above, Vec3::ZERO, 0.0);
        assert_eq!((light, probability), (1, 1.0));
        // Below the second lamp, the first faces the point.
        assert!(tree.probability(0, Vec3::new(1.5, -5.0, 0.0), Vec3::ZERO) > 0.99);
        // Level with both, edge-on, the bounds' spheres still count.
        assert_consistent(&tree, Vec3::new(1.5, 0.0, 5.0), Vec3::ZERO, "edge-on");
    }

    /// Lights all in one place, in a line, of zero or overflowing weight,
    /// or one alone: the tree is built, stays shallow, and its picks still
    /// match its probabilities.
    #[test]
    fn degenerate_lights_build_and_sample() {
        let same: Vec<TreeLight> = (0..1000).map(|_| point(Vec3::ONE, 1.0)).collect();
        let tree = LightTree::new(&same).unwrap();
        // A balanced binary tree of depth 10, opened three levels a node.
        let deepest = (0..tree.len()).map(|i| tree.depth(i)).max().unwrap();
        assert!(deepest <= 4, "{deepest}");
        assert!((tree.probability(17, Vec3::ZERO, Vec3::ZERO) - 1e-3).abs() < 1e-6);
        // Each 1.2× farther than the last: a cost split would peel them off
        // one at a time; past MAX_COST_DEPTH the median takes over.
        let line: Vec<TreeLight> = (0..200).map(|i| point(Vec3::new(1.2f32.powi(i), 0.0, 0.0), 1.0)).collect();
        let tree = LightTree::new(&line).unwrap();
        let deepest = (0..tree.len()).map(|i| tree.depth(i)).max().unwrap();
        assert!(deepest <= MAX_COST_DEPTH as usize + 9, "{deepest}");
        assert_consistent(&tree, Vec3::new(3.0, 1.0, 0.0), Vec3::ZERO, "a line");
        let odd = [point(Vec3::ZERO, 0.0), point(Vec3::X, f32::INFINITY), point(Vec3::Y, 1.0), point(Vec3::ONE, 0.0)];
        let tree = LightTree::new(&odd).unwrap();
        for p in [Vec3::ZERO, Vec3::splat(5.0)] {
            let (light, probability, rest) = tree.sample(p, Vec3::ZERO, 0.3);
            assert!(light < 4 && probability.is_finite() && (0.0..1.0).contains(&rest));
            let total: f32 = (0..4).map(|i| tree.probability(i, p, Vec3::ZERO)).sum();
            assert!((total - 1.0).abs() < 1e-6, "{total}");
        }
        let one = LightTree::new(&[point(Vec3::ZERO, 2.0)]).unwrap();
        assert_eq!(one.sample(Vec3::X, Vec3::ZERO, 0.7), (0, 1.0, 0.7));
        assert_eq!(one.probability(0, Vec3::X, Vec3::ZERO), 1.0);
        assert!(LightTree::new(&[]).is_none());
    }

    /// A node's starts never decrease, every target in [0, total) lands
    /// in a lane with a part and within its interval, and each lane's
    /// interval is as wide as its part: lanes of zero anywhere (first,
    /// last, runs of them), parts of very different sizes, and targets at
    /// the ends, where the total (added in its own order) can round past
    /// the last start.
    #[test]
    fn a_pick_lands_in_a_lane_with_a_part() {
        let mut rng = Rng::new(5, 0);
        let mut parts_of = |k: usize| -> [f32; WIDTH] {
            std::array::from_fn(|i| match (k + i * 7) % 5 {
                0 => 0.0,
                1 => rng.next_f32() * 1e-6,
                2 => rng.next_f32() * 1e6,
                _ => rng.next_f32(),
            })
        };
        let mut cases: Vec<[f32; WIDTH]> = (0..2000).map(&mut parts_of).collect();
        cases.push([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        cases.push([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        cases.push([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.0]);
        cases.push([3.0e-8, 1.0, 1.0e8, 0.0, 1.0, 3.0, 0.0, 0.0]);
        for parts in cases {
            let (starts, total) = starts(&parts);
            if !(total > 0.0) {
                continue;
            }
            assert!(starts.windows(2).all(|w| w[0] <= w[1]), "{parts:?}: {starts:?}");
            assert_eq!(total, sum(&parts));
            for target in [0.0, total * 0.25, total * 0.5, total * ONE_BELOW, f32::from_bits(total.to_bits() - 1)] {
                let (lane, offset) = pick(&parts, &starts, target);
                assert!(parts[lane] > 0.0, "{parts:?} at {target}: lane {lane}");
                // Within the sums' rounding (`sample` clamps u to [0, 1)).
                assert!(offset >= 0.0 && offset <= parts[lane] + 4.0 * f32::EPSILON * total, "{parts:?} at {target}: lane {lane}, offset {offset}");
            }
            // Each lane is picked for the start of its interval, where it
            // has one: a part below the rounding of the sum before it has
            // none (as with running sums; its probability is then below
            // 1e-7 of its neighbour's).
            let end = |i: usize| if i + 1 < WIDTH { starts[i + 1] } else { total };
            for lane in (0..WIDTH).filter(|&i| parts[i] > 0.0 && end(i) > starts[i]) {
                assert_eq!(pick(&parts, &starts, starts[lane]).0, lane, "{parts:?}");
            }
        }
    }

    impl LightTree {
        /// The nodes on the way from the root to a light's leaf.
        fn depth(&self, light: usize) -> usize {
            let (mut at, mut depth) = (self.leaf_of[light], 1);
            while self.nodes[at as usize / WIDTH].parent != u32::MAX {
                at = self.nodes[at as usize / WIDTH].parent;
                depth += 1;
            }
            depth
        }
    }
}
