//! A render request: the small JSON file the Blender addon writes beside the
//! scene (and `glint render --request` reads) with what glTF cannot say —
//! image size, samples or a time budget, the camera and its lens shift and
//! depth of field, the World colour and Blender's area lights. Every field is optional; unknown fields are an
//! error, so a misspelt one is not silently ignored.
//!
//! ```json
//! { "job": "render-3", "width": 640, "height": 360, "samples": 128,
//!   "time_limit": 0, "noise_threshold": 0.01, "adaptive_min_samples": 0,
//!   "max_depth": 13, "camera": "Camera", "seed": 0,
//!   "light_paths": true,
//!   "output": "render.exr", "background": [0.05, 0.05, 0.05],
//!   "area_lights": [ { "name": "Area", "shape": "RECTANGLE",
//!     "size": [1, 0.5], "matrix": [16 numbers], "color": [1, 1, 1],
//!     "power": 100, "portal": false, "spread": 1.0472 } ],
//!   "coat_tints": [ { "material": "Car paint", "tint": [0.6, 0.1, 0.1] } ],
//!   "diffuse_roughness": [ { "material": "Plaster", "roughness": 0.8 } ],
//!   "volume_absorption": [ { "material": "Wine", "color": [0.8, 0.1, 0.2], "density": 12 } ],
//!   "bsdf_nodes": [ { "material": "Clay", "node": "diffuse", "color": [0.6, 0.4, 0.3] },
//!     { "material": "Window", "node": "glass", "color": [1, 1, 1], "roughness": 0, "ior": 1.45 } ],
//!   "shader_mixes": [ { "weight": 0.3, "mixed": { "material": "Lacquer", "node": "glossy", "color": [1, 1, 1], "roughness": 0.1 } } ],
//!   "hidden_from_camera": [ "Bounce card" ],
//!   "hidden_from_rays": [ { "object": "Fill", "rays": ["shadow", "glossy"] } ],
//!   "anisotropy_tangents": [ { "material": "Brushed", "uv_map": 0 },
//!     { "material": "Dial", "radial_axis": "X" } ],
//!   "light_sizes": [ { "name": "Point", "radius": 0.1, "soft_falloff": true },
//!     { "name": "Sun", "angle": 0.00918 } ],
//!   "lens": { "shift": [0.1, 0], "aperture": { "radius": 0.0125,
//!     "focus_distance": 4.2, "blades": 6, "rotation": 0, "ratio": 1 } } }
//! ```

use crate::bsdf::BsdfModel;
use crate::lamps::AreaLight;
use serde::Deserialize;
use std::path::Path;

/// One material's Coat Tint: linear Rec.709, each channel in [0, 1] (the
/// colour the coat gives light that crosses it straight down and back).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CoatTint {
    pub material: String,
    pub tint: [f32; 3],
}

/// One material's Diffuse Roughness (Principled BSDF), in [0, 1].
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DiffuseRoughness {
    pub material: String,
    pub roughness: f32,
}

/// One material's Blender Volume Absorption (a Volume Absorption node on
/// its Material Output's Volume): Color linear Rec.709, each channel in
/// [0, 1]; Density per metre, finite and ≥ 0. Inside the material's glass
/// it absorbs (1 − Color) × Density per metre, as Cycles reads the node.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VolumeAbsorption {
    pub material: String,
    pub color: [f32; 3],
    pub density: f32,
}

/// Blender's plain BSDF nodes, which glTF cannot carry.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum BsdfNodeKind {
    Diffuse,
    Glossy,
    Glass,
    /// A Transparent BSDF: rays pass (white only; the add-on names a
    /// coloured one as approximate).
    Transparent,
    /// A Translucent BSDF: Lambert through the surface, in its colour.
    Translucent,
    /// An Emission shader: black, emitting Color × Strength (radiance,
    /// W·sr⁻¹·m⁻², as the Principled BSDF's Emission).
    Emission,
}

/// A material whose surface is one of Blender's plain BSDF nodes (the
/// exporter writes glTF's default material, a white rough metal, for it):
/// its Color, linear Rec.709, each channel in [0, 1]; Roughness in [0, 1]
/// (Glossy and Glass); IOR ≥ 1 (Glass).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BsdfNode {
    pub material: String,
    pub node: BsdfNodeKind,
    pub color: [f32; 3],
    #[serde(default)]
    pub roughness: f32,
    #[serde(default = "BsdfNode::default_ior")]
    pub ior: f32,
    /// Emission: its Strength, finite and ≥ 0.
    #[serde(default)]
    pub strength: f32,
}

impl BsdfNode {
    fn default_ior() -> f32 {
        1.5
    }
}

/// A material whose surface is a Mix Shader of its Principled BSDF (the
/// one glTF carries) and one of Blender's plain BSDF nodes, with a
/// constant Fac: `mixed` is the node, as a `BsdfNode` record of the
/// material, and `weight` its share, in [0, 1] (Fac, or 1 − Fac where
/// the Principled BSDF is the lower input).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ShaderMix {
    pub weight: f32,
    pub mixed: BsdfNode,
    /// The material's whole emission (radiance, each channel finite and
    /// ≥ 0), where the file's is not the Principled BSDF's: Blender's
    /// exporter writes an Emission shader's in a mix instead.
    #[serde(default)]
    pub emission: Option<[f32; 3]>,
}

/// Whether a colour's channels all lie in [0, 1] (none NaN): what a tint,
/// an absorption colour, a BSDF node's colour or the default surface
/// must be.
pub(crate) fn is_unit_rgb(c: &[f32; 3]) -> bool {
    c.iter().all(|v| (0.0..=1.0).contains(v))
}

/// Whether a radiance's channels are all finite and ≥ 0 (none NaN): what
/// a World colour or an emission must be.
pub(crate) fn is_radiance(c: &[f32; 3]) -> bool {
    c.iter().all(|v| v.is_finite() && *v >= 0.0)
}

/// Largest request file read (area lights are ~300 bytes each).
pub const MAX_REQUEST_BYTES: u64 = 16 << 20;

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderRequest {
    /// Echoed in the daemon's status, so a client knows which request a
    /// status is about.
    pub job: Option<String>,
    /// Scene file name in the job folder [default: scene.glb, else scene.gltf].
    pub scene: Option<String>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Samples per pixel; 0 with a time limit: as many as fit.
    pub samples: Option<u32>,
    /// Seconds of rendering (not counting load, BVH build and the lights'
    /// set-up); 0: none.
    pub time_limit: Option<f64>,
    /// Adaptive sampling's Noise Threshold (Blender's Render › Sampling);
    /// 0: off.
    pub noise_threshold: Option<f32>,
    /// Its Min Samples; 0: from the threshold, as Cycles.
    pub adaptive_min_samples: Option<u32>,
    /// Most scattering events on a path (Cycles' max bounces + 1).
    pub max_depth: Option<u32>,
    /// Camera by node or camera name.
    pub camera: Option<String>,
    pub seed: Option<u64>,
    /// Multiple importance sampling on (default) or the seed's rule.
    pub mis: Option<bool>,
    /// "principled" (default) or "seed".
    pub bsdf: Option<BsdfModel>,
    /// Light subpaths (`--light-paths`): true always, false never; absent,
    /// where they pay (`auto`).
    pub light_paths: Option<bool>,
    /// Where the EXR goes, relative to the request's folder.
    pub output: Option<String>,
    /// World radiance in W·sr⁻¹·m⁻² (Blender: Background colour × strength).
    pub background: Option<[f32; 3]>,
    /// Every emissive surface emits from both faces, as Blender's Emission
    /// does in Cycles (glTF's doubleSided is Blender's backface culling).
    pub two_sided_emission: Option<bool>,
    /// Materials, by name, whose Principled BSDF uses plain "GGX" rather
    /// than Cycles' default "Multiscatter GGX".
    pub single_scatter_materials: Vec<String>,
    /// Blender's Coat Tint of coated materials, by name, where it is not
    /// white (glTF's clearcoat has no tint).
    pub coat_tints: Vec<CoatTint>,
    /// Blender's Diffuse Roughness of Principled BSDFs, by material name,
    /// where it is above 0 (glTF has no rough diffuse).
    pub diffuse_roughness: Vec<DiffuseRoughness>,
    /// Glass materials, by name, with a Volume Absorption inside (replaces
    /// the glTF file's KHR_materials_volume, which Blender's exporter
    /// writes only from a glTF Material Output node).
    pub volume_absorption: Vec<VolumeAbsorption>,
    /// Materials, by name, whose surface is a Diffuse, Glossy, Glass or
    /// Transparent BSDF node.
    pub bsdf_nodes: Vec<BsdfNode>,
    /// Materials, by name, whose surface mixes their Principled BSDF
    /// with such a node.
    pub shader_mixes: Vec<ShaderMix>,
    pub area_lights: Vec<AreaLight>,
    /// Diffuse colour of primitives without a material, instead of glTF's
    /// default (white metal): Cycles renders them with its default surface,
    /// a diffuse BSDF of 0.8 grey.
    pub default_surface: Option<[f32; 3]>,
    /// The World as an environment image (replaces `background`).
    pub environment: Option<EnvironmentRequest>,
    /// What camera rays see where they leave the scene, where that is not
    /// the World that lights it (Blender's Light Path › Is Camera Ray
    /// mixing two World shaders).
    pub camera_world: Option<CameraWorld>,
    /// Sizes of the glTF file's point, spot and sun lights, by name.
    pub light_sizes: Vec<LightSize>,
    /// Nodes (Blender objects) hidden from the camera: camera rays pass
    /// their meshes, which every other ray sees.
    pub hidden_from_camera: Vec<String>,
    /// Nodes (Blender objects) hidden from other rays: shadow, diffuse,
    /// glossy or transmission.
    pub hidden_from_rays: Vec<HiddenFromRays>,
    /// Anisotropic materials, by name, whose Tangent input is a Tangent
    /// node: radial about another axis than Z, or a UV map's.
    pub anisotropy_tangents: Vec<AnisotropyTangent>,
    /// What Blender's camera has and glTF cannot carry.
    pub lens: Option<LensRequest>,
    /// Blender's Film › Transparent: the camera does not see the World and
    /// the EXR's alpha is each pixel's coverage.
    pub transparent_film: Option<bool>,
    /// Film › Transparent Glass, with its Roughness Threshold: on a
    /// transparent film, the World seen through glass no rougher than
    /// this is transparency too.
    pub transparent_glass: Option<f32>,
    /// Blender's Film › Pixel Filter: its type and Width in pixels
    /// (pixel_filter.rs); a one-pixel box without.
    pub pixel_filter: Option<crate::pixel_filter::FilterRequest>,
}

/// Blender's camera beyond glTF: Shift X and Y, and Depth of Field.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LensRequest {
    /// Fractions of the image's width and height by which the view moves
    /// right and up (Blender's shift is in units of the view's larger
    /// side; the add-on converts it).
    #[serde(default)]
    pub shift: [f32; 2],
    /// Depth of field (camera.rs).
    pub aperture: Option<crate::camera::Aperture>,
    /// A panoramic camera's projection (panorama.rs), which replaces the
    /// glTF camera's; its shift is in fractions of the view's unit square.
    pub panorama: Option<crate::panorama::Panorama>,
}

/// An object's Ray Visibility but the camera's (Blender's Object ›
/// Visibility › Ray Visibility): the kinds of rays, by name, that pass it.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HiddenFromRays {
    pub object: String,
    pub rays: Vec<String>,
}

impl HiddenFromRays {
    /// The kinds it names; an error naming the first unknown one.
    pub fn rays(&self) -> Result<crate::material::Rays, String> {
        use crate::material::Rays;
        self.rays.iter().try_fold(Rays::NONE, |set, name| {
            Rays::named(name).map(|r| set.union(r)).ok_or_else(|| format!("hidden_from_rays of '{}': '{name}' is not a kind of ray (shadow, diffuse, glossy, transmission)", self.object))
        })
    }
}

/// A material's Tangent node (Blender's Principled BSDF › Tangent): one of
/// `radial_axis` (Radial, about the object's X, Y or Z) and `uv_map` (UV
/// Map: the texture coordinate set, TEXCOORD_n, whose tangent it takes).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnisotropyTangent {
    pub material: String,
    #[serde(default)]
    pub radial_axis: Option<crate::material::Axis>,
    #[serde(default)]
    pub uv_map: Option<u32>,
}

impl AnisotropyTangent {
    /// The source it names; an error unless it names exactly one.
    pub fn source(&self) -> Result<crate::material::TangentSource, String> {
        use crate::material::TangentSource;
        match (self.radial_axis, self.uv_map) {
            (Some(axis), None) => Ok(TangentSource::Radial(axis)),
            (None, Some(set)) if set <= 1 => Ok(TangentSource::UvMap(set)),
            (None, Some(set)) => Err(format!("anisotropy tangent of '{}': UV map {set} is not read (TEXCOORD_0 and _1 are)", self.material)),
            _ => Err(format!("anisotropy tangent of '{}' must have one of radial_axis and uv_map", self.material)),
        }
    }
}

/// What KHR_lights_punctual cannot say of a Blender light (punctual.rs).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSize {
    /// The glTF light's name (Blender's light data name).
    pub name: String,
    /// Point and spot: radius in metres.
    #[serde(default)]
    pub radius: f32,
    /// Point and spot: Blender's Soft Falloff (its default): a disk facing
    /// what it lights; off: a sphere.
    #[serde(default = "yes")]
    pub soft_falloff: bool,
    /// Sun: its angle (the disk's diameter) in radians.
    #[serde(default)]
    pub angle: f32,
    /// Blender's Object › Visibility › Camera: camera rays see the light
    /// (off by default, as in Blender).
    #[serde(default)]
    pub visible_camera: bool,
    /// Blender's Light › Cast Shadow (on by default).
    #[serde(default = "yes")]
    pub cast_shadow: bool,
}

fn yes() -> bool {
    true
}

/// Blender's Environment Texture: an equirectangular image × the
/// Background's strength, turned by the Mapping node's Z rotation.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentRequest {
    /// HDR, EXR, PNG or JPEG file; a relative path is relative to the
    /// request's folder.
    pub image: std::path::PathBuf,
    #[serde(default = "one")]
    pub strength: f32,
    /// Radians about Blender's Z axis.
    #[serde(default)]
    pub rotation: f32,
}

fn one() -> f32 {
    1.0
}

/// The World camera rays see (`RenderRequest::camera_world`): an
/// environment image, else a colour (W·sr⁻¹·m⁻², black without).
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraWorld {
    pub background: Option<[f32; 3]>,
    pub environment: Option<EnvironmentRequest>,
}

impl RenderRequest {
    /// Read and check a request file; errors are one line without the path.
    pub fn read(path: &Path) -> Result<Self, String> {
        let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
        if meta.len() > MAX_REQUEST_BYTES {
            return Err(format!("request is {} bytes; at most {MAX_REQUEST_BYTES} are read", meta.len()));
        }
        let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
        Self::parse(&bytes)
    }

    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        let r: RenderRequest = serde_json::from_slice(bytes).map_err(|e| format!("not a valid render request: {e}"))?;
        r.check()?;
        Ok(r)
    }

    fn check(&self) -> Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if v.is_some_and(|v| !(1..=32768).contains(&v)) {
                return Err(format!("{name} must be 1 to 32768"));
            }
        }
        if self.max_depth.is_some_and(|d| !(1..=1024).contains(&d)) {
            return Err("max_depth must be 1 to 1024".into());
        }
        if self.time_limit.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
            return Err("time_limit must be a number of seconds ≥ 0".into());
        }
        if self.noise_threshold.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
            return Err("noise_threshold must be a number ≥ 0".into());
        }
        if self.samples == Some(0) && self.time_limit.unwrap_or(0.0) == 0.0 {
            return Err("samples 0 (unlimited) needs a time_limit".into());
        }
        if self.background.is_some_and(|b| !is_radiance(&b)) {
            return Err("background must be three finite numbers ≥ 0".into());
        }
        if self.environment.as_ref().is_some_and(|e| !(e.strength.is_finite() && e.strength >= 0.0 && e.rotation.is_finite())) {
            return Err("environment strength must be ≥ 0 and rotation finite".into());
        }
        if self.default_surface.is_some_and(|b| !is_unit_rgb(&b)) {
            return Err("default_surface must be three numbers in [0, 1]".into());
        }
        for hidden in &self.hidden_from_rays {
            hidden.rays()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_request_parses_and_bad_ones_say_why() {
        let ok = br#"{"job": "j1", "width": 64, "height": 32, "samples": 0, "time_limit": 2.5,
            "background": [0.1, 0.2, 0.3], "area_lights": [{"shape": "DISK", "size": [1, 1],
            "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,2,0,1], "color": [1,1,1], "power": 10},
            {"shape": "RECTANGLE", "size": [1, 2], "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,2,0,1],
            "color": [1,1,1], "power": 10, "portal": true}]}"#;
        let r = RenderRequest::parse(ok).unwrap();
        assert_eq!((r.width, r.height, r.area_lights.len(), r.lens), (Some(64), Some(32), 2, None));
        let with_lens = RenderRequest::parse(br#"{"lens": {"shift": [0.1, 0], "aperture": {"radius": 0.01, "focus_distance": 2}}, "transparent_film": true}"#).unwrap();
        assert_eq!(with_lens.transparent_film, Some(true));
        let lens = with_lens.lens.unwrap();
        let aperture = lens.aperture.unwrap();
        assert_eq!((lens.shift, aperture.blades, aperture.rotation, aperture.ratio), ([0.1, 0.0], 0, 0.0, 1.0));
        assert!(!r.area_lights[0].portal && r.area_lights[1].portal);
        let hidden = RenderRequest::parse(br#"{"hidden_from_rays": [{"object": "Card", "rays": ["shadow", "glossy", "shadow"]}]}"#).unwrap();
        use crate::material::Rays;
        assert_eq!(hidden.hidden_from_rays[0].rays(), Ok(Rays::SHADOW.union(Rays::GLOSSY)));
        for (bad, why) in [
            (&br#"{"widht": 64}"#[..], "unknown field"),
            (br#"{"width": 0}"#, "width"),
            (br#"{"samples": 0}"#, "time_limit"),
            (br#"{"background": [1, 1]}"#, "length 3"),
            (br#"{"time_limit": -1}"#, "time_limit"),
            (br#"{"noise_threshold": -0.01}"#, "noise_threshold"),
            (br#"{"area_lights": [{"shape": "STAR", "size": [1,1], "matrix": [], "color": [1,1,1], "power": 1}]}"#, "STAR"),
            (br#"{"width": 64"#, "EOF"),
            (br#"{"default_surface": [2, 0, 0]}"#, "default_surface"),
            (br#"{"environment": {"image": "sky.hdr", "strength": -1}}"#, "environment strength"),
            (br#"{"environment": {"strength": 1}}"#, "missing field `image`"),
            (br#"{"lens": {"aperture": {"radius": 0.01}}}"#, "missing field `focus_distance`"),
            (br#"{"lens": {"shift": [0.1, 0], "fstop": 2}}"#, "unknown field `fstop`"),
            (br#"{"hidden_from_rays": [{"object": "Card", "rays": ["shadow", "volume"]}]}"#, "'volume' is not a kind of ray"),
            (br#"{"hidden_from_rays": [{"object": "Card"}]}"#, "missing field `rays`"),
        ] {
            let e = RenderRequest::parse(bad).unwrap_err();
            assert!(e.contains(why) && !e.contains('\n'), "{e}");
        }
    }
}
