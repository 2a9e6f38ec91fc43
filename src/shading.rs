//! A material at one point of one triangle: its factors times its textures
//! and the vertex colour, its emission, its alpha, and its normal map.
//!
//! A material with no textures in a scene with no vertex colours takes its
//! factors as they are: one branch, no UV interpolation.

use crate::material::{AlphaMode, Material, Surface};
use crate::scene::Scene;
use crate::texture::{Encoding, TextureSlot};
use glam::{Vec2, Vec4};
use crate::Vec3;
use std::ops::{Add, Mul};

/// Barycentric weights (b0, b1, b2) of a hit on a triangle.
#[derive(Clone, Copy, Debug)]
pub struct Barycentric(pub [f32; 3]);

impl Barycentric {
    pub fn new(b1: f32, b2: f32) -> Self {
        Barycentric([1.0 - b1 - b2, b1, b2])
    }

    /// The value at this point of a per-corner attribute.
    #[inline]
    pub fn mix<T: Copy + Mul<f32, Output = T> + Add<Output = T>>(&self, v: &[T; 3]) -> T {
        v[0] * self.0[0] + v[1] * self.0[1] + v[2] * self.0[2]
    }
}

fn texture_coordinates(scene: &Scene, triangle: u32, b: Barycentric) -> [Vec2; 2] {
    let uv = &scene.attributes.uv;
    let at = |set: usize| uv[set].get(triangle as usize).map_or(Vec2::ZERO, |c| b.mix(c));
    [at(0), at(1)]
}

fn vertex_color(scene: &Scene, triangle: u32, b: Barycentric) -> Vec4 {
    scene.attributes.color.get(triangle as usize).map_or(Vec4::ONE, |c| b.mix(c))
}

/// Whether anything at this point differs from the material's factors:
/// textures, vertex colours, or an anisotropic lobe's tangent.
#[inline]
pub fn varies(scene: &Scene, m: &Material) -> bool {
    m.textures.is_some() || !scene.attributes.color.is_empty() || m.anisotropy > 0.0
}

/// The surface a BSDF sees at a point.
#[inline]
pub fn surface_at(scene: &Scene, m: &Material, triangle: u32, b: Barycentric) -> Surface {
    let mut s = m.surface();
    if !varies(scene, m) {
        return s;
    }
    if m.anisotropy > 0.0 {
        s.tangent = scene.attributes.anisotropy_tangent.get(triangle as usize).map_or(Vec3::ZERO, |t| b.mix(t));
    }
    s.base_color *= Vec3::from_vec4(vertex_color(scene, triangle, b));
    if let Some(t) = &m.textures {
        let uv = texture_coordinates(scene, triangle, b);
        if let Some(slot) = &t.base_color {
            s.base_color *= Vec3::from_vec4(slot.sample(&scene.images, &uv, Encoding::Srgb));
        }
        if let Some(slot) = &t.metallic_roughness {
            let mr = slot.sample(&scene.images, &uv, Encoding::Linear);
            s.roughness *= mr.y;
            s.metallic *= mr.z;
        }
        if let Some(slot) = &t.transmission {
            s.transmission *= slot.sample(&scene.images, &uv, Encoding::Linear).x;
        }
        if let Some(slot) = &t.coat {
            s.coat *= slot.sample(&scene.images, &uv, Encoding::Linear).x;
        }
        if let Some(slot) = &t.coat_roughness {
            s.coat_roughness *= slot.sample(&scene.images, &uv, Encoding::Linear).y;
        }
        // A normal map bends the layers below the coat, not the coat,
        // which keeps the interpolated normal or is bent by its own map.
        if (t.normal.is_some() || t.coat_normal.is_some()) && m.is_coated() {
            let n = b.mix(&scene.triangles[triangle as usize].n()).normalize_or_zero();
            s.coat_normal = match &t.coat_normal {
                Some((slot, scale)) if n != Vec3::ZERO => normal_mapped(scene, slot, *scale, triangle, b, n),
                _ => n,
            };
        }
    }
    s.base_color = s.base_color.clamp(Vec3::ZERO, Vec3::ONE);
    s.metallic = s.metallic.clamp(0.0, 1.0);
    s.roughness = s.roughness.clamp(0.0, 1.0);
    s.coat = s.coat.clamp(0.0, 1.0);
    s.coat_roughness = s.coat_roughness.clamp(0.0, 1.0);
    s
}

/// Radiance leaving a point of an emitter (W·sr⁻¹·m⁻²): the factor ×
/// strength × the emissive texture.
// Always inline: left to the compiler, a change to camera rays' set-up
// (the pixel filter) put it out of line, 0.6% more instructions on the
// benchmark's gold sphere.
#[inline(always)]
pub fn emission_at(scene: &Scene, m: &Material, triangle: u32, b: Barycentric, front_face: bool) -> Vec3 {
    let le = m.emitted(front_face);
    match m.textures.as_ref().and_then(|t| t.emissive.as_ref()) {
        Some(slot) if le != Vec3::ZERO => le * Vec3::from_vec4(slot.sample(&scene.images, &texture_coordinates(scene, triangle, b), Encoding::Srgb)),
        _ => le,
    }
}

/// Coverage at a point: base colour factor alpha × texture alpha × vertex
/// colour alpha.
fn alpha_at(scene: &Scene, m: &Material, triangle: u32, b: Barycentric) -> f32 {
    let mut a = m.alpha * vertex_color(scene, triangle, b).w;
    if let Some(slot) = m.textures.as_ref().and_then(|t| t.base_color.as_ref()) {
        a *= slot.sample(&scene.images, &texture_coordinates(scene, triangle, b), Encoding::Linear).w;
    }
    a
}

/// Whether a ray stops at this point of a triangle: always for an opaque
/// material; where alpha ≥ cutoff for MASK; with probability alpha for
/// BLEND, drawing `u` only then.
#[inline]
pub fn stops_ray(scene: &Scene, triangle: u32, b1: f32, b2: f32, u: &mut impl FnMut() -> f32) -> bool {
    let tri = &scene.triangles[triangle as usize];
    let m = &scene.materials[tri.material as usize];
    if !m.has_alpha() {
        return true;
    }
    let a = alpha_at(scene, m, triangle, Barycentric::new(b1, b2));
    match m.alpha_mode {
        AlphaMode::Opaque => true,
        AlphaMode::Mask(cutoff) => a >= cutoff,
        AlphaMode::Blend => a >= 1.0 || u() < a,
    }
}

/// The shading normal with the material's normal map applied, from the
/// interpolated vertex normal `n` (unit, front-face orientation): glTF's
/// tangent-space map, n' = normalize(x·T + y·B + z·N) with
/// (x, y, z) = (2·texel − 1)·(scale, scale, 1), B = sign·(N × T) — what
/// Cycles' Normal Map node computes from MikkTSpace tangents.
pub fn mapped_normal(scene: &Scene, m: &Material, triangle: u32, b: Barycentric, n: Vec3) -> Vec3 {
    match m.textures.as_ref().and_then(|t| t.normal.as_ref()) {
        Some((slot, scale)) => normal_mapped(scene, slot, *scale, triangle, b, n),
        None => n,
    }
}

/// `n` bent by the tangent-space normal map in `slot` (`mapped_normal`).
fn normal_mapped(scene: &Scene, slot: &TextureSlot, scale: f32, triangle: u32, b: Barycentric, n: Vec3) -> Vec3 {
    let Some(corners) = scene.attributes.tangent.get(triangle as usize) else { return n };
    let t4 = b.mix(corners);
    let sign = if t4.w < 0.0 { -1.0 } else { 1.0 };
    // Gram-Schmidt: the interpolated tangent is not quite orthogonal to n.
    let t3 = Vec3::from_vec4(t4);
    let t = (t3 - n * n.dot(t3)).normalize_or_zero();
    if t == Vec3::ZERO {
        return n;
    }
    let bitangent = sign * n.cross(t);
    let texel = slot.sample(&scene.images, &texture_coordinates(scene, triangle, b), Encoding::Linear);
    let v = (Vec3::from_vec4(texel) * 2.0 - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
    let mapped = (t * v.x + bitangent * v.y + n * v.z).normalize_or_zero();
    if mapped.is_finite() && mapped != Vec3::ZERO { mapped } else { n }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::material::MaterialTextures;
    use crate::scene::Triangle;
    use crate::texture::{Image, Sampler, TextureSlot, Texels};
    use glam::Mat4;

    /// One triangle with UVs (0,0), (1,0), (0,1), and a 2 × 1 texture.
    fn scene(material: Material, texel: [[u8; 4]; 2]) -> Scene {
        let tri = Triangle::new([Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z; 3], 0);
        let camera = Camera::from_world("c".into(), &Mat4::IDENTITY, 1.0, None).unwrap();
        let mut s = Scene::new(vec![tri], vec![material], camera);
        s.attributes.uv[0] = vec![[Vec2::ZERO, Vec2::X, Vec2::Y]];
        s.attributes.tangent = vec![[Vec4::new(1.0, 0.0, 0.0, 1.0); 3]];
        s.images = vec![Image { name: "t".into(), width: 2, height: 1, texels: Texels::Rgba8(texel.to_vec()) }];
        s
    }

    fn slot() -> TextureSlot {
        TextureSlot { image: 0, sampler: Sampler { nearest: true, ..Sampler::default() }, texcoord: 0, transform: None }
    }

    fn textured(t: MaterialTextures) -> Material {
        Material { textures: Some(Box::new(t)), ..Material::default() }
    }

    #[test]
    fn textures_multiply_the_factors() {
        let mut m = textured(MaterialTextures { base_color: Some(slot()), metallic_roughness: Some(slot()), ..Default::default() });
        m.base_color = Vec3::new(1.0, 0.5, 1.0);
        m.roughness = 0.5;
        // u < ½ reads texel 0, u > ½ texel 1.
        let s = scene(m, [[255, 255, 0, 255], [0, 128, 255, 255]]);
        let left = surface_at(&s, &s.materials[0], 0, Barycentric::new(0.1, 0.1));
        assert_eq!(left.base_color, Vec3::new(1.0, 0.5, 0.0));
        assert_eq!((left.roughness, left.metallic), (0.5, 0.0));
        let right = surface_at(&s, &s.materials[0], 0, Barycentric::new(0.8, 0.1));
        assert!((right.roughness - 0.5 * 128.0 / 255.0).abs() < 1e-6 && right.metallic == 1.0);
    }

    /// KHR_materials_clearcoat's textures: R scales the coat's weight, G
    /// its roughness (one image for both, as Blender's exporter writes).
    #[test]
    fn coat_textures_scale_the_coat_factors() {
        let mut m = textured(MaterialTextures { coat: Some(slot()), coat_roughness: Some(slot()), ..Default::default() });
        (m.coat, m.coat_roughness) = (0.8, 0.5);
        let s = scene(m, [[255, 128, 0, 255], [0, 255, 0, 255]]);
        let left = surface_at(&s, &s.materials[0], 0, Barycentric::new(0.1, 0.1));
        assert!(left.coat == 0.8 && (left.coat_roughness - 0.5 * 128.0 / 255.0).abs() < 1e-6, "{} {}", left.coat, left.coat_roughness);
        let right = surface_at(&s, &s.materials[0], 0, Barycentric::new(0.8, 0.1));
        assert_eq!((right.coat, right.coat_roughness), (0.0, 0.5));
    }

    /// A coat's own normal map bends the coat and not the layers below:
    /// the texel (0.85, 0.5, 0.85) tilts it 45° toward the tangent (+x); the
    /// base keeps the interpolated normal, and so does a coat whose map
    /// is the base's alone.
    #[test]
    fn a_coat_normal_map_bends_the_coat_alone() {
        let coated = |t: MaterialTextures| Material { coat: 1.0, ..textured(t) };
        let s = scene(coated(MaterialTextures { coat_normal: Some((slot(), 1.0)), ..Default::default() }), [[218, 128, 218, 255]; 2]);
        let b = Barycentric::new(0.2, 0.2);
        let coat = surface_at(&s, &s.materials[0], 0, b).coat_normal;
        assert!((coat - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 0.01, "{coat}");
        assert_eq!(mapped_normal(&s, &s.materials[0], 0, b, Vec3::Z), Vec3::Z);
        let s = scene(coated(MaterialTextures { normal: Some((slot(), 1.0)), ..Default::default() }), [[218, 128, 218, 255]; 2]);
        assert_eq!(surface_at(&s, &s.materials[0], 0, b).coat_normal, Vec3::Z);
        assert!(mapped_normal(&s, &s.materials[0], 0, b, Vec3::Z).x > 0.69);
    }

    #[test]
    fn vertex_colours_multiply_base_colour_and_alpha() {
        let mut s = scene(Material { base_color: Vec3::splat(0.5), alpha_mode: AlphaMode::Mask(0.5), ..Material::default() }, [[0; 4]; 2]);
        s.attributes.color = vec![[Vec4::new(1.0, 0.0, 0.0, 1.0), Vec4::new(1.0, 0.0, 0.0, 0.0), Vec4::new(1.0, 0.0, 0.0, 1.0)]];
        let at = surface_at(&s, &s.materials[0], 0, Barycentric::new(0.2, 0.2));
        assert_eq!(at.base_color, Vec3::new(0.5, 0.0, 0.0));
        let mut never = || panic!("MASK draws no random number");
        assert!(stops_ray(&s, 0, 0.2, 0.2, &mut never));
        assert!(!stops_ray(&s, 0, 0.8, 0.1, &mut never), "alpha 0.2 < cutoff 0.5");
    }

    #[test]
    fn blend_lets_rays_through_with_probability_one_minus_alpha() {
        let m = Material { alpha: 0.25, alpha_mode: AlphaMode::Blend, ..Material::default() };
        let s = scene(m, [[0; 4]; 2]);
        let mut rng = crate::rng::Rng::new(1, 1);
        let n = 100_000;
        let stops = (0..n).filter(|_| stops_ray(&s, 0, 0.3, 0.3, &mut || rng.next_f32())).count();
        assert!((stops as f32 / n as f32 - 0.25).abs() < 0.005, "{stops}");
    }

    #[test]
    fn emissive_texture_scales_emission() {
        let mut m = textured(MaterialTextures { emissive: Some(slot()), ..Default::default() });
        m.emission = Vec3::splat(2.0);
        let s = scene(m, [[255, 0, 255, 255], [0; 4]]);
        assert_eq!(emission_at(&s, &s.materials[0], 0, Barycentric::new(0.1, 0.1), true), Vec3::new(2.0, 0.0, 2.0));
        assert_eq!(emission_at(&s, &s.materials[0], 0, Barycentric::new(0.1, 0.1), false), Vec3::ZERO);
    }

    #[test]
    fn normal_map_tilts_the_normal_toward_the_tangent() {
        let flat = [128u8, 128, 255, 255];
        // x = 1, z = 0.5: tilted toward +T (= +X) by atan(2).
        let tilted = [255u8, 128, 191, 255];
        let m = textured(MaterialTextures { normal: Some((slot(), 1.0)), ..Default::default() });
        let s = scene(m, [flat, tilted]);
        let n = |b1| mapped_normal(&s, &s.materials[0], 0, Barycentric::new(b1, 0.1), Vec3::Z);
        assert!((n(0.1) - Vec3::Z).length() < 0.01, "{}", n(0.1));
        let t = n(0.8);
        assert!(t.x > 0.85 && t.z > 0.4 && t.y.abs() < 0.01 && (t.length() - 1.0).abs() < 1e-5, "{t}");
        // A degenerate tangent leaves the normal alone.
        let mut s = s;
        s.attributes.tangent = vec![[Vec4::new(0.0, 0.0, 1.0, 1.0); 3]];
        assert_eq!(mapped_normal(&s, &s.materials[0], 0, Barycentric::new(0.8, 0.1), Vec3::Z), Vec3::Z);
    }
}
