//! Light portals: Blender area lights marked Portal (Cycles' Light ›
//! Portal), placed in the windows and doorways of an interior lit by the
//! World. A portal emits nothing and blocks nothing; it tells light
//! sampling where the World's light comes in. Inside a room the sky is
//! seen only through its windows, and a direction drawn over the
//! hemisphere (or, beside a lamp, left to BSDF sampling, as a constant
//! World is under MIS) finds a window only by chance. Through a portal, every light sample of
//! the World looks at it.
//!
//! A point in front of a portal (on the side its light would shine to,
//! Blender's −Z, into the room) draws a direction uniformly over the solid
//! angle the portals cover there: each piece — a rectangular portal whole,
//! sampled as a spherical rectangle (spherical_rectangle.rs), or a
//! triangle of a disk's or a sheared one's outline, as a spherical
//! triangle (spherical_triangle.rs) — is picked by its solid angle, so the
//! density is n/Ω, Ω the portals' total solid angle seen from the point
//! and n the number of portals the direction passes through (1 unless two
//! portals overlap in view). Pieces under `MIN_SOLID_ANGLE` (a far, small
//! window) are left to BSDF sampling, in the sampling and in the density
//! alike.

use crate::accel::{self, RtTriangle};
use crate::spherical_rectangle::{Rectangle, SphericalRectangle};
use crate::spherical_triangle::{self, SphericalTriangle};
use crate::Vec3;
use glam::Vec2;
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

/// One portal: the triangles of its outline and the unit normal of the
/// side the World's light goes to.
#[derive(Clone, Debug)]
pub struct Portal {
    pub triangles: Vec<[Vec3; 3]>,
    /// Where the outline is a rectangle (a square or rectangle light not
    /// sheared): the rectangle, sampled whole
    /// as a spherical rectangle rather than as its two triangles (in a
    /// room lit through a window, 2.2× → 1.4× the time per sample of the
    /// room without its portal; single precision, as the rectangle is
    /// left to BSDF samples under `MIN_SOLID_ANGLE`).
    pub rectangle: Option<Rectangle>,
    pub inward: Vec3,
    /// A point of its plane.
    pub origin: Vec3,
}

impl Portal {
    /// Whether `p` lies in front of the portal, off its plane by more than
    /// rounding: only there do directions through it lead out.
    fn faces(&self, p: Vec3) -> bool {
        let rounding = 8.0 * f32::EPSILON * p.abs().max(self.origin.abs()).max_element();
        (p - self.origin).dot(self.inward) > rounding
    }
}

/// What is sampled whole: a portal's rectangle, or one triangle of its
/// outline.
#[derive(Clone, Copy)]
enum Piece<'a> {
    /// The rectangle, and the outline's triangles (for `crosses`).
    Rectangle(&'a Rectangle, &'a [[Vec3; 3]]),
    Triangle(&'a [Vec3; 3]),
}

impl Piece<'_> {
    /// Its solid angle from `p`; 0 under `MIN_SOLID_ANGLE` or with `p` in
    /// its plane.
    fn solid_angle(self, p: Vec3) -> f32 {
        match self {
            Piece::Rectangle(..) => self.rectangle(p).map_or(0.0, |r| r.solid_angle),
            Piece::Triangle(t) => spherical_triangle::solid_angle(p, t).unwrap_or(0.0),
        }
    }

    /// A rectangle piece as seen from `p`.
    fn rectangle(self, p: Vec3) -> Option<SphericalRectangle> {
        match self {
            Piece::Rectangle(r, _) => SphericalRectangle::seen(p, r, spherical_triangle::MIN_SOLID_ANGLE),
            Piece::Triangle(_) => None,
        }
    }

    /// A direction uniform over its solid angle `omega` from `p`; a
    /// rectangle seen from there already, as `seen`.
    fn sample(self, p: Vec3, omega: f32, seen: Option<SphericalRectangle>, u: Vec2) -> Option<Vec3> {
        match self {
            Piece::Rectangle(..) => Some(seen.or_else(|| self.rectangle(p))?.sample(u)),
            Piece::Triangle(t) => Some(SphericalTriangle::new(p, t, omega)?.sample(u)),
        }
    }

    fn crosses(self, p: Vec3, dir: Vec3) -> bool {
        match self {
            Piece::Rectangle(_, triangles) => triangles.iter().any(|t| crosses(p, dir, t)),
            Piece::Triangle(t) => crosses(p, dir, t),
        }
    }
}

/// The scene's portals.
#[derive(Clone, Debug, Default)]
pub struct Portals {
    list: Vec<Portal>,
    /// Every piece as (its portal, its triangle there; 0 for a
    /// rectangle), portal by portal.
    pieces: Vec<(u32, u32)>,
    /// Which list this is, for the views kept per thread: a number no
    /// other list made in this process has (an address could be reused by
    /// the next scene's list).
    id: u64,
}

/// Pieces whose solid angles a `View` keeps; those after them (a disk
/// portal's 64 triangles) are computed each time they are asked for.
const KEPT: usize = 16;
/// Rectangles a `View` keeps as seen, for the light sample drawn there
/// (seeing one takes its four inner angles' arc cosines).
const KEPT_RECTANGLES: usize = 4;

/// What the portals look like from one point: their total solid angle,
/// the first `KEPT` pieces' own (0 for one the point does not face or
/// that is under `MIN_SOLID_ANGLE`), and the first rectangles as seen.
#[derive(Clone, Copy)]
struct View {
    /// The portal list and the point (its bits) it was made for.
    key: (u64, [u32; 3]),
    total: f32,
    omega: [f32; KEPT],
    rectangles: [Option<SphericalRectangle>; KEPT_RECTANGLES],
}

impl Portals {
    pub fn new(list: Vec<Portal>) -> Self {
        static LISTS: AtomicU64 = AtomicU64::new(1);
        let pieces = list.iter().enumerate().flat_map(|(j, portal)| (0..if portal.rectangle.is_some() { 1 } else { portal.triangles.len() }).map(move |k| (j as u32, k as u32))).collect();
        Portals { list, pieces, id: LISTS.fetch_add(1, Ordering::Relaxed) }
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Every portal's pieces in order: (the piece's index, its portal's,
    /// the piece, whether `p` faces its portal).
    fn pieces(&self, p: Vec3) -> impl Iterator<Item = (usize, usize, Piece<'_>, bool)> + '_ {
        // A flat list rather than nested iterators: a vertex walks it up to
        // four times (2% of a window room's instructions, callgrind).
        // Whether `p` faces a portal is found once for all its pieces (a
        // disk's 64 triangles), as the nested walk did.
        let mut facing = (u32::MAX, false);
        self.pieces.iter().enumerate().map(move |(i, &(j, k))| {
            let portal = &self.list[j as usize];
            if facing.0 != j {
                facing = (j, portal.faces(p));
            }
            let piece = match &portal.rectangle {
                Some(r) => Piece::Rectangle(r, &portal.triangles),
                None => Piece::Triangle(&portal.triangles[k as usize]),
            };
            (i, j as usize, piece, facing.1)
        })
    }

    /// The solid angle from `p` of piece `i`, from `view` where it keeps
    /// it.
    fn omega(view: &View, i: usize, piece: Piece, faces: bool, p: Vec3) -> f32 {
        match view.omega.get(i) {
            Some(&omega) => omega,
            None if faces => piece.solid_angle(p),
            None => 0.0,
        }
    }

    /// `f` of the portals seen from `p`. A vertex asks up to eight times
    /// (the World's pick probability and its directions' density, for the
    /// light sample and again for the MIS weight of the BSDF sample that
    /// escapes), each time from the same point: the last point's view is
    /// kept per thread. Computed afresh each time, the solid angles had
    /// tripled the time per sample of a room lit through one window. The
    /// view is lent where it is kept (copying it out, 300 bytes
    /// a time, was a tenth of the render's time).
    fn with_view<R>(&self, p: Vec3, f: impl FnOnce(&View) -> R) -> R {
        thread_local! {
            // Key (0, …) is no list's: the first point makes its view.
            static LAST: RefCell<View> = const { RefCell::new(View { key: (0, [0; 3]), total: 0.0, omega: [0.0; KEPT], rectangles: [None; KEPT_RECTANGLES] }) };
        }
        // Keyed by the list too: two scenes may render on one thread.
        let key = (self.id, [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]);
        LAST.with(|last| {
            if last.borrow().key != key {
                // Made where it is kept: moving 300 bytes in was 2% of
                // the render.
                self.see(p, key, &mut last.borrow_mut());
            }
            // `f` may ask again, for the same point: a shared borrow.
            f(&last.borrow())
        })
    }

    /// Makes `view` the portals seen from `p`.
    fn see(&self, p: Vec3, key: (u64, [u32; 3]), view: &mut View) {
        // Entries past the pieces are never read: left as they were.
        view.key = key;
        view.total = 0.0;
        for (i, _, piece, faces) in self.pieces(p) {
            let seen = if faces { piece.rectangle(p) } else { None };
            if let Some(kept) = view.rectangles.get_mut(i) {
                *kept = seen;
            }
            let omega = match (faces, seen) {
                (false, _) => 0.0,
                (true, Some(r)) => r.solid_angle,
                (true, None) => piece.solid_angle(p),
            };
            if let Some(kept) = view.omega.get_mut(i) {
                *kept = omega;
            }
            view.total += omega;
        }
    }

    /// The total solid angle (sr) of the portal pieces `p` faces; 0
    /// where it faces none (light sampling of the World then goes on as
    /// without portals).
    ///
    /// Out of line, as `sample` and `pdf` are: where the profile-guided
    /// build (tests/pgo-build) chose how to inline them, the window room's
    /// render took 5.5% more instructions after a change to code it never
    /// runs (08c5e21); out of line, 2.6% fewer than then.
    #[inline(never)]
    pub fn solid_angle(&self, p: Vec3) -> f32 {
        self.with_view(p, |view| view.total)
    }

    /// A direction from `p` uniform over the portals' solid angle and its
    /// density (per steradian), from `u` in [0, 1)²; None where `p` faces
    /// no portal.
    #[inline(never)]
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        self.with_view(p, |view| {
            let (dir, chosen) = self.direction(view, p, u)?;
            // The portal drawn from holds the direction; only the others
            // need the ray test (with one portal, none does).
            let pdf = (1 + self.through(view, p, dir, Some(chosen))) as f32 / view.total;
            (pdf > 0.0 && pdf.is_finite()).then_some((dir, pdf))
        })
    }

    /// `sample`'s direction and the index of the portal it goes through,
    /// from the view at `p`.
    fn direction(&self, view: &View, p: Vec3, u: Vec2) -> Option<(Vec3, usize)> {
        if !(view.total > 0.0 && view.total.is_finite()) {
            return None;
        }
        // The piece whose share of the total holds u.x, and u.x rescaled
        // within that share; rounding past the last one takes the last.
        let target = u.x * view.total;
        let mut below = 0.0f32;
        let mut chosen = None;
        for (i, j, piece, faces) in self.pieces(p) {
            let omega = Self::omega(view, i, piece, faces, p);
            if omega > 0.0 {
                chosen = Some((i, j, piece, omega, below));
                if target < below + omega {
                    break;
                }
                below += omega;
            }
        }
        let (i, j, piece, omega, below) = chosen?;
        let ux = ((target - below) / omega).clamp(0.0, 1.0 - f32::EPSILON);
        let dir = piece.sample(p, omega, view.rectangles.get(i).copied().flatten(), Vec2::new(ux, u.y))?;
        Some((dir, j))
    }

    /// How many portals seen from `p` the ray along `dir` passes through,
    /// but for portal `except`: each once, though it may cross two of a
    /// portal's triangles where they share an edge.
    fn through(&self, view: &View, p: Vec3, dir: Vec3, except: Option<usize>) -> usize {
        let mut counted = None;
        let mut count = 0;
        for (i, j, piece, faces) in self.pieces(p) {
            if Some(j) != except && Some(j) != counted && faces && Self::omega(view, i, piece, faces, p) > 0.0 && piece.crosses(p, dir) {
                counted = Some(j);
                count += 1;
            }
        }
        count
    }

    /// The density (per steradian) with which `sample` draws unit
    /// direction `dir` from `p`.
    #[inline(never)]
    pub fn pdf(&self, p: Vec3, dir: Vec3) -> f32 {
        self.with_view(p, |view| {
            if !(view.total > 0.0) {
                return 0.0;
            }
            self.through(view, p, dir, None) as f32 / view.total
        })
    }
}

/// Whether the ray from `p` along `dir` passes through triangle `t`
/// (either face, ahead of `p`).
fn crosses(p: Vec3, dir: Vec3, t: &[Vec3; 3]) -> bool {
    accel::intersect(&RtTriangle::from(t), p, dir, 0.0, f32::INFINITY).is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A 1 × 2 m window in the plane z = 0, its light going to −z.
    fn window(centre: Vec3) -> Portal {
        let (hx, hy) = (0.5, 1.0);
        let c = |x: f32, y: f32| centre + Vec3::new(x, y, 0.0);
        let q = [c(-hx, -hy), c(hx, -hy), c(hx, hy), c(-hx, hy)];
        Portal { triangles: vec![[q[0], q[1], q[2]], [q[0], q[2], q[3]]], rectangle: Some(Rectangle::new(q[0], q[1] - q[0], q[3] - q[0])), inward: Vec3::NEG_Z, origin: centre }
    }

    /// The solid angle of a w × h rectangle seen from distance d on its
    /// axis: 4·atan(wh / (2d·√(4d² + w² + h²))).
    fn on_axis(w: f32, h: f32, d: f32) -> f32 {
        4.0 * (w * h / (2.0 * d * (4.0 * d * d + w * w + h * h).sqrt())).atan()
    }

    #[test]
    fn directions_go_through_the_window_with_one_over_its_solid_angle() {
        // As a rectangle, and as two triangles (a sheared one's outline).
        for whole in [true, false] {
            let mut w = window(Vec3::ZERO);
            if !whole {
                w.rectangle = None;
            }
            through_the_window(Portals::new(vec![w]));
        }
    }

    fn through_the_window(portals: Portals) {
        let p = Vec3::new(0.0, 0.0, -0.7);
        let omega = on_axis(1.0, 2.0, 0.7);
        assert!((portals.solid_angle(p) - omega).abs() < 1e-4 * omega, "{} {omega}", portals.solid_angle(p));
        let mut rng = Rng::new(3, 0);
        for _ in 0..2000 {
            let (dir, pdf) = portals.sample(p, rng.next_2d()).expect("a direction through the window");
            // Where the ray meets z = 0 lies in the window.
            let hit = p + dir * (-p.z / dir.z);
            assert!(hit.x.abs() <= 0.5 + 1e-4 && hit.y.abs() <= 1.0 + 1e-4, "{hit}");
            assert!((pdf - 1.0 / omega).abs() < 1e-4 / omega);
        }
        // Away from the window the density is 0.
        assert_eq!(portals.pdf(p, Vec3::new(0.0, 0.99, 0.1).normalize()), 0.0);
    }

    /// Two windows side by side: picked by solid angle, each gets its
    /// share of the directions, and E[1/pdf] over them is their total
    /// solid angle.
    #[test]
    fn two_windows_share_the_samples_by_solid_angle() {
        let (near, far) = (window(Vec3::new(-1.0, 0.0, 0.0)), window(Vec3::new(3.0, 0.0, 0.0)));
        let portals = Portals::new(vec![near.clone(), far.clone()]);
        let p = Vec3::new(-1.0, 0.0, -1.0);
        let (a, b) = (Portals::new(vec![near]).solid_angle(p), Portals::new(vec![far]).solid_angle(p));
        let n = 20000;
        let mut rng = Rng::new(5, 0);
        let (mut to_far, mut inverse) = (0, 0.0f64);
        for _ in 0..n {
            let (dir, pdf) = portals.sample(p, rng.next_2d()).unwrap();
            to_far += ((p + dir * (-p.z / dir.z)).x > 1.0) as usize;
            inverse += 1.0 / pdf as f64;
        }
        let share = to_far as f32 / n as f32;
        assert!((share - b / (a + b)).abs() < 0.01, "{share} {}", b / (a + b));
        assert!((inverse / n as f64 - (a + b) as f64).abs() < 1e-3 * (a + b) as f64);
    }

    /// A window seen through another (the far one as two triangles): where
    /// they overlap in view the density counts both, so
    /// E[1{through a window} / pdf] is each one's own solid angle.
    #[test]
    fn windows_overlapping_in_view_count_once_each() {
        let near = window(Vec3::ZERO);
        let mut far = window(Vec3::new(0.4, 0.5, 1.0));
        far.rectangle = None;
        let p = Vec3::new(0.1, 0.2, -0.8);
        let (a, b) = (Portals::new(vec![near.clone()]).solid_angle(p), Portals::new(vec![far.clone()]).solid_angle(p));
        let portals = Portals::new(vec![near.clone(), far.clone()]);
        let (n, mut rng) = (200_000, Rng::new(9, 0));
        let (mut through_near, mut through_far) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (dir, pdf) = portals.sample(p, rng.next_2d()).unwrap();
            assert_eq!(pdf, portals.pdf(p, dir), "{dir}");
            let within = |w: &Portal| {
                let hit = p + dir * ((w.origin.z - p.z) / dir.z);
                (hit.x - w.origin.x).abs() <= 0.5 && (hit.y - w.origin.y).abs() <= 1.0
            };
            through_near += within(&near) as u8 as f64 / pdf as f64;
            through_far += within(&far) as u8 as f64 / pdf as f64;
        }
        let (near_mean, far_mean) = (through_near / n as f64, through_far / n as f64);
        assert!((near_mean - a as f64).abs() < 0.01 * a as f64, "{near_mean} vs {a}");
        assert!((far_mean - b as f64).abs() < 0.01 * b as f64, "{far_mean} vs {b}");
    }

    #[test]
    fn behind_in_or_far_from_the_window_there_is_nothing_to_sample() {
        let portals = Portals::new(vec![window(Vec3::ZERO)]);
        for p in [Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.2, 0.1, 0.0), Vec3::new(0.0, 0.0, -1e5), Vec3::splat(f32::NAN)] {
            assert_eq!(portals.solid_angle(p), 0.0, "{p}");
            assert!(portals.sample(p, Vec2::new(0.3, 0.6)).is_none(), "{p}");
            assert_eq!(portals.pdf(p, Vec3::Z), 0.0, "{p}");
        }
    }
}
