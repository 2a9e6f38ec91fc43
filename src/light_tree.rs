//! A light tree (Conty Estevez & Kulla 2018; Cycles' and pbrt-v4's
//! many-light samplers): the local lights in a binary tree whose nodes
//! bound their lights' place, facing and power. A light is picked by
//! walking down from the root, taking each child with its share of the
//! two children's irradiance bounds at the shading point, so the lamps
//! near a point and facing it get its light samples. Picking by power
//! alone gives a lamp at the far end of a hall as many as the one above.
//!
//! A light's probability is the product of the shares on its way down;
//! MIS recomputes it from the leaf up (every node knows its parent).
//! The shading point's normal is not used, so the probability of a light
//! depends on the point alone, as `Lights` promises its callers.

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
}

/// A leaf's child field: the high bit, then its light.
const LEAF: u32 = 1 << 31;
/// Below this depth a node is split where the cost says; deeper (lights
/// bunched so that each split peels off one) at the median, so no walk is
/// longer than this plus log₂ of the light count.
const MAX_COST_DEPTH: u32 = 32;
/// Candidate split planes per node.
const BUCKETS: usize = 12;

struct Node {
    weight: f32,
    centre: Vec3,
    radius2: f32,
    cone: Option<Cone>,
    parent: u32,
    /// The first of two children (the second follows it), or LEAF | light.
    child: u32,
}

impl Node {
    /// An upper bound of the node's irradiance at `p`, up to the constant
    /// 1/π: W·cos/d², d no less than the bounding sphere's radius.
    fn importance(&self, p: Vec3) -> f32 {
        let v = p - self.centre;
        let dist2 = v.length_squared();
        let d2 = dist2.max(self.radius2).max(f32::MIN_POSITIVE);
        let cos = match &self.cone {
            Some(cone) => cone.cos_bound(v, dist2, self.radius2),
            None => 1.0,
        };
        self.weight * cos / d2
    }
}

pub struct LightTree {
    nodes: Vec<Node>,
    /// Each light's leaf.
    leaf_of: Vec<u32>,
}

impl LightTree {
    /// The tree over `lights` (indices into it are what `sample` returns);
    /// None without lights.
    pub fn new(lights: &[TreeLight]) -> Option<Self> {
        if lights.is_empty() {
            return None;
        }
        let mut order: Vec<u32> = (0..lights.len() as u32).collect();
        let mut tree = LightTree { nodes: Vec::with_capacity(2 * lights.len() - 1), leaf_of: vec![0; lights.len()] };
        tree.nodes.push(bound(lights, &order, u32::MAX));
        // (node, its lights' range in `order`, depth): a stack, as a
        // recursion as deep as a degenerate tree could overflow.
        let mut work = vec![(0u32, 0..lights.len(), 0u32)];
        while let Some((node, range, depth)) = work.pop() {
            if range.len() == 1 {
                let light = order[range.start];
                tree.nodes[node as usize].child = LEAF | light;
                tree.leaf_of[light as usize] = node;
                continue;
            }
            let mid = range.start + split(lights, &mut order[range.clone()], depth);
            let first = tree.nodes.len() as u32;
            tree.nodes[node as usize].child = first;
            tree.nodes.push(bound(lights, &order[range.start..mid], node));
            tree.nodes.push(bound(lights, &order[mid..range.end], node));
            work.push((first, range.start..mid, depth + 1));
            work.push((first + 1, mid..range.end, depth + 1));
        }
        Some(tree)
    }

    /// A light for a point at `p`, from `u` in [0, 1): its index, the
    /// probability of picking it, and u rescaled within the pick to a fresh
    /// number in [0, 1).
    pub fn sample(&self, p: Vec3, u: f32) -> (usize, f32, f32) {
        let mut u = u.clamp(0.0, ONE_BELOW);
        let (mut node, mut probability) = (0usize, 1.0f32);
        loop {
            let child = self.nodes[node].child;
            if child & LEAF != 0 {
                return ((child & !LEAF) as usize, probability, u);
            }
            let left = self.left_share(child as usize, p);
            if u < left {
                u /= left;
                probability *= left;
                node = child as usize;
            } else {
                u = (u - left) / (1.0 - left);
                probability *= 1.0 - left;
                node = child as usize + 1;
            }
            u = u.min(ONE_BELOW);
        }
    }

    /// The probability with which `sample` picks `light` for a point at `p`.
    pub fn probability(&self, light: usize, p: Vec3) -> f32 {
        let mut node = self.leaf_of[light] as usize;
        let mut probability = 1.0f32;
        while node != 0 {
            let parent = self.nodes[node].parent as usize;
            let first = self.nodes[parent].child as usize;
            let left = self.left_share(first, p);
            probability *= if node == first { left } else { 1.0 - left };
            node = parent;
        }
        probability
    }

    /// The share of the first of two sibling nodes at `p`: by their
    /// importance, or, where neither has any (a point behind every lamp)
    /// or it overflows, by their weight.
    fn left_share(&self, first: usize, p: Vec3) -> f32 {
        let (a, b) = (&self.nodes[first], &self.nodes[first + 1]);
        let (ia, ib) = (a.importance(p), b.importance(p));
        let share = ia / (ia + ib);
        if share.is_finite() {
            return share;
        }
        let share = a.weight / (a.weight + b.weight);
        if share.is_finite() { share } else { 0.5 }
    }

    pub fn len(&self) -> usize {
        self.leaf_of.len()
    }

    pub fn is_empty(&self) -> bool {
        self.leaf_of.is_empty()
    }
}

const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// The node bounding `lights[order]`, child of `parent`.
fn bound(lights: &[TreeLight], order: &[u32], parent: u32) -> Node {
    let (mut lo, mut hi, mut weight) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0.0f32);
    for &i in order {
        let l = &lights[i as usize];
        (lo, hi, weight) = (lo.min(l.lo), hi.max(l.hi), weight + l.weight);
    }
    let facing = order.iter().map(|&i| &lights[i as usize]).filter_map(|l| l.facing.map(|(n, two_sided)| (n, two_sided, l.weight)));
    let cone = if facing.clone().count() == order.len() { Cone::around(facing) } else { None };
    let (centre, radius2) = if lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z { (0.5 * (lo + hi), (0.5 * (hi - lo)).length_squared()) } else { (Vec3::ZERO, f32::INFINITY) };
    Node { weight, centre, radius2, cone, parent, child: 0 }
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
        TreeLight { weight, lo: p, hi: p, facing: None }
    }

    /// A small square lamp at `p` facing `n`.
    fn panel(p: Vec3, n: Vec3, weight: f32) -> TreeLight {
        TreeLight { weight, lo: p - Vec3::splat(0.05), hi: p + Vec3::splat(0.05), facing: Some((n, false)) }
    }

    /// Stratified numbers down the tree land on each light as often as
    /// its probability says (a light's numbers are one interval, so the
    /// count is within one of n·p), and the probabilities sum to 1.
    fn assert_consistent(tree: &LightTree, p: Vec3, what: &str) {
        let n = 20_000;
        let mut counts = vec![0u32; tree.len()];
        for k in 0..n {
            let (light, probability, rest) = tree.sample(p, (k as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&rest), "{what}: u rescaled to {rest}");
            // The same shares, multiplied top-down here and bottom-up there.
            let again = tree.probability(light, p);
            assert!((probability - again).abs() <= 1e-5 * again, "{what}: light {light}: {probability} {again}");
            counts[light] += 1;
        }
        let total: f32 = (0..tree.len()).map(|i| tree.probability(i, p)).sum();
        assert!((total - 1.0).abs() < 1e-4, "{what}: probabilities sum to {total}");
        for (i, &c) in counts.iter().enumerate() {
            let expected = n as f32 * tree.probability(i, p);
            assert!((c as f32 - expected).abs() <= 2.0 + 1e-3 * expected, "{what}: light {i} picked {c} times for {expected}");
        }
    }

    #[test]
    fn picks_match_probabilities_for_random_lights() {
        let mut rng = Rng::new(7, 1);
        for case in 0..20 {
            let count = 1 + case * 7;
            let lights: Vec<TreeLight> = (0..count)
                .map(|_| {
                    let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0 - 10.0;
                    let w = 0.01 + 100.0 * rng.next_f32() * rng.next_f32();
                    if rng.next_f32() < 0.5 { point(c, w) } else { panel(c, Vec3::new(rng.next_f32() - 0.5, -1.0, rng.next_f32() - 0.5).normalize(), w) }
                })
                .collect();
            let tree = LightTree::new(&lights).unwrap();
            for _ in 0..3 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 30.0 - 15.0;
                assert_consistent(&tree, p, &format!("{count} lights at {p}"));
            }
        }
    }

    /// Two equal lamps 100 m apart: beside one, it gets nearly every pick;
    /// half-way, each gets half.
    #[test]
    fn the_near_lamp_gets_the_samples() {
        let (a, b) = (Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0));
        let tree = LightTree::new(&[point(a, 1.0), point(b, 1.0)]).unwrap();
        let near_a = Vec3::new(0.0, 1.0, 0.0);
        assert!(tree.probability(0, near_a) > 0.999, "{}", tree.probability(0, near_a));
        assert!((tree.probability(1, Vec3::new(50.0, 3.0, 0.0)) - 0.5).abs() < 1e-6);
    }

    /// A one-sided lamp facing away from a point gets none of its picks
    /// while another lamp lights it; behind every lamp, they share by
    /// weight.
    #[test]
    fn a_lamp_facing_away_gets_no_picks() {
        let lights = [panel(Vec3::ZERO, -Vec3::Y, 1.0), panel(Vec3::new(3.0, 0.0, 0.0), Vec3::Y, 3.0)];
        let tree = LightTree::new(&lights).unwrap();
        let above = Vec3::new(1.5, 5.0, 0.0);
        assert_eq!(tree.probability(0, above), 0.0);
        assert_eq!(tree.probability(1, above), 1.0);
        let (light, probability, _) = tree.sample(above, 0.0);
        assert_eq!((light, probability), (1, 1.0));
        // Below the second lamp, the first faces the point.
        assert!(tree.probability(0, Vec3::new(1.5, -5.0, 0.0)) > 0.99);
        // Level with both, edge-on, the bounds' spheres still count.
        assert_consistent(&tree, Vec3::new(1.5, 0.0, 5.0), "edge-on");
    }

    /// Lights all in one place, in a line, of zero or overflowing weight,
    /// or one alone: the tree is built, stays shallow, and its picks still
    /// match its probabilities.
    #[test]
    fn degenerate_lights_build_and_sample() {
        let same: Vec<TreeLight> = (0..1000).map(|_| point(Vec3::ONE, 1.0)).collect();
        let tree = LightTree::new(&same).unwrap();
        assert!(tree.nodes.len() == 1999);
        let deepest = (0..tree.len()).map(|i| tree.depth(i)).max().unwrap();
        assert!(deepest <= 11, "{deepest}");
        assert!((tree.probability(17, Vec3::ZERO) - 1e-3).abs() < 1e-6);
        // Each 1.2× farther than the last: a cost split would peel them off
        // one at a time; past MAX_COST_DEPTH the median takes over.
        let line: Vec<TreeLight> = (0..200).map(|i| point(Vec3::new(1.2f32.powi(i), 0.0, 0.0), 1.0)).collect();
        let tree = LightTree::new(&line).unwrap();
        let deepest = (0..tree.len()).map(|i| tree.depth(i)).max().unwrap();
        assert!(deepest <= MAX_COST_DEPTH as usize + 9, "{deepest}");
        assert_consistent(&tree, Vec3::new(3.0, 1.0, 0.0), "a line");
        let odd = [point(Vec3::ZERO, 0.0), point(Vec3::X, f32::INFINITY), point(Vec3::Y, 1.0), point(Vec3::ONE, 0.0)];
        let tree = LightTree::new(&odd).unwrap();
        for p in [Vec3::ZERO, Vec3::splat(5.0)] {
            let (light, probability, rest) = tree.sample(p, 0.3);
            assert!(light < 4 && probability.is_finite() && (0.0..1.0).contains(&rest));
            let total: f32 = (0..4).map(|i| tree.probability(i, p)).sum();
            assert!((total - 1.0).abs() < 1e-6, "{total}");
        }
        let one = LightTree::new(&[point(Vec3::ZERO, 2.0)]).unwrap();
        assert_eq!(one.sample(Vec3::X, 0.7), (0, 1.0, 0.7));
        assert_eq!(one.probability(0, Vec3::X), 1.0);
        assert!(LightTree::new(&[]).is_none());
    }

    impl LightTree {
        fn depth(&self, light: usize) -> usize {
            let (mut node, mut depth) = (self.leaf_of[light] as usize, 0);
            while node != 0 {
                node = self.nodes[node].parent as usize;
                depth += 1;
            }
            depth
        }
    }
}
