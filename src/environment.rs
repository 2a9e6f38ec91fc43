//! The World: a uniform colour, or an equirectangular environment image
//! (Blender's Environment Texture) × strength, turned about Blender's Z.
//! Both are lights: sampled by next-event estimation and MIS-weighted
//! against BSDF rays that escape (integrator.rs).
//!
//! Directions: Glint works in glTF's Y-up world; Blender's (and the image's)
//! is Z-up, b = (g.x, −g.z, g.y). The image is looked up as Cycles does:
//! u = ½ − atan2(b.y, b.x)/2π, and the top row is straight up (v measured
//! from the top: θ/π, θ the angle from +Z). The Mapping node's Z rotation
//! turns the lookup direction: b' = Rz(rotation)·b.
//!
//! Sampling: a uniform World by the cosine about the surface's geometric
//! normal (for a Lambertian surface that estimate is exact); an image by
//! texel luminance × sinθ (a 2-D table: rows, then columns in the row),
//! with 1% of the mean weight added to every texel so that bilinear lookups
//! between a bright texel and a black one are still reachable.

use crate::bsdf::luminance;
use crate::sampling::{cosine_hemisphere, Distribution1D, Frame};
use crate::texture::{Encoding, Image, Sampler, Texels, Wrap};
use glam::Vec2;
use crate::Vec3;
use std::f32::consts::PI;
use std::path::Path;

#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    pub image: Image,
    encoding: Encoding,
    pub strength: f32,
    /// Radians about Blender's Z (the Mapping node's rotation).
    pub rotation: f32,
    rows: Distribution1D,
    columns: Vec<Distribution1D>,
    /// Mean radiance over the sphere (for the light's power).
    pub mean: Vec3,
    /// Mean over the sphere of the luminance above lum(mean): the part of
    /// the World light sampling is for (lights.rs).
    pub excess: f32,
}

const SAMPLER: Sampler = Sampler { wrap_s: Wrap::Repeat, wrap_t: Wrap::ClampToEdge, nearest: false };

impl EnvironmentMap {
    /// Read an HDR, EXR, PNG or JPEG file.
    pub fn load(path: &Path, strength: f32, rotation: f32) -> Result<Self, String> {
        if !(strength.is_finite() && strength >= 0.0 && rotation.is_finite()) {
            return Err("environment strength must be ≥ 0 and rotation finite".into());
        }
        let bytes = std::fs::read(path).map_err(|e| format!("environment image '{}': {e}", path.display()))?;
        let image = crate::loader::decode_image(&bytes, &path.display().to_string()).map_err(|e| format!("environment image '{}': {e}", path.display()))?;
        Ok(Self::new(image, strength, rotation))
    }

    pub fn new(image: Image, strength: f32, rotation: f32) -> Self {
        // 8-bit images are sRGB colour, as Blender reads them; float ones linear.
        let encoding = if matches!(image.texels, Texels::Rgba8(_)) { Encoding::Srgb } else { Encoding::Linear };
        let (w, h) = (image.width, image.height);
        let mut weights = vec![0.0f64; (w * h) as usize];
        let mut mean = Vec3::ZERO.as_dvec3();
        let sin_thetas: Vec<f32> = (0..h).map(|y| (PI * (y as f32 + 0.5) / h as f32).sin()).collect();
        for (y, &sin_theta) in (0..h).zip(&sin_thetas) {
            for x in 0..w {
                let c = Vec3::from_vec4(image.texel(x, y, encoding));
                let c = if c.is_finite() { c.max(Vec3::ZERO) } else { Vec3::ZERO };
                weights[(y * w + x) as usize] = (luminance(c) * sin_theta) as f64;
                mean += (c * sin_theta).as_dvec3();
            }
        }
        // ∫ sinθ dθ dφ over the texels = 4π; each texel spans (π/h)(2π/w).
        let per_texel = 2.0 * std::f64::consts::PI * std::f64::consts::PI / (w as f64 * h as f64) / (4.0 * std::f64::consts::PI);
        let mean_luminance = luminance((mean * per_texel).as_vec3a());
        // weights hold lum·sinθ.
        let excess: f64 = weights
            .chunks(w as usize)
            .zip(&sin_thetas)
            .map(|(row, &sin_theta)| row.iter().map(|&v| (v - (mean_luminance * sin_theta) as f64).max(0.0)).sum::<f64>())
            .sum();
        let excess = (excess * per_texel) as f32 * strength;
        let mean = (mean * per_texel).as_vec3a() * strength;
        let floor = 0.01 * weights.iter().sum::<f64>() / weights.len() as f64;
        let floor = if floor > 0.0 { floor } else { 1.0 };
        let columns: Vec<Distribution1D> = weights.chunks(w as usize).map(|row| Distribution1D::new(row.iter().map(|v| v + floor))).collect();
        let rows = Distribution1D::new(columns.iter().map(|c| c.total()));
        EnvironmentMap { image, encoding, strength, rotation, rows, columns, mean, excess }
    }

    fn blender_direction(&self, g: Vec3) -> Vec3 {
        let b = Vec3::new(g.x, -g.z, g.y);
        let (s, c) = self.rotation.sin_cos();
        Vec3::new(c * b.x - s * b.y, s * b.x + c * b.y, b.z)
    }

    fn gltf_direction(&self, b: Vec3) -> Vec3 {
        let (s, c) = (-self.rotation).sin_cos();
        let b = Vec3::new(c * b.x - s * b.y, s * b.x + c * b.y, b.z);
        Vec3::new(b.x, b.z, -b.y)
    }

    /// Image coordinates (top row v = 0) of a unit direction.
    pub fn uv(&self, dir: Vec3) -> Vec2 {
        let b = self.blender_direction(dir);
        Vec2::new(0.5 - b.y.atan2(b.x) / (2.0 * PI), b.z.clamp(-1.0, 1.0).acos() / PI)
    }

    fn direction(&self, uv: Vec2) -> Vec3 {
        let phi = 2.0 * PI * (0.5 - uv.x);
        let theta = PI * uv.y;
        self.gltf_direction(Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()))
    }

    /// Radiance arriving from direction `dir` (W·sr⁻¹·m⁻²).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let c = Vec3::from_vec4(self.image.sample(self.uv(dir), SAMPLER, self.encoding)) * self.strength;
        if c.is_finite() { c.max(Vec3::ZERO) } else { Vec3::ZERO }
    }

    /// A direction by the sampling table, and its solid-angle pdf.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (row, v) = self.rows.sample_remapped(u.y);
        let (col, uu) = self.columns[row].sample_remapped(u.x);
        let uv = Vec2::new((col as f32 + uu) / self.image.width as f32, (row as f32 + v) / self.image.height as f32);
        let dir = self.direction(uv);
        // The pdf of the direction as `pdf` sees it (not of the texel drawn):
        // rounding can put a sample on its neighbour's side of a texel
        // edge, and MIS must weigh this sample with what an escaping ray in
        // the same direction is weighed with.
        let pdf = self.pdf(dir);
        (pdf > 0.0 && dir.is_finite()).then_some((dir, pdf))
    }

    /// Solid-angle pdf of `sample` producing `dir`: the texel's share of
    /// the table over its solid angle, (2π/w)(π/h) sinθ.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let uv = self.uv(dir);
        let (w, h) = (self.image.width, self.image.height);
        let x = ((uv.x.rem_euclid(1.0) * w as f32) as usize).min(w as usize - 1);
        let y = ((uv.y * h as f32) as usize).min(h as usize - 1);
        let sin_theta = (PI * uv.y).sin();
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        let share = (self.columns[y].probability(x) * self.rows.probability(y)) as f32;
        share * (w * h) as f32 / (2.0 * PI * PI * sin_theta)
    }
}

/// A direction for a uniform World: cosine-distributed about `ng`.
pub fn sample_uniform(ng: Vec3, u: Vec2) -> (Vec3, f32) {
    let local = cosine_hemisphere(u);
    (Frame::from_normal(ng).to_world(local), local.z / PI)
}

/// The pdf of `sample_uniform` for `dir`.
pub fn uniform_pdf(ng: Vec3, dir: Vec3) -> f32 {
    dir.dot(ng).max(0.0) / PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A 16 × 8 float map: one bright texel on a dim background.
    fn map(rotation: f32) -> EnvironmentMap {
        let mut texels = vec![[0.1f32, 0.2, 0.3, 1.0]; 16 * 8];
        texels[2 * 16 + 5] = [50.0, 40.0, 30.0, 1.0];
        EnvironmentMap::new(Image { name: "env".into(), width: 16, height: 8, texels: Texels::RgbaF32(texels) }, 2.0, rotation)
    }

    #[test]
    fn directions_and_image_coordinates_round_trip() {
        let m = map(0.7);
        let mut rng = Rng::new(3, 3);
        for _ in 0..1000 {
            let uv = Vec2::new(rng.next_f32(), rng.next_f32() * 0.98 + 0.01);
            let back = m.uv(m.direction(uv));
            assert!((back - uv).length() < 1e-4 || (back.x - uv.x).abs() > 0.999, "{uv} → {back}");
        }
        // glTF +Y is Blender's +Z: the top row.
        assert!(map(0.0).uv(Vec3::Y).y < 1e-6);
        // Blender +X (glTF +X) is the image's centre column (Cycles' mapping).
        assert!((map(0.0).uv(Vec3::X).x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn the_pdf_integrates_to_one_and_sampling_follows_it() {
        let m = map(0.3);
        let mut rng = Rng::new(5, 6);
        // E over uniform directions of pdf·4π = 1.
        let n = 400_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = 2.0 * PI * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            sum += (m.pdf(Vec3::new(r * phi.cos(), z, r * phi.sin())) * 4.0 * PI) as f64;
        }
        assert!((sum / n as f64 - 1.0).abs() < 0.02, "{}", sum / n as f64);
        // Samples land on the bright texel about as often as its share says.
        let bright = Vec2::new(5.5 / 16.0, 2.5 / 8.0);
        let hits = (0..100_000).filter_map(|_| m.sample(rng.next_2d())).filter(|(d, _)| ((m.uv(*d) - bright) * Vec2::new(16.0, 8.0)).abs().max_element() < 0.5).count();
        let share = m.columns[2].probability(5) * m.rows.probability(2);
        assert!((hits as f64 / 1e5 - share).abs() < 0.01, "{hits} vs {share}");
        // Every sample's pdf is the pdf of its direction.
        for _ in 0..1000 {
            let (d, pdf) = m.sample(rng.next_2d()).unwrap();
            assert!((pdf - m.pdf(d)).abs() <= 1e-3 * pdf, "{pdf} vs {}", m.pdf(d));
        }
    }

    #[test]
    fn strength_scales_and_the_mean_is_over_the_sphere() {
        let uniform = EnvironmentMap::new(Image { name: "u".into(), width: 8, height: 4, texels: Texels::RgbaF32(vec![[0.5; 4]; 32]) }, 3.0, 0.0);
        assert!((uniform.radiance(Vec3::new(0.3, 0.5, -0.8).normalize()) - Vec3::splat(1.5)).abs().max_element() < 1e-6);
        // Σ sinθ·Δθ·Δφ over 4 rows is within 3% of 4π (midpoint rule).
        assert!((uniform.mean - Vec3::splat(1.5)).abs().max_element() < 0.05, "{}", uniform.mean);
    }

    #[test]
    fn the_excess_is_the_mean_luminance_above_the_mean() {
        let uniform = EnvironmentMap::new(Image { name: "u".into(), width: 8, height: 4, texels: Texels::RgbaF32(vec![[0.5; 4]; 32]) }, 3.0, 0.0);
        assert!(uniform.excess.abs() < 1e-6, "{}", uniform.excess);
        // Radiance 2 above the horizon, 0 below: mean 1, and 1 above it over
        // half the sphere. Rows straddle no horizon, so the midpoint rule's
        // rows cover each half by the same weight.
        let (w, h) = (16u32, 64u32);
        let texels = (0..w * h).map(|i| if i / w < h / 2 { [2.0, 2.0, 2.0, 1.0] } else { [0.0; 4] }).collect();
        let half = EnvironmentMap::new(Image { name: "h".into(), width: w, height: h, texels: Texels::RgbaF32(texels) }, 1.0, 0.0);
        assert!((half.mean.x - 1.0).abs() < 1e-3 && (half.excess - 0.5).abs() < 1e-3, "{} {}", half.mean, half.excess);
    }

    #[test]
    fn uniform_sampling_is_cosine_about_the_normal() {
        let n = Vec3::new(0.0, 1.0, 0.0);
        let (d, pdf) = sample_uniform(n, Vec2::new(0.3, 0.6));
        assert!((pdf - uniform_pdf(n, d)).abs() < 1e-6 && d.dot(n) > 0.0);
        assert_eq!(uniform_pdf(n, -n), 0.0);
    }
}
