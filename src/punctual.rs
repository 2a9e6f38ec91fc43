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
//! These are Cycles' shapes. A sized light is also seen, as in Cycles with
//! Blender's default ray visibility: BSDF rays (a mirror, glass, a rough
//! surface's bounce) reach it and are MIS-weighted against its light
//! samples; camera rays pass through it unless the request says the camera
//! sees it (Blender hides lights from the camera by default); it casts no
//! shadow. With r = 0 only light sampling
//! reaches a light, and its samples take the full weight.

use crate::sampling::{cone_pdf, cone_sample_in, cone_sample_opposite, cone_sample_within, disk_point, one_minus_cos, Frame};
use glam::Vec2;
use crate::Vec3;
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
    /// Camera rays see a sized light too (Blender's Object › Visibility ›
    /// Camera, off for lights by default).
    pub camera_sees: bool,
    /// Blender's Cast Shadow off: its light samples trace no shadow ray.
    pub shadowless: bool,
}

/// What every light sample of a sized sun, and every light subpath it
/// starts, shares, formed once a render (`Lights`) instead of at each:
/// two sines and a frame.
#[derive(Clone, Copy, Debug)]
pub struct SunDisk {
    /// About the direction toward the sun.
    frame: Frame,
    /// 1 − cos of the sun's angular radius.
    one_minus_cos: f32,
    /// L/pdf_ω over the irradiance E: E/(π sin²θ) · 2π(1 − cosθ) / E.
    scale: f32,
    /// π sin²θ, which the irradiance is divided by for the disk's radiance.
    pi_sin2: f32,
}

impl SunDisk {
    /// A direction the sun's light travels along, uniform within the cone
    /// of its disk: `cone_sample_within(travel, …)`'s, to the bit.
    pub fn leaving(&self, u: Vec2) -> Vec3 {
        cone_sample_opposite(&self.frame, self.one_minus_cos, u)
    }

    /// The solid-angle density of `leaving` and of a light sample.
    pub fn pdf(&self) -> f32 {
        cone_pdf(self.one_minus_cos)
    }

    /// The disk's radiance E/(π sin²θ), E the sun's irradiance
    /// (`PunctualLight::sun_radiance`).
    pub fn radiance(&self, irradiance: Vec3) -> Vec3 {
        irradiance / self.pi_sin2
    }
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
    /// Solid-angle density of `wi` (infinite for a punctual light).
    pub pdf: f32,
}

/// Where a light subpath leaves a point or spot light (`PunctualLight::start`).
pub struct Start {
    pub origin: Vec3,
    /// Unit direction the subpath leaves along.
    pub dir: Vec3,
    /// Radiant intensity along `dir`, W·sr⁻¹ (a spot's cone applied).
    pub intensity: Vec3,
    /// Solid-angle density of `dir` (`start_pdf`).
    pub pdf_dir: f32,
}

/// A sized light seen along a ray.
pub struct Seen {
    /// Radiance towards the ray's origin, W·sr⁻¹·m⁻².
    pub radiance: Vec3,
    /// Solid-angle density with which `incident` draws this direction
    /// from the ray's origin.
    pub pdf: f32,
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
            return Some(match self.sun_disk() {
                Some(disk) => self.sun_incident(&disk, u),
                None => Incident { wi: -self.direction, distance: f32::INFINITY, irradiance: self.intensity, pdf: f32::INFINITY },
            });
        }
        let to_light = self.position - p;
        let d2 = to_light.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            return None;
        }
        let d = d2.sqrt();
        let r = self.size;
        let (wi, distance, irradiance, pdf) = if r > 0.0 && self.sphere && d > r {
            // The cone the sphere subtends, sin θmax = r/d; the sampled
            // direction's distance to the sphere by the law of cosines.
            let (wi, one_minus_cos) = cone_sample(to_light / d, (r / d).asin(), u);
            let cos = wi.dot(to_light / d);
            let t = d * cos - (r * r - d2 * (1.0 - cos * cos)).max(0.0).sqrt();
            // L/pdf_ω with L = I/(πr²).
            (wi, t, self.intensity * (2.0 * one_minus_cos / (r * r)), cone_pdf(one_minus_cos))
        } else if r > 0.0 {
            // A disk facing p (also inside a sphere light, where no cone
            // is subtended).
            let n = -to_light / d;
            let q = disk_point(self.position, n, r, u);
            let to_q = q - p;
            let t2 = to_q.length_squared();
            let t = t2.sqrt();
            let wi = to_q / t;
            // L·cosθ'·πr²/t² with L = I/(πr²).
            let cos_light = n.dot(-wi).max(0.0);
            (wi, t, self.intensity * (cos_light / t2), disk_pdf(t2, r, cos_light))
        } else {
            (to_light / d, d, self.intensity / d2, f32::INFINITY)
        };
        let cone = self.cone(wi);
        (cone > 0.0 && distance > 0.0 && irradiance.is_finite()).then(|| Incident { wi, distance, irradiance: irradiance * cone, pdf })
    }

    /// A sized sun's `SunDisk`; None for other lights and a sun of size 0.
    pub fn sun_disk(&self) -> Option<SunDisk> {
        (matches!(self.kind, PunctualKind::Sun) && self.size > 0.0).then(|| {
            let one_minus_cos = one_minus_cos(self.size);
            let s = self.size.sin();
            SunDisk { frame: Frame::from_normal(-self.direction), one_minus_cos, scale: 2.0 * one_minus_cos / (s * s), pi_sin2: PI * s * s }
        })
    }

    /// `incident` for a sized sun whose `SunDisk` is `disk`.
    pub fn sun_incident(&self, disk: &SunDisk, u: Vec2) -> Incident {
        let wi = cone_sample_in(&disk.frame, disk.one_minus_cos, u);
        Incident { wi, distance: f32::INFINITY, irradiance: self.intensity * disk.scale, pdf: disk.pdf() }
    }

    /// The start of a light subpath (light_paths.rs): a direction
    /// uniform over the sphere (a point light) or in the spot's cone, and
    /// for a sized light an origin uniform on the disk of its radius
    /// through its centre, square to that direction. Each ray carries the
    /// radiance I/(πr²) of a sphere of radius r: the rays that reach a
    /// point p are those that pass within r of the centre, one per unit
    /// of the disk, from the cone the sphere subtends at p, with density
    /// pdf_dir·|cos_p|/(πr²) per steradian and unit area there (pdf_dir·
    /// |cos_p|/d² per unit area from a light of radius 0). None for a sun.
    pub fn start(&self, u_point: Vec2, u_dir: Vec2) -> Option<Start> {
        let dir = match self.kind {
            PunctualKind::Point => crate::sampling::uniform_sphere(u_dir),
            PunctualKind::Spot { cos_outer, .. } => cone_sample_within(self.direction, 1.0 - cos_outer, u_dir),
            PunctualKind::Sun => return None,
        };
        Some(self.start_along(u_point, dir, self.start_pdf(-dir)))
    }

    /// A start leaving along unit `dir`, drawn with density `pdf_dir`
    /// (`start`'s, or the caustic guide's cone toward the glass: a spot's
    /// light outside its cone is then zero). Not for a sun.
    pub fn start_along(&self, u_point: Vec2, dir: Vec3, pdf_dir: f32) -> Start {
        let origin = if self.size > 0.0 { disk_point(self.position, dir, self.size, u_point) } else { self.position };
        Start { origin, dir, intensity: self.intensity * self.cone(-dir), pdf_dir }
    }

    /// What `start`'s density toward a point at squared distance `d2` is
    /// divided by: per unit area there and steradian toward a sized light,
    /// pdf_dir·|cos|/(πr²); per unit area from one of radius 0,
    /// pdf_dir·|cos|/d². Light subpaths and camera paths both weigh by it.
    pub fn start_spread(&self, d2: f32) -> f32 {
        if self.size > 0.0 { PI * self.size * self.size } else { d2 }
    }

    /// The density with which `start` leaves along −`toward_light` (a
    /// unit direction from a point toward the light); 0 outside a spot's
    /// cone. A sun's subpaths (`Lights::sample_start`) leave uniformly
    /// within its cone, or, without a size, along its light: 1 there, the
    /// only direction asked of it.
    pub fn start_pdf(&self, toward_light: Vec3) -> f32 {
        match self.kind {
            PunctualKind::Point => 1.0 / (4.0 * PI),
            PunctualKind::Spot { cos_outer, .. } if self.cone(toward_light) > 0.0 => cone_pdf(1.0 - cos_outer),
            PunctualKind::Sun if self.size > 0.0 => {
                let cone = one_minus_cos(self.size);
                if self.within_sun(toward_light, cone) { cone_pdf(cone) } else { 0.0 }
            }
            PunctualKind::Sun => 1.0,
            _ => 0.0,
        }
    }

    /// Whether unit `toward_light` lies within a sized sun's disk, whose
    /// 1 − cos of its angular radius is `cone`: 1 − cos of the angle to
    /// the sun's centre is |toward_light + direction|²/2, which keeps a
    /// small sun's.
    fn within_sun(&self, toward_light: Vec3, cone: f32) -> bool {
        (toward_light + self.direction).length_squared() * 0.5 <= cone
    }

    /// A sized sun's radiance, E/(π sin²θ) for its irradiance E and
    /// angular radius θ.
    pub fn sun_radiance(&self) -> Vec3 {
        let s = self.size.sin();
        self.intensity / (PI * s * s)
    }

    /// The spot's attenuation for light leaving towards −`wi` (1 for
    /// other lights).
    fn cone(&self, wi: Vec3) -> f32 {
        match self.kind {
            PunctualKind::Spot { cos_outer, smooth } => {
                let c = self.direction.dot(-wi);
                if smooth > 0.0 { smoothstep((c - cos_outer) / smooth) } else if c > cos_outer { 1.0 } else { 0.0 }
            }
            _ => 1.0,
        }
    }

    /// The sized light as a ray from `o` along unit `d` sees it between
    /// `t_min` (a camera ray's Clip Start) and `t_max` (infinite: the ray
    /// left the scene, the only way to see the sun), with the density
    /// `incident` gives that direction from `o`. None for a punctual
    /// light, which no ray can hit.
    pub fn seen(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<Seen> {
        if !(self.size > 0.0) {
            return None;
        }
        if let PunctualKind::Sun = self.kind {
            // Every ray that leaves the scene asks; as 1 − cosθ ≤ θ²/2,
            // those off the disk by more than twice that are turned away
            // before the sine (0.9% of a sunlit render's time).
            if t_max < f32::INFINITY || (d + self.direction).length_squared() * 0.5 > self.size * self.size {
                return None;
            }
            let cone = one_minus_cos(self.size);
            if !self.within_sun(d, cone) {
                return None;
            }
            return Some(Seen { radiance: self.sun_radiance(), pdf: cone_pdf(cone) });
        }
        let to_light = self.position - o;
        let d2 = to_light.length_squared();
        let r = self.size;
        if !(d2 > 0.0 && d2.is_finite()) {
            return None;
        }
        let pdf = if self.sphere && d2 > r * r {
            // The nearer root of |o + t·d − c|² = r², from the squared
            // distance of the centre to the ray (stable for a small sphere).
            let along = to_light.dot(d);
            let miss2 = (to_light - along * d).length_squared();
            if along <= 0.0 || miss2 > r * r {
                return None;
            }
            let t = along - (r * r - miss2).sqrt();
            if !(t > 0.0 && t >= t_min && t < t_max) {
                return None;
            }
            cone_pdf(one_minus_cos((r / d2.sqrt()).min(1.0).asin()))
        } else {
            // The disk through the centre facing o.
            let dist = d2.sqrt();
            let n = -to_light / dist;
            let cos_light = -n.dot(d);
            if !(cos_light > 0.0) {
                return None;
            }
            let t = dist / cos_light;
            if !(t >= t_min && t < t_max) || (o + t * d - self.position).length_squared() > r * r {
                return None;
            }
            disk_pdf(t * t, r, cos_light)
        };
        let cone = self.cone(d);
        (cone > 0.0).then(|| Seen { radiance: self.intensity * (cone / (PI * r * r)), pdf })
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

/// Solid-angle density of a point drawn uniformly on a disk of radius r,
/// seen at distance² `t2` and cosine `cos_light`.
fn disk_pdf(t2: f32, r: f32, cos_light: f32) -> f32 {
    if cos_light > 0.0 { t2 / (PI * r * r * cos_light) } else { f32::INFINITY }
}

/// A direction uniformly in the cone of half-angle θmax about `axis`, and
/// the cone's 1 − cosθmax.
fn cone_sample(axis: Vec3, theta_max: f32, u: Vec2) -> (Vec3, f32) {
    let one_minus_cos = one_minus_cos(theta_max);
    (cone_sample_within(axis, one_minus_cos, u), one_minus_cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_square_cone_and_sun() {
        let point = PunctualLight { name: "p".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, 2.0, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(8.0), size: 0.0, sphere: false, camera_sees: false, shadowless: false };
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
        let disk = PunctualLight { name: "d".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, h, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(i), size: r, sphere: false, camera_sees: false, shadowless: false };
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
        // Radius 0 is the punctual light, whatever u, and no ray sees it.
        assert!(PunctualLight { size: 0.0, ..disk.clone() }.seen(Vec3::ZERO, Vec3::Y, 0.0, f32::INFINITY).is_none());
        let point = PunctualLight { size: 0.0, ..disk };
        assert_eq!(point.incident(Vec3::ZERO, Vec2::new(0.3, 0.9)).unwrap().irradiance, Vec3::splat(i / (h * h)));
    }

    /// What a ray sees of a sized light agrees with what light sampling
    /// draws: every sampled direction sees the light, with the sample's
    /// density and L/pdf = the sample's estimate; and the density `seen`
    /// reports integrates to 1 over the directions that see the light
    /// (so MIS weights of the two strategies sum to 1).
    #[test]
    fn rays_see_sized_lights_as_light_sampling_draws_them() {
        let spot = PunctualLight::spot(1.2, 0.6);
        let base = PunctualLight { name: "l".into(), kind: PunctualKind::Point, position: Vec3::new(0.3, 1.5, -0.2), direction: Vec3::new(0.2, -1.0, 0.1).normalize(), intensity: Vec3::new(8.0, 4.0, 2.0), size: 0.4, sphere: false, camera_sees: false, shadowless: false };
        let lights = [
            base.clone(),
            PunctualLight { sphere: true, ..base.clone() },
            PunctualLight { kind: spot, ..base.clone() },
            PunctualLight { kind: PunctualKind::Sun, size: 0.3, ..base.clone() },
            PunctualLight { sphere: true, size: 1e-3, position: Vec3::new(0.0, 50.0, 0.0), ..base.clone() },
        ];
        let mut rng = crate::rng::Rng::new(5, 1);
        for (k, light) in lights.iter().enumerate() {
            for o in [Vec3::ZERO, Vec3::new(1.0, -0.5, 2.0)] {
                for _ in 0..2000 {
                    let Some(inc) = light.incident(o, rng.next_2d()) else { continue };
                    let seen = light.seen(o, inc.wi, 0.0, f32::INFINITY).unwrap_or_else(|| panic!("light {k}: a sampled direction misses"));
                    assert!((seen.pdf / inc.pdf - 1.0).abs() < 2e-3, "light {k}: pdf {} vs {}", seen.pdf, inc.pdf);
                    let estimate = seen.radiance / seen.pdf;
                    assert!((estimate - inc.irradiance).abs().max_element() <= 2e-3 * inc.irradiance.max_element(), "light {k}: {estimate} vs {}", inc.irradiance);
                    // Something in front of the light hides it, except the
                    // sun, which only a ray leaving the scene sees.
                    assert!(light.seen(o, inc.wi, 0.0, 0.5 * inc.distance.min(1.0)).is_none());
                }
                // ∫ pdf dω by directions drawn uniformly in a cone wider
                // than the light (half again its angular radius).
                let (axis, dist) = match light.kind {
                    PunctualKind::Sun => (-light.direction, 1.0),
                    _ => ((light.position - o).normalize(), (light.position - o).length()),
                };
                let half_angle = 1.5 * if let PunctualKind::Sun = light.kind { light.size } else { (light.size / dist).asin() };
                let n = 200_000;
                let mut sum = 0.0f64;
                for _ in 0..n {
                    let (d, one_minus_cos) = cone_sample(axis, half_angle, rng.next_2d());
                    if let Some(seen) = light.seen(o, d, 0.0, f32::INFINITY).filter(|s| s.radiance != Vec3::ZERO) {
                        sum += (seen.pdf * 2.0 * PI * one_minus_cos) as f64;
                    }
                }
                let integral = sum / n as f64;
                // A spot's cone cuts the disk for some origins: then less.
                let spotlit = matches!(light.kind, PunctualKind::Spot { .. });
                assert!((integral - 1.0).abs() < 0.01 || (spotlit && integral < 1.01), "light {k} from {o}: ∫pdf dω = {integral}");
            }
        }
    }
}
