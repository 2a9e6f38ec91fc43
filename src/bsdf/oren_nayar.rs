//! Rough diffuse: Blender's Diffuse Roughness (Principled BSDF) and a
//! Diffuse BSDF node's Roughness, as Cycles 4.5 renders them — Fujii's
//! improved Oren–Nayar model with the energy-preserving multiple-scattering
//! term of OpenPBR's EON. With σ the roughness in [0, 1], μ = cos θ in the
//! shading frame and ρ the albedo, per unit of the lobe's weight (which, in
//! Cycles as here, holds ρ once more):
//!
//!   f = A + B·s/t + E_ms · (1 − E(μo)) (1 − E(μi))
//!
//! * A = 1/(π + σ(π/2 − 2/3)), B = σA; s = wo·wi − μo μi, t = max(μo, μi)
//!   where s > 0, else 1. At σ = 0 this is Lambert's 1/π.
//! * E(μ) = Aπ + B·G(μ), the single-scattering lobe's directional albedo,
//!   G(μ) = sin θ (θ − 2/3 − sin θ cos θ) + (2/3) tan θ (1 − sin³ θ);
//!   its cosine-weighted mean Ē = Aπ + B(2π − 5.6)/3.
//! * E_ms = (1/π) ρ² Ē/(1 − Ē) / (1 − ρ(1 − Ē)): a white surface then
//!   reflects all the light it gets at every angle.
//!
//! Sampled by the cosine, as Lambert's. The model is reciprocal.

use crate::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// Below this roughness Cycles renders plain Lambert (where 1 − Ē
/// vanishes, E_ms would divide by zero).
pub const SMOOTH_ROUGHNESS: f32 = 1e-5;

/// A material's rough diffuse lobe: what depends on σ and ρ alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrenNayar {
    a: f32,
    b: f32,
    /// E_ms per channel.
    ms: Vec3,
}

impl OrenNayar {
    /// None where the lobe is Lambert's (σ below `SMOOTH_ROUGHNESS`).
    pub fn new(roughness: f32, albedo: Vec3) -> Option<Self> {
        let sigma = roughness.clamp(0.0, 1.0);
        if !(sigma >= SMOOTH_ROUGHNESS) {
            return None;
        }
        let a = 1.0 / (PI + sigma * (FRAC_PI_2 - 2.0 / 3.0));
        let b = sigma * a;
        let e_avg = a * PI + b * ((2.0 * PI - 5.6) / 3.0);
        let rho = albedo.clamp(Vec3::ZERO, Vec3::ONE);
        // 1 − Ē ≥ 0.2σ/π > 0 and 1 − ρ(1 − Ē) ≥ Ē > 0: finite.
        let ms = rho * rho * (e_avg / (PI * (1.0 - e_avg))) / (Vec3::ONE - rho * (1.0 - e_avg));
        Some(OrenNayar { a, b, ms })
    }

    /// E(μ): the single-scattering lobe's directional albedo.
    fn albedo(&self, mu: f32) -> f32 {
        albedo(self.a, self.b, mu)
    }

    /// The lobe seen from wo (μo = wo.z, its shading-frame cosine).
    // Out of line, as `RoughDiffuse::eval`: the kernel that has them
    // (principled.rs, `DiffuseBase`) keeps the Principled BSDF's
    // `evaluate` and `sample` short enough to inline.
    #[inline(never)]
    pub fn at(&self, mu_o: f32) -> RoughDiffuse {
        RoughDiffuse { a: self.a, b: self.b, ms_o: self.ms * (1.0 - self.albedo(mu_o)) }
    }
}

fn albedo(a: f32, b: f32, mu: f32) -> f32 {
    a * PI + b * g(mu)
}

/// G(μ) of the module's E(μ), without the cancellations of its textbook
/// form: 1 − sin³θ = (1 − sin θ)(1 + sin θ + sin²θ) and 1 − sin θ =
/// μ²/(1 + sin θ), so the tangent's term is (2/3) sin θ · μ (1 + sin θ +
/// sin²θ)/(1 + sin θ), finite at grazing (where G → π/2 − 2/3).
fn g(mu: f32) -> f32 {
    let mu = mu.clamp(0.0, 1.0);
    let sin = (1.0 - mu * mu).max(0.0).sqrt();
    let theta = mu.acos();
    let tan_term = (2.0 / 3.0) * sin * mu * (1.0 + sin + sin * sin) / (1.0 + sin);
    sin * (theta - 2.0 / 3.0 - sin * mu) + tan_term
}

/// A rough diffuse lobe at one wo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDiffuse {
    a: f32,
    b: f32,
    /// E_ms · (1 − E(μo)).
    ms_o: Vec3,
}

impl RoughDiffuse {
    /// f / weight for wo, wi in the upper hemisphere (the caller tests
    /// that): Lambert's 1/π becomes this.
    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (mu_o, mu_i) = (wo.z.max(0.0), wi.z.max(0.0));
        let s = wo.dot(wi) - mu_o * mu_i;
        // s > 0 divides by max(μo, μi) ≥ s: no blow-up at grazing.
        let s_over_t = if s > 0.0 { s / (mu_o.max(mu_i) + f32::MIN_POSITIVE) } else { s };
        let single = self.a + self.b * s_over_t;
        Vec3::splat(single) + self.ms_o * (1.0 - albedo(self.a, self.b, mu_i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_1_PI;

    fn direction(mu: f32, phi: f32) -> Vec3 {
        let sin = (1.0 - mu * mu).max(0.0).sqrt();
        Vec3::new(sin * phi.cos(), sin * phi.sin(), mu)
    }

    /// ∫ f(wo, wi) cos θi dωi × ρ (the lobe's weight) by a midpoint rule
    /// over (μi, φi).
    fn reflected(lobe: &OrenNayar, rho: f32, wo: Vec3) -> f32 {
        let (n_mu, n_phi) = (400, 200);
        let at = lobe.at(wo.z);
        let mut sum = 0.0f64;
        for i in 0..n_mu {
            let mu = (i as f32 + 0.5) / n_mu as f32;
            for j in 0..n_phi {
                let phi = (j as f32 + 0.5) / n_phi as f32 * 2.0 * PI;
                sum += (at.eval(wo, direction(mu, phi)).x * mu) as f64;
            }
        }
        rho * (sum * 2.0 * std::f64::consts::PI / (n_mu * n_phi) as f64) as f32
    }

    /// White furnace: at ρ = 1 the lobe reflects all the light at every
    /// angle and roughness (what the multiple-scattering term is for);
    /// the single-scattering term alone loses a fifth of it head-on at σ = 1.
    #[test]
    fn a_white_rough_diffuse_surface_reflects_everything() {
        for sigma in [0.05f32, 0.3, 0.7, 1.0] {
            let lobe = OrenNayar::new(sigma, Vec3::ONE).unwrap();
            for mu_o in [1.0f32, 0.7, 0.3, 0.05] {
                let r = reflected(&lobe, 1.0, direction(mu_o, 0.3));
                assert!((r - 1.0).abs() < 2e-3, "σ {sigma}, μo {mu_o}: {r}");
            }
        }
        let single = OrenNayar { ms: Vec3::ZERO, ..OrenNayar::new(1.0, Vec3::ONE).unwrap() };
        let lost = 1.0 - reflected(&single, 1.0, direction(1.0, 0.0));
        assert!(lost > 0.2, "{lost}");
    }

    /// E(μ) is the single-scattering lobe's albedo, and Ē its mean: the
    /// closed forms the compensation rests on, against quadrature.
    #[test]
    fn the_albedo_closed_forms_match_quadrature() {
        for sigma in [0.2f32, 1.0] {
            let lobe = OrenNayar::new(sigma, Vec3::ONE).unwrap();
            let single = OrenNayar { ms: Vec3::ZERO, ..lobe };
            let mut mean = 0.0;
            let n = 40;
            for k in 0..n {
                let mu = (k as f32 + 0.5) / n as f32;
                let e = reflected(&single, 1.0, direction(mu, 1.0));
                assert!((e - lobe.albedo(mu)).abs() < 2e-3, "σ {sigma}, μ {mu}: {e} vs {}", lobe.albedo(mu));
                mean += 2.0 * mu * lobe.albedo(mu) / n as f32;
            }
            let e_avg = lobe.a * PI + lobe.b * ((2.0 * PI - 5.6) / 3.0);
            assert!((mean - e_avg).abs() < 2e-3, "σ {sigma}: {mean} vs {e_avg}");
        }
    }

    /// Swapping wo and wi changes nothing, and a coloured surface reflects
    /// less than its albedo (ρ·E plus a multiple-scattering part that is
    /// ρ³-small for dark colours, as in Cycles).
    #[test]
    fn rough_diffuse_is_reciprocal_and_keeps_below_its_albedo() {
        let rho = Vec3::new(0.9, 0.5, 0.1);
        let lobe = OrenNayar::new(0.8, rho).unwrap();
        for (a, b) in [(direction(0.9, 0.0), direction(0.2, 2.0)), (direction(0.01, 1.0), direction(0.6, 1.2)), (direction(0.5, 0.0), direction(0.5, 0.1))] {
            let (ab, ba) = (lobe.at(a.z).eval(a, b), lobe.at(b.z).eval(b, a));
            assert!((ab - ba).abs().max_element() < 1e-6, "{ab} vs {ba}");
            assert!(ab.min_element() >= 0.0 && ab.is_finite());
        }
        for (channel, &r) in rho.to_array().iter().enumerate() {
            let lobe = OrenNayar::new(0.8, Vec3::splat(r)).unwrap();
            let reflected = reflected(&lobe, r, direction(0.6, 0.0));
            assert!(reflected < r && reflected > 0.8 * r, "channel {channel}: {reflected} of {r}");
        }
    }

    /// Lambert below the threshold; continuous above it; finite at exact
    /// grazing and at normal incidence.
    #[test]
    fn smooth_is_lambert_and_grazing_is_finite() {
        assert!(OrenNayar::new(0.0, Vec3::ONE).is_none() && OrenNayar::new(f32::NAN, Vec3::ONE).is_none());
        let barely = OrenNayar::new(2.0 * SMOOTH_ROUGHNESS, Vec3::splat(0.7)).unwrap();
        let (wo, wi) = (direction(0.4, 0.0), direction(0.8, 2.5));
        assert!((barely.at(wo.z).eval(wo, wi) - Vec3::splat(FRAC_1_PI)).abs().max_element() < 1e-4);
        let rough = OrenNayar::new(1.0, Vec3::splat(0.7)).unwrap();
        for (o, i) in [(direction(0.0, 0.0), direction(1.0, 0.0)), (direction(0.0, 0.0), direction(0.0, 0.0)), (direction(1.0, 0.0), direction(0.0, 1.0)), (direction(1e-7, 0.0), direction(1e-7, 0.0))] {
            let f = rough.at(o.z).eval(o, i);
            assert!(f.is_finite() && f.min_element() >= 0.0, "{o} {i}: {f}");
        }
        assert!((g(0.0) - (FRAC_PI_2 - 2.0 / 3.0)).abs() < 1e-6 && g(1.0).abs() < 1e-6);
    }
}
