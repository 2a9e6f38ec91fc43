//! Where a camera path's BSDF sample should look for a caustic.
//!
//! Light that glass or a mirror focuses onto a diffuse surface reaches a
//! camera path at that surface two ways: light tracing from the surface
//! to the camera (light_paths.rs, `DeltaStart`), where the camera sees it
//! straight, and otherwise only a BSDF sample that happens to go back
//! through the same delta lobes onto the light. Seen in a mirror or
//! through the glass itself (camera → glass → floor → glass → lamp), the
//! second is the only way, and its fireflies were most of what was left of
//! the noise on the benchmark's glass sphere.
//!
//! The light subpaths know those directions: each that went through delta
//! lobes alone and landed on a surface arrived along one. Before a render
//! a few thousand subpaths are traced (light_paths.rs, `caustic_arrivals`),
//! aimed at the sphere around the glass and mirrors (`Aim`: a subpath
//! leaving a lamp by the cosine meets a glass ball a few metres away a few
//! times in a hundred); where they arrived beyond delta lobes alone is
//! binned in a grid of cells, each arrival with the direction back along
//! its last segment. A camera vertex in a cell that holds some draws its
//! direction, with probability `SHARE`, uniformly in a cone of half-angle
//! `CONE` about one of them (picked uniformly), and otherwise from its
//! BSDF: the direction's density is the mixture (1 − s)·p_bsdf + s·p_guide.
//! The path's throughput divides by that mixture, while the MIS weights
//! keep the BSDF's own density on every side, so that they still sum to 1
//! over the strategies: the estimate stays unbiased, and what changes is
//! which directions the samples take. Point and spot lights aim their
//! subpaths at the same sphere (`PunctualLight::start_along`; a spot's
//! that leave outside its cone carry nothing and end): a glass ball under
//! a 5 cm bulb (tests/glass.rs) charted 1,336 directions in 479 cells
//! where, left unaimed, the bulb's subpaths had charted 102 in 18.

use crate::sampling::{cone_pdf, cone_sample_within, one_minus_cos, Frame};
use crate::Vec3;
use glam::Vec2;

/// The chance a vertex in an occupied cell samples the guide.
pub const SHARE: f32 = 0.5;
/// Half-angle of the cone about an arrival's direction (radians).
pub const CONE: f32 = 0.2;
/// Arrivals a cell keeps at most, and the number it aims for when the
/// grid's cell size is chosen.
const PER_CELL: usize = 32;
const TARGET_PER_CELL: f32 = 12.0;

/// The sphere around the scene's smooth glass and mirrors
/// (`Material::throws_caustics`), which the guide's subpaths leave their
/// lamps toward.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aim {
    centre: Vec3,
    radius: f32,
}

impl Aim {
    /// The sphere around every triangle whose material throws caustics;
    /// None where there is none.
    pub fn toward_caustics(scene: &crate::scene::Scene) -> Option<Self> {
        let targets = scene.triangles.iter().filter(|t| scene.materials[t.material as usize].throws_caustics());
        let (lo, hi) = targets.clone().flat_map(|t| t.p()).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
        let centre = (lo + hi) * 0.5;
        let radius = targets.flat_map(|t| t.p()).map(|p| p.distance(centre)).fold(0.0f32, f32::max);
        (centre.is_finite() && radius.is_finite() && radius > 0.0).then_some(Aim { centre, radius })
    }

    /// A direction uniformly in the sphere's cone from `from`, in the
    /// frame of unit normal `normal` (z along it); None from inside the
    /// sphere. Below the face where the cone dips under it: the caller
    /// drops it.
    pub fn direction(&self, from: Vec3, normal: Vec3, u: Vec2) -> Option<Vec3> {
        self.world_direction(from, u).map(|(world, _)| Frame::from_normal(normal).to_local(world))
    }

    /// A direction uniformly in the sphere's cone from `from`, in world
    /// space, and the cone's density; None from inside the sphere.
    pub fn world_direction(&self, from: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        let to = self.centre - from;
        let d2 = to.length_squared();
        let s = self.radius * self.radius / d2;
        if !(s < 1.0) {
            return None;
        }
        // 1 − cos of the cone's half-angle, without cancellation.
        let one_minus_cos_max = s / (1.0 + (1.0 - s).sqrt());
        Some((cone_sample_within(to / d2.sqrt(), one_minus_cos_max, u), cone_pdf(one_minus_cos_max)))
    }
}

/// One light subpath's arrival beyond delta lobes.
#[derive(Clone, Copy, Debug)]
pub struct Arrival {
    pub p: Vec3,
    /// Unit direction back toward the last delta vertex.
    pub dir: Vec3,
}

/// The arrivals binned in a grid of cubic cells.
pub struct CausticGuide {
    origin: Vec3,
    inv_cell: f32,
    /// Cell keys, sorted, with each cell's range in `dirs`.
    cells: Vec<(u64, u32, u32)>,
    dirs: Vec<Vec3>,
    /// The cone's 1 − cos and cos of its half-angle, and its density.
    one_minus_cos: f32,
    cos_cone: f32,
    cone_density: f32,
}

impl CausticGuide {
    /// The guide of `arrivals`; None without any.
    pub fn new(arrivals: &[Arrival]) -> Option<Self> {
        let finite: Vec<&Arrival> = arrivals.iter().filter(|l| l.p.is_finite() && l.dir.is_finite()).collect();
        if finite.is_empty() {
            return None;
        }
        let (lo, hi) = finite.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), l| (lo.min(l.p), hi.max(l.p)));
        let origin = lo;
        // A cell size that puts about TARGET_PER_CELL arrivals in an
        // occupied cell: arrivals lie on surfaces, so refine from a
        // guess by the square root of the count's error.
        let mut cell = ((hi - lo).length() / 64.0).max(1e-6);
        for _ in 0..4 {
            let occupied = Self::bin(&finite, origin, 1.0 / cell).len();
            let per = finite.len() as f32 / occupied.max(1) as f32;
            cell *= (TARGET_PER_CELL / per).sqrt().clamp(0.25, 4.0);
        }
        let inv_cell = 1.0 / cell;
        let binned = Self::bin(&finite, origin, inv_cell);
        let mut cells = Vec::with_capacity(binned.len());
        let mut dirs = Vec::new();
        for (key, members) in binned {
            let start = dirs.len() as u32;
            // Evenly through the cell's arrivals where it has too many.
            let step = members.len().div_ceil(PER_CELL).max(1);
            dirs.extend(members.iter().step_by(step).map(|&i| finite[i].dir));
            cells.push((key, start, dirs.len() as u32));
        }
        let one_minus_cos = one_minus_cos(CONE);
        Some(CausticGuide { origin, inv_cell, cells, dirs, one_minus_cos, cos_cone: CONE.cos(), cone_density: cone_pdf(one_minus_cos) })
    }

    /// The directions kept, the cells holding them, and the cells' edge
    /// (`--stats`).
    pub fn summary(&self) -> (usize, usize, f32) {
        (self.dirs.len(), self.cells.len(), 1.0 / self.inv_cell)
    }

    /// Arrivals by cell key, sorted by key.
    fn bin(arrivals: &[&Arrival], origin: Vec3, inv_cell: f32) -> Vec<(u64, Vec<usize>)> {
        let mut keyed: Vec<(u64, usize)> = arrivals.iter().enumerate().filter_map(|(i, l)| Self::key(origin, inv_cell, l.p).map(|k| (k, i))).collect();
        keyed.sort_unstable();
        let mut out: Vec<(u64, Vec<usize>)> = Vec::new();
        for (k, i) in keyed {
            match out.last_mut() {
                Some((last, members)) if *last == k => members.push(i),
                _ => out.push((k, vec![i])),
            }
        }
        out
    }

    /// The key of the cell holding `p`; None outside the grid's range.
    #[inline]
    fn key(origin: Vec3, inv_cell: f32, p: Vec3) -> Option<u64> {
        let c = (p - origin) * inv_cell;
        if !(c.min_element() >= -1.0 && c.max_element() < 2_097_150.0) {
            return None;
        }
        let [x, y, z] = (c + Vec3::ONE).to_array().map(|v| v.floor() as u64);
        Some(x | y << 21 | z << 42)
    }

    /// The arrivals' directions in the cell holding `p`; empty where none.
    #[inline]
    pub fn at(&self, p: Vec3) -> &[Vec3] {
        let Some(key) = Self::key(self.origin, self.inv_cell, p) else { return &[] };
        match self.cells.binary_search_by_key(&key, |c| c.0) {
            Ok(i) => &self.dirs[self.cells[i].1 as usize..self.cells[i].2 as usize],
            Err(_) => &[],
        }
    }

    /// A direction uniformly in the cone about one of `dirs` (from `at`),
    /// picked by `u_pick`.
    #[inline]
    pub fn sample(&self, dirs: &[Vec3], u_pick: f32, u: Vec2) -> Vec3 {
        let axis = dirs[((u_pick * dirs.len() as f32) as usize).min(dirs.len() - 1)];
        cone_sample_within(axis, self.one_minus_cos, u)
    }

    /// The density (solid angle) of `sample` drawing `dir` among `dirs`.
    #[inline]
    pub fn pdf(&self, dirs: &[Vec3], dir: Vec3) -> f32 {
        if dirs.is_empty() {
            return 0.0;
        }
        let inside = dirs.iter().filter(|d| d.dot(dir) >= self.cos_cone).count();
        inside as f32 * self.cone_density / dirs.len() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn arrivals(n: usize) -> Vec<Arrival> {
        let mut rng = Rng::new(5, 0);
        (0..n)
            .map(|_| {
                let u = rng.next_2d();
                let dir = Vec3::new(u.x - 0.5, 1.0, u.y - 0.5).normalize();
                Arrival { p: Vec3::new(u.x * 2.0, 0.0, u.y), dir }
            })
            .collect()
    }

    /// Drawn directions fall in a cone as often as `pdf` says, and the
    /// density integrates to 1 over the sphere.
    #[test]
    fn samples_follow_the_density() {
        let guide = CausticGuide::new(&arrivals(4000)).unwrap();
        let dirs = guide.at(Vec3::new(1.0, 0.0, 0.5));
        assert!(dirs.len() >= 4 && dirs.len() <= PER_CELL, "{}", dirs.len());
        let mut rng = Rng::new(6, 0);
        // ∫ pdf dω by uniform directions on the sphere.
        let n = 400_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = crate::sampling::uniform_sphere(rng.next_2d());
            sum += guide.pdf(dirs, d) as f64 * 4.0 * std::f64::consts::PI / n as f64;
        }
        assert!((sum - 1.0).abs() < 0.03, "∫ pdf = {sum}");
        // Every drawn direction has a density.
        for _ in 0..1000 {
            let d = guide.sample(dirs, rng.next_f32(), rng.next_2d());
            assert!((d.length() - 1.0).abs() < 1e-4 && guide.pdf(dirs, d) > 0.0);
        }
    }

    /// Nothing to guide by: no guide, or an empty cell far away.
    #[test]
    fn empty_and_far_cells_guide_nothing() {
        assert!(CausticGuide::new(&[]).is_none());
        let bad = [Arrival { p: Vec3::splat(f32::NAN), dir: Vec3::Y }];
        assert!(CausticGuide::new(&bad).is_none());
        let guide = CausticGuide::new(&arrivals(100)).unwrap();
        assert!(guide.at(Vec3::new(1e9, 0.0, 0.0)).is_empty());
        assert!(guide.at(Vec3::new(-50.0, 3.0, 0.0)).is_empty());
        assert_eq!(guide.pdf(&[], Vec3::Y), 0.0);
    }
}
