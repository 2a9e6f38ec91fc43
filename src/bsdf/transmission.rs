//! Glass mixed into a BSDF model as Cycles' Principled BSDF mixes it:
//!
//!   f = t · f_glass + (1 − t) · f_base(metallic m / (1 − t)),   t = (1 − m) · transmission
//!
//! so the metal keeps its weight m, the glass (dielectric.rs) gets
//! (1 − m)·transmission and the specular-over-diffuse layer the rest,
//! (1 − m)(1 − transmission). Only kernels for scenes with a transmissive
//! material run this (features.rs): other scenes never pay for it.

use super::dielectric::Dielectric;
use super::microfacet::eta_from_f0;
use super::{translucent, Bsdf, BsdfSample};
use crate::material::Surface;
use glam::Vec2;
use crate::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct WithGlass<B> {
    /// None when the surface is all glass.
    base: Option<B>,
    /// None when none of the surface is glass.
    glass: Option<Transmitting>,
    /// t above.
    glass_weight: f32,
    /// Probability of sampling the glass (t: both parts return about all
    /// they receive, so their weights are their shares).
    glass_probability: f32,
}

/// What the transmission part is: glass, or a Translucent BSDF node's
/// Lambert through the surface in its colour (`Surface::translucent`).
#[derive(Clone, Copy, Debug)]
enum Transmitting {
    Glass(Dielectric),
    Translucent(Vec3),
}

impl Transmitting {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Transmitting::Glass(g) => g.eval(wo, wi),
            Transmitting::Translucent(albedo) => translucent::eval(*albedo, wo, wi),
        }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Transmitting::Glass(g) => g.pdf(wo, wi),
            Transmitting::Translucent(_) => translucent::pdf(wo, wi),
        }
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Transmitting::Glass(g) => g.sample(wo, u_lobe, u),
            Transmitting::Translucent(albedo) => {
                let wi = translucent::sample(wo, u);
                let pdf = translucent::pdf(wo, wi);
                (pdf > 0.0).then(|| BsdfSample { wi, f: translucent::eval(*albedo, wo, wi), pdf, weight: *albedo, delta: false, diffuse: true })
            }
        }
    }
}

/// The relative IOR of the glass: the surface's, moved by
/// KHR_materials_specular as Cycles moves it by Specular IOR Level (its
/// F0 scaled, the IOR recovered from it, 1 when F0 is 0).
fn glass_eta(s: &Surface) -> f32 {
    if s.specular == 1.0 {
        return s.ior;
    }
    let eta = eta_from_f0(s.dielectric_f0());
    if s.ior < 1.0 { 1.0 / eta } else { eta }
}

/// What `WithGlass` knows of a surface before it knows wo: the base's
/// own preparation for its share of the metal, and the glass's constants.
/// Prepared once per material (render.rs), so that a floor in a scene
/// with glass does not rebuild its base's lobes at every vertex.
#[derive(Clone, Copy, Debug)]
pub struct PreparedGlass<P> {
    base: Option<P>,
    glass: Option<TransmittingPart>,
    /// t above.
    share: f32,
}

/// The transmission part's constants (`Transmitting` less what depends
/// on wo).
#[derive(Clone, Copy, Debug)]
enum TransmittingPart {
    Glass { eta: f32, roughness: f32, tint: Vec3, multiscatter: bool, specular_tint: Vec3 },
    Translucent(Vec3),
}

impl<B: Bsdf> Bsdf for WithGlass<B> {
    type Prepared = PreparedGlass<B::Prepared>;
    const GLASS: bool = true;
    fn prepare(s: &Surface) -> Self::Prepared {
        let metallic = s.metallic.clamp(0.0, 1.0);
        let t = (1.0 - metallic) * s.transmission.clamp(0.0, 1.0);
        let base_color = s.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        let glass = (t > 0.0).then(|| {
            if s.translucent {
                TransmittingPart::Translucent(base_color)
            } else {
                TransmittingPart::Glass { eta: glass_eta(s), roughness: s.roughness, tint: base_color.map(f32::sqrt), multiscatter: s.multiscatter, specular_tint: s.specular_tint }
            }
        });
        let base = (t < 1.0).then(|| B::prepare(&Surface { metallic: metallic / (1.0 - t), transmission: 0.0, translucent: false, ..*s }));
        PreparedGlass { base, glass, share: t }
    }

    fn at(p: &Self::Prepared, wo: Vec3) -> Self {
        let glass = p.glass.map(|part| match part {
            TransmittingPart::Translucent(albedo) => Transmitting::Translucent(albedo),
            TransmittingPart::Glass { eta, roughness, tint, multiscatter, specular_tint } => Transmitting::Glass(Dielectric::new(eta, roughness, tint, multiscatter, wo.z.clamp(0.0, 1.0)).with_specular_tint(specular_tint)),
        });
        let base = p.base.as_ref().map(|b| B::at(b, wo));
        WithGlass { base, glass, glass_weight: p.share, glass_probability: p.share }
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let glass = self.glass.as_ref().map_or(Vec3::ZERO, |g| g.eval(wo, wi));
        let base = self.base.as_ref().map_or(Vec3::ZERO, |b| b.eval(wo, wi));
        glass * self.glass_weight + base * (1.0 - self.glass_weight)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let glass = self.glass.as_ref().map_or(0.0, |g| g.pdf(wo, wi));
        let base = self.base.as_ref().map_or(0.0, |b| b.pdf(wo, wi));
        glass * self.glass_probability + base * (1.0 - self.glass_probability)
    }

    fn evaluate(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let (glass, glass_pdf) = self.glass.as_ref().map_or((Vec3::ZERO, 0.0), |g| (g.eval(wo, wi), g.pdf(wo, wi)));
        let (base, base_pdf) = self.base.as_ref().map_or((Vec3::ZERO, 0.0), |b| b.evaluate(wo, wi));
        (glass * self.glass_weight + base * (1.0 - self.glass_weight), glass_pdf * self.glass_probability + base_pdf * (1.0 - self.glass_probability))
    }

    fn transmits(&self) -> bool {
        match self.glass {
            Some(Transmitting::Glass(g)) => !g.smooth,
            Some(Transmitting::Translucent(_)) => true,
            None => false,
        }
    }

    /// Glass passes on about all it receives, a translucent surface its
    /// albedo.
    fn reflectance(&self) -> f32 {
        let passed = match self.glass {
            Some(Transmitting::Translucent(albedo)) => super::luminance(albedo),
            _ => 1.0,
        };
        self.glass_weight * passed + (1.0 - self.glass_weight) * self.base.as_ref().map_or(0.0, |b| b.reflectance())
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let p = self.glass_probability;
        // One uniform picks the part and, rescaled, the lobe within it.
        let (s, weight, probability) = match (&self.glass, &self.base) {
            (Some(g), _) if u_lobe < p => (g.sample(wo, u_lobe / p, u)?, self.glass_weight, p),
            (_, Some(b)) => (b.sample(wo, ((u_lobe - p) / (1.0 - p)).clamp(0.0, 1.0), u)?, 1.0 - self.glass_weight, 1.0 - p),
            _ => return None,
        };
        // No other part can produce a delta direction, and a surface with
        // one part alone is that part: its sample's f and pdf are the
        // mixture's.
        if s.delta || self.glass.is_none() || self.base.is_none() {
            return Some(BsdfSample { f: s.f * weight, pdf: s.pdf * probability, weight: s.weight * (weight / probability), ..s });
        }
        let (f, pdf) = self.evaluate(wo, s.wi);
        let weight = f * (s.wi.z.abs() / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { f, pdf, weight, ..s })
    }
}
