//! Which subtrees of obvhs' binary tree become the 8-wide BVH's nodes and
//! leaves: the surface-area heuristic's optimal collapse (Ylitie, Karras
//! and Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs", §3), with the costs of Glint's own queries and
//! leaves of up to 4 triangles, one `TrianglePack` each.
//!
//! obvhs' CWBVH conversion makes the same choice for leaves of up to 3
//! (its 8-bit child encoding) and then quantises every box and orders the
//! children by ray octant, none of which Glint's traversal uses; it took
//! a fifth of a million-triangle run, besides Glint's decoding of it.
//!
//! For a binary node n and k = 1..8 slots of a wide node, `cost[k]` is the
//! least expected cost of n's subtree spread over at most k children:
//!
//!   cost(n, 1) = min(leaf(n), A(n)·C_NODE + split(n, 8))
//!   cost(n, k) = min(cost(n, k − 1), split(n, k))
//!   split(n, k) = min over a + b = k of cost(left, a) + cost(right, b)
//!   leaf(n) = A(n)·(C_LEAF + N·C_TRIANGLE) where n holds N ≤ 4 triangles,
//!             else ∞
//!
//! with A the box's half area: the chance that a ray through the root
//! enters n, up to a constant.

use obvhs::bvh2::Bvh2;

/// Triangles a leaf holds at most: the lanes of one `TrianglePack`.
pub const LEAF_SIZE: u32 = 4;

/// Costs of the heuristic, per unit of half area: an 8-wide node a ray
/// enters (its children's boxes tested, the entered ones sorted and
/// stacked), a leaf (one 4-lane triangle test), and each triangle in it
/// (its lane's hit handled). Measured rather than derived: replaying the
/// rays of the four benchmark scenes (`glint render --traversal`, 6
/// alternating runs each), a leaf priced as one node and its triangles
/// free (leaves of 4 wherever the count allows) made the gold sphere's
/// queries the fastest (bounce rays 208% of obvhs' own rate against 186%
/// with its CWBVH) but the window room's shadow rays no faster (317%
/// against 312%); these costs give 206% and 365%, the Cornell box 203%
/// against 196%, and the lamp hall within its scatter.
const C_NODE: f32 = 1.0;
const C_LEAF: f32 = 0.3;
const C_TRIANGLE: f32 = 0.15;

/// The collapse of one binary tree: per binary node, 10 bytes. The costs
/// live only while the walk needs them (a node's, until its parent's are
/// known), on a stack as deep as the tree.
pub struct Plan {
    /// How node n's subtree is spread over k slots, k = 1..8: 0 is one
    /// slot, n itself (a leaf or a node, `as_leaf`); else `a << 4 | b`, a
    /// slots for the left subtree and b for the right.
    splits: Vec<[u8; 8]>,
    /// Whether n in one slot is a leaf (else an inner node).
    as_leaf: Vec<bool>,
    /// Slots given to the left subtree where n is an inner node; the right
    /// gets the rest of the 8.
    inner_split: Vec<u8>,
    /// The heuristic's cost of the whole tree: what the wide tree the
    /// plan lays out costs.
    pub cost: f32,
}

/// One child of a wide node: a binary node, as a leaf or an inner node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    pub node: u32,
    pub leaf: bool,
}

fn half_area(bvh: &Bvh2, n: usize) -> f32 {
    let d = bvh.nodes[n].aabb().max - bvh.nodes[n].aabb().min;
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// `split(n, k)` and its a (a + b = k) from the children's costs; the
/// first split (a = 1) where no sum is finite, so that every choice names
/// slots that exist.
fn best_split(left: &[f32; 8], right: &[f32; 8], k: usize) -> (f32, u8) {
    let mut best = (left[0] + right[k - 2], 1u8);
    for a in 2..k {
        let c = left[a - 1] + right[k - a - 1];
        if c < best.0 {
            best = (c, a as u8);
        }
    }
    best
}

/// What the walk keeps of a finished subtree for its parent.
struct Done {
    cost: [f32; 8],
    triangles: u32,
}

impl Plan {
    /// The collapse of `bvh`, whose leaves hold one primitive each (as
    /// obvhs' PLOC builds them; a leaf of more is a leaf all the same).
    pub fn new(bvh: &Bvh2) -> Self {
        let n = bvh.nodes.len();
        let mut plan = Plan { splits: vec![[0; 8]; n], as_leaf: vec![false; n], inner_split: vec![0; n], cost: 0.0 };
        if n == 0 {
            return plan;
        }
        // Post-order: a node is visited once (false) to stack its
        // children, and again (true) when both are done.
        let mut walk = vec![(0u32, false)];
        let mut done: Vec<Done> = Vec::new();
        while let Some((i, children_done)) = walk.pop() {
            let node = &bvh.nodes[i as usize];
            if node.is_leaf() {
                let area = half_area(bvh, i as usize);
                plan.as_leaf[i as usize] = true;
                done.push(Done { cost: [area * (C_LEAF + C_TRIANGLE * node.prim_count as f32); 8], triangles: node.prim_count });
                continue;
            }
            if !children_done {
                walk.extend([(i, true), (node.first_index + 1, false), (node.first_index, false)]);
                continue;
            }
            let area = half_area(bvh, i as usize);
            // Both children are on top, the right one last.
            let (Some(right), Some(left)) = (done.pop(), done.pop()) else { unreachable!("a binary node's two children are done before it") };
            let triangles = left.triangles.saturating_add(right.triangles);
            let (spread, a) = best_split(&left.cost, &right.cost, 8);
            let inner = area * C_NODE + spread;
            let leaf_cost = area * (C_LEAF + C_TRIANGLE * triangles as f32);
            let leaf = triangles <= LEAF_SIZE && leaf_cost < inner;
            let i = i as usize;
            plan.inner_split[i] = a;
            plan.as_leaf[i] = leaf;
            let mut cost = [if leaf { leaf_cost } else { inner }; 8];
            for k in 2..=8 {
                cost[k - 1] = cost[k - 2];
                plan.splits[i][k - 1] = plan.splits[i][k - 2];
                let (c, a) = if k == 8 { (spread, a) } else { best_split(&left.cost, &right.cost, k) };
                if c < cost[k - 1] {
                    cost[k - 1] = c;
                    plan.splits[i][k - 1] = a << 4 | (k as u8 - a);
                }
            }
            done.push(Done { cost, triangles });
        }
        plan.cost = done.first().map_or(0.0, |root| root.cost[0]);
        plan
    }

    /// Whether the root is best a single leaf: a wide BVH still needs a
    /// root node, which then has it as its only child.
    pub fn root_is_leaf(&self) -> bool {
        self.as_leaf.first().copied().unwrap_or(false)
    }

    /// The children of the wide node made from inner binary node `n`
    /// (root: 0); `out` receives up to 8, their number returned.
    pub fn children(&self, bvh: &Bvh2, n: u32, out: &mut [Slot; 8]) -> usize {
        let node = &bvh.nodes[n as usize];
        if node.is_leaf() {
            out[0] = Slot { node: n, leaf: true };
            return 1;
        }
        let a = self.inner_split[n as usize] as usize;
        let mut count = 0;
        self.spread(bvh, node.first_index, a, out, &mut count);
        self.spread(bvh, node.first_index + 1, 8 - a, out, &mut count);
        count
    }

    fn spread(&self, bvh: &Bvh2, n: u32, k: usize, out: &mut [Slot; 8], count: &mut usize) {
        let split = self.splits[n as usize][k - 1];
        if split == 0 {
            out[*count] = Slot { node: n, leaf: self.as_leaf[n as usize] };
            *count += 1;
        } else {
            let first = bvh.nodes[n as usize].first_index;
            self.spread(bvh, first, (split >> 4) as usize, out, count);
            self.spread(bvh, first + 1, (split & 15) as usize, out, count);
        }
    }
}

/// The primitives (obvhs' input indices) of binary node n's subtree, in
/// the tree's order, appended to `out`.
pub fn primitives_of(bvh: &Bvh2, n: u32, out: &mut Vec<u32>) {
    let mut stack = vec![n];
    while let Some(i) = stack.pop() {
        let node = &bvh.nodes[i as usize];
        if node.is_leaf() {
            let first = node.first_index as usize;
            out.extend_from_slice(&bvh.primitive_indices[first..first + node.prim_count as usize]);
        } else {
            stack.extend([node.first_index + 1, node.first_index]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::binary_tree;
    use crate::rng::Rng;
    use crate::scene::Triangle;
    use crate::Vec3;

    fn soup(n: usize, seed: u64) -> Vec<Triangle> {
        let mut rng = Rng::new(seed, 3);
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        (0..n)
            .map(|_| {
                let c = v();
                Triangle::new([c, c + v() * 0.3, c + v() * 0.3], [Vec3::Z; 3], 0)
            })
            .collect()
    }

    fn leaf_cost(bvh: &Bvh2, n: u32) -> f32 {
        let mut prims = Vec::new();
        primitives_of(bvh, n, &mut prims);
        half_area(bvh, n as usize) * (C_LEAF + C_TRIANGLE * prims.len() as f32)
    }

    /// The heuristic's cost of the wide tree the plan lays out, walked
    /// through `children` as `WideBvh::from_bvh2` walks it; checks each
    /// node's slots on the way: at most 8, leaves of 1 to 4 triangles,
    /// each triangle in exactly one leaf.
    fn laid_out_cost(bvh: &Bvh2, plan: &Plan, seen: &mut [u32]) -> f32 {
        fn node(bvh: &Bvh2, plan: &Plan, n: u32, seen: &mut [u32]) -> f32 {
            let mut slots = [Slot { node: 0, leaf: true }; 8];
            let count = plan.children(bvh, n, &mut slots);
            assert!((1..=8).contains(&count));
            let mut cost = half_area(bvh, n as usize) * C_NODE;
            for s in &slots[..count] {
                cost += if s.leaf {
                    let mut prims = Vec::new();
                    primitives_of(bvh, s.node, &mut prims);
                    assert!((1..=LEAF_SIZE as usize).contains(&prims.len()), "a leaf of {}", prims.len());
                    prims.iter().for_each(|&p| seen[p as usize] += 1);
                    leaf_cost(bvh, s.node)
                } else {
                    node(bvh, plan, s.node, seen)
                };
            }
            cost
        }
        if plan.root_is_leaf() {
            let mut prims = Vec::new();
            primitives_of(bvh, 0, &mut prims);
            prims.iter().for_each(|&p| seen[p as usize] += 1);
            return leaf_cost(bvh, 0);
        }
        node(bvh, plan, 0, seen)
    }

    /// Every way to spread node n's subtree over slots, by brute force:
    /// (slots, cost) for n as one leaf, n as one wide node over any of its
    /// children's spreads that fit 8 slots, and n dissolved into its
    /// children's slots side by side.
    fn every_spread(bvh: &Bvh2, n: u32) -> Vec<(usize, f32)> {
        let node = &bvh.nodes[n as usize];
        let mut prims = Vec::new();
        primitives_of(bvh, n, &mut prims);
        let mut out = Vec::new();
        if prims.len() <= LEAF_SIZE as usize || node.is_leaf() {
            out.push((1, leaf_cost(bvh, n)));
        }
        if !node.is_leaf() {
            let (left, right) = (every_spread(bvh, node.first_index), every_spread(bvh, node.first_index + 1));
            let area = half_area(bvh, n as usize);
            for &(a, ca) in &left {
                for &(b, cb) in &right {
                    if a + b <= 8 {
                        out.push((a + b, ca + cb));
                        out.push((1, area * C_NODE + ca + cb));
                    }
                }
            }
        }
        out
    }

    /// The plan's cost is the least of every collapse (brute force over
    /// trees of up to 11 triangles, so that a node's 8 slots bind), and
    /// the tree it lays out costs exactly that.
    #[test]
    fn the_plan_is_the_cheapest_collapse_and_lays_out_at_its_cost() {
        for (n, seed) in [(1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (8, 6), (9, 7), (11, 8), (11, 9)] {
            let tris = soup(n, seed);
            let all: Vec<u32> = (0..n as u32).collect();
            let bvh = binary_tree(&tris, &all);
            let plan = Plan::new(&bvh);
            let best = every_spread(&bvh, 0).into_iter().filter(|&(slots, _)| slots == 1).map(|(_, c)| c).fold(f32::INFINITY, f32::min);
            assert!((plan.cost - best).abs() <= 1e-5 * best, "{n} triangles: plan {} against brute force {best}", plan.cost);
            let mut seen = vec![0; n];
            let laid_out = laid_out_cost(&bvh, &plan, &mut seen);
            assert!((laid_out - plan.cost).abs() <= 1e-5 * plan.cost, "laid out {laid_out} against planned {}", plan.cost);
            assert!(seen.iter().all(|&k| k == 1), "{seen:?}");
        }
    }

    /// Larger and degenerate input: 500 copies of one triangle (every box
    /// the same), a flat grid (boxes of zero height), a mix of 1e-5 and
    /// 1e5 sizes and 5,000 random triangles keep the layout's invariants
    /// and its cost.
    #[test]
    fn degenerate_input_lays_out_whole() {
        let one = Triangle::new([Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.6, 0.2, 0.3), Vec3::new(0.1, 0.7, 0.35)], [Vec3::Z; 3], 0);
        let mut grid = Vec::new();
        for i in 0..30 {
            for j in 0..30 {
                let (x, z) = (i as f32 * 0.1, j as f32 * 0.1);
                grid.push(Triangle::new([Vec3::new(x, 0.0, z), Vec3::new(x + 0.1, 0.0, z), Vec3::new(x, 0.0, z + 0.1)], [Vec3::Z; 3], 0));
            }
        }
        let mut mixed = soup(300, 11);
        mixed.extend(soup(300, 12).into_iter().map(|t| Triangle::new(t.p().map(|p| p * 1e-5), [Vec3::Z; 3], 0)));
        mixed.push(Triangle::new([Vec3::splat(1e5), Vec3::new(-1e5, 1e5, 1e5), Vec3::new(1e5, -1e5, 1e5)], [Vec3::Z; 3], 0));
        for tris in [vec![one; 500], grid, mixed, soup(5000, 13)] {
            let all: Vec<u32> = (0..tris.len() as u32).collect();
            let bvh = binary_tree(&tris, &all);
            let plan = Plan::new(&bvh);
            let mut seen = vec![0; tris.len()];
            let laid_out = laid_out_cost(&bvh, &plan, &mut seen);
            assert!((laid_out - plan.cost).abs() <= 1e-4 * plan.cost.max(f32::MIN_POSITIVE), "laid out {laid_out} against planned {}", plan.cost);
            assert!(seen.iter().all(|&k| k == 1));
        }
    }
}
