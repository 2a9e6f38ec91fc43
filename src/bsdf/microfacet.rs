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

use super::ggx;
use glam::Vec2;
use crate::Vec3;
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

/// cosθ·√(1 + α² tan²θ) = √(z² + α²(x² + y²)), of which Λ is made:
/// 1 + Λ(w) = (cosθ + this) / (2 cosθ). So
///   G2 / (4 cosθo cosθi) = 1 / (2 (cosθi·root(wo) + cosθo·root(wi)))
///   G1(wo) / (4 cosθo)   = 1 / (2 (cosθo + root(wo)))
/// with no tan² and no division by a cosine, which at grazing angles
/// were four divisions of each evaluation and their rounding.
#[inline]
fn smith_root(w: Vec3, a2: f32) -> f32 {
    (w.z * w.z + a2 * (w.x * w.x + w.y * w.y)).sqrt()
}

/// D of the half vector of wo and wi, from h = wo + wi unnormalised: its
/// bracket (ggx::d) from cos²θh = h_z²/|h|² and sin²θh = (h_x² + h_y²)/|h|²,
/// which needs no square root. Formed at h itself, the bracket's square
/// underflowed to 0 where wo and wi both graze on opposite sides (|h| ~
/// 1e-8 with α = 1e-4 gave inf, smaller NaN); the ratios are in [0, 1].
#[inline]
fn d_of_sum(h: Vec3, a2: f32) -> f32 {
    if !(h.z > 0.0) {
        return 0.0;
    }
    let (z2, s2) = (h.z * h.z, h.x * h.x + h.y * h.y);
    let inv_len2 = 1.0 / (z2 + s2);
    ggx::d_of_bracket(z2 * inv_len2 * a2 + s2 * inv_len2, a2)
}

/// D·G2 / (4 cosθo cosθi): the lobe without its Fresnel factor.
pub fn eval(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    eval_pdf(wo, wi, alpha).0
}

/// A visible normal for wo (Heitz 2018): a point on the disk seen from wo
/// in the stretched (α = 1) configuration, lifted to the hemisphere and
/// unstretched.
pub fn sample_visible_normal(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    Anisotropic { alpha_x: alpha, alpha_y: alpha }.sample_visible_normal(wo, u)
}

/// wo reflected about a visible normal; None below the surface.
pub fn sample(wo: Vec3, alpha: f32, u: Vec2) -> Option<(Vec3, Vec3)> {
    Anisotropic { alpha_x: alpha, alpha_y: alpha }.sample(wo, u)
}

/// `eval` and `pdf` together, sharing D and root(wo): `eval` and `pdf`
/// are this, so the three give the same numbers, bit for bit.
#[inline]
pub fn eval_pdf(wo: Vec3, wi: Vec3, alpha: f32) -> (f32, f32) {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return (0.0, 0.0);
    }
    let a2 = alpha * alpha;
    let half_d = 0.5 * d_of_sum(wo + wi, a2);
    let root_o = smith_root(wo, a2);
    (half_d / (wi.z * root_o + wo.z * smith_root(wi, a2)), half_d / (wo.z + root_o))
}

pub fn pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    eval_pdf(wo, wi, alpha).1
}

/// Anisotropic GGX (Blender's Anisotropic): α_x along the local x axis
/// (the tangent), α_y along y. The same formulas with α²(x² + y²) read
/// as α_x²x² + α_y²y²:
///
///   D(h) = 1 / (π α_x α_y (h_x²/α_x² + h_y²/α_y² + h_z²)²)
///   Λ(w) = (√(1 + (α_x² w_x² + α_y² w_y²)/w_z²) − 1) / 2
///
/// and the visible normals sampled in the configuration stretched by
/// (α_x, α_y). With α_x = α_y these are the isotropic functions above
/// (kept apart: an isotropic material computes what it always did).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anisotropic {
    pub alpha_x: f32,
    pub alpha_y: f32,
}

impl Anisotropic {
    /// √(z² + α_x² x² + α_y² y²): `smith_root` with its own α per axis.
    #[inline]
    fn root(&self, w: Vec3) -> f32 {
        let (ax, ay) = (self.alpha_x * w.x, self.alpha_y * w.y);
        (w.z * w.z + ax * ax + ay * ay).sqrt()
    }

    /// D of the half vector of wo and wi from their unnormalised sum h, as
    /// `d_of_sum`: α_x α_y / (π b²) with b = (h_x² α_y/α_x + h_y² α_x/α_y +
    /// h_z² α_x α_y) / |h|², which is the isotropic bracket where the two
    /// are equal.
    #[inline]
    fn d_of_sum(&self, h: Vec3) -> f32 {
        if !(h.z > 0.0) {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let (x2, y2, z2) = (h.x * h.x, h.y * h.y, h.z * h.z);
        let inv_len2 = 1.0 / (x2 + y2 + z2);
        let bracket = (x2 * (ay / ax) + y2 * (ax / ay) + z2 * (ax * ay)) * inv_len2;
        ax * ay / (PI * bracket * bracket)
    }

    /// `eval_pdf` of this lobe: D·G2 / (4 cosθo cosθi) and D_wo(h) / (4 wo·h).
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (0.0, 0.0);
        }
        let half_d = 0.5 * self.d_of_sum(wo + wi);
        let root_o = self.root(wo);
        (half_d / (wi.z * root_o + wo.z * self.root(wi)), half_d / (wo.z + root_o))
    }

    /// A visible normal for wo (Heitz 2018): a point on the disk seen from
    /// wo in the configuration stretched to α = 1, lifted to the hemisphere
    /// and unstretched, by α_x and α_y apart (equal for the isotropic
    /// `sample_visible_normal`).
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let v = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
        let len2 = v.x * v.x + v.y * v.y;
        let t1 = if len2 > 0.0 { Vec3::new(-v.y, v.x, 0.0) / len2.sqrt() } else { Vec3::X };
        let t2 = v.cross(t1);
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + v.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let n = t1 * p1 + t2 * p2 + v * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        Vec3::new(ax * n.x, ay * n.y, n.z.max(0.0)).normalize()
    }

    /// wo reflected about a visible normal, and that normal; None below
    /// the surface.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, Vec3)> {
        if wo.z <= 0.0 {
            return None;
        }
        let h = self.sample_visible_normal(wo, u);
        let wi = 2.0 * wo.dot(h) * h - wo;
        (wi.z > 0.0 && wi.is_finite()).then_some((wi, h))
    }
}

/// wo·h for the half vector h of unit wo and wi: √((1 + wo·wi)/2), one
/// square root where normalising h took one and a division.
#[inline]
pub fn cos_half(wo: Vec3, wi: Vec3) -> f32 {
    ((1.0 + wo.dot(wi)) * 0.5).max(0.0).sqrt()
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
