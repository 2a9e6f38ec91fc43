//! A glTF perspective camera: it looks down its node's −Z with +Y up.

use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Camera {
    pub name: String,
    pub position: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// The file's aspect ratio (width / height), used only to pick a default
    /// image height; the image's own aspect ratio shapes the frustum.
    pub aspect_ratio: Option<f32>,
}

impl Camera {
    /// From the camera node's world transform (scale is removed).
    pub fn from_world(name: String, world: &Mat4, yfov: f32, aspect_ratio: Option<f32>) -> Result<Self, String> {
        if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) {
            return Err(format!("camera '{name}' has yfov {yfov}, which must be in (0, π)"));
        }
        let position = world.w_axis.truncate();
        let forward = (-world.z_axis.truncate()).normalize_or_zero();
        let right = (world.x_axis.truncate() - forward * world.x_axis.truncate().dot(forward)).normalize_or_zero();
        let up = right.cross(forward);
        if !position.is_finite() || forward == Vec3::ZERO || right == Vec3::ZERO || !up.is_finite() {
            return Err(format!("camera '{name}' has a degenerate or non-finite transform"));
        }
        let aspect_ratio = aspect_ratio.filter(|a| a.is_finite() && *a > 0.0);
        Ok(Camera { name, position, right, up, forward, yfov, aspect_ratio })
    }

    /// `--camera auto`: a camera that frames a bounding box, for scenes
    /// without one. It looks at the box's centre from the front (+Z, glTF's
    /// forward-facing side), a little above and to the right, far enough
    /// that the box's bounding sphere fits the vertical field of view.
    pub fn framing(min: Vec3, max: Vec3) -> Result<Self, String> {
        /// Blender's default camera: a 50 mm lens on a 36 mm sensor, ≈ 39.6°.
        const YFOV: f32 = 0.691;
        if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
            return Err("--camera auto: the scene has no geometry to frame".into());
        }
        let centre = 0.5 * (min + max);
        // A flat or point-like scene still needs a distance.
        let radius = (0.5 * (max - min).length()).max(1e-3 * centre.abs().max_element()).max(f32::MIN_POSITIVE.sqrt());
        let view = Vec3::new(0.5, 0.4, 1.0).normalize();
        let position = centre + view * (radius / (0.5 * YFOV).sin());
        let right = Vec3::Y.cross(view).normalize();
        let world = Mat4::from_cols(right.extend(0.0), view.cross(right).extend(0.0), view.extend(0.0), position.extend(1.0));
        Camera::from_world("auto".into(), &world, YFOV, None)
    }

    /// A primary ray through a point on the image plane given in pixels
    /// (x right, y down, continuous: the pixel (i, j) spans [i, i+1)×[j, j+1)).
    pub fn ray(&self, pixel: Vec2, width: u32, height: u32) -> (Vec3, Vec3) {
        self.lens(width, height).ray(pixel)
    }

    /// The camera for an image of this size: what every primary ray shares,
    /// computed once a pass (a tangent per ray had been 1% of a render).
    pub fn lens(&self, width: u32, height: u32) -> Lens<'_> {
        Lens { camera: self, tan_half: (0.5 * self.yfov).tan(), aspect: width as f32 / height as f32, width: width as f32, height: height as f32 }
    }
}

/// A camera and an image size (`Camera::lens`).
pub struct Lens<'a> {
    camera: &'a Camera,
    tan_half: f32,
    aspect: f32,
    width: f32,
    height: f32,
}

impl Lens<'_> {
    /// `Camera::ray`.
    pub fn ray(&self, pixel: Vec2) -> (Vec3, Vec3) {
        let c = self.camera;
        let sx = (2.0 * pixel.x / self.width - 1.0) * self.tan_half * self.aspect;
        let sy = (1.0 - 2.0 * pixel.y / self.height) * self.tan_half;
        let dir = (c.forward + c.right * sx + c.up * sy).normalize();
        (c.position, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_down_minus_z_and_corners_match_fov() {
        let cam = Camera::from_world("c".into(), &Mat4::IDENTITY, 90f32.to_radians(), None).unwrap();
        let (_, d) = cam.ray(Vec2::new(50.0, 50.0), 100, 100);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        // Top edge centre at 45° above the axis for a 90° vertical fov.
        let (_, d) = cam.ray(Vec2::new(50.0, 0.0), 100, 100);
        assert!((d.y - d.z.abs()).abs() < 1e-6 && d.y > 0.0);
        // Right of the image is +X.
        let (_, d) = cam.ray(Vec2::new(200.0, 50.0), 200, 100);
        assert!(d.x > 0.0 && (d.x / -d.z - 2.0).abs() < 1e-5);
    }

    #[test]
    fn rejects_bad_fov_and_degenerate_transform() {
        assert!(Camera::from_world("c".into(), &Mat4::IDENTITY, 0.0, None).is_err());
        assert!(Camera::from_world("c".into(), &Mat4::IDENTITY, f32::NAN, None).is_err());
        assert!(Camera::from_world("c".into(), &Mat4::ZERO, 1.0, None).is_err());
    }
}
