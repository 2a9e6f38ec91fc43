//! A glTF camera, perspective or orthographic: it looks down its node's −Z
//! with +Y up. Beside what glTF says of it (the projection, and `znear`
//! and `zfar`, Blender's Clip Start and End), a render request can give it
//! what Blender's camera has and glTF cannot carry: a lens shift, a depth
//! of field (`Aperture`) and a panoramic projection (panorama.rs), each as
//! Cycles renders it.

use glam::{Mat4, Vec2};
use crate::panorama::Panorama;
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
    /// Clip Start and End (glTF's `znear` and `zfar`, metres along
    /// `forward`): camera rays see only what lies between the two planes,
    /// as in Cycles, which starts a perspective ray at the near plane
    /// (a camera behind a wall, Clip Start past it, sees the room) and
    /// shows the World past the far one. Far is infinite where glTF gives
    /// none.
    pub clip: [f32; 2],
    /// Blender's Shift X and Y, as fractions of the image's width and
    /// height: the view moves right and up by them, the camera stays (a
    /// panorama's view is the unit square its mapping takes, moved so).
    pub shift: Vec2,
    /// Depth of field; None: everything is sharp.
    pub aperture: Option<Aperture>,
}

/// How the image's points become rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Rays from the camera's position; `yfov` is the vertical field of
    /// view in radians.
    Perspective { yfov: f32 },
    /// Parallel rays along the camera's forward axis, from the near plane
    /// (where Cycles starts them too); `half_height` is half the view's
    /// height in metres (glTF's `ymag`; Blender's Orthographic Scale is
    /// the whole view's larger side).
    Orthographic { half_height: f32 },
    /// Rays from the camera's position in every direction a panorama maps
    /// the view to (panorama.rs). Its frame is Cycles': x forward (the
    /// camera's −Z), y left, z up; a mirror ball's forward is its −y.
    Panoramic(Panorama),
}

/// A thin lens, Blender's Depth of Field as Cycles renders it: a ray
/// leaves from a point of the aperture (in the camera's x-y plane, drawn
/// uniformly) toward the point where the ray of the same image point from
/// the aperture's centre meets the plane of focus, so that only that plane
/// is sharp.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Aperture {
    /// Metres (Blender: focal length / (2 × F-Stop)).
    pub radius: f32,
    /// The plane of focus's distance along `forward`, metres.
    pub focus_distance: f32,
    /// 0: a disk; 3 or more: a regular polygon of that many blades
    /// inscribed in `radius` (Blender's Blades).
    #[serde(default)]
    pub blades: u32,
    /// The polygon's turn, radians (Blender's Rotation).
    #[serde(default)]
    pub rotation: f32,
    /// Blender's Ratio: the aperture's height over its width (an
    /// anamorphic lens's oval bokeh; Cycles divides its x by it).
    #[serde(default = "one")]
    pub ratio: f32,
}

fn one() -> f32 {
    1.0
}

/// The largest orthographic half-height and clip distance, in metres, and
/// shift, in image sizes: a view's corner, at most 32,768 image aspects
/// wide, stays a finite float.
const MAX_EXTENT: f32 = 1e15;
const MAX_SHIFT: f32 = 1e3;

impl Aperture {
    /// Why these values cannot be rendered, if they cannot.
    pub fn check(&self) -> Result<(), String> {
        if !(0.0..=MAX_EXTENT).contains(&self.radius) {
            return Err(format!("aperture radius {} must be in [0, {MAX_EXTENT:e}] m", self.radius));
        }
        if !(self.focus_distance > 0.0 && self.focus_distance <= MAX_EXTENT) {
            return Err(format!("focus distance {} must be in (0, {MAX_EXTENT:e}] m", self.focus_distance));
        }
        if self.blades > 1000 {
            return Err(format!("{} aperture blades; at most 1000", self.blades));
        }
        if !self.rotation.is_finite() {
            return Err(format!("aperture rotation {} must be finite", self.rotation));
        }
        if !(1e-3..=1e3).contains(&self.ratio) {
            return Err(format!("aperture ratio {} must be in [0.001, 1000]", self.ratio));
        }
        Ok(())
    }

    /// A uniformly drawn point of the aperture, in the camera's x-y plane
    /// (metres), from two numbers in [0, 1).
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let unit = if self.blades < 3 {
            crate::sampling::concentric_disk(u)
        } else {
            // Blade k's triangle (the centre and two neighbouring corners,
            // at rotation + (2k ± 1)π/n on the unit circle), picked by u.x,
            // then a uniform point of it.
            let n = self.blades as f32;
            let k = (u.x * n).floor().min(n - 1.0);
            let (a, b) = ((u.x * n - k).clamp(0.0, 1.0).sqrt(), u.y);
            let half = std::f32::consts::PI / n;
            // (a, b) → barycentrics toward the corners; the triangle's
            // axis is along +x before its turn.
            let local = Vec2::new(a * half.cos(), a * (2.0 * b - 1.0) * half.sin());
            let (sin, cos) = (self.rotation + k * 2.0 * half).sin_cos();
            Vec2::new(cos * local.x - sin * local.y, sin * local.x + cos * local.y)
        };
        Vec2::new(unit.x / self.ratio, unit.y) * self.radius
    }
}

impl Camera {
    /// A perspective camera from its node's world transform (scale is
    /// removed), clipping nothing.
    pub fn from_world(name: String, world: &Mat4, yfov: f32, aspect_ratio: Option<f32>) -> Result<Self, String> {
        Self::with_projection(name, world, Projection::Perspective { yfov }, aspect_ratio, [0.0, f32::INFINITY])
    }

    /// A camera of either projection from its node's world transform, with
    /// its clip planes.
    pub fn with_projection(name: String, world: &Mat4, projection: Projection, aspect_ratio: Option<f32>, clip: [f32; 2]) -> Result<Self, String> {
        match projection {
            Projection::Perspective { yfov } if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) => {
                return Err(format!("camera '{name}' has yfov {yfov}, which must be in (0, π)"));
            }
            Projection::Orthographic { half_height } if !(half_height > 0.0 && half_height <= MAX_EXTENT) => {
                return Err(format!("camera '{name}' has ymag {half_height}, which must be in (0, {MAX_EXTENT:e}] m"));
            }
            _ => {}
        }
        let [near, far] = clip;
        if !(0.0..=MAX_EXTENT).contains(&near) {
            return Err(format!("camera '{name}' has znear {near}, which must be in [0, {MAX_EXTENT:e}] m"));
        }
        if !(far > near) {
            return Err(format!("camera '{name}' has zfar {far}, which must be beyond znear ({near} m)"));
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
        Ok(Camera { name, position, right, up, forward, projection, aspect_ratio, clip, shift: Vec2::ZERO, aperture: None })
    }

    /// Give the camera Blender's lens shift and depth of field, and its
    /// panoramic projection, which replaces glTF's.
    pub fn set_lens(&mut self, shift: Vec2, aperture: Option<Aperture>, panorama: Option<Panorama>) -> Result<(), String> {
        if !(shift.is_finite() && shift.abs().max_element() <= MAX_SHIFT) {
            return Err(format!("lens shift {shift} must be within ±{MAX_SHIFT} image sizes"));
        }
        if let Some(a) = &aperture {
            a.check()?;
        }
        if let Some(p) = &panorama {
            p.check()?;
            self.projection = Projection::Panoramic(*p);
        }
        self.shift = shift;
        // A closed aperture is a pinhole.
        self.aperture = aperture.filter(|a| a.radius > 0.0);
        Ok(())
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

    /// The ray through a point on an image of this size (`Lens::ray`), from
    /// the aperture's centre.
    pub fn ray(&self, pixel: Vec2, width: u32, height: u32) -> Option<CameraRay> {
        self.lens(width, height).ray(pixel, Vec2::splat(0.5))
    }

    /// The camera for an image of this size: what every primary ray shares,
    /// computed once a pass (a tangent per ray had been 1% of a render).
    pub fn lens(&self, width: u32, height: u32) -> Lens<'_> {
        let (half_height, orthographic, panorama) = match self.projection {
            Projection::Perspective { yfov } => ((0.5 * yfov).tan(), false, None),
            Projection::Orthographic { half_height } => (half_height, true, None),
            // No image plane: a pixel's area and the shift below are not
            // read.
            Projection::Panoramic(p) => (1.0, false, Some(p)),
        };
        let aspect = width as f32 / height as f32;
        // A pixel's area on the image plane (at distance 1 for a
        // perspective camera).
        let pixel_area = (2.0 * half_height * aspect / width as f32) * (2.0 * half_height / height as f32);
        let shift = Vec2::new(2.0 * half_height * aspect, 2.0 * half_height) * self.shift;
        Lens { camera: self, half_height, orthographic, panorama, shift, aspect, width: width as f32, height: height as f32, pixel_area, image_width: width }
    }
}

/// A camera and an image size (`Camera::lens`).
pub struct Lens<'a> {
    camera: &'a Camera,
    /// Half the image plane's height: tan(yfov/2) at distance 1 for a
    /// perspective camera, metres for an orthographic one.
    half_height: f32,
    orthographic: bool,
    panorama: Option<Panorama>,
    /// The lens shift on the image plane, in its units.
    shift: Vec2,
    aspect: f32,
    width: f32,
    height: f32,
    pixel_area: f32,
    image_width: u32,
}

/// A camera ray from the lens, which sees what lies between `tmin` and
/// `tmax` along it (Clip Start and End). Cycles moves the ray's origin to
/// Clip Start instead; far from the scene's origin that rounds the origin
/// off the ray (at 10⁵ m, by up to 4 mm), where a minimum distance leaves
/// it exact.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

/// A point as the camera sees it (`Lens::project`).
pub struct Seen {
    /// Row-major index from the top-left of the pixel it appears in; None
    /// just outside the image (within the `reach` asked for).
    pub pixel: Option<u32>,
    /// Where in the image it appears, in pixels (as `ray` takes them).
    pub image: Vec2,
    /// Where on the lens the point is seen from: the camera's position, or
    /// a point of its aperture.
    pub lens_point: Vec3,
    /// Unit direction from the point to `lens_point`, and its distance.
    pub to_camera: Vec3,
    pub distance: f32,
    /// How much of that distance, from the lens, camera rays skip (nearer
    /// than Clip Start): what stands there blocks nothing.
    pub skipped: f32,
    /// How densely the camera's rays reach the point (`Lens::density`).
    pub density: CameraDensity,
}

/// How densely a pixel's samples reach a point x a camera ray meets, which
/// light tracing's MIS weighs against: per unit area at x, with `cos` the
/// cosine there and `t2` the squared distance from the lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraDensity {
    /// W per steradian (`Lens::importance`): W·cos/t².
    PerSolidAngle(f32),
    /// An orthographic camera's rays fill the image plane evenly, one
    /// direction: 1/A per unit of that plane, where A is a pixel's area
    /// there, and cos/A per unit area at x.
    PerArea(f32),
}

impl CameraDensity {
    /// The density scaled by `k`: the pixel filter's at the sample's
    /// offset.
    #[inline]
    pub fn scaled(self, k: f32) -> Self {
        match self {
            CameraDensity::PerSolidAngle(w) => CameraDensity::PerSolidAngle(w * k),
            CameraDensity::PerArea(a) => CameraDensity::PerArea(a * k),
        }
    }

    #[inline]
    pub fn at(self, cos: f32, t2: f32) -> f32 {
        match self {
            CameraDensity::PerSolidAngle(w) => w * cos / t2,
            CameraDensity::PerArea(inverse_area) => inverse_area * cos,
        }
    }
}

impl Lens<'_> {
    /// The ray through a point on the image given in pixels (x right, y
    /// down, continuous: the pixel (i, j) spans [i, i+1)×[j, j+1)), leaving
    /// from the aperture's point `aperture_u` (two numbers in [0, 1), read
    /// only where the camera has an aperture: `has_aperture`). None where
    /// a panorama sees nothing (outside a fisheye's circle).
    #[inline]
    pub fn ray(&self, pixel: Vec2, aperture_u: Vec2) -> Option<CameraRay> {
        let c = self.camera;
        let [near, far] = c.clip;
        if let Some(p) = &self.panorama {
            return self.panoramic_ray(p, pixel, aperture_u);
        }
        let s = Vec2::new((2.0 * pixel.x / self.width - 1.0) * self.half_height * self.aspect, (1.0 - 2.0 * pixel.y / self.height) * self.half_height) + self.shift;
        let lens = self.aperture_point(aperture_u);
        if self.orthographic {
            let start = c.position + c.right * s.x + c.up * s.y;
            return Some(match lens {
                None => CameraRay { origin: start, dir: c.forward, tmin: near, tmax: far },
                Some((l, focus)) => CameraRay { origin: start + l, dir: (c.forward * focus - l).normalize(), tmin: near, tmax: far },
            });
        }
        // Summed in this order, a ray's bits are those of every earlier
        // version (images stay the same to the byte).
        let pinhole = c.forward + c.right * s.x + c.up * s.y;
        // Clip Start and End are depths: along a ray of the image point,
        // depth × |pinhole|, as Cycles measures them for either kind of ray.
        let stretch = pinhole.length();
        let (origin, dir) = match lens {
            None => (c.position, pinhole.normalize()),
            Some((l, focus)) => (c.position + l, (pinhole * focus - l).normalize()),
        };
        Some(CameraRay { origin, dir, tmin: near * stretch, tmax: far * stretch })
    }

    /// `ray` for a panorama, kept out of line: the other cameras' rays,
    /// inlined where the render loop makes them, stay as short as they
    /// were.
    ///
    /// With an aperture, as Cycles does it: the ray leaves a point of the
    /// aperture set across the pinhole ray d, on axes u along the
    /// panorama's forward x with d's share of it taken off, and v = d × u,
    /// toward d's point at the focus distance (along the ray, not a
    /// depth): every ray of an image point meets there.
    #[inline(never)]
    fn panoramic_ray(&self, p: &Panorama, pixel: Vec2, aperture_u: Vec2) -> Option<CameraRay> {
        let c = self.camera;
        // (u, v) from the view's bottom-left corner, as Cycles' raster.
        let uv = Vec2::new(pixel.x / self.width, 1.0 - pixel.y / self.height) + c.shift;
        let mut d = p.direction(uv)?;
        let mut origin = Vec3::ZERO;
        if let Some(a) = &c.aperture {
            let l = a.sample(aperture_u);
            // Straight along x (a fisheye's centre) any axes across d do.
            let u = (Vec3::X - d.x * d).try_normalize().unwrap_or(Vec3::Y);
            let v = d.cross(u);
            origin = u * l.x + v * l.y;
            d = (d * a.focus_distance - origin).normalize();
        }
        let world = |w: Vec3| if p.is_mirrorball() { c.right * w.x - c.forward * w.y + c.up * w.z } else { c.forward * w.x - c.right * w.y + c.up * w.z };
        // Clip Start and End are distances along a panorama's rays.
        Some(CameraRay { origin: c.position + world(origin), dir: world(d), tmin: c.clip[0], tmax: c.clip[1] })
    }

    /// The point of the aperture drawn from `aperture_u`, as an offset from
    /// the camera's position, and the plane of focus's distance; None
    /// without an aperture.
    fn aperture_point(&self, aperture_u: Vec2) -> Option<(Vec3, f32)> {
        let c = self.camera;
        c.aperture.map(|a| {
            let l = a.sample(aperture_u);
            (c.right * l.x + c.up * l.y, a.focus_distance)
        })
    }

    /// Whether image point (x, y) lies within `reach` pixels of the image.
    fn within_reach(&self, x: f32, y: f32, reach: f32) -> bool {
        x >= -reach && x < self.width + reach && y >= -reach && y < self.height + reach
    }

    /// The row-major index of the pixel at image point (`x`, `y`), as
    /// `ray` takes them; None outside the image.
    fn pixel_index(&self, x: f32, y: f32) -> Option<u32> {
        if !(x >= 0.0 && x < self.width && y >= 0.0 && y < self.height) {
            return None;
        }
        // Rounding can put x or y on the far edge.
        let (px, py) = ((x as u32).min(self.image_width - 1), (y as u32).min(self.height as u32 - 1));
        Some(py * self.image_width + px)
    }

    /// Whether rays leave from points of an aperture, which draws two more
    /// numbers a ray.
    pub fn has_aperture(&self) -> bool {
        self.camera.aperture.is_some()
    }

    /// Whether every ray starts at one point, the camera's position, and
    /// crosses one image plane: a perspective camera without an aperture
    /// (`CameraHits` needs it).
    pub fn pinhole(&self) -> bool {
        !self.orthographic && !self.has_aperture() && self.panorama.is_none()
    }

    /// Whether a point can be joined to the camera (`project`): a
    /// perspective camera through its centre or a point of its aperture,
    /// an orthographic one along its one direction (as a sun is joined to
    /// a point lit), but not an orthographic one with an aperture, whose
    /// rays through a point of the plane of focus are not drawn by area,
    /// nor a panorama, whose mappings have no inverse here.
    pub fn joinable(&self) -> bool {
        !(self.orthographic && self.has_aperture()) && self.panorama.is_none()
    }

    /// How densely the camera's ray in direction `dir` reaches what it
    /// meets (`CameraDensity`); 0 where no other strategy can reach the
    /// camera (`joinable`).
    #[inline]
    pub fn density(&self, dir: Vec3) -> CameraDensity {
        match (self.orthographic, self.joinable()) {
            (false, true) => CameraDensity::PerSolidAngle(self.importance(dir)),
            (true, true) => CameraDensity::PerArea(1.0 / self.pixel_area),
            (_, false) => CameraDensity::PerArea(0.0),
        }
    }

    /// Where a perspective camera's centre is.
    pub fn position(&self) -> Vec3 {
        self.camera.position
    }

    /// W(ω) = 1/(A_p cos³θ): the density per steradian with which a pixel's
    /// uniformly jittered samples draw the direction ω of a camera ray in
    /// it, A_p the pixel's area on the image plane at distance 1 (dω =
    /// cos³θ dA there). A pixel's value is ∫ W L dω over its directions.
    /// From a point of an aperture it is the same: the pixel's patch of
    /// the plane of focus, seen from there, subtends the same density.
    /// For a perspective camera (`density`).
    #[inline]
    pub fn importance(&self, dir: Vec3) -> f32 {
        let cos = dir.dot(self.camera.forward);
        if cos > 0.0 { 1.0 / (self.pixel_area * cos * cos * cos) } else { 0.0 }
    }

    /// Where on a perspective camera's image (in pixels, as `ray` takes
    /// them) the point at offset `v` from the camera's centre appears,
    /// wherever that is; None behind the camera or level with it.
    #[inline]
    pub fn image_point(&self, v: Vec3) -> Option<Vec2> {
        let c = self.camera;
        let z = v.dot(c.forward);
        (z > 0.0).then(|| {
            // The shift taken off before the one division: with none, the
            // bits of every earlier version.
            let s = Vec2::new(v.dot(c.right), v.dot(c.up)) - self.shift * z;
            Vec2::new((s.x / (z * self.half_height * self.aspect) + 1.0) * 0.5 * self.width, (1.0 - s.y / (z * self.half_height)) * 0.5 * self.height)
        })
    }

    /// The camera's forward axis: what `image_point`'s depth is along.
    pub fn forward(&self) -> Vec3 {
        self.camera.forward
    }

    /// The distance from the camera, per unit of depth along `forward`,
    /// of the frustum's farthest corner.
    pub fn corner_stretch(&self) -> f32 {
        let corner = Vec2::new(self.half_height * self.aspect, self.half_height) + self.shift.abs();
        (1.0 + corner.length_squared()).sqrt()
    }

    /// The pixel a point appears in, if any, seen from a point of the
    /// aperture drawn from `aperture_u` (as `ray` draws it): the inverse of
    /// `ray`. None where the camera is not `joinable`.
    /// Points up to `reach` pixels outside the image are seen too (a pixel
    /// filter wider than a pixel reaches them), with no pixel of their own.
    pub fn project(&self, p: Vec3, aperture_u: Vec2, reach: f32) -> Option<Seen> {
        if !self.joinable() {
            return None;
        }
        let c = self.camera;
        if self.orthographic {
            // Seen along −forward from the image plane through the camera.
            let v = p - c.position;
            let depth = v.dot(c.forward);
            let s = (Vec2::new(v.dot(c.right), v.dot(c.up)) - self.shift) / self.half_height;
            let image = Vec2::new((s.x / self.aspect + 1.0) * 0.5 * self.width, (1.0 - s.y) * 0.5 * self.height);
            if !self.within_reach(image.x, image.y, reach) {
                return None;
            }
            let pixel = self.pixel_index(image.x, image.y);
            let [near, far] = c.clip;
            if !(depth > near && depth <= far) {
                return None;
            }
            let density = self.density(c.forward);
            return Some(Seen { pixel, image, lens_point: p - c.forward * depth, to_camera: -c.forward, distance: depth, skipped: near, density });
        }
        let (lens_point, focus) = match self.aperture_point(aperture_u) {
            None => (c.position, None),
            Some((l, focus)) => (c.position + l, Some(focus)),
        };
        let v = p - lens_point;
        let distance = v.length();
        let dir = v / distance;
        if !distance.is_finite() {
            return None;
        }
        let cos = dir.dot(c.forward);
        // The image point: where the ray from the lens point crosses the
        // plane of focus, seen from the centre.
        let pinhole = match focus {
            None => dir,
            Some(f) if cos > 0.0 => lens_point - c.position + dir * (f / cos),
            Some(_) => return None,
        };
        let image = self.image_point(pinhole)?;
        if !self.within_reach(image.x, image.y, reach) {
            return None;
        }
        let pixel = self.pixel_index(image.x, image.y);
        // The depths between the clip planes, as `ray` measures them.
        let stretch = pinhole.length() / pinhole.dot(c.forward);
        let [near, far] = c.clip;
        let (skipped, reach) = (near * stretch, far * stretch);
        if !(distance > skipped && distance <= reach) {
            return None;
        }
        Some(Seen { pixel, image, lens_point, to_camera: -dir, distance, skipped, density: self.density(dir) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_down_minus_z_and_corners_match_fov() {
        let cam = Camera::from_world("c".into(), &Mat4::IDENTITY, 90f32.to_radians(), None).unwrap();
        let d = cam.ray(Vec2::new(50.0, 50.0), 100, 100).unwrap().dir;
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        // Top edge centre at 45° above the axis for a 90° vertical fov.
        let d = cam.ray(Vec2::new(50.0, 0.0), 100, 100).unwrap().dir;
        assert!((d.y - d.z.abs()).abs() < 1e-6 && d.y > 0.0);
        // Right of the image is +X.
        let d = cam.ray(Vec2::new(200.0, 50.0), 200, 100).unwrap().dir;
        assert!(d.x > 0.0 && (d.x / -d.z - 2.0).abs() < 1e-5);
    }

    fn turned_camera(clip: [f32; 2], shift: Vec2, aperture: Option<Aperture>) -> Camera {
        let world = Mat4::from_rotation_y(0.4) * Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0));
        let mut cam = Camera::with_projection("c".into(), &world, Projection::Perspective { yfov: 1.2 }, None, clip).unwrap();
        cam.set_lens(shift, aperture, None).unwrap();
        cam
    }

    /// `project` undoes `ray` (seen from the same point of the aperture),
    /// for a plain camera, a shifted one with clip planes, and one with an
    /// oval five-bladed aperture.
    #[test]
    fn projection_inverts_rays() {
        let aperture = Aperture { radius: 0.2, focus_distance: 4.0, blades: 5, rotation: 0.3, ratio: 1.5 };
        for cam in [turned_camera([0.0, f32::INFINITY], Vec2::ZERO, None), turned_camera([0.5, 20.0], Vec2::new(0.3, -0.2), None), turned_camera([0.5, 20.0], Vec2::new(0.1, 0.4), Some(aperture))] {
            let lens = cam.lens(64, 48);
            for (x, y) in [(0.5f32, 0.5f32), (10.25, 40.75), (63.9, 0.1), (32.3, 24.6)] {
                for u in [Vec2::new(0.5, 0.5), Vec2::new(0.1, 0.9), Vec2::new(0.77, 0.2)] {
                    let ray = lens.ray(Vec2::new(x, y), u).unwrap();
                    let seen = lens.project(ray.origin + ray.dir * 7.0, u, 0.0).expect("in view");
                    assert_eq!(seen.pixel, Some(y as u32 * 64 + x as u32), "({x}, {y}) {u}");
                    assert!((seen.image - Vec2::new(x, y)).length() < 1e-3, "{}", seen.image);
                    assert!((ray.origin - seen.lens_point).length() < 1e-6);
                    assert!((seen.to_camera + ray.dir).length() < 1e-5 && (seen.distance - 7.0).abs() < 1e-4);
                    assert!((seen.skipped - ray.tmin).abs() < 1e-5, "{} {}", seen.skipped, ray.tmin);
                }
            }
            assert!(lens.project(cam.position - cam.forward, Vec2::splat(0.5), 0.0).is_none());
            // Just outside the image: seen, with no pixel, where a filter
            // reaches that far.
            let ray = lens.ray(Vec2::new(-0.8, 20.0), Vec2::ZERO).unwrap();
            let p = ray.origin + ray.dir * 7.0;
            assert!(lens.project(p, Vec2::ZERO, 0.0).is_none());
            assert!(lens.project(p, Vec2::ZERO, 1.0).is_some_and(|s| s.pixel.is_none() && (s.image.x + 0.8).abs() < 1e-3));
        }
    }

    /// W integrates to 1 over a pixel's directions (a corner pixel, where
    /// cos θ is smallest; and one far off the axis by a shift).
    #[test]
    fn importance_is_normalised_per_pixel() {
        for shift in [Vec2::ZERO, Vec2::new(0.8, -0.5)] {
            let cam = turned_camera([0.0, f32::INFINITY], shift, None);
            let lens = cam.lens(64, 48);
            // ∫ W dω over the directions `project` puts in pixel (0, 0),
            // by Monte Carlo over a cone around it of known solid angle.
            let axis = lens.ray(Vec2::new(0.5, 0.5), Vec2::ZERO).unwrap().dir;
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
                if lens.project(cam.position + d, Vec2::ZERO, 0.0).is_some_and(|s| s.pixel == Some(0)) {
                    sum += lens.importance(d) as f64;
                }
            }
            let integral = sum / n as f64 * 2.0 * std::f64::consts::PI * (1.0 - cos_max as f64);
            // The estimate's standard error is about 0.3%.
            assert!((integral - 1.0).abs() < 0.015, "shift {shift}: {integral}");
        }
    }

    /// A shift moves the view by a fraction of the image: the centre ray of
    /// a view shifted by (0.5, 0.25) is the old ray of the image's right
    /// edge and the point halfway to its top.
    #[test]
    fn a_shift_moves_the_view_by_fractions_of_the_image() {
        let plain = turned_camera([0.0, f32::INFINITY], Vec2::ZERO, None);
        let shifted = turned_camera([0.0, f32::INFINITY], Vec2::new(0.5, 0.25), None);
        let (a, b) = (shifted.ray(Vec2::new(32.0, 24.0), 64, 48).unwrap().dir, plain.ray(Vec2::new(64.0, 12.0), 64, 48).unwrap().dir);
        assert!((a - b).length() < 1e-6, "{a} {b}");
    }

    /// Clip Start and End are depths: rays see from the near plane to the
    /// far one, however far off the axis; points outside them are not
    /// seen, and only the stretch beyond Clip Start must be clear.
    #[test]
    fn clip_planes_bound_what_camera_rays_reach() {
        let cam = turned_camera([0.5, 20.0], Vec2::ZERO, None);
        let lens = cam.lens(64, 48);
        let depth = |p: Vec3| (p - cam.position).dot(cam.forward);
        for pixel in [Vec2::new(0.2, 0.3), Vec2::new(32.5, 24.5), Vec2::new(60.0, 3.0)] {
            let ray = lens.ray(pixel, Vec2::ZERO).unwrap();
            assert!((depth(ray.origin + ray.dir * ray.tmin) - 0.5).abs() < 1e-5 && (depth(ray.origin + ray.dir * ray.tmax) - 20.0).abs() < 1e-3, "{pixel}");
            let at = |d: f32| lens.project(cam.position + ray.dir * (d / ray.dir.dot(cam.forward)), Vec2::ZERO, 0.0);
            assert!(at(0.4).is_none() && at(20.5).is_none());
            let seen = at(2.0).unwrap();
            assert!((seen.skipped - seen.distance * 0.25).abs() < 1e-5);
        }
    }

    /// Every ray of an image point, whatever its point of the aperture,
    /// passes through one point of the plane of focus; the aperture's
    /// points are uniform over its disk or polygon, squashed by its ratio.
    #[test]
    fn an_aperture_focuses_on_its_plane_and_is_sampled_uniformly() {
        for (blades, rotation, ratio) in [(0, 0.0, 1.0), (5, 0.3, 1.0), (6, 1.0, 2.0), (3, 0.0, 0.5)] {
            let aperture = Aperture { radius: 0.3, focus_distance: 4.0, blades, rotation, ratio };
            let cam = turned_camera([0.1, f32::INFINITY], Vec2::new(0.1, 0.0), Some(aperture));
            let lens = cam.lens(64, 48);
            let mut rng = crate::rng::Rng::new(3, 1);
            let focus = |u: Vec2| {
                let ray = lens.ray(Vec2::new(10.3, 40.6), u).unwrap();
                ray.origin + ray.dir * ((cam.position + cam.forward * 4.0 - ray.origin).dot(cam.forward) / ray.dir.dot(cam.forward))
            };
            let sharp = focus(Vec2::splat(0.5));
            for _ in 0..100 {
                assert!((focus(rng.next_2d()) - sharp).length() < 1e-5);
            }
            // Unsquashed, the points fill the polygon (corners on the unit
            // circle at rotation + (2k + 1)π/n) or disk evenly: a 16 × 16
            // grid's cells wholly inside get equal counts, none outside.
            let inside = |p: Vec2| {
                let p = Vec2::new(p.x * ratio, p.y) / 0.3;
                if blades == 0 {
                    return p.length() <= 1.0 + 1e-5;
                }
                let n = blades as f32;
                (0..blades).all(|k| {
                    let mid = rotation + 2.0 * std::f32::consts::PI * k as f32 / n;
                    p.dot(Vec2::new(mid.cos(), mid.sin())) <= (std::f32::consts::PI / n).cos() + 1e-5
                })
            };
            let (cells, n) = (16usize, 400_000);
            let mut counts = vec![0u32; cells * cells];
            let cell = |v: f32| (((v / 0.3 + 1.0) * 0.5 * cells as f32) as usize).min(cells - 1);
            for _ in 0..n {
                let p = aperture.sample(rng.next_2d());
                assert!(inside(p), "{blades} blades: {p} outside");
                let q = Vec2::new(p.x * ratio, p.y);
                counts[cell(q.y) * cells + cell(q.x)] += 1;
            }
            let corner = |i: usize, j: usize| Vec2::new((i as f32 / cells as f32 * 2.0 - 1.0) * 0.3 / ratio, (j as f32 / cells as f32 * 2.0 - 1.0) * 0.3);
            let full: Vec<u32> = (0..cells * cells)
                .filter(|&c| { let (i, j) = (c % cells, c / cells); [(0, 0), (1, 0), (0, 1), (1, 1)].iter().all(|(a, b)| inside(corner(i + a, j + b))) })
                .map(|c| counts[c])
                .collect();
            let mean = full.iter().sum::<u32>() as f64 / full.len() as f64;
            for c in &full {
                assert!((*c as f64 - mean).abs() < 5.0 * mean.sqrt(), "{blades} blades: a cell has {c}, the mean {mean}");
            }
        }
    }

    #[test]
    fn rejects_bad_fov_clip_lens_and_degenerate_transform() {
        assert!(Camera::from_world("c".into(), &Mat4::IDENTITY, 0.0, None).is_err());
        assert!(Camera::from_world("c".into(), &Mat4::IDENTITY, f32::NAN, None).is_err());
        assert!(Camera::from_world("c".into(), &Mat4::ZERO, 1.0, None).is_err());
        let ortho = |half_height, near| Camera::with_projection("c".into(), &Mat4::IDENTITY, Projection::Orthographic { half_height }, None, [near, f32::INFINITY]);
        assert!(ortho(1.0, 0.0).is_ok() && ortho(MAX_EXTENT, MAX_EXTENT).is_ok());
        for (half_height, near) in [(0.0, 0.1), (-1.0, 0.1), (f32::NAN, 0.1), (f32::INFINITY, 0.1), (2e15, 0.1), (1.0, -0.1), (1.0, f32::NAN), (1.0, 2e15)] {
            assert!(ortho(half_height, near).is_err(), "{half_height} {near}");
        }
        let clipped = |clip| Camera::with_projection("c".into(), &Mat4::IDENTITY, Projection::Perspective { yfov: 1.0 }, None, clip);
        for clip in [[1.0, 1.0], [1.0, 0.5], [0.1, f32::NAN], [f32::NAN, 1.0]] {
            assert!(clipped(clip).unwrap_err().contains("camera 'c'"), "{clip:?}");
        }
        let mut cam = clipped([0.1, 100.0]).unwrap();
        let good = Aperture { radius: 0.01, focus_distance: 2.0, blades: 0, rotation: 0.0, ratio: 1.0 };
        assert!(cam.set_lens(Vec2::new(0.2, -0.1), Some(good), None).is_ok());
        let bad = [
            Aperture { radius: -1.0, ..good },
            Aperture { radius: f32::NAN, ..good },
            Aperture { focus_distance: 0.0, ..good },
            Aperture { focus_distance: f32::INFINITY, ..good },
            Aperture { blades: 100_000, ..good },
            Aperture { rotation: f32::NAN, ..good },
            Aperture { ratio: 0.0, ..good },
            Aperture { ratio: f32::INFINITY, ..good },
        ];
        for a in bad {
            assert!(cam.set_lens(Vec2::ZERO, Some(a), None).is_err(), "{a:?}");
        }
        assert!(cam.set_lens(Vec2::new(f32::NAN, 0.0), None, None).is_err() && cam.set_lens(Vec2::new(0.0, 1e4), None, None).is_err());
        // A closed aperture is no aperture.
        cam.set_lens(Vec2::ZERO, Some(Aperture { radius: 0.0, ..good }), None).unwrap();
        assert!(cam.aperture.is_none());
    }

    /// A panorama with an aperture focuses every ray of an image point on
    /// one point, at the focus distance along its pinhole ray, from points
    /// of the aperture set across that ray; without one, every ray leaves
    /// the camera's centre. Straight ahead (a fisheye's centre) too.
    #[test]
    fn a_panoramas_rays_focus_at_the_focus_distance() {
        use crate::panorama::Panorama;
        let aperture = Aperture { radius: 0.2, focus_distance: 3.0, blades: 6, rotation: 0.2, ratio: 1.3 };
        for panorama in [Panorama::FisheyeEquidistant { fov: 3.0 }, Panorama::Mirrorball {}, Panorama::Equirectangular { latitude: [-1.5, 1.5], longitude: [-3.0, 3.0] }] {
            let mut cam = turned_camera([0.0, f32::INFINITY], Vec2::ZERO, None);
            cam.set_lens(Vec2::ZERO, Some(aperture), Some(panorama)).unwrap();
            let lens = cam.lens(64, 48);
            assert!(lens.has_aperture() && !lens.pinhole() && !lens.joinable());
            let mut rng = crate::rng::Rng::new(5, 2);
            for pixel in [Vec2::new(32.0, 24.0), Vec2::new(20.3, 30.7), Vec2::new(40.1, 10.2)] {
                let mut pinhole = cam.clone();
                pinhole.aperture = None;
                let centre = pinhole.lens(64, 48).ray(pixel, Vec2::ZERO).unwrap();
                assert_eq!(centre.origin, cam.position);
                let focus = centre.origin + centre.dir * 3.0;
                for _ in 0..50 {
                    let ray = lens.ray(pixel, rng.next_2d()).unwrap();
                    let off = ray.origin - cam.position;
                    assert!(off.length() <= 0.2 * 1.0001 && off.dot(centre.dir).abs() < 1e-5, "{panorama:?} {pixel}: {off}");
                    let t = (focus - ray.origin).length();
                    assert!((ray.origin + ray.dir * t - focus).length() < 1e-4 && (ray.dir.length() - 1.0).abs() < 1e-5, "{panorama:?} {pixel}");
                }
            }
        }
    }

    /// An orthographic camera's rays all look down −Z, from the near plane
    /// on, over a view `2·half_height` tall and as wide as the image's aspect
    /// makes it; a point projects onto it along its one direction.
    #[test]
    fn orthographic_rays_are_parallel_from_the_near_plane() {
        let world = Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0));
        let cam = Camera::with_projection("o".into(), &world, Projection::Orthographic { half_height: 1.5 }, None, [0.25, 10.0]).unwrap();
        let lens = cam.lens(200, 100);
        assert!(!lens.pinhole() && lens.joinable());
        for (pixel, expected) in [((0.0, 0.0), (-3.0, 1.5)), ((200.0, 100.0), (3.0, -1.5)), ((100.0, 50.0), (0.0, 0.0)), ((150.0, 25.0), (1.5, 0.75))] {
            let ray = lens.ray(Vec2::new(pixel.0, pixel.1), Vec2::ZERO).unwrap();
            assert_eq!((ray.dir, ray.tmin, ray.tmax), (Vec3::NEG_Z, 0.25, 10.0));
            let want = Vec3::new(1.0 + expected.0, 2.0 + expected.1, 3.0);
            assert!((ray.origin - want).length() < 1e-6, "{pixel:?}: {} against {want}", ray.origin);
        }
        // A point is seen along −forward, from where on the image plane the
        // ray through it starts, at its depth, beyond Clip Start only.
        let seen = lens.project(Vec3::new(2.5, 2.75, -1.0), Vec2::ZERO, 0.0).unwrap();
        let ray = lens.ray(Vec2::new(150.0, 25.0), Vec2::ZERO).unwrap();
        assert_eq!((seen.pixel, seen.to_camera, seen.distance, seen.skipped), (Some(25 * 200 + 150), Vec3::Z, 4.0, 0.25));
        assert!((seen.lens_point - ray.origin).length() < 1e-5, "{} {}", seen.lens_point, ray.origin);
        assert!(lens.project(Vec3::new(1.0, 2.0, 2.9), Vec2::ZERO, 0.0).is_none() && lens.project(Vec3::new(1.0, 2.0, -7.5), Vec2::ZERO, 0.0).is_none());
        // A pixel is 0.03 × 0.03 m: its samples land at 1/A per unit area.
        assert_eq!(seen.density, CameraDensity::PerArea(1.0 / (0.03 * 0.03)));
        assert!(Camera::from_world("p".into(), &world, 1.0, None).unwrap().lens(64, 64).pinhole());
    }
}
