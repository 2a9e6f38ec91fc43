//! A clear coat over a BSDF, as Cycles 4.5's Principled BSDF lays its Coat
//! over everything below it (glTF's KHR_materials_clearcoat, which Blender's
//! exporter writes from Coat Weight and Coat Roughness):
//!
//!   f = c · S_c · F_diel(wo·h) · f_ggx(α_c) + (1 − c · E_layer(μo, r_c)) · f_base
//!
//! * c: the coat's weight; α_c = r_c², r_c its roughness.
//! * The coat is Cycles' dielectric microfacet reflection at IOR 1.5 (glTF's
//!   coat IOR, Blender's default): exact Fresnel, and always compensated for
//!   multiple scattering (S_c, energy.rs), whatever the node's Distribution
//!   says — Cycles' `bsdf_microfacet_setup_fresnel_dielectric` does so.
//! * What lies below gets what the coat does not reflect: its weight is
//!   1 − c·E_layer(μo, r_c), the coat's albedo at wo from the same table as
//!   the Principled specular layer's (Cycles' `closure_layering_weight`).
//!   Like Cycles' layering, it depends on wo only.
//! * Coat Tint (from the render request: glTF carries none) colours what
//!   the layers below send through the coat: their weight × mix(1,
//!   tint^(1/cosθt), c), θt the angle of wo refracted into the coat — a
//!   path through a coat of unit thickness, as Cycles takes it.
//! * Emission lies under the coat too, as in Cycles, which sets it up with
//!   the weight the coat leaves the layers below: what leaves toward a
//!   direction at cosine μ to the face is Emission × (1 − c·E_layer(μ,
//!   r_c)) × mix(1, tint^(1/cosθt), c) (`emission_weight`). Every way
//!   Glint finds an emitter takes μ about its geometric normal, so that
//!   they agree (Cycles takes the interpolated normal: the same on a flat
//!   emitter), and the coat's factors, not its textures (which light
//!   sampling would have to read at every sample).
//! * The coat's normal is the interpolated normal before a normal map, as
//!   Cycles takes it where Coat Normal is unlinked: a normal map bends the
//!   layers below, not the coat. Where the two differ the coat's lobe is
//!   evaluated and sampled in a frame of its own (`Surface::coat_normal`).
//!
//! Only kernels for scenes with a coated material run this (features.rs).

use super::energy::{layer_fresnel, ms_fraction, ms_scale, tables, EnergyRows, TableRow, DIELECTRIC_ETA};
use super::microfacet::{self, fresnel_dielectric};
use super::{luminance, Bsdf, BsdfSample, SMOOTH_ALPHA_SQ, SPEC_MIN_SHARE};
use crate::material::{Material, Surface};
use crate::sampling::Frame;
use glam::Vec2;
use crate::Vec3;

/// The coat's IOR: glTF's (KHR_materials_clearcoat has no other), the
/// one the energy tables and `layer_fresnel` hold.
const COAT_ETA: f32 = DIELECTRIC_ETA;

/// What of a coat depends on the surface alone, not on wo.
#[derive(Clone, Copy, Debug)]
pub struct CoatLayer {
    weight: f32,
    roughness: f32,
    alpha: f32,
    /// α² ≤ SMOOTH_ALPHA_SQ: a perfect mirror.
    smooth: bool,
    /// The coat's roughness in the energy tables, and for a material
    /// that keeps its layer (`for_material`) the tables along μ there.
    row: TableRow,
    rows: Option<EnergyRows>,
    /// F_ms of the coat, for its multiple-scattering scale.
    f_ms: f32,
    /// Coat Tint, where it is not white.
    tint: Option<Vec3>,
    /// The coat's own frame, in the BSDF's local one, where its normal
    /// is not the shading normal.
    frame: Option<Frame>,
}

impl CoatLayer {
    /// None where the surface has no coat. Built at every hit of a
    /// textured surface: its energy rows are not interpolated here (the
    /// tables are read in place), as `PrincipledLobes::new`'s.
    pub fn of(s: &Surface) -> Option<Self> {
        let n = s.coat_normal.normalize_or_zero();
        let frame = (n.is_finite() && n != Vec3::ZERO && n != Vec3::Z).then(|| Frame::from_normal(n));
        CoatLayer::new(s.coat, s.coat_roughness, s.coat_tint).map(|c| CoatLayer { frame, ..c })
    }

    /// A coat of this weight, roughness and tint about the shading normal;
    /// None for weight 0.
    fn new(weight: f32, roughness: f32, tint: Vec3) -> Option<Self> {
        let weight = weight.clamp(0.0, 1.0);
        if !(weight > 0.0) {
            return None;
        }
        let roughness = roughness.clamp(0.0, 1.0);
        let alpha = roughness * roughness;
        let smooth = alpha * alpha <= SMOOTH_ALPHA_SQ;
        let t = tables();
        let f_ms = if smooth { 0.0 } else { ms_fraction(t.e_avg(roughness), Vec3::splat(t.dielectric_f_avg)).x };
        let tint = (tint != Vec3::ONE).then(|| tint.clamp(Vec3::ZERO, Vec3::ONE));
        Some(CoatLayer { weight, roughness, alpha, smooth, row: TableRow::of(roughness), rows: None, f_ms, tint, frame: None })
    }

    /// At cosine `mu` to the coat: its lobe's multiple-scattering scale
    /// S_c, what it reflects (c·E_layer(μ), for a mirror c·F(μ)), and the
    /// share of the light it lets through, tinted (Cycles'
    /// `closure_layering_weight` and Coat Tint).
    fn at(&self, mu: f32) -> (f32, f32, Vec3) {
        // A mirror loses nothing to single scattering, and its albedo is
        // the Fresnel reflectance itself.
        let (s, albedo) = if self.smooth {
            (1.0, fresnel_dielectric(mu, COAT_ETA))
        } else {
            let (e, albedo) = self.energies(mu);
            (ms_scale(e, Vec3::splat(self.f_ms)).x, albedo)
        };
        let reflected = self.weight * albedo;
        let mut through = Vec3::splat((1.0 - reflected).clamp(0.0, 1.0));
        if let Some(tint) = self.tint {
            let cos_t = (1.0 - (1.0 - mu * mu) / (COAT_ETA * COAT_ETA)).sqrt();
            through *= Vec3::ONE.lerp(tint.powf(1.0 / cos_t), self.weight);
        }
        (s, reflected, through)
    }

    /// `of`, for a material whose surface is the same at every point: with
    /// its own energy rows, read along μ alone (the same numbers).
    fn for_material(s: &Surface) -> Option<Self> {
        CoatLayer::of(s).map(|c| CoatLayer { rows: (!c.smooth).then(|| tables().rows(c.row)), ..c })
    }

    /// E(μ) and E_layer(μ) at the coat's roughness.
    fn energies(&self, mu: f32) -> (f32, f32) {
        match &self.rows {
            Some(rows) => rows.at(mu),
            None => tables().e_and_layer_in(self.row, mu),
        }
    }

    /// A direction of the BSDF's frame in the coat's.
    #[inline]
    fn local(&self, w: Vec3) -> Vec3 {
        local(self.frame, w)
    }
}

#[inline]
fn local(frame: Option<Frame>, w: Vec3) -> Vec3 {
    frame.map_or(w, |f| f.to_local(w))
}

/// A coat at one wo: what its lobe needs, its scale and its albedo.
#[derive(Clone, Copy, Debug)]
struct CoatAt {
    alpha: f32,
    smooth: bool,
    frame: Option<Frame>,
    /// c · S_c: the lobe's weight times its multiple-scattering scale.
    scale: f32,
    /// c · E_layer(μo): what the coat reflects (for a mirror, c·F(μo)).
    reflected: f32,
}

impl CoatAt {
    #[inline]
    fn local(&self, w: Vec3) -> Vec3 {
        local(self.frame, w)
    }

    #[inline]
    fn world(&self, w: Vec3) -> Vec3 {
        self.frame.map_or(w, |f| f.to_world(w))
    }
}

#[derive(Clone, Copy, Debug)]
pub struct WithCoat<B> {
    base: B,
    /// None where this point has no coat.
    coat: Option<CoatAt>,
    /// 1 − c·E_layer(μo), tinted: the share of the light the coat lets
    /// through.
    base_weight: Vec3,
    /// Probability of sampling the coat rather than the base.
    coat_probability: f32,
}

impl<B: Bsdf> WithCoat<B> {
    fn of(base: B, layer: Option<CoatLayer>, wo: Vec3) -> Self {
        let Some(layer) = layer else {
            return WithCoat { base, coat: None, base_weight: Vec3::ONE, coat_probability: 0.0 };
        };
        let mu = layer.local(wo).z.clamp(0.0, 1.0);
        let (s, reflected, base_weight) = layer.at(mu);
        let below = luminance(base_weight) * base.reflectance();
        let mut coat_probability = if reflected + below > 0.0 { reflected / (reflected + below) } else { 1.0 };
        // As the Principled specular layer: a narrow lobe gets at least a
        // floor share, for the sharp highlights light samples miss.
        if below > 0.0 {
            coat_probability = coat_probability.max(SPEC_MIN_SHARE * (1.0 - layer.roughness) * (1.0 - layer.roughness));
        }
        let coat = CoatAt { alpha: layer.alpha, smooth: layer.smooth, frame: layer.frame, scale: layer.weight * s, reflected };
        WithCoat { base, coat: Some(coat), base_weight, coat_probability }
    }

    /// The coat's lobe alone (0 for a mirror coat, which only sampling
    /// finds), in its own frame: a solid-angle pdf is the same in any.
    /// The integrator weighs f by the cosine about the shading normal; a
    /// coat with a normal of its own is weighed, as Cycles weighs each
    /// closure, by the cosine about that: f carries their ratio.
    fn coat_eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let Some(c) = &self.coat else { return (Vec3::ZERO, 0.0) };
        // Above both the shading surface and the coat, as its samples are.
        if c.smooth || !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let shading_cos = wi.z;
        let (wo, wi) = (c.local(wo), c.local(wi));
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let (mut lobe, pdf) = microfacet::eval_pdf(wo, wi, c.alpha);
        if c.frame.is_some() {
            lobe *= wi.z / shading_cos;
        }
        (Vec3::splat(c.scale * layer_fresnel(microfacet::cos_half(wo, wi)) * lobe), pdf)
    }
}

impl<B: Bsdf> Bsdf for WithCoat<B> {
    type Prepared = (B::Prepared, Option<CoatLayer>);
    const GLASS: bool = B::GLASS;

    fn prepare(surface: &Surface) -> Self::Prepared {
        (B::prepare(surface), CoatLayer::for_material(surface))
    }

    fn at(prepared: &Self::Prepared, wo: Vec3) -> Self {
        WithCoat::of(B::at(&prepared.0, wo), prepared.1, wo)
    }

    fn new(surface: &Surface, wo: Vec3) -> Self {
        WithCoat::of(B::new(surface, wo), CoatLayer::of(surface), wo)
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.coat_eval_pdf(wo, wi).0 + self.base.eval(wo, wi) * self.base_weight
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.coat_probability;
        p * self.coat_eval_pdf(wo, wi).1 + (1.0 - p) * self.base.pdf(wo, wi)
    }

    fn evaluate(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let p = self.coat_probability;
        let (coat, coat_pdf) = self.coat_eval_pdf(wo, wi);
        let (base, base_pdf) = self.base.evaluate(wo, wi);
        (coat + base * self.base_weight, p * coat_pdf + (1.0 - p) * base_pdf)
    }

    fn transmits(&self) -> bool {
        self.base.transmits()
    }

    fn reflectance(&self) -> f32 {
        self.coat.map_or(0.0, |c| c.reflected) + luminance(self.base_weight) * self.base.reflectance()
    }

    #[inline]
    fn emission_weight(material: &Material, cos_out: f32) -> Option<Vec3> {
        (material.coat > 0.0).then(|| emission_weight(material, cos_out))
    }

    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let p = self.coat_probability;
        let s = match &self.coat {
            Some(c) if u_lobe < p => {
                let wo_c = c.local(wo);
                if wo.z <= 0.0 || wo_c.z <= 0.0 {
                    return None;
                }
                let wi = if c.smooth {
                    c.world(Vec3::new(-wo_c.x, -wo_c.y, wo_c.z))
                } else {
                    c.world(microfacet::sample(wo_c, c.alpha, u)?.0)
                };
                if wi.z <= 0.0 {
                    return None;
                }
                if c.smooth {
                    // The mirror: no other lobe makes this direction, and
                    // it reflects what the coat reflects at wo.
                    let f = Vec3::splat(c.reflected);
                    return Some(BsdfSample { wi, f, pdf: p, weight: f / p, delta: true, diffuse: false });
                }
                BsdfSample { wi, f: Vec3::ZERO, pdf: 0.0, weight: Vec3::ZERO, delta: false, diffuse: false }
            }
            _ => {
                // One uniform picks the layer and, rescaled, the lobe below.
                let s = self.base.sample(wo, ((u_lobe - p) / (1.0 - p)).clamp(0.0, 1.0), u)?;
                if self.coat.is_none() {
                    return Some(s);
                }
                if s.delta {
                    return Some(BsdfSample { f: s.f * self.base_weight, pdf: s.pdf * (1.0 - p), weight: s.weight * (self.base_weight / (1.0 - p)), ..s });
                }
                s
            }
        };
        let (f, pdf) = self.evaluate(wo, s.wi);
        let weight = f * (s.wi.z.abs() / pdf);
        (pdf > 0.0 && weight.is_finite()).then_some(BsdfSample { f, pdf, weight, ..s })
    }
}

/// What of a coated material's emission leaves through its coat toward a
/// direction at cosine `cos_out` to its face (either side): the share the
/// coat lets through there, tinted, as Cycles weighs the emission under it.
pub fn emission_weight(material: &Material, cos_out: f32) -> Vec3 {
    CoatLayer::new(material.coat, material.coat_roughness, material.coat_tint).map_or(Vec3::ONE, |c| c.at(cos_out.abs().min(1.0)).2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::chi2::{albedo_of, bsdf_chi2, dir_at};
    use crate::bsdf::{PrincipledBsdf, WithGlass};
    use crate::material::Material;
    use crate::rng::Rng;

    type Coated = WithCoat<WithGlass<PrincipledBsdf>>;

    fn coated(base: Vec3, metallic: f32, roughness: f32, coat: f32, coat_roughness: f32) -> Surface {
        Material { base_color: base, metallic, roughness, coat, coat_roughness, ..Material::default() }.surface()
    }

    /// A white surface under a coat still returns all the light: the coat
    /// reflects c·E_layer(μo) (its lobe compensated for multiple
    /// scattering) and what lies below gets the rest. Cycles' layering
    /// keeps this furnace too.
    #[test]
    fn a_coated_white_surface_passes_the_furnace_test() {
        let mut worst = 0.0f32;
        for (metallic, roughness) in [(0.0f32, 0.5f32), (1.0, 0.3), (0.0, 0.0)] {
            for (coat, coat_roughness) in [(1.0f32, 0.03f32), (1.0, 0.3), (0.5, 0.8), (1.0, 0.0)] {
                for theta in [0.0f32, 45.0, 75.0, 85.0] {
                    let wo = dir_at(theta);
                    let bsdf = Coated::new(&coated(Vec3::ONE, metallic, roughness, coat, coat_roughness), wo);
                    let a = albedo_of(&bsdf, wo, 100_000, 31).max_element();
                    worst = worst.max((a - 1.0).abs());
                    // As the Principled furnace (bsdf/tests.rs): noise < 0.3%,
                    // the tables' interpolation < 1%.
                    assert!((a - 1.0).abs() < 0.015, "metallic {metallic} roughness {roughness} coat {coat}/{coat_roughness} θo {theta}: albedo {a}");
                }
            }
        }
        eprintln!("white furnace under a coat: worst |albedo − 1| = {worst:.4}");
    }

    /// A black base shows the coat alone: c·E_layer(μo), what it takes
    /// from the layers below.
    #[test]
    fn over_black_the_coat_reflects_its_own_albedo() {
        for (coat, coat_roughness) in [(1.0f32, 0.3f32), (0.6, 0.7), (1.0, 0.0)] {
            for theta in [0.0f32, 60.0, 85.0] {
                let wo = dir_at(theta);
                let s = coated(Vec3::ZERO, 0.0, 0.5, coat, coat_roughness);
                let bsdf = Coated::new(&Surface { specular: 0.0, ..s }, wo);
                let a = albedo_of(&bsdf, wo, 200_000, 32).x;
                let expected = 1.0 - bsdf.base_weight.x;
                assert!((a - expected).abs() < 0.01 * expected + 1e-4, "coat {coat}/{coat_roughness} θo {theta}: {a} vs {expected}");
            }
        }
    }

    #[test]
    fn coated_sampling_matches_its_pdf() {
        const P_MIN: f64 = 1e-4;
        for (base, metallic, roughness) in [(Vec3::new(0.8, 0.3, 0.2), 0.0f32, 0.5f32), (Vec3::new(1.0, 0.7, 0.3), 1.0, 0.6)] {
            for coat_roughness in [0.3f32, 0.6] {
                for theta in [10.0f32, 60.0, 85.0] {
                    let wo = dir_at(theta);
                    let bsdf = Coated::new(&coated(base, metallic, roughness, 0.8, coat_roughness), wo);
                    let r = bsdf_chi2(&bsdf, wo, 1_000_000, 7);
                    assert!(r.p_value > P_MIN, "metallic {metallic} coat roughness {coat_roughness} θo {theta}: p = {}", r.p_value);
                }
            }
        }
    }

    /// Without a coat the layer is not there, bit for bit: the general
    /// kernel (`--features all`) renders what the scene's own does.
    #[test]
    fn no_coat_is_the_base_bit_for_bit() {
        let mut rng = Rng::new(3, 4);
        for (metallic, roughness, transmission) in [(0.0f32, 0.0f32, 0.0f32), (0.0, 0.4, 0.0), (1.0, 0.2, 0.0), (0.0, 0.3, 0.7)] {
            let m = Surface { transmission, ..coated(Vec3::new(0.9, 0.6, 0.2), metallic, roughness, 0.0, 0.3) };
            for theta in [0.0f32, 40.0, 89.0] {
                let wo = dir_at(theta);
                let (a, b) = (Coated::new(&m, wo), WithGlass::<PrincipledBsdf>::new(&m, wo));
                for _ in 0..300 {
                    let d = crate::sampling::cosine_hemisphere(rng.next_2d());
                    let wi = if rng.next_f32() < 0.3 { -d } else { d };
                    assert_eq!(a.evaluate(wo, wi), b.evaluate(wo, wi));
                    let (ul, u) = (rng.next_f32(), rng.next_2d());
                    let (sa, sb) = (a.sample(wo, ul, u), b.sample(wo, ul, u));
                    assert_eq!(sa.map(|s| (s.wi, s.f, s.pdf, s.weight, s.delta)), sb.map(|s| (s.wi, s.f, s.pdf, s.weight, s.delta)));
                }
            }
        }
    }

    /// A coat of roughness 0 is a mirror: sampled as a delta lobe with the
    /// Fresnel reflectance of IOR 1.5, never evaluated, and the base below
    /// gets 1 − c·F(μo).
    #[test]
    fn a_smooth_coat_is_a_fresnel_mirror() {
        let wo = dir_at(60.0);
        let bsdf = Coated::new(&coated(Vec3::new(0.5, 0.5, 0.5), 0.0, 0.5, 0.8, 0.0), wo);
        let fresnel = fresnel_dielectric(wo.z, COAT_ETA);
        assert!((bsdf.base_weight - Vec3::splat(1.0 - 0.8 * fresnel)).abs().max_element() < 1e-6);
        let s = bsdf.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
        assert!(s.delta && s.wi == Vec3::new(-wo.x, -wo.y, wo.z) && (s.f.x - 0.8 * fresnel).abs() < 1e-6, "{s:?}");
        let base = WithGlass::<PrincipledBsdf>::new(&coated(Vec3::new(0.5, 0.5, 0.5), 0.0, 0.5, 0.0, 0.0), wo);
        assert_eq!(bsdf.eval(wo, s.wi), base.eval(wo, s.wi) * bsdf.base_weight);
    }

    /// Emission under a coat keeps what the coat lets through toward its
    /// direction, the weight the layers below get for that wo: the same
    /// numbers, on either face, and all of it without a coat; less toward
    /// grazing, where the coat reflects more; finite at every angle.
    #[test]
    fn emission_under_a_coat_keeps_what_the_layers_below_keep() {
        let surface = Surface { coat_tint: Vec3::new(0.4, 0.8, 1.0), ..coated(Vec3::ONE, 0.0, 0.5, 0.7, 0.3) };
        let material = Material { coat: 0.7, coat_roughness: 0.3, coat_tint: surface.coat_tint, ..Material::default() };
        for theta in [0.0f32, 40.0, 75.0] {
            let wo = dir_at(theta);
            let below = Coated::new(&surface, wo).base_weight;
            for cos in [wo.z, -wo.z] {
                assert!((emission_weight(&material, cos) - below).abs().max_element() < 1e-6, "{theta}°: {} against {below}", emission_weight(&material, cos));
            }
        }
        assert!(emission_weight(&material, 0.2).z < emission_weight(&material, 0.9).z);
        assert_eq!(emission_weight(&Material::default(), 0.5), Vec3::ONE);
        for roughness in [0.0, 0.01, 0.5, 1.0] {
            let m = Material { coat: 1.0, coat_roughness: roughness, ..material.clone() };
            for cos in [-1.0, -1e-7, 0.0, 1e-7, 0.3, 1.0, 1.5] {
                let w = emission_weight(&m, cos);
                assert!(w.is_finite() && w.min_element() >= 0.0 && w.max_element() <= 1.0, "roughness {roughness}, cos {cos}: {w}");
            }
        }
    }

    /// Coat Tint colours what crosses the coat: under a smooth coat the
    /// layers below keep (1 − c·F(μo)) · mix(1, tint^(1/cosθt), c), θt the
    /// refraction angle of wo into IOR 1.5 (Cycles' path length through a
    /// coat of unit thickness); the coat's own reflection stays white.
    #[test]
    fn a_tint_colours_what_crosses_the_coat() {
        let tint = Vec3::new(0.5, 1.0, 0.25);
        let m = Surface { coat_tint: tint, ..coated(Vec3::ONE, 0.0, 0.5, 0.8, 0.0) };
        for theta in [0.0f32, 60.0, 85.0] {
            let wo = dir_at(theta);
            let bsdf = Coated::new(&m, wo);
            let cos_t = (1.0 - (1.0 - wo.z * wo.z) / 2.25f32).sqrt();
            let expected = (1.0 - 0.8 * fresnel_dielectric(wo.z, COAT_ETA)) * Vec3::ONE.lerp(tint.powf(1.0 / cos_t), 0.8);
            assert!((bsdf.base_weight - expected).abs().max_element() < 1e-5, "θo {theta}: {} vs {expected}", bsdf.base_weight);
            let mirror = bsdf.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
            assert!(mirror.delta && mirror.f.x == mirror.f.y && mirror.f.y == mirror.f.z, "{mirror:?}");
        }
    }

    /// With a normal map below it, the coat keeps the normal from before
    /// the map (`Surface::coat_normal`, local to the BSDF's frame): its
    /// mirror reflects about that normal, its rough lobe is sampled as its
    /// pdf says, and its highlight follows it, not the shading normal.
    #[test]
    fn a_coat_keeps_its_own_normal_under_a_normal_map() {
        let tilted = Vec3::new(0.3, -0.2, 1.0).normalize();
        let m = Surface { coat_normal: tilted, ..coated(Vec3::new(0.6, 0.3, 0.2), 0.0, 0.6, 1.0, 0.0) };
        let wo = dir_at(30.0);
        let mirror = Coated::new(&m, wo).sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
        let expected = 2.0 * wo.dot(tilted) * tilted - wo;
        assert!(mirror.delta && (mirror.wi - expected).length() < 1e-5, "{:?} vs {expected}", mirror.wi);
        for (coat_roughness, theta) in [(0.3f32, 10.0f32), (0.3, 60.0), (0.6, 45.0)] {
            let wo = dir_at(theta);
            let bsdf = Coated::new(&Surface { coat_roughness, ..m }, wo);
            let r = bsdf_chi2(&bsdf, wo, 1_000_000, 8);
            assert!(r.p_value > 1e-4, "coat roughness {coat_roughness} θo {theta}: p = {}", r.p_value);
        }
        // The rough coat's highlight: strongest about the tilted normal.
        let bsdf = Coated::new(&Surface { coat_roughness: 0.2, ..m }, wo);
        let coat_only = |wi: Vec3| bsdf.coat_eval_pdf(wo, wi).0.x;
        let untilted = Vec3::new(-wo.x, -wo.y, wo.z);
        assert!(coat_only(expected) > 10.0 * coat_only(untilted), "{} vs {}", coat_only(expected), coat_only(untilted));
        // Weighed by the cosine about its own normal, as Cycles weighs a
        // closure: f · cos about the shading normal, which the integrator
        // takes, is the upright coat's f · cos about the tilted one, for
        // the same directions turned into the coat's frame.
        let upright = Coated::new(&Surface { coat_roughness: 0.2, coat_normal: Vec3::ZERO, ..m }, Frame::from_normal(tilted).to_local(wo));
        for wi in [expected, Vec3::new(0.1, 0.4, 0.9).normalize(), Vec3::new(-0.5, 0.2, 0.6).normalize()] {
            let (wo_c, wi_c) = (Frame::from_normal(tilted).to_local(wo), Frame::from_normal(tilted).to_local(wi));
            let (here, there) = (coat_only(wi) * wi.z, upright.coat_eval_pdf(wo_c, wi_c).0.x * wi_c.z);
            assert!((here - there).abs() <= 1e-4 * there, "{wi}: {here} against {there}");
        }
    }

    /// Roughness to 0, grazing and back-facing directions: finite,
    /// non-negative values, and sampled pdfs that `pdf` agrees with.
    #[test]
    fn coats_are_finite_at_every_roughness_and_angle() {
        let at_cos = |c: f32, phi: f32| Vec3::new((1.0 - c * c).sqrt() * phi.cos(), (1.0 - c * c).sqrt() * phi.sin(), c);
        let cosines = [1.0f32, 0.3, 1e-3, 1e-7, 0.0, -1e-7, -0.5];
        let mut rng = Rng::new(12, 14);
        for coat_roughness in [0.0f32, 1e-4, 1e-3, 0.03, 0.5, 1.0] {
            for metallic in [0.0f32, 1.0] {
                let m = coated(Vec3::new(1.0, 0.5, 0.0), metallic, 0.2, 1.0, coat_roughness);
                for &co in &cosines {
                    let wo = at_cos(co, 0.3);
                    let bsdf = Coated::new(&m, wo);
                    for &ci in &cosines {
                        let (f, pdf) = bsdf.evaluate(wo, at_cos(ci, 2.0));
                        assert!(f.is_finite() && f.min_element() >= 0.0 && pdf.is_finite() && pdf >= 0.0, "coat {coat_roughness} cos {co}/{ci}: {f} {pdf}");
                    }
                    for _ in 0..2000 {
                        if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
                            assert!(co > 0.0 && s.weight.is_finite() && s.weight.min_element() >= 0.0, "coat {coat_roughness} cos {co}: {s:?}");
                            if !s.delta {
                                assert!((s.pdf - bsdf.pdf(wo, s.wi)).abs() <= 1e-4 * s.pdf);
                            }
                        }
                    }
                }
            }
        }
    }
}
