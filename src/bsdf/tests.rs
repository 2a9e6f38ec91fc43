//! Sampling-against-pdf, normalisation, finiteness, energy and reciprocity
//! tests of every lobe and of the seed material.

use super::chi2::{albedo_of, bsdf_chi2, chi2_test, dir_at, u2};
use super::*;
use super::microfacet;
use crate::material::{Material, Surface};
use crate::rng::Rng;

fn material(base: Vec3, metallic: f32, roughness: f32) -> Surface {
    Material { base_color: base, metallic, roughness, ..Material::default() }.surface()
}

/// With ~30 chi-square tests in the suite, a per-test level of 1e-4 keeps
/// the family-wise false alarm rate under 0.3% while a wrong pdf (p ≪ 1e-6
/// at a million samples) still fails.
const P_MIN: f64 = 1e-4;
const N: usize = 1_000_000;

#[test]
fn lambert_sampling_matches_pdf() {
    let wo = dir_at(30.0);
    let r = chi2_test(N, 1, |rng| Some(lambert::sample(u2(rng))), |wi| lambert::pdf(wo, wi));
    assert!(r.p_value > P_MIN, "p = {} (χ² {} dof {})", r.p_value, r.statistic, r.dof);
    assert!((r.pdf_integral - 1.0).abs() < 1e-3, "∫pdf = {}", r.pdf_integral);
}

#[test]
fn ggx_sampling_matches_pdf() {
    for roughness in [0.3f32, 0.5, 1.0] {
        let alpha = roughness * roughness;
        for theta in [0.0f32, 45.0, 80.0] {
            let wo = dir_at(theta);
            let r = chi2_test(N, 2, |rng| ggx::sample(wo, u2(rng), alpha), |wi| ggx::pdf(wo, wi, alpha));
            assert!(r.p_value > P_MIN, "roughness {roughness} θo {theta}: p = {} (χ² {} dof {})", r.p_value, r.statistic, r.dof);
            // The pdf integrates to the fraction of samples that stay above
            // the surface (1 at normal incidence for a narrow lobe).
            assert!((r.pdf_integral - r.success_fraction).abs() < 5e-3,
                "roughness {roughness} θo {theta}: ∫pdf {} vs success {}", r.pdf_integral, r.success_fraction);
            assert!(r.pdf_integral <= 1.0 + 2e-3);
        }
    }
}

#[test]
fn ggx_half_vector_pdf_integrates_to_one() {
    // ∫ D(h) (n·h) dω_h = 1 is GGX's normalisation; check it numerically on a
    // fine θ grid for smooth and rough lobes alike.
    for alpha in [1e-3f32, 0.01, 0.1, 0.5, 1.0] {
        let n = 200_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            // Substitute t = tan θ / α to resolve the narrow peak: θ = atan(α t).
            let t = (i as f64 + 0.5) / n as f64 * 2000.0;
            let dt = 2000.0 / n as f64;
            let theta = ((alpha as f64) * t).atan();
            let dtheta = alpha as f64 / (1.0 + (alpha as f64 * t).powi(2)) * dt;
            let h = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
            sum += ggx::d(h, alpha) as f64 * theta.cos() * theta.sin() * dtheta * 2.0 * std::f64::consts::PI;
        }
        assert!((sum - 1.0).abs() < 2e-3, "α {alpha}: ∫D cos = {sum}");
    }
}

#[test]
fn seed_material_sampling_matches_pdf() {
    for (base, metallic) in [(Vec3::new(0.8, 0.3, 0.2), 0.0f32), (Vec3::new(1.0, 0.7, 0.3), 1.0), (Vec3::splat(0.5), 0.5)] {
        for roughness in [0.3f32, 0.6, 1.0] {
            for theta in [10.0f32, 60.0, 85.0] {
                let wo = dir_at(theta);
                let bsdf = SeedBsdf::new(&material(base, metallic, roughness), wo);
                let r = bsdf_chi2(&bsdf, wo, N, 3);
                assert!(r.p_value > P_MIN, "metallic {metallic} roughness {roughness} θo {theta}: p = {}", r.p_value);
            }
        }
    }
}

#[test]
fn samples_are_finite_and_consistent_everywhere() {
    let mut rng = Rng::new(9, 9);
    for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 0.3, 1.0] {
        for metallic in [0.0f32, 1.0] {
            for cos_o in [1.0f32, 0.5, 1e-3, 1e-7] {
                let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
                let bsdf = SeedBsdf::new(&material(Vec3::new(0.9, 0.5, 0.1), metallic, roughness), wo);
                for _ in 0..20_000 {
                    let ul = rng.next_f32();
                    if let Some(s) = bsdf.sample(wo, ul, rng.next_2d()) {
                        let w = s.weight;
                        assert!(w.is_finite() && w.min_element() >= 0.0, "r {roughness} m {metallic} cos {cos_o}: {w}");
                        if s.delta {
                            // Only roughness below Cycles' threshold is a mirror.
                            assert!(roughness < 0.004 && s.wi == Vec3::new(-wo.x, -wo.y, wo.z));
                            assert!((w - s.f / bsdf.spec_probability).abs().max_element() <= 1e-6 * w.max_element());
                        } else {
                            assert!((w - s.f * s.wi.z / s.pdf).abs().max_element() <= 1e-5 * w.max_element());
                            assert!((s.pdf - bsdf.pdf(wo, s.wi)).abs() <= 1e-4 * s.pdf);
                        }
                    }
                }
            }
        }
    }
}



#[test]
fn white_lambert_reflects_exactly_one() {
    // Cosine sampling makes every sample weight exactly albedo: no noise at all.
    let mut rng = Rng::new(4, 4);
    let wo = dir_at(40.0);
    for _ in 0..10_000 {
        let wi = lambert::sample(rng.next_2d());
        if wi.z <= 0.0 {
            continue;
        }
        let w = lambert::eval(Vec3::ONE, wo, wi) * wi.z / lambert::pdf(wo, wi);
        assert!((w - Vec3::ONE).abs().max_element() < 1e-5);
    }
}

/// ∫ f(wo, wi) cos θi dωi by midpoint quadrature in (θ, φ).
fn albedo_quadrature(bsdf: &SeedBsdf, wo: Vec3) -> Vec3 {
    let (nt, np) = (600, 300);
    let dt = std::f32::consts::FRAC_PI_2 / nt as f32;
    let dp = 2.0 * std::f32::consts::PI / np as f32;
    let mut sum = Vec3::ZERO;
    for i in 0..nt {
        let t = (i as f32 + 0.5) * dt;
        for j in 0..np {
            let p = (j as f32 + 0.5) * dp;
            let wi = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            sum += bsdf.eval(wo, wi) * wi.z * t.sin() * dt * dp;
        }
    }
    sum
}

#[test]
fn ggx_lobe_never_gains_energy_and_estimator_matches_quadrature() {
    // A white metal is the GGX lobe alone with F = 1: single scattering can
    // only lose energy. (The seed's k = (α+1)²/8 stays ≈ 1/8 as α → 0, so it
    // loses a lot at grazing angles: measured 0.015 at roughness 0, 89°.)
    for roughness in [0.0f32, 0.05, 0.3, 0.7, 1.0] {
        for theta in [0.0f32, 45.0, 75.0, 89.0] {
            let wo = dir_at(theta);
            let bsdf = SeedBsdf::new(&material(Vec3::ONE, 1.0, roughness), wo);
            let a = albedo_of(&bsdf, wo, 200_000, 11).max_element();
            // 200k samples of a weight in [0, 1]: 0.01 is beyond 5σ.
            assert!(a <= 1.0 + 0.01, "roughness {roughness} θo {theta}: albedo {a}");
            if roughness >= 0.3 && theta <= 75.0 {
                // The quadrature resolves these lobes to better than 0.5%; at
                // 89° the lobe is too thin in φ for its grid.
                let q = albedo_quadrature(&bsdf, wo).max_element();
                assert!((a - q).abs() < 0.01, "roughness {roughness} θo {theta}: MC {a} vs quadrature {q}");
            }
        }
    }
}

/// The seed's kd = (1 − F(wo·h)) does not subtract what the specular lobe
/// really reflects, so a white dielectric reflects more than it receives at
/// grazing angles. This pins the measured size of that known flaw (it is
/// the reason the Principled model exists) so a change to it is noticed.
#[test]
fn seed_dielectric_energy_gain_is_the_known_one() {
    let mut worst = 0.0f32;
    for roughness in [0.05f32, 0.3, 0.7, 1.0] {
        for theta in [0.0f32, 45.0, 75.0, 89.0] {
            let wo = dir_at(theta);
            let bsdf = SeedBsdf::new(&material(Vec3::ONE, 0.0, roughness), wo);
            let a = albedo_of(&bsdf, wo, 200_000, 11).max_element();
            assert!(a > 0.8, "roughness {roughness} θo {theta}: {a}");
            worst = worst.max(a);
        }
    }
    // Measured: 1.09 at roughness 0.05, θo = 75°.
    assert!(worst > 1.03 && worst < 1.15, "worst white-dielectric albedo {worst}");
}

#[test]
fn seed_material_is_reciprocal() {
    let mut rng = Rng::new(6, 6);
    for _ in 0..10_000 {
        let a = crate::sampling::cosine_hemisphere(rng.next_2d());
        let b = crate::sampling::cosine_hemisphere(rng.next_2d());
        let m = material(Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()), rng.next_f32(), rng.next_f32().max(0.05));
        // The lobe choice depends on wo, the BSDF value must not.
        let fa = SeedBsdf::new(&m, a).eval(a, b);
        let fb = SeedBsdf::new(&m, b).eval(b, a);
        assert!((fa - fb).abs().max_element() <= 1e-4 * fa.max_element().max(1.0), "{fa} vs {fb}");
    }
}

/// Grazing and below-horizon directions: n·wo and n·wi of 1e-7 and exactly
/// 0, and back-facing ones, give finite, non-negative values, and nothing
/// at all below the horizon.
#[test]
fn grazing_and_back_facing_directions_are_finite_and_non_negative() {
    let at_cos = |c: f32, phi: f32| Vec3::new((1.0 - c * c).sqrt() * phi.cos(), (1.0 - c * c).sqrt() * phi.sin(), c);
    let cosines = [1.0f32, 0.3, 1e-3, 1e-7, 0.0, -1e-7, -0.5];
    let mut rng = Rng::new(12, 12);
    for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 0.5, 1.0] {
        for metallic in [0.0f32, 1.0] {
            let m = material(Vec3::new(1.0, 0.5, 0.0), metallic, roughness);
            for &co in &cosines {
                let wo = at_cos(co, 0.3);
                let bsdf = SeedBsdf::new(&m, wo);
                for &ci in &cosines {
                    for phi in [0.3f32, 0.3 + std::f32::consts::PI, 2.0] {
                        let wi = at_cos(ci, phi);
                        let (f, pdf) = (bsdf.eval(wo, wi), bsdf.pdf(wo, wi));
                        assert!(f.is_finite() && f.min_element() >= 0.0, "r {roughness} cos {co}/{ci}: f {f}");
                        assert!(pdf.is_finite() && pdf >= 0.0, "r {roughness} cos {co}/{ci}: pdf {pdf}");
                        if co <= 0.0 || ci <= 0.0 {
                            assert!(f == Vec3::ZERO && pdf == 0.0, "r {roughness} cos {co}/{ci}: {f} {pdf}");
                        }
                    }
                }
                for _ in 0..2000 {
                    let s = bsdf.sample(wo, rng.next_f32(), rng.next_2d());
                    if co <= 0.0 {
                        assert!(s.is_none(), "r {roughness} cos {co}: sampled from below the horizon");
                    } else if let Some(s) = s {
                        assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0 && s.wi.z >= 0.0);
                    }
                }
            }
        }
    }
}

/// A mirror over a diffuse base passes to the base exactly what the mirror
/// does not reflect, so a white one returns all the light at every angle.
#[test]
fn white_dielectric_mirror_returns_exactly_one() {
    for roughness in [0.0f32, 1e-3] {
        for theta in [0.0f32, 45.0, 75.0, 85.0, 89.0, 89.99] {
            let wo = dir_at(theta);
            let bsdf = SeedBsdf::new(&material(Vec3::ONE, 0.0, roughness), wo);
            assert!(bsdf.smooth);
            let a = albedo_of(&bsdf, wo, 200_000, 13).max_element();
            // Mirror weight F/p and diffuse weight (1−F)/(1−p): ±0.01 is > 5σ.
            assert!((a - 1.0).abs() < 0.01, "roughness {roughness} θo {theta}: albedo {a}");
        }
    }
}

// ---------------------------------------------------------------- Principled

/// Roughness from 0.3: the harness' quadrature (bins of 9°, cells of
/// 0.14°) cannot resolve a narrower lobe squeezed against the horizon —
/// there the seed's long-tested sampler fails it identically.
#[test]
fn visible_normal_sampling_matches_its_pdf() {
    for roughness in [0.3f32, 0.5, 1.0] {
        let alpha = roughness * roughness;
        for theta in [0.0f32, 45.0, 80.0, 85.0] {
            let wo = dir_at(theta);
            let r = chi2_test(N, 4, |rng| microfacet::sample(wo, alpha, u2(rng)).map(|s| s.0), |wi| microfacet::pdf(wo, wi, alpha));
            assert!(r.p_value > P_MIN, "roughness {roughness} θo {theta}: p = {} (χ² {} dof {})", r.p_value, r.statistic, r.dof);
            assert!((r.pdf_integral - r.success_fraction).abs() < 5e-3, "roughness {roughness} θo {theta}: ∫pdf {} vs {}", r.pdf_integral, r.success_fraction);
        }
    }
}

#[test]
fn principled_sampling_matches_pdf() {
    for (base, metallic) in [(Vec3::new(0.8, 0.3, 0.2), 0.0f32), (Vec3::new(1.0, 0.7, 0.3), 1.0), (Vec3::splat(0.5), 0.5)] {
        for roughness in [0.3f32, 0.6, 1.0] {
            for theta in [10.0f32, 60.0, 85.0] {
                let wo = dir_at(theta);
                let bsdf = PrincipledBsdf::new(&material(base, metallic, roughness), wo);
                let r = bsdf_chi2(&bsdf, wo, N, 5);
                assert!(r.p_value > P_MIN, "metallic {metallic} roughness {roughness} θo {theta}: p = {}", r.p_value);
            }
        }
    }
}


/// The white furnace: a white Principled surface, metal or dielectric,
/// returns all the light at every angle (to 89°) and roughness — the diffuse base
/// gets exactly what the specular layer leaves, and the multiple-scattering
/// compensation returns what single scattering loses. (The seed's model
/// gains up to 8.5%; see seed_dielectric_energy_gain_is_the_known_one.)
#[test]
fn white_principled_surfaces_pass_the_furnace_test() {
    let mut worst = 0.0f32;
    for metallic in [0.0f32, 1.0] {
        for roughness in [0.0f32, 0.05, 0.3, 0.7, 1.0] {
            for theta in [0.0f32, 45.0, 75.0, 85.0, 89.0] {
                let wo = dir_at(theta);
                let bsdf = PrincipledBsdf::new(&material(Vec3::ONE, metallic, roughness), wo);
                let a = albedo_of(&bsdf, wo, 100_000, 21).max_element();
                worst = worst.max((a - 1.0).abs());
                // 100k samples: noise < 0.3%; table interpolation < 0.3%, up
                // to 0.9% at 89° where low-roughness albedos bend sharply.
                assert!((a - 1.0).abs() < 0.015, "metallic {metallic} roughness {roughness} θo {theta}: albedo {a}");
            }
        }
    }
    eprintln!("white furnace, Principled: worst |albedo − 1| = {worst:.4}");
}

/// The furnace again with a rough diffuse base (Diffuse Roughness), under
/// a specular layer and without one (specular 0, the Lambert-only path):
/// Oren–Nayar's multiple-scattering term returns what its single
/// scattering loses, up to a fifth head-on. Rendering it as Lambert's
/// single-scattering part alone fails this by 2–22%.
#[test]
fn a_white_rough_diffuse_principled_surface_passes_the_furnace_test() {
    for specular in [1.0f32, 0.0] {
        for diffuse_roughness in [0.4f32, 1.0] {
            let m = Surface { specular, diffuse_roughness, ..material(Vec3::ONE, 0.0, 0.5) };
            // Rough diffuse scatters back toward the light (the kernel of
            // scenes without it renders Lambert, as it must).
            let back = dir_at(60.0);
            let (rough, lambert) = (RoughPrincipledBsdf::new(&m, back).eval(back, back), PrincipledBsdf::new(&m, back).eval(back, back));
            assert!(rough.x > 1.05 * lambert.x, "{rough} against {lambert}");
            for theta in [0.0f32, 45.0, 85.0] {
                let wo = dir_at(theta);
                let a = albedo_of(&RoughPrincipledBsdf::new(&m, wo), wo, 100_000, 23).max_element();
                assert!((a - 1.0).abs() < 0.015, "specular {specular} diffuse roughness {diffuse_roughness} θo {theta}: albedo {a}");
            }
        }
    }
}

/// Plain "GGX" (no multiple-scattering compensation) keeps single
/// scattering's loss: a white metal at roughness 1 seen head-on returns
/// 1 − ln 2 (energy.rs derives it).
#[test]
fn without_multiscatter_a_rough_white_metal_loses_what_single_scattering_loses() {
    let mut m = material(Vec3::ONE, 1.0, 1.0);
    m.multiscatter = false;
    let wo = dir_at(0.0);
    let a = albedo_of(&PrincipledBsdf::new(&m, wo), wo, 400_000, 22).x;
    assert!((a - (1.0 - std::f32::consts::LN_2)).abs() < 0.005, "{a}");
}

/// A non-metal with specular 0 is exactly Lambert in both models, bit for
/// bit, so the Lambert kernel renders the same image (features.rs).
#[test]
fn zero_specular_dielectric_is_exactly_lambert_in_every_model() {
    fn same<B: Bsdf>(m: &Surface, rng: &mut Rng) {
        for theta in [0.0f32, 50.0, 89.0, 89.99] {
            let wo = dir_at(theta);
            let (bsdf, lambert) = (B::new(m, wo), LambertBsdf::new(m, wo));
            for _ in 0..2000 {
                let (u_lobe, u) = (rng.next_f32(), rng.next_2d());
                let (s, l) = (bsdf.sample(wo, u_lobe, u).unwrap(), lambert.sample(wo, u_lobe, u).unwrap());
                assert_eq!((s.wi, s.f, s.pdf, s.weight, s.delta), (l.wi, l.f, l.pdf, l.weight, l.delta));
                assert!((s.f - m.base_color / std::f32::consts::PI).abs().max_element() < 1e-6);
                let wi = crate::sampling::cosine_hemisphere(rng.next_2d());
                assert_eq!((bsdf.eval(wo, wi), bsdf.pdf(wo, wi)), (lambert.eval(wo, wi), lambert.pdf(wo, wi)));
            }
        }
    }
    let mut rng = Rng::new(8, 8);
    for roughness in [0.0, 0.4, 1.0] {
        let mut m = material(Vec3::new(0.5, 0.6, 0.7), 0.0, roughness);
        m.specular = 0.0;
        same::<SeedBsdf>(&m, &mut rng);
        same::<PrincipledBsdf>(&m, &mut rng);
    }
}

/// The glossy lobes alone are reciprocal (the layering weight, like
/// Cycles', depends on wo only).
#[test]
fn principled_metal_lobe_is_reciprocal() {
    let mut rng = Rng::new(6, 7);
    for _ in 0..10_000 {
        let a = crate::sampling::cosine_hemisphere(rng.next_2d());
        let b = crate::sampling::cosine_hemisphere(rng.next_2d());
        let alpha = rng.next_f32().max(0.05);
        let (fa, fb) = (microfacet::eval(a, b, alpha), microfacet::eval(b, a, alpha));
        assert!((fa - fb).abs() <= 1e-4 * fa.max(1.0), "{fa} vs {fb}");
    }
}

#[test]
fn principled_is_finite_at_grazing_and_back_facing_directions_and_every_roughness() {
    let at_cos = |c: f32, phi: f32| Vec3::new((1.0 - c * c).sqrt() * phi.cos(), (1.0 - c * c).sqrt() * phi.sin(), c);
    let cosines = [1.0f32, 0.3, 1e-3, 1e-7, 0.0, -1e-7, -0.5];
    let mut rng = Rng::new(12, 13);
    // Isotropic, and at full Anisotropic (α_y = 0.32 α, α_x clamped at 1
    // from roughness 0.56 on) with the axis turned off the frame's.
    let surfaces = |roughness: f32, metallic: f32| {
        let m = material(Vec3::new(1.0, 0.5, 0.0), metallic, roughness);
        [m, Surface { anisotropy: 1.0, tangent: Vec3::new(0.8, -0.6, 0.0), ..m }]
    };
    for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 0.5, 1.0] {
        for m in [0.0f32, 0.5, 1.0].into_iter().flat_map(|metallic| surfaces(roughness, metallic)) {
            for &co in &cosines {
                let wo = at_cos(co, 0.3);
                let bsdf = PrincipledBsdf::new(&m, wo);
                for &ci in &cosines {
                    let wi = at_cos(ci, 2.0);
                    let (f, pdf) = (bsdf.eval(wo, wi), bsdf.pdf(wo, wi));
                    assert!(f.is_finite() && f.min_element() >= 0.0 && pdf.is_finite() && pdf >= 0.0, "r {roughness} metallic {} anisotropy {} cos {co}/{ci}: {f} {pdf}", m.metallic, m.anisotropy);
                    if co <= 0.0 || ci <= 0.0 {
                        assert!(f == Vec3::ZERO && pdf == 0.0);
                    }
                }
                for _ in 0..2000 {
                    if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
                        assert!(co > 0.0 && s.weight.is_finite() && s.weight.min_element() >= 0.0 && s.wi.z >= 0.0, "r {roughness} cos {co}: {:?}", s);
                        if !s.delta {
                            assert!((s.pdf - bsdf.pdf(wo, s.wi)).abs() <= 1e-4 * s.pdf);
                        }
                    }
                }
            }
        }
    }
}

/// `evaluate` gives what `eval` and `pdf` give, bit for bit, for every
/// model and mix, on both sides of the surface and at the rough and smooth
/// ends: the integrator calls one where it used to call the other two.
#[test]
fn evaluate_is_eval_and_pdf_bit_for_bit() {
    fn same<B: Bsdf>(m: &Surface, rng: &mut Rng) {
        for theta in [0.0f32, 30.0, 75.0, 89.9] {
            let wo = dir_at(theta);
            let bsdf = B::new(m, wo);
            for _ in 0..500 {
                let d = crate::sampling::cosine_hemisphere(rng.next_2d());
                let wi = if rng.next_f32() < 0.2 { -d } else { d };
                assert_eq!(bsdf.evaluate(wo, wi), (bsdf.eval(wo, wi), bsdf.pdf(wo, wi)), "wo {wo} wi {wi}");
            }
        }
    }
    let mut rng = Rng::new(9, 9);
    for roughness in [0.0, 0.05, 0.3, 1.0] {
        for metallic in [0.0, 0.5, 1.0] {
            let mut m = material(Vec3::new(0.9, 0.6, 0.2), metallic, roughness);
            same::<SeedBsdf>(&m, &mut rng);
            same::<PrincipledBsdf>(&m, &mut rng);
            same::<RoughPrincipledBsdf>(&Surface { diffuse_roughness: 0.7, ..m }, &mut rng);
            same::<RoughPrincipledBsdf>(&m, &mut rng);
            m.transmission = 0.7;
            same::<WithGlass<PrincipledBsdf>>(&m, &mut rng);
        }
    }
}

/// The lobe's visibility form (microfacet::eval_pdf: no tan², no division
/// by a cosine) is the textbook one, D(ĥ)·G2/(4 cosθo cosθi) and
/// D(ĥ)·G1/(4 cosθo) with Λ as the energy tables use it, to float
/// rounding (1e-4 relative, a few ulps through D's squares), from the
/// mirror threshold to α = 1 and from normal incidence to cosines of 1e-6,
/// and where wo and wi graze on opposite sides (cosines to 1e-10, the half
/// vector's length ~1e-10), whose D had underflowed to inf and NaN.
#[test]
fn the_lobe_in_visibility_form_is_the_textbook_one() {
    let textbook = |wo: Vec3, wi: Vec3, alpha: f32| {
        let d = ggx::d((wo + wi).normalize(), alpha);
        (d * microfacet::g2(wo, wi, alpha) / (4.0 * wo.z * wi.z), d * microfacet::g1(wo, alpha) / (4.0 * wo.z))
    };
    let check = |wo: Vec3, wi: Vec3, alpha: f32| {
        let (f, pdf) = microfacet::eval_pdf(wo, wi, alpha);
        let (f_ref, pdf_ref) = textbook(wo, wi, alpha);
        for (got, want) in [(f, f_ref), (pdf, pdf_ref)] {
            assert!(got.is_finite() && got >= 0.0, "α {alpha} wo {wo} wi {wi}: {got}");
            if want.is_finite() && want > 1e-30 {
                assert!((got / want - 1.0).abs() < 1e-4, "α {alpha} wo {wo} wi {wi}: {got} against {want}");
            }
        }
        assert_eq!((microfacet::eval(wo, wi, alpha), microfacet::pdf(wo, wi, alpha)), (f, pdf));
    };
    for alpha in [SMOOTH_ALPHA_SQ.sqrt() * 1.01, 1e-4, 0.01, 0.3] {
        for eps in [1e-4f32, 1e-6, 1e-8, 1e-10] {
            check(Vec3::new(1.0, 0.0, eps).normalize(), Vec3::new(-1.0, 0.0, eps).normalize(), alpha);
        }
    }
    let mut rng = Rng::new(4, 2);
    for alpha in [SMOOTH_ALPHA_SQ.sqrt() * 1.01, 1e-3, 0.09, 0.5, 1.0] {
        for theta_o in [0.0f32, 45.0, 89.0, 89.99994] {
            let wo = dir_at(theta_o);
            for _ in 0..400 {
                let wi = crate::sampling::cosine_hemisphere(rng.next_2d());
                let wi = if rng.next_f32() < 0.1 { microfacet::sample(wo, alpha, rng.next_2d()).map_or(wi, |s| s.0) } else { wi };
                check(wo, wi, alpha);
            }
        }
    }
}

/// Anisotropic GGX against its textbook form — D(h) = 1/(π α_x α_y
/// (h_x²/α_x² + h_y²/α_y² + h_z²)²), Λ(w) = (√(1 + (α_x² w_x² + α_y²
/// w_y²)/w_z²) − 1)/2, f = D G2/(4 cos cos), pdf = D G1(wo)/(4 cosθo) —
/// and, with α_x = α_y, against the isotropic lobe.
#[test]
fn anisotropic_ggx_is_the_textbook_one() {
    let textbook = |wo: Vec3, wi: Vec3, ax: f32, ay: f32| {
        let h = (wo + wi).normalize();
        let b = h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay) + h.z * h.z;
        let d = 1.0 / (std::f32::consts::PI * ax * ay * b * b);
        let lambda = |w: Vec3| ((1.0 + (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z)).sqrt() - 1.0) / 2.0;
        (d / (1.0 + lambda(wo) + lambda(wi)) / (4.0 * wo.z * wi.z), d / (1.0 + lambda(wo)) / (4.0 * wo.z))
    };
    let mut rng = Rng::new(9, 3);
    for (ax, ay) in [(0.3f32, 0.05), (0.05, 0.3), (0.8, 0.2), (1.0, 0.6), (0.2, 0.2)] {
        let lobe = microfacet::Anisotropic { alpha_x: ax, alpha_y: ay };
        for _ in 0..2000 {
            let (wo, wi) = (crate::sampling::cosine_hemisphere(rng.next_2d()), crate::sampling::cosine_hemisphere(rng.next_2d()));
            if wo.z < 1e-3 || wi.z < 1e-3 {
                continue;
            }
            let (f, pdf) = lobe.eval_pdf(wo, wi);
            let (f_ref, pdf_ref) = textbook(wo, wi, ax, ay);
            assert!((f / f_ref - 1.0).abs() < 1e-3 && (pdf / pdf_ref - 1.0).abs() < 1e-3, "α ({ax}, {ay}) wo {wo} wi {wi}: {f}, {pdf} against {f_ref}, {pdf_ref}");
            if ax == ay {
                let (fi, pdfi) = microfacet::eval_pdf(wo, wi, ax);
                assert!((f / fi - 1.0).abs() < 1e-5 && (pdf / pdfi - 1.0).abs() < 1e-5);
            }
        }
        // Below the surface, nothing.
        assert_eq!(lobe.eval_pdf(dir_at(30.0), Vec3::new(0.0, 0.3, -0.9).normalize()), (0.0, 0.0));
    }
}

/// The visible normals of an anisotropic lobe sample its pdf, for views
/// along, across and between its axes, down to grazing.
#[test]
fn anisotropic_sampling_matches_its_pdf() {
    for (ax, ay) in [(0.47f32, 0.13), (0.13, 0.47), (0.9, 0.5)] {
        let lobe = microfacet::Anisotropic { alpha_x: ax, alpha_y: ay };
        for (theta, phi) in [(0.0f32, 0.0f32), (45.0, 0.0), (45.0, 90.0), (60.0, 30.0), (85.0, 135.0)] {
            let (t, p) = (theta.to_radians(), phi.to_radians());
            let wo = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            let r = chi2_test(N, 6, |rng| lobe.sample(wo, u2(rng)).map(|s| s.0), |wi| lobe.eval_pdf(wo, wi).1);
            assert!(r.p_value > P_MIN, "α ({ax}, {ay}) θo {theta} φo {phi}: p = {} (χ² {} dof {})", r.p_value, r.statistic, r.dof);
            assert!((r.pdf_integral - r.success_fraction).abs() < 5e-3, "α ({ax}, {ay}) θo {theta} φo {phi}: ∫pdf {} vs {}", r.pdf_integral, r.success_fraction);
        }
    }
}

fn anisotropic(base: Vec3, metallic: f32, roughness: f32, anisotropy: f32, axis: Vec3) -> Surface {
    Surface { anisotropy, tangent: axis, ..material(base, metallic, roughness) }
}

/// An anisotropic Principled BSDF (metal, dielectric, and between) samples
/// its own pdf, its axis along x or turned.
#[test]
fn anisotropic_principled_sampling_matches_pdf() {
    let turned = Vec3::new(0.6, 0.8, 0.0);
    for (base, metallic) in [(Vec3::new(1.0, 0.7, 0.3), 1.0f32), (Vec3::new(0.8, 0.3, 0.2), 0.0), (Vec3::splat(0.5), 0.5)] {
        for (roughness, anisotropy, axis) in [(0.5f32, 0.8f32, Vec3::X), (0.7, 1.0, turned), (0.4, 0.5, turned)] {
            for theta in [10.0f32, 60.0, 85.0] {
                let wo = Vec3::new(0.3, 0.7, 0.0).normalize() * theta.to_radians().sin() + Vec3::Z * theta.to_radians().cos();
                let bsdf = PrincipledBsdf::new(&anisotropic(base, metallic, roughness, anisotropy, axis), wo);
                let r = bsdf_chi2(&bsdf, wo, N, 7);
                assert!(r.p_value > P_MIN, "metallic {metallic} roughness {roughness} anisotropy {anisotropy} θo {theta}: p = {}", r.p_value);
            }
        }
    }
}

/// Anisotropic 0 is the isotropic BSDF, bit for bit, whatever the tangent;
/// at Anisotropic 1 the highlight of a head-on view stretches along the
/// tangent: α_x/α_y = 1/(1 − 0.9) = 10, and reflected directions spread
/// 8.4× as far along it as across (slopes of the wide axis are not small
/// at roughness 0.3), and the axis turned a quarter turn turns the spread
/// with it.
#[test]
fn anisotropy_stretches_the_highlight_along_the_tangent() {
    let mut rng = Rng::new(5, 8);
    let gold = Vec3::new(1.0, 0.78, 0.34);
    for _ in 0..200 {
        let (wo, wi) = (crate::sampling::cosine_hemisphere(rng.next_2d()), crate::sampling::cosine_hemisphere(rng.next_2d()));
        let iso = PrincipledBsdf::new(&material(gold, 1.0, 0.4), wo);
        let zero = PrincipledBsdf::new(&anisotropic(gold, 1.0, 0.4, 0.0, Vec3::Y), wo);
        assert_eq!(iso.evaluate(wo, wi), zero.evaluate(wo, wi));
    }
    let spread = |axis: Vec3| {
        let wo = Vec3::Z;
        let bsdf = PrincipledBsdf::new(&anisotropic(gold, 1.0, 0.3, 1.0, axis), wo);
        let mut rng = Rng::new(6, 1);
        let (mut x, mut y) = (0.0f64, 0.0f64);
        for _ in 0..100_000 {
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
                (x, y) = (x + (s.wi.x as f64).abs(), y + (s.wi.y as f64).abs());
            }
        }
        x / y
    };
    let along_x = spread(Vec3::X);
    assert!((7.5..10.0).contains(&along_x), "spread along x over across: {along_x}");
    let along_y = spread(Vec3::Y);
    assert!((1.0 / along_y - along_x).abs() < 0.2, "turned a quarter: {along_y}");
}

/// A white anisotropic metal never returns more than the light it gets.
/// The multiple-scattering compensation is the isotropic lobe's, read at
/// (α_x α_y)^¼ as Cycles reads it, which does not make up what the wider
/// axis loses: at Anisotropic 0.1 it returns all the light within 1.5%
/// (as the isotropic furnace test), at 1 as little as 0.70 head-on
/// (roughness 0.5), as Cycles' Principled BSDF does.
#[test]
fn an_anisotropic_white_metal_never_gains_energy() {
    for roughness in [0.2f32, 0.5, 0.9] {
        for theta in [0.0f32, 45.0, 80.0] {
            let wo = dir_at(theta);
            let albedo = |anisotropy: f32| albedo_of(&PrincipledBsdf::new(&anisotropic(Vec3::ONE, 1.0, roughness, anisotropy, Vec3::new(0.6, 0.8, 0.0)), wo), wo, 100_000, 23).x;
            let (slight, full) = (albedo(0.1), albedo(1.0));
            assert!((slight - 1.0).abs() < 0.015, "roughness {roughness} θo {theta}: albedo {slight} at anisotropy 0.1");
            assert!(full < 1.005 && full > 0.6, "roughness {roughness} θo {theta}: albedo {full} at anisotropy 1");
        }
    }
}
