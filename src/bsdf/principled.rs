//! What Cycles 4.5's Principled BSDF does for the inputs glTF carries (base
//! colour, metallic, roughness, specular level), in the local frame:
//!
//!   f = m · S_m · F_schlick(base, wo·h) · f_ggx
//!     + (1 − m) · [ s · S_d · F_diel(wo·h) · f_ggx + (1 − E_layer(μo)) · base/π ]
//!
//! * f_ggx = D G2 / (4 cosθo cosθi): GGX with α = roughness², height-correlated
//!   Smith masking, sampled by visible normals (microfacet.rs).
//! * Metal (weight m): Fresnel-Schlick with F0 = base colour — Cycles' F82-tint
//!   model with a white tint.
//! * Dielectric (weight 1 − m): exact Fresnel at IOR 1.5 over a Lambert base
//!   that gets what the specular layer does not reflect, 1 − E_layer(μo), so a
//!   white dielectric reflects all the light at every angle.
//! * S_m, S_d: multiple-scattering compensation ("Multiscatter GGX", Cycles'
//!   default; `Material::multiscatter` off gives plain "GGX"), see energy.rs.
//! * s: KHR_materials_specular's factor (Blender's Specular IOR Level × 2)
//!   times F0(IOR)/F0(1.5) for a KHR_materials_ior other than 1.5. It
//!   scales the dielectric layer and E_layer linearly: exact for s = 0 and
//!   1, an approximation elsewhere.
//! * Glass (KHR_materials_transmission) is the dielectric.rs lobe, mixed in
//!   by transmission.rs.
//!
//! Like Cycles, the layering and the compensation depend on wo only, so the
//! model is not reciprocal; the lobes themselves are.

use super::energy::{layer_fresnel, ms_fraction, ms_scale, tables, EnergyRows, TableRow, DIELECTRIC_ETA};
use super::microfacet::{self, fresnel_dielectric, schlick_average};
use super::{fresnel_schlick, lambert, luminance, BsdfSample, SMOOTH_ALPHA_SQ, SPEC_MIN_SHARE};
use crate::material::Surface;
use glam::Vec2;
use crate::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct PrincipledBsdf {
    base: Vec3,
    metallic: f32,
    specular: f32,
    alpha: f32,
    /// The glossy lobes are a perfect mirror (α² ≤ SMOOTH_ALPHA_SQ).
    pub smooth: bool,
    /// Multiple-scattering scales of the metal (per channel) and the
    /// dielectric specular lobe.
    s_metal: Vec3,
    s_dielectric: f32,
    /// Weight of the Lambert base: (1 − m)(1 − s·E_layer(μo)).
    diffuse_weight: f32,
    /// Probability of sampling the glossy lobes (else the diffuse one).
    pub glossy_probability: f32,
    /// The lobes' expected reflectance at wo (their sampling weights).
    reflectance: f32,
}

/// What of a Principled BSDF depends on the surface alone, not on wo:
/// computed once per material where the surface is the same at every
/// point (render.rs), which was half of building the BSDF at each hit.
#[derive(Clone, Copy, Debug)]
pub struct PrincipledLobes {
    base: Vec3,
    metallic: f32,
    specular: f32,
    roughness: f32,
    /// The energy tables' rows for this roughness, and for a material that
    /// keeps its lobes (`for_material`) those rows read at its roughness.
    row: TableRow,
    rows: Option<EnergyRows>,
    alpha: f32,
    smooth: bool,
    pure_lambert: bool,
    multiscatter: bool,
    /// F_ms of the metal (per channel) and of the dielectric layer, for
    /// the multiple-scattering scales (energy.rs).
    f_ms_metal: Vec3,
    f_ms_dielectric: f32,
    /// luminance(F_avg) of the metal and luminance(base), for the lobe choice.
    metal_reflectance: f32,
    base_luminance: f32,
}

impl PrincipledLobes {
    pub fn new(m: &Surface) -> Self {
        let roughness = m.roughness.clamp(0.0, 1.0);
        let alpha = roughness * roughness;
        let base = m.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        // The tables hold IOR 1.5; another IOR scales the layer by its F0,
        // exactly as KHR_materials_specular does (an approximation between
        // the tables' exact ends, like s itself).
        let ior_ratio = (m.ior - 1.0) / (m.ior + 1.0) / 0.2;
        let (smooth, pure_lambert) = (alpha * alpha <= SMOOTH_ALPHA_SQ, m.is_pure_lambert());
        let (f_ms_metal, f_ms_dielectric) = if pure_lambert || smooth {
            (Vec3::ZERO, 0.0)
        } else {
            let t = tables();
            let e_avg = t.e_avg(roughness);
            (ms_fraction(e_avg, schlick_average(base)), ms_fraction(e_avg, Vec3::splat(t.dielectric_f_avg)).x)
        };
        PrincipledLobes {
            base,
            metallic: m.metallic.clamp(0.0, 1.0),
            specular: (m.specular * ior_ratio * ior_ratio).clamp(0.0, 4.0),
            roughness,
            row: TableRow::of(roughness),
            rows: None,
            alpha,
            smooth,
            pure_lambert,
            multiscatter: m.multiscatter,
            f_ms_metal,
            f_ms_dielectric,
            metal_reflectance: luminance(schlick_average(base)),
            base_luminance: luminance(base),
        }
    }

    /// The lobes a material keeps where its surface is the same at every
    /// point, with its own 1-D energy rows: `e_and_layer_in` and the rest
    /// of `PrincipledBsdf::at` had been 6% of a render's time (perf).
    pub fn for_material(m: &Surface) -> Self {
        let lobes = PrincipledLobes::new(m);
        let rows = (!lobes.pure_lambert && !lobes.smooth).then(|| tables().rows(lobes.row));
        PrincipledLobes { rows, ..lobes }
    }
}

impl PrincipledBsdf {
    pub fn new(m: &Surface, wo: Vec3) -> Self {
        Self::at(&PrincipledLobes::new(m), wo)
    }

    pub fn at(m: &PrincipledLobes, wo: Vec3) -> Self {
        let PrincipledLobes { base, metallic, specular, roughness, alpha, smooth, .. } = *m;
        let mu = wo.z.clamp(0.0, 1.0);
        if m.pure_lambert {
            // No glossy lobe, nothing to look up.
            return PrincipledBsdf { base, metallic, specular, alpha, smooth, s_metal: Vec3::ONE, s_dielectric: 1.0, diffuse_weight: 1.0, glossy_probability: 0.0, reflectance: m.base_luminance };
        }
        // A mirror loses nothing to single scattering and its layer albedo
        // is the Fresnel reflectance itself.
        let (s_metal, s_dielectric, layer) = if smooth {
            (Vec3::ONE, 1.0, fresnel_dielectric(mu, DIELECTRIC_ETA))
        } else {
            let (e, layer) = match &m.rows {
                Some(rows) => rows.at(mu),
                None => tables().e_and_layer_in(m.row, mu),
            };
            let s_dielectric = ms_scale(e, Vec3::splat(m.f_ms_dielectric)).x;
            if m.multiscatter {
                (ms_scale(e, m.f_ms_metal), s_dielectric, layer)
            } else {
                // Plain GGX: the lobes lose what single scattering loses,
                // but Cycles weights the base below by the albedo its
                // layering table holds for both distributions
                // (bsdf_microfacet_estimate_albedo): the lobe scaled to a
                // white albedo of 1, each bounce Fresnel-weighted. That is
                // the compensated albedo undarkened, E_layer / (S·E) — a
                // plain-GGX dielectric is darker than a multiscatter one.
                (Vec3::ONE, 1.0, layer / (s_dielectric * e).max(f32::MIN_POSITIVE))
            }
        };
        let diffuse_weight = (1.0 - metallic) * (1.0 - specular * layer).max(0.0);
        // Lobe choice by expected reflectance at this wo: the metal's ≈ its
        // average Fresnel, the dielectric layer's E_layer. As in the seed
        // model, a narrow dielectric lobe gets at least a floor share.
        let w_glossy = metallic * m.metal_reflectance + (1.0 - metallic) * specular * layer;
        let w_diffuse = diffuse_weight * m.base_luminance;
        let mut glossy_probability = if w_glossy + w_diffuse > 0.0 { w_glossy / (w_glossy + w_diffuse) } else { 1.0 };
        if w_glossy > 0.0 && w_diffuse > 0.0 {
            glossy_probability = glossy_probability.max(SPEC_MIN_SHARE * (1.0 - roughness) * (1.0 - roughness));
        }
        PrincipledBsdf { base, metallic, specular, alpha, smooth, s_metal, s_dielectric, diffuse_weight, glossy_probability, reflectance: w_glossy + w_diffuse }
    }

    /// Expected reflectance at wo: what a coat above weighs it by.
    pub fn reflectance(&self) -> f32 {
        self.reflectance
    }

    /// Fresnel of the glossy lobes, summed with their weights and scales.
    /// A lobe of weight 0 (a pure metal's dielectric, a dielectric's metal)
    /// is not evaluated: the exact Fresnel was a tenth of a metal's shading.
    fn glossy_fresnel(&self, cos_h: f32) -> Vec3 {
        let metal = if self.metallic > 0.0 { self.metallic * self.s_metal * fresnel_schlick(self.base, cos_h) } else { Vec3::ZERO };
        let dielectric_weight = (1.0 - self.metallic) * self.specular;
        let dielectric = if dielectric_weight > 0.0 { dielectric_weight * self.s_dielectric * layer_fresnel(cos_h) } else { 0.0 };
        metal + Vec3::splat(dielectric)
    }

    fn has_glossy(&self) -> bool {
        self.glossy_probability > 0.0
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let diffuse = lambert::eval(self.base, wo, wi) * self.diffuse_weight;
        if self.smooth || !self.has_glossy() {
            return diffuse;
        }
        diffuse + self.glossy_fresnel(microfacet::cos_half(wo, wi)) * microfacet::eval(wo, wi, self.alpha)
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.glossy_probability;
        let glossy = if self.smooth || p == 0.0 { 0.0 } else { p * microfacet::pdf(wo, wi, self.alpha) };
        glossy + (1.0 - p) * lambert::pdf(wo, wi)
    }

    /// `eval` and `pdf` at once, with the lobe's shared terms computed
    /// once: the same numbers, bit for bit.
    pub fn evaluate(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let p = self.glossy_probability;
        let diffuse_pdf = (1.0 - p) * lambert::pdf(wo, wi);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, diffuse_pdf);
        }
        let diffuse = lambert::eval(self.base, wo, wi) * self.diffuse_weight;
        if self.smooth || !self.has_glossy() {
            return (diffuse, 0.0 + diffuse_pdf);
        }
        let (lobe, lobe_pdf) = microfacet::eval_pdf(wo, wi, self.alpha);
        (diffuse + self.glossy_fresnel(microfacet::cos_half(wo, wi)) * lobe, p * lobe_pdf + diffuse_pdf)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.glossy_probability;
        if self.smooth && u_lobe < p {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = self.glossy_fresnel(wo.z);
            return Some(BsdfSample { wi, f, pdf: p, weight: f / p, delta: true });
        }
        let wi = if u_lobe < p { microfacet::sample(wo, self.alpha, u)?.0 } else { lambert::sample(u) };
        let (f, pdf) = self.evaluate(wo, wi);
        let weight = f * (wi.z / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { wi, f, pdf, weight, delta: false })
    }
}
