//! Tests of the glass lobe (dielectric.rs) and of its mixing into the
//! models (transmission.rs): sampling against the pdf, energy, the smooth
//! limit, the energy table against an independent integral, and extreme
//! inputs.

use super::chi2::{bsdf_chi2, chi2_test, dir_at, u2};
use super::dielectric::{glass_tables, refract, Dielectric};
use super::*;
use crate::material::{Material, Surface};
use crate::rng::Rng;

const P_MIN: f64 = 1e-4;
const N: usize = 1_000_000;

fn glass(base: Vec3, metallic: f32, roughness: f32, transmission: f32, ior: f32) -> Surface {
    Material { base_color: base, metallic, roughness, transmission, ior, ..Material::default() }.surface()
}

/// Entering (1.5) and leaving (1/1.5) a glass of IOR 1.5.
const ETAS: [f32; 2] = [1.5, 1.0 / 1.5];

/// The harness' quadrature (bins of 9°) resolves these lobes. Narrower
/// ones fail it without a fault in the sampler: at roughness 0.3 seen
/// head-on the refracted lobe is ~2° wide, and a 16× finer quadrature of
/// the same pdf then matched the sampled shares above and below the
/// surface to within 1σ of their binomial noise.
#[test]
fn glass_sampling_matches_its_pdf_both_ways_through() {
    for eta in ETAS {
        for roughness in [0.4f32, 0.7, 1.0] {
            for theta in [10.0f32, 45.0, 70.0] {
                let wo = dir_at(theta);
                let g = Dielectric::new(eta, roughness, Vec3::ONE, true, wo.z);
                let r = chi2_test(N, 31, |rng| {
                    let ul = rng.next_f32();
                    g.sample(wo, ul, u2(rng)).map(|s| s.wi)
                }, |wi| g.pdf(wo, wi));
                assert!(r.p_value > P_MIN, "η {eta} roughness {roughness} θo {theta}: p = {} (χ² {} dof {})", r.p_value, r.statistic, r.dof);
                assert!((r.pdf_integral - r.success_fraction).abs() < 5e-3, "η {eta} r {roughness} θo {theta}: ∫pdf {} vs {}", r.pdf_integral, r.success_fraction);
            }
        }
    }
}

/// Weights carry 1/η² when refracted (radiance); η² undoes it to count
/// energy.
fn energy_of(g: &Dielectric, wo: Vec3, eta: f32, n: usize, seed: u64) -> f32 {
    let mut rng = Rng::new(seed, 3);
    let mut sum = 0.0f64;
    for _ in 0..n {
        let ul = rng.next_f32();
        if let Some(s) = g.sample(wo, ul, rng.next_2d()) {
            let flux = if s.wi.z < 0.0 { eta * eta } else { 1.0 };
            sum += (s.weight.x * flux) as f64;
        }
    }
    (sum / n as f64) as f32
}

/// The white furnace for glass: clear glass neither gains nor loses energy
/// at any roughness or angle, entering or leaving (total internal
/// reflection included), once multiple scattering is compensated.
#[test]
fn clear_glass_passes_the_furnace_test() {
    let mut worst = 0.0f32;
    for eta in ETAS {
        for roughness in [0.0f32, 0.05, 0.3, 0.6, 1.0] {
            for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
                let wo = dir_at(theta);
                let g = Dielectric::new(eta, roughness, Vec3::ONE, true, wo.z);
                let e = energy_of(&g, wo, eta, 100_000, 7);
                worst = worst.max((e - 1.0).abs());
                // 100k samples of weights near 1: noise < 0.3%. The table's
                // grid (16 points in √μ, roughness and z) adds up to ~1%.
                assert!((e - 1.0).abs() < 0.02, "η {eta} roughness {roughness} θo {theta}: energy {e}");
            }
        }
    }
    eprintln!("white furnace, glass: worst |energy − 1| = {worst:.4}");
}

/// A smooth boundary reflects F(θ) and refracts the rest by Snell's law,
/// exactly: no noise in the weights.
#[test]
fn smooth_glass_is_fresnel_and_snell_exactly() {
    let mut rng = Rng::new(5, 5);
    for eta in ETAS {
        for theta in [0.0f32, 30.0, 41.0, 42.0, 60.0, 89.0] {
            let wo = dir_at(theta);
            let tint = Vec3::new(0.9, 0.5, 0.2);
            let g = Dielectric::new(eta, 0.0, tint, true, wo.z);
            assert!(g.smooth && g.eval(wo, -wo) == Vec3::ZERO && g.pdf(wo, -wo) == 0.0);
            let f = microfacet::fresnel_dielectric(wo.z, eta);
            let (mut reflected, n) = (0usize, 20_000);
            for _ in 0..n {
                let s = g.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
                assert!(s.delta);
                if s.wi.z > 0.0 {
                    reflected += 1;
                    assert_eq!((s.wi, s.weight), (Vec3::new(-wo.x, -wo.y, wo.z), Vec3::ONE));
                } else {
                    // Snell: sinθt = sinθo / η, in the plane of incidence.
                    let sin_t = (s.wi.x * s.wi.x + s.wi.y * s.wi.y).sqrt();
                    assert!((sin_t - wo.x / eta).abs() < 1e-5 && s.wi.x <= 0.0, "θo {theta} η {eta}: {}", s.wi);
                    assert!((s.weight - tint / (eta * eta)).abs().max_element() < 1e-6);
                }
            }
            let share = reflected as f32 / n as f32;
            // Binomial noise at 20k draws: < 0.004 at 1σ.
            assert!((share - f).abs() < 0.02, "θo {theta} η {eta}: reflected {share} vs F {f}");
        }
    }
    // Past the critical angle (41.8° leaving IOR 1.5) all is reflected.
    assert!(refract(dir_at(42.0), Vec3::Z, 1.0 / 1.5).is_none() && refract(dir_at(41.0), Vec3::Z, 1.0 / 1.5).is_some());
}

/// Specular Tint on glass: a smooth boundary reflects F_t = (1 + k)F − k
/// per channel (F0·tint head-on, 1 past the critical angle) and lets
/// through 1 − F_t, sampled by the untinted F; rough glass weighs its two
/// lobes the same way; a white tint is the untinted glass bit for bit.
#[test]
fn specular_tint_tints_f0_of_what_glass_reflects_and_lets_through() {
    let tint = Vec3::new(1.0, 0.3, 0.1);
    let base = Vec3::new(0.9, 0.8, 0.7);
    for eta in ETAS {
        let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        let k = super::dielectric::specular_tint_k(f0, tint);
        for theta in [0.0f32, 30.0, 60.0, 85.0] {
            let wo = dir_at(theta);
            let f = microfacet::fresnel_dielectric(wo.z, eta);
            let reflected = ((Vec3::ONE + k) * f - k).clamp(Vec3::ZERO, Vec3::ONE);
            let g = Dielectric::new(eta, 0.0, base, true, wo.z).with_specular_tint(tint);
            // u_lobe 0 reflects, just under 1 refracts (where anything does).
            let r = g.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
            assert!((r.f - reflected).abs().max_element() < 1e-6 && (r.weight * r.pdf - reflected).abs().max_element() < 1e-6, "η {eta} θo {theta}: {} vs {reflected}", r.f);
            if let Some(t) = g.sample(wo, 0.999_999, Vec2::splat(0.5)).filter(|s| s.wi.z < 0.0) {
                let through = (Vec3::ONE - reflected) * base / (eta * eta);
                assert!((t.f - through).abs().max_element() < 1e-5 && (t.pdf - (1.0 - f)).abs() < 1e-6, "η {eta} θo {theta}: {} vs {through}", t.f);
            }
            if theta == 0.0 {
                assert!((reflected - f0 * tint).abs().max_element() < 1e-6);
            }
            let mut rng = Rng::new(7, 3);
            for roughness in [0.0f32, 0.3] {
                let plain = Dielectric::new(eta, roughness, base, true, wo.z);
                let white = plain.with_specular_tint(Vec3::ONE);
                for _ in 0..50 {
                    let (u, ul) = (rng.next_2d(), rng.next_f32());
                    let (a, b) = (plain.sample(wo, ul, u), white.sample(wo, ul, u));
                    assert_eq!(a.map(|s| (s.wi, s.f, s.pdf, s.weight)), b.map(|s| (s.wi, s.f, s.pdf, s.weight)));
                }
            }
        }
        // Rough: each side's value is the untinted one times its tinted share.
        let wo = dir_at(40.0);
        let (plain, tinted) = (Dielectric::new(eta, 0.3, base, true, wo.z), Dielectric::new(eta, 0.3, base, true, wo.z).with_specular_tint(tint));
        let mut rng = Rng::new(8, 1);
        for _ in 0..200 {
            let Some(s) = plain.sample(wo, rng.next_f32(), rng.next_2d()) else { continue };
            let h = if s.wi.z > 0.0 { (wo + s.wi).normalize() } else { -(wo + eta * s.wi).normalize() };
            let h = if h.z < 0.0 { -h } else { h };
            let f = microfacet::fresnel_dielectric(wo.dot(h), eta);
            let t = ((Vec3::ONE + k) * f - k).clamp(Vec3::ZERO, Vec3::ONE);
            let share = if s.wi.z > 0.0 { t / f } else { (Vec3::ONE - t) / (1.0 - f) };
            let expected = plain.eval(wo, s.wi) * share;
            assert!((tinted.eval(wo, s.wi) - expected).abs().max_element() <= 1e-4 * expected.max_element().max(1e-3), "η {eta}: {} vs {expected}", tinted.eval(wo, s.wi));
            assert_eq!(tinted.pdf(wo, s.wi), plain.pdf(wo, s.wi));
        }
    }
}

/// The table against a quadrature of the lobe itself over the whole
/// sphere (eval, not the sampler the table was built with), without
/// compensation or radiance scaling.
#[test]
fn glass_table_matches_a_quadrature_of_the_lobe() {
    let t = glass_tables();
    for eta in ETAS {
        for roughness in [0.5f32, 1.0] {
            for theta in [0.0f32, 50.0] {
                let wo = dir_at(theta);
                let g = Dielectric::new(eta, roughness, Vec3::ONE, false, wo.z);
                let (nt, np) = (1200, 240);
                let (dt, dp) = (std::f32::consts::PI / nt as f32, 2.0 * std::f32::consts::PI / np as f32);
                let mut sum = 0.0f64;
                for i in 0..nt {
                    let th = (i as f32 + 0.5) * dt;
                    for j in 0..np {
                        let ph = (j as f32 + 0.5) * dp;
                        let wi = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                        let flux = if wi.z < 0.0 { eta * eta } else { 1.0 };
                        sum += (g.eval(wo, wi).x * wi.z.abs() * flux * th.sin() * dt * dp) as f64;
                    }
                }
                let e = t.e(wo.z, roughness, eta);
                assert!((sum as f32 - e).abs() < 0.01, "η {eta} roughness {roughness} θo {theta}: quadrature {sum} vs table {e}");
            }
        }
    }
}

#[test]
fn glass_is_finite_for_extreme_inputs() {
    let at_cos = |c: f32, phi: f32| Vec3::new((1.0 - c * c).sqrt() * phi.cos(), (1.0 - c * c).sqrt() * phi.sin(), c);
    let cosines = [1.0f32, 0.3, 1e-3, 1e-7, 0.0, -1e-7, -1e-3, -0.5, -1.0];
    let mut rng = Rng::new(14, 14);
    for eta in [1.5f32, 1.0 / 1.5, 1.0, 1.0005, 1.0 / 1.0005, 3.0, 10.0, 0.1] {
        for roughness in [0.0f32, 1e-4, 1e-2, 0.05, 0.5, 1.0] {
            for &co in &cosines {
                let wo = at_cos(co, 0.3);
                let g = Dielectric::new(eta, roughness, Vec3::new(1.0, 0.5, 0.0), true, co.max(0.0));
                for &ci in &cosines {
                    let wi = at_cos(ci, 2.0);
                    let (f, pdf) = (g.eval(wo, wi), g.pdf(wo, wi));
                    assert!(f.is_finite() && f.min_element() >= 0.0 && pdf.is_finite() && pdf >= 0.0, "η {eta} r {roughness} cos {co}/{ci}: {f} {pdf}");
                }
                for _ in 0..500 {
                    if let Some(s) = g.sample(wo, rng.next_f32(), rng.next_2d()) {
                        assert!(co > 0.0 && s.weight.is_finite() && s.weight.min_element() >= 0.0 && s.wi.is_finite(), "η {eta} r {roughness} cos {co}: {s:?}");
                        if !s.delta {
                            assert!((s.pdf - g.pdf(wo, s.wi)).abs() <= 1e-3 * s.pdf, "η {eta} r {roughness} cos {co}: {} vs {}", s.pdf, g.pdf(wo, s.wi));
                        }
                    }
                }
            }
        }
    }
}

/// Half glass over a coloured plastic, and glass under part metal: the
/// mixture's sampler matches the mixture's pdf.
#[test]
fn glass_mixed_into_principled_matches_its_pdf() {
    for (metallic, transmission) in [(0.0f32, 0.5f32), (0.4, 1.0)] {
        for theta in [10.0f32, 70.0] {
            let wo = dir_at(theta);
            let m = glass(Vec3::new(0.8, 0.5, 0.3), metallic, 0.5, transmission, 1.5);
            let bsdf = WithGlass::<PrincipledBsdf>::new(&m, wo);
            let r = bsdf_chi2(&bsdf, wo, N, 32);
            assert!(r.p_value > P_MIN, "metallic {metallic} transmission {transmission} θo {theta}: p = {}", r.p_value);
        }
    }
}

/// Without transmission the mixture is its base model, bit for bit, so
/// the glass kernel renders glass-free materials exactly as before.
#[test]
fn without_transmission_the_mixture_is_the_model_itself() {
    let mut rng = Rng::new(15, 15);
    for (metallic, roughness) in [(0.0f32, 0.0f32), (0.0, 0.4), (1.0, 0.2), (0.5, 1.0)] {
        let m = glass(Vec3::new(0.7, 0.4, 0.2), metallic, roughness, 0.0, 1.5);
        for theta in [0.0f32, 60.0, 89.0] {
            let wo = dir_at(theta);
            let (mixed, plain) = (WithGlass::<PrincipledBsdf>::new(&m, wo), PrincipledBsdf::new(&m, wo));
            for _ in 0..2000 {
                let (ul, u) = (rng.next_f32(), rng.next_2d());
                let (a, b) = (mixed.sample(wo, ul, u), plain.sample(wo, ul, u));
                assert_eq!(a.map(|s| (s.wi, s.f, s.pdf, s.weight, s.delta)), b.map(|s| (s.wi, s.f, s.pdf, s.weight, s.delta)));
                let wi = crate::sampling::cosine_hemisphere(rng.next_2d());
                assert_eq!((Bsdf::eval(&mixed, wo, wi), Bsdf::pdf(&mixed, wo, wi)), (plain.eval(wo, wi), plain.pdf(wo, wi)));
            }
        }
    }
}

/// All glass, the mixture is the glass: a rough glass's sample keeps the
/// glass's own f and pdf, which are those `evaluate` gives the mixture
/// (its sampler no longer evaluates them a second time).
#[test]
fn all_glass_samples_carry_the_mixtures_f_and_pdf() {
    let mut rng = Rng::new(17, 17);
    for roughness in [0.1f32, 0.5, 1.0] {
        let m = glass(Vec3::new(0.9, 0.7, 0.5), 0.0, roughness, 1.0, 1.45);
        for theta in [0.0f32, 50.0, 85.0] {
            let wo = dir_at(theta);
            let bsdf = WithGlass::<PrincipledBsdf>::new(&m, wo);
            let mut checked = 0;
            for _ in 0..2000 {
                let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) else { continue };
                let (f, pdf) = bsdf.evaluate(wo, s.wi);
                assert!((s.pdf - pdf).abs() <= 1e-5 * pdf && (s.f - f).abs().max_element() <= 1e-5 * f.max_element(), "r {roughness} θo {theta}: sample {:?}, evaluate {f} {pdf}", s);
                assert!((s.weight - f * (s.wi.z.abs() / pdf)).abs().max_element() <= 1e-5 * s.weight.max_element());
                checked += 1;
            }
            assert!(checked > 1000, "r {roughness} θo {theta}: {checked} samples");
        }
    }
}

/// Principled glass takes Cycles' weights: a half-metal glass reflects the
/// metal's share and passes (1 − m) of the light, tinted by the base
/// colour once each way through (√base per crossing).
#[test]
fn principled_glass_weights_are_cycles_weights() {
    let wo = dir_at(0.0);
    let base = Vec3::new(0.64, 0.25, 0.09);
    let m = glass(base, 0.0, 0.0, 1.0, 1.5);
    let bsdf = WithGlass::<PrincipledBsdf>::new(&m, wo);
    let mut rng = Rng::new(16, 16);
    let s = (0..100).filter_map(|_| bsdf.sample(wo, rng.next_f32(), rng.next_2d())).find(|s| s.wi.z < 0.0).unwrap();
    assert!((s.weight - Vec3::new(0.8, 0.5, 0.3) / 2.25).abs().max_element() < 1e-6, "{}", s.weight);
    // Specular 0 sets F0 to 0: the IOR becomes 1 and the glass vanishes.
    let mut clear = m;
    clear.specular = 0.0;
    let s = WithGlass::<PrincipledBsdf>::new(&clear, dir_at(30.0)).sample(dir_at(30.0), 0.5, Vec2::splat(0.5)).unwrap();
    assert!((s.wi + dir_at(30.0)).length() < 1e-3 && s.delta, "{}", s.wi);
}


/// A Translucent BSDF (a request's node: transmission 1, `translucent`):
/// its sampler matches its pdf, alone and as half of a mix with a
/// plastic; it passes its albedo, base/π on the far side, at every angle
/// and reflects nothing; and a sample's weight is that albedo exactly.
#[test]
fn translucent_is_lambert_through_the_surface() {
    let albedo = Vec3::new(0.8, 0.5, 0.2);
    let translucent = |transmission| Surface { translucent: true, ..glass(albedo, 0.0, 0.5, transmission, 1.5) };
    for theta in [0.0f32, 45.0, 85.0] {
        let wo = dir_at(theta);
        for transmission in [1.0f32, 0.5] {
            let bsdf = WithGlass::<PrincipledBsdf>::new(&translucent(transmission), wo);
            let r = bsdf_chi2(&bsdf, wo, N, 33);
            assert!(r.p_value > P_MIN, "transmission {transmission} θo {theta}: p = {}", r.p_value);
            assert!((r.pdf_integral - r.success_fraction).abs() < 5e-3, "θo {theta}: ∫pdf {} vs {}", r.pdf_integral, r.success_fraction);
        }
        let bsdf = WithGlass::<PrincipledBsdf>::new(&translucent(1.0), wo);
        assert!(bsdf.transmits());
        let passed = super::chi2::albedo_of(&bsdf, wo, 20_000, 3);
        // Every weight is the albedo; the f32 sum of 20,000 rounds.
        assert!((passed - albedo).abs().max_element() < 1e-3, "θo {theta}: {passed}");
        let (below, above) = (Vec3::new(0.3, -0.2, -0.5).normalize(), Vec3::new(0.3, -0.2, 0.5).normalize());
        assert!((Bsdf::eval(&bsdf, wo, below) - albedo * std::f32::consts::FRAC_1_PI).abs().max_element() < 1e-7);
        assert_eq!((Bsdf::eval(&bsdf, wo, above), Bsdf::pdf(&bsdf, wo, above)), (Vec3::ZERO, 0.0));
    }
}
