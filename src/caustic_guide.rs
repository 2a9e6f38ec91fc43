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
//! aimed at spheres around the glass and mirrors (`Aim`: a subpath
//! leaving a lamp by the cosine meets a glass ball a few metres away a few
//! times in a hundred); where they arrived beyond delta lobes alone is
//! binned in a grid of cells, each arrival with the direction back along
//! its last segment. A camera vertex in a cell that holds some draws its
//! direction, with probability `SHARE`, uniformly in a cone about one of
//! them (picked the likelier the nearer it landed, `NEAR_WIDTH`; the
//! cone's half-angle one of `CONES`, picked uniformly), and otherwise
//! from its
//! BSDF: the direction's density is the mixture (1 − s)·p_bsdf + s·p_guide.
//! The path's throughput divides by that mixture, while the MIS weights
//! keep the BSDF's own density on every side, so that they still sum to 1
//! over the strategies: the estimate stays unbiased, and what changes is
//! which directions the samples take. Point and spot lights aim their
//! subpaths at the same spheres (`PunctualLight::start_along`; a spot's
//! that leave outside its cone carry nothing and end): a glass ball under
//! a 5 cm bulb (tests/glass.rs) charted 1,336 directions in 479 cells
//! where, left unaimed, the bulb's subpaths had charted 102 in 18. Suns
//! start theirs on the disk a sphere casts across their light
//! (`Aim::across`), where unaimed they start anywhere on the scene's.

use crate::sampling::{cone_pdf, cone_sample_within, one_minus_cos, Frame};
use crate::Vec3;
use glam::Vec2;

/// The chance a vertex in an occupied cell samples the guide.
pub const SHARE: f32 = 0.5;
/// Half-angles of the two cones about an arrival's direction (radians),
/// each drawn half the time. The narrow one holds the caustic where the
/// arrivals of a cell came the way a vertex's light comes; the wide one
/// where they landed elsewhere in the cell (0.24 m on the glass sphere),
/// whose direction to the glass is up to 0.4 rad off. On the glass sphere
/// at 16 spp, of the lamp hits through the glass after a guided vertex,
/// 1.6% had been outside every narrow cone, with 30% of the hits' sum of
/// squares; with the wide cones 0.5% are outside both, with a quarter of
/// the light those had carried. The glass
/// sphere's relMSE, 144 seeds at 4 spp: 0.226 ± 0.012 → 0.193 ± 0.008;
/// 48 seeds at 16 spp: 0.0470 → 0.0454 ± 0.0013; instructions the same
/// (1,688.8 → 1,688.1 M, callgrind, 4 spp). Wide cones alone, of 0.3,
/// 0.4 or 0.5 rad, had been no better than 0.2 over 96 seeds.
pub const CONES: [f32; 2] = [0.2, 0.5];
// `CausticGuide::pdf` counts the narrow cone as inside the wide one.
const _: () = assert!(CONES[0] < CONES[1] && CONES[1] < std::f32::consts::PI);
/// How much likelier a vertex picks an arrival that landed near it: an
/// arrival at distance r has odds 1 / (1 + (r / w)²), w this fraction of
/// a cell's edge. An arrival's direction is the caustic's at the point
/// it landed; across a cell (0.24 m on the glass sphere, 5–10 cm from
/// the glass at its foot) the direction back to the glass turns by
/// tenths of a radian, so the nearest arrivals are the best aimed. Against
/// picking uniformly, the glass sphere's relMSE at 4 spp (two sets of 64
/// seeds, paired): −9.3% ± 3.1 and −8.9% ± 3.2; at 1 spp (96 seeds)
/// −6% ± 4; at 16 spp (24) −2% ± 2; 1.3% more instructions (callgrind,
/// 4 spp). Widths of 0.05 to 0.25 did alike; more arrivals a cell (64),
/// larger or smaller cells (24 or 6 a cell), or a cell's arrivals taken
/// from its neighbours too, no better.
const NEAR_WIDTH: f32 = 0.1;
/// Arrivals a cell keeps at most, and the number it aims for when the
/// grid's cell size is chosen.
const PER_CELL: usize = 32;
const TARGET_PER_CELL: f32 = 12.0;

/// Spheres around the scene's smooth glass and mirrors
/// (`Material::throws_caustics`), which the guide's subpaths leave their
/// lamps toward: one around each object (its triangles joined through
/// shared corners, `scene::joined_parts`), so that a glass on a table and
/// a window pane across the room are each aimed at, not the room between
/// them; past `MAX_SPHERES` objects, one around those whose centres share
/// an octant of the box around them all.
#[derive(Clone, Debug, PartialEq)]
pub struct Aim {
    spheres: Vec<Sphere>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Sphere {
    centre: Vec3,
    radius: f32,
}

/// Spheres an `Aim` keeps at most.
const MAX_SPHERES: usize = 8;

impl Aim {
    /// The spheres around the objects whose material throws caustics;
    /// None where there is none.
    pub fn toward_caustics(scene: &crate::scene::Scene) -> Option<Self> {
        let targets: Vec<u32> = (0..scene.triangles.len() as u32).filter(|&t| scene.material_of(t).throws_caustics()).collect();
        if targets.is_empty() {
            return None;
        }
        let parts = crate::scene::joined_parts(scene, &targets);
        let boxes = crate::scene::part_boxes(scene, &targets, &parts);
        let roots: Vec<usize> = (0..targets.len()).filter(|&k| parts[k] as usize == k).collect();
        // Each object its own group, or, past MAX_SPHERES, the octant of
        // the whole box its box's centre lies in; at each part's root.
        let (lo, hi) = roots.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &r| (lo.min(boxes[r].0), hi.max(boxes[r].1)));
        let middle = (lo + hi) * 0.5;
        let mut group = vec![0usize; targets.len()];
        for (i, &r) in roots.iter().enumerate() {
            let c = (boxes[r].0 + boxes[r].1) * 0.5;
            group[r] = if roots.len() <= MAX_SPHERES { i } else { (c.x > middle.x) as usize | ((c.y > middle.y) as usize) << 1 | ((c.z > middle.z) as usize) << 2 };
        }
        let groups = roots.len().min(MAX_SPHERES);
        let mut group_boxes = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); groups];
        for &r in &roots {
            let g = &mut group_boxes[group[r]];
            *g = (g.0.min(boxes[r].0), g.1.max(boxes[r].1));
        }
        let centres: Vec<Vec3> = group_boxes.iter().map(|(lo, hi)| (*lo + *hi) * 0.5).collect();
        let mut radii = vec![0.0f32; groups];
        for (&t, &part) in targets.iter().zip(&parts) {
            let g = group[part as usize];
            for p in scene.triangles[t as usize].p() {
                radii[g] = radii[g].max(p.distance(centres[g]));
            }
        }
        let spheres: Vec<Sphere> = centres.into_iter().zip(radii).map(|(centre, radius)| Sphere { centre, radius }).filter(|s| s.centre.is_finite() && s.radius.is_finite() && s.radius > 0.0).collect();
        (!spheres.is_empty()).then_some(Aim { spheres })
    }

    /// A direction uniformly in one sphere's cone from `from`, in the
    /// frame of unit normal `normal` (z along it); None from inside every
    /// sphere. Below the face where the cone dips under it: the caller
    /// drops it.
    pub fn direction(&self, from: Vec3, normal: Vec3, u: Vec2) -> Option<Vec3> {
        self.world_direction(from, u).map(|(world, _)| Frame::from_normal(normal).to_local(world))
    }

    /// A point uniform on the disk that one sphere casts across light
    /// travelling along unit `travel` (a sun's, `Lights::sample_start`),
    /// the sphere picked by its cross-section, with `u.x`, rescaled, left
    /// to the disk.
    pub fn across(&self, travel: Vec3, u: Vec2) -> Option<Vec3> {
        let (s, u) = self.pick(|s| s.radius * s.radius, u)?;
        Some(crate::sampling::disk_point(s.centre, travel, s.radius, u))
    }

    /// A sphere picked in proportion to `weight`, with `u.x`, and `u`
    /// with its x rescaled to what of it the pick left; None when no
    /// sphere weighs anything.
    fn pick(&self, weight: impl Fn(&Sphere) -> f32, u: Vec2) -> Option<(&Sphere, Vec2)> {
        let total: f32 = self.spheres.iter().map(&weight).sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut rest = u.x * total;
        let mut picked = (self.spheres.last()?, 0.0, 1.0);
        for s in &self.spheres {
            let w = weight(s);
            if rest < w {
                picked = (s, rest, w);
                break;
            }
            rest -= w;
        }
        let (s, rest, w) = picked;
        Some((s, Vec2::new((rest / w).clamp(0.0, 1.0 - f32::EPSILON), u.y)))
    }

    /// A direction uniformly in one sphere's cone from `from`, in world
    /// space, and that cone's density; the sphere picked by the solid
    /// angle it covers (about r²/d²), with `u.x`, rescaled, left to the
    /// cone. None from inside every sphere.
    pub fn world_direction(&self, from: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        let (sphere, u) = match self.spheres.as_slice() {
            [one] => (one, u),
            _ => self.pick(
                |s| {
                    let d2 = (s.centre - from).length_squared();
                    if d2 > s.radius * s.radius { s.radius * s.radius / d2 } else { 0.0 }
                },
                u,
            )?,
        };
        let to = sphere.centre - from;
        let d2 = to.length_squared();
        let s = sphere.radius * sphere.radius / d2;
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
    /// Cell keys, sorted, with each cell's range in `dirs` and `points`.
    cells: Vec<(u64, u32, u32)>,
    dirs: Vec<Vec3>,
    /// Where each of `dirs` arrived.
    points: Vec<Vec3>,
    /// 1 / (`NEAR_WIDTH` · the cell's edge)².
    inv_width2: f32,
    /// The two cones (`CONES`), narrow first.
    cones: [Cone; 2],
}

/// A cone of directions about an axis.
#[derive(Clone, Copy)]
struct Cone {
    /// 1 − cos of its half-angle, and the cos.
    one_minus_cos: f32,
    cos: f32,
    /// The solid-angle density of a direction drawn uniformly in it.
    density: f32,
}

impl Cone {
    fn new(half_angle: f32) -> Self {
        let one_minus_cos = one_minus_cos(half_angle);
        Cone { one_minus_cos, cos: half_angle.cos(), density: cone_pdf(one_minus_cos) }
    }
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
        let mut points = Vec::new();
        for (key, members) in binned {
            let start = dirs.len() as u32;
            // Evenly through the cell's arrivals where it has too many.
            let step = members.len().div_ceil(PER_CELL).max(1);
            for &i in members.iter().step_by(step) {
                dirs.push(finite[i].dir);
                points.push(finite[i].p);
            }
            cells.push((key, start, dirs.len() as u32));
        }
        let width = NEAR_WIDTH * cell;
        Some(CausticGuide { origin, inv_cell, cells, dirs, points, inv_width2: 1.0 / (width * width), cones: CONES.map(Cone::new) })
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

    /// The arrivals in the cell holding `p`, with the odds a vertex at
    /// `p` picks each by (`NEAR_WIDTH`); None where the cell holds none.
    #[inline]
    pub fn near(&self, p: Vec3) -> Option<Near<'_>> {
        let key = Self::key(self.origin, self.inv_cell, p)?;
        let cell = self.cells[self.cells.binary_search_by_key(&key, |c| c.0).ok()?];
        let range = cell.1 as usize..cell.2 as usize;
        let mut odds = [0.0f32; PER_CELL];
        let mut total = 0.0;
        for (w, q) in odds.iter_mut().zip(&self.points[range.clone()]) {
            *w = 1.0 / (1.0 + q.distance_squared(p) * self.inv_width2);
            total += *w;
        }
        (total > 0.0 && total.is_finite()).then(|| Near { dirs: &self.dirs[range], odds, total })
    }

    /// A direction uniformly in a cone about one of `near`'s arrivals:
    /// `u_pick` picks the arrival by its odds, and what is left of it
    /// within that arrival's share the cone, narrow or wide.
    #[inline]
    pub fn sample(&self, near: &Near, u_pick: f32, u: Vec2) -> Vec3 {
        let mut rest = u_pick * near.total;
        let mut k = near.dirs.len() - 1;
        for (i, &w) in near.odds[..near.dirs.len()].iter().enumerate() {
            if rest < w {
                k = i;
                break;
            }
            rest -= w;
        }
        let cone = self.cones[(rest >= 0.5 * near.odds[k]) as usize];
        cone_sample_within(near.dirs[k], cone.one_minus_cos, u)
    }

    /// The density (solid angle) of `sample` drawing `dir` from `near`.
    #[inline]
    pub fn pdf(&self, near: &Near, dir: Vec3) -> f32 {
        let [narrow, wide] = self.cones;
        let mut sum = 0.0;
        for (d, &w) in near.dirs.iter().zip(&near.odds) {
            let c = d.dot(dir);
            if c >= wide.cos {
                sum += w * if c >= narrow.cos { narrow.density + wide.density } else { wide.density };
            }
        }
        0.5 * sum / near.total
    }
}

/// The arrivals of the cell a vertex lies in, each with the odds the
/// vertex picks it by (`CausticGuide::near`), and their sum.
pub struct Near<'a> {
    dirs: &'a [Vec3],
    odds: [f32; PER_CELL],
    total: f32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::rng::Rng;
    use crate::scene::{Scene, Triangle};

    /// Corner `i` (bits x, y, z) of the cube of edge 0.2 m about `c`.
    fn cube_corner(c: Vec3, i: usize) -> Vec3 {
        c + 0.1 * Vec3::new(if i & 1 == 0 { -1.0 } else { 1.0 }, if i & 2 == 0 { -1.0 } else { 1.0 }, if i & 4 == 0 { -1.0 } else { 1.0 })
    }

    /// Smooth glass cubes of edge 0.2 m at `centres` (their corners shared
    /// within each), over a matte floor.
    fn glass_cubes(centres: &[Vec3]) -> Scene {
        let floor = [Vec3::new(-50.0, -1.0, -50.0), Vec3::new(50.0, -1.0, -50.0), Vec3::new(50.0, -1.0, 50.0), Vec3::new(-50.0, -1.0, 50.0)];
        let mut triangles = vec![Triangle::new([floor[0], floor[2], floor[1]], [Vec3::Y; 3], 0), Triangle::new([floor[0], floor[3], floor[2]], [Vec3::Y; 3], 0)];
        for &c in centres {
            let corner = |i: usize| cube_corner(c, i);
            for [a, b, d, e] in [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]] {
                triangles.push(Triangle::new([corner(a), corner(b), corner(d)], [Vec3::ZERO; 3], 1));
                triangles.push(Triangle::new([corner(a), corner(d), corner(e)], [Vec3::ZERO; 3], 1));
            }
        }
        let materials = vec![Material { metallic: 0.0, ..Material::default() }, Material { metallic: 0.0, roughness: 0.0, transmission: 1.0, ..Material::default() }];
        let camera = crate::camera::Camera::from_world("c".into(), &glam::Mat4::from_translation(glam::Vec3::new(0.0, 1.0, 3.0)), 1.0, None).unwrap();
        Scene::new(triangles, materials, camera)
    }

    /// Two glass cubes 10 m apart are aimed at each alone, and from a
    /// point 1 m from one and about 10 m from the other the draws go to
    /// each by the solid angle it covers (about 100 : 1), every one inside
    /// its cube's cone. Past `MAX_SPHERES` cubes (twenty in a row), eight
    /// spheres at most still hold every cube.
    #[test]
    fn each_object_is_aimed_at_apart() {
        let (near, far) = (Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
        let aim = Aim::toward_caustics(&glass_cubes(&[near, far])).unwrap();
        assert_eq!(aim.spheres.len(), 2, "{aim:?}");
        assert!(aim.spheres.iter().all(|s| s.radius < 0.18), "{aim:?}");
        let from = Vec3::new(0.0, 1.0, 0.0);
        let mut rng = Rng::new(3, 0);
        let mut toward_near = 0;
        let n = 20_000;
        for _ in 0..n {
            let (d, pdf) = aim.world_direction(from, rng.next_2d()).unwrap();
            assert!(pdf > 0.0 && pdf.is_finite() && (d.length() - 1.0).abs() < 1e-5);
            let hits = |c: Vec3| {
                let t = (c - from).dot(d);
                (from + d * t).distance(c) <= 0.18
            };
            assert!(hits(near) || hits(far), "{d}");
            toward_near += hits(near) as usize;
        }
        let (w_near, w_far) = (0.173f32.powi(2) / 1.0, 0.173f32.powi(2) / 101.0);
        let expected = w_near / (w_near + w_far);
        assert!((toward_near as f32 / n as f32 - expected).abs() < 0.005, "{toward_near} of {n}, expected {expected}");
        // Inside every sphere, no direction.
        assert!(Aim::toward_caustics(&glass_cubes(&[near])).unwrap().world_direction(near, Vec2::splat(0.5)).is_none());
        let row: Vec<Vec3> = (0..20).map(|i| Vec3::new(i as f32, 0.0, (i % 3) as f32)).collect();
        let aim = Aim::toward_caustics(&glass_cubes(&row)).unwrap();
        assert!(aim.spheres.len() <= MAX_SPHERES && aim.spheres.len() >= 2, "{}", aim.spheres.len());
        for c in &row {
            let corners = (0..8).map(|i| cube_corner(*c, i));
            assert!(aim.spheres.iter().any(|s| corners.clone().all(|p| s.centre.distance(p) <= s.radius * (1.0 + 1e-5))), "{c} in none of {aim:?}");
        }
    }

    /// A sun's aimed starts (`Aim::across`) lie on the disks the two cubes'
    /// spheres cast across its light, each sphere picked by its
    /// cross-section: equal spheres, half each (20,000 draws, 4 standard
    /// errors).
    #[test]
    fn sun_starts_cross_each_sphere() {
        let aim = Aim::toward_caustics(&glass_cubes(&[Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)])).unwrap();
        let travel = Vec3::new(0.3, -1.0, 0.2).normalize();
        let mut rng = Rng::new(9, 0);
        let n = 20_000;
        let mut first = 0;
        for _ in 0..n {
            let p = aim.across(travel, rng.next_2d()).unwrap();
            let on = aim.spheres.iter().position(|s| {
                let off = p - s.centre;
                off.dot(travel).abs() < 1e-4 && off.length() <= s.radius * (1.0 + 1e-5)
            });
            assert!(on.is_some(), "{p} on no sphere's disk");
            first += (on == Some(0)) as usize;
        }
        assert!((first as f64 - 0.5 * n as f64).abs() < 4.0 * (0.25 * n as f64).sqrt(), "{first} of {n}");
    }

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
        let near = guide.near(Vec3::new(1.0, 0.0, 0.5)).unwrap();
        assert!(near.dirs.len() >= 4 && near.dirs.len() <= PER_CELL, "{}", near.dirs.len());
        let mut rng = Rng::new(6, 0);
        // ∫ pdf dω by uniform directions on the sphere.
        let n = 400_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = crate::sampling::uniform_sphere(rng.next_2d());
            sum += guide.pdf(&near, d) as f64 * 4.0 * std::f64::consts::PI / n as f64;
        }
        assert!((sum - 1.0).abs() < 0.03, "∫ pdf = {sum}");
        // Every drawn direction has a density.
        for _ in 0..1000 {
            let d = guide.sample(&near, rng.next_f32(), rng.next_2d());
            assert!((d.length() - 1.0).abs() < 1e-4 && guide.pdf(&near, d) > 0.0);
        }
    }

    /// Draws land in the narrow cone about a direction, in the ring of
    /// the wide one around it, and outside both as often as the density
    /// says. With one arrival in the cell, half the draws are in each
    /// cone: the density is 1/2 of the sum of both cones' inside the
    /// narrow one, 1/2 of the wide one's in the ring, 0 beyond, and the
    /// narrow cone holds 1/2 + 1/2·(its solid angle over the wide one's)
    /// of the draws. Counts of 40,000 draws, 4 standard errors from that
    /// at most.
    #[test]
    fn two_cones_follow_the_density() {
        let axis = Vec3::new(0.3, 1.0, -0.2).normalize();
        let guide = CausticGuide::new(&[Arrival { p: Vec3::ZERO, dir: axis }]).unwrap();
        let near = guide.near(Vec3::ZERO).unwrap();
        assert_eq!(near.dirs.len(), 1);
        let [narrow, wide] = guide.cones;
        let region = |d: Vec3| {
            let c = d.dot(axis);
            if c >= narrow.cos { 0 } else if c >= wide.cos { 1 } else { 2 }
        };
        let density = [0.5 * (narrow.density + wide.density), 0.5 * wide.density, 0.0];
        let mut rng = Rng::new(11, 0);
        for _ in 0..2000 {
            let d = crate::sampling::uniform_sphere(rng.next_2d());
            let want = density[region(d)];
            assert!((guide.pdf(&near, d) - want).abs() <= 1e-5 * want, "{d}: {} against {want}", guide.pdf(&near, d));
        }
        let n = 40_000;
        let mut counts = [0usize; 3];
        for _ in 0..n {
            counts[region(guide.sample(&near, rng.next_f32(), rng.next_2d()))] += 1;
        }
        let narrow_share = 0.5 + 0.5 * narrow.one_minus_cos as f64 / wide.one_minus_cos as f64;
        let sigma = (n as f64 * narrow_share * (1.0 - narrow_share)).sqrt();
        assert!((counts[0] as f64 - n as f64 * narrow_share).abs() < 4.0 * sigma && counts[2] == 0, "{counts:?}, narrow share {narrow_share}");
    }

    /// Nothing to guide by: no guide, or an empty cell far away.
    #[test]
    fn empty_and_far_cells_guide_nothing() {
        assert!(CausticGuide::new(&[]).is_none());
        let bad = [Arrival { p: Vec3::splat(f32::NAN), dir: Vec3::Y }];
        assert!(CausticGuide::new(&bad).is_none());
        let guide = CausticGuide::new(&arrivals(100)).unwrap();
        assert!(guide.near(Vec3::new(1e9, 0.0, 0.0)).is_none());
        assert!(guide.near(Vec3::new(-50.0, 3.0, 0.0)).is_none());
    }

    /// Of two arrivals in one cell whose cones do not meet, a vertex
    /// where the first landed picks the first by odds 1 against
    /// 1 / (1 + (r / w)²) for the second, r away (`NEAR_WIDTH`): its draws
    /// fall in each's wide cone that often (40,000 draws, 4 standard
    /// errors), and the density in each narrow cone is that share of the
    /// two cones' densities, halved.
    #[test]
    fn nearer_arrivals_are_picked_more() {
        let (a, b) = (Arrival { p: Vec3::ZERO, dir: Vec3::Y }, Arrival { p: Vec3::new(0.3, 0.0, 0.1), dir: Vec3::X });
        let guide = CausticGuide::new(&[a, b]).unwrap();
        let (_, cells, edge) = guide.summary();
        assert_eq!(cells, 1, "both in one cell of {edge} m");
        let near = guide.near(a.p).unwrap();
        let w = NEAR_WIDTH * edge;
        let odds_b = 1.0 / (1.0 + a.p.distance_squared(b.p) / (w * w));
        let share_a = 1.0 / (1.0 + odds_b as f64);
        assert!(share_a > 0.9 && share_a < 1.0, "{share_a}");
        let [narrow, wide] = guide.cones;
        let in_narrow = 0.5 * (narrow.density + wide.density) as f64;
        for (arrival, share) in [(a, share_a), (b, 1.0 - share_a)] {
            let pdf = guide.pdf(&near, arrival.dir) as f64;
            assert!((pdf - in_narrow * share).abs() <= 1e-4 * in_narrow * share, "{pdf} against {}", in_narrow * share);
        }
        let mut rng = Rng::new(12, 0);
        let n = 40_000;
        let mut toward = [0usize; 2];
        for _ in 0..n {
            let d = guide.sample(&near, rng.next_f32(), rng.next_2d());
            for (k, arrival) in [a, b].iter().enumerate() {
                toward[k] += (d.dot(arrival.dir) >= wide.cos) as usize;
            }
        }
        let sigma = (n as f64 * share_a * (1.0 - share_a)).sqrt();
        assert!((toward[0] as f64 - n as f64 * share_a).abs() < 4.0 * sigma && toward[0] + toward[1] == n, "{toward:?}, share {share_a}");
    }
}
