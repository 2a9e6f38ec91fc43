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

/// A square of half-side R, square to a sun's light, centred on the line
/// through the scene's centre, just outside the scene's sphere; its cells
/// picked by weight and a point uniform in the picked cell.
pub struct SunCells {
    /// The square's centre and its frame (z along the sun's light).
    centre: Vec3,
    frame: Frame,
    half: f32,
    cells: Distribution1D,
}

impl SunCells {
    /// The cells for a sun whose light travels along unit `travel`, over
    /// the scene's sphere (`centre`, `radius`); and the share of the
    /// sun's light through the scene's disk that lands in view, the
    /// cells' light that the test below judged seen, over the disk's.
    pub fn new(ctx: &Context, travel: Vec3, centre: Vec3, radius: f32) -> (Self, f32) {
        let square = SunCells { centre: centre - travel * (radius * 1.01), frame: Frame::from_normal(travel), half: radius, cells: Distribution1D::default() };
        let (w, h) = (1024, (1024.0 / ctx.scene.camera.aspect_ratio.unwrap_or(1.0)).round().clamp(1.0, 65536.0) as u32);
        let lens = ctx.scene.camera.lens(w, h);
        let mut rng = Rng::new(0x7375_6e5f_6365_6c6c, 0);
        let mut meets = vec![false; CELLS * CELLS];
        let mut seen = vec![false; CELLS * CELLS];
        let mut focused = vec![false; CELLS * CELLS];
        let (mut in_disk, mut in_view_count) = (0u32, 0u32);
        for i in 0..CELLS * CELLS {
            let local = square.local_point(i, rng.next_2d());
            let mut origin = square.world_point(local);
            let mut lands = None;
            // Through glass, which light subpaths pass (ending none there),
            // to where the light lands; glass seen counts as in view.
            for _ in 0..PANES {
                let Some(hit) = ctx.intersect(origin, travel, RayKind::Bounce, &mut rng) else { break };
                let (si, _) = SurfaceHit::with_normal(ctx.scene, &hit, travel, &mut rng);
                // A roughness texture is taken as smooth somewhere.
                let m = ctx.scene.material_of(hit.triangle);
                focused[i] |= m.transmission > 0.0 || m.focuses_light(|_| 0.0);
                let view = in_sight(ctx, &lens, &si, &mut rng);
                lands = Some(view);
                if view || m.transmission <= 0.0 {
                    break;
                }
                origin = si.spawn_origin(travel);
            }
            meets[i] = lands.is_some();
            seen[i] = lands == Some(true) || (lands.is_some() && !lens.joinable());
            focused[i] &= seen[i];
            if local.length_squared() <= 1.0 {
                in_disk += 1;
                in_view_count += seen[i] as u32;
            }
        }
        let (meets, seen, focused) = (dilate(&meets), dilate(&seen), dilate(&focused));
        let count = |m: &[bool]| m.iter().filter(|&&b| b).count().max(1) as f64;
        let (n_meets, n_seen, n_focused) = (count(&meets), count(&seen), count(&focused));
        let (in_view, focus) = if focused.contains(&true) { (IN_VIEW, FOCUSED) } else { (IN_VIEW + FOCUSED, 0.0) };
        let share = |set: bool, of: f64, n: f64| if set { of / n } else { 0.0 };
        let weights = (0..CELLS * CELLS).map(|i| UNIFORM / (CELLS * CELLS) as f64 + share(meets[i], MEETS, n_meets) + share(seen[i], in_view, n_seen) + share(focused[i], focus, n_focused));
        let landed = if in_disk > 0 { in_view_count as f32 / in_disk as f32 } else { 0.0 };
        (SunCells { cells: Distribution1D::new(weights), ..square }, landed)
    }

    /// Cell `i`'s point at `u` within it, in units of the half-side
    /// (the square is [-1, 1]²).
    fn local_point(&self, i: usize, u: Vec2) -> Vec2 {
        let cell = Vec2::new((i % CELLS) as f32, (i / CELLS) as f32);
        (cell + u) * (2.0 / CELLS as f32) - Vec2::ONE
    }

    fn world_point(&self, local: Vec2) -> Vec3 {
        self.centre + self.frame.to_world(Vec3::from((local * self.half).extend(0.0)))
    }

    /// A start's point, and its density per unit area of the square.
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (i, rest) = self.cells.sample_remapped(u.x);
        (self.world_point(self.local_point(i, Vec2::new(rest, u.y))), self.cell_density(i))
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
        let cell = (Vec2::new(local.x, local.y) / self.half + Vec2::ONE) * (0.5 * CELLS as f32);
        if !(cell.x >= 0.0 && cell.y >= 0.0 && cell.x < CELLS as f32 && cell.y < CELLS as f32) {
            return 0.0;
        }
        self.cell_density(cell.y as usize * CELLS + cell.x as usize)
    }

    fn cell_density(&self, i: usize) -> f32 {
        let side = 2.0 * self.half / CELLS as f32;
        self.cells.probability(i) as f32 / (side * side)
    }
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
        let square = SunCells { centre: Vec3::new(1.0, 2.0, 3.0), frame: Frame::from_normal(Vec3::new(0.3, -0.5, 0.8).normalize()), half: 2.5, cells: Distribution1D::new((0..CELLS * CELLS).map(|i| (i % 7) as f64)) };
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

    #[test]
    fn densities_integrate_to_one_over_the_square() {
        let square = SunCells { centre: Vec3::ZERO, frame: Frame::from_normal(Vec3::Z), half: 0.5, cells: Distribution1D::new((0..CELLS * CELLS).map(|i| 1.0 + (i % 5) as f64)) };
        let n = 512;
        let sum: f64 = (0..n * n).map(|k| square.density(Vec3::new(((k % n) as f32 + 0.5) / n as f32 - 0.5, ((k / n) as f32 + 0.5) / n as f32 - 0.5, 1.0), Vec3::Z) as f64).sum::<f64>() / (n * n) as f64;
        assert!((sum - 1.0).abs() < 1e-4, "{sum}");
    }
}
