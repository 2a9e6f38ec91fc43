//! Light picks from a grid over the scene, for a few dozen lights: each
//! cell holds every light's bound over the whole cell and its distance,
//! so that a pick at a point is one lookup, a few products a light and a
//! pick among them — no square root or division a light, no walk down a tree
//! whose every level waits on the one above. In the benchmark's hall of
//! 32 lamps a light tree's pick (two levels of such bounds) was a quarter
//! of the render's time.
//!
//! A light's part at `p` of normal `n` is the cell's bound W·cos/d² (the
//! light's bounding sphere widened by the cell's, seen from the cell's
//! centre: `Cone::cos_bound` of the tree) times clamp((n·(c − p) + r)/d,
//! 0, 1), c and r the light's sphere, d the cell's distance to it: about
//! the receiver's cosine, and zero only where the whole sphere lies below
//! the point's plane, where the light cannot reach it. So the parts are
//! an importance never zero where the light can light the point. A zero
//! normal (a BSDF that transmits) counts light from every side.
//!
//! At a point whose normal lies along an axis (±x, ±y, ±z: floors, walls
//! and ceilings as modelled), the parts are the cell's own, computed with
//! the grid for each of the six: the facing term's most over the cell's
//! points (and normals within `AXIS_COS` of the axis) in place of its
//! value at p, summed, so that a pick is a lookup and a count of the sums
//! at or below its number, and a probability two reads. These parts are
//! never below the point's own, so no reachable light loses its share
//! (but for one under 2⁻²⁴ of the cell's sum, whose interval the f32
//! running sums round away, as the tree's sums do); they are a little
//! looser beside a lamp. The table is made only where some surface of
//! the scene lies along an axis.
//!
//! Points outside the grid, and cells where no light has a part, are the
//! tree's (`LightTree::sample` asks the cache first).
//!
//! Each worker thread picks from a copy of the tables of its own, written
//! by that worker, where the copies fit `COPIES_BUDGET`. The hall's tables
//! are 4 MB, more than a core's 2 MB L2, and both cores read them at
//! random: on the benchmark machine (a Xeon under KVM) two threads reading
//! the same lines took 7–8% more CPU time than two processes, each with
//! its own, reading theirs (1 and 2 threads, 8 spp: 1,040 and 1,130 ms of
//! CPU). With a copy each, the hall (256²) at 8 spp took 3.6% ± 1.2 less
//! time (12 pairs of alternating runs); at 1 spp 2.5–3.6% less in a fast
//! spell of the machine and the same in a slow one (−0.5% ± 1.9, +1.4% ±
//! 0.9, 40 pairs each). A copy made by one thread and read by the other
//! gained at 8 spp only, likely as the lines it wrote were still in its
//! maker's caches when the other first read them.

use crate::light_tree::{pick, starts, Cone, TreeLight, ONE_BELOW, WIDTH};
use crate::Vec3;
use rayon::prelude::*;

/// Groups of `WIDTH` lights (a light tree node's lanes) a cell holds: a
/// cache serves up to `GROUPS * WIDTH` lights.
const GROUPS: usize = 4;
const MAX_LIGHTS: usize = GROUPS * WIDTH;
/// About this many cells over the scene's box, as near cubes as its
/// shape allows (1 MB for 32 lights, and 3 MB more for the parts by
/// axis). In the benchmark's hall (256², 4 seeds, Glint's 512-spp
/// image), before the parts by axis, against the tree at 16 spp: 1,024
/// cells −5.6% time and −2.4% relMSE; 4,096, −3.5% and −8.7%; 16,384,
/// −1.6% and −9.8% (more cells, tighter bounds, but fewer of them in
/// cache).
const CELLS: f32 = 4096.0;

/// A normal within this cosine of an axis (0.8°) picks from the cell's
/// parts for that axis (`Tables::axis_ends`).
const AXIS_COS: f32 = 0.9999;

/// The most memory the copies of the tables take together (one copy a
/// worker thread): 4 MB tables get a copy a worker on up to 8 workers,
/// and one, shared, on more.
const COPIES_BUDGET: usize = 32 << 20;

/// Where a pick reads the tables: the cell of its point (None outside the
/// grid) and, where the tables keep parts by axis, the axis its normal
/// lies along.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Site {
    cell: Option<usize>,
    axis: Option<usize>,
}

/// What a pick at a site reads: the cell's running sums for the axis, or
/// the cell's terms.
enum Read<'a> {
    Ends(&'a [f32; MAX_LIGHTS]),
    Cell(&'a Cell),
}

impl Site {
    /// What a pick here reads of `tables`; None outside the grid.
    #[inline(always)]
    fn read(self, tables: &Tables) -> Option<Read<'_>> {
        let k = self.cell?;
        Some(match self.axis {
            Some(axis) => Read::Ends(&tables.axis_ends.get(k)?[axis]),
            None => Read::Cell(tables.cells.get(k)?),
        })
    }
}

/// Every light's terms in one cell, a lane each (light k in lane k).
#[derive(Clone, Copy)]
struct Cell {
    /// W·cos/d² over the cell; 0 for an unused lane.
    bound: [f32; MAX_LIGHTS],
    /// 1/d, d the distance from the cell's centre to the light's (no less
    /// than the two spheres' radii together).
    inv_dist: [f32; MAX_LIGHTS],
}

/// What a pick reads of the cells.
#[derive(Clone)]
struct Tables {
    cells: Vec<Cell>,
    /// Each cell's parts for normals along +x, −x, +y, −y, +z and −z, as
    /// running sums: lane k holds lanes 0..=k's. Empty where no surface
    /// lies along an axis. Apart from `cells`, whose 256 bytes a pick at
    /// any other normal reads.
    axis_ends: Vec<[[f32; MAX_LIGHTS]; 6]>,
}

impl Tables {
    fn bytes(&self) -> usize {
        std::mem::size_of_val(self.cells.as_slice()) + std::mem::size_of_val(self.axis_ends.as_slice())
    }
}

pub struct LightCache {
    lo: Vec3,
    hi: Vec3,
    /// Cells per unit length along each axis.
    scale: Vec3,
    dims: [usize; 3],
    /// The last cell's coordinates along each axis: dims − 1.
    last: Vec3,
    /// The tables, copy i for the worker thread of index i of the pool
    /// that made the cache, or one for all (`copies`).
    copies: Vec<Tables>,
    /// Each light's bounding sphere: centre and radius, a lane each.
    x: [f32; MAX_LIGHTS],
    y: [f32; MAX_LIGHTS],
    z: [f32; MAX_LIGHTS],
    radius: [f32; MAX_LIGHTS],
}

impl LightCache {
    /// The cache of `lights` over the box `lo`..`hi` that shading points
    /// lie in (the scene's triangles'), with parts by axis where
    /// `along_axes` says some surface lies along one (asked only for a
    /// grid that is made); None for more than `MAX_LIGHTS`, an empty or
    /// infinite box.
    pub fn new(lights: &[TreeLight], lo: Vec3, hi: Vec3, along_axes: impl FnOnce() -> bool) -> Option<Self> {
        if lights.is_empty() || lights.len() > MAX_LIGHTS || !(lo.cmple(hi).all() && lo.is_finite() && hi.is_finite()) {
            return None;
        }
        // A flat box (a floor alone) still gets cells of some depth.
        let extent = (hi - lo).max(Vec3::splat((hi - lo).max_element() * 1e-3)).max(Vec3::splat(1e-6));
        let side = (extent.x * extent.y * extent.z / CELLS).cbrt();
        let dims = [extent.x, extent.y, extent.z].map(|e| ((e / side).round() as usize).clamp(1, 64));
        let size = extent / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
        let scale = Vec3::ONE / size;
        if !scale.is_finite() {
            return None;
        }
        let cell_radius = 0.5 * size.length();
        let centre = |k: usize| {
            let (i, j, l) = (k % dims[0], (k / dims[0]) % dims[1], k / (dims[0] * dims[1]));
            lo + size * Vec3::new(i as f32 + 0.5, j as f32 + 0.5, l as f32 + 0.5)
        };
        let count = dims[0] * dims[1] * dims[2];
        let cells: Vec<Cell> = (0..count).into_par_iter().map(|k| cell(lights, centre(k), cell_radius)).collect();
        let axis_ends = if along_axes() { (0..count).into_par_iter().map(|k| axis_ends(lights, centre(k), cell_radius, &cells[k])).collect() } else { Vec::new() };
        let zero = [0.0; MAX_LIGHTS];
        let copies = copies(Tables { cells, axis_ends });
        let last = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32) - Vec3::ONE;
        let mut cache = LightCache { lo, hi: lo + extent, scale, dims, last, copies, x: zero, y: zero, z: zero, radius: zero };
        for (i, light) in lights.iter().enumerate() {
            let (middle, radius) = sphere(light);
            (cache.x[i], cache.y[i], cache.z[i], cache.radius[i]) = (middle.x, middle.y, middle.z, radius);
        }
        Some(cache)
    }

    /// The index of the cell holding `p`; None outside the grid.
    #[inline(always)]
    fn index(&self, p: Vec3) -> Option<usize> {
        if !(p.cmpge(self.lo).all() && p.cmple(self.hi).all()) {
            return None;
        }
        let [i, j, l] = cell_coords((p - self.lo) * self.scale, self.last);
        Some(i + self.dims[0] * (j + self.dims[1] * l))
    }

    /// The calling worker's copy of the tables; the first off the pool.
    /// Looked up once a pick (a thread-local read).
    #[inline(always)]
    fn tables(&self) -> &Tables {
        rayon::current_thread_index().and_then(|i| self.copies.get(i)).unwrap_or(&self.copies[0])
    }

    /// Where a pick at `p` and `n` reads the tables (`sample_at`).
    #[inline(always)]
    pub fn site(&self, p: Vec3, n: Vec3) -> Site {
        Site { cell: self.index(p), axis: if self.copies[0].axis_ends.is_empty() { None } else { axis_of(n) } }
    }

    /// `site`, and the lines a pick there reads asked for: the hall's
    /// picks had waited on the first read of a cell's sums for a third of
    /// their time (perf), 5% of the render's, where the BSDF's set-up now
    /// runs while they arrive.
    #[inline]
    pub fn site_fetched(&self, p: Vec3, n: Vec3) -> Site {
        let site = self.site(p, n);
        match site.read(self.tables()) {
            Some(Read::Ends(ends)) => crate::memory::prefetch(ends),
            Some(Read::Cell(cell)) => crate::memory::prefetch(cell),
            None => {}
        }
        site
    }

    /// Every light's part at `p` of normal `n` in `cell`, each group's sum
    /// and the total; None where the total is not positive and finite.
    #[inline(always)]
    #[allow(clippy::needless_range_loop, clippy::manual_clamp)] // a lane of six arrays; NaN
    fn parts(&self, cell: &Cell, p: Vec3, n: Vec3) -> Option<([[f32; WIDTH]; GROUPS], [f32; GROUPS], f32)> {
        // A zero normal: 1 added to every light's facing, which the
        // clamp then makes 1.
        let every_side = if n == Vec3::ZERO { 1.0 } else { 0.0 };
        let mut flat = [0.0; MAX_LIGHTS];
        for i in 0..MAX_LIGHTS {
            // n·(c − p) + r > 0: some of the light's sphere is above the
            // receiver's plane. Over the distance, about the cosine there.
            let above = n.x * (self.x[i] - p.x) + n.y * (self.y[i] - p.y) + n.z * (self.z[i] - p.z) + self.radius[i];
            let facing = above * cell.inv_dist[i] + every_side;
            // max, then min: a NaN facing gives no share (clamp keeps it).
            flat[i] = cell.bound[i] * facing.max(0.0).min(1.0);
        }
        let parts: [[f32; WIDTH]; GROUPS] = std::array::from_fn(|g| std::array::from_fn(|i| flat[g * WIDTH + i]));
        let sums = parts.map(|g| starts(&g).1);
        let total = (sums[0] + sums[1]) + (sums[2] + sums[3]);
        (total > 0.0 && total < f32::INFINITY).then_some((parts, sums, total))
    }

    /// A light for `p` and `n` from `u` in [0, 1) (as `LightTree::sample`:
    /// its index, its probability, u rescaled within the pick); None where
    /// the tree must pick.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        self.sample_at(self.site(p, n), p, n, u)
    }

    /// `sample` where `site` is `site(p, n)`'s.
    #[inline]
    pub fn sample_at(&self, site: Site, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        let cell = match site.read(self.tables())? {
            Read::Ends(ends) => return sample_ends(ends, u),
            Read::Cell(cell) => cell,
        };
        let (parts, sums, total) = self.parts(cell, p, n)?;
        let group_starts = [0.0, sums[0], sums[0] + sums[1], (sums[0] + sums[1]) + sums[2]];
        let (group, offset) = pick(&sums, &group_starts, u * total);
        let (lane, offset) = pick(&parts[group], &starts(&parts[group]).0, offset);
        let part = parts[group][lane];
        Some((group * WIDTH + lane, part / total, (offset / part).clamp(0.0, ONE_BELOW)))
    }

    /// The probability with which `sample` picks `light` at `p` and `n`;
    /// None where the tree picks.
    #[inline]
    pub fn probability(&self, light: usize, p: Vec3, n: Vec3) -> Option<f32> {
        let cell = match self.site(p, n).read(self.tables())? {
            Read::Ends(ends) => {
                let total = valid_total(ends)?;
                return Some((ends[light] - start_of(ends, light)) / total);
            }
            Read::Cell(cell) => cell,
        };
        let (parts, _, total) = self.parts(cell, p, n)?;
        Some(parts[light / WIDTH][light % WIDTH] / total)
    }
}

/// `tables` for every worker thread of the current pool, each copy made
/// by its worker (module docs), where they fit `COPIES_BUDGET`; else
/// `tables` alone.
fn copies(tables: Tables) -> Vec<Tables> {
    let workers = rayon::current_num_threads();
    if workers < 2 || workers.saturating_mul(tables.bytes()) > COPIES_BUDGET {
        return vec![tables];
    }
    let mut copies = rayon::broadcast(|worker| (worker.index(), tables.clone()));
    copies.sort_unstable_by_key(|&(index, _)| index);
    copies.into_iter().map(|(_, copy)| copy).collect()
}

/// Cell coordinates `c` (each finite and ≥ 0) as integers, none past
/// `last`'s: min(⌊c⌋, last) in each lane, all three in one conversion on
/// x86-64, where three saturating `as usize` casts had been 1.75% of the
/// hall's instructions (a pick asks twice: its light, then MIS its
/// probability).
#[inline(always)]
fn cell_coords(c: Vec3, last: Vec3) -> [usize; 3] {
    let c = c.min(last);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvtsi128_si32, _mm_cvttps_epi32, _mm_shuffle_epi32};
        // Truncation, as `as` does, of values within i32's range.
        // SAFETY: SSE2 is part of every x86-64 CPU (the target's baseline).
        unsafe {
            let v = _mm_cvttps_epi32(c.into());
            [_mm_cvtsi128_si32(v), _mm_cvtsi128_si32(_mm_shuffle_epi32::<1>(v)), _mm_cvtsi128_si32(_mm_shuffle_epi32::<2>(v))].map(|k| k as usize)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        [c.x as usize, c.y as usize, c.z as usize]
    }
}

/// Which of +x, −x, +y, −y, +z, −z `n` lies along, to `AXIS_COS`; None
/// for any other normal and for zero.
#[inline(always)]
pub(crate) fn axis_of(n: Vec3) -> Option<usize> {
    let a = n.abs();
    let k = if a.x >= a.y && a.x >= a.z { 0 } else if a.y >= a.z { 1 } else { 2 };
    (a[k] >= AXIS_COS).then(|| 2 * k + (n[k] < 0.0) as usize)
}

/// The sum of the parts whose running sums are `ends`, where it is
/// positive and finite.
#[inline(always)]
fn valid_total(ends: &[f32; MAX_LIGHTS]) -> Option<f32> {
    let total = ends[MAX_LIGHTS - 1];
    (total > 0.0 && total < f32::INFINITY).then_some(total)
}

/// Where lane `k`'s interval starts in running sums `ends`.
#[inline(always)]
fn start_of(ends: &[f32; MAX_LIGHTS], k: usize) -> f32 {
    if k == 0 { 0.0 } else { ends[k - 1] }
}

/// `LightCache::sample` from running sums: the lane is the count of sums
/// at or below u·total, compares side by side.
#[inline(always)]
fn sample_ends(ends: &[f32; MAX_LIGHTS], u: f32) -> Option<(usize, f32, f32)> {
    let total = valid_total(ends)?;
    let target = u * total;
    let mut lane = ends.iter().map(|&e| (e <= target) as usize).sum::<usize>();
    if lane == MAX_LIGHTS {
        // u·total rounded up to the total: the last lane with a part.
        lane = (0..MAX_LIGHTS).rev().find(|&k| ends[k] > start_of(ends, k)).unwrap_or(0);
    }
    let start = start_of(ends, lane);
    let part = ends[lane] - start;
    Some((lane, part / total, ((target - start) / part).clamp(0.0, ONE_BELOW)))
}

/// A light's bounding sphere: its box's centre and half diagonal.
fn sphere(light: &TreeLight) -> (Vec3, f32) {
    (0.5 * (light.lo + light.hi), 0.5 * (light.hi - light.lo).length())
}

/// Every light's terms seen from a cell of centre `centre` and bounding
/// radius `radius`.
fn cell(lights: &[TreeLight], centre: Vec3, radius: f32) -> Cell {
    let zero = [0.0; MAX_LIGHTS];
    let mut cell = Cell { bound: zero, inv_dist: zero };
    for (i, light) in lights.iter().enumerate() {
        let (middle, own) = sphere(light);
        let reach = own + radius;
        let v = centre - middle;
        let dist2 = v.length_squared();
        // The light's emission cone, seen from anywhere within `reach` of
        // its centre (a widened sphere), and the distance no nearer than
        // the spheres touching.
        let cos = match light.facing {
            Some((normal, both_ways)) => Cone { axis: normal, cos_o: 1.0, sin_o: 0.0, both_ways }.cos_bound(v, dist2, reach * reach),
            None => 1.0,
        };
        let bound = light.weight * cos / dist2.max(reach * reach).max(f32::MIN_POSITIVE);
        cell.bound[i] = if bound.is_finite() { bound.max(0.0) } else { 0.0 };
        let inv = 1.0 / dist2.sqrt().max(reach);
        cell.inv_dist[i] = if inv.is_finite() { inv } else { f32::MAX };
    }
    cell
}

/// The running sums of every light's part in a cell for normals along
/// each axis: the cell's bound times the facing term at its most over
/// the cell's points and the normals within `AXIS_COS` of the axis.
fn axis_ends(lights: &[TreeLight], centre: Vec3, radius: f32, cell: &Cell) -> [[f32; MAX_LIGHTS]; 6] {
    let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let sin_cone = (1.0 - AXIS_COS * AXIS_COS).sqrt();
    let mut ends = [[0.0; MAX_LIGHTS]; 6];
    for (i, light) in lights.iter().enumerate() {
        let (middle, own) = sphere(light);
        // n·(c − p) ≤ n·v + radius for p in the cell, v = c − centre, and
        // n·v at most |v|·cos(max(0, angle(axis, v) − θ)) in the cone;
        // a millionth of the lengths more against rounding.
        let v = middle - centre;
        let length = v.length();
        let slack = 1e-6 * (length + radius + own + centre.abs().max_element());
        for (a, axis) in axes.iter().enumerate() {
            let along = axis.dot(v);
            let most = if along >= length * AXIS_COS { length } else { along * AXIS_COS + axis.cross(v).length() * sin_cone };
            // max, then min: as `LightCache::parts` (NaN becomes 0 there,
            // where `clamp` keeps it).
            #[allow(clippy::manual_clamp)]
            let facing = ((most + radius + own + slack) * cell.inv_dist[i]).max(0.0).min(1.0);
            ends[a][i] = cell.bound[i] * facing;
        }
    }
    for sums in &mut ends {
        for k in 1..MAX_LIGHTS {
            sums[k] += sums[k - 1];
        }
    }
    ends
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cell of a point, three lanes at once, is each lane's ⌊c⌋ no
    /// past the last cell, as one `as usize` and `min` a lane gives it:
    /// at zeros of both signs, just below and at whole numbers, at and
    /// past the far side.
    #[test]
    fn cell_coordinates_are_the_lanes_truncated_and_capped() {
        let last = Vec3::new(63.0, 1.0, 2.0);
        let below = |v: f32| f32::from_bits(v.to_bits() - 1);
        let mut values = vec![0.0, -0.0, 1e-30, 0.5, below(1.0), 1.0, below(2.0), 2.0, 17.25, below(63.0), 63.0, below(64.0), 64.0, 64.0001, 1e6];
        values.extend((0..200).map(|k| k as f32 * 0.3217));
        for &x in &values {
            for &y in &values[..20] {
                for &z in &values[..6] {
                    let c = Vec3::new(x, y, z);
                    let scalar = [(x as usize).min(63), (y as usize).min(1), (z as usize).min(2)];
                    assert_eq!(cell_coords(c, last), scalar, "{c:?}");
                }
            }
        }
    }

    fn lamps(count: usize) -> Vec<TreeLight> {
        (0..count)
            .map(|i| {
                let c = Vec3::new((i % 4) as f32 * 3.0 - 4.5, 2.5, (i / 4) as f32 * 3.0 - 4.5);
                TreeLight { weight: 1.0 + i as f32, lo: c - Vec3::splat(0.1), hi: c + Vec3::splat(0.1), facing: Some((Vec3::NEG_Y, false)), cos_spread: 0.0 }
            })
            .collect()
    }

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap()
    }

    /// A cache made in a pool of two keeps a copy of its tables for each
    /// worker, apart in memory, and each worker picks from its own with
    /// the same picks and probabilities; off the pool, the first copy.
    #[test]
    fn each_worker_picks_from_its_own_copy_alike() {
        let lights = lamps(16);
        let (lo, hi) = (Vec3::splat(-6.0), Vec3::splat(6.0));
        let pool = pool(2);
        let cache = pool.install(|| LightCache::new(&lights, lo, hi, || true)).unwrap();
        assert_eq!(cache.copies.len(), 2);
        assert!(cache.copies[0].bytes() > 0 && cache.copies[0].axis_ends.len() == cache.copies[0].cells.len());
        assert_ne!(cache.copies[0].cells.as_ptr(), cache.copies[1].cells.as_ptr());
        assert_ne!(cache.copies[0].axis_ends.as_ptr(), cache.copies[1].axis_ends.as_ptr());
        let points = [(Vec3::new(0.3, -1.0, 0.2), Vec3::Y), (Vec3::new(-2.0, 0.5, 1.0), Vec3::new(0.3, 0.8, -0.5).normalize()), (Vec3::new(4.0, 1.0, -3.0), Vec3::ZERO)];
        // Which copy (its address) a thread read, and what it picked.
        // A pick's (light, probability, u left) and light 3's probability.
        type Seen = (Option<(usize, f32, f32)>, Option<f32>);
        let picks = |cache: &LightCache| -> (usize, Vec<Seen>) {
            let seen = points.iter().flat_map(|&(p, n)| [0.1f32, 0.5, 0.9].map(|u| (cache.sample(p, n, u), cache.probability(3, p, n)))).collect();
            (cache.tables().cells.as_ptr() as usize, seen)
        };
        let mut by_worker = pool.broadcast(|worker| (worker.index(), picks(&cache)));
        by_worker.sort_by_key(|(index, _)| *index);
        for (index, (table, seen)) in &by_worker {
            assert_eq!(*table, cache.copies[*index].cells.as_ptr() as usize, "worker {index} reads another's copy");
            assert_eq!(seen, &by_worker[0].1 .1, "worker {index} picks otherwise");
        }
        assert!(by_worker[0].1 .1.iter().all(|(pick, _)| pick.is_some()));
        let (table, seen) = std::thread::scope(|s| s.spawn(|| picks(&cache)).join().unwrap());
        assert_eq!((table, &seen), (cache.copies[0].cells.as_ptr() as usize, &by_worker[0].1 .1));
    }

    /// A pick from the site fetched as the vertex is found is the pick at
    /// the point, and each pick's probability is the one MIS asks for:
    /// along the axes (parts by axis) and off them, with no normal, on the
    /// grid's faces and outside it, with the tables by axis and without.
    #[test]
    fn a_pick_from_its_fetched_site_is_the_pick_there() {
        let lights = lamps(16);
        let (lo, hi) = (Vec3::splat(-6.0), Vec3::splat(6.0));
        let mut rng = crate::rng::Rng::new(3, 1);
        let normals = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(0.3, 0.8, -0.5).normalize(), Vec3::ZERO];
        for by_axis in [true, false] {
            let cache = LightCache::new(&lights, lo, hi, || by_axis).unwrap();
            let mut picked = 0;
            for k in 0..600 {
                let p = match k % 6 {
                    0 => hi,
                    1 => Vec3::new(lo.x, 0.0, hi.z),
                    2 => Vec3::new(7.0, 0.0, 0.0),
                    _ => lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                };
                let n = normals[k % normals.len()];
                let u = rng.next_f32();
                let pick = cache.sample(p, n, u);
                assert_eq!(cache.sample_at(cache.site_fetched(p, n), p, n, u), pick, "{p:?} {n:?}");
                // Outside the grid the tree picks; below every lamp, none
                // can be picked.
                assert!(k % 6 != 2 || pick.is_none());
                if let Some((light, probability, _)) = pick {
                    picked += 1;
                    assert_eq!(cache.probability(light, p, n), Some(probability), "{p:?} {n:?}");
                }
            }
            assert!(picked > 200, "{picked} picked");
        }
    }

    /// One copy, shared, where a copy a worker would pass the budget, and
    /// in a pool of one.
    #[test]
    fn one_copy_past_the_budget_or_for_one_worker() {
        let lights = lamps(32);
        let (lo, hi) = (Vec3::splat(-6.0), Vec3::splat(6.0));
        let one = pool(1).install(|| LightCache::new(&lights, lo, hi, || true)).unwrap();
        assert_eq!(one.copies.len(), 1);
        let bytes = one.copies[0].bytes();
        let most = COPIES_BUDGET / bytes;
        assert!((2..16).contains(&most), "{bytes} bytes");
        assert_eq!(pool(most).install(|| LightCache::new(&lights, lo, hi, || true)).unwrap().copies.len(), most);
        assert_eq!(pool(most + 1).install(|| LightCache::new(&lights, lo, hi, || true)).unwrap().copies.len(), 1);
    }
}
