//! Energy tables for the Principled model, computed by Glint's own lobe
//! code, baked into the binary (baked.rs) and read by bilinear
//! interpolation:
//!
//! * E(μ, r): directional albedo of the single-scattering GGX lobe with
//!   F = 1 — what a perfectly reflecting rough surface loses to the missing
//!   multiple bounces is 1 − E.
//! * E_avg(r) = 2∫ E(μ) μ dμ.
//! * E_layer(μ, r): directional albedo of the dielectric specular layer
//!   (IOR 1.5, exact Fresnel, multiple-scattering compensation included):
//!   what the diffuse base under it does not receive.
//!
//! r = roughness (α = r²) on a 32-point grid over [0, 1]; μ = cosθo on a
//! 32-point grid uniform in √μ, dense near grazing where low-roughness
//! albedos change fastest (uniform in μ, a white dielectric at roughness
//! 0.05 seen at 89° returned 1.04).
//!
//! Multiple-scattering compensation (Kulla & Conty 2017, as Cycles applies
//! it): the single-scattering lobe is scaled by S = 1 + F_ms (1 − E)/E with
//! F_ms = F_avg E_avg / (1 − F_avg (1 − E_avg)), F_avg the lobe's average
//! Fresnel. With F = 1, S·E = 1: a white rough metal reflects everything.

use super::microfacet::{fresnel_dielectric, g1, g2, sample_visible_normal};
use super::{baked, SMOOTH_ALPHA_SQ};
use crate::rng::Rng;
use rayon::prelude::*;
use glam::Vec2;
use crate::Vec3;
use std::sync::OnceLock;

const N: usize = 32;
/// Stratified samples per table entry (STRATA² of them).
const STRATA: usize = 48;
/// The relative IOR of Blender's Principled default (IOR 1.5, F0 = 0.04).
pub const DIELECTRIC_ETA: f32 = 1.5;

pub struct EnergyTables {
    e: Vec<f32>,
    e_avg: Vec<f32>,
    e_layer: Vec<f32>,
    /// Average dielectric Fresnel at DIELECTRIC_ETA.
    pub dielectric_f_avg: f32,
}

fn grid(i: usize) -> f32 {
    i as f32 / (N - 1) as f32
}

/// The μ of grid column i.
fn grid_mu(i: usize) -> f32 {
    grid(i) * grid(i)
}

/// Fractional grid column of μ.
fn column(mu: f32) -> f32 {
    mu.clamp(0.0, 1.0).sqrt() * (N - 1) as f32
}

/// Fractional grid row of a roughness.
fn row(roughness: f32) -> f32 {
    roughness.clamp(0.0, 1.0) * (N - 1) as f32
}

/// Linear interpolation of grid values at fractional index x ∈ [0, len−1].
pub(super) fn lerp_grid(values: &[f32], x: f32) -> f32 {
    let i = cell(x, values.len());
    let t = x - i as f32;
    values[i] * (1.0 - t) + values[i + 1] * t
}

/// A view direction at cosine μ (tiny μ is held at 1e-3: the lobe's
/// albedo is continuous there, the sampler's arithmetic is not).
pub(super) fn view(mu: f32) -> Vec3 {
    let mu = mu.max(1e-3);
    Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu)
}

/// E_VNDF[F(wo·h) G2/G1(wo)] over jittered-stratified visible normals:
/// the single-scattering albedo with Fresnel `fresnel`. (Stratum midpoints
/// instead of jitter came out 1.2% low at roughness 0.35: the grid aliases
/// with the sampler's warp.)
fn single_scatter_albedo(mu: f32, roughness: f32, fresnel: impl Fn(f32) -> f32) -> f32 {
    let wo = view(mu);
    let alpha = roughness * roughness;
    if alpha * alpha <= SMOOTH_ALPHA_SQ {
        return fresnel(wo.z);
    }
    let g1o = g1(wo, alpha);
    let mut rng = Rng::new(mu.to_bits() as u64, roughness.to_bits() as u64);
    visible_normal_mean(wo, alpha, STRATA, &mut rng, |h| {
        let wi = 2.0 * wo.dot(h) * h - wo;
        if wi.z > 0.0 { fresnel(wo.dot(h)) * g2(wo, wi, alpha) / g1o } else { 0.0 }
    })
}

/// The mean of `weight(h)` over strata² jittered-stratified visible
/// normals for wo: the estimator every albedo table here is built with.
pub(super) fn visible_normal_mean(wo: Vec3, alpha: f32, strata: usize, rng: &mut Rng, weight: impl Fn(Vec3) -> f32) -> f32 {
    let mut sum = 0.0f64;
    for i in 0..strata {
        for j in 0..strata {
            let u = (Vec2::new(i as f32, j as f32) + rng.next_2d()) / strata as f32;
            sum += weight(sample_visible_normal(wo, alpha, u)) as f64;
        }
    }
    (sum / (strata * strata) as f64) as f32
}

/// 2∫ f(μ) μ dμ by the midpoint rule.
pub(super) fn cosine_average(f: impl Fn(f32) -> f32) -> f32 {
    let n = 1000;
    (0..n).map(|i| (i as f32 + 0.5) / n as f32).map(|mu| 2.0 * f(mu) * mu / n as f32).sum()
}

/// F_ms = F_avg E_avg / (1 − F_avg (1 − E_avg)), per channel for a
/// coloured average Fresnel: what `ms_scale` needs of the lobe besides E,
/// so a material computes it once.
pub fn ms_fraction(e_avg: f32, f_avg: Vec3) -> Vec3 {
    f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg))
}

/// Scale of the single-scattering lobe that puts back the energy of the
/// missing bounces, S = 1 + F_ms (1 − E)/E.
pub fn ms_scale(e: f32, f_ms: Vec3) -> Vec3 {
    let e = e.max(1e-4);
    Vec3::ONE + f_ms * ((1.0 - e) / e)
}

/// Floats a baked `EnergyTables` holds: E, E_avg, E_layer, F_avg.
pub(super) const BAKED_FLOATS: usize = 2 * N * N + N + 1;

impl EnergyTables {
    /// The tables from the lobe code (about 0.1 s on 2 cores).
    pub fn build() -> Self {
        // Rows in parallel: 2 × 1024 entries × 2304 samples.
        let e: Vec<f32> = (0..N * N).into_par_iter().map(|k| single_scatter_albedo(grid_mu(k % N), grid(k / N), |_| 1.0)).collect();
        let e_avg: Vec<f32> = e.chunks(N).map(|e_row| cosine_average(|mu| lerp_grid(e_row, column(mu)))).collect();
        let f_avg = cosine_average(|mu| fresnel_dielectric(mu, DIELECTRIC_ETA));
        let e_layer: Vec<f32> = (0..N * N)
            .into_par_iter()
            .map(|k| {
                let (mi, ri) = (k % N, k / N);
                let single = single_scatter_albedo(grid_mu(mi), grid(ri), |c| fresnel_dielectric(c, DIELECTRIC_ETA));
                (single * ms_scale(e[k], ms_fraction(e_avg[ri], Vec3::splat(f_avg))).x).min(1.0)
            })
            .collect();
        EnergyTables { e, e_avg, e_layer, dielectric_f_avg: f_avg }
    }

    /// Every value, in the baked file's order.
    pub fn to_floats(&self) -> Vec<f32> {
        [&self.e[..], &self.e_avg, &self.e_layer, &[self.dielectric_f_avg]].concat()
    }

    fn from_floats(v: &[f32]) -> Self {
        let (e, rest) = v.split_at(N * N);
        let (e_avg, rest) = rest.split_at(N);
        let (e_layer, rest) = rest.split_at(N * N);
        EnergyTables { e: e.to_vec(), e_avg: e_avg.to_vec(), e_layer: e_layer.to_vec(), dielectric_f_avg: rest[0] }
    }

    pub fn e(&self, mu: f32, roughness: f32) -> f32 {
        GridPoint::at(column(mu), TableRow::of(roughness)).read(&self.e)
    }

    pub fn e_avg(&self, roughness: f32) -> f32 {
        lerp_grid(&self.e_avg, row(roughness))
    }

    pub fn e_layer(&self, mu: f32, roughness: f32) -> f32 {
        GridPoint::at(column(mu), TableRow::of(roughness)).read(&self.e_layer)
    }

    /// `e` and `e_layer` at once: the same numbers, the grid position
    /// (a square root and two roundings) found once.
    pub fn e_and_layer(&self, mu: f32, roughness: f32) -> (f32, f32) {
        self.e_and_layer_in(TableRow::of(roughness), mu)
    }

    /// `e_and_layer` in a roughness's rows, found once per material
    /// (`TableRow::of`): the same numbers. Half of a lookup's 114
    /// instructions had been finding the row and rounding both indices to
    /// `usize`, and a Principled BSDF is built about ten times a path.
    #[inline]
    pub fn e_and_layer_in(&self, row: TableRow, mu: f32) -> (f32, f32) {
        let at = GridPoint::at(column(mu), row);
        (at.read(&self.e), at.read(&self.e_layer))
    }

    /// `e` and `e_layer` along μ at a roughness, interpolated across the
    /// grid's rows once: a material whose roughness is the same everywhere
    /// then reads two values a table where `e_and_layer_in` reads four.
    pub fn rows(&self, row: TableRow) -> EnergyRows {
        let TableRow { j, ty } = row;
        let across = |table: &[f32]| std::array::from_fn(|i| table[j * N + i] * (1.0 - ty) + table[(j + 1) * N + i] * ty);
        EnergyRows { e: across(&self.e), e_layer: across(&self.e_layer) }
    }
}

/// `e` and `e_layer` at one roughness, over the grid's columns.
#[derive(Clone, Copy, Debug)]
pub struct EnergyRows {
    e: [f32; N],
    e_layer: [f32; N],
}

impl EnergyRows {
    /// `e_and_layer_in` at μ, bit for bit.
    #[inline]
    pub fn at(&self, mu: f32) -> (f32, f32) {
        let x = column(mu);
        let i = cell(x, N);
        let t = x - i as f32;
        let lerp = |r: &[f32; N]| r[i] * (1.0 - t) + r[i + 1] * t;
        (lerp(&self.e), lerp(&self.e_layer))
    }
}

/// The cell's lower index along an axis of `len` grid points for a
/// fractional index `x` in [0, len − 1] (or NaN, which lands on 0 as an
/// `as usize` would): through i32, whose conversion is one instruction
/// where usize's takes a dozen.
#[inline]
pub(super) fn cell(x: f32, len: usize) -> usize {
    (x as i32).clamp(0, len as i32 - 2) as usize
}

/// Where a roughness falls between the grid's rows: the lower row and the
/// fraction toward the next.
#[derive(Clone, Copy, Debug)]
pub struct TableRow {
    j: usize,
    ty: f32,
}

impl TableRow {
    pub fn of(roughness: f32) -> Self {
        let y = row(roughness);
        let j = cell(y, N);
        TableRow { j, ty: y - j as f32 }
    }
}

/// Where (μ, roughness) falls on the N × N grid: the cell's corner and the
/// fractions across it, for bilinear reads of any table on that grid.
struct GridPoint {
    i: usize,
    tx: f32,
    row: TableRow,
}

impl GridPoint {
    #[inline]
    fn at(x: f32, row: TableRow) -> Self {
        let i = cell(x, N);
        GridPoint { i, tx: x - i as f32, row }
    }

    /// Across rows j and j + 1 in columns i and i + 1, then along μ: the
    /// operations of `EnergyTables::rows` and `EnergyRows::at`, so that a
    /// material's 1-D rows read the same numbers, bit for bit, as a
    /// textured surface's 2-D reads (and the kernels that prepare
    /// materials render the general kernel's image).
    #[inline]
    fn read(&self, table: &[f32]) -> f32 {
        let TableRow { j, ty } = self.row;
        let (k0, k1) = (j * N + self.i, (j + 1) * N + self.i);
        let (r0, r1) = (&table[k0..k0 + 2], &table[k1..k1 + 2]);
        let a = r0[0] * (1.0 - ty) + r1[0] * ty;
        let b = r0[1] * (1.0 - ty) + r1[1] * ty;
        a * (1.0 - self.tx) + b * self.tx
    }
}

/// Cells of `layer_fresnel`'s table over cosines 0 … 1.
const FRESNEL_CELLS: usize = 1024;

/// `fresnel_dielectric(cos, DIELECTRIC_ETA)`, the Principled BSDF's
/// specular layer's Fresnel, interpolated in a table of 1,025 values:
/// every BSDF evaluation of a dielectric asks for it, and its square root
/// and two divisions in a row were about 30% of an evaluation's time (perf).
/// Within 5e-6 of the exact value at every cosine (the test below), where
/// the layer's albedo tables hold 1e-5.
#[inline]
pub fn layer_fresnel(cos: f32) -> f32 {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    let table = TABLE.get_or_init(|| (0..=FRESNEL_CELLS).map(|i| fresnel_dielectric(i as f32 / FRESNEL_CELLS as f32, DIELECTRIC_ETA)).collect());
    let x = cos.abs().min(1.0) * FRESNEL_CELLS as f32;
    let i = cell(x, FRESNEL_CELLS + 1);
    let t = x - i as f32;
    let (a, b) = (table[i], table[i + 1]);
    a + t * (b - a)
}

/// The baked tables (built afresh only if the baked file were not the
/// tables' size, which the tests rule out).
pub fn tables() -> &'static EnergyTables {
    static TABLES: OnceLock<EnergyTables> = OnceLock::new();
    TABLES.get_or_init(|| baked::floats(include_bytes!("energy.bin"), BAKED_FLOATS).map_or_else(EnergyTables::build, |v| EnergyTables::from_floats(&v)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet;

    #[test]
    fn a_roughness_rows_read_what_the_tables_do_bit_for_bit() {
        let t = tables();
        for r in 0..=200 {
            let roughness = r as f32 / 200.0;
            let rows = t.rows(TableRow::of(roughness));
            for m in 0..=1000 {
                let mu = m as f32 / 1000.0;
                let ((e, layer), (e1, layer1)) = (t.e_and_layer(mu, roughness), rows.at(mu));
                assert!(e.to_bits() == e1.to_bits() && layer.to_bits() == layer1.to_bits(), "roughness {roughness}, mu {mu}: {e} {e1}, {layer} {layer1}");
            }
        }
    }

    #[test]
    fn layer_fresnel_is_the_exact_fresnel_to_5e_6() {
        let n = 1_000_000;
        let worst = (0..=n).map(|k| k as f32 / n as f32).map(|c| (layer_fresnel(c) - fresnel_dielectric(c, DIELECTRIC_ETA)).abs()).fold(0.0f32, f32::max);
        assert!(worst < 5e-6, "{worst}");
        // Either side, and past 1 by rounding.
        assert_eq!(layer_fresnel(-0.3), layer_fresnel(0.3));
        assert_eq!(layer_fresnel(1.0 + 1e-6), fresnel_dielectric(1.0, DIELECTRIC_ETA));
        assert!((layer_fresnel(0.0) - 1.0).abs() < 1e-6 && layer_fresnel(f32::NAN).is_finite());
    }

    /// The tables against an independent Monte Carlo integral of the lobe:
    /// half vectors drawn from D(h)cosθh (the seed's sampler, not the
    /// visible-normal one the tables use), weighted by f·cosθi / pdf.
    #[test]
    fn tables_match_a_monte_carlo_integral_of_the_lobe() {
        let t = tables();
        let mut rng = Rng::new(4, 4);
        for roughness in [0.1f32, 0.35, 0.6, 1.0] {
            for mu in [0.15f32, 0.5, 0.95] {
                let wo = view(mu);
                let alpha = roughness * roughness;
                let (n, mut sum_e, mut sum_f) = (400_000, 0.0f64, 0.0f64);
                for _ in 0..n {
                    let Some(wi) = crate::bsdf::ggx::sample(wo, rng.next_2d(), alpha) else { continue };
                    let f = microfacet::eval(wo, wi, alpha) * wi.z / crate::bsdf::ggx::pdf(wo, wi, alpha);
                    let h = (wo + wi).normalize();
                    sum_e += f as f64;
                    sum_f += (f * fresnel_dielectric(wo.dot(h), DIELECTRIC_ETA)) as f64;
                }
                let (e_mc, f_mc) = ((sum_e / n as f64) as f32, (sum_f / n as f64) as f32);
                let e = t.e(mu, roughness);
                let s = ms_scale(e, ms_fraction(t.e_avg(roughness), Vec3::splat(t.dielectric_f_avg))).x;
                // 400k samples: the estimate's noise is < 0.1%; the
                // tables' grid interpolation adds up to ~0.3%.
                let tol = 0.005;
                assert!((e - e_mc).abs() < tol * e_mc, "r {roughness} μ {mu}: table E {e} vs MC {e_mc}");
                let layer = t.e_layer(mu, roughness);
                assert!((layer - f_mc * s).abs() < tol * f_mc * s + 1e-4, "r {roughness} μ {mu}: layer {layer} vs MC {}", f_mc * s);
            }
        }
        // Known values: IOR 1.5 averages F = 0.0918; a smooth lobe loses nothing.
        assert!((t.dielectric_f_avg - 0.0918).abs() < 5e-4, "{}", t.dielectric_f_avg);
        assert!((t.e(0.5, 0.0) - 1.0).abs() < 1e-6 && (t.e_avg(0.0) - 1.0).abs() < 1e-3);
        assert!((t.e_layer(1.0, 0.0) - 0.04).abs() < 1e-4);
    }

    /// The joint lookup is both lookups, and each is `lerp_grid` along μ in
    /// two rows then across them, bit for bit.
    #[test]
    fn the_joint_lookup_is_both_lookups_bit_for_bit() {
        let t = tables();
        let rows = |table: &[f32], mu: f32, roughness: f32| {
            // Across the two rows, then along μ as lerp_grid does.
            let (x, y) = (column(mu), row(roughness));
            let j = (y as usize).min(N - 2);
            let ty = y - j as f32;
            let across: Vec<f32> = (0..N).map(|i| table[j * N + i] * (1.0 - ty) + table[(j + 1) * N + i] * ty).collect();
            lerp_grid(&across, x)
        };
        for ri in 0..=40 {
            for mi in 0..=40 {
                let (mu, roughness) = (mi as f32 / 40.0, ri as f32 / 40.0);
                let (e, layer) = t.e_and_layer(mu, roughness);
                assert_eq!((e.to_bits(), layer.to_bits()), (t.e(mu, roughness).to_bits(), t.e_layer(mu, roughness).to_bits()), "μ {mu} r {roughness}");
                assert_eq!((e.to_bits(), layer.to_bits()), (rows(&t.e, mu, roughness).to_bits(), rows(&t.e_layer, mu, roughness).to_bits()), "μ {mu} r {roughness}");
            }
        }
    }

    #[test]
    fn compensation_makes_a_white_lobe_reflect_everything() {
        let t = tables();
        for roughness in [0.2f32, 0.5, 1.0] {
            for mu in [0.1f32, 0.5, 1.0] {
                let e = t.e(mu, roughness);
                let s = ms_scale(e, ms_fraction(t.e_avg(roughness), Vec3::ONE)).x;
                assert!((s * e - 1.0).abs() < 1e-4, "r {roughness} μ {mu}: S·E = {}", s * e);
            }
        }
        // At α = 1 and normal incidence D = 1/π and G2 = 2μi/(μi + 1), so
        // E = ∫ D G2 / 4 dωi = 1 − ln 2: single scattering keeps only 31%.
        let e = t.e(1.0, 1.0);
        assert!((e - (1.0 - std::f32::consts::LN_2)).abs() < 1e-3, "{e}");
    }
}
