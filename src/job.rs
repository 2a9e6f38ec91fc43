//! One render job: a scene file plus the options that say how to render it,
//! gathered from the command line and a render request, turned into
//! everything the renderer needs. Shared by `glint render` and `glint watch`.

use crate::environment::EnvironmentMap;
use crate::adaptive::Adaptive;
use crate::bsdf::BsdfModel;
use crate::features::FeatureMode;
use crate::lamps::AreaLight;
use crate::loader::{self, LoadOptions};
use crate::pixel_filter::PixelFilter;
use crate::progressive::Budget;
use crate::render::{resolution, LightPaths, RenderSettings};
use crate::punctual::PunctualKind;
use crate::material::AlphaMode;
use crate::request::{is_radiance, is_unit_rgb, AnisotropyTangent, BsdfNode, BsdfNodeKind, CoatTint, DiffuseRoughness, LensRequest, LightSize, RenderRequest, ShaderMix, VolumeAbsorption};
use crate::scene::{Backdrop, Scene};
use crate::Vec3;
use std::path::Path;
use std::time::Duration;

pub const DEFAULT_SAMPLES: u32 = 64;
pub const DEFAULT_MAX_DEPTH: u32 = 16;

/// How to render; a field left `None` falls through to the next source.
#[derive(Clone, Debug, Default)]
pub struct JobOptions {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub samples: Option<u32>,
    pub time_limit: Option<f64>,
    /// Adaptive sampling's Noise Threshold; 0 or none: off.
    pub noise_threshold: Option<f32>,
    /// Its Min Samples; 0 or none: from the threshold.
    pub adaptive_min_samples: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u64>,
    pub mis: Option<bool>,
    pub camera: Option<String>,
    pub scene_index: Option<usize>,
    pub background: Option<[f32; 3]>,
    pub bsdf: Option<BsdfModel>,
    pub two_sided_emission: Option<bool>,
    pub features: Option<FeatureMode>,
    /// An environment image for the World (replaces `background`).
    pub environment: Option<crate::request::EnvironmentRequest>,
    /// The World camera rays see instead (`Scene::camera_world`).
    pub camera_world: Option<crate::request::CameraWorld>,
    pub sampler: Option<crate::rng::Sampler>,
    /// `--light-paths`, else the request's, else `Auto`.
    pub light_paths: Option<LightPaths>,
    /// Film › Transparent (`RenderSettings::transparent`).
    pub transparent: Option<bool>,
    /// Film › Transparent Glass's roughness threshold
    /// (`RenderSettings::transparent_glass`).
    pub transparent_glass: Option<f32>,
    /// Film › Pixel Filter and its Width (`RenderSettings::pixel_filter`).
    pub pixel_filter: Option<crate::pixel_filter::FilterRequest>,
}

impl JobOptions {
    /// These options, with gaps filled from `fallback`.
    pub fn or(self, fallback: &JobOptions) -> JobOptions {
        let f = fallback.clone();
        JobOptions {
            width: self.width.or(f.width),
            height: self.height.or(f.height),
            samples: self.samples.or(f.samples),
            time_limit: self.time_limit.or(f.time_limit),
            noise_threshold: self.noise_threshold.or(f.noise_threshold),
            adaptive_min_samples: self.adaptive_min_samples.or(f.adaptive_min_samples),
            max_depth: self.max_depth.or(f.max_depth),
            seed: self.seed.or(f.seed),
            mis: self.mis.or(f.mis),
            camera: self.camera.or(f.camera),
            scene_index: self.scene_index.or(f.scene_index),
            background: self.background.or(f.background),
            bsdf: self.bsdf.or(f.bsdf),
            two_sided_emission: self.two_sided_emission.or(f.two_sided_emission),
            features: self.features.or(f.features),
            environment: self.environment.or(f.environment),
            camera_world: self.camera_world.or(f.camera_world),
            sampler: self.sampler.or(f.sampler),
            light_paths: self.light_paths.or(f.light_paths),
            transparent: self.transparent.or(f.transparent),
            transparent_glass: self.transparent_glass.or(f.transparent_glass),
            pixel_filter: self.pixel_filter.or(f.pixel_filter),
        }
    }
}

impl From<&RenderRequest> for JobOptions {
    fn from(r: &RenderRequest) -> Self {
        JobOptions {
            width: r.width,
            height: r.height,
            samples: r.samples,
            time_limit: r.time_limit,
            noise_threshold: r.noise_threshold,
            adaptive_min_samples: r.adaptive_min_samples,
            max_depth: r.max_depth,
            seed: r.seed,
            mis: r.mis,
            camera: r.camera.clone(),
            scene_index: None,
            background: r.background,
            bsdf: r.bsdf,
            two_sided_emission: r.two_sided_emission,
            features: None,
            sampler: None,
            light_paths: r.light_paths.map(|on| if on { LightPaths::On } else { LightPaths::Off }),
            environment: r.environment.clone(),
            camera_world: r.camera_world.clone(),
            transparent: r.transparent_film,
            transparent_glass: r.transparent_glass,
            pixel_filter: r.pixel_filter,
        }
    }
}

pub struct Job {
    pub scene: Scene,
    pub settings: RenderSettings,
    pub budget: Budget,
}

/// What a render request adds to a scene besides options.
#[derive(Clone, Copy, Default)]
pub struct SceneExtras<'a> {
    pub area_lights: &'a [AreaLight],
    /// Materials rendered with plain (single-scattering) GGX.
    pub single_scatter_materials: &'a [String],
    pub coat_tints: &'a [CoatTint],
    pub diffuse_roughness: &'a [DiffuseRoughness],
    pub volume_absorption: &'a [VolumeAbsorption],
    pub bsdf_nodes: &'a [BsdfNode],
    pub shader_mixes: &'a [ShaderMix],
    pub default_surface: Option<[f32; 3]>,
    pub light_sizes: &'a [LightSize],
    /// The camera's shift and depth of field.
    pub lens: Option<&'a LensRequest>,
    /// Nodes whose meshes camera rays pass.
    pub hidden_from_camera: &'a [String],
    /// Nodes whose meshes some other rays pass.
    pub hidden_from_rays: &'a [crate::request::HiddenFromRays],
    pub anisotropy_tangents: &'a [AnisotropyTangent],
}

impl<'a> From<&'a RenderRequest> for SceneExtras<'a> {
    fn from(r: &'a RenderRequest) -> Self {
        SceneExtras { area_lights: &r.area_lights, single_scatter_materials: &r.single_scatter_materials, coat_tints: &r.coat_tints, diffuse_roughness: &r.diffuse_roughness, volume_absorption: &r.volume_absorption, bsdf_nodes: &r.bsdf_nodes, shader_mixes: &r.shader_mixes, default_surface: r.default_surface, light_sizes: &r.light_sizes, lens: r.lens.as_ref(), hidden_from_camera: &r.hidden_from_camera, hidden_from_rays: &r.hidden_from_rays, anisotropy_tangents: &r.anisotropy_tangents }
    }
}

/// The brightest emitter or World a scene may have (W·sr⁻¹·m⁻²): 10^13
/// times the Sun's disk. Far below f32::MAX, so that the image's sums of
/// the samples that see it stay finite (render::MAX_SAMPLE, 10^4 above
/// it, is where a sample is dropped); an emission strength of 3·10^38,
/// which glTF allows, had made pixels infinite.
pub const MAX_RADIANCE: f32 = 1e20;

/// Every emitting material (a glTF emission × its strength, a Blender area
/// light's power over its area), every point, spot and sun (its intensity
/// in W·sr⁻¹, a sun's irradiance in W·m⁻²: the radiance of a surface it
/// lights at 1 m is of that order), the World's colour and its image's
/// brightest texel × strength within `MAX_RADIANCE`.
fn check_radiance(scene: &Scene) -> Result<(), String> {
    let too_bright = |v: f32| !(v <= MAX_RADIANCE);
    if let Some(m) = scene.materials.iter().find(|m| too_bright(m.emission.max_element())) {
        // A lamp's material is named as its light ("area light 'Key'").
        let what = if m.lamp { m.name.clone() } else { format!("material '{}'", m.name) };
        return Err(format!("{what} emits {:e} W·sr⁻¹·m⁻²; Glint renders emitters up to {MAX_RADIANCE:e}", m.emission.max_element()));
    }
    if let Some(l) = scene.punctual.iter().find(|l| too_bright(l.intensity.max_element())) {
        let unit = if l.kind == PunctualKind::Sun { "W·m⁻²" } else { "W·sr⁻¹" };
        return Err(format!("light '{}' has an intensity of {:e} {unit}; Glint renders lights up to {MAX_RADIANCE:e}", l.name, l.intensity.max_element()));
    }
    if too_bright(scene.background.max_element()) {
        return Err(format!("the World's colour is {:e} W·sr⁻¹·m⁻²; Glint renders up to {MAX_RADIANCE:e}", scene.background.max_element()));
    }
    if let Some(env) = scene.environment.as_ref().filter(|e| too_bright(e.brightest)) {
        return Err(format!("the environment image's brightest texel × strength is {:e} W·sr⁻¹·m⁻²; Glint renders up to {MAX_RADIANCE:e}", env.brightest));
    }
    let camera_brightest = match &scene.camera_world {
        Some(Backdrop::Colour(c)) => c.max_element(),
        Some(Backdrop::Image(map)) => map.brightest,
        None => 0.0,
    };
    if too_bright(camera_brightest) {
        return Err(format!("the World the camera sees is {camera_brightest:e} W·sr⁻¹·m⁻² at its brightest; Glint renders up to {MAX_RADIANCE:e}"));
    }
    Ok(())
}

/// The World camera rays see, from the request: its image, else its
/// colour, else black.
fn camera_backdrop(seen: &crate::request::CameraWorld) -> Result<Backdrop, String> {
    if let Some(env) = &seen.environment {
        return EnvironmentMap::load(&env.image, env.strength, env.rotation).map(|map| Backdrop::Image(Box::new(map)));
    }
    let colour = seen.background.unwrap_or([0.0; 3]);
    if !is_radiance(&colour) {
        return Err("background must be finite and ≥ 0".into());
    }
    Ok(Backdrop::Colour(Vec3::from(colour)))
}

/// The Principled BSDF that renders a plain BSDF node as Cycles does:
/// Diffuse (at Roughness 0) is Lambert's, no specular layer
/// (KHR_materials_specular 0); a white Glossy is a white metal (F = 1 at
/// every angle, as the node's constant colour); a clear Glass is
/// Principled glass of its IOR. A coloured Glossy or Glass is that colour's
/// metal or tinted glass, which the add-on names as approximate. No coat;
/// emission, none in such a material, stays, but for an Emission
/// shader's (`as_node`).
fn node_material(materials: &mut [crate::material::Material], node: &BsdfNode) -> Result<(), String> {
    check_node(node)?;
    for m in materials.iter_mut().filter(|m| m.name == node.material) {
        as_node(m, node);
    }
    Ok(())
}

fn check_node(node: &BsdfNode) -> Result<(), String> {
    let BsdfNode { material, color, roughness, ior, strength, .. } = node;
    if !(is_unit_rgb(color) && (0.0..=1.0).contains(roughness) && ior.is_finite() && *ior >= 1.0 && strength.is_finite() && *strength >= 0.0) {
        return Err(format!("BSDF node of '{material}' must have colour channels and roughness in [0, 1], an IOR ≥ 1 and a finite strength ≥ 0"));
    }
    Ok(())
}

/// Material `m` made the Principled BSDF that `node` is (`node_material`);
/// a Transparent BSDF makes it let every ray pass, an Emission shader a
/// black emitter.
fn as_node(m: &mut crate::material::Material, node: &BsdfNode) {
    let BsdfNode { color, roughness, ior, .. } = node;
    let colour = Vec3::from(*color);
    // Principled glass tints what crosses by √base and what reflects by
    // its Specular Tint on F0; Cycles' Glass BSDF takes its colour on
    // both whole, once per event: base = colour², tint = colour comes
    // nearest (a coloured glass sphere 0.4–1.9% bright against Cycles,
    // 3–11% with base = colour and no tint). A Glossy BSDF's Fresnel is
    // constant, a metal's brightens toward grazing; tinting its F82 by
    // the colour was further off (−1.6%, against +0.2% without).
    let (base, tint, metallic, specular, transmission) = match node.node {
        BsdfNodeKind::Diffuse => (colour, Vec3::ONE, 0.0, 0.0, 0.0),
        BsdfNodeKind::Glossy => (colour, Vec3::ONE, 1.0, 1.0, 0.0),
        BsdfNodeKind::Glass => (colour * colour, colour, 0.0, 1.0, 1.0),
        BsdfNodeKind::Translucent => (colour, Vec3::ONE, 0.0, 0.0, 1.0),
        BsdfNodeKind::Transparent => {
            (m.alpha, m.alpha_mode) = (0.0, AlphaMode::Blend);
            return;
        }
        BsdfNodeKind::Emission => {
            m.emission = colour * node.strength;
            (Vec3::ZERO, Vec3::ONE, 0.0, 0.0, 0.0)
        }
    };
    (m.base_color, m.metallic, m.specular, m.transmission, m.coat) = (base, metallic, specular, transmission, 0.0);
    // A Diffuse BSDF's Roughness is Cycles' Oren–Nayar lobe, as the
    // Principled BSDF's Diffuse Roughness; the other nodes have none.
    m.diffuse_roughness = if node.node == BsdfNodeKind::Diffuse { *roughness } else { 0.0 };
    (m.roughness, m.ior, m.specular_tint) = (*roughness, *ior, tint);
    m.translucent = node.node == BsdfNodeKind::Translucent;
}

/// Blender's Mix Shader of a material's Principled BSDF and a plain node
/// (`ShaderMix`), on every material of that name (hidden copies too).
/// Cycles weighs each half, emission included, by its share: the
/// material's emission is the Principled BSDF's × its share, plus an
/// Emission shader's × the node's; a Transparent BSDF's share lets rays
/// pass (alpha × the Principled BSDF's share); any other node becomes a
/// second material without textures (`Material::mix`; an Emission
/// shader's is black), with the first's emission, alpha and ray
/// visibility.
fn mix_shaders(materials: &mut Vec<crate::material::Material>, mix: &ShaderMix) -> Result<(), String> {
    let node = &mix.mixed;
    check_node(node)?;
    if !(0.0..=1.0).contains(&mix.weight) || mix.emission.is_some_and(|e| !is_radiance(&e)) {
        return Err(format!("shader mix of '{}' must have a weight in [0, 1] and an emission of finite numbers ≥ 0", node.material));
    }
    let node_emission = if node.node == BsdfNodeKind::Emission { Vec3::from(node.color) * node.strength } else { Vec3::ZERO };
    for id in 0..materials.len() {
        let m = &mut materials[id];
        if m.name != node.material || m.lamp || m.mix.is_some() {
            continue;
        }
        let emission = mix.emission.map_or(m.emission * (1.0 - mix.weight) + node_emission * mix.weight, Vec3::from);
        m.emission = emission;
        if node.node == BsdfNodeKind::Transparent {
            m.alpha *= 1.0 - mix.weight;
            if m.alpha_mode == AlphaMode::Opaque && mix.weight > 0.0 {
                m.alpha_mode = AlphaMode::Blend;
            }
            continue;
        }
        if mix.weight == 0.0 {
            continue;
        }
        let mut other = crate::material::Material { textures: None, ..m.clone() };
        as_node(&mut other, node);
        other.emission = emission;
        if mix.weight == 1.0 {
            materials[id] = other;
            continue;
        }
        materials[id].mix = Some(crate::material::Mix { with: materials.len() as u32, weight: mix.weight });
        materials.push(other);
    }
    Ok(())
}

/// A point or spot light's radius, relative to its distance from the
/// origin (at least 1 m), at or below which it is a point (`size_lights`).
const POINT_RADIUS: f32 = 1e-5;

/// Give the named punctual lights their Blender sizes.
fn size_lights(scene: &mut Scene, sizes: &[LightSize]) -> Result<(), String> {
    for size in sizes {
        if !(size.radius.is_finite() && size.radius >= 0.0 && size.angle.is_finite() && (0.0..=std::f32::consts::PI).contains(&size.angle)) {
            return Err(format!("light_sizes: {}: radius must be finite and ≥ 0, angle in [0, π]", size.name));
        }
        for light in scene.punctual.iter_mut().filter(|l| l.name == size.name) {
            (light.size, light.sphere) = match light.kind {
                PunctualKind::Sun => (0.5 * size.angle, false),
                // A radius that small (about 80 times the rounding of
                // the light's position, or less) is a point's: a ray's
                // test against such a disk is the rounding's, and light
                // subpaths that leave it would miss it (a 1e-8 m bulb lost
                // 0.45% of the gold sphere's image with them, a 1e-30 m
                // one 2.1%).
                _ if size.radius <= POINT_RADIUS * light.position.abs().max_element().max(1.0) => (0.0, false),
                _ => (size.radius, !size.soft_falloff),
            };
            (light.camera_sees, light.shadowless) = (size.visible_camera, !size.cast_shadow);
        }
    }
    Ok(())
}

/// Load a scene (None: the embedded default) and apply the options and the
/// request's extras. Errors are one line naming the file.
pub fn prepare(scene_file: Option<&Path>, options: &JobOptions, extras: SceneExtras) -> Result<Job, String> {
    let name = scene_file.map_or(crate::DEFAULT_SCENE_NAME.to_string(), |p| p.display().to_string());
    let tangents = extras.anisotropy_tangents.iter().map(|t| Ok((t.material.clone(), t.source()?))).collect::<Result<Vec<_>, String>>();
    let anisotropy_tangents = tangents.map_err(|e| format!("{name}: {e}"))?;
    let hidden = extras.hidden_from_rays.iter().map(|h| Ok((h.object.clone(), h.rays()?))).collect::<Result<Vec<_>, String>>();
    let hidden_from_rays = hidden.map_err(|e| format!("{name}: {e}"))?;
    let load = LoadOptions { scene_index: options.scene_index, camera: options.camera.clone(), hidden_from_camera: extras.hidden_from_camera.to_vec(), hidden_from_rays, anisotropy_tangents };
    let mut scene = match scene_file {
        Some(path) => loader::load_file(path, &load),
        None => loader::load_bytes(crate::DEFAULT_SCENE.as_bytes(), None, crate::DEFAULT_SCENE_NAME, &load),
    }
    .map_err(|e| e.to_string())?;
    let pixel_filter = match &options.pixel_filter {
        None => PixelFilter::default(),
        Some(r) => PixelFilter::from_request(r).ok_or_else(|| format!("{name}: the pixel filter's width must be between 0.01 and 10 pixels"))?,
    };
    if options.transparent_glass.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
        return Err(format!("{name}: transparent glass's roughness threshold must be finite and ≥ 0"));
    }
    if let Some(b) = options.background {
        if !is_radiance(&b) {
            return Err(format!("{name}: background must be finite and ≥ 0"));
        }
        scene.background = Vec3::from(b);
    }
    if options.two_sided_emission == Some(true) {
        for m in scene.materials.iter_mut().filter(|m| m.is_emissive()) {
            m.double_sided = true;
        }
    }
    for m in scene.materials.iter_mut().filter(|m| extras.single_scatter_materials.contains(&m.name)) {
        m.multiscatter = false;
    }
    for CoatTint { material, tint } in extras.coat_tints {
        if !is_unit_rgb(tint) {
            return Err(format!("{name}: coat tint of '{material}' must have channels in [0, 1]"));
        }
        for m in scene.materials.iter_mut().filter(|m| &m.name == material) {
            m.coat_tint = Vec3::from(*tint);
        }
    }
    for DiffuseRoughness { material, roughness } in extras.diffuse_roughness {
        if !(0.0..=1.0).contains(roughness) {
            return Err(format!("{name}: diffuse roughness of '{material}' must be in [0, 1]"));
        }
        for m in scene.materials.iter_mut().filter(|m| &m.name == material) {
            m.diffuse_roughness = *roughness;
        }
    }
    for VolumeAbsorption { material, color, density } in extras.volume_absorption {
        if !(is_unit_rgb(color) && density.is_finite() && *density >= 0.0) {
            return Err(format!("{name}: volume absorption of '{material}' must have colour channels in [0, 1] and a finite density ≥ 0"));
        }
        // Cycles' Volume Absorption: σ_a = (1 − Color) × Density, per
        // metre (a Blender unit).
        for m in scene.materials.iter_mut().filter(|m| &m.name == material) {
            m.absorption = (Vec3::ONE - Vec3::from(*color)) * *density;
        }
    }
    for node in extras.bsdf_nodes {
        node_material(&mut scene.materials, node).map_err(|e| format!("{name}: {e}"))?;
    }
    for mix in extras.shader_mixes {
        mix_shaders(&mut scene.materials, mix).map_err(|e| format!("{name}: {e}"))?;
    }
    if let (Some(colour), Some(id)) = (extras.default_surface, scene.default_material) {
        let m = &mut scene.materials[id as usize];
        (m.base_color, m.metallic, m.specular) = (Vec3::from(colour), 0.0, 0.0);
    }
    crate::lamps::add_area_lights(&mut scene, extras.area_lights).map_err(|e| format!("{name}: {e}"))?;
    size_lights(&mut scene, extras.light_sizes).map_err(|e| format!("{name}: {e}"))?;
    if let Some(lens) = extras.lens {
        scene.camera.set_lens(glam::Vec2::from(lens.shift), lens.aperture, lens.panorama).map_err(|e| format!("{name}: lens: {e}"))?;
    }
    if let Some(env) = &options.environment {
        let map = EnvironmentMap::load(&env.image, env.strength, env.rotation).map_err(|e| format!("{name}: {e}"))?;
        scene.environment = Some(map);
    }
    if let Some(seen) = &options.camera_world {
        scene.camera_world = Some(camera_backdrop(seen).map_err(|e| format!("{name}: camera World: {e}"))?);
    }
    check_radiance(&scene).map_err(|e| format!("{name}: {e}"))?;
    // A previewed asset without lights is lit by a white World.
    let unlit = scene.punctual.is_empty() && !scene.materials.iter().any(|m| m.is_emissive());
    if options.camera.as_deref() == Some(loader::AUTO_CAMERA) && options.background.is_none() && options.environment.is_none() && unlit {
        scene.background = Vec3::ONE;
    }
    let (width, height) = resolution(options.width, options.height, scene.camera.aspect_ratio);
    // A limit past what a Duration holds (1e300 s) is no limit at all;
    // `from_secs_f64` panicked on it.
    let time = options.time_limit.filter(|t| *t > 0.0).map(|t| Duration::try_from_secs_f64(t).unwrap_or(Duration::MAX));
    let samples = match options.samples {
        Some(0) if time.is_none() => return Err(format!("{name}: samples 0 (unlimited) needs a time limit")),
        Some(n) => n,
        None if time.is_some() => 0,
        None => DEFAULT_SAMPLES,
    };
    // `--light-paths` turns the connections and light tracing on and off
    // together.
    let light_paths = options.light_paths.unwrap_or_default();
    let settings = RenderSettings {
        width,
        height,
        spp: samples,
        max_depth: options.max_depth.unwrap_or(DEFAULT_MAX_DEPTH),
        seed: options.seed.unwrap_or(0),
        mis: options.mis.unwrap_or(true),
        bsdf: options.bsdf.unwrap_or_default(),
        features: options.features.unwrap_or_default(),
        sampler: options.sampler.unwrap_or_default(),
        light_paths,
        light_tracing: true,
        caustic_guide: true,
        merge: true,
        strategies: Default::default(),
        transparent: options.transparent.unwrap_or(false),
        transparent_glass: options.transparent_glass,
        pixel_filter,
        adaptive: options.noise_threshold.filter(|t| *t > 0.0).map(|threshold| Adaptive { threshold, min_samples: options.adaptive_min_samples.unwrap_or(0) }),
    };
    Ok(Job { scene, settings, budget: Budget { samples, time, paced: true } })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A request's Coat Tint reaches the material it names; a tint outside
    /// [0, 1] is one line naming the file and the material.
    #[test]
    fn coat_tints_reach_their_materials_and_bad_ones_are_errors() {
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let tints = [CoatTint { material: "red".into(), tint: [0.9, 0.5, 0.2] }];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { coat_tints: &tints, ..SceneExtras::default() }).unwrap();
        let tint_of = |name: &str| job.scene.materials.iter().find(|m| m.name == name).unwrap().coat_tint;
        assert_eq!((tint_of("red"), tint_of("white")), (Vec3::new(0.9, 0.5, 0.2), Vec3::ONE));
        let bad = [CoatTint { material: "red".into(), tint: [0.9, f32::NAN, 0.2] }];
        let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { coat_tints: &bad, ..SceneExtras::default() }).err().unwrap();
        assert!(err.contains("cornell-box.gltf") && err.contains("'red'") && !err.contains('\n'), "{err}");
    }

    /// A request's Diffuse Roughness reaches the material it names; one
    /// outside [0, 1] is one line naming the file and the material. A
    /// Diffuse BSDF node's Roughness is its material's; other nodes have
    /// none, whatever the Principled BSDF had.
    #[test]
    fn diffuse_roughness_reaches_its_material_and_bad_ones_are_errors() {
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let rough = [DiffuseRoughness { material: "red".into(), roughness: 0.7 }, DiffuseRoughness { material: "green".into(), roughness: 0.4 }];
        let nodes = [BsdfNode { material: "green".into(), node: BsdfNodeKind::Glossy, color: [1.0; 3], roughness: 0.3, ior: 1.5, strength: 1.0 }];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { diffuse_roughness: &rough, bsdf_nodes: &nodes, ..SceneExtras::default() }).unwrap();
        let of = |name: &str| job.scene.materials.iter().find(|m| m.name == name).unwrap().diffuse_roughness;
        assert_eq!((of("red"), of("white"), of("green")), (0.7, 0.0, 0.0));
        let diffuse = [BsdfNode { material: "white".into(), node: BsdfNodeKind::Diffuse, color: [0.5; 3], roughness: 0.8, ior: 1.5, strength: 1.0 }];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { bsdf_nodes: &diffuse, ..SceneExtras::default() }).unwrap();
        assert_eq!(job.scene.materials.iter().find(|m| m.name == "white").unwrap().diffuse_roughness, 0.8);
        for bad in [1.5, -0.1, f32::NAN] {
            let rough = [DiffuseRoughness { material: "red".into(), roughness: bad }];
            let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { diffuse_roughness: &rough, ..SceneExtras::default() }).err().unwrap();
            assert!(err.contains("cornell-box.gltf") && err.contains("'red'") && !err.contains('\n'), "{err}");
        }
    }

    /// A request's pixel filter reaches the settings; a width outside 0.01
    /// to 10 pixels is one line naming the file.
    #[test]
    fn the_pixel_filter_reaches_the_settings_and_a_bad_width_is_an_error() {
        use crate::pixel_filter::{FilterKind, FilterRequest};
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let options = |width| JobOptions { pixel_filter: Some(FilterRequest { kind: FilterKind::BlackmanHarris, width }), ..JobOptions::default() };
        let job = prepare(Some(&path), &options(1.5), SceneExtras::default()).unwrap();
        assert!(!job.settings.pixel_filter.is_unit_box() && job.settings.pixel_filter.radius() == 1.5);
        assert!(prepare(Some(&path), &JobOptions::default(), SceneExtras::default()).unwrap().settings.pixel_filter.is_unit_box());
        for bad in [0.0, -1.0, 10.5, f32::NAN, f32::INFINITY] {
            let err = prepare(Some(&path), &options(bad), SceneExtras::default()).err().unwrap();
            assert!(err.contains("cornell-box.gltf") && err.contains("pixel filter") && !err.contains('\n'), "{err}");
        }
    }

    /// A request's Volume Absorption reaches the material it names as
    /// Cycles' σ_a = (1 − Color) × Density, replacing the file's; a colour
    /// outside [0, 1] or a density below 0 or not finite is one line naming
    /// the file and the material.
    #[test]
    fn volume_absorption_reaches_its_material_and_bad_ones_are_errors() {
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let volumes = [VolumeAbsorption { material: "red".into(), color: [0.75, 0.5, 1.0], density: 4.0 }];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { volume_absorption: &volumes, ..SceneExtras::default() }).unwrap();
        let absorption_of = |name: &str| job.scene.materials.iter().find(|m| m.name == name).unwrap().absorption;
        assert_eq!((absorption_of("red"), absorption_of("white")), (Vec3::new(1.0, 2.0, 0.0), Vec3::ZERO));
        for (color, density) in [([0.5, 1.5, 0.5], 1.0), ([0.5, f32::NAN, 0.5], 1.0), ([0.5; 3], -1.0), ([0.5; 3], f32::INFINITY)] {
            let bad = [VolumeAbsorption { material: "red".into(), color, density }];
            let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { volume_absorption: &bad, ..SceneExtras::default() }).err().unwrap();
            assert!(err.contains("cornell-box.gltf") && err.contains("'red'") && !err.contains('\n'), "{err}");
        }
    }

    /// A request's BSDF node makes the material it names what Cycles
    /// renders for it (glTF's default white metal before): Diffuse pure
    /// Lambert, Glossy a metal, Glass glass of its IOR; a colour or
    /// roughness outside [0, 1] or an IOR below 1 is one line naming the
    /// file and the material.
    #[test]
    fn bsdf_nodes_reach_their_materials_and_bad_ones_are_errors() {
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let node = |material: &str, node, color: [f32; 3], roughness, ior| BsdfNode { material: material.into(), node, color, roughness, ior, strength: 0.0 };
        let nodes = [node("red", BsdfNodeKind::Diffuse, [0.5, 0.25, 0.125], 0.0, 1.5), node("green", BsdfNodeKind::Glossy, [1.0; 3], 0.3, 1.5), node("white", BsdfNodeKind::Glass, [1.0; 3], 0.1, 1.33)];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { bsdf_nodes: &nodes, ..SceneExtras::default() }).unwrap();
        let named = |name: &str| job.scene.materials.iter().find(|m| m.name == name).unwrap().clone();
        let (red, green, white) = (named("red"), named("green"), named("white"));
        assert!(red.is_pure_lambert() && red.base_color == Vec3::new(0.5, 0.25, 0.125), "{red:?}");
        assert!(green.metallic == 1.0 && green.roughness == 0.3 && green.base_color == Vec3::ONE && !green.is_transmissive(), "{green:?}");
        assert!(white.is_transmissive() && white.ior == 1.33 && white.roughness == 0.1 && white.metallic == 0.0, "{white:?}");
        // A coloured Glass: base colour², Specular Tint the colour.
        let coloured = [node("white", BsdfNodeKind::Glass, [0.5, 0.25, 1.0], 0.0, 1.5)];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { bsdf_nodes: &coloured, ..SceneExtras::default() }).unwrap();
        let glass = job.scene.materials.iter().find(|m| m.name == "white").unwrap();
        assert!(glass.base_color == Vec3::new(0.25, 0.0625, 1.0) && glass.specular_tint == Vec3::new(0.5, 0.25, 1.0), "{glass:?}");
        for bad in [node("red", BsdfNodeKind::Diffuse, [0.5, -0.1, 0.5], 0.0, 1.5), node("red", BsdfNodeKind::Glossy, [0.5; 3], 1.5, 1.5), node("red", BsdfNodeKind::Glass, [0.5; 3], 0.0, 0.9), node("red", BsdfNodeKind::Glass, [0.5; 3], f32::NAN, 1.5)] {
            let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { bsdf_nodes: &[bad], ..SceneExtras::default() }).err().unwrap();
            assert!(err.contains("cornell-box.gltf") && err.contains("'red'") && !err.contains('\n'), "{err}");
        }
    }

    /// A Mix Shader in the request: a plain node's half becomes a second
    /// material the first names with its share, which keeps the first's
    /// emission scaled by the Principled BSDF's share; a Transparent BSDF's
    /// share becomes alpha; a weight outside [0, 1] is one line naming the
    /// file and the material.
    #[test]
    fn shader_mixes_make_second_materials_and_bad_ones_are_errors() {
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let mix = |material: &str, weight, node| ShaderMix { weight, mixed: BsdfNode { material: material.into(), node, color: [1.0, 0.5, 0.25], roughness: 0.2, ior: 1.5, strength: 4.0 }, emission: None };
        let plain = prepare(Some(&path), &JobOptions::default(), SceneExtras::default()).unwrap();
        let mixes = [mix("red", 0.25, BsdfNodeKind::Glossy), mix("green", 0.4, BsdfNodeKind::Transparent), mix("light", 0.5, BsdfNodeKind::Diffuse), mix("white", 0.25, BsdfNodeKind::Emission)];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { shader_mixes: &mixes, ..SceneExtras::default() }).unwrap();
        let m = &job.scene.materials;
        let named = |name: &str| m.iter().position(|m| m.name == name).unwrap();
        let before = |name: &str| plain.scene.materials.iter().find(|m| m.name == name).unwrap().clone();
        let red = &m[named("red")];
        let Some(crate::material::Mix { with, weight }) = red.mix else { panic!("{red:?}") };
        let glossy = &m[with as usize];
        assert!(weight == 0.25 && glossy.metallic == 1.0 && glossy.roughness == 0.2 && glossy.base_color == Vec3::new(1.0, 0.5, 0.25) && glossy.mix.is_none(), "{glossy:?}");
        assert_eq!(crate::material::Material { mix: None, ..red.clone() }, before("red"));
        let green = &m[named("green")];
        assert!(green.mix.is_none() && green.alpha == 0.6 && green.alpha_mode == AlphaMode::Blend, "{green:?}");
        let light = &m[named("light")];
        let diffuse = &m[light.mix.unwrap().with as usize];
        assert!(light.emission == before("light").emission * 0.5 && diffuse.emission == light.emission && diffuse.is_pure_lambert(), "{light:?} {diffuse:?}");
        // An Emission shader's half is black; both halves emit the mix's.
        let white = &m[named("white")];
        let glow = &m[white.mix.unwrap().with as usize];
        let expected = before("white").emission * 0.75 + Vec3::new(1.0, 0.5, 0.25);
        assert!(white.emission == expected && glow.emission == expected && glow.base_color == Vec3::ZERO && glow.specular == 0.0 && glow.metallic == 0.0, "{white:?} {glow:?}");
        assert_eq!(m.len(), plain.scene.materials.len() + 3);
        // The whole emission, where the request gives it.
        let given = [ShaderMix { emission: Some([0.5, 0.25, 0.0]), ..mix("white", 0.25, BsdfNodeKind::Emission) }];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { shader_mixes: &given, ..SceneExtras::default() }).unwrap();
        assert!(job.scene.materials.iter().filter(|m| m.name == "white").all(|m| m.emission == Vec3::new(0.5, 0.25, 0.0)));
        for bad in [mix("red", 1.5, BsdfNodeKind::Diffuse), mix("red", f32::NAN, BsdfNodeKind::Glossy), ShaderMix { mixed: BsdfNode { ior: 0.5, ..mix("red", 0.5, BsdfNodeKind::Glass).mixed }, ..mix("red", 0.5, BsdfNodeKind::Glass) }, ShaderMix { mixed: BsdfNode { strength: -1.0, ..mix("red", 0.5, BsdfNodeKind::Emission).mixed }, ..mix("red", 0.5, BsdfNodeKind::Glass) }, ShaderMix { emission: Some([1.0, f32::INFINITY, 0.0]), ..mix("red", 0.5, BsdfNodeKind::Emission) }] {
            let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { shader_mixes: &[bad], ..SceneExtras::default() }).err().unwrap();
            assert!(err.contains("cornell-box.gltf") && err.contains("'red'") && !err.contains('\n'), "{err}");
        }
    }

    /// A Tangent node in the request reaches its material; one naming no
    /// source is one line naming the file.
    #[test]
    fn anisotropy_tangents_reach_their_materials_and_bad_ones_are_errors() {
        use crate::material::{Axis, TangentSource};
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        let tangents = [AnisotropyTangent { material: "red".into(), radial_axis: Some(Axis::X), uv_map: None }];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { anisotropy_tangents: &tangents, ..SceneExtras::default() }).unwrap();
        let source_of = |name: &str| job.scene.materials.iter().find(|m| m.name == name).unwrap().anisotropy_tangent;
        assert_eq!((source_of("red"), source_of("white")), (TangentSource::Radial(Axis::X), TangentSource::default()));
        let bad = [AnisotropyTangent { material: "red".into(), radial_axis: None, uv_map: None }];
        let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { anisotropy_tangents: &bad, ..SceneExtras::default() }).err().unwrap();
        assert!(err.starts_with(&format!("{}: ", path.display())) && err.contains("'red'") && !err.contains('\n'), "{err}");
    }

    /// Transparent Glass's roughness threshold is a roughness: a negative
    /// or non-finite one is one line naming the file.
    #[test]
    fn a_bad_transparent_glass_threshold_is_an_error() {
        let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf"));
        for bad in [-0.1, f32::NAN, f32::INFINITY] {
            let options = JobOptions { transparent: Some(true), transparent_glass: Some(bad), ..JobOptions::default() };
            let err = prepare(Some(&path), &options, SceneExtras::default()).err().unwrap();
            assert!(err.contains("cornell-box.gltf") && err.contains("transparent glass") && !err.contains('\n'), "{err}");
        }
        let options = JobOptions { transparent: Some(true), transparent_glass: Some(0.1), ..JobOptions::default() };
        assert_eq!(prepare(Some(&path), &options, SceneExtras::default()).unwrap().settings.transparent_glass, Some(0.1));
    }
}
