//! GGX as Cycles' Principled BSDF uses it: height-correlated Smith
//! masking-shadowing and sampling of the visible normals, plus the exact
//! dielectric Fresnel. Local frame, normal = +z; α = roughness².
//!
//!   Λ(w)  = (√(1 + α² tan²θ) − 1) / 2
//!   G1(w) = 1 / (1 + Λ(w)),  G2(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))
//!   f     = D(h) F G2 / (4 cosθo cosθi)
//!   pdf   = D_wo(h) / (4 wo·h) = D(h) G1(wo) / (4 cosθo)   (Heitz 2018)
//!
//! so a sample's weight f·cosθi/pdf is F·G2/G1(wo): no D, no division by a
//! small cosine.

use super::ggx::d;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Smith's Λ for GGX. α² tan²θ is formed as α²(x² + y²)/z², exact for tiny
/// α and at normal incidence.
#[inline]
pub fn lambda(w: Vec3, alpha: f32) -> f32 {
    if w.z <= 0.0 {
        return f32::INFINITY;
    }
    let a2t2 = alpha * alpha * (w.x * w.x + w.y * w.y) / (w.z * w.z);
    // (√(1+x) − 1)/2 written as x / (2(√(1+x) + 1)): no cancellation for small x.
    a2t2 / (2.0 * ((1.0 + a2t2).sqrt() + 1.0))
}

#[inline]
pub fn g1(w: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + lambda(w, alpha))
}

#[inline]
pub fn g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + lambda(wo, alpha) + lambda(wi, alpha))
}

/// D·G2 / (4 cosθo cosθi): the lobe without its Fresnel factor.
pub fn eval(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize_or_zero();
    d(h, alpha) * g2(wo, wi, alpha) / (4.0 * wo.z * wi.z)
}

/// A visible normal for wo (Heitz 2018): a point on the disk seen from wo
/// in the stretched (α = 1) configuration, lifted to the hemisphere and
/// unstretched.
pub fn sample_visible_normal(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 0.0 { Vec3::new(-v.y, v.x, 0.0) / len2.sqrt() } else { Vec3::X };
    let t2 = v.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let n = t1 * p1 + t2 * p2 + v * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3::new(alpha * n.x, alpha * n.y, n.z.max(0.0)).normalize()
}

/// wo reflected about a visible normal; None below the surface.
pub fn sample(wo: Vec3, alpha: f32, u: Vec2) -> Option<(Vec3, Vec3)> {
    if wo.z <= 0.0 {
        return None;
    }
    let h = sample_visible_normal(wo, alpha, u);
    let wi = 2.0 * wo.dot(h) * h - wo;
    (wi.z > 0.0 && wi.is_finite()).then_some((wi, h))
}

/// `eval` and `pdf` together, sharing h, D and Λ(wo): the same numbers,
/// bit for bit.
#[inline]
pub fn eval_pdf(wo: Vec3, wi: Vec3, alpha: f32) -> (f32, f32) {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return (0.0, 0.0);
    }
    let h = (wo + wi).normalize_or_zero();
    let d = d(h, alpha);
    let lambda_o = lambda(wo, alpha);
    let g2 = 1.0 / (1.0 + lambda_o + lambda(wi, alpha));
    let g1 = 1.0 / (1.0 + lambda_o);
    (d * g2 / (4.0 * wo.z * wi.z), d * g1 / (4.0 * wo.z))
}

pub fn pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize_or_zero();
    d(h, alpha) * g1(wo, alpha) / (4.0 * wo.z)
}

/// Fresnel reflectance of a smooth dielectric boundary, unpolarised, for
/// light arriving from the outside (relative IOR `eta` > 0) at cosine
/// `cos_i` to the (micro)normal. 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let c = cos_i.abs().min(1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (c - eta * cos_t) / (c + eta * cos_t);
    let rp = (eta * c - cos_t) / (eta * c + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// The relative IOR whose normal-incidence reflectance is `f0`.
pub fn eta_from_f0(f0: f32) -> f32 {
    let s = f0.clamp(0.0, 0.999).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// Cosine-weighted hemispherical average of Fresnel-Schlick with this F0:
/// 2∫ F(μ) μ dμ = F0 + (1 − F0)/21.
pub fn schlick_average(f0: Vec3) -> Vec3 {
    f0 + (Vec3::ONE - f0) / 21.0
}
