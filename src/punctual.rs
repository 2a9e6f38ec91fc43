//! Point, spot and sun lights (glTF KHR_lights_punctual), in the units
//! Blender's exporter writes in its COMPAT lighting mode:
//!
//! * point and spot: `intensity` = P/(4π), radiant intensity in W·sr⁻¹ for a
//!   Blender light of power P watts (Cycles' point light of radius 0);
//! * sun: `intensity` = Blender's strength, irradiance in W·m⁻² on a surface
//!   facing it.
//!
//! A spot is a point light cut by a cone, as in Cycles (not renormalised to
//! the cone): with the outer half-angle θo and Blender's blend b (the exporter
//! writes inner = θo(1 − b)), the attenuation is
//! smoothstep((cosθ − cosθo) / ((1 − cosθo)·b)), a hard edge for b = 0.
//!
//! Blender's lights have a size, which the add-on passes in the request
//! (`light_sizes`): a point or spot of radius r and a sun of angle a.
//! * Soft falloff (Blender's default): a disk of radius r always facing the
//!   shading point, of radiance I/(πr²), sampled uniformly by area — the
//!   same intensity I seen head-on, shadows softened, finite light up close.
//! * Soft falloff off: a sphere of radius r and the same radiance (its
//!   power is again 4π·I), sampled uniformly in the cone it subtends.
//! * A sun of angle a: a disk of angular radius a/2 and radiance
//!   E/(π sin²(a/2)), sampled uniformly in its cone.
//!
//! These are Cycles' shapes. As with r = 0, only light sampling reaches
//! them: camera and BSDF rays pass through a lamp (so a mirror does not
//! show it), and its samples take the full weight.

use crate::sampling::{concentric_disk, Frame};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    Point,
    Spot { cos_outer: f32, smooth: f32 },
    Sun,
}

#[derive(Clone, Debug)]
pub struct PunctualLight {
    pub name: String,
    pub kind: PunctualKind,
    pub position: Vec3,
    /// Unit direction the light shines along (its node's −Z).
    pub direction: Vec3,
    /// colour × intensity: W·sr⁻¹ (point, spot) or W·m⁻² (sun).
    pub intensity: Vec3,
    /// Point and spot: radius in metres; sun: angular radius in radians
    /// (half Blender's angle). 0: punctual.
    pub size: f32,
    /// A point or spot with soft falloff off: a sphere, not a facing disk.
    pub sphere: bool,
}

/// Light arriving at a point from a punctual light.
pub struct Incident {
    /// Unit direction from the point towards the light.
    pub wi: Vec3,
    /// Distance to the light (infinite for the sun).
    pub distance: f32,
    /// Irradiance on a surface facing the light, W·m⁻²: I/r² (times the
    /// spot's cone) or the sun's.
    pub irradiance: Vec3,
}

fn smoothstep(x: f32) -> f32 {
    let t = x.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl PunctualLight {
    pub fn spot(outer: f32, inner: f32) -> PunctualKind {
        let outer = outer.clamp(0.0, std::f32::consts::FRAC_PI_2);
        let blend = if outer > 0.0 { ((outer - inner.clamp(0.0, outer)) / outer).clamp(0.0, 1.0) } else { 0.0 };
        let cos_outer = outer.cos();
        PunctualKind::Spot { cos_outer, smooth: (1.0 - cos_outer) * blend }
    }

    /// Light arriving at p from one point of the light, drawn with `u`
    /// (unused when the light is punctual). `irradiance` is the one-sample
    /// estimate: L·cosθ'/(r²·pdf_A), or L/pdf_ω for a cone.
    pub fn incident(&self, p: Vec3, u: Vec2) -> Option<Incident> {
        if let PunctualKind::Sun = self.kind {
            if self.size > 0.0 {
                let (wi, one_minus_cos) = cone_sample(-self.direction, self.size, u);
                // L/pdf_ω = E/(π sin²θ) · 2π(1 − cosθ).
                let s = self.size.sin();
                return Some(Incident { wi, distance: f32::INFINITY, irradiance: self.intensity * (2.0 * one_minus_cos / (s * s)) });
            }
            return Some(Incident { wi: -self.direction, distance: f32::INFINITY, irradiance: self.intensity });
        }
        let to_light = self.position - p;
        let d2 = to_light.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            return None;
        }
        let d = d2.sqrt();
        let r = self.size;
        let (wi, distance, irradiance) = if r > 0.0 && self.sphere && d > r {
            // The cone the sphere subtends, sin θmax = r/d; the sampled
            // direction's distance to the sphere by the law of cosines.
            let (wi, one_minus_cos) = cone_sample(to_light / d, (r / d).asin(), u);
            let cos = wi.dot(to_light / d);
            let t = d * cos - (r * r - d2 * (1.0 - cos * cos)).max(0.0).sqrt();
            // L/pdf_ω with L = I/(πr²).
            (wi, t, self.intensity * (2.0 * one_minus_cos / (r * r)))
        } else if r > 0.0 {
            // A disk facing p (also inside a sphere light, where no cone
            // is subtended).
            let n = -to_light / d;
            let frame = Frame::from_normal(n);
            let q = self.position + frame.to_world((concentric_disk(u) * r).extend(0.0));
            let to_q = q - p;
            let t2 = to_q.length_squared();
            let t = t2.sqrt();
            let wi = to_q / t;
            // L·cosθ'·πr²/t² with L = I/(πr²).
            (wi, t, self.intensity * (n.dot(-wi).max(0.0) / t2))
        } else {
            (to_light / d, d, self.intensity / d2)
        };
        let cone = match self.kind {
            PunctualKind::Spot { cos_outer, smooth } => {
                let c = self.direction.dot(-wi);
                if smooth > 0.0 { smoothstep((c - cos_outer) / smooth) } else if c > cos_outer { 1.0 } else { 0.0 }
            }
            _ => 1.0,
        };
        (cone > 0.0 && distance > 0.0 && irradiance.is_finite()).then(|| Incident { wi, distance, irradiance: irradiance * cone })
    }

    /// Emitted power (luminance-weighted, W), for choosing among lights.
    /// The sun's is its irradiance over a disk of the scene's radius.
    pub fn power(&self, scene_radius: f32) -> f64 {
        let lum = crate::bsdf::luminance(self.intensity) as f64;
        match self.kind {
            PunctualKind::Point => 4.0 * std::f64::consts::PI * lum,
            PunctualKind::Spot { cos_outer, .. } => 2.0 * std::f64::consts::PI * (1.0 - cos_outer as f64) * lum,
            PunctualKind::Sun => std::f64::consts::PI * (scene_radius as f64).powi(2) * lum,
        }
    }
}

/// A direction uniformly in the cone of half-angle θmax about `axis`, and
/// 1 − cosθmax (the cone's solid angle / 2π), formed as 2 sin²(θmax/2)
/// so that a cone of 0.01° is not lost to rounding.
fn cone_sample(axis: Vec3, theta_max: f32, u: Vec2) -> (Vec3, f32) {
    let h = (0.5 * theta_max).sin();
    let one_minus_cos = 2.0 * h * h;
    // 1 − cosθ uniform in [0, 1 − cosθmax].
    let omc = u.x * one_minus_cos;
    let sin_t = (omc * (2.0 - omc)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - omc);
    (Frame::from_normal(axis).to_world(local).normalize(), one_minus_cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_square_cone_and_sun() {
        let point = PunctualLight { name: "p".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, 2.0, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(8.0), size: 0.0, sphere: false };
        let i = point.incident(Vec3::ZERO, Vec2::ZERO).unwrap();
        assert_eq!(i.wi, Vec3::Y);
        assert!((i.irradiance.x - 2.0).abs() < 1e-6 && (i.distance - 2.0).abs() < 1e-6);
        // A 45° spot with blend 0.5: the smoothstep runs over cosθ from
        // cos 45° up by (1 − cos 45°)·0.5, i.e. from 45° in to 31.4°.
        let spot = PunctualLight { kind: PunctualLight::spot(std::f32::consts::FRAC_PI_4, std::f32::consts::FRAC_PI_8), ..point.clone() };
        let at = |deg: f32| spot.incident(Vec3::new(2.0 * deg.to_radians().tan(), 0.0, 0.0), Vec2::ZERO).map_or(0.0, |i| i.irradiance.x * (2.0f32.powi(2) + (2.0 * deg.to_radians().tan()).powi(2)) / 8.0);
        assert!((at(0.0) - 1.0).abs() < 1e-5 && at(46.0) == 0.0);
        assert!((at(31.0) - 1.0).abs() < 1e-5 && at(40.0) > 0.0 && at(40.0) < 1.0);
        let hard = PunctualLight { kind: PunctualLight::spot(0.5, 0.5), ..point.clone() };
        assert!(hard.incident(Vec3::new(0.5, 0.0, 0.0), Vec2::ZERO).is_some() && hard.incident(Vec3::new(1.5, 0.0, 0.0), Vec2::ZERO).is_none());
        let sun = PunctualLight { kind: PunctualKind::Sun, ..point };
        let s = sun.incident(Vec3::new(5.0, -3.0, 1.0), Vec2::ZERO).unwrap();
        assert!(s.wi == Vec3::Y && s.distance.is_infinite() && s.irradiance.x == 8.0);
    }

    /// Irradiance on a surface facing the light, averaged over the light's
    /// samples, against closed forms: a facing disk of radiance I/(πr²) at
    /// distance h gives I/(r² + h²); a sphere of that radiance gives I/d²
    /// outside it, as a point does (Newton's shell theorem, for light); a
    /// sun disk of radiance E/(π sin²θ) gives E.
    #[test]
    fn sized_lights_give_their_closed_form_irradiance() {
        let mut rng = crate::rng::Rng::new(3, 3);
        let mut mean = |light: &PunctualLight, p: Vec3, n: Vec3| {
            let count = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..count {
                if let Some(i) = light.incident(p, rng.next_2d()) {
                    sum += (i.irradiance.x * i.wi.dot(n).max(0.0)) as f64;
                    assert!(i.distance.is_finite() || matches!(light.kind, PunctualKind::Sun));
                }
            }
            sum / count as f64
        };
        let (r, h, i) = (0.5f32, 1.0f32, 8.0f32);
        let disk = PunctualLight { name: "d".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, h, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(i), size: r, sphere: false };
        let e = mean(&disk, Vec3::ZERO, Vec3::Y);
        assert!((e - (i / (r * r + h * h)) as f64).abs() < 2e-3 * e, "disk: {e}");
        let sphere = PunctualLight { sphere: true, ..disk.clone() };
        let e = mean(&sphere, Vec3::ZERO, Vec3::Y);
        assert!((e - (i / (h * h)) as f64).abs() < 2e-3 * e, "sphere: {e}");
        // A tiny sphere far away: the cone's 1 − cosθmax survives rounding.
        let far = PunctualLight { size: 1e-3, position: Vec3::new(0.0, 100.0, 0.0), ..sphere.clone() };
        let e = mean(&far, Vec3::ZERO, Vec3::Y);
        assert!((e - (i / 1e4) as f64).abs() < 1e-3 * e, "far sphere: {e}");
        let sun = PunctualLight { kind: PunctualKind::Sun, size: 0.1, ..disk.clone() };
        let e = mean(&sun, Vec3::ZERO, Vec3::Y);
        assert!((e - i as f64).abs() < 2e-3 * e, "sun: {e}");
        // Radius 0 is the punctual light, whatever u.
        let point = PunctualLight { size: 0.0, ..disk };
        assert_eq!(point.incident(Vec3::ZERO, Vec2::new(0.3, 0.9)).unwrap().irradiance, Vec3::splat(i / (h * h)));
    }
}
