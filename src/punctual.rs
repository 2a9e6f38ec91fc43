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
//! All three are delta lights: only light sampling can reach them, so their
//! samples take the full MIS weight.

use glam::Vec3;

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

    pub fn incident(&self, p: Vec3) -> Option<Incident> {
        if let PunctualKind::Sun = self.kind {
            return Some(Incident { wi: -self.direction, distance: f32::INFINITY, irradiance: self.intensity });
        }
        let to_light = self.position - p;
        let d2 = to_light.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            return None;
        }
        let distance = d2.sqrt();
        let wi = to_light / distance;
        let cone = match self.kind {
            PunctualKind::Spot { cos_outer, smooth } => {
                let c = self.direction.dot(-wi);
                if smooth > 0.0 { smoothstep((c - cos_outer) / smooth) } else if c > cos_outer { 1.0 } else { 0.0 }
            }
            _ => 1.0,
        };
        (cone > 0.0).then(|| Incident { wi, distance, irradiance: self.intensity * (cone / d2) })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_square_cone_and_sun() {
        let point = PunctualLight { name: "p".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, 2.0, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(8.0) };
        let i = point.incident(Vec3::ZERO).unwrap();
        assert_eq!(i.wi, Vec3::Y);
        assert!((i.irradiance.x - 2.0).abs() < 1e-6 && (i.distance - 2.0).abs() < 1e-6);
        // A 45° spot with blend 0.5: the smoothstep runs over cosθ from
        // cos 45° up by (1 − cos 45°)·0.5, i.e. from 45° in to 31.4°.
        let spot = PunctualLight { kind: PunctualLight::spot(std::f32::consts::FRAC_PI_4, std::f32::consts::FRAC_PI_8), ..point.clone() };
        let at = |deg: f32| spot.incident(Vec3::new(2.0 * deg.to_radians().tan(), 0.0, 0.0)).map_or(0.0, |i| i.irradiance.x * (2.0f32.powi(2) + (2.0 * deg.to_radians().tan()).powi(2)) / 8.0);
        assert!((at(0.0) - 1.0).abs() < 1e-5 && at(46.0) == 0.0);
        assert!((at(31.0) - 1.0).abs() < 1e-5 && at(40.0) > 0.0 && at(40.0) < 1.0);
        let hard = PunctualLight { kind: PunctualLight::spot(0.5, 0.5), ..point.clone() };
        assert!(hard.incident(Vec3::new(0.5, 0.0, 0.0)).is_some() && hard.incident(Vec3::new(1.5, 0.0, 0.0)).is_none());
        let sun = PunctualLight { kind: PunctualKind::Sun, ..point };
        let s = sun.incident(Vec3::new(5.0, -3.0, 1.0)).unwrap();
        assert!(s.wi == Vec3::Y && s.distance.is_infinite() && s.irradiance.x == 8.0);
    }
}
