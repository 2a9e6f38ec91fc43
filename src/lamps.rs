//! Blender area lights, which glTF cannot carry: the addon sends each as a
//! record in the render request, and Glint turns it into lamp triangles — a
//! one-sided emitter that rays otherwise pass through (see
//! `Material::lamp`).
//!
//! Units follow Cycles: a light of power P watts and colour c over a
//! world-space area A emits the radiance L = c·P / (π·A) W·sr⁻¹·m⁻² from its
//! front face, so its whole output over the hemisphere, L·π·A, is c·P (a
//! Spread below 180° scales L by direction and keeps that output:
//! `material::Spread`). The
//! light's local frame is Blender's: the shape lies in the XY plane, centred
//! on the origin, and emits towards local −Z.

use crate::material::{Material, Spread, MIN_SPREAD};
use crate::portals::Portal;
use crate::spherical_rectangle::Rectangle;
use crate::scene::{Scene, Triangle};
use glam::Mat4;
use crate::Vec3;
use serde::Deserialize;
use std::f32::consts::PI;

/// Blender's `AreaLight.shape`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(rename_all = "UPPERCASE")]
pub enum LampShape {
    Square,
    Rectangle,
    Disk,
    Ellipse,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaLight {
    #[serde(default)]
    pub name: String,
    pub shape: LampShape,
    /// Extent along local X and Y in metres: side lengths of a rectangle,
    /// diameters of an ellipse (Blender's `size` and `size_y`; a square or a
    /// disk uses the first).
    pub size: [f32; 2],
    /// Object to world, column-major, in glTF's world (Y up, metres).
    pub matrix: [f32; 16],
    /// Linear Rec.709.
    pub color: [f32; 3],
    /// Watts.
    pub power: f32,
    /// Blender's Object › Visibility › Camera: camera rays see the lamp
    /// (off by default, as in Blender).
    #[serde(default)]
    pub visible_camera: bool,
    /// Cycles' Light › Portal: the light emits nothing and guides light
    /// sampling of the World through its shape instead (portals.rs).
    #[serde(default)]
    pub portal: bool,
    /// Blender's Spread in radians: the opening of the cone the light
    /// leaves in (π, every way, by default; `Spread`).
    #[serde(default = "every_way")]
    pub spread: f32,
    /// Blender's Light › Cast Shadow (on by default): off, its light
    /// samples trace no shadow ray (`Material::shadowless`).
    #[serde(default = "yes")]
    pub cast_shadow: bool,
}

fn yes() -> bool {
    true
}

fn every_way() -> f32 {
    PI
}

/// Segments of the polygon standing in for a disk or an ellipse.
const ELLIPSE_SEGMENTS: usize = 64;

impl AreaLight {
    fn label(&self) -> String {
        if self.name.is_empty() { "area light".into() } else { format!("area light '{}'", self.name) }
    }

    /// Local extents (x, y), the square and disk using Blender's `size` only.
    fn extent(&self) -> (f32, f32) {
        match self.shape {
            LampShape::Square | LampShape::Disk => (self.size[0], self.size[0]),
            LampShape::Rectangle | LampShape::Ellipse => (self.size[0], self.size[1]),
        }
    }

    /// The outline in local coordinates, counter-clockwise seen from +Z.
    fn outline(&self) -> Vec<Vec3> {
        let (hx, hy) = (0.5 * self.extent().0, 0.5 * self.extent().1);
        match self.shape {
            LampShape::Square | LampShape::Rectangle => {
                vec![Vec3::new(-hx, -hy, 0.0), Vec3::new(hx, -hy, 0.0), Vec3::new(hx, hy, 0.0), Vec3::new(-hx, hy, 0.0)]
            }
            LampShape::Disk | LampShape::Ellipse => {
                // The inscribed polygon would lose ~0.16% of the area (and of
                // the power); this radius makes its area exactly π·hx·hy.
                let n = ELLIPSE_SEGMENTS as f32;
                let k = (PI / (0.5 * n * (2.0 * PI / n).sin())).sqrt();
                (0..ELLIPSE_SEGMENTS)
                    .map(|i| {
                        let phi = 2.0 * PI * i as f32 / n;
                        Vec3::new(k * hx * phi.cos(), k * hy * phi.sin(), 0.0)
                    })
                    .collect()
            }
        }
    }

    /// World-space area of the exact shape.
    fn area(&self, m: &Mat4) -> f32 {
        let (sx, sy) = self.extent();
        let scale = Vec3::from_vec4(m.x_axis).cross(Vec3::from_vec4(m.y_axis)).length();
        let shape = match self.shape {
            LampShape::Square | LampShape::Rectangle => 1.0,
            LampShape::Disk | LampShape::Ellipse => PI / 4.0,
        };
        shape * sx * sy * scale
    }
}

/// Append the lamps to the scene, and the portals to its portals. A light
/// that cannot emit (no power, no area) is left out, with a warning where
/// it has no area; a malformed record is an error.
pub fn add_area_lights(scene: &mut Scene, lights: &[AreaLight]) -> Result<(), String> {
    for light in lights {
        let label = light.label();
        let m = Mat4::from_cols_array(&light.matrix);
        let finite = light.size.iter().chain(&light.matrix).chain(&light.color).all(|v| v.is_finite()) && light.power.is_finite();
        if !finite {
            return Err(format!("{label} has a non-finite size, transform, colour or power"));
        }
        if light.power < 0.0 || light.color.iter().any(|&c| c < 0.0) || light.size.iter().any(|&s| s < 0.0) {
            return Err(format!("{label} has a negative size, colour or power"));
        }
        let area = light.area(&m);
        let color = Vec3::from(light.color);
        if !(area > 0.0 && area.is_finite()) {
            scene.warnings.push(format!("{label} has no area; left out"));
            continue;
        }
        let points: Vec<Vec3> = light.outline().iter().map(|&p| m.transform_point3a(p)).collect();
        let centre = m.transform_point3a(Vec3::ZERO);
        let front = -Vec3::from_vec4(m.z_axis);
        let fan: Vec<[Vec3; 3]> = match points.len() {
            4 => vec![[points[0], points[1], points[2]], [points[0], points[2], points[3]]],
            n => (0..n).map(|i| [centre, points[i], points[(i + 1) % n]]).collect(),
        };
        if light.portal {
            // Its power and colour mean nothing to Cycles either. Its plane's
            // normal on the −Z side (a sheared transform tilts −Z off it).
            let normal = Vec3::from_vec4(m.x_axis).cross(Vec3::from_vec4(m.y_axis)).normalize_or_zero();
            let inward = if normal.dot(front) < 0.0 { -normal } else { normal };
            if inward == Vec3::ZERO {
                scene.warnings.push(format!("{label} (a portal) has no facing; left out"));
            } else {
                // A rectangle whose edges stay perpendicular is sampled whole.
                let rectangle = (points.len() == 4)
                    .then(|| [points[0], points[1] - points[0], points[3] - points[0]])
                    .filter(|[_, ex, ey]| ex.dot(*ey).abs() <= 1e-4 * ex.length() * ey.length())
                    .map(|[corner, ex, ey]| Rectangle::new(corner, ex, ey));
                scene.portals.push(Portal { triangles: fan, rectangle, inward, origin: centre });
            }
            continue;
        }
        if light.power == 0.0 || color == Vec3::ZERO {
            continue;
        }
        if light.spread.is_nan() {
            return Err(format!("{label} has a spread that is not a number"));
        }
        if light.spread < MIN_SPREAD {
            scene.warnings.push(format!("{label}: Spread {:.2}° rendered as 1°", light.spread.to_degrees()));
        }
        let radiance = color * (light.power / (PI * area));
        let material = scene.materials.len() as u32;
        scene.materials.push(Material {
            name: label,
            base_color: Vec3::ZERO,
            metallic: 0.0,
            specular: 0.0,
            emission: radiance,
            lamp: true,
            camera_sees_lamp: light.visible_camera,
            spread: Spread::new(light.spread),
            shadowless: !light.cast_shadow,
            ..Material::default()
        });
        for mut p in fan {
            let mut normal = (p[1] - p[0]).cross(p[2] - p[0]);
            // A mirroring transform turns the winding; the front stays −Z.
            if normal.dot(front) < 0.0 {
                p.swap(1, 2);
                normal = -normal;
            }
            let n = normal.normalize_or_zero();
            if n != Vec3::ZERO && p.iter().all(|v| v.is_finite()) {
                scene.triangles.push(Triangle::new(p, [n; 3], material));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;

    fn light(shape: LampShape, size: [f32; 2], m: Mat4) -> AreaLight {
        AreaLight { name: "L".into(), shape, size, matrix: m.to_cols_array(), color: [1.0, 0.5, 0.25], power: 100.0, visible_camera: false, portal: false, spread: PI, cast_shadow: true }
    }

    fn empty_scene() -> Scene {
        Scene::new(vec![], vec![], Camera::from_world("c".into(), &Mat4::IDENTITY, 1.0, None).unwrap())
    }

    /// Σ L·π·A over the lamp triangles: the power the lamps emit.
    fn emitted_power(scene: &Scene) -> Vec3 {
        scene.triangles.iter().map(|t| scene.materials[t.material as usize].emission * PI * t.area()).sum()
    }

    #[test]
    fn every_shape_emits_its_power_from_its_front() {
        // Scaled, rotated and moved, once mirrored in X.
        let base = Mat4::from_scale_rotation_translation(glam::Vec3::new(2.0, 0.5, 3.0), glam::Quat::from_rotation_x(0.7), glam::Vec3::new(1.0, 2.0, 3.0));
        for m in [base, base * Mat4::from_scale(glam::Vec3::new(-1.0, 1.0, 1.0))] {
            for (shape, size, area) in [
                (LampShape::Square, [0.3, 9.0], 0.09),
                (LampShape::Rectangle, [0.3, 0.2], 0.06),
                (LampShape::Disk, [0.4, 9.0], PI * 0.04),
                (LampShape::Ellipse, [0.4, 0.2], PI * 0.02),
            ] {
                let mut scene = empty_scene();
                add_area_lights(&mut scene, &[light(shape, size, m)]).unwrap();
                let power = emitted_power(&scene);
                let expected = Vec3::new(100.0, 50.0, 25.0);
                assert!((power - expected).abs().max_element() < 1e-3 * 100.0, "{shape:?}: {power}");
                // Radiance from the exact area: A_world = area × |X × Y| of the transform = area.
                let le = scene.materials[0].emission.x;
                assert!((le - 100.0 / (PI * area)).abs() < 1e-3 * le, "{shape:?}: {le}");
                let front = -Vec3::from_vec4(m.z_axis).normalize();
                assert!(scene.triangles.iter().all(|t| t.cross().normalize().dot(front) > 0.999), "{shape:?}");
                assert!(scene.is_lamp(&scene.triangles[0]));
            }
        }
    }

    #[test]
    fn bad_records_are_errors_and_empty_lights_are_left_out() {
        let mut scene = empty_scene();
        let mut nan = light(LampShape::Square, [1.0, 1.0], Mat4::IDENTITY);
        nan.matrix[5] = f32::NAN;
        assert!(add_area_lights(&mut scene, &[nan]).unwrap_err().contains("non-finite"));
        let mut negative = light(LampShape::Square, [1.0, 1.0], Mat4::IDENTITY);
        negative.power = -1.0;
        assert!(add_area_lights(&mut scene, &[negative]).is_err());
        let flat = light(LampShape::Rectangle, [1.0, 0.0], Mat4::IDENTITY);
        let mut dark = light(LampShape::Disk, [1.0, 1.0], Mat4::IDENTITY);
        dark.power = 0.0;
        add_area_lights(&mut scene, &[flat, dark]).unwrap();
        assert!(scene.triangles.is_empty());
        assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    }

    /// A Spread below 180° goes to the lamp's material; one below 1° is
    /// rendered as 1°, with a warning naming the light; one that is not a
    /// number is an error.
    #[test]
    fn a_spread_goes_to_the_lamp_and_a_broken_one_is_named() {
        let mut scene = empty_scene();
        let spread = |angle: f32| AreaLight { spread: angle, ..light(LampShape::Square, [1.0, 1.0], Mat4::IDENTITY) };
        add_area_lights(&mut scene, &[spread(PI), spread(1.0), spread(0.0)]).unwrap();
        let spreads: Vec<_> = scene.materials.iter().map(|m| m.spread).collect();
        assert_eq!(spreads, vec![None, Spread::new(1.0), Spread::new(MIN_SPREAD)]);
        assert_eq!(scene.warnings, vec!["area light 'L': Spread 0.00° rendered as 1°".to_string()]);
        assert!(add_area_lights(&mut scene, &[spread(f32::NAN)]).unwrap_err().contains("spread"));
    }

    /// A portal adds no lamp: its outline, facing its light's −Z (a
    /// mirroring or sheared transform included), goes to the scene's
    /// portals, whatever its power; one without area is left out.
    #[test]
    fn a_portal_is_an_outline_facing_its_minus_z_and_emits_nothing() {
        let shear = Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.6, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        for (m, shape) in [(Mat4::IDENTITY, LampShape::Rectangle), (Mat4::from_scale(glam::Vec3::new(-1.0, 2.0, 1.0)), LampShape::Square), (shear, LampShape::Disk)] {
            let mut scene = empty_scene();
            let mut portal = light(shape, [1.0, 0.5], m);
            portal.portal = true;
            add_area_lights(&mut scene, &[portal]).unwrap();
            assert!(scene.triangles.is_empty() && scene.materials.is_empty());
            let [p] = &scene.portals[..] else { panic!("one portal") };
            let normal = Vec3::from_vec4(m.x_axis).cross(Vec3::from_vec4(m.y_axis)).normalize();
            assert!((p.inward.dot(normal).abs() - 1.0).abs() < 1e-6 && p.inward.dot(-Vec3::from_vec4(m.z_axis)) > 0.0, "{m}: {}", p.inward);
            let area: f32 = p.triangles.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()).sum();
            assert!((area - light(shape, [1.0, 0.5], m).area(&m)).abs() < 1e-5, "{m}: {area}");
        }
        let mut scene = empty_scene();
        let mut flat = light(LampShape::Rectangle, [1.0, 0.0], Mat4::IDENTITY);
        flat.portal = true;
        add_area_lights(&mut scene, &[flat]).unwrap();
        assert!(scene.portals.is_empty() && scene.warnings.len() == 1);
    }
}
