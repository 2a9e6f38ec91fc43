//! The light list: emissive triangles and punctual lights, picked with
//! probability proportional to their power (luminance-weighted watts: π·A·Le
//! for a triangle, see punctual.rs for the others). A triangle is then
//! sampled uniformly, so a point x' on an emitter of radiance Le has area
//! density pdf_A = π·lum(Le) / P_total: the same for every point of every
//! emitter of that radiance, so it depends on the material.

use crate::bsdf::luminance;
use crate::sampling::{uniform_triangle, Distribution1D};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

pub struct Lights {
    /// Scene triangle index of each emitter; the distribution's entries
    /// are these, then the scene's punctual lights.
    pub triangles: Vec<u32>,
    distribution: Distribution1D,
    /// Σ of the lights' powers (luminance-weighted watts).
    total_power: f64,
    /// Probability of picking the World (the distribution's last entry); 0
    /// when it is black.
    pub world_probability: f32,
    /// The scene's punctual lights that have a size, which rays can hit.
    pub sized: Vec<usize>,
}

/// What light sampling picked.
pub enum LightChoice {
    Area(LightSample),
    /// Scene punctual light `index`, picked with this probability.
    Punctual { index: usize, probability: f32 },
    /// The World (environment.rs), picked with this probability.
    World { probability: f32 },
}

/// A point on an emitter.
pub struct LightSample {
    pub triangle: u32,
    pub b1: f32,
    pub b2: f32,
    pub point: Vec3,
    /// Unit face normal of the emitter (its front side).
    pub normal: Vec3,
    /// Area density of this point.
    pub pdf_area: f32,
}

impl Lights {
    pub fn new(scene: &Scene) -> Self {
        let (triangles, mut powers): (Vec<u32>, Vec<f64>) = scene
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| (i as u32, std::f64::consts::PI * t.area() as f64 * luminance(scene.materials[t.material as usize].emission) as f64))
            .filter(|&(_, power)| power > 0.0)
            .unzip();
        let world = scene.has_world();
        if world || !scene.punctual.is_empty() {
            let radius = scene_radius(scene);
            powers.extend(scene.punctual.iter().map(|l| l.power(radius)));
            if world {
                // What crosses the scene's bounding sphere from a World of
                // that mean radiance: π·(πr²)·L.
                powers.push(std::f64::consts::PI * std::f64::consts::PI * (radius as f64).powi(2) * luminance(scene.world_mean()) as f64);
            }
        }
        let distribution = Distribution1D::new(powers);
        let world_probability = if world && !distribution.is_empty() { distribution.probability(distribution.len() - 1) as f32 } else { 0.0 };
        let sized = scene.punctual.iter().enumerate().filter(|(_, l)| l.size > 0.0).map(|(i, _)| i).collect();
        Lights { total_power: distribution.total(), triangles, distribution, world_probability, sized }
    }

    pub fn is_empty(&self) -> bool {
        self.distribution.is_empty()
    }

    /// Area density of every point on an emitter of radiance `le`.
    pub fn pdf_area(&self, le: Vec3) -> f32 {
        if self.total_power > 0.0 { (std::f64::consts::PI * luminance(le) as f64 / self.total_power) as f32 } else { 0.0 }
    }

    /// The probability `sample` picks scene punctual light `index`.
    pub fn punctual_probability(&self, index: usize) -> f32 {
        self.distribution.probability(self.triangles.len() + index) as f32
    }

    pub fn sample(&self, scene: &Scene, u_pick: f32, u: Vec2) -> Option<LightChoice> {
        if self.is_empty() {
            return None;
        }
        let pick = self.distribution.sample(u_pick);
        if self.world_probability > 0.0 && pick == self.distribution.len() - 1 {
            return Some(LightChoice::World { probability: self.world_probability });
        }
        if pick >= self.triangles.len() {
            let probability = self.distribution.probability(pick) as f32;
            return (probability > 0.0).then_some(LightChoice::Punctual { index: pick - self.triangles.len(), probability });
        }
        let triangle = self.triangles[pick];
        let tri = &scene.triangles[triangle as usize];
        let b = uniform_triangle(u);
        let point = tri.p[0] * (1.0 - b.x - b.y) + tri.p[1] * b.x + tri.p[2] * b.y;
        let normal = tri.cross().normalize();
        let pdf_area = self.pdf_area(scene.materials[tri.material as usize].emission);
        Some(LightChoice::Area(LightSample { triangle, b1: b.x, b2: b.y, point, normal, pdf_area }))
    }
}

/// Radius of a sphere about the bounds' centre that holds every surface,
/// where the sun's and the World's power is counted (at least 1 m).
fn scene_radius(scene: &Scene) -> f32 {
    let (lo, hi) = crate::scene::bounds(&scene.triangles);
    if lo.x > hi.x { 1.0 } else { (0.5 * (hi - lo).length()).max(1.0) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::material::Material;
    use crate::scene::Triangle;

    #[test]
    fn emitters_are_picked_by_power_and_the_density_integrates_to_one() {
        let tri = |x: f32, material: u32| Triangle {
            p: [Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)],
            n: [Vec3::Z; 3],
            material,
        };
        let m = |le: f32| Material { emission: Vec3::splat(le), ..Material::default() };
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let scene = Scene::new(vec![tri(0.0, 0), tri(2.0, 1), tri(4.0, 2)], vec![m(1.0), m(3.0), m(0.0)], camera);
        let lights = Lights::new(&scene);
        assert_eq!(lights.triangles, vec![0, 1]);
        // ∫ pdf_A dA over the emitters = Σ pdf_A(Le_i) A_i = 1.
        let total: f32 = [0, 1].iter().map(|&i| lights.pdf_area(scene.materials[i].emission) * 0.5).sum();
        // (pdf_A includes the π of π·A·Le; the density over area sums to 1.)
        assert!((total - 1.0).abs() < 1e-6);
        let mut counts = [0u32; 2];
        for k in 0..4000 {
            let Some(LightChoice::Area(s)) = lights.sample(&scene, (k as f32 + 0.5) / 4000.0, Vec2::splat(0.3)) else { panic!("no light") };
            counts[s.triangle as usize] += 1;
        }
        assert_eq!(counts, [1000, 3000]);
    }
}
