//! Chi-square goodness-of-fit test of a direction sampler against its pdf,
//! as pbrt-v4 and Mitsuba do: histogram the sampled directions over the
//! sphere, integrate the pdf numerically over the same bins, and compare.

use crate::rng::Rng;
use glam::Vec2;
use crate::Vec3;
use std::f64::consts::PI;

pub struct Chi2Result {
    pub p_value: f64,
    pub statistic: f64,
    pub dof: usize,
    /// ∫ pdf over the sphere, by the same quadrature.
    pub pdf_integral: f64,
    /// Fraction of sample calls that returned a direction.
    pub success_fraction: f64,
}

const THETA_BINS: usize = 20;
const PHI_BINS: usize = 40;
/// Quadrature cells per bin along θ and φ: fine enough that the
/// quadrature error of a roughness-0.3 lobe stays far below the noise of
/// a million samples.
const SUB_T: usize = 64;
const SUB_P: usize = 32;

fn bin_of(w: Vec3) -> usize {
    let theta = (w.z as f64).clamp(-1.0, 1.0).acos();
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let ti = ((theta / PI * THETA_BINS as f64) as usize).min(THETA_BINS - 1);
    let pi = ((phi / (2.0 * PI) * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
    ti * PHI_BINS + pi
}

/// `sample(rng)` draws one direction (None when the sampler fails);
/// `pdf(w)` is its solid-angle density.
pub fn chi2_test(
    samples: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Chi2Result {
    let nbins = THETA_BINS * PHI_BINS;
    let mut observed = vec![0.0f64; nbins];
    let mut rng = Rng::new(seed, 17);
    let mut successes = 0usize;
    for _ in 0..samples {
        if let Some(w) = sample(&mut rng) {
            assert!(w.is_finite() && (w.length() - 1.0).abs() < 1e-3, "sampled direction not unit: {w}");
            observed[bin_of(w)] += 1.0;
            successes += 1;
        }
    }

    // Midpoint quadrature in (θ, φ) with the sin θ Jacobian.
    let dt = PI / (THETA_BINS * SUB_T) as f64;
    let dp = 2.0 * PI / (PHI_BINS * SUB_P) as f64;
    let mut expected = vec![0.0f64; nbins];
    let mut total = 0.0;
    for ti in 0..THETA_BINS * SUB_T {
        let theta = (ti as f64 + 0.5) * dt;
        let (st, ct) = theta.sin_cos();
        for pj in 0..PHI_BINS * SUB_P {
            let phi = (pj as f64 + 0.5) * dp;
            let w = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
            let v = pdf(w) as f64 * st * dt * dp;
            let bin = (ti / SUB_T) * PHI_BINS + pj / SUB_P;
            expected[bin] += v;
            total += v;
        }
    }

    // The failures form one more cell: the mass the sampler puts nowhere.
    let mut cells: Vec<(f64, f64)> = observed
        .iter()
        .zip(&expected)
        .map(|(&o, &e)| (o, e * samples as f64))
        .collect();
    cells.push(((samples - successes) as f64, ((1.0 - total).max(0.0)) * samples as f64));

    // Pool cells with too few expected counts, as the test requires.
    cells.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap());
    let mut pooled = (0.0, 0.0);
    let mut stat = 0.0;
    let mut dof = 0usize;
    for (o, e) in cells {
        if e < 5.0 {
            pooled.0 += o;
            pooled.1 += e;
            continue;
        }
        stat += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pooled.1 > 0.0 {
        stat += (pooled.0 - pooled.1) * (pooled.0 - pooled.1) / pooled.1;
        dof += 1;
    } else if pooled.0 > 0.0 {
        // Samples where the pdf says there is no mass at all.
        stat = f64::INFINITY;
    }
    let dof = dof.saturating_sub(1).max(1);
    Chi2Result {
        p_value: chi2_survival(stat, dof as f64),
        statistic: stat,
        dof,
        pdf_integral: total,
        success_fraction: successes as f64 / samples as f64,
    }
}

/// P(X > x) for X ~ χ²(k): the regularised upper incomplete gamma Q(k/2, x/2).
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    if !x.is_finite() {
        return 0.0;
    }
    gamma_q(k / 2.0, x / 2.0)
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation (g = 7, n = 9), accurate to ~1e-15.
    const C: [f64; 9] = [
        0.999_999_999_999_809_9, 676.520_368_121_885_1, -1_259.139_216_722_402_8,
        771.323_428_777_653_1, -176.615_029_162_140_6, 12.507_343_278_686_905,
        -0.138_571_095_265_720_12, 9.984_369_578_019_572e-6, 1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        // Series for P, then Q = 1 − P.
        let mut sum = 1.0 / a;
        let mut term = sum;
        let mut n = a;
        for _ in 0..10_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        // Continued fraction for Q (Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}

/// A direction at polar angle θ from the normal, in the xz plane.
pub fn dir_at(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// Two uniform numbers, for samplers that take a `Vec2`.
pub fn u2(rng: &mut Rng) -> Vec2 {
    rng.next_2d()
}

/// `chi2_test` of a BSDF's sampler at `wo` against its own pdf.
pub fn bsdf_chi2<B: crate::bsdf::Bsdf>(bsdf: &B, wo: Vec3, samples: usize, seed: u64) -> Chi2Result {
    chi2_test(samples, seed, |rng| {
        let ul = rng.next_f32();
        bsdf.sample(wo, ul, u2(rng)).map(|s| s.wi)
    }, |wi| bsdf.pdf(wo, wi))
}

/// E[f cos / pdf] over a BSDF's sampler: its directional albedo at `wo`.
pub fn albedo_of<B: crate::bsdf::Bsdf>(bsdf: &B, wo: Vec3, n: usize, seed: u64) -> Vec3 {
    let mut rng = Rng::new(seed, 5);
    let mut sum = Vec3::ZERO;
    for _ in 0..n {
        let ul = rng.next_f32();
        if let Some(s) = bsdf.sample(wo, ul, rng.next_2d()) {
            sum += s.weight;
        }
    }
    sum / n as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survival_function_matches_known_values() {
        // Tabulated χ² critical values: P(X > 3.841 | k=1) = 0.05, P(X > 18.307 | k=10) = 0.05.
        assert!((chi2_survival(3.841, 1.0) - 0.05).abs() < 1e-3);
        assert!((chi2_survival(18.307, 10.0) - 0.05).abs() < 1e-3);
        assert!((chi2_survival(2.0, 2.0) - (-1.0f64).exp()).abs() < 1e-9);
    }

    #[test]
    fn detects_a_wrong_pdf() {
        use crate::sampling::cosine_hemisphere;
        // Cosine samples judged against a uniform-hemisphere pdf must fail.
        let r = chi2_test(200_000, 3, |rng| Some(cosine_hemisphere(rng.next_2d())), |w| {
            if w.z > 0.0 { 1.0 / (2.0 * std::f32::consts::PI) } else { 0.0 }
        });
        assert!(r.p_value < 1e-6, "p = {}", r.p_value);
    }
}
