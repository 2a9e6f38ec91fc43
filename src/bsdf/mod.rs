//! BSDF models, in the local shading frame (normal = +z): the seed's below,
//! and the Principled one Cycles uses in `principled.rs`, both behind the
//! `Bsdf` trait the integrator is generic over.
//!
//! The seed's BSDF: Lambert diffuse plus a GGX (Trowbridge-Reitz) microfacet
//! specular lobe.
//!
//!   f(wo, wi) = kd · baseColor/π + D(h)·F(wo·h)·G(wo, wi) / (4 (n·wo)(n·wi))
//!   D: GGX with α = roughness²
//!   G: Schlick-GGX in Smith's separable form, k = (α+1)²/8
//!   F: Fresnel-Schlick with F0 = mix(0.04, baseColor, metallic)
//!   kd = (1 − F)(1 − metallic)
//!
//! KHR_materials_specular's factor s scales the dielectric layer as that
//! extension defines: F0 = mix(0.04·s, baseColor, metallic) and
//! F90 = mix(s, 1, metallic). With s = 1 (no extension) this is the seed.
//!
//! Each lobe keeps `eval`, `sample` and `pdf` side by side. The material picks
//! a lobe with probability `spec_probability` and reports the mixture pdf, so
//! `f·cos/pdf` is an unbiased one-sample estimate whatever the choice.

use crate::material::{Material, Surface};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use glam::Vec2;
use crate::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// One sampled direction (pbrt's BSDFSample).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f(wo, wi); for a delta lobe, the lobe's reflectance (the factor of
    /// the Dirac delta, without the 1/cos θi that cancels the cosine).
    pub f: Vec3,
    /// Solid-angle pdf; for a delta lobe, the discrete probability of
    /// having picked it.
    pub pdf: f32,
    /// f·cos θi / pdf, the path throughput factor, computed once here.
    pub weight: Vec3,
    /// Drawn from a delta lobe: no other strategy can produce this wi, so
    /// an emitter it hits takes the full MIS weight.
    pub delta: bool,
    /// Drawn from the diffuse lobe: the ray it sends is a diffuse ray
    /// (Blender's Ray Visibility; otherwise glossy, or a transmission
    /// where wi lies below the surface).
    pub diffuse: bool,
}

/// The share of samples a near-mirror specular lobe gets at least; it
/// falls to 0 as roughness reaches 1 (see `SeedBsdf::new`).
pub const SPEC_MIN_SHARE: f32 = 0.5;

/// Squared α under which a GGX lobe is a perfect mirror: Cycles'
/// BSDF_ROUGHNESS_SQ_THRESH (roughness ≲ 0.0038). Above it D(h) ≤ 1/(π α²)
/// = 1.6e9 and its denominator (≥ α⁴ = 4e-20) stay well inside f32.
pub const SMOOTH_ALPHA_SQ: f32 = 2e-10;

#[inline]
fn cos_theta(w: Vec3) -> f32 {
    w.z
}

pub fn fresnel_schlick(f0: Vec3, cos: f32) -> Vec3 {
    fresnel_schlick_f90(f0, Vec3::ONE, cos)
}

pub fn fresnel_schlick_f90(f0: Vec3, f90: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (f90 - f0) * m
}

pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

// ---------------------------------------------------------------- Lambert

pub mod lambert {
    use super::*;

    /// f = albedo / π on the upper hemisphere.
    pub fn eval(albedo: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        if cos_theta(wo) <= 0.0 || cos_theta(wi) <= 0.0 {
            return Vec3::ZERO;
        }
        albedo * FRAC_1_PI
    }

    pub fn sample(u: Vec2) -> Vec3 {
        cosine_hemisphere(u)
    }

    pub fn pdf(wo: Vec3, wi: Vec3) -> f32 {
        if cos_theta(wo) <= 0.0 {
            return 0.0;
        }
        cosine_hemisphere_pdf(cos_theta(wi))
    }
}

// ---------------------------------------------------------------- Translucent

/// Blender's Translucent BSDF: Lambert through the surface, f = albedo/π
/// for wi on the other side from wo, sampled by the cosine there (Cycles'
/// bsdf_translucent).
pub mod translucent {
    use super::*;

    pub fn eval(albedo: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        if cos_theta(wo) * cos_theta(wi) >= 0.0 {
            return Vec3::ZERO;
        }
        albedo * FRAC_1_PI
    }

    /// A direction on the other side from `wo`.
    pub fn sample(wo: Vec3, u: Vec2) -> Vec3 {
        let w = cosine_hemisphere(u);
        Vec3::new(w.x, w.y, if cos_theta(wo) < 0.0 { w.z } else { -w.z })
    }

    pub fn pdf(wo: Vec3, wi: Vec3) -> f32 {
        if cos_theta(wo) * cos_theta(wi) >= 0.0 {
            return 0.0;
        }
        cosine_hemisphere_pdf(cos_theta(wi).abs())
    }
}

// ---------------------------------------------------------------- GGX

pub mod ggx {
    use super::*;

    /// GGX normal distribution D(h) = α² / (π ((n·h)²(α²−1) + 1)²) for a
    /// local unit half vector h. The bracket is written cos²·α² + sin² with
    /// sin² = hx² + hy², which has no cancellation as α → 0 and h → n.
    pub fn d(h: Vec3, alpha: f32) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = alpha * alpha;
        d_of_bracket(h.z * h.z * a2 + (h.x * h.x + h.y * h.y), a2)
    }

    /// D from its bracket cos²θh·α² + sin²θh and α².
    #[inline]
    pub fn d_of_bracket(bracket: f32, a2: f32) -> f32 {
        a2 / (PI * bracket * bracket)
    }

    /// Schlick-GGX masking for one direction, G1 = n·v / (n·v (1−k) + k).
    pub fn g1_schlick(cos_v: f32, k: f32) -> f32 {
        cos_v / (cos_v * (1.0 - k) + k)
    }

    /// The seed's remapping k = (α+1)²/8.
    pub fn seed_k(alpha: f32) -> f32 {
        (alpha + 1.0) * (alpha + 1.0) / 8.0
    }

    /// Specular term D·F·G / (4 (n·wo)(n·wi)), given F already evaluated.
    pub fn eval(alpha: f32, fresnel: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        let (co, ci) = (cos_theta(wo), cos_theta(wi));
        if co <= 0.0 || ci <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize_or_zero();
        let k = seed_k(alpha);
        let g = g1_schlick(co, k) * g1_schlick(ci, k);
        fresnel * (d(h, alpha) * g / (4.0 * co * ci))
    }

    /// A half vector drawn from D(h)(n·h). The seed writes
    /// θ_h = arccos sqrt((1−ε)/(ε(α²−1)+1)); the same angle is
    /// tan²θ_h = α² ε / (1−ε), which stays accurate for tiny α and for ε → 1.
    pub fn sample_half(u: Vec2, alpha: f32) -> Vec3 {
        let tan2 = alpha * alpha * u.x / (1.0 - u.x);
        let cos_t = 1.0 / (1.0 + tan2).sqrt();
        let sin_t = (tan2 / (1.0 + tan2)).sqrt();
        let phi = 2.0 * PI * u.y;
        Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
    }

    /// Reflect wo about h; None when the result is not above the surface.
    pub fn sample(wo: Vec3, u: Vec2, alpha: f32) -> Option<Vec3> {
        let h = sample_half(u, alpha);
        let wi = 2.0 * wo.dot(h) * h - wo;
        (cos_theta(wi) > 0.0).then_some(wi)
    }

    /// pdf(wi) = D(h)(n·h) / (4 |wo·h|): the half-vector pdf times the
    /// Jacobian of reflection.
    pub fn pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
        if cos_theta(wo) <= 0.0 || cos_theta(wi) <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize_or_zero();
        let wo_h = wo.dot(h);
        if wo_h <= 0.0 {
            return 0.0;
        }
        d(h, alpha) * h.z / (4.0 * wo_h)
    }
}

// ---------------------------------------------------------------- the material

/// The seed material evaluated for one shading point.
#[derive(Clone, Copy, Debug)]
pub struct SeedBsdf {
    pub base_color: Vec3,
    pub metallic: f32,
    pub alpha: f32,
    /// The specular lobe is a perfect mirror (α² ≤ SMOOTH_ALPHA_SQ).
    pub smooth: bool,
    pub f0: Vec3,
    pub f90: Vec3,
    /// Probability of sampling the specular lobe, from the lobes' expected
    /// reflectance at this wo (see `new`).
    pub spec_probability: f32,
}

impl SeedBsdf {
    pub fn new(m: &Surface, wo: Vec3) -> Self {
        let r = m.roughness.clamp(0.0, 1.0);
        let alpha = r * r;
        let smooth = alpha * alpha <= SMOOTH_ALPHA_SQ;
        let metallic = m.metallic.clamp(0.0, 1.0);
        let base = m.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        let specular = m.specular.clamp(0.0, 1.0);
        let f0 = Vec3::splat(0.04 * specular).lerp(base, metallic);
        let f90 = Vec3::splat(specular).lerp(Vec3::ONE, metallic);
        // Lobe weights: specular ≈ Fresnel at the viewing angle, diffuse ≈ what
        // is left times the diffuse albedo. A lobe of zero weight is never picked.
        let w_spec = luminance(fresnel_schlick_f90(f0, f90, cos_theta(wo)));
        let w_diff = (1.0 - metallic) * luminance(base) * (1.0 - w_spec);
        let mut spec_probability = if w_spec + w_diff > 0.0 { w_spec / (w_spec + w_diff) } else { 1.0 };
        // Weights by reflectance assume light arrives evenly from all sides.
        // A narrow lobe concentrates what it reflects, so missing it costs
        // more: a glossy plastic reflecting a small bright light picked its
        // lobe 1 time in 10 and stayed noisy (tests/stability.rs). Narrow
        // lobes get at least SPEC_MIN_SHARE·(1 − roughness)² of the samples.
        if w_spec > 0.0 && w_diff > 0.0 {
            spec_probability = spec_probability.max(SPEC_MIN_SHARE * (1.0 - r) * (1.0 - r));
        }
        SeedBsdf { base_color: base, metallic, alpha, smooth, f0, f90, spec_probability }
    }

    /// f(wo, wi), without the cosine; a mirror lobe contributes nothing
    /// here (it is zero almost everywhere).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if cos_theta(wo) <= 0.0 || cos_theta(wi) <= 0.0 {
            return Vec3::ZERO;
        }
        // A mirror's only microfacet normal is n, so what it reflects is
        // F(n·wo) and the diffuse layer gets the rest. (The seed's F(wo·h)
        // with h between wo and a diffuse wi would let a white plastic mirror
        // return 1.85 of the light at 89°.)
        let cos_d = if self.smooth { cos_theta(wo) } else { wo.dot((wo + wi).normalize_or_zero()) };
        let f = fresnel_schlick_f90(self.f0, self.f90, cos_d);
        let kd = (Vec3::ONE - f) * (1.0 - self.metallic);
        let diffuse = kd * lambert::eval(self.base_color, wo, wi);
        if self.spec_probability == 0.0 || self.smooth {
            return diffuse; // no glossy lobe: s = 0 and not metallic, or a mirror
        }
        diffuse + ggx::eval(self.alpha, f, wo, wi)
    }

    /// Mixture pdf of the two sampling strategies, over the non-delta lobes.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.spec_probability;
        let spec = if self.smooth || p == 0.0 { 0.0 } else { p * ggx::pdf(wo, wi, self.alpha) };
        spec + (1.0 - p) * lambert::pdf(wo, wi)
    }

    /// `u_lobe` picks the lobe, `u` drives it.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if cos_theta(wo) <= 0.0 {
            return None;
        }
        let p = self.spec_probability;
        if self.smooth && u_lobe < p {
            // Perfect mirror: wi = reflect(wo), h = n, weight F(n·wo) / p.
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = fresnel_schlick_f90(self.f0, self.f90, cos_theta(wo));
            return Some(BsdfSample { wi, f, pdf: p, weight: f / p, delta: true, diffuse: false });
        }
        let wi = if u_lobe < p { ggx::sample(wo, u, self.alpha)? } else { lambert::sample(u) };
        let pdf = self.pdf(wo, wi);
        let f = self.eval(wo, wi);
        let weight = f * (cos_theta(wi) / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { wi, f, pdf, weight, delta: false, diffuse: u_lobe >= p })
    }
}

/// A pure Lambert surface, for scenes that have nothing else (features.rs).
/// It computes exactly what both models compute for a non-metal with
/// specular 0, in the same order, so the images agree bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct LambertBsdf {
    albedo: Vec3,
}

impl LambertBsdf {
    pub fn new(m: &Surface, _wo: Vec3) -> Self {
        LambertBsdf { albedo: m.base_color.clamp(Vec3::ZERO, Vec3::ONE) }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        lambert::eval(self.albedo, wo, wi)
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        lambert::pdf(wo, wi)
    }

    pub fn sample(&self, wo: Vec3, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if cos_theta(wo) <= 0.0 {
            return None;
        }
        let wi = lambert::sample(u);
        let pdf = self.pdf(wo, wi);
        let f = self.eval(wo, wi);
        let weight = f * (cos_theta(wi) / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { wi, f, pdf, weight, delta: false, diffuse: true })
    }
}

/// A material evaluated at one shading point, for one outgoing direction:
/// what the integrator needs of any BSDF model.
pub trait Bsdf: Sized {
    /// What the model computes of a surface before it knows wo: once per
    /// material where the surface is the same at every point (render.rs).
    type Prepared: Sync;
    /// Whether the model has glass: without, no path enters a medium
    /// (media.rs), and a kernel compiled for it carries no code for one.
    const GLASS: bool = false;
    fn prepare(surface: &Surface) -> Self::Prepared;
    /// The BSDF for one outgoing direction.
    fn at(prepared: &Self::Prepared, wo: Vec3) -> Self;
    fn new(surface: &Surface, wo: Vec3) -> Self {
        Self::at(&Self::prepare(surface), wo)
    }
    /// f(wo, wi) without the cosine; delta lobes contribute nothing here.
    /// wi below the surface (z < 0) is transmission: zero unless the model
    /// has glass.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;
    /// Solid-angle pdf of `sample` producing wi, over its non-delta lobes.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// `eval` and `pdf` together (psychopath's `evaluate`): a model whose
    /// two share work computes it once.
    fn evaluate(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }
    /// `u_lobe` picks the lobe, `u` drives it.
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample>;
    /// Whether eval can be non-zero below the surface: lets light sampling
    /// skip a light behind an opaque surface before any shading work.
    fn transmits(&self) -> bool {
        false
    }
    /// About how much of the light from wo it reflects or transmits, for a
    /// layer above it to weigh its samples against (coat.rs).
    fn reflectance(&self) -> f32 {
        1.0
    }
    /// What of `material`'s emission leaves toward a direction at cosine
    /// `cos_out` to its face, where a layer over it (a coat, coat.rs)
    /// takes some; None where the model lays nothing over emission.
    #[inline]
    fn emission_weight(_material: &Material, _cos_out: f32) -> Option<Vec3> {
        None
    }
}

/// Which BSDF model renders the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BsdfModel {
    /// The seed's formulas (Schlick-GGX k = (α+1)²/8, Fresnel-Schlick,
    /// kd = (1−F)(1−metallic)), kept for comparison.
    Seed,
    /// What Cycles' Principled BSDF does (principled.rs).
    #[default]
    Principled,
}

/// The trait over a model's inherent methods; `evaluate` names one that
/// computes f and the pdf together (else the trait's default pairs them),
/// `prepared` the type its inherent `prepare`/`at` split `new` into (else
/// the surface itself is what is prepared), `reflectance` the method that
/// estimates its albedo (else the trait's 1).
macro_rules! impl_bsdf {
    ($t:ty $(, $evaluate:ident)? $(; prepared $p:ty)? $(; reflectance $reflectance:ident)?) => {
        impl Bsdf for $t {
            impl_bsdf!(@prepare $t $(, $p)?);
            fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
                <$t>::eval(self, wo, wi)
            }
            fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
                <$t>::pdf(self, wo, wi)
            }
            $(
                #[inline]
                fn $evaluate(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
                    <$t>::$evaluate(self, wo, wi)
                }
            )?
            #[inline]
            fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
                <$t>::sample(self, wo, u_lobe, u)
            }
            $(
                fn reflectance(&self) -> f32 {
                    <$t>::$reflectance(self)
                }
            )?
        }
    };
    (@prepare $t:ty) => {
        type Prepared = Surface;
        fn prepare(surface: &Surface) -> Surface {
            *surface
        }
        fn at(surface: &Surface, wo: Vec3) -> Self {
            <$t>::new(surface, wo)
        }
    };
    (@prepare $t:ty, $p:ty) => {
        type Prepared = $p;
        fn prepare(surface: &Surface) -> $p {
            <$p>::for_material(surface)
        }
        fn at(prepared: &$p, wo: Vec3) -> Self {
            <$t>::at(prepared, wo)
        }
        fn new(surface: &Surface, wo: Vec3) -> Self {
            <$t>::new(surface, wo)
        }
    };
}
impl_bsdf!(LambertBsdf);
impl_bsdf!(SeedBsdf);
impl_bsdf!(PrincipledBsdf, evaluate; prepared principled::PrincipledLobes; reflectance reflectance);
impl_bsdf!(RoughPrincipledBsdf, evaluate; prepared principled::PrincipledLobes; reflectance reflectance);

pub mod baked;
pub mod coat;
pub mod dielectric;
pub mod energy;
pub mod microfacet;
pub mod oren_nayar;
pub mod principled;
pub mod transmission;
pub use principled::{PrincipledBsdf, RoughPrincipledBsdf};
pub use coat::WithCoat;
pub use transmission::WithGlass;

#[cfg(test)]
pub(crate) mod chi2;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod glass_tests;
