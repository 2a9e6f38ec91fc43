//! A material as plain data: glTF pbrMetallicRoughness factors and emission.

use crate::texture::TextureSlot;
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
    /// The relative IOR the ray meets here: the material's IOR entering a
    /// front face, its inverse leaving through a back face (SurfaceHit).
    pub ior: f32,
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
    /// Cycles' "Multiscatter GGX" (its default): the glossy lobes get back
    /// the energy single scattering loses. Off: plain "GGX".
    pub multiscatter: bool,
    /// KHR_materials_transmission transmissionFactor (0 without it).
    pub transmission: f32,
    /// KHR_materials_ior (1.5 without it, Blender's default too).
    pub ior: f32,
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
            multiscatter: true,
            transmission: 0.0,
            ior: 1.5,
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
            ior: self.ior,
        }
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
}
