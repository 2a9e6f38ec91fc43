//! A glTF camera, perspective or orthographic: it looks down its node's −Z
//! with +Y up.

use glam::{Mat4, Vec2};
use crate::Vec3;

#[derive(Clone, Debug)]
pub struct Camera {
    pub name: String,
    pub position: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub projection: Projection,
    /// The file's aspect ratio (width / height), used only to pick a default
    /// image height; the image's own aspect ratio shapes the view.
    pub aspect_ratio: Option<f32>,
}

/// How the image's points become rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Rays from the camera's position; `yfov` is the vertical field of
    /// view in radians.
    Perspective { yfov: f32 },
    /// Parallel rays along the camera's forward axis, from the plane
    /// `near` metres in front of it (glTF's `znear`, Blender's Clip Start,
    /// where Cycles starts them too); `half_height` is half the view's
    /// height in metres (glTF's `ymag`; Blender's Orthographic Scale is
    /// the whole view's larger side).
    Orthographic { half_height: f32, near: f32 },
}

/// The largest orthographic half-height and near distance, in metres: a
/// view's corner, at most 32,768 image aspects wide, stays a finite float.
const MAX_ORTHOGRAPHIC: f32 = 1e15;

impl Camera {
    /// A perspective camera from its node's world transform (scale is
    /// removed).
    pub fn from_world(name: String, world: &Mat4, yfov: f32, aspect_ratio: Option<f32>) -> Result<Self, String> {
        Self::with_projection(name, world, Projection::Perspective { yfov }, aspect_ratio)
    }

    /// A camera of either projection from its node's world transform.
    pub fn with_projection(name: String, world: &Mat4, projection: Projection, aspect_ratio: Option<f32>) -> Result<Self, String> {
        match projection {
            Projection::Perspective { yfov } if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) => {
                return Err(format!("camera '{name}' has yfov {yfov}, which must be in (0, π)"));
            }
            Projection::Orthographic { half_height, .. } if !(half_height > 0.0 && half_height <= MAX_ORTHOGRAPHIC) => {
                return Err(format!("camera '{name}' has ymag {half_height}, which must be in (0, {MAX_ORTHOGRAPHIC:e}] m"));
            }
            Projection::Orthographic { near, .. } if !(near >= 0.0 && near <= MAX_ORTHOGRAPHIC) => {
                return Err(format!("camera '{name}' has znear {near}, which must be in [0, {MAX_ORTHOGRAPHIC:e}] m"));
            }
            _ => {}
        }
        let position = Vec3::from_vec4(world.w_axis);
        let forward = (-Vec3::from_vec4(world.z_axis)).normalize_or_zero();
        let x_axis = Vec3::from_vec4(world.x_axis);
        let right = (x_axis - forward * x_axis.dot(forward)).normalize_or_zero();
        let up = right.cross(forward);
        if !position.is_finite() || forward == Vec3::ZERO || right == Vec3::ZERO || !up.is_finite() {
            return Err(format!("camera '{name}' has a degenerate or non-finite transform"));
        }
        let aspect_ratio = aspect_ratio.filter(|a| a.is_finite() && *a > 0.0);
        Ok(Camera { name, position, right, up, forward, projection, aspect_ratio })
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
        let (half_height, parallel_from) = match self.projection {
            Projection::Perspective { yfov } => ((0.5 * yfov).tan(), None),
            Projection::Orthographic { half_height, near } => (half_height, Some(near)),
        };
        let aspect = width as f32 / height as f32;
        // A pixel's area on the image plane (at distance 1 for a
        // perspective camera).
        let pixel_area = (2.0 * half_height * aspect / width as f32) * (2.0 * half_height / height as f32);
        Lens { camera: self, half_height, parallel_from, aspect, width: width as f32, height: height as f32, pixel_area, image_width: width }
    }
}

/// A camera and an image size (`Camera::lens`).
pub struct Lens<'a> {
    camera: &'a Camera,
    /// Half the image plane's height: tan(yfov/2) at distance 1 for a
    /// perspective camera, metres for an orthographic one.
    half_height: f32,
    /// An orthographic camera's near distance, where its rays start.
    parallel_from: Option<f32>,
    aspect: f32,
    width: f32,
    height: f32,
    pixel_area: f32,
    image_width: u32,
}

/// A point as the camera sees it (`Lens::project`).
pub struct Seen {
    /// Row-major pixel index from the top-left.
    pub pixel: u32,
    /// Unit direction from the point to the camera, and its distance.
    pub to_camera: Vec3,
    pub distance: f32,
    /// W of the direction (`Lens::importance`).
    pub importance: f32,
}

impl Lens<'_> {
    /// `Camera::ray`.
    pub fn ray(&self, pixel: Vec2) -> (Vec3, Vec3) {
        let c = self.camera;
        let sx = (2.0 * pixel.x / self.width - 1.0) * self.half_height * self.aspect;
        let sy = (1.0 - 2.0 * pixel.y / self.height) * self.half_height;
        match self.parallel_from {
            None => (c.position, (c.forward + c.right * sx + c.up * sy).normalize()),
            Some(near) => (c.position + c.forward * near + c.right * sx + c.up * sy, c.forward),
        }
    }

    /// Whether every ray starts at one point, the camera's position: a
    /// perspective camera. Only such a camera can be joined to a point
    /// (`project`); an orthographic camera's rays share a direction
    /// instead, which a light subpath's vertex meets with probability 0.
    pub fn pinhole(&self) -> bool {
        self.parallel_from.is_none()
    }

    /// Where a perspective camera's rays start.
    pub fn position(&self) -> Vec3 {
        self.camera.position
    }

    /// W(ω) = 1/(A_p cos³θ): the density per steradian with which a pixel's
    /// uniformly jittered samples draw the direction ω of a camera ray in
    /// it, A_p the pixel's area on the image plane at distance 1 (dω =
    /// cos³θ dA there). A pixel's value is ∫ W L dω over its directions.
    /// 0 for an orthographic camera, which no other strategy reaches
    /// (`pinhole`): its rays' one direction is a delta.
    #[inline]
    pub fn importance(&self, dir: Vec3) -> f32 {
        let cos = dir.dot(self.camera.forward);
        if cos > 0.0 && self.pinhole() { 1.0 / (self.pixel_area * cos * cos * cos) } else { 0.0 }
    }

    /// Where on a perspective camera's image (in pixels, as `ray` takes
    /// them) the point at offset `v` from the camera appears, wherever that
    /// is; None behind the camera or level with it.
    #[inline]
    pub fn image_point(&self, v: Vec3) -> Option<Vec2> {
        let c = self.camera;
        let z = v.dot(c.forward);
        (z > 0.0).then(|| Vec2::new((v.dot(c.right) / (z * self.half_height * self.aspect) + 1.0) * 0.5 * self.width, (1.0 - v.dot(c.up) / (z * self.half_height)) * 0.5 * self.height))
    }

    /// The camera's forward axis: what `image_point`'s depth is along.
    pub fn forward(&self) -> Vec3 {
        self.camera.forward
    }

    /// The distance from the camera, per unit of depth along `forward`,
    /// of the frustum's farthest corner.
    pub fn corner_stretch(&self) -> f32 {
        (1.0 + self.half_height * self.half_height * (1.0 + self.aspect * self.aspect)).sqrt()
    }

    /// The pixel a point appears in, if any: the inverse of `ray`. None
    /// for an orthographic camera (`pinhole`).
    pub fn project(&self, p: Vec3) -> Option<Seen> {
        if !self.pinhole() {
            return None;
        }
        let c = self.camera;
        let v = p - c.position;
        let distance = v.length();
        let dir = v / distance;
        if !distance.is_finite() {
            return None;
        }
        let Vec2 { x, y } = self.image_point(dir)?;
        if !(x >= 0.0 && x < self.width && y >= 0.0 && y < self.height) {
            return None;
        }
        // Rounding can put x or y on the far edge.
        let (px, py) = ((x as u32).min(self.image_width - 1), (y as u32).min(self.height as u32 - 1));
        Some(Seen { pixel: py * self.image_width + px, to_camera: -dir, distance, importance: self.importance(dir) })
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

    /// `project` undoes `ray`, and W integrates to 1 over a pixel's
    /// directions (a corner pixel, where cos θ is smallest).
    #[test]
    fn projection_inverts_rays_and_importance_is_normalised_per_pixel() {
        let world = Mat4::from_rotation_y(0.4) * Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0));
        let cam = Camera::from_world("c".into(), &world, 1.2, None).unwrap();
        let lens = cam.lens(64, 48);
        for (x, y) in [(0.5f32, 0.5f32), (10.25, 40.75), (63.9, 0.1), (32.0, 24.0)] {
            let (o, d) = lens.ray(Vec2::new(x, y));
            let seen = lens.project(o + d * 7.0).expect("in view");
            assert_eq!(seen.pixel, y as u32 * 64 + x as u32, "({x}, {y})");
            assert!((seen.to_camera + d).length() < 1e-5 && (seen.distance - 7.0).abs() < 1e-4);
        }
        assert!(lens.project(cam.position - cam.forward).is_none());
        // ∫ W dω over the directions `project` puts in corner pixel (0, 0),
        // by Monte Carlo over a cone around it of known solid angle.
        let (_, axis) = lens.ray(Vec2::new(0.5, 0.5));
        let frame = crate::sampling::Frame::from_normal(axis);
        let (cos_max, n) = (0.03f32.cos(), 400_000);
        let mut rng = crate::rng::Rng::new(7, 0);
        let mut sum = 0.0f64;
        for _ in 0..n {
            let (u, v) = (rng.next_f32(), rng.next_f32());
            let cos = 1.0 - u * (1.0 - cos_max);
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * v;
            let d = frame.to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos));
            if lens.project(cam.position + d).is_some_and(|s| s.pixel == 0) {
                sum += lens.importance(d) as f64;
            }
        }
        let integral = sum / n as f64 * 2.0 * std::f64::consts::PI * (1.0 - cos_max as f64);
        // The estimate's standard error is about 0.3%.
        assert!((integral - 1.0).abs() < 0.015, "{integral}");
    }

    #[test]
    fn rejects_bad_fov_and_degenerate_transform() {
        assert!(Camera::from_world("c".into(), &Mat4::IDENTITY, 0.0, None).is_err());
        assert!(Camera::from_world("c".into(), &Mat4::IDENTITY, f32::NAN, None).is_err());
        assert!(Camera::from_world("c".into(), &Mat4::ZERO, 1.0, None).is_err());
        let ortho = |half_height, near| Camera::with_projection("c".into(), &Mat4::IDENTITY, Projection::Orthographic { half_height, near }, None);
        assert!(ortho(1.0, 0.0).is_ok() && ortho(MAX_ORTHOGRAPHIC, MAX_ORTHOGRAPHIC).is_ok());
        for (half_height, near) in [(0.0, 0.1), (-1.0, 0.1), (f32::NAN, 0.1), (f32::INFINITY, 0.1), (2e15, 0.1), (1.0, -0.1), (1.0, f32::NAN), (1.0, 2e15)] {
            assert!(ortho(half_height, near).is_err(), "{half_height} {near}");
        }
    }

    /// An orthographic camera's rays all look down −Z from the near plane,
    /// over a view `2·half_height` tall and as wide as the image's aspect
    /// makes it; nothing projects onto it, and its importance is 0.
    #[test]
    fn orthographic_rays_are_parallel_from_the_near_plane() {
        let world = Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0));
        let cam = Camera::with_projection("o".into(), &world, Projection::Orthographic { half_height: 1.5, near: 0.25 }, None).unwrap();
        let lens = cam.lens(200, 100);
        assert!(!lens.pinhole());
        for (pixel, expected) in [((0.0, 0.0), (-3.0, 1.5)), ((200.0, 100.0), (3.0, -1.5)), ((100.0, 50.0), (0.0, 0.0)), ((150.0, 25.0), (1.5, 0.75))] {
            let (o, d) = lens.ray(Vec2::new(pixel.0, pixel.1));
            assert_eq!(d, Vec3::NEG_Z);
            let want = Vec3::new(1.0 + expected.0, 2.0 + expected.1, 3.0 - 0.25);
            assert!((o - want).length() < 1e-6, "{pixel:?}: {o} against {want}");
        }
        assert!(lens.project(Vec3::new(1.0, 2.0, 0.0)).is_none());
        assert_eq!(lens.importance(Vec3::NEG_Z), 0.0);
        assert!(cam.lens(64, 64).pinhole() == false && Camera::from_world("p".into(), &world, 1.0, None).unwrap().lens(64, 64).pinhole());
    }
}
