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
//! normal (for a Lambertian surface that estimate is exact); an image by a
//! 2-D table over its texels (rows, then columns in the row), each texel
//! weighted by the most luminance a bilinear lookup inside it can return
//! (`cell_bounds`) × sinθ. With MIS the weight is that bound's excess over
//! the mean luminance, max(b − lum(L̄), 0)·sinθ (Karlík et al. 2019, MIS
//! compensation): BSDF samples already find the even part of the light,
//! so light samples go where the sky is brighter than that — the sun, not
//! the whole sky — and a texel at or below the mean is left to BSDF
//! samples alone. Without MIS only light samples see the World and the
//! weight is the whole bound; that table is built when a render first
//! asks for it.

use crate::bsdf::luminance;
use crate::sampling::{cosine_hemisphere, Distribution1D, Frame};
use crate::texture::{Encoding, Image, Sampler, Texels, Wrap};
use glam::Vec2;
use crate::Vec3;
use std::f32::consts::PI;
use std::path::Path;
use std::sync::OnceLock;

#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    pub image: Image,
    encoding: Encoding,
    pub strength: f32,
    /// Radians about Blender's Z (the Mapping node's rotation).
    pub rotation: f32,
    /// Light sampling with MIS: texels by their luminance bound above the
    /// mean; None where no texel is above it (an even World).
    above_mean: Option<Table>,
    /// Light sampling without MIS, and of an even World that is the only
    /// light: every texel by its luminance bound.
    whole: OnceLock<Option<Table>>,
    /// Mean radiance over the sphere (for the light's power).
    pub mean: Vec3,
    /// Mean over the sphere of the luminance above lum(mean): the part of
    /// the World light sampling is for (lights.rs).
    pub excess: f32,
    /// Its brightest texel's largest channel, × strength (job.rs bounds it).
    pub brightest: f32,
}

const SAMPLER: Sampler = Sampler { wrap_s: Wrap::Repeat, wrap_t: Wrap::ClampToEdge, nearest: false };

/// A texel's radiance before strength: finite and non-negative.
fn texel_radiance(image: &Image, encoding: Encoding, x: u32, y: u32) -> Vec3 {
    let c = Vec3::from_vec4(image.texel(x, y, encoding));
    if c.is_finite() { c.max(Vec3::ZERO) } else { Vec3::ZERO }
}

/// Every texel's luminance, row by row.
fn texel_luminances(image: &Image, encoding: Encoding) -> Vec<f32> {
    let mut out = Vec::with_capacity(image.width as usize * image.height as usize);
    for y in 0..image.height {
        out.extend((0..image.width).map(|x| luminance(texel_radiance(image, encoding, x, y))));
    }
    out
}

/// The most a bilinear lookup within each texel's cell can return: the
/// largest luminance of the texel and its eight neighbours (wrapping
/// across u, clamped at the poles, as `SAMPLER` reads). A table weighted
/// by the texel's own value left the bilinear halo around a small sun —
/// half the sun's radiance, in texels weighted as sky — to BSDF samples
/// at full MIS weight: fireflies of a thousand times the sky's light.
fn cell_bounds(luminances: &[f32], width: usize) -> Vec<f32> {
    let height = luminances.len() / width;
    let mut across = Vec::with_capacity(luminances.len());
    for row in luminances.chunks(width) {
        for x in 0..width {
            let left = if x == 0 { row[width - 1] } else { row[x - 1] };
            let right = if x + 1 == width { row[0] } else { row[x + 1] };
            across.push(left.max(row[x]).max(right));
        }
    }
    let mut bounds = Vec::with_capacity(luminances.len());
    for y in 0..height {
        let (up, down) = (y.saturating_sub(1) * width, (y + 1).min(height - 1) * width);
        for x in 0..width {
            bounds.push(across[up + x].max(across[y * width + x]).max(across[down + x]));
        }
    }
    bounds
}

/// A sampling table over an image's texels: a row by its sum, then a
/// column within the row.
#[derive(Clone, Debug)]
struct Table {
    rows: Distribution1D,
    columns: Vec<Distribution1D>,
}

impl Table {
    /// Texels weighted by how far their luminance bound (`cell_bounds`)
    /// rises above `level`, × sinθ (their solid angle); None where none
    /// does.
    fn above(bounds: &[f32], level: f32, width: usize) -> Option<Self> {
        let sin_thetas = EnvironmentMap::sin_thetas((bounds.len() / width) as u32);
        let columns: Vec<Distribution1D> = bounds.chunks(width).zip(&sin_thetas).map(|(row, &s)| Distribution1D::new(row.iter().map(|&b| ((b - level) * s).max(0.0) as f64))).collect();
        let rows = Distribution1D::new(columns.iter().map(|c| c.total()));
        (!rows.is_empty()).then_some(Table { rows, columns })
    }

    /// A texel (column, row) and where in it, each in [0, 1).
    fn sample(&self, u: Vec2) -> (usize, usize, Vec2) {
        let (row, v) = self.rows.sample_remapped(u.y);
        let (column, uu) = self.columns[row].sample_remapped(u.x);
        (column, row, Vec2::new(uu, v))
    }

    /// The probability of texel (x, y); 0 in a row of no weight.
    fn probability(&self, x: usize, y: usize) -> f64 {
        let row = self.rows.probability(y);
        if row > 0.0 { row * self.columns[y].probability(x) } else { 0.0 }
    }
}

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
        // One pass over the texels (decoding them was most of the time a
        // 4k map took to load): the mean, and each texel's luminance.
        let mut mean = Vec3::ZERO.as_dvec3();
        let mut luminances = Vec::with_capacity((w * h) as usize);
        let mut brightest = 0.0f32;
        let sin_thetas = Self::sin_thetas(h);
        for (y, &sin_theta) in (0..h).zip(&sin_thetas) {
            for x in 0..w {
                let c = texel_radiance(&image, encoding, x, y);
                brightest = brightest.max(c.max_element());
                mean += (c * sin_theta).as_dvec3();
                luminances.push(luminance(c));
            }
        }
        // ∫ sinθ dθ dφ over the texels = 4π; each texel spans (π/h)(2π/w).
        let per_texel = 2.0 * std::f64::consts::PI * std::f64::consts::PI / (w as f64 * h as f64) / (4.0 * std::f64::consts::PI);
        let mean_luminance = luminance((mean * per_texel).as_vec3a());
        let excess: f64 = luminances.chunks(w as usize).zip(&sin_thetas).map(|(row, &s)| row.iter().map(|&l| ((l - mean_luminance) * s).max(0.0) as f64).sum::<f64>()).sum();
        let above_mean = if excess > 0.0 { Table::above(&cell_bounds(&luminances, w as usize), mean_luminance, w as usize) } else { None };
        let excess = (excess * per_texel) as f32 * strength;
        let mean = (mean * per_texel).as_vec3a() * strength;
        EnvironmentMap { image, encoding, strength, rotation, above_mean, whole: OnceLock::new(), mean, excess, brightest: brightest * strength }
    }

    /// Each row's mean sinθ over its span Δθ = π/h, (cosθ₀ − cosθ₁)/Δθ:
    /// its solid angle, 2π·Δθ·that, exactly. sinθ at the row's centre
    /// is the same on a fine map, but a one-row map's is 1 where the mean
    /// is 2/π, and its mean radiance came out π/2 times too bright.
    fn sin_thetas(height: u32) -> Vec<f32> {
        let h = height as f64;
        let cos = |y: u32| (std::f64::consts::PI * y as f64 / h).cos();
        (0..height).map(|y| ((cos(y) - cos(y + 1)) * h / std::f64::consts::PI) as f32).collect()
    }

    /// The table light samples draw from: above the mean with MIS where
    /// some texel is, else the whole one (built on first use; None for a
    /// black image).
    fn table(&self, mis: bool) -> Option<&Table> {
        match (&self.above_mean, mis) {
            (Some(table), true) => Some(table),
            _ => self
                .whole
                .get_or_init(|| {
                    let w = self.image.width as usize;
                    Table::above(&cell_bounds(&texel_luminances(&self.image, self.encoding), w), 0.0, w)
                })
                .as_ref(),
        }
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

    /// A direction by the sampling table for `mis`, and its solid-angle
    /// pdf.
    pub fn sample(&self, u: Vec2, mis: bool) -> Option<(Vec3, f32)> {
        let (column, row, within) = self.table(mis)?.sample(u);
        let uv = Vec2::new((column as f32 + within.x) / self.image.width as f32, (row as f32 + within.y) / self.image.height as f32);
        let dir = self.direction(uv);
        // The pdf of the direction as `pdf` sees it (not of the texel drawn):
        // rounding can put a sample on its neighbour's side of a texel
        // edge, and MIS must weigh this sample with what an escaping ray in
        // the same direction is weighed with.
        let pdf = self.pdf(dir, mis);
        (pdf > 0.0 && dir.is_finite()).then_some((dir, pdf))
    }

    /// Solid-angle pdf of `sample` producing `dir`: the texel's share of
    /// the table over its solid angle, (2π/w)(π/h) sinθ.
    pub fn pdf(&self, dir: Vec3, mis: bool) -> f32 {
        let uv = self.uv(dir);
        let (w, h) = (self.image.width, self.image.height);
        let x = ((uv.x.rem_euclid(1.0) * w as f32) as usize).min(w as usize - 1);
        let y = ((uv.y * h as f32) as usize).min(h as usize - 1);
        let sin_theta = (PI * uv.y).sin();
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        let share = self.table(mis).map_or(0.0, |t| t.probability(x, y)) as f32;
        share * (w * h) as f32 / (2.0 * PI * PI * sin_theta)
    }
}

/// A direction for a uniform World: cosine-distributed about `ng`, or,
/// for a surface light reaches from both sides (`two_sided`: it
/// transmits), about `ng` or `−ng`, each half the time.
pub fn sample_uniform(ng: Vec3, two_sided: bool, u: Vec2) -> (Vec3, f32) {
    if two_sided {
        let (side, u) = if u.x < 0.5 { (ng, Vec2::new(2.0 * u.x, u.y)) } else { (-ng, Vec2::new((2.0 * u.x - 1.0).min(1.0 - f32::EPSILON), u.y)) };
        let local = cosine_hemisphere(u);
        return (Frame::from_normal(side).to_world(local), local.z / (2.0 * PI));
    }
    let local = cosine_hemisphere(u);
    (Frame::from_normal(ng).to_world(local), local.z / PI)
}

/// The pdf of `sample_uniform` for `dir`.
pub fn uniform_pdf(ng: Vec3, two_sided: bool, dir: Vec3) -> f32 {
    if two_sided { dir.dot(ng).abs() / (2.0 * PI) } else { dir.dot(ng).max(0.0) / PI }
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

    /// Both tables: the pdf integrates to 1 over the sphere, samples land
    /// on the bright texel as often as its share says, and every sample's
    /// pdf is its direction's.
    #[test]
    fn the_pdf_integrates_to_one_and_sampling_follows_it() {
        let m = map(0.3);
        let mut rng = Rng::new(5, 6);
        for mis in [true, false] {
            // E over uniform directions of pdf·4π = 1.
            let n = 400_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let z = 1.0 - 2.0 * rng.next_f32();
                let phi = 2.0 * PI * rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                sum += (m.pdf(Vec3::new(r * phi.cos(), z, r * phi.sin()), mis) * 4.0 * PI) as f64;
            }
            assert!((sum / n as f64 - 1.0).abs() < 0.02, "mis {mis}: {}", sum / n as f64);
            let bright = Vec2::new(5.5 / 16.0, 2.5 / 8.0);
            let hits = (0..100_000).filter_map(|_| m.sample(rng.next_2d(), mis)).filter(|(d, _)| ((m.uv(*d) - bright) * Vec2::new(16.0, 8.0)).abs().max_element() < 0.5).count();
            let share = m.table(mis).unwrap().probability(5, 2);
            assert!((hits as f64 / 1e5 - share).abs() < 0.01, "mis {mis}: {hits} vs {share}");
            for _ in 0..1000 {
                let (d, pdf) = m.sample(rng.next_2d(), mis).unwrap();
                assert!((pdf - m.pdf(d, mis)).abs() <= 1e-3 * pdf, "mis {mis}: {pdf} vs {}", m.pdf(d, mis));
            }
        }
    }

    /// With MIS only texels whose bound is above the mean are
    /// light-sampled: on a dim map with one bright texel, that texel and
    /// the eight around it (its bilinear halo), where the whole table
    /// (without MIS) gives them most of its weight and the rest the dim
    /// texels'. An even map has no table above its mean; a World that is
    /// the only light then draws from the whole table.
    #[test]
    fn with_mis_light_samples_go_where_the_world_is_above_its_mean() {
        let m = map(0.0);
        assert!(m.whole.get().is_none(), "the whole table is built only when asked for");
        let block = |mis: bool| (1..=3).flat_map(|y| (4..=6).map(move |x| (x, y))).map(|(x, y)| m.table(mis).unwrap().probability(x, y)).sum::<f64>();
        assert!((block(true) - 1.0).abs() < 1e-12, "{}", block(true));
        assert!(block(false) > 0.9 && block(false) < 1.0, "{}", block(false));
        let dim = Vec3::new(0.0, 1.0, 0.2).normalize();
        assert_eq!(m.pdf(dim, true), 0.0);
        assert!(m.pdf(dim, false) > 0.0);
        let even = EnvironmentMap::new(Image { name: "u".into(), width: 8, height: 4, texels: Texels::RgbaF32(vec![[0.5; 4]; 32]) }, 1.0, 0.0);
        assert!(even.above_mean.is_none());
        assert!(even.sample(Vec2::splat(0.3), true).is_some_and(|(_, pdf)| pdf > 0.0));
    }

    /// A light sample's radiance over its pdf stays within a few times the
    /// World's mean luminance × 4π in every direction, the bilinear halo
    /// of a tiny bright sun included (away from the poles, where a row's
    /// sinθ varies most): a table weighted by each texel's own value gave
    /// the texels beside the sun half its radiance at a sky texel's
    /// density, 10⁴ × as much.
    #[test]
    fn light_samples_of_a_small_sun_carry_bounded_weights() {
        let (w, h) = (64u32, 32u32);
        let mut texels = vec![[0.2f32, 0.3, 0.5, 1.0]; (w * h) as usize];
        texels[(10 * w + 20) as usize] = [5e4, 5e4, 5e4, 1.0];
        let m = EnvironmentMap::new(Image { name: "sun".into(), width: w, height: h, texels: Texels::RgbaF32(texels) }, 1.0, 0.0);
        let bound = 4.0 * PI * luminance(m.mean) * 9.0;
        let mut rng = Rng::new(7, 7);
        let mut worst = 0.0f32;
        for _ in 0..200_000 {
            let z = 1.8 * rng.next_f32() - 0.9;
            let phi = 2.0 * PI * rng.next_f32();
            let r = (1.0 - z * z).sqrt();
            let dir = Vec3::new(r * phi.cos(), z, r * phi.sin());
            let pdf = m.pdf(dir, false);
            assert!(pdf > 0.0);
            worst = worst.max(luminance(m.radiance(dir)) / pdf);
        }
        assert!(worst < 1.5 * bound, "{worst} against {bound}");
    }

    /// Tiny, black and broken maps (one texel, one row, one column, NaN,
    /// infinite and negative texels) sample without a panic, with finite
    /// directions and pdfs that match them; a black map has nothing to
    /// sample.
    #[test]
    fn degenerate_maps_sample_safely() {
        let cases: [(u32, u32, Vec<[f32; 4]>); 5] = [
            (1, 1, vec![[2.0, 1.0, 0.5, 1.0]]),
            (1, 5, vec![[0.1; 4], [0.1; 4], [9.0; 4], [0.1; 4], [0.1; 4]]),
            (7, 1, (0..7).map(|i| [i as f32; 4]).collect()),
            (4, 2, vec![[f32::NAN; 4], [f32::INFINITY; 4], [-3.0; 4], [1.0; 4], [0.0; 4], [1e30; 4], [0.5; 4], [f32::NEG_INFINITY; 4]]),
            (3, 3, vec![[0.0; 4]; 9]),
        ];
        let mut rng = Rng::new(2, 9);
        for (w, h, texels) in cases {
            let m = EnvironmentMap::new(Image { name: "odd".into(), width: w, height: h, texels: Texels::RgbaF32(texels) }, 1.0, 0.2);
            let black = m.mean == Vec3::ZERO;
            for mis in [true, false] {
                let mut misses = 0;
                for _ in 0..2000 {
                    match m.sample(rng.next_2d(), mis) {
                        Some((d, pdf)) => {
                            assert!(!black && d.is_finite() && pdf.is_finite() && pdf > 0.0, "{w}x{h}: {d} {pdf}");
                            assert!((pdf - m.pdf(d, mis)).abs() <= 1e-3 * pdf, "{w}x{h}");
                        }
                        // A direction that rounds onto a pole (sinθ = 0)
                        // has no density: a measure-zero miss.
                        None => misses += 1,
                    }
                }
                assert!(if black { misses == 2000 } else { misses < 5 }, "{w}x{h} mis {mis}: {misses} of 2000 drew nothing");
                assert!(m.pdf(Vec3::Y, mis).is_finite() && m.radiance(Vec3::new(0.6, -0.8, 0.0)).is_finite());
            }
        }
    }

    #[test]
    fn strength_scales_and_the_mean_is_over_the_sphere() {
        let uniform = EnvironmentMap::new(Image { name: "u".into(), width: 8, height: 4, texels: Texels::RgbaF32(vec![[0.5; 4]; 32]) }, 3.0, 0.0);
        assert!((uniform.radiance(Vec3::new(0.3, 0.5, -0.8).normalize()) - Vec3::splat(1.5)).abs().max_element() < 1e-6);
        // The rows' solid angles are exact: they sum to 4π on 4 rows.
        assert!((uniform.mean - Vec3::splat(1.5)).abs().max_element() < 1e-5, "{}", uniform.mean);
    }

    #[test]
    fn the_excess_is_the_mean_luminance_above_the_mean() {
        let uniform = EnvironmentMap::new(Image { name: "u".into(), width: 8, height: 4, texels: Texels::RgbaF32(vec![[0.5; 4]; 32]) }, 3.0, 0.0);
        assert!(uniform.excess.abs() < 1e-6, "{}", uniform.excess);
        // Radiance 2 above the horizon, 0 below: mean 1, and 1 above it over
        // half the sphere (no row straddles the horizon).
        let (w, h) = (16u32, 64u32);
        let texels = (0..w * h).map(|i| if i / w < h / 2 { [2.0, 2.0, 2.0, 1.0] } else { [0.0; 4] }).collect();
        let half = EnvironmentMap::new(Image { name: "h".into(), width: w, height: h, texels: Texels::RgbaF32(texels) }, 1.0, 0.0);
        assert!((half.mean.x - 1.0).abs() < 1e-3 && (half.excess - 0.5).abs() < 1e-3, "{} {}", half.mean, half.excess);
    }

    #[test]
    fn uniform_sampling_is_cosine_about_the_normal() {
        let n = Vec3::new(0.0, 1.0, 0.0);
        let (d, pdf) = sample_uniform(n, false, Vec2::new(0.3, 0.6));
        assert!((pdf - uniform_pdf(n, false, d)).abs() < 1e-6 && d.dot(n) > 0.0);
        assert_eq!(uniform_pdf(n, false, -n), 0.0);
        // Two-sided: the same densities halved, on both sides.
        for (u, below) in [(0.15, false), (0.65, true)] {
            let (d, pdf) = sample_uniform(n, true, Vec2::new(u, 0.6));
            assert!((pdf - uniform_pdf(n, true, d)).abs() < 1e-6 && (d.dot(n) < 0.0) == below, "{d} {pdf}");
            assert!((pdf - d.dot(n).abs() / (2.0 * PI)).abs() < 1e-6);
        }
    }
}
