//! A rough dielectric boundary (glass): GGX reflection and refraction after
//! Walter et al. 2007, in the local frame with the normal (+z) on the side
//! of wo. η = n_below / n_above is the relative IOR the ray meets: the
//! material's IOR entering a front face, its inverse leaving through a back
//! face (SurfaceHit flips it).
//!
//!   reflection (wi above):  f = D F G2 / (4 cosθo cosθi),           h ∝ wo + wi
//!   refraction (wi below):  f = D (1−F) G2 |wi·h| (wo·h)
//!                               / (cosθo |cosθi| (η wi·h + wo·h)²),  h ∝ wo + η wi
//!
//! F is the exact dielectric Fresnel at wo·h. The refraction term is the
//! BTDF for radiance: radiance crossing into the denser side grows by η², so
//! a camera path entering glass is weighted 1/η² and leaving it η² — the
//! two cancel through a closed object. (Cycles leaves this factor out, which
//! is the same image whenever camera and lights are outside the glass.)
//!
//! Sampling: a visible normal h for wo (microfacet.rs), then reflection with
//! probability F(wo·h), else refraction through h. The pdf is the visible
//! normal density times the Jacobian of the chosen mapping, 1/(4 wo·h) for
//! reflection and η²|wi·h|/(η wi·h + wo·h)² for refraction, times the
//! choice's probability. A sample's weight is then G2/G1(wo), ×1/η² when
//! refracted.
//!
//! As in Cycles' Principled BSDF, refraction is tinted by √base colour (the
//! colour once in and once out), reflection is not, and multiple scattering
//! is compensated by 1/E (E the lobe's single-scattering albedo, both lobes,
//! tabulated below), darkened for a coloured tint as energy.rs does for metal.

use super::energy::{cell, cosine_average, lerp_grid, ms_fraction, ms_scale, view, visible_normal_mean};
use super::ggx::d;
use super::microfacet::{fresnel_dielectric, g1, g2, sample_visible_normal};
use super::{baked, BsdfSample, SMOOTH_ALPHA_SQ};
use crate::rng::Rng;
use glam::Vec2;
use crate::Vec3;
use rayon::prelude::*;
use std::sync::OnceLock;

/// k of a generalized-Schlick tint of F0 (Cycles' Specular Tint on a
/// dielectric), F_t = (1 + k)·F − k: F0·(1 − tint)/(1 − F0), zero for a
/// white tint, the tint in [0, 1].
pub fn specular_tint_k(f0: f32, tint: Vec3) -> Vec3 {
    (Vec3::ONE - tint) * (f0 / (1.0 - f0))
}

/// |η − 1| under which the boundary bends nothing and reflects nothing: a
/// ray passes straight on (the generalised half vector is undefined there).
const INDEX_MATCHED: f32 = 1e-3;

#[derive(Clone, Copy, Debug)]
pub struct Dielectric {
    eta: f32,
    alpha: f32,
    /// A perfectly smooth boundary: both lobes are deltas.
    pub smooth: bool,
    /// Refraction's tint, √base colour.
    tint: Vec3,
    /// Multiple-scattering compensation of both lobes (1 when smooth or
    /// plain "GGX").
    scale: Vec3,
    /// Specular Tint's k (`with_specular_tint`); None untinted.
    specular_k: Option<Vec3>,
}

/// wo refracted through the microfacet normal h (wo·h > 0) into the side
/// below, η = n_below / n_above; None under total internal reflection.
pub fn refract(wo: Vec3, h: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(h);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / eta + (cos_i / eta - cos_t) * h)
}

/// Λ's direction argument is a slope: the same for a direction below the
/// surface as for its mirror image above.
#[inline]
fn upper(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, w.z.abs())
}

impl Dielectric {
    /// `mu` = cosθo decides the compensation, as Cycles' does.
    pub fn new(eta: f32, roughness: f32, tint: Vec3, multiscatter: bool, mu: f32) -> Self {
        let eta = if eta.is_finite() && eta > 0.0 { eta } else { 1.5 };
        let roughness = roughness.clamp(0.0, 1.0);
        let alpha = roughness * roughness;
        let smooth = alpha * alpha <= SMOOTH_ALPHA_SQ || (eta - 1.0).abs() < INDEX_MATCHED;
        let tint = tint.clamp(Vec3::ZERO, Vec3::ONE);
        let scale = if smooth || !multiscatter {
            Vec3::ONE
        } else {
            let t = glass_tables();
            ms_scale(t.e(mu, roughness, eta), ms_fraction(t.e_avg(roughness, eta), tint))
        };
        Dielectric { eta, alpha, smooth, tint, scale, specular_k: None }
    }

    /// Blender's Specular Tint on glass, as Cycles' Principled BSDF takes
    /// it: F0 × tint, and F = mix(F0·tint, 1, s) along the exact curve —
    /// per channel F_t = (1 + k)·F − k, k = F0(1 − tint)/(1 − F0), the
    /// dielectric layer's form (principled.rs) — in what the glass
    /// reflects and, as 1 − F_t, in what it lets through. Sampling still
    /// picks a side by the untinted F; a white tint changes nothing.
    pub fn with_specular_tint(self, tint: Vec3) -> Self {
        let tint = tint.clamp(Vec3::ZERO, Vec3::ONE);
        let r = (self.eta - 1.0) / (self.eta + 1.0);
        if tint == Vec3::ONE {
            return self;
        }
        Dielectric { specular_k: Some(specular_tint_k(r * r, tint)), ..self }
    }

    /// Fresnel F at a microfacet as the two sides get it, per channel:
    /// reflected F_t and refracted 1 − F_t (F and 1 − F untinted).
    #[inline]
    fn sides(&self, f: f32) -> (Vec3, Vec3) {
        match self.specular_k {
            None => (Vec3::splat(f), Vec3::splat(1.0 - f)),
            Some(k) => {
                let reflected = ((Vec3::ONE + k) * f - k).clamp(Vec3::ZERO, Vec3::ONE);
                (reflected, Vec3::ONE - reflected)
            }
        }
    }

    /// The microfacet normal joining wo and wi, facing +z, with whether wi
    /// is refracted; None where no microfacet does (or wi is grazing).
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, bool)> {
        if wo.z <= 0.0 || wi.z == 0.0 {
            return None;
        }
        let refracted = wi.z < 0.0;
        let mut h = if refracted { wo + self.eta * wi } else { wo + wi };
        if h.z < 0.0 {
            h = -h;
        }
        let h = h.normalize_or_zero();
        // Both directions must see the microfacet from their own side.
        let ok = h.z > 0.0 && wo.dot(h) > 0.0 && (wi.dot(h) < 0.0) == refracted && wi.dot(h) != 0.0;
        ok.then_some((h, refracted))
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.smooth {
            return Vec3::ZERO;
        }
        let Some((h, refracted)) = self.half_vector(wo, wi) else { return Vec3::ZERO };
        let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
        let f = fresnel_dielectric(wo_h, self.eta);
        let dg = d(h, self.alpha) * g2(wo, upper(wi), self.alpha);
        let (reflected, through) = self.sides(f);
        if refracted {
            let denom = self.eta * wi_h + wo_h;
            self.tint * self.scale * (dg * through * wi_h.abs() * wo_h / (wo.z * wi.z.abs() * denom * denom))
        } else {
            self.scale * (dg * reflected / (4.0 * wo.z * wi.z))
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.smooth {
            return 0.0;
        }
        let Some((h, refracted)) = self.half_vector(wo, wi) else { return 0.0 };
        let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
        let f = fresnel_dielectric(wo_h, self.eta);
        let visible = d(h, self.alpha) * g1(wo, self.alpha) * wo_h / wo.z;
        if refracted {
            let denom = self.eta * wi_h + wo_h;
            visible * (1.0 - f) * self.eta * self.eta * wi_h.abs() / (denom * denom)
        } else {
            visible * f / (4.0 * wo_h)
        }
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let radiance = 1.0 / (self.eta * self.eta);
        if self.smooth {
            let f = fresnel_dielectric(wo.z, self.eta);
            // Untinted, each side's share over its probability is 1 exactly.
            let (reflected, through) = self.sides(f);
            if u_lobe < f {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                return Some(BsdfSample { wi, f: reflected, pdf: f, weight: reflected / f, delta: true, diffuse: false });
            }
            let wi = refract(wo, Vec3::Z, self.eta)?;
            let weight = self.tint * radiance;
            return Some(BsdfSample { wi, f: weight * through, pdf: 1.0 - f, weight: weight * (through / (1.0 - f)), delta: true, diffuse: false });
        }
        let h = sample_visible_normal(wo, self.alpha, u);
        let f = fresnel_dielectric(wo.dot(h), self.eta);
        let wi = if u_lobe < f {
            let wi = 2.0 * wo.dot(h) * h - wo;
            if wi.z <= 0.0 {
                return None;
            }
            wi
        } else {
            let wi = refract(wo, h, self.eta)?;
            if wi.z >= 0.0 {
                return None;
            }
            wi
        };
        let pdf = self.pdf(wo, wi);
        let f = self.eval(wo, wi);
        let weight = f * (wi.z.abs() / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { wi, f, pdf, weight, delta: false, diffuse: false })
    }
}

// ---------------------------------------------------------------- energy

/// Grid points per axis: roughness, √μ and z = √((η−1)/(η+1)).
const G: usize = 16;
/// Stratified samples per entry (STRATA² of them).
const STRATA: usize = 32;
/// The largest η the table holds (z for η = 4); beyond it, its edge.
const Z_MAX: f32 = 0.774_596_7;

fn grid(i: usize) -> f32 {
    i as f32 / (G - 1) as f32
}

fn eta_of_z(z: f32) -> f32 {
    let x = z * z;
    (1.0 + x) / (1.0 - x)
}

/// Single-scattering albedo of the glass lobes, F = exact Fresnel, no tint,
/// no radiance scaling (what is compensated is energy, not radiance), as a
/// function of cosθo, roughness and η; entering (η > 1) and leaving (η < 1)
/// are separate tables over the same grid of η ≥ 1.
pub struct GlassTables {
    e: [Vec<f32>; 2],
    e_avg: [Vec<f32>; 2],
}

/// E_VNDF[G2/G1(wo)] over the lobe the sampler picks by F.
fn glass_albedo(mu: f32, roughness: f32, eta: f32) -> f32 {
    let wo = view(mu);
    let alpha = (roughness * roughness).max(1e-4);
    let g1o = g1(wo, alpha);
    let mut rng = Rng::new(mu.max(1e-3).to_bits() as u64, (roughness.to_bits() as u64) << 32 | eta.to_bits() as u64);
    visible_normal_mean(wo, alpha, STRATA, &mut rng, |h| {
        let f = fresnel_dielectric(wo.dot(h), eta);
        let reflected = 2.0 * wo.dot(h) * h - wo;
        let r = if reflected.z > 0.0 { f * g2(wo, reflected, alpha) / g1o } else { 0.0 };
        let t = refract(wo, h, eta).filter(|t| t.z < 0.0).map_or(0.0, |t| (1.0 - f) * g2(wo, upper(t), alpha) / g1o);
        r + t
    })
}

/// Floats a baked `GlassTables` holds: E entering, E leaving, then E_avg
/// of each.
pub(super) const BAKED_FLOATS: usize = 2 * G * G * G + 2 * G * G;

impl GlassTables {
    /// The tables from the lobe code (about 0.3 s on 2 cores).
    pub fn build() -> Self {
        let table = |leaving: bool| -> (Vec<f32>, Vec<f32>) {
            // Index: (z·G + roughness)·G + √μ.
            let e: Vec<f32> = (0..G * G * G)
                .into_par_iter()
                .map(|k| {
                    let (mi, ri, zi) = (k % G, (k / G) % G, k / (G * G));
                    let eta = eta_of_z(grid(zi) * Z_MAX);
                    glass_albedo(grid(mi) * grid(mi), grid(ri), if leaving { 1.0 / eta } else { eta })
                })
                .collect();
            let e_avg = e.chunks(G).map(|row| cosine_average(|mu| lerp_grid(row, mu.sqrt() * (G - 1) as f32))).collect();
            (e, e_avg)
        };
        let (enter, leave) = (table(false), table(true));
        GlassTables { e: [enter.0, leave.0], e_avg: [enter.1, leave.1] }
    }

    /// Every value, in the baked file's order.
    pub fn to_floats(&self) -> Vec<f32> {
        [&self.e[0][..], &self.e[1], &self.e_avg[0], &self.e_avg[1]].concat()
    }

    fn from_floats(v: &[f32]) -> Self {
        let (e, e_avg) = v.split_at(2 * G * G * G);
        let (enter, leave) = e.split_at(G * G * G);
        let (enter_avg, leave_avg) = e_avg.split_at(G * G);
        GlassTables { e: [enter.to_vec(), leave.to_vec()], e_avg: [enter_avg.to_vec(), leave_avg.to_vec()] }
    }

    /// Which table, and the fractional z index, for a relative IOR.
    fn locate(eta: f32) -> (usize, f32) {
        let (side, eta) = if eta < 1.0 { (1, 1.0 / eta) } else { (0, eta) };
        let z = ((eta - 1.0) / (eta + 1.0)).max(0.0).sqrt();
        (side, (z / Z_MAX).min(1.0) * (G - 1) as f32)
    }

    pub fn e(&self, mu: f32, roughness: f32, eta: f32) -> f32 {
        let (side, z) = Self::locate(eta);
        let (x, y) = (mu.clamp(0.0, 1.0).sqrt() * (G - 1) as f32, roughness.clamp(0.0, 1.0) * (G - 1) as f32);
        let plane = |zi: usize| {
            let at = |ri: usize| lerp_grid(&self.e[side][(zi * G + ri) * G..(zi * G + ri + 1) * G], x);
            lerp_pair(at, y)
        };
        lerp_pair(plane, z).clamp(1e-3, 1.0)
    }

    pub fn e_avg(&self, roughness: f32, eta: f32) -> f32 {
        let (side, z) = Self::locate(eta);
        let y = roughness.clamp(0.0, 1.0) * (G - 1) as f32;
        lerp_pair(|zi| lerp_grid(&self.e_avg[side][zi * G..(zi + 1) * G], y), z).clamp(1e-3, 1.0)
    }
}

/// Linear interpolation between the values at the two grid indices around
/// x, each given by `at` (a row or plane of a table).
fn lerp_pair(at: impl Fn(usize) -> f32, x: f32) -> f32 {
    let i = cell(x, G);
    let t = (x - i as f32).clamp(0.0, 1.0);
    at(i) * (1.0 - t) + at(i + 1) * t
}

/// The baked tables (baked.rs; built afresh only if the baked file were
/// not the tables' size, which the tests rule out).
pub fn glass_tables() -> &'static GlassTables {
    static TABLES: OnceLock<GlassTables> = OnceLock::new();
    TABLES.get_or_init(|| baked::floats(include_bytes!("glass.bin"), BAKED_FLOATS).map_or_else(GlassTables::build, |v| GlassTables::from_floats(&v)))
}
