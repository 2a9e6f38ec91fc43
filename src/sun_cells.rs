//! Where on a square across a sun's light its light subpaths start
//! (lights.rs, `SunStarts`): cells weighted by where the sun's light
//! through them first lands. A sun's light through the scene's disk
//! lands mostly where the camera may never look (a roof, the outside of
//! a room's walls, a ground plane beyond the view); its subpaths pay only
//! where it lands in view, or passes glass on its way there. Starts drawn
//! uniformly over the disk spent most of themselves outside, and a
//! room's lamps lost the starts the sun took.

use crate::integrator::{Context, SurfaceHit};
use crate::traversal_bench::RayKind;
use crate::rng::Rng;
use crate::sampling::{Distribution1D, Frame};
use crate::Vec3;
use glam::Vec2;

/// Cells along each side of the square: 64² rays per sun, as many as
/// the light-path rule's (`light_paths::landing`).
const CELLS: usize = 64;
/// The starts' shares: uniform over the square (so that every point the
/// sun's light crosses keeps a start, however the test below judged its
/// cell), over the cells whose light meets a surface, over those whose
/// light lands in view, and over those whose light lands in view on a
/// surface that focuses it (glass, or glossy enough for a caustic,
/// `Material::focuses_light`), or passes glass on its way. Without the
/// last kind its share is the third's; shares of other absent kinds go
/// to the rest. Against 80% in view and none focused (relMSE, paired
/// seeds): the gold sphere under a 5° sun −39% ± 5 at 4 spp and −43% ± 5
/// at 16 for 6% more time a sample (70% focused: −47% at 4 spp); the
/// glass sphere with the sun beside its lamp −1.8% ± 0.5 at 4 spp; the
/// window room with the sun on its gold ball +2.3% ± 1.2 at 16 spp (70%:
/// +8.8%), where the light the floor sends on is most of the image.
const UNIFORM: f64 = 0.05;
const MEETS: f64 = 0.15;
const IN_VIEW: f64 = 0.4;
const FOCUSED: f64 = 0.4;
/// Glass a cell's light passes through before it lands, at most.
const PANES: u32 = 4;

/// A square of half-side R, square to a sun's light through the scene's
/// centre; its cells picked by weight and a point uniform in the picked
/// cell, through which a start passes (from outside the scene's sphere,
/// `Lights::sun_start`). On a square outside the sphere, a sized sun's
/// cone had spread the light of a cell R·θ wide where it lands: on a
/// ground plane a kilometre wide, a 5° sun's starts meant for a ball 2 m
/// across landed up to 30 m from it. Where the surfaces in view that
/// focus light cast their shadows on a small part of the square (a ball
/// on a ground plane a kilometre wide, whose shadow one cell of 22 m
/// holds, and which one ray a cell missed), a finer grid over them takes
/// `FINE_SHARE` of the starts instead of the coarse cells' focusing
/// share.
pub struct SunCells {
    /// The square's centre and its frame (z along the sun's light).
    centre: Vec3,
    frame: Frame,
    half: f32,
    coarse: Grid,
    /// The grid over the focusing surfaces, and its share of the starts.
    fine: Option<(Grid, f32)>,
}

/// CELLS × CELLS cells over a square part of the square, in units of its
/// half-side (the whole square is [-1, 1]²).
struct Grid {
    /// Its lower corner and side.
    lo: Vec2,
    side: f32,
    cells: Distribution1D,
    /// Each cell's density per unit area of the square, kept: every
    /// connection to a sun's subpath and every sun light sample's MIS
    /// weight asks it (two lookups and an f64 division each, 1.6% of a
    /// sunlit render's time).
    densities: Vec<f32>,
}

impl Grid {
    fn whole() -> Self {
        Grid::over(-Vec2::ONE, 2.0)
    }

    fn over(lo: Vec2, side: f32) -> Self {
        Grid { lo, side, cells: Distribution1D::default(), densities: Vec::new() }
    }

    /// The grid with its cells weighted, the square's half-side `half`.
    fn weighed(mut self, weights: impl IntoIterator<Item = f64>, half: f32) -> Self {
        self.cells = Distribution1D::new(weights);
        let side = self.side * half / CELLS as f32;
        self.densities = (0..self.cells.len()).map(|i| self.cells.probability(i) as f32 / (side * side)).collect();
        self
    }

    /// Cell `i`'s point at `u` within it.
    fn local_point(&self, i: usize, u: Vec2) -> Vec2 {
        let cell = Vec2::new((i % CELLS) as f32, (i / CELLS) as f32);
        self.lo + (cell + u) * (self.side / CELLS as f32)
    }

    /// The cell that holds `local`, if the grid does.
    fn cell_at(&self, local: Vec2) -> Option<usize> {
        let cell = (local - self.lo) * (CELLS as f32 / self.side);
        (cell.x >= 0.0 && cell.y >= 0.0 && cell.x < CELLS as f32 && cell.y < CELLS as f32).then(|| cell.y as usize * CELLS + cell.x as usize)
    }

    /// Cell `i`'s density per unit area.
    fn density(&self, i: usize) -> f32 {
        self.densities[i]
    }
}

/// Where the sun's light through one ray of each of a grid's cells lands.
struct Landing {
    meets: Vec<bool>,
    seen: Vec<bool>,
    focused: Vec<bool>,
    /// The cells within the disk (the scene's sphere's shadow), and how
    /// many of them are seen.
    in_disk: u32,
    in_view: u32,
}

/// The share of a fine grid's starts uniform over it, the rest going to
/// its cells whose light lands in view on a surface that focuses it
/// (0.3: +3% and +7% relMSE on the gold sphere under a 5° sun on its 20
/// m and 1 km floors, 4 spp, 8 seeds).
const FINE_UNIFORM: f64 = 0.1;
/// The fine grid's share of all starts, where there is one, the coarse
/// cells' focusing share; their other shares make up the rest in their
/// proportions. 0.6 instead (relMSE, paired seeds): the gold sphere under
/// a 5° sun on its 20 m and 1 km floors −13.5% ± 4 and −10% ± 4 at 4 spp
/// (8 seeds; 0.8: −2% more, 0.25: +18% and +28%), the glass sphere with
/// the sun beside its lamp −0.3% ± 0.1 (16 seeds), but the window room
/// with the sun on a gold ball 0.4 m across +2.8% ± 0.3 at 16 spp (6
/// seeds) and 8% more time a sample, where the light the floor sends on
/// is most of the image: open ground and a closed room want different
/// shares, and two scenes do not set a rule.
const FINE_SHARE: f32 = FOCUSED as f32;

impl SunCells {
    /// The cells for a sun whose light travels along unit `travel`, over
    /// the scene's sphere (`centre`, `radius`); and the share of the
    /// sun's light through the scene's disk that lands in view, the
    /// cells' light that the test below judged seen, over the disk's.
    pub fn new(ctx: &Context, travel: Vec3, centre: Vec3, radius: f32) -> (Self, f32) {
        let mut square = SunCells { centre, frame: Frame::from_normal(travel), half: radius, coarse: Grid::whole(), fine: None };
        let (w, h) = (1024, (1024.0 / ctx.scene.camera.aspect_ratio.unwrap_or(1.0)).round().clamp(1.0, 65536.0) as u32);
        let lens = ctx.scene.camera.lens(w, h);
        let mut rng = Rng::new(0x7375_6e5f_6365_6c6c, 0);
        let landing = square.landing(ctx, &lens, &square.coarse, &mut rng);
        let fine = square.focusing_bounds(ctx, &lens).and_then(|(lo, side)| {
            let grid = Grid::over(lo, side);
            let focused = dilate(&square.landing(ctx, &lens, &grid, &mut rng).focused);
            let n = focused.iter().filter(|&&b| b).count();
            (n > 0).then(|| grid.weighed(focused.iter().map(|&f| FINE_UNIFORM / (CELLS * CELLS) as f64 + if f { (1.0 - FINE_UNIFORM) / n as f64 } else { 0.0 }), radius))
        });
        let (meets, seen) = (dilate(&landing.meets), dilate(&landing.seen));
        // The focusing share goes to the fine grid where there is one.
        let focused = if fine.is_some() { vec![false; CELLS * CELLS] } else { dilate(&landing.focused) };
        let count = |m: &[bool]| m.iter().filter(|&&b| b).count().max(1) as f64;
        let (n_meets, n_seen, n_focused) = (count(&meets), count(&seen), count(&focused));
        let (in_view, focus) = if focused.contains(&true) || fine.is_some() { (IN_VIEW, FOCUSED) } else { (IN_VIEW + FOCUSED, 0.0) };
        let share = |set: bool, of: f64, n: f64| if set { of / n } else { 0.0 };
        let weights = (0..CELLS * CELLS).map(|i| UNIFORM / (CELLS * CELLS) as f64 + share(meets[i], MEETS, n_meets) + share(seen[i], in_view, n_seen) + share(focused[i], focus, n_focused));
        square.coarse = Grid::whole().weighed(weights, radius);
        square.fine = fine.map(|g| (g, FINE_SHARE));
        let landed = if landing.in_disk > 0 { landing.in_view as f32 / landing.in_disk as f32 } else { 0.0 };
        (square, landed)
    }

    /// One ray along the light through each of `grid`'s cells: where it
    /// lands, through glass, which light subpaths pass (ending none
    /// there); glass seen counts as in view.
    fn landing(&self, ctx: &Context, lens: &crate::camera::Lens, grid: &Grid, rng: &mut Rng) -> Landing {
        let travel = self.frame.to_world(Vec3::Z);
        let mut out = Landing { meets: vec![false; CELLS * CELLS], seen: vec![false; CELLS * CELLS], focused: vec![false; CELLS * CELLS], in_disk: 0, in_view: 0 };
        for i in 0..CELLS * CELLS {
            let local = grid.local_point(i, rng.next_2d());
            let mut origin = self.world_point(local) - travel * (self.half * 1.01);
            let mut lands = None;
            for _ in 0..PANES {
                let Some(hit) = ctx.intersect(origin, travel, RayKind::Bounce, rng) else { break };
                let (si, _) = SurfaceHit::with_normal(ctx.scene, &hit, travel, rng);
                let m = ctx.scene.material_of(hit.triangle);
                out.focused[i] |= focuses(m);
                let view = in_sight(ctx, lens, &si, rng);
                lands = Some(view);
                if view || m.transmission <= 0.0 {
                    break;
                }
                origin = si.spawn_origin(travel);
            }
            out.meets[i] = lands.is_some();
            out.seen[i] = lands == Some(true) || (lands.is_some() && !lens.joinable());
            out.focused[i] &= out.seen[i];
            if local.length_squared() <= 1.0 {
                out.in_disk += 1;
                out.in_view += out.seen[i] as u32;
            }
        }
        out
    }

    /// The square (lower corner and side, in units of the half-side) that
    /// holds the shadows of the surfaces that focus light with a corner in
    /// view, padded by a sixteenth; None where there are none or that
    /// square is more than an eighth of the whole's side, a few coarse
    /// cells: the coarse grid then finds them.
    fn focusing_bounds(&self, ctx: &Context, lens: &crate::camera::Lens) -> Option<(Vec2, f32)> {
        let scene = ctx.scene;
        let focusing: Vec<bool> = scene.materials.iter().map(focuses).collect();
        let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
        for t in scene.triangles.iter().filter(|t| focusing.get(t.material as usize) == Some(&true)) {
            let corners = t.p();
            if lens.joinable() && !corners.iter().any(|&p| lens.project(p, Vec2::splat(0.5), 0.0).is_some_and(|s| s.pixel.is_some())) {
                continue;
            }
            for p in corners {
                let local = self.frame.to_local(p - self.centre);
                let local = Vec2::new(local.x, local.y) / self.half;
                (lo, hi) = (lo.min(local), hi.max(local));
            }
        }
        let side = (hi - lo).max_element() * (1.0 + 1.0 / 16.0);
        (side.is_finite() && side > 0.0 && side <= 2.0 / 8.0).then(|| ((lo + hi - Vec2::splat(side)) * 0.5, side))
    }

    fn world_point(&self, local: Vec2) -> Vec3 {
        self.centre + self.frame.to_world(Vec3::from((local * self.half).extend(0.0)))
    }

    /// A start's point, and its density per unit area of the square.
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (grid, u_cell) = match &self.fine {
            Some((fine, share)) if u.x < *share => (fine, u.x / share),
            Some((_, share)) => (&self.coarse, ((u.x - share) / (1.0 - share)).min(1.0 - f32::EPSILON)),
            None => (&self.coarse, u.x),
        };
        let (i, rest) = grid.cells.sample_remapped(u_cell);
        let local = grid.local_point(i, Vec2::new(rest, u.y));
        let density = match &self.fine {
            Some(_) => self.density_at(local),
            None => self.coarse.density(i),
        };
        (self.world_point(local), density)
    }

    /// The density per unit area of the square with which `sample` draws
    /// the point where the line through `p` along unit `dir` crosses it;
    /// 0 where it misses the square or runs along it.
    pub fn density(&self, p: Vec3, dir: Vec3) -> f32 {
        let axis = self.frame.to_world(Vec3::Z);
        let along = dir.dot(axis);
        if !(along > 0.0) {
            return 0.0;
        }
        let x = p - dir * ((p - self.centre).dot(axis) / along);
        let local = self.frame.to_local(x - self.centre);
        self.density_at(Vec2::new(local.x, local.y) / self.half)
    }

    /// The density at `local` (in units of the half-side).
    fn density_at(&self, local: Vec2) -> f32 {
        let coarse = self.coarse.cell_at(local).map_or(0.0, |i| self.coarse.density(i));
        match &self.fine {
            Some((fine, share)) => (1.0 - share) * coarse + share * fine.cell_at(local).map_or(0.0, |i| fine.density(i)),
            None => coarse,
        }
    }
}

/// Whether a surface of `m` focuses a sun's light (glass, or glossy enough
/// for a caustic; a roughness texture taken as smooth somewhere) or lets
/// it through.
fn focuses(m: &crate::material::Material) -> bool {
    m.transmission > 0.0 || m.focuses_light(|_| 0.0)
}

/// Whether the camera sees `si` from the side the light came from (si.ng
/// faces it), through nothing.
pub(crate) fn in_sight(ctx: &Context, lens: &crate::camera::Lens, si: &SurfaceHit, rng: &mut Rng) -> bool {
    let Some(seen) = lens.project(si.p, Vec2::splat(0.5), 0.0) else { return false };
    if seen.pixel.is_none() || !(si.ng.dot(seen.to_camera) > 0.0) {
        return false;
    }
    ctx.clear_to_camera(si.spawn_origin(seen.to_camera), &seen, rng)
}

/// Each cell set where it or one of its eight neighbours is: a sized
/// sun's light crosses a cell at an angle, and a cell's one ray stands
/// for all of it.
fn dilate(mask: &[bool]) -> Vec<bool> {
    let n = CELLS as i64;
    (0..CELLS * CELLS)
        .map(|i| {
            let (x, y) = ((i % CELLS) as i64, (i / CELLS) as i64);
            (-1..=1).any(|dy| (-1..=1).any(|dx| (0..n).contains(&(x + dx)) && (0..n).contains(&(y + dy)) && mask[((y + dy) * n + x + dx) as usize]))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn densities_agree_with_samples() {
        let square = SunCells { centre: Vec3::new(1.0, 2.0, 3.0), frame: Frame::from_normal(Vec3::new(0.3, -0.5, 0.8).normalize()), half: 2.5, coarse: Grid::whole().weighed((0..CELLS * CELLS).map(|i| (i % 7) as f64), 2.5), fine: None };
        let axis = square.frame.to_world(Vec3::Z);
        let mut rng = Rng::new(3, 0);
        for _ in 0..1000 {
            let (x, pdf) = square.sample(rng.next_2d());
            // Found again from a point further along the light, along
            // the axis and along a tilted direction through x.
            let tilted = (axis + 0.05 * square.frame.to_world(Vec3::X)).normalize();
            for dir in [axis, tilted] {
                let again = square.density(x + dir * 3.7, dir);
                assert!((again - pdf).abs() <= 1e-3 * pdf, "{again} {pdf}");
            }
            assert!(pdf > 0.0);
        }
        // Behind, along and off the square.
        assert_eq!(square.density(square.centre, -axis), 0.0);
        assert_eq!(square.density(square.centre + square.frame.to_world(Vec3::X) * 2.6, axis), 0.0);
    }

    /// With a fine grid over a small part of the square as well, each
    /// sample's density is the mixture's, found again from the point; and
    /// the mixture integrates to 1.
    #[test]
    fn a_fine_grid_mixes_with_the_coarse_one() {
        // Weights by row; the sum's 2560² points fall 64 to a side of it.
        let fine = Grid::over(Vec2::new(0.1, -0.3), 0.05).weighed((0..CELLS * CELLS).map(|i| (i / CELLS < 20) as u32 as f64), 0.5);
        let square = SunCells { centre: Vec3::ZERO, frame: Frame::from_normal(Vec3::Z), half: 0.5, coarse: Grid::whole().weighed((0..CELLS * CELLS).map(|i| 1.0 + (i % 5) as f64), 0.5), fine: Some((fine, 0.4)) };
        let mut rng = Rng::new(4, 0);
        let mut in_fine = 0;
        for _ in 0..4000 {
            let (x, pdf) = square.sample(rng.next_2d());
            let again = square.density(x - Vec3::Z, Vec3::Z);
            assert!((again - pdf).abs() <= 1e-3 * pdf, "{again} {pdf}");
            in_fine += (x.x > 0.05 && x.x < 0.075 && x.y > -0.15 && x.y < -0.15 + 0.025 * 20.0 / 64.0) as u32;
        }
        assert!((in_fine as f32 / 4000.0 - 0.4).abs() < 0.04, "{in_fine}");
        let n = 2560;
        let sum: f64 = (0..n * n).map(|k| square.density(Vec3::new(((k % n) as f32 + 0.5) / n as f32 - 0.5, ((k / n) as f32 + 0.5) / n as f32 - 0.5, 1.0), Vec3::Z) as f64).sum::<f64>() / (n * n) as f64;
        assert!((sum - 1.0).abs() < 1e-4, "{sum}");
    }

    #[test]
    fn densities_integrate_to_one_over_the_square() {
        let square = SunCells { centre: Vec3::ZERO, frame: Frame::from_normal(Vec3::Z), half: 0.5, coarse: Grid::whole().weighed((0..CELLS * CELLS).map(|i| 1.0 + (i % 5) as f64), 0.5), fine: None };
        let n = 512;
        let sum: f64 = (0..n * n).map(|k| square.density(Vec3::new(((k % n) as f32 + 0.5) / n as f32 - 0.5, ((k / n) as f32 + 0.5) / n as f32 - 0.5, 1.0), Vec3::Z) as f64).sum::<f64>() / (n * n) as f64;
        assert!((sum - 1.0).abs() < 1e-4, "{sum}");
    }
}
