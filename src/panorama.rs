//! Blender's panoramic cameras, mapped as Cycles 4.5 maps them
//! (`kernel/camera/projection.h`; parameters as `blender/camera.cpp` syncs
//! them). A point of the view, (u, v) in [0, 1]² from the bottom-left
//! corner, becomes a direction in the panorama's own frame: x forward, y
//! left, z up (Cycles' convention, in which an equirectangular camera's
//! centre looks down +x, as an environment texture's centre does). glTF
//! cannot carry these cameras; the render request does (`lens.panorama`).
//!
//! Fisheyes and the mirror ball see nothing outside their circle: there
//! `direction` gives None, and, as in Cycles, the pixel's sample is black
//! and opaque.

use glam::Vec2;
use serde::Deserialize;
use std::f32::consts::{FRAC_PI_2, PI};

use crate::Vec3;

/// Blender's Panorama Type, with the settings each one reads. Angles in
/// radians; `lens` and `sensor` in millimetres (their ratio is what counts).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "SCREAMING_SNAKE_CASE", deny_unknown_fields)]
pub enum Panorama {
    /// Latitude and Longitude Min and Max: the view spans longitude Min at
    /// its left edge to Max at its right (longitude grows from forward
    /// toward the right), latitude Min at its bottom to Max at its top.
    Equirectangular { latitude: [f32; 2], longitude: [f32; 2] },
    /// One face of an equiangular cube map: 90° each way, evenly in angle.
    EquiangularCubemapFace {},
    /// The view as reflected by a mirror ball that fills it, seen from far
    /// along its axis.
    Mirrorball {},
    /// The angle from the axis grows in proportion to the distance from
    /// the centre, reaching `fov`/2 on the circle inscribed in the view.
    FisheyeEquidistant { fov: f32 },
    /// r = 2·lens·sin(θ/2) on a sensor of `sensor` (width, height) fitted
    /// to the view as Blender's Sensor Fit says; nothing beyond `fov`/2.
    FisheyeEquisolid { fov: f32, lens: f32, sensor: [f32; 2] },
    /// θ = −(k0 + k1·r + k2·r² + k3·r³ + k4·r⁴), r in mm on the fitted
    /// sensor; nothing beyond `fov`/2.
    FisheyeLensPolynomial { fov: f32, k: [f32; 5], sensor: [f32; 2] },
    /// A cylinder around the camera's up axis: u spans the angle
    /// `u_range` (Min to Max, radians), v the height `v_range` on a
    /// cylinder of `radius`.
    CentralCylindrical { u_range: [f32; 2], v_range: [f32; 2], radius: f32 },
}

/// Largest magnitude of an angle, a lens or a coefficient taken: far beyond
/// anything meaningful, small enough that products stay finite.
const MAX_SETTING: f32 = 1e6;

impl Panorama {
    /// Why these settings cannot be rendered, if they cannot.
    pub fn check(&self) -> Result<(), String> {
        let finite = |name: &str, values: &[f32]| match values.iter().find(|x| !(x.abs() <= MAX_SETTING)) {
            Some(x) => Err(format!("panorama {name} {x} must be finite (at most {MAX_SETTING:e} in size)")),
            None => Ok(()),
        };
        let fov = |fov: f32| match fov > 0.0 && fov <= 2.0 * PI {
            true => Ok(()),
            false => Err(format!("panorama fov {fov} must be in (0, 2π]")),
        };
        let positive = |x: f32| x > 0.0 && x <= MAX_SETTING;
        let size = |name: &str, x: f32, unit: &str| match positive(x) {
            true => Ok(()),
            false => Err(format!("panorama {name} {x} must be in (0, {MAX_SETTING:e}]{unit}")),
        };
        let sensor = |s: [f32; 2]| match s.into_iter().all(positive) {
            true => Ok(()),
            false => Err(format!("panorama sensor {s:?} must be two sizes in (0, {MAX_SETTING:e}] mm")),
        };
        match *self {
            Panorama::Equirectangular { latitude, longitude } => finite("latitude", &latitude).and(finite("longitude", &longitude)),
            Panorama::EquiangularCubemapFace {} | Panorama::Mirrorball {} => Ok(()),
            Panorama::FisheyeEquidistant { fov: f } => fov(f),
            Panorama::FisheyeEquisolid { fov: f, lens, sensor: s } => fov(f).and(sensor(s)).and(size("lens", lens, " mm")),
            Panorama::FisheyeLensPolynomial { fov: f, k, sensor: s } => fov(f).and(sensor(s)).and(finite("coefficient", &k)),
            Panorama::CentralCylindrical { u_range, v_range, radius } => finite("u range", &u_range).and(finite("v range", &v_range)).and(size("radius", radius, "")),
        }
    }

    /// Whether the frame Cycles turns this panorama's directions by is the
    /// mirror ball's: it looks down its own −y, the others down +x.
    pub fn is_mirrorball(&self) -> bool {
        matches!(self, Panorama::Mirrorball {})
    }

    /// The unit direction, in the panorama's frame, of the view's point
    /// (u, v) (from its bottom-left corner, in [0, 1]² across the image);
    /// None where the panorama sees nothing.
    pub fn direction(&self, uv: Vec2) -> Option<Vec3> {
        let Vec2 { x: u, y: v } = uv;
        let d = match *self {
            Panorama::Equirectangular { latitude: [lat_min, lat_max], longitude: [lon_min, lon_max] } => {
                // φ, the angle from +x toward +y (left), is −longitude.
                let phi = (lon_min - lon_max) * u - lon_min;
                let theta = (lat_min - lat_max) * v - lat_min + FRAC_PI_2;
                let (sin_t, cos_t) = theta.sin_cos();
                let (sin_p, cos_p) = phi.sin_cos();
                Vec3::new(sin_t * cos_p, sin_t * sin_p, cos_t)
            }
            Panorama::EquiangularCubemapFace {} => Vec3::new(1.0, ((0.5 - u) * FRAC_PI_2).tan(), ((v - 0.5) * FRAC_PI_2).tan()),
            Panorama::Mirrorball {} => {
                // The ball's point under (u, v), on its hemisphere facing
                // −y, reflects i = −y about its normal n: 2(n·i)n − i, −y
                // at the centre (which Cycles turns to the camera's
                // forward), +y on the rim.
                let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
                let r2 = x * x + z * z;
                if r2 > 1.0 {
                    return None;
                }
                let n = Vec3::new(x, -(1.0 - r2).max(0.0).sqrt(), z);
                let i = Vec3::new(0.0, -1.0, 0.0);
                2.0 * n.dot(i) * n - i
            }
            Panorama::FisheyeEquidistant { fov } => {
                let p = 2.0 * (uv - 0.5);
                let r = p.length();
                if r > 1.0 {
                    return None;
                }
                fisheye(r * fov * 0.5, p, r)
            }
            Panorama::FisheyeEquisolid { fov, lens, sensor } => {
                let p = (uv - 0.5) * Vec2::from(sensor);
                let r = p.length();
                if r > 2.0 * lens * (0.25 * fov).sin() {
                    return None;
                }
                fisheye(2.0 * (r / (2.0 * lens)).min(1.0).asin(), p, r)
            }
            Panorama::FisheyeLensPolynomial { fov, k, sensor } => {
                let p = (uv - 0.5) * Vec2::from(sensor);
                let r = p.length();
                let theta = -(k[0] + r * (k[1] + r * (k[2] + r * (k[3] + r * k[4]))));
                if !(theta.abs() <= 0.5 * fov) {
                    return None;
                }
                fisheye(theta, p, r)
            }
            Panorama::CentralCylindrical { u_range: [u_min, u_max], v_range: [v_min, v_max], radius } => {
                let theta = -u_min + (u_min - u_max) * u;
                let height = (v_min + (v_max - v_min) * v) / radius;
                Vec3::new(theta.cos(), theta.sin(), height)
            }
        };
        let d = d.normalize_or_zero();
        (d != Vec3::ZERO).then_some(d)
    }
}

/// A fisheye's direction at angle `theta` from its axis, toward the sensor
/// point `p` (at distance r from the centre; right is −y, up is +z).
fn fisheye(theta: f32, p: Vec2, r: f32) -> Vec3 {
    let (sin_t, cos_t) = theta.sin_cos();
    // At the centre every way is the axis; any unit vector serves.
    let toward = if r > 0.0 { p / r } else { Vec2::X };
    Vec3::new(cos_t, -toward.x * sin_t, toward.y * sin_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FULL: Panorama = Panorama::Equirectangular { latitude: [-FRAC_PI_2, FRAC_PI_2], longitude: [-PI, PI] };

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    /// The full equirectangular view: its centre looks forward, its left
    /// quarter left, its right quarter right, its edges behind, its top and
    /// bottom rows up and down; its rows are circles of latitude.
    #[test]
    fn equirectangular_spans_the_sphere_as_an_environment_texture_does() {
        let at = |u, v| FULL.direction(Vec2::new(u, v)).unwrap();
        assert!(close(at(0.5, 0.5), Vec3::X));
        assert!(close(at(0.25, 0.5), Vec3::Y) && close(at(0.75, 0.5), -Vec3::Y));
        assert!(close(at(0.0, 0.5), -Vec3::X) && close(at(1.0, 0.5), -Vec3::X));
        assert!(close(at(0.3, 1.0), Vec3::Z) && close(at(0.8, 0.0), -Vec3::Z));
        for u in [0.1, 0.4, 0.9] {
            assert!((at(u, 0.75).z - (PI / 4.0).sin()).abs() < 1e-6);
        }
        // A narrower range: latitude 0 to 60° and longitude ±30° span the
        // view; its bottom-left corner is on the horizon, 30° left.
        let part = Panorama::Equirectangular { latitude: [0.0, PI / 3.0], longitude: [-PI / 6.0, PI / 6.0] };
        let corner = part.direction(Vec2::ZERO).unwrap();
        assert!(close(corner, Vec3::new((PI / 6.0).cos(), (PI / 6.0).sin(), 0.0)), "{corner}");
        assert!((part.direction(Vec2::new(0.5, 1.0)).unwrap().z - (PI / 3.0).sin()).abs() < 1e-6);
    }

    /// An equidistant fisheye of 180°: its centre looks forward, its circle
    /// sideways, right at the right and up at the top, the angle linear in
    /// the distance from the centre; nothing outside the circle.
    #[test]
    fn equidistant_fisheye_angle_grows_with_radius() {
        let eye = Panorama::FisheyeEquidistant { fov: PI };
        let at = |u, v| eye.direction(Vec2::new(u, v));
        assert!(close(at(0.5, 0.5).unwrap(), Vec3::X));
        assert!(close(at(1.0, 0.5).unwrap(), -Vec3::Y) && close(at(0.5, 1.0).unwrap(), Vec3::Z));
        for r in [0.1f32, 0.37, 0.8] {
            let d = at(0.5 - 0.5 * r * 0.6, 0.5 - 0.5 * r * 0.8).unwrap();
            assert!((d.x.acos() - r * PI / 2.0).abs() < 1e-5, "{r}: {d}");
            assert!(d.y > 0.0 && d.z < 0.0 && (d.y / d.z + 0.75).abs() < 1e-4, "{d}");
        }
        assert!(at(0.95, 0.95).is_none() && at(0.0, 0.0).is_none());
    }

    /// An equisolid fisheye of a 10.5 mm lens on a 36 × 24 mm sensor: a
    /// point r mm from the centre looks 2·asin(r / 21) off the axis;
    /// beyond the 180° circle (r = 21·sin 45°) nothing.
    #[test]
    fn equisolid_fisheye_follows_its_lens_formula() {
        let eye = Panorama::FisheyeEquisolid { fov: PI, lens: 10.5, sensor: [36.0, 24.0] };
        for (x, y) in [(3.0f32, 0.0f32), (0.0, -7.0), (-10.0, 4.0)] {
            let d = eye.direction(Vec2::new(0.5 + x / 36.0, 0.5 + y / 24.0)).unwrap();
            let r = (x * x + y * y).sqrt();
            assert!((d.x.acos() - 2.0 * (r / 21.0).asin()).abs() < 1e-5, "({x}, {y}): {d}");
            assert!(-d.y * x >= 0.0 && d.z * y >= 0.0);
        }
        let edge = 21.0 * (PI / 4.0).sin();
        assert!(eye.direction(Vec2::new(0.5 + (edge - 0.01) / 36.0, 0.5)).is_some());
        assert!(eye.direction(Vec2::new(0.5 + (edge + 0.01) / 36.0, 0.5)).is_none());
    }

    /// The polynomial lens with θ = r/10 (k1 = −0.1) is the equidistant
    /// fisheye of 10 mm per radian; past fov/2 (1.1 rad, 11 mm), nothing.
    #[test]
    fn a_linear_polynomial_lens_is_equidistant() {
        let eye = Panorama::FisheyeLensPolynomial { fov: 2.2, k: [0.0, -0.1, 0.0, 0.0, 0.0], sensor: [36.0, 24.0] };
        let d = eye.direction(Vec2::new(0.5 + 6.0 / 36.0, 0.5 + 8.0 / 24.0)).unwrap();
        assert!((d.x.acos() - 1.0).abs() < 1e-5 && d.y < 0.0 && d.z > 0.0, "{d}");
        assert!(eye.direction(Vec2::new(0.5 + 10.9 / 36.0, 0.5)).is_some() && eye.direction(Vec2::new(0.5 + 11.1 / 36.0, 0.5)).is_none());
    }

    /// The mirror ball's centre reflects what is straight ahead of the
    /// camera (−y in its frame), its rim what is behind it; halfway out its
    /// normal is 30° off the axis, so it reflects 60° off it.
    #[test]
    fn mirror_ball_reflects_the_view_behind_it_at_the_rim() {
        let ball = Panorama::Mirrorball {};
        assert!(close(ball.direction(Vec2::splat(0.5)).unwrap(), -Vec3::Y));
        let rim = ball.direction(Vec2::new(1.0, 0.5)).unwrap();
        assert!(close(rim, Vec3::Y), "{rim}");
        let half = ball.direction(Vec2::new(0.75, 0.5)).unwrap();
        assert!(((-half.y).acos() - PI / 3.0).abs() < 1e-5 && half.x > 0.0, "{half}");
        assert!(ball.direction(Vec2::new(0.9, 0.9)).is_none());
    }

    /// A cube face's corners look 45° off the axis each way, evenly in
    /// angle between; a cylinder's columns are angles and its rows heights.
    #[test]
    fn cube_face_and_cylinder_map_angles_and_heights() {
        let face = Panorama::EquiangularCubemapFace {};
        let corner = face.direction(Vec2::new(1.0, 1.0)).unwrap();
        assert!(close(corner, Vec3::new(1.0, -1.0, 1.0).normalize()), "{corner}");
        let quarter = face.direction(Vec2::new(0.25, 0.5)).unwrap();
        assert!((quarter.y.atan2(quarter.x) - PI / 8.0).abs() < 1e-6);
        let cylinder = Panorama::CentralCylindrical { u_range: [-PI, PI], v_range: [-2.0, 2.0], radius: 2.0 };
        let d = cylinder.direction(Vec2::new(0.75, 1.0)).unwrap();
        assert!(close(d, Vec3::new(0.0, -1.0, 1.0).normalize()), "{d}");
    }

    /// Every direction is a unit vector or none, over a dense grid of the
    /// view, for every type at extreme settings.
    #[test]
    fn directions_are_unit_or_none_at_extreme_settings() {
        let panoramas = [
            FULL,
            Panorama::Equirectangular { latitude: [1.0, 1.0], longitude: [1e6, -1e6] },
            Panorama::EquiangularCubemapFace {},
            Panorama::Mirrorball {},
            Panorama::FisheyeEquidistant { fov: 2.0 * PI },
            Panorama::FisheyeEquidistant { fov: 1e-6 },
            Panorama::FisheyeEquisolid { fov: 2.0 * PI, lens: 1e-6, sensor: [1e6, 1e-6] },
            Panorama::FisheyeLensPolynomial { fov: 2.0 * PI, k: [1e6, -1e6, 1e6, -1e6, 1e6], sensor: [36.0, 24.0] },
            Panorama::CentralCylindrical { u_range: [0.0, 0.0], v_range: [-1e6, 1e6], radius: 1e-6 },
        ];
        for p in panoramas {
            p.check().unwrap();
            for i in 0..=64 {
                for j in 0..=64 {
                    if let Some(d) = p.direction(Vec2::new(i as f32 / 64.0, j as f32 / 64.0)) {
                        assert!((d.length() - 1.0).abs() < 1e-5, "{p:?} ({i}, {j}): {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        let bad = [
            Panorama::Equirectangular { latitude: [f32::NAN, 1.0], longitude: [0.0, 1.0] },
            Panorama::Equirectangular { latitude: [0.0, 1.0], longitude: [0.0, f32::INFINITY] },
            Panorama::FisheyeEquidistant { fov: 0.0 },
            Panorama::FisheyeEquidistant { fov: 7.0 },
            Panorama::FisheyeEquisolid { fov: PI, lens: 0.0, sensor: [36.0, 24.0] },
            Panorama::FisheyeEquisolid { fov: PI, lens: 10.0, sensor: [36.0, -1.0] },
            Panorama::FisheyeLensPolynomial { fov: PI, k: [0.0, f32::NAN, 0.0, 0.0, 0.0], sensor: [36.0, 24.0] },
            Panorama::CentralCylindrical { u_range: [-1.0, 1.0], v_range: [-1.0, 1.0], radius: 0.0 },
        ];
        for p in bad {
            assert!(p.check().unwrap_err().starts_with("panorama "), "{p:?}");
        }
    }

    /// The request's spelling: Blender's own enum names.
    #[test]
    fn reads_blender_panorama_types() {
        let p: Panorama = serde_json::from_str(r#"{"type": "FISHEYE_EQUISOLID", "fov": 3.0, "lens": 10.5, "sensor": [36, 24]}"#).unwrap();
        assert_eq!(p, Panorama::FisheyeEquisolid { fov: 3.0, lens: 10.5, sensor: [36.0, 24.0] });
        let p: Panorama = serde_json::from_str(r#"{"type": "MIRRORBALL"}"#).unwrap();
        assert!(p.is_mirrorball());
        assert!(serde_json::from_str::<Panorama>(r#"{"type": "MIRRORBALL", "fov": 1}"#).is_err());
        assert!(serde_json::from_str::<Panorama>(r#"{"type": "STEREOGRAPHIC"}"#).is_err());
    }
}
