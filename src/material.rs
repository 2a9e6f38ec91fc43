//! A material as plain data: glTF pbrMetallicRoughness factors and emission.

use crate::texture::TextureSlot;
use crate::sampling::concentric_disk;
use glam::Vec2;
use crate::Vec3;

/// What a BSDF needs of a material at one point: its factors, with any
/// textures and vertex colours already applied (shading.rs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Linear Rec.709 reflectance, each channel in [0, 1].
    pub base_color: Vec3,
    pub metallic: f32,
    /// Perceptual roughness; the microfacet α is roughness².
    pub roughness: f32,
    /// KHR_materials_specular specularFactor.
    pub specular: f32,
    pub multiscatter: bool,
    /// KHR_materials_transmission's factor: the share of the non-metal
    /// that is glass rather than a specular layer over a diffuse base.
    pub transmission: f32,
    /// The transmission is Blender's Translucent BSDF, Lambert through the
    /// surface, rather than glass (bsdf/translucent.rs).
    pub translucent: bool,
    /// The relative IOR the ray meets here: the material's IOR entering a
    /// front face, its inverse leaving through a back face (SurfaceHit).
    pub ior: f32,
    /// KHR_materials_clearcoat (Blender's Coat Weight and Roughness): a
    /// dielectric layer over everything else (bsdf/coat.rs); weight 0
    /// without it.
    pub coat: f32,
    pub coat_roughness: f32,
    /// Blender's Coat Tint (white: none).
    pub coat_tint: Vec3,
    /// Blender's Specular Tint (glTF's specularColorFactor): the metal's
    /// F82 tint, the dielectric layer's and the glass's F0 tint.
    pub specular_tint: Vec3,
    /// The coat's own normal where it differs from the shading normal:
    /// the interpolated normal before the base's normal map (Cycles' Coat
    /// Normal unlinked), or that normal bent by the coat's own map. World space from `shading::surface_at`,
    /// local to the BSDF's frame by `integrator::bsdf_on`; zero: the
    /// shading normal.
    pub coat_normal: Vec3,
    /// Blender's Anisotropic (0: isotropic) and Anisotropic Rotation, in
    /// turns about the normal (`Material::anisotropy`).
    pub anisotropy: f32,
    pub anisotropy_rotation: f32,
    /// Blender's Diffuse Roughness (0: Lambert), bsdf/oren_nayar.rs.
    pub diffuse_roughness: f32,
    /// The direction the glossy lobes are roughest along (α_x), for an
    /// anisotropic surface: Cycles' default Tangent, not yet square to the
    /// normal nor rotated, world space from `shading::surface_at`; unit,
    /// rotated, in the plane of the BSDF's frame by `integrator::bsdf_on`.
    /// Zero: none.
    pub tangent: Vec3,
}

impl Surface {
    /// No glossy layer at all: not metallic, not transmissive and
    /// KHR_materials_specular 0.
    pub fn is_pure_lambert(&self) -> bool {
        self.metallic <= 0.0 && self.specular <= 0.0 && self.transmission <= 0.0
    }

    /// Normal-incidence reflectance of the dielectric boundary: the IOR's,
    /// scaled by KHR_materials_specular as Cycles scales it by Specular IOR
    /// Level (F0 × 2·level, and glTF's factor is 2·level).
    pub fn dielectric_f0(&self) -> f32 {
        let r = (self.ior - 1.0) / (self.ior + 1.0);
        (r * r * self.specular).clamp(0.0, 1.0)
    }
}

/// The roughness below which a glossy lobe focuses light enough for light
/// subpaths to pay for themselves. On the benchmark's gold sphere under one
/// area light (256², 1–16 spp, 4 seeds, error × time against Glint's
/// 512-spp image), light subpaths halved error × time at gold roughness
/// 0.3, lowered it 5–50% at 0.5 and raised it 20–30% at 0.7; for a
/// yellow plastic (specular layer) sphere they lowered it 40–55% at 4–16
/// spp at roughness 0.1 and were even at 0.3.
pub const FOCUSING_ROUGHNESS: f32 = 0.6;

/// Whether a lobe of this roughness is a delta, as the BSDFs decide it:
/// α² ≤ `SMOOTH_ALPHA_SQ`, α = roughness².
pub(crate) fn is_smooth(roughness: f32) -> bool {
    (roughness * roughness).powi(2) <= crate::bsdf::SMOOTH_ALPHA_SQ
}

/// The tangent an anisotropic material is stretched along, as Cycles'
/// Tangent node gives it (its default, for an unlinked Tangent input:
/// radial about Z).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TangentSource {
    /// Circles about one of the object's axes (Blender's X, Y or Z), from
    /// its generated coordinates.
    Radial(Axis),
    /// The MikkTSpace tangent of a texture coordinate set (TEXCOORD_n).
    UvMap(u32),
}

impl Default for TangentSource {
    fn default() -> Self {
        TangentSource::Radial(Axis::Z)
    }
}

/// An axis of a Blender object (Z up).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
pub enum Axis {
    X,
    Y,
    Z,
}

/// Kinds of rays after the camera's that an object can be hidden from
/// (Blender's Object › Visibility › Ray Visibility; Camera is
/// `Material::hidden_from_camera`), as Cycles types a ray: a shadow ray
/// of light sampling, or the ray a BSDF sample sends on, by the lobe it
/// came from — diffuse, glossy (a specular, metal or coat reflection, and
/// glass's) or transmission (through glass). Several at once as a set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Rays(u8);

impl Rays {
    pub const NONE: Rays = Rays(0);
    pub const SHADOW: Rays = Rays(1);
    pub const DIFFUSE: Rays = Rays(2);
    pub const GLOSSY: Rays = Rays(4);
    pub const TRANSMISSION: Rays = Rays(8);
    /// The rays a BSDF sample sends on.
    pub const SCATTERED: Rays = Rays(2 | 4 | 8);
    const NAMES: [(Rays, &'static str); 4] = [(Rays::SHADOW, "shadow"), (Rays::DIFFUSE, "diffuse"), (Rays::GLOSSY, "glossy"), (Rays::TRANSMISSION, "transmission")];

    /// The kind a render request names: shadow, diffuse, glossy or
    /// transmission.
    pub fn named(name: &str) -> Option<Rays> {
        Rays::NAMES.iter().find(|(_, n)| *n == name).map(|&(r, _)| r)
    }

    /// The names of the kinds in the set, in `NAMES`' order.
    pub fn names(self) -> Vec<&'static str> {
        Rays::NAMES.iter().filter(|(r, _)| self.meets(*r)).map(|&(_, n)| n).collect()
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Whether the two sets share a kind.
    #[inline]
    pub fn meets(self, other: Rays) -> bool {
        self.0 & other.0 != 0
    }

    pub fn union(self, other: Rays) -> Rays {
        Rays(self.0 | other.0)
    }

    pub fn without(self, other: Rays) -> Rays {
        Rays(self.0 & !other.0)
    }
}

/// The other half of a Mix Shader (`Material::mix`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mix {
    /// The other material's index, which no triangle names.
    pub with: u32,
    /// Its share of the mix, in (0, 1).
    pub weight: f32,
}

/// glTF's alphaMode. Cycles renders alpha as stochastic transparency, and
/// so does Glint: camera, bounce and shadow rays alike.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    #[default]
    Opaque,
    /// Opaque where alpha ≥ cutoff, else not there.
    Mask(f32),
    /// There with probability alpha.
    Blend,
}

/// The textures a material samples (glTF texture references resolved).
/// Occlusion textures are not read: a path tracer computes occlusion.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialTextures {
    /// sRGB colour × baseColorFactor; its alpha × the factor's alpha.
    pub base_color: Option<TextureSlot>,
    /// B = metallic, G = roughness, × their factors.
    pub metallic_roughness: Option<TextureSlot>,
    /// sRGB colour × emissiveFactor × strength.
    pub emissive: Option<TextureSlot>,
    /// R × transmissionFactor (KHR_materials_transmission).
    pub transmission: Option<TextureSlot>,
    /// R × clearcoatFactor and G × clearcoatRoughnessFactor
    /// (KHR_materials_clearcoat; Blender's exporter writes one image for
    /// both where Coat Weight and Roughness come from its channels).
    pub coat: Option<TextureSlot>,
    pub coat_roughness: Option<TextureSlot>,
    /// The coat's own tangent-space normal map and its scale
    /// (clearcoatNormalTexture: Blender's Coat Normal from a Normal Map
    /// node), in the same tangent frame as `normal`.
    pub coat_normal: Option<(TextureSlot, f32)>,
    /// Tangent-space normal map and its scale (normalTexture.scale).
    pub normal: Option<(TextureSlot, f32)>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear Rec.709 reflectance, each channel in [0, 1].
    pub base_color: Vec3,
    pub metallic: f32,
    /// Perceptual roughness; the microfacet α is roughness².
    pub roughness: f32,
    /// KHR_materials_specular specularFactor: scales the dielectric specular
    /// layer (0 makes a non-metal purely Lambertian). 1 without the extension.
    pub specular: f32,
    /// Emitted radiance in W·sr⁻¹·m⁻²: emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    /// Emitters emit from both faces only when double-sided.
    pub double_sided: bool,
    /// A lamp (a Blender area light), not a surface: it emits from its front
    /// face and is otherwise not there — rays pass through it and it casts
    /// no shadow, as lights do in Cycles.
    pub lamp: bool,
    /// Camera rays see the lamp too (Blender hides lights from the camera
    /// by default; BSDF rays always see them).
    pub camera_sees_lamp: bool,
    /// A lamp's Spread below 180°: its light leaves within a cone about its
    /// normal (None: every way, as a Lambertian emitter).
    pub spread: Option<Spread>,
    /// Cycles' "Multiscatter GGX" (its default): the glossy lobes get back
    /// the energy single scattering loses. Off: plain "GGX".
    pub multiscatter: bool,
    /// KHR_materials_transmission transmissionFactor (0 without it).
    pub transmission: f32,
    /// Its transmission is a Translucent BSDF node's (a render request's):
    /// Lambert through the surface, not glass.
    pub translucent: bool,
    /// KHR_materials_ior (1.5 without it, Blender's default too).
    pub ior: f32,
    /// σ_a, per metre of world space, of the medium inside the mesh, which
    /// a ray refracted into it through a front face travels in (media.rs):
    /// KHR_materials_volume's −ln(attenuationColor) / attenuationDistance,
    /// or a render request's Blender Volume Absorption, (1 − Color) ×
    /// Density. Zero: clear.
    pub absorption: Vec3,
    /// KHR_materials_clearcoat's clearcoatFactor and
    /// clearcoatRoughnessFactor (0 and 0 without it).
    pub coat: f32,
    pub coat_roughness: f32,
    /// Blender's Coat Tint, from a render request (white without).
    pub coat_tint: Vec3,
    /// KHR_materials_specular specularColorFactor, Blender's Specular Tint
    /// (white without): the metal's F82 tint and the dielectric layer's and
    /// the glass's F0 tint.
    pub specular_tint: Vec3,
    /// KHR_materials_anisotropy's anisotropyStrength and anisotropyRotation
    /// (in turns), read as Blender's importer reads them: Blender's
    /// Anisotropic and Anisotropic Rotation, which its exporter writes
    /// there (the rotation × 2π). Rendered as Cycles' Principled BSDF does
    /// (bsdf/principled.rs), along Cycles' default tangent
    /// (`VertexAttributes::anisotropy_tangent`). 0 and 0 without it.
    pub anisotropy: f32,
    pub anisotropy_rotation: f32,
    /// Blender's Diffuse Roughness on the Principled BSDF, or a Diffuse
    /// BSDF node's Roughness, from a render request (glTF has neither):
    /// above 0 the base is Cycles' Oren–Nayar lobe (bsdf/oren_nayar.rs).
    /// 0 without.
    pub diffuse_roughness: f32,
    /// Where its anisotropy's tangent comes from (a render request's
    /// `anisotropy_tangents`; Cycles' default without).
    pub anisotropy_tangent: TangentSource,
    /// A Mix Shader of this material's BSDF and another's (Blender's Mix
    /// Shader, constant Fac): each hit is shaded by one of the two, drawn
    /// with these shares, which leaves every estimate's expectation that
    /// of the mix (`SurfaceHit::with_normal`). Emission, alpha and what
    /// rays pass are this material's, whichever is drawn.
    pub mix: Option<Mix>,
    /// A lamp with Blender's Cast Shadow off: its light samples trace no
    /// shadow ray (every other ray meets what lies before it, as in
    /// Cycles).
    pub shadowless: bool,
    /// On an object hidden from the camera (Blender's Object › Visibility ›
    /// Ray Visibility › Camera off, from a render request): camera rays
    /// pass it and light tracing does not splat it; every other ray sees
    /// it. The loader gives such an object's triangles a copy of their
    /// material with this set.
    pub hidden_from_camera: bool,
    /// The rays after the camera's that pass it (`Rays`), on an object
    /// hidden from them; the loader makes that copy of the material too.
    pub hidden_from_rays: Rays,
    /// Textures, when the material has any.
    pub textures: Option<Box<MaterialTextures>>,
    /// baseColorFactor's alpha.
    pub alpha: f32,
    pub alpha_mode: AlphaMode,
}

impl Default for Material {
    /// glTF 2.0's default material (spec §3.9.6): white, metallic 1, roughness 1.
    fn default() -> Self {
        Material {
            name: "glTF default".into(),
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            specular: 1.0,
            emission: Vec3::ZERO,
            double_sided: false,
            lamp: false,
            camera_sees_lamp: false,
            spread: None,
            multiscatter: true,
            transmission: 0.0,
            translucent: false,
            ior: 1.5,
            absorption: Vec3::ZERO,
            coat: 0.0,
            coat_roughness: 0.0,
            coat_tint: Vec3::ONE,
            specular_tint: Vec3::ONE,
            anisotropy: 0.0,
            anisotropy_rotation: 0.0,
            diffuse_roughness: 0.0,
            anisotropy_tangent: TangentSource::default(),
            mix: None,
            shadowless: false,
            hidden_from_camera: false,
            hidden_from_rays: Rays::NONE,
            textures: None,
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
        }
    }
}

impl Material {
    /// No glossy layer anywhere on it: not metallic, not transmissive and
    /// KHR_materials_specular 0 (a metallic texture only scales the factor).
    pub fn is_pure_lambert(&self) -> bool {
        self.surface().is_pure_lambert()
    }

    /// The factors alone, as at a point with no textures or vertex colours.
    #[inline]
    pub fn surface(&self) -> Surface {
        Surface {
            base_color: self.base_color,
            metallic: self.metallic,
            roughness: self.roughness,
            specular: self.specular,
            multiscatter: self.multiscatter,
            transmission: self.transmission,
            translucent: self.translucent,
            ior: self.ior,
            coat: self.coat,
            coat_roughness: self.coat_roughness,
            coat_tint: self.coat_tint,
            coat_normal: Vec3::ZERO,
            specular_tint: self.specular_tint,
            anisotropy: self.anisotropy,
            anisotropy_rotation: self.anisotropy_rotation,
            diffuse_roughness: self.diffuse_roughness,
            tangent: Vec3::ZERO,
        }
    }

    /// Whether some of its surface reflects light in a lobe sharp enough
    /// to focus it into caustics, which light subpaths find and camera
    /// paths rarely do (light_paths.rs): a GGX lobe (metal or specular
    /// layer) whose roughness, its texture's smallest texel counted, is
    /// below `FOCUSING_ROUGHNESS`; or smooth glass, absorbing or not,
    /// through which light subpaths go on from their emitter
    /// (light_paths.rs, `DeltaStart`; rough glass ends them).
    /// `smallest_roughness_texel` gives an image's smallest G (roughness)
    /// texel; it is asked only when the factors leave the answer open, so
    /// that a caller can scan each image once (`Image::smallest`).
    pub fn focuses_light(&self, smallest_roughness_texel: impl FnOnce(u32) -> f32) -> bool {
        let textures = self.textures.as_deref();
        if !self.lamp && self.is_transmissive() && !self.translucent && is_smooth(self.roughness) {
            return true;
        }
        let somewhere_opaque = self.transmission <= 0.0 || textures.is_some_and(|t| t.transmission.is_some());
        if self.lamp || !(self.metallic > 0.0 || self.specular > 0.0) || !somewhere_opaque {
            return false;
        }
        let smallest_roughness = match textures.and_then(|t| t.metallic_roughness.as_ref()) {
            Some(slot) if self.roughness >= FOCUSING_ROUGHNESS => self.roughness * smallest_roughness_texel(slot.image),
            _ => self.roughness,
        };
        smallest_roughness < FOCUSING_ROUGHNESS
    }

    /// Whether some lobe of it may be smooth enough to be a delta (α² ≤
    /// `SMOOTH_ALPHA_SQ`, α = roughness²): its roughness or its coat's, or
    /// a roughness texture's texel of 0.
    pub fn may_be_smooth(&self) -> bool {
        let textures = self.textures.as_deref();
        is_smooth(self.roughness) || textures.is_some_and(|t| t.metallic_roughness.is_some()) || (self.is_coated() && (is_smooth(self.coat_roughness) || textures.is_some_and(|t| t.coat_roughness.is_some())))
    }

    /// Glass or metal whose lobe is a delta one (`is_smooth`), not a
    /// lamp: a surface that focuses an emitter's light into a caustic
    /// only light subpaths through delta lobes carry (caustic_guide.rs).
    pub fn throws_caustics(&self) -> bool {
        let glass = self.is_transmissive() && !self.translucent;
        !self.lamp && is_smooth(self.roughness) && (glass || self.metallic >= 0.5)
    }

    /// Whether a clear coat lies over it.
    pub fn is_coated(&self) -> bool {
        self.coat > 0.0
    }

    /// Whether some of it is glass.
    pub fn is_transmissive(&self) -> bool {
        self.transmission > 0.0 && self.metallic < 1.0
    }

    /// Whether some of its surface can be missing (alpha).
    pub fn has_alpha(&self) -> bool {
        self.alpha_mode != AlphaMode::Opaque
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Radiance leaving the front face (or either face when double-sided).
    #[inline]
    pub fn emitted(&self, front_face: bool) -> Vec3 {
        if front_face || self.double_sided {
            self.emission
        } else {
            Vec3::ZERO
        }
    }

    /// What the radiance `emitted` gives is multiplied by where it leaves
    /// at cosine `cos_out` to the front normal: 1 but for a lamp's Spread.
    #[inline]
    pub fn spread_factor(&self, cos_out: f32) -> f32 {
        self.spread.map_or(1.0, |s| s.factor(cos_out))
    }

    /// The density of a light subpath's first direction at cosine
    /// `cos_out` to the emitting face over a Lambertian emitter's cos θ/π
    /// (`Spread::direction_weight`; 1 without a Spread).
    #[inline]
    pub fn emission_direction_weight(&self, cos_out: f32) -> f32 {
        self.spread.map_or(1.0, |s| s.direction_weight(cos_out))
    }
}

/// Blender's area light Spread below 180°, as Cycles renders it: a
/// softbox grid, whose slats let through the light that leaves at angle θ
/// to the normal in proportion to tan h − tan θ (h half the spread, none
/// past it), scaled by 1/(tan h − h) so that the lamp's power stays that of
/// a Lambertian emitter: ∫ (tan h − tan θ) cos θ dω over the cone is
/// π (tan h − h), the Lambertian's ∫ cos θ dω = π times it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    tan_half: f32,
    normalize: f32,
    /// sin h, and 1/sin² h: the cone that light subpaths leave in.
    sin_half: f32,
    inv_sin2_half: f32,
}

/// Spreads below this (radians, 1°, the least Blender's Spread takes) are
/// rendered as this: the factor's peak, tan h/(tan h − h) ≈ 3/h², would
/// grow without bound, and a request can ask for 0.
pub const MIN_SPREAD: f32 = 0.017_453_292;

impl Spread {
    /// The spread of `angle` radians (the full opening, Blender's
    /// `spread`), at least `MIN_SPREAD`; None from 180° on, where the lamp
    /// is Lambertian, and for an angle that is not a number.
    pub fn new(angle: f32) -> Option<Self> {
        if !(angle < std::f32::consts::PI - 1e-4) {
            return None;
        }
        let half = 0.5 * angle.max(MIN_SPREAD) as f64;
        // tan h − h loses its digits to cancellation for small h: its series.
        let excess = if half > 0.05 { half.tan() - half } else { half.powi(3) / 3.0 + 2.0 * half.powi(5) / 15.0 };
        Some(Spread { tan_half: half.tan() as f32, normalize: (1.0 / excess) as f32, sin_half: half.sin() as f32, inv_sin2_half: (1.0 / (half.sin() * half.sin())) as f32 })
    }

    /// tan h, h half the spread.
    pub fn tan_half(&self) -> f32 {
        self.tan_half
    }

    /// cos h.
    pub fn cos_half(&self) -> f32 {
        1.0 / (1.0 + self.tan_half * self.tan_half).sqrt()
    }

    /// A direction for light leaving the lamp (local to its face, z the
    /// normal), from `u` in [0, 1)²: cosine-weighted within the cone, the
    /// density cos θ/(π sin² h), where a light subpath started Lambertian
    /// would leave the cone (and carry nothing) 1 − sin² h of the time:
    /// 93% at 30°.
    pub fn emission_direction(&self, u: Vec2) -> Vec3 {
        let d = concentric_disk(u) * self.sin_half;
        Vec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
    }

    /// The density of `emission_direction` at cosine `cos_out` over a
    /// Lambertian emitter's, cos θ/π: 1/sin² h within the cone, 0 past it.
    #[inline]
    pub fn direction_weight(&self, cos_out: f32) -> f32 {
        if cos_out > 0.0 && (1.0 - cos_out * cos_out) * self.inv_sin2_half <= 1.0 {
            self.inv_sin2_half
        } else {
            0.0
        }
    }

    /// The factor on the radiance leaving at cosine `cos_out` to the normal.
    #[inline]
    pub fn factor(&self, cos_out: f32) -> f32 {
        if !(cos_out > 0.0) {
            return 0.0;
        }
        let tan = (1.0 - cos_out * cos_out).max(0.0).sqrt() / cos_out;
        ((self.tan_half - tan) * self.normalize).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::{Image, Sampler, Texels};

    fn material(metallic: f32, roughness: f32, specular: f32) -> Material {
        Material { metallic, roughness, specular, ..Material::default() }
    }

    /// A 2 × 1 metallic-roughness image whose G channels are `g`.
    fn roughness_image(g: [u8; 2]) -> Vec<Image> {
        vec![Image { name: "mr".into(), width: 2, height: 1, texels: Texels::Rgba8(g.map(|g| [0, g, 255, 255]).to_vec()) }]
    }

    /// What `Features::of` passes: an image's smallest G texel, 1 for an
    /// image that is not there.
    fn smallest_in(images: &[Image]) -> impl FnOnce(u32) -> f32 + '_ {
        |image| images.get(image as usize).map_or(1.0, |image| image.smallest(1))
    }

    fn with_roughness_texture(mut m: Material) -> Material {
        let slot = TextureSlot { image: 0, sampler: Sampler::default(), texcoord: 0, transform: None };
        m.textures = Some(Box::new(MaterialTextures { metallic_roughness: Some(slot), ..Default::default() }));
        m
    }

    #[test]
    fn a_glossy_lobe_focuses_light_and_a_rough_or_lambertian_one_does_not() {
        assert!(material(1.0, 0.3, 1.0).focuses_light(smallest_in(&[])), "gold of roughness 0.3");
        assert!(material(0.0, 0.1, 1.0).focuses_light(smallest_in(&[])), "a glossy specular layer");
        assert!(!material(1.0, 0.7, 1.0).focuses_light(smallest_in(&[])), "rough metal");
        assert!(!material(0.0, 0.0, 0.0).focuses_light(smallest_in(&[])), "Lambert (specular 0), however smooth");
        assert!(Material { transmission: 1.0, ..material(0.0, 0.0, 1.0) }.focuses_light(smallest_in(&[])), "smooth glass: light subpaths go through");
        assert!(!Material { transmission: 1.0, ..material(0.0, 0.2, 1.0) }.focuses_light(smallest_in(&[])), "rough glass: light subpaths stop there");
        assert!(Material { transmission: 1.0, absorption: Vec3::ONE, ..material(0.0, 0.0, 1.0) }.focuses_light(smallest_in(&[])), "absorbing glass: light subpaths go through, absorbed");
        assert!(!Material { lamp: true, ..material(1.0, 0.0, 1.0) }.focuses_light(smallest_in(&[])), "a lamp is not a surface");
    }

    /// Which materials may sample a delta lobe (features' `smooth`): the
    /// rule is the lobes' own, α² ≤ SMOOTH_ALPHA_SQ with α = roughness².
    #[test]
    fn a_surface_may_be_smooth_by_its_roughness_its_coat_or_a_texture() {
        assert!(material(1.0, 0.0, 1.0).may_be_smooth(), "a mirror");
        assert!(material(0.0, 0.003, 1.0).may_be_smooth(), "roughness 0.003: α² = 8e-11");
        assert!(!material(0.0, 0.005, 1.0).may_be_smooth(), "roughness 0.005: α² = 6e-10");
        assert!(!material(0.0, 0.5, 1.0).may_be_smooth());
        assert!(Material { coat: 1.0, coat_roughness: 0.0, ..material(0.0, 0.5, 1.0) }.may_be_smooth(), "a smooth coat");
        assert!(!Material { coat: 0.0, coat_roughness: 0.0, ..material(0.0, 0.5, 1.0) }.may_be_smooth(), "no coat");
        assert!(with_roughness_texture(material(1.0, 1.0, 1.0)).may_be_smooth(), "a texel may be 0");
    }

    #[test]
    fn a_roughness_texture_counts_by_its_smoothest_texel() {
        let rough = with_roughness_texture(material(1.0, 1.0, 1.0));
        assert!(rough.focuses_light(smallest_in(&roughness_image([64, 255]))), "a texel of roughness 0.25");
        assert!(!rough.focuses_light(smallest_in(&roughness_image([200, 255]))), "no texel below 0.6");
        // The factor scales the texels: 0.5 × 200/255 = 0.39.
        assert!(with_roughness_texture(material(1.0, 0.5, 1.0)).focuses_light(smallest_in(&roughness_image([200, 255]))));
        // A texture that is not there (a broken index) reads as 1.
        assert!(!rough.focuses_light(smallest_in(&[])));
    }

    /// A Spread keeps the lamp's power: Σ factor·cos over the hemisphere
    /// is π, the Lambertian's, from 1° to 179° (midpoint rule in θ, 200,000
    /// steps, within 0.1%); no light leaves past half the spread, and the
    /// most along the normal. 180° and more are Lambertian (no Spread).
    #[test]
    fn a_spread_narrows_the_light_and_keeps_its_power() {
        use std::f64::consts::PI;
        for degrees in [1.0f32, 5.0, 30.0, 60.0, 90.0, 150.0, 179.0] {
            let spread = Spread::new(degrees.to_radians()).expect("below 180°");
            let n = 200_000;
            let dtheta = 0.5 * PI / n as f64;
            let power: f64 = (0..n)
                .map(|i| {
                    let theta = (i as f64 + 0.5) * dtheta;
                    spread.factor(theta.cos() as f32) as f64 * theta.cos() * theta.sin() * 2.0 * PI * dtheta
                })
                .sum();
            assert!((power / PI - 1.0).abs() < 1e-3, "{degrees}°: {power} against π");
            let half = 0.5 * degrees.to_radians();
            assert_eq!(spread.factor((half * 1.001).min(std::f32::consts::FRAC_PI_2 - 1e-4).cos()), 0.0, "{degrees}°: past the cone");
            assert!(spread.factor(1.0) > spread.factor((0.5 * half).cos()), "{degrees}°");
            assert_eq!(spread.factor(0.0), 0.0);
            assert_eq!(spread.factor(-0.5), 0.0, "behind the lamp");
            assert_eq!(spread.factor(f32::NAN), 0.0);
        }
        assert_eq!(Spread::new(std::f32::consts::PI), None);
        assert_eq!(Spread::new(f32::NAN), None);
        assert_eq!(Spread::new(0.0), Spread::new(MIN_SPREAD), "below 1°: 1°");
        assert_eq!(Material::default().spread_factor(-1.0), 1.0, "no Spread: the factor is 1");
    }
}
