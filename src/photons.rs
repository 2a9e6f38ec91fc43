//! Caustic photons: where light subpaths that left their emitter through
//! delta lobes alone (glass, mirrors; light_paths.rs, `DeltaStart`)
//! landed, kept in a hashed grid so that a camera vertex finds those
//! within a radius of it (vertex merging, a photon map's density
//! estimate).
//!
//! Why: a caustic seen through glass or in a mirror (camera → glass →
//! floor → glass → lamp) is made by one strategy only, the floor point's
//! BSDF sample that happens to pass back through the glass onto the lamp;
//! no shadow ray bends through glass, and no connection or splat passes a
//! delta lobe to the camera. On the benchmark's glass sphere those paths
//! held nearly all of the noise (README, *Where the noise is*). Merging
//! the floor point with the photons around it is a second strategy for the
//! same light, weighed against the BSDF sample by MIS (integrator.rs,
//! `merged`), so the estimate keeps the better of the two for each path.
//!
//! Merging is biased by the blur of a disk of radius r, which shrinks with
//! the sample index as progressive photon mapping's does (r_i² ∝ i^(α−1),
//! α = 2/3): the bias goes to zero as samples accumulate while each
//! sample's photons still fall inside (`radius`).

use crate::light_paths::ConnectionVertex;
use crate::Vec3;
use glam::IVec3;

/// Photons a disk is sized to hold on average where they land
/// (`radius`).
pub const PER_DISK: f32 = 8.0;
/// Progressive photon mapping's α: the share of the photons a disk keeps
/// from one sample index to the next as it shrinks.
const ALPHA: f32 = 2.0 / 3.0;

/// One sample index's caustic photons, bucketed by grid cell.
pub struct Photons {
    /// Sorted by bucket; `starts[b]..starts[b + 1]` are bucket b's.
    photons: Vec<ConnectionVertex>,
    starts: Vec<u32>,
    /// The inverse edge of a cell (2r): a disk overlaps 2×2×2 cells.
    inv_cell: f32,
    /// The merge radius r.
    pub radius: f32,
    /// The subpaths traced whose photons these are (those that landed
    /// none count too): the density estimate divides by their number.
    pub subpaths: f32,
}

/// A cell's bucket among `mask + 1`.
#[inline]
fn bucket(cell: IVec3, mask: u32) -> usize {
    let h = (cell.x as u32).wrapping_mul(73_856_093) ^ (cell.y as u32).wrapping_mul(19_349_663) ^ (cell.z as u32).wrapping_mul(83_492_791);
    (h & mask) as usize
}

/// The cell holding `p`, by cells of inverse edge `inv_cell` (`as`
/// saturates coordinates beyond i32's range, and makes NaN 0).
#[inline]
fn cell_of(p: Vec3, inv_cell: f32) -> IVec3 {
    let q = (p * inv_cell).floor();
    IVec3::new(q.x as i32, q.y as i32, q.z as i32)
}

impl Photons {
    /// The grid of `photons` for merge radius `radius`, from `subpaths`
    /// subpaths; None without photons or a usable radius.
    pub fn new(photons: Vec<ConnectionVertex>, radius: f32, subpaths: u32) -> Option<Self> {
        if photons.is_empty() || subpaths == 0 || !(radius > 0.0 && radius.is_finite() && (1.0 / (2.0 * radius)).is_finite()) {
            return None;
        }
        let inv_cell = 1.0 / (2.0 * radius);
        let buckets = photons.len().next_power_of_two().max(16);
        let mask = (buckets - 1) as u32;
        let key = |v: &ConnectionVertex| bucket(cell_of(v.p, inv_cell), mask);
        // Stable: a bucket's photons stay in the order they were traced.
        let mut photons = photons;
        photons.sort_by_key(key);
        let mut starts = vec![0u32; buckets + 1];
        for v in &photons {
            starts[key(v) + 1] += 1;
        }
        for b in 0..buckets {
            starts[b + 1] += starts[b];
        }
        Some(Photons { photons, starts, inv_cell, radius, subpaths: subpaths as f32 })
    }

    /// Calls `each` once for every photon within the radius of `p`.
    #[inline]
    pub fn near(&self, p: Vec3, mut each: impl FnMut(&ConnectionVertex)) {
        let mask = (self.starts.len() - 2) as u32;
        let low = cell_of(p - Vec3::splat(self.radius), self.inv_cell);
        let mut seen = [usize::MAX; 8];
        let r2 = self.radius * self.radius;
        for i in 0..8usize {
            let corner = IVec3::new((i & 1) as i32, ((i >> 1) & 1) as i32, (i >> 2) as i32);
            let b = bucket(low + corner, mask);
            // Two cells in one bucket: its photons once.
            if seen[..i].contains(&b) {
                continue;
            }
            seen[i] = b;
            for v in &self.photons[self.starts[b] as usize..self.starts[b + 1] as usize] {
                if (v.p - p).length_squared() <= r2 {
                    each(v);
                }
            }
        }
    }

    pub fn len(&self) -> usize {
        self.photons.len()
    }

    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }
}

/// The merge radius for sample index `sample` of `photons`: a disk where
/// they land holds `PER_DISK` of them on average, their density taken
/// over the cells they occupy of a grid (a cell holds about edge² of the
/// surfaces they land on), times progressive photon mapping's shrinking
/// over the sample index. The grid starts at 1/64 of their extent and
/// coarsens until an occupied cell holds 4 photons on average: sparser,
/// many a cell they would cover holds none by chance, and the density came
/// out 1.6 times too high at one a cell. 0 with fewer than two photons or
/// no extent.
pub fn radius(photons: &[ConnectionVertex], sample: u32) -> f32 {
    if photons.len() < 2 {
        return 0.0;
    }
    let (lo, hi) = photons.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), v| (lo.min(v.p), hi.max(v.p)));
    let extent = (hi - lo).max_element();
    if !(extent > 0.0 && extent.is_finite()) {
        return 0.0;
    }
    let occupied = |edge: f32| {
        let mut cells: Vec<IVec3> = photons.iter().map(|v| cell_of(v.p - lo, 1.0 / edge)).collect();
        cells.sort_unstable_by_key(|c| (c.x, c.y, c.z));
        cells.dedup();
        cells.len() as f32
    };
    let mut edge = extent / 64.0;
    let mut cells = occupied(edge);
    while (photons.len() as f32) < 4.0 * cells && edge < extent {
        edge *= 2.0;
        cells = occupied(edge);
    }
    let density = photons.len() as f32 / (cells * edge * edge);
    let r = (PER_DISK / (std::f32::consts::PI * density)).sqrt();
    r * ((sample + 1) as f32).powf((ALPHA - 1.0) / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn gathered(photons: &Photons, p: Vec3) -> Vec<u32> {
        let mut found = Vec::new();
        photons.near(p, |v| found.push(v.triangle));
        found.sort_unstable();
        found
    }

    /// Every photon within the radius, each once, against brute force:
    /// spread over a plane, piled on one point, on cell boundaries, at
    /// coordinates of 10⁶ m, and with far more cells than buckets (which
    /// share buckets).
    #[test]
    fn near_finds_each_photon_within_the_radius_once() {
        let mut rng = Rng::for_sample(3, 0, 0);
        let mut cases: Vec<(Vec<Vec3>, f32)> = Vec::new();
        cases.push(((0..2000).map(|_| Vec3::new(rng.next_f32() * 4.0 - 2.0, 0.0, rng.next_f32() * 4.0 - 2.0)).collect(), 0.1));
        cases.push((vec![Vec3::splat(0.25); 50], 0.125));
        cases.push(((0..200).map(|i| Vec3::new((i % 20) as f32 * 0.25, 0.0, (i / 20) as f32 * 0.25)).collect(), 0.125));
        cases.push(((0..500).map(|_| Vec3::new(1e6 + rng.next_f32() * 10.0, -1e6, rng.next_f32() * 10.0)).collect(), 0.5));
        cases.push(((0..64).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1000.0).collect(), 1e-3));
        for (k, (points, radius)) in cases.into_iter().enumerate() {
            let vertices: Vec<ConnectionVertex> = points
                .iter()
                .enumerate()
                .map(|(i, &p)| {
                    let mut v = ConnectionVertex::at(p);
                    v.triangle = i as u32;
                    v
                })
                .collect();
            let photons = Photons::new(vertices, radius, 100).expect("photons");
            for q in points.iter().take(100).copied().chain([Vec3::ZERO, Vec3::splat(0.25), Vec3::new(1e6 + 5.0, -1e6, 5.0)]) {
                let expected: Vec<u32> = points.iter().enumerate().filter(|(_, p)| (**p - q).length_squared() <= radius * radius).map(|(i, _)| i as u32).collect();
                assert_eq!(gathered(&photons, q), expected, "case {k}, query {q}");
            }
        }
    }

    /// No photons, or no usable radius, no grid; a query far outside finds
    /// nothing; NaN and infinite points neither panic nor are found.
    #[test]
    fn degenerate_photons_and_radii_are_refused_or_found_by_none() {
        let one = || vec![ConnectionVertex::at(Vec3::ZERO)];
        assert!(Photons::new(Vec::new(), 0.1, 10).is_none());
        for r in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e-45] {
            assert!(Photons::new(one(), r, 10).is_none(), "radius {r}");
        }
        assert!(Photons::new(one(), 0.1, 0).is_none());
        let odd = vec![ConnectionVertex::at(Vec3::NAN), ConnectionVertex::at(Vec3::INFINITY), ConnectionVertex::at(Vec3::ZERO)];
        let photons = Photons::new(odd, 0.1, 10).unwrap();
        assert_eq!(gathered(&photons, Vec3::splat(5.0)), Vec::<u32>::new());
        assert_eq!(gathered(&photons, Vec3::ZERO).len(), 1);
        assert_eq!(gathered(&photons, Vec3::NAN).len(), 0);
    }

    /// The radius holds `PER_DISK` photons where they land, whatever the
    /// scale, and shrinks as i^(−1/6) over the sample index; fewer than two
    /// photons, or all on one point, give none.
    #[test]
    fn the_radius_holds_a_few_photons_and_shrinks_with_the_sample_index() {
        let mut rng = Rng::for_sample(5, 0, 0);
        let square: Vec<Vec3> = (0..4096).map(|_| Vec3::new(rng.next_f32(), 0.0, rng.next_f32())).collect();
        for scale in [1e-3f32, 1.0, 1e3] {
            let photons: Vec<ConnectionVertex> = square.iter().map(|&p| ConnectionVertex::at(p * scale)).collect();
            let r = radius(&photons, 0);
            let expected = (PER_DISK / (std::f32::consts::PI * 4096.0)).sqrt() * scale;
            assert!((r / expected - 1.0).abs() < 0.05, "scale {scale}: radius {r}, expected {expected}");
            let later = radius(&photons, 63);
            assert!((later / r - 64f32.powf(-1.0 / 6.0)).abs() < 1e-4, "scale {scale}: {later} after 64 samples");
        }
        assert_eq!(radius(&[ConnectionVertex::at(Vec3::ONE)], 0), 0.0);
        assert_eq!(radius(&[ConnectionVertex::at(Vec3::ONE), ConnectionVertex::at(Vec3::ONE)], 0), 0.0);
    }
}
