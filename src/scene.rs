//! The renderable scene: world-space triangles, materials and a camera.
//! World space is glTF's: metres, Y up, right-handed.

use crate::camera::Camera;
use crate::material::Material;
use crate::punctual::PunctualLight;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Triangle {
    /// World positions, counter-clockwise seen from the front face.
    pub p: [Vec3; 3],
    /// Unit shading normals per vertex (the face normal where the file has none).
    pub n: [Vec3; 3],
    pub material: u32,
}

impl Triangle {
    /// Unnormalised face normal, pointing out of the front face.
    pub fn cross(&self) -> Vec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }

    pub fn area(&self) -> f32 {
        0.5 * self.cross().length()
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub camera: Camera,
    /// Radiance (W·sr⁻¹·m⁻²) arriving from every direction no surface
    /// covers: a plain-colour World. Black by default, as in glTF.
    pub background: Vec3,
    /// Point, spot and sun lights.
    pub punctual: Vec<PunctualLight>,
    /// One line each; the CLI prints them, the daemon logs them.
    pub warnings: Vec<String>,
    /// Materials that reference a texture (not rendered yet: their factors are).
    pub textured_materials: usize,
    /// Bytes of buffer data the loader read or decoded: only what the
    /// chosen scene references.
    pub bytes_read: u64,
}

impl Scene {
    /// A black background and no warnings.
    pub fn new(triangles: Vec<Triangle>, materials: Vec<Material>, camera: Camera) -> Self {
        Scene { triangles, materials, camera, background: Vec3::ZERO, punctual: Vec::new(), warnings: Vec::new(), textured_materials: 0, bytes_read: 0 }
    }

    /// Whether a triangle is lamp geometry rather than a surface.
    pub fn is_lamp(&self, triangle: &Triangle) -> bool {
        self.materials.get(triangle.material as usize).is_some_and(|m| m.lamp)
    }
}
