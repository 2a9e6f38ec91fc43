//! The light list: emissive triangles, picked with probability proportional
//! to area and sampled uniformly on their surface, so a point x' on the
//! emitters has area density pdf_A = 1 / A_total.

use crate::sampling::{uniform_triangle, Distribution1D};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

pub struct Lights {
    /// Scene triangle index of each emitter.
    pub triangles: Vec<u32>,
    distribution: Distribution1D,
}

/// A point on an emitter.
pub struct LightSample {
    pub triangle: u32,
    pub b1: f32,
    pub b2: f32,
    pub point: Vec3,
    /// Unit face normal of the emitter (its front side).
    pub normal: Vec3,
    /// Area density of this point, 1 / A_total.
    pub pdf_area: f32,
}

impl Lights {
    pub fn new(scene: &Scene) -> Self {
        let triangles: Vec<u32> = scene
            .triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| scene.materials[t.material as usize].is_emissive())
            .map(|(i, _)| i as u32)
            .collect();
        let distribution = Distribution1D::new(triangles.iter().map(|&i| scene.triangles[i as usize].area() as f64));
        Lights { triangles, distribution }
    }

    pub fn is_empty(&self) -> bool {
        self.distribution.is_empty()
    }

    pub fn total_area(&self) -> f64 {
        self.distribution.total()
    }

    /// Area density of every point on the emitters, 1 / A_total.
    pub fn pdf_area(&self) -> f32 {
        (1.0 / self.total_area()) as f32
    }

    pub fn sample(&self, scene: &Scene, u_pick: f32, u: Vec2) -> Option<LightSample> {
        if self.is_empty() {
            return None;
        }
        let triangle = self.triangles[self.distribution.sample(u_pick)];
        let tri = &scene.triangles[triangle as usize];
        let b = uniform_triangle(u);
        let point = tri.p[0] * (1.0 - b.x - b.y) + tri.p[1] * b.x + tri.p[2] * b.y;
        let normal = tri.cross().normalize();
        Some(LightSample { triangle, b1: b.x, b2: b.y, point, normal, pdf_area: self.pdf_area() })
    }
}
