//! What Cycles 4.5's Principled BSDF does for the inputs glTF carries (base
//! colour, metallic, roughness, specular level), in the local frame:
//!
//!   f = m · S_m · F_schlick(base, wo·h) · f_ggx
//!     + (1 − m) · [ s · S_d · F_diel(wo·h) · f_ggx + (1 − E_layer(μo)) · base/π ]
//!
//! * f_ggx = D G2 / (4 cosθo cosθi): GGX with α = roughness², height-correlated
//!   Smith masking, sampled by visible normals (microfacet.rs).
//! * Metal (weight m): Cycles' F82-tint model, F0 = base colour: Schlick's
//!   F0 + (1 − F0)(1 − μ)^5 less b·μ(1 − μ)^6, with b set so that at
//!   μ = 1/7 (about 82°) it is Schlick's value × Blender's Specular Tint
//!   (glTF's specularColorFactor, which Blender's exporter writes from it):
//!   b = F_schlick(1/7) · (1 − tint) · 7/(6/7)^6. A white tint is Schlick's.
//! * Specular Tint on the dielectric layer, as Cycles' generalized Schlick
//!   with a negative exponent: F_t = mix(F0·tint, 1, s), s = (F − F0)/(1 − F0)
//!   along the exact curve F — per channel F_t = (1 + k)·F − k with
//!   k = F0 (1 − tint)/(1 − F0). Being affine in F, so are its mean (for the
//!   compensation, per channel) and the layer's albedo: E_t = S_t·E·((1 + k)·A
//!   − k), A = E_layer/(S·E) the table's albedo of the untinted lobe scaled
//!   to white; the base gets 1 − max over channels of E_t (Cycles'
//!   `closure_layering_weight`).
//! * Dielectric (weight 1 − m): exact Fresnel at IOR 1.5 over a Lambert base
//!   that gets what the specular layer does not reflect, 1 − E_layer(μo), so a
//!   white dielectric reflects all the light at every angle.
//! * S_m, S_d: multiple-scattering compensation ("Multiscatter GGX", Cycles'
//!   default; `Material::multiscatter` off gives plain "GGX"), see energy.rs.
//! * s: KHR_materials_specular's factor (Blender's Specular IOR Level × 2)
//!   times F0(IOR)/F0(1.5) for a KHR_materials_ior other than 1.5. It
//!   scales the dielectric layer and E_layer linearly: exact for s = 0 and
//!   1, an approximation elsewhere.
//! * Diffuse Roughness (from a render request) turns the base's base/π
//!   into Cycles' Oren–Nayar lobe (oren_nayar.rs), weighted alike.
//! * Glass (KHR_materials_transmission) is the dielectric.rs lobe, mixed in
//!   by transmission.rs.
//! * Anisotropic (KHR_materials_anisotropy): f_ggx of both glossy lobes
//!   stretched along the tangent, the energy terms as Cycles reads them
//!   (`AnisotropicLobe`).
//!
//! Like Cycles, the layering and the compensation depend on wo only, so the
//! model is not reciprocal; the lobes themselves are.

use super::energy::{layer_fresnel, ms_fraction, ms_scale, tables, EnergyRows, TableRow, DIELECTRIC_ETA};
use super::microfacet::{self, fresnel_dielectric, schlick_average, Anisotropic};
use super::oren_nayar::{OrenNayar, RoughDiffuse};
use super::{fresnel_schlick, lambert, luminance, BsdfSample, SMOOTH_ALPHA_SQ, SPEC_MIN_SHARE};
use crate::material::Surface;
use glam::Vec2;
use crate::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct PrincipledBsdfWith<D: DiffuseBase> {
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
    /// Specular Tint's terms, None where it is white: an untinted
    /// surface writes and tests one tag (a tinted one is rare).
    tints: Option<Tints>,
    /// The glossy lobes' GGX where Anisotropic is above 0.
    anisotropic: Option<AnisotropicLobe>,
    /// The diffuse base's lobe.
    diffuse_lobe: D,
}

/// The Principled BSDF's diffuse base: Lambert's alone, or, in a kernel
/// for scenes with Diffuse Roughness, Cycles' Oren–Nayar where a
/// material's is above 0. A scene without pays nothing for it: its kernel
/// has no tag to test (a tag and a call had tipped `evaluate` and `sample`
/// out of line, 3.6% more instructions on the benchmark's gold sphere).
pub trait DiffuseBase: Copy + std::fmt::Debug {
    fn at(roughness: f32, base: Vec3, mu_o: f32) -> Self;
    /// The lobe's f for wo and wi above the surface, albedo `base`.
    fn eval(&self, base: Vec3, wo: Vec3, wi: Vec3) -> Vec3;
}

/// Lambert's base/π, whatever the material's Diffuse Roughness.
#[derive(Clone, Copy, Debug)]
pub struct Lambertian;

impl DiffuseBase for Lambertian {
    #[inline]
    fn at(_: f32, _: Vec3, _: f32) -> Self {
        Lambertian
    }
    #[inline]
    fn eval(&self, base: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        lambert::eval(base, wo, wi)
    }
}

/// Oren–Nayar where the material has a Diffuse Roughness, else Lambert.
impl DiffuseBase for Option<RoughDiffuse> {
    #[inline]
    fn at(roughness: f32, base: Vec3, mu_o: f32) -> Self {
        if roughness > 0.0 { OrenNayar::new(roughness, base).map(|lobe| lobe.at(mu_o)) } else { None }
    }
    #[inline]
    fn eval(&self, base: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            None => lambert::eval(base, wo, wi),
            Some(lobe) => base * lobe.eval(wo, wi),
        }
    }
}

/// The Principled BSDF with a Lambert base.
pub type PrincipledBsdf = PrincipledBsdfWith<Lambertian>;
/// The Principled BSDF with a rough diffuse base where a material has one.
pub type RoughPrincipledBsdf = PrincipledBsdfWith<Option<RoughDiffuse>>;

/// The metal's and the specular layer's GGX under Blender's Anisotropic a
/// (Cycles' Principled BSDF): α_x = α/k along the tangent (at most 1) and
/// α_y = α·k across it, k = √(1 − 0.9a). Cycles reads its energy tables
/// at (α_x α_y)^¼: the material's roughness, as α_x α_y = α², unless α_x
/// was clamped. Evaluated in the lobe's own frame, the BSDF's turned about
/// the normal to put the tangent on x.
#[derive(Clone, Copy, Debug)]
struct AnisotropicLobe {
    ggx: Anisotropic,
    /// The tangent (α_x's axis) in the BSDF's frame: (cos φ, sin φ).
    axis: Vec2,
}

impl AnisotropicLobe {
    fn new(alpha: f32, anisotropy: f32, axis: Vec3) -> Self {
        let k = (1.0 - 0.9 * anisotropy.clamp(0.0, 1.0)).sqrt();
        let axis = if axis == Vec3::ZERO { Vec2::X } else { Vec2::new(axis.x, axis.y) };
        // Cycles clamps each α to 1 (bsdf_microfacet_ggx_setup).
        AnisotropicLobe { ggx: Anisotropic { alpha_x: (alpha / k).min(1.0), alpha_y: alpha * k }, axis }
    }

    /// The roughness Cycles reads its energy tables at: (α_x α_y)^¼, the
    /// material's own unless α_x was clamped.
    fn table_roughness(&self) -> f32 {
        (self.ggx.alpha_x * self.ggx.alpha_y).sqrt().sqrt()
    }

    /// A direction of the BSDF's frame in the lobe's.
    #[inline]
    fn in_lobe(&self, w: Vec3) -> Vec3 {
        let (c, s) = (self.axis.x, self.axis.y);
        Vec3::new(c * w.x + s * w.y, c * w.y - s * w.x, w.z)
    }

    /// A direction of the lobe's frame in the BSDF's.
    #[inline]
    fn in_bsdf(&self, w: Vec3) -> Vec3 {
        let (c, s) = (self.axis.x, self.axis.y);
        Vec3::new(c * w.x - s * w.y, s * w.x + c * w.y, w.z)
    }

    // Kept out of line, as `sample`: inlined, they made every isotropic
    // BSDF's evaluate and sample too long to inline (1.5% more
    // instructions on the benchmark's gold sphere).
    #[inline(never)]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        self.ggx.eval_pdf(self.in_lobe(wo), self.in_lobe(wi))
    }

    #[inline(never)]
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        self.ggx.sample(self.in_lobe(wo), u).map(|(wi, _)| self.in_bsdf(wi))
    }
}

/// A Specular Tint at one wo: the metal's F82 term b, the dielectric
/// layer's k, and that layer's multiple-scattering scale per channel.
#[derive(Clone, Copy, Debug)]
struct Tints {
    f82_b: Vec3,
    spec_k: Vec3,
    s_tinted: Vec3,
}

/// k of a tinted dielectric layer, F_t = (1 + k)·F − k: F0·(1 − tint)/(1 −
/// F0) at the tables' IOR 1.5 (zero for a white tint), the tint in [0, 1].
fn dielectric_tint_k(tint: Vec3) -> Vec3 {
    super::dielectric::specular_tint_k(((DIELECTRIC_ETA - 1.0) / (DIELECTRIC_ETA + 1.0)).powi(2), tint)
}

/// b of the F82-tint model for F0 and a Specular Tint in [0, 1]: F(1/7)
/// is Schlick's there × the tint (b is 0 for a white tint).
fn f82_tint_b(f0: Vec3, tint: Vec3) -> Vec3 {
    // μ(1 − μ)^6 at μ = 1/7, where it peaks: (1/7)(6/7)^6.
    let f = 6.0f32 / 7.0;
    let schlick = f0 + (Vec3::ONE - f0) * f.powi(5);
    schlick * (Vec3::ONE - tint) * (7.0 / f.powi(6))
}

/// The metal's cosine-weighted mean Fresnel, 2∫F μ dμ: Schlick's less
/// b·2∫μ²(1 − μ)^6 dμ = b·2·B(3, 7) = b/126.
fn metal_average_fresnel(f0: Vec3, f82_b: Vec3) -> Vec3 {
    schlick_average(f0) - f82_b / 126.0
}

/// The metal's Fresnel at cos θ = `cos` under a Specular Tint.
#[inline]
fn metal_fresnel(f0: Vec3, f82_b: Vec3, cos: f32) -> Vec3 {
    let schlick = fresnel_schlick(f0, cos);
    let (c, m) = (cos.clamp(0.0, 1.0), 1.0 - cos.clamp(0.0, 1.0));
    let m2 = m * m;
    (schlick - f82_b * (c * m2 * m2 * m2)).max(Vec3::ZERO)
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
    /// A Specular Tint's terms: the metal's b, the dielectric layer's k
    /// and F_ms per channel (`s_tinted` of `Tints` holds that F_ms here);
    /// None for a white tint.
    tints: Option<Tints>,
    anisotropic: Option<AnisotropicLobe>,
    /// Diffuse Roughness (0 for a metal, which has no base).
    diffuse_roughness: f32,
}

impl PrincipledLobes {
    pub fn new(m: &Surface) -> Self {
        let roughness = m.roughness.clamp(0.0, 1.0);
        let alpha = roughness * roughness;
        let anisotropic = (m.anisotropy > 0.0 && alpha * alpha > SMOOTH_ALPHA_SQ && !m.is_pure_lambert()).then(|| AnisotropicLobe::new(alpha, m.anisotropy, m.tangent));
        let roughness = anisotropic.map_or(roughness, |a| a.table_roughness());
        let base = m.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        // The tables hold IOR 1.5; another IOR scales the layer by its F0,
        // exactly as KHR_materials_specular does (an approximation between
        // the tables' exact ends, like s itself).
        let ior_ratio = (m.ior - 1.0) / (m.ior + 1.0) / 0.2;
        let (smooth, pure_lambert) = (alpha * alpha <= SMOOTH_ALPHA_SQ, m.is_pure_lambert());
        // Specular Tint's terms, worked out only for a tinted material (a
        // textured one builds its lobes at every hit).
        let tint = m.specular_tint.clamp(Vec3::ZERO, Vec3::ONE);
        let tinted = tint != Vec3::ONE;
        let f82_b = if tinted { f82_tint_b(base, tint) } else { Vec3::ZERO };
        let metal_average = metal_average_fresnel(base, f82_b);
        let e_avg = (!(pure_lambert || smooth)).then(|| tables().e_avg(roughness));
        let (f_ms_metal, f_ms_dielectric) = match e_avg {
            None => (Vec3::ZERO, 0.0),
            Some(e_avg) => (ms_fraction(e_avg, metal_average), ms_fraction(e_avg, Vec3::splat(tables().dielectric_f_avg)).x),
        };
        let tints = tinted.then(|| {
            let spec_k = dielectric_tint_k(tint);
            let tinted_average = (Vec3::ONE + spec_k) * tables().dielectric_f_avg - spec_k;
            Tints { f82_b, spec_k, s_tinted: e_avg.map_or(Vec3::ZERO, |e_avg| ms_fraction(e_avg, tinted_average)) }
        });
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
            metal_reflectance: luminance(metal_average),
            base_luminance: luminance(base),
            tints,
            anisotropic,
            diffuse_roughness: if m.metallic < 1.0 { m.diffuse_roughness } else { 0.0 },
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

impl<D: DiffuseBase> PrincipledBsdfWith<D> {
    pub fn new(m: &Surface, wo: Vec3) -> Self {
        Self::at(&PrincipledLobes::new(m), wo)
    }

    pub fn at(m: &PrincipledLobes, wo: Vec3) -> Self {
        let PrincipledLobes { base, metallic, specular, roughness, alpha, smooth, .. } = *m;
        let mu = wo.z.clamp(0.0, 1.0);
        if m.pure_lambert {
            // No glossy lobe, nothing to look up.
            let diffuse_lobe = D::at(m.diffuse_roughness, base, mu);
            return PrincipledBsdfWith { base, metallic, specular, alpha, smooth, s_metal: Vec3::ONE, s_dielectric: 1.0, diffuse_weight: 1.0, glossy_probability: 0.0, reflectance: m.base_luminance, tints: None, anisotropic: None, diffuse_lobe };
        }
        // A mirror loses nothing to single scattering and its layer albedo
        // is the Fresnel reflectance itself. E (the white lobe's albedo) is
        // kept for a tinted layer below.
        let (s_metal, s_dielectric, layer, e) = if smooth {
            (Vec3::ONE, 1.0, fresnel_dielectric(mu, DIELECTRIC_ETA), 1.0)
        } else {
            let (e, layer) = match &m.rows {
                Some(rows) => rows.at(mu),
                None => tables().e_and_layer_in(m.row, mu),
            };
            let s_dielectric = ms_scale(e, Vec3::splat(m.f_ms_dielectric)).x;
            if m.multiscatter {
                (ms_scale(e, m.f_ms_metal), s_dielectric, layer, e)
            } else {
                // Plain GGX: the lobes lose what single scattering loses,
                // but Cycles weights the base below by the albedo its
                // layering table holds for both distributions
                // (bsdf_microfacet_estimate_albedo): the lobe scaled to a
                // white albedo of 1, each bounce Fresnel-weighted. That is
                // the compensated albedo undarkened, E_layer / (S·E) — a
                // plain-GGX dielectric is darker than a multiscatter one.
                (Vec3::ONE, 1.0, layer / (s_dielectric * e).max(f32::MIN_POSITIVE), e)
            }
        };
        // A tinted layer's albedo per channel (module doc): the base gets
        // what its brightest channel leaves, and lobes are chosen by it.
        let (layer, tints) = match m.tints {
            None => (layer, None),
            Some(Tints { f82_b, spec_k: k, s_tinted: f_ms_tinted }) => {
                let (layer, s_tinted) = if smooth {
                    (((Vec3::ONE + k) * layer - k).max(Vec3::ZERO).max_element(), Vec3::ONE)
                } else {
                    let (white, s_t) = if m.multiscatter {
                        (layer / (s_dielectric * e).max(f32::MIN_POSITIVE), ms_scale(e, f_ms_tinted))
                    } else {
                        (layer, Vec3::ONE)
                    };
                    let tinted = (Vec3::ONE + k) * white - k;
                    let albedo = if m.multiscatter { s_t * e * tinted } else { tinted };
                    (albedo.max(Vec3::ZERO).max_element(), s_t)
                };
                (layer, Some(Tints { f82_b, spec_k: k, s_tinted }))
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
        let diffuse_lobe = D::at(m.diffuse_roughness, base, mu);
        PrincipledBsdfWith { base, metallic, specular, alpha, smooth, s_metal, s_dielectric, diffuse_weight, glossy_probability, reflectance: w_glossy + w_diffuse, tints, anisotropic: m.anisotropic, diffuse_lobe }
    }

    /// Expected reflectance at wo: what a coat above weighs it by.
    pub fn reflectance(&self) -> f32 {
        self.reflectance
    }

    /// Fresnel of the glossy lobes, summed with their weights and scales.
    /// A lobe of weight 0 (a pure metal's dielectric, a dielectric's metal)
    /// is not evaluated: the exact Fresnel was a tenth of a metal's shading.
    fn glossy_fresnel(&self, cos_h: f32) -> Vec3 {
        let dielectric_weight = (1.0 - self.metallic) * self.specular;
        if let Some(t) = &self.tints {
            let metal = if self.metallic > 0.0 { self.metallic * self.s_metal * metal_fresnel(self.base, t.f82_b, cos_h) } else { Vec3::ZERO };
            let dielectric = if dielectric_weight > 0.0 { ((Vec3::ONE + t.spec_k) * layer_fresnel(cos_h) - t.spec_k).max(Vec3::ZERO) } else { Vec3::ZERO };
            return metal + dielectric_weight * t.s_tinted * dielectric;
        }
        let metal = if self.metallic > 0.0 { self.metallic * self.s_metal * fresnel_schlick(self.base, cos_h) } else { Vec3::ZERO };
        let dielectric = if dielectric_weight > 0.0 { dielectric_weight * self.s_dielectric * layer_fresnel(cos_h) } else { 0.0 };
        metal + Vec3::splat(dielectric)
    }

    fn has_glossy(&self) -> bool {
        self.glossy_probability > 0.0
    }

    /// The glossy lobes' GGX without Fresnel, and its sampling pdf.
    #[inline]
    fn ggx_eval_pdf(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        match &self.anisotropic {
            None => microfacet::eval_pdf(wo, wi, self.alpha),
            Some(lobe) => lobe.eval_pdf(wo, wi),
        }
    }

    /// The base's lobe, weighted, for wo and wi above the surface.
    #[inline]
    fn diffuse(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.diffuse_lobe.eval(self.base, wo, wi) * self.diffuse_weight
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let diffuse = self.diffuse(wo, wi);
        if self.smooth || !self.has_glossy() {
            return diffuse;
        }
        diffuse + self.glossy_fresnel(microfacet::cos_half(wo, wi)) * self.ggx_eval_pdf(wo, wi).0
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.glossy_probability;
        let glossy = if self.smooth || p == 0.0 { 0.0 } else { p * self.ggx_eval_pdf(wo, wi).1 };
        glossy + (1.0 - p) * lambert::pdf(wo, wi)
    }

    /// `eval` and `pdf` at once, with the lobe's shared terms computed
    /// once: the same numbers, bit for bit.
    #[inline]
    pub fn evaluate(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let p = self.glossy_probability;
        let diffuse_pdf = (1.0 - p) * lambert::pdf(wo, wi);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, diffuse_pdf);
        }
        let diffuse = self.diffuse(wo, wi);
        if self.smooth || !self.has_glossy() {
            return (diffuse, 0.0 + diffuse_pdf);
        }
        let (lobe, lobe_pdf) = self.ggx_eval_pdf(wo, wi);
        (diffuse + self.glossy_fresnel(microfacet::cos_half(wo, wi)) * lobe, p * lobe_pdf + diffuse_pdf)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.glossy_probability;
        if self.smooth && u_lobe < p {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = self.glossy_fresnel(wo.z);
            return Some(BsdfSample { wi, f, pdf: p, weight: f / p, delta: true, diffuse: false });
        }
        let wi = match (u_lobe < p, &self.anisotropic) {
            (true, None) => microfacet::sample(wo, self.alpha, u)?.0,
            (true, Some(lobe)) => lobe.sample(wo, u)?,
            (false, _) => lambert::sample(u),
        };
        let (f, pdf) = self.evaluate(wo, wi);
        let weight = f * (wi.z / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { wi, f, pdf, weight, delta: false, diffuse: u_lobe >= p })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tinted dielectric layer reflects mix(F0·tint, 1, s) per channel:
    /// F0·tint head-on, 1 at grazing, and (1 + k)·F − k between, F the
    /// untinted exact Fresnel (a smooth layer over black shows it alone).
    #[test]
    fn a_tinted_dielectric_layer_is_generalized_schlick() {
        let tint = Vec3::new(0.2, 0.5, 1.0);
        let m = Surface { base_color: Vec3::ZERO, metallic: 0.0, roughness: 0.0, specular_tint: tint, ..crate::material::Material::default().surface() };
        let k = dielectric_tint_k(tint);
        for (theta, expected) in [(0.0f32, 0.04 * tint), (60.0, (Vec3::ONE + k) * fresnel_dielectric(0.5, 1.5) - k)] {
            let wo = Vec3::new(theta.to_radians().sin(), 0.0, theta.to_radians().cos());
            let s = PrincipledBsdf::new(&m, wo).sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
            assert!(s.delta && (s.f - expected).abs().max_element() < 1e-5, "θo {theta}: {} vs {expected}", s.f);
        }
        assert_eq!(dielectric_tint_k(Vec3::ONE), Vec3::ZERO);
    }

    /// The F82-tint Fresnel is Schlick's × the tint at μ = 1/7, Schlick's
    /// itself at normal and grazing incidence, never negative (clamped, as
    /// Cycles saturates it), and its cosine-weighted mean is Schlick's less
    /// b/126.
    #[test]
    fn the_f82_tint_fresnel_is_schlicks_times_the_tint_at_82_degrees() {
        assert_eq!(f82_tint_b(Vec3::splat(0.5), Vec3::ONE), Vec3::ZERO);
        for f0 in [Vec3::new(1.0, 0.78, 0.34), Vec3::new(0.04, 0.5, 0.95), Vec3::ZERO] {
            for tint in [Vec3::new(0.3, 0.6, 1.0), Vec3::ZERO, Vec3::splat(0.9)] {
                let b = f82_tint_b(f0, tint);
                let at = |c: f32| metal_fresnel(f0, b, c);
                let close = |a: Vec3, e: Vec3| (a - e).abs().max_element() < 1e-5;
                assert!(close(at(1.0 / 7.0), fresnel_schlick(f0, 1.0 / 7.0) * tint), "{f0} {tint}: {}", at(1.0 / 7.0));
                assert!(close(at(1.0), f0) && close(at(0.0), Vec3::ONE));
                let n = 20_000;
                let mut mean = Vec3::ZERO;
                for i in 0..n {
                    let c = (i as f32 + 0.5) / n as f32;
                    assert!(at(c).min_element() >= 0.0);
                    // A dark tint over a small F0 takes the model below 0
                    // past 82°, where it is clamped; the mean (Cycles' F_ss
                    // too) is the unclamped model's.
                    let unclamped = fresnel_schlick(f0, c) - b * (c * (1.0 - c).powi(6));
                    mean += unclamped * (2.0 * c / n as f32);
                }
                assert!((mean - metal_average_fresnel(f0, b)).abs().max_element() < 1e-4, "{f0} {tint}: {mean} vs {}", metal_average_fresnel(f0, b));
            }
        }
    }
}
