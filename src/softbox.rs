//! Light samples of a rectangular lamp with a Spread (`material::Spread`)
//! drawn from the part of it whose light can pass the softbox grid toward
//! the shading point, as Cycles draws them: light leaving at more than h
//! (half the spread) from the normal is stopped, so a point at height d in
//! front of the lamp gets light only from within d·tan h of its foot on
//! the lamp's plane. The square of that half-width around the foot,
//! clipped to the lamp, holds all of it. Drawn over the whole lamp, a 30°
//! grid 1.5 m above a floor left 80% of a 2 × 1.2 m lamp's samples dark.
//!
//! The clipped rectangle is drawn uniformly over the solid angle it covers
//! (spherical_rectangle.rs), or by area where it covers too little for
//! that to be precise; its density is the lamp's pick probability over
//! that solid angle or area, and `Lights::pdf_emitter` computes the same
//! clip from the same point for MIS.

use crate::spherical_rectangle::{Rectangle, SphericalRectangle};
use crate::spherical_triangle::MIN_SOLID_ANGLE;
use crate::Vec3;
use glam::Vec2;

/// A rectangular lamp with a Spread: the corner where the parameters of
/// its quad (parallelogram.rs) are 0, its unit edges and their lengths,
/// and the unit normal of its emitting face.
#[derive(Clone, Copy, Debug)]
pub struct Softbox {
    corner: Vec3,
    x: Vec3,
    y: Vec3,
    normal: Vec3,
    lx: f32,
    ly: f32,
    tan_half: f32,
    /// The whole lamp's area (m²).
    pub area: f32,
}

/// The part of a softbox a point sees through its grid: [s0, s1] × [t0, t1]
/// metres along its edges from the corner.
#[derive(Clone, Copy, Debug)]
pub struct Clip {
    s0: f32,
    s1: f32,
    t0: f32,
    t1: f32,
    /// The clip as the point sees it, where it covers enough solid angle
    /// to be drawn by it.
    pub view: Option<SphericalRectangle>,
    /// Its area (m²).
    pub area: f32,
}

impl Softbox {
    /// The lamp with corner `corner`, edges `e1` and `e2` and emitting
    /// normal `normal`, whose spread is 2·atan(`tan_half`); None where the
    /// edges are not perpendicular (a lamp sheared by its object's
    /// transform, whose light is then drawn over the whole lamp).
    pub fn new(corner: Vec3, e1: Vec3, e2: Vec3, normal: Vec3, tan_half: f32) -> Option<Self> {
        let (lx, ly) = (e1.length(), e2.length());
        if !(lx > 0.0 && ly > 0.0 && tan_half > 0.0 && tan_half.is_finite()) {
            return None;
        }
        let (x, y) = (e1 / lx, e2 / ly);
        (x.dot(y).abs() < 1e-4 && normal.is_finite()).then_some(Softbox { corner, x, y, normal, lx, ly, tan_half, area: lx * ly })
    }

    /// The part of the lamp whose light can reach `p`; None where none can
    /// (`p` behind the lamp or beside its cone).
    #[inline]
    pub fn seen_from(&self, p: Vec3) -> Option<Clip> {
        let v = p - self.corner;
        let height = v.dot(self.normal);
        if !(height > 0.0) {
            return None;
        }
        let reach = height * self.tan_half;
        let (s, t) = (v.dot(self.x), v.dot(self.y));
        let (s0, s1) = ((s - reach).max(0.0), (s + reach).min(self.lx));
        let (t0, t1) = ((t - reach).max(0.0), (t + reach).min(self.ly));
        if !(s0 < s1 && t0 < t1) {
            return None;
        }
        let (w, h) = (s1 - s0, t1 - t0);
        let rectangle = Rectangle::framed(self.corner + self.x * s0 + self.y * t0, self.x, self.y, w, h);
        Some(Clip { s0, s1, t0, t1, view: SphericalRectangle::seen(p, &rectangle, MIN_SOLID_ANGLE), area: w * h })
    }

    /// Where `point` (on the lamp) lies along its edges, in metres.
    fn along(&self, point: Vec3) -> Vec2 {
        let v = point - self.corner;
        Vec2::new(v.dot(self.x), v.dot(self.y))
    }
}

impl Clip {
    /// A point of the clip seen from `p`, from `u` in [0, 1)²: as the
    /// fractions of the lamp's edges that are its quad's parameters. None
    /// where a direction drawn toward it does not meet its plane (a clip
    /// seen edge-on, which covers too little solid angle to be drawn so).
    #[inline]
    pub fn sample(&self, softbox: &Softbox, p: Vec3, u: Vec2) -> Option<Vec2> {
        let at = match &self.view {
            Some(view) => {
                let dir = view.sample(u);
                let toward = -dir.dot(softbox.normal);
                let height = (p - softbox.corner).dot(softbox.normal);
                let distance = height / toward;
                if !(distance > 0.0 && distance < f32::INFINITY) {
                    return None;
                }
                let at = softbox.along(p + dir * distance);
                // Rounding puts a point drawn at the rim a hair outside.
                Vec2::new(at.x.clamp(self.s0, self.s1), at.y.clamp(self.t0, self.t1))
            }
            None => Vec2::new(self.s0 + u.x * (self.s1 - self.s0), self.t0 + u.y * (self.t1 - self.t0)),
        };
        Some(at / Vec2::new(softbox.lx, softbox.ly))
    }

    /// Whether `point` on the lamp lies in the clip: `sample` draws no
    /// point outside it, so a ray that reaches one there has no light
    /// sample's density (and no light: it is beyond the grid's cone).
    #[inline]
    pub fn holds(&self, softbox: &Softbox, point: Vec3) -> bool {
        let at = softbox.along(point);
        at.x >= self.s0 && at.x <= self.s1 && at.y >= self.t0 && at.y <= self.t1
    }
}

/// A disk or ellipse lamp with a Spread, a fan of `segments` triangles
/// about its centre whose rim points lie at (ax·cos φ, ay·sin φ) along its
/// unit axes x and y, φ = 2πi/segments (lamps.rs). Its light reaching a
/// point comes from within a circle of radius d·tan h about the point's
/// foot; where that circle is smaller than the lamp, Cycles draws the
/// samples from it (uniformly by area, those that land beyond the rim
/// lost), and so does Glint; else over the whole lamp.
#[derive(Clone, Copy, Debug)]
pub struct RoundSoftbox {
    centre: Vec3,
    x: Vec3,
    y: Vec3,
    normal: Vec3,
    ax: f32,
    ay: f32,
    tan_half: f32,
    segments: usize,
    /// The fan's area (m²).
    pub area: f32,
}

/// Where a round softbox's light samples come from, seen from a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// The point is behind the lamp: no light reaches it.
    Behind,
    /// The circle of the lamp's plane about `foot` of radius `radius`,
    /// smaller than the lamp.
    Circle { foot: Vec3, radius: f32 },
    /// The whole lamp, as a lamp without a Spread.
    Whole,
}

impl RoundSoftbox {
    /// The lamp with centre `centre` whose first rim point (φ = 0) is
    /// `rim_x` and whose rim point a quarter turn on is `rim_y`; None where
    /// those are not perpendicular (a sheared lamp, drawn as without a
    /// Spread) or the segments do not make quarter turns.
    pub fn new(centre: Vec3, rim_x: Vec3, rim_y: Vec3, normal: Vec3, tan_half: f32, segments: usize, area: f32) -> Option<Self> {
        let (ex, ey) = (rim_x - centre, rim_y - centre);
        let (ax, ay) = (ex.length(), ey.length());
        if !(ax > 0.0 && ay > 0.0 && tan_half > 0.0 && tan_half.is_finite() && area > 0.0 && segments.is_multiple_of(4) && segments > 0) {
            return None;
        }
        let (x, y) = (ex / ax, ey / ay);
        (x.dot(y).abs() < 1e-4 && normal.is_finite()).then_some(RoundSoftbox { centre, x, y, normal, ax, ay, tan_half, segments, area })
    }

    /// Where the light samples for a point at `p` come from.
    #[inline]
    pub fn reach(&self, p: Vec3) -> Reach {
        let v = p - self.centre;
        let height = v.dot(self.normal);
        if !(height > 0.0) {
            return Reach::Behind;
        }
        let radius = height * self.tan_half;
        if std::f32::consts::PI * radius * radius >= self.area {
            return Reach::Whole;
        }
        Reach::Circle { foot: p - self.normal * height, radius }
    }

    /// The triangles of its fan.
    pub fn segments(&self) -> usize {
        self.segments
    }

    /// The fan segment (0 to `segments` − 1) whose angle holds `point` of
    /// the lamp's plane.
    pub fn segment(&self, point: Vec3) -> usize {
        let v = point - self.centre;
        let turn = (v.dot(self.y) / self.ay).atan2(v.dot(self.x) / self.ax).rem_euclid(std::f32::consts::TAU);
        ((turn * (self.segments as f32 / std::f32::consts::TAU)) as usize).min(self.segments - 1)
    }

    /// A point of the circle of radius `radius` about `foot`, uniform by
    /// area, from `u` in [0, 1)².
    pub fn in_circle(&self, foot: Vec3, radius: f32, u: Vec2) -> Vec3 {
        let d = crate::sampling::concentric_disk(u) * radius;
        foot + self.x * d.x + self.y * d.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Spread;
    use crate::rng::Rng;

    /// A 2 × 1.2 m lamp in the plane z = 1.5 facing down, a 30° grid.
    fn lamp() -> (Softbox, Spread) {
        let half = 15f32.to_radians();
        let softbox = Softbox::new(Vec3::new(-1.0, -0.6, 1.5), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 1.2, 0.0), -Vec3::Z, half.tan()).unwrap();
        (softbox, Spread::new(2.0 * half).unwrap())
    }

    /// Every point of the lamp whose light reaches p through the grid lies
    /// in p's clip, and points drawn from the clip land in it and on the
    /// lamp; points behind the lamp or beyond its cone have no clip.
    #[test]
    fn the_clip_holds_all_the_light_that_passes_the_grid() {
        let (softbox, spread) = lamp();
        let mut rng = Rng::new(3, 0);
        for p in [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.9, 0.5, 0.2), Vec3::new(1.3, 0.0, 0.0), Vec3::new(-0.2, 0.1, 1.49), Vec3::new(0.3, -0.2, -20.0)] {
            let clip = softbox.seen_from(p).expect("some light reaches it");
            for _ in 0..20_000 {
                let u = rng.next_2d();
                let point = softbox.corner + softbox.x * (u.x * softbox.lx) + softbox.y * (u.y * softbox.ly);
                let cos_out = (p - point).normalize().dot(softbox.normal);
                if spread.factor(cos_out) > 0.0 {
                    assert!(clip.holds(&softbox, point), "{p}: {point} lit but outside");
                }
                let params = clip.sample(&softbox, p, rng.next_2d()).expect("a point");
                assert!(params.min_element() >= 0.0 && params.max_element() <= 1.0, "{p}: {params}");
                let drawn = softbox.corner + softbox.x * (params.x * softbox.lx) + softbox.y * (params.y * softbox.ly);
                assert!(clip.holds(&softbox, drawn), "{p}: {drawn}");
            }
            assert!(clip.area < softbox.area || p.z < -10.0);
        }
        assert!(softbox.seen_from(Vec3::new(0.0, 0.0, 2.0)).is_none(), "behind");
        assert!(softbox.seen_from(Vec3::new(3.0, 0.0, 0.0)).is_none(), "beyond the cone");
        // A sheared lamp is drawn whole.
        assert!(Softbox::new(Vec3::ZERO, Vec3::X, Vec3::new(0.3, 1.0, 0.0), Vec3::Z, 0.5).is_none());
    }
}
