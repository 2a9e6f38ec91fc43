//! Textures, vertex colours, texture transforms, alpha and normal-map
//! tangents, from glTF files built here, rendered where the answer is exact:
//! a Lambertian quad filling the view under a uniform World of radiance 1
//! reflects exactly its albedo (cosine sampling of a constant integrand has
//! no variance), and an emitter seen directly shows exactly its radiance.

mod common;

use base64::Engine;
use common::{assert_clean, render, settings};
use glint::Vec3;
use glint::loader::{load_bytes, LoadOptions};
use glint::scene::Scene;
use glint::texture::srgb_to_linear;
use serde_json::{json, Value};

/// A PNG as a data: URI.
fn png(width: u32, texels: &[[u8; 4]]) -> String {
    let raw: Vec<u8> = texels.iter().flatten().copied().collect();
    let img = image::RgbaImage::from_raw(width, texels.len() as u32 / width, raw).unwrap();
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes.into_inner()))
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// The quad |x|, |y| ≤ 1 at z = 0 facing +Z (u along +X, v down the
/// image = along −Y), seen by a camera at z = 3 whose view it fills. The
/// material is `material`; `colors` adds COLOR_0 (RGBA per vertex).
fn quad_gltf(material: Value, images: Vec<String>, colors: Option<[[f32; 4]; 4]>) -> Vec<u8> {
    let positions = [-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0];
    let normals = [0.0, 0.0, 1.0].repeat(4);
    let uvs = [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
    let indices: Vec<u8> = [0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()).collect();
    let mut data = [f32_bytes(&positions), f32_bytes(&normals), f32_bytes(&uvs), indices].concat();
    let mut views = vec![json!({"buffer": 0, "byteOffset": 0, "byteLength": 48}), json!({"buffer": 0, "byteOffset": 48, "byteLength": 48}), json!({"buffer": 0, "byteOffset": 96, "byteLength": 32}), json!({"buffer": 0, "byteOffset": 128, "byteLength": 12})];
    let mut accessors = vec![
        json!({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}),
        json!({"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}),
        json!({"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}),
        json!({"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}),
    ];
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2});
    if let Some(c) = colors {
        data.extend(f32_bytes(c.as_flattened()));
        data.resize(data.len().next_multiple_of(4), 0);
        views.push(json!({"buffer": 0, "byteOffset": 140, "byteLength": 64}));
        accessors.push(json!({"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC4"}));
        attributes["COLOR_0"] = json!(4);
    }
    let yfov = 2.0 * (0.8f32 / 3.0).atan();
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_specular", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 3]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 3, "material": 0}]}],
        "materials": [material],
        "textures": (0..images.len()).map(|i| json!({"source": i, "sampler": 0})).collect::<Vec<_>>(),
        "samplers": [{"magFilter": 9728, "minFilter": 9728}],
        "images": images.iter().map(|uri| json!({"uri": uri})).collect::<Vec<_>>(),
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": data.len(), "uri": format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data))}],
    });
    serde_json::to_vec(&doc).unwrap()
}

fn load(bytes: &[u8]) -> Scene {
    load_bytes(bytes, None, "quad.gltf", &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// A pure Lambert material (specular 0, not metallic) with these textures.
fn lambert(extra: Value) -> Value {
    let mut m = json!({
        "pbrMetallicRoughness": {"metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}
    });
    for (k, v) in extra.as_object().unwrap() {
        if k == "pbr" {
            for (pk, pv) in v.as_object().unwrap() {
                m["pbrMetallicRoughness"][pk] = pv.clone();
            }
        } else {
            m[k] = v.clone();
        }
    }
    m
}

/// The mean of the left and right thirds of a 24 × 24 render under a white
/// World (the middle third straddles the texel boundary).
fn halves(scene: &mut Scene, background: Vec3) -> (Vec3, Vec3) {
    scene.background = background;
    let (w, h) = (24, 24);
    let (img, stats) = render(scene, &settings(w, h, 4, 4, 1), 2);
    assert_clean(&img, &stats, "textured quad");
    let mean = |x0: u32, x1: u32| {
        let px: Vec<Vec3> = (0..h).flat_map(|y| (x0..x1).map(move |x| (x, y))).map(|(x, y)| img[(y * w + x) as usize]).collect();
        px.iter().copied().sum::<Vec3>() / px.len() as f32
    };
    (mean(0, 8), mean(16, 24))
}

fn linear(t: [u8; 4]) -> Vec3 {
    Vec3::new(srgb_to_linear(t[0] as f32 / 255.0), srgb_to_linear(t[1] as f32 / 255.0), srgb_to_linear(t[2] as f32 / 255.0))
}

fn close(a: Vec3, b: Vec3, what: &str) {
    close_within(a, b, 1e-4, what)
}

/// Within `tolerance`. 1e-4: the estimator is exact up to float rounding
/// of the sums wherever the image is constant per region.
fn close_within(a: Vec3, b: Vec3, tolerance: f32, what: &str) {
    assert!((a - b).abs().max_element() < tolerance, "{what}: {a} vs {b}");
}

const RED: [u8; 4] = [200, 50, 50, 255];
const BLUE: [u8; 4] = [20, 120, 240, 255];

#[test]
fn base_colour_texture_is_srgb_decoded_and_multiplies_the_factor() {
    let material = lambert(json!({"pbr": {"baseColorTexture": {"index": 0}, "baseColorFactor": [1.0, 0.5, 1.0, 1.0]}}));
    let mut scene = load(&quad_gltf(material, vec![png(2, &[RED, BLUE])], None));
    let (left, right) = halves(&mut scene, Vec3::ONE);
    close(left, linear(RED) * Vec3::new(1.0, 0.5, 1.0), "left texel");
    close(right, linear(BLUE) * Vec3::new(1.0, 0.5, 1.0), "right texel");
}

#[test]
fn texture_transform_moves_the_texture() {
    // Offset u by ½ with REPEAT: the halves swap.
    let info = json!({"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0]}}});
    let mut scene = load(&quad_gltf(lambert(json!({"pbr": {"baseColorTexture": info}})), vec![png(2, &[RED, BLUE])], None));
    let (left, right) = halves(&mut scene, Vec3::ONE);
    close(left, linear(BLUE), "left after the offset");
    close(right, linear(RED), "right after the offset");
}

#[test]
fn vertex_colours_multiply_the_base_colour() {
    let colors = [[1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0, 0.0, 0.0, 1.0]];
    let mut scene = load(&quad_gltf(lambert(json!({"pbr": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}})), vec![], Some(colors)));
    let (left, right) = halves(&mut scene, Vec3::ONE);
    // Colours interpolate linearly in x ∈ [−1, 1]; the view spans
    // |x| ≤ 0.8, so the left third's mean x is −1.6/3 and its weight of
    // the left colour 1 − (1 − 1.6/3)/2 = 23/30.
    // Where in its pixel each sample lands (4 per pixel) moves the mean
    // of a gradient by ~1e-4: tolerance 1e-3.
    let w = 23.0 / 30.0;
    close_within(left, Vec3::new(0.5 * w, 0.0, 0.5 * (1.0 - w)), 1e-3, "left");
    close_within(right, Vec3::new(0.5 * (1.0 - w), 0.0, 0.5 * w), 1e-3, "right");
}

#[test]
fn alpha_mask_and_blend_let_the_world_through() {
    let clear = [20, 120, 240, 0];
    let mask = lambert(json!({"pbr": {"baseColorTexture": {"index": 0}}, "alphaMode": "MASK", "alphaCutoff": 0.5}));
    let mut scene = load(&quad_gltf(mask, vec![png(2, &[RED, clear])], None));
    let (left, right) = halves(&mut scene, Vec3::splat(0.7));
    close(left, linear(RED) * 0.7, "opaque texel");
    close(right, Vec3::splat(0.7), "cut-out texel shows the World");
    // BLEND at factor alpha 0.25: a quarter of the rays stop. Noisy, so
    // many samples: 24² px × 64 spp of a two-valued estimate, σ ≈ 0.0015.
    let blend = lambert(json!({"pbr": {"baseColorFactor": [0.2, 0.2, 0.2, 0.25]}, "alphaMode": "BLEND"}));
    let mut scene = load(&quad_gltf(blend, vec![], None));
    scene.background = Vec3::ONE;
    let (img, stats) = render(&scene, &settings(24, 24, 64, 4, 2), 2);
    assert_clean(&img, &stats, "blend");
    let mean = common::channel_mean(&img);
    let expected = 0.25 * 0.2 + 0.75;
    assert!((mean - expected).abs() < 0.01, "blend: {mean} vs {expected}");
}

#[test]
fn emissive_texture_scales_the_emission() {
    let material = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 1.0, 1.0],
        "emissiveTexture": {"index": 0},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}, "KHR_materials_specular": {"specularFactor": 0.0}}
    });
    let mut scene = load(&quad_gltf(material, vec![png(2, &[RED, BLUE])], None));
    let (left, right) = halves(&mut scene, Vec3::ZERO);
    close(left, linear(RED) * 2.0, "left emission");
    close(right, linear(BLUE) * 2.0, "right emission");
}

#[test]
fn normal_maps_get_mikktspace_tangents_when_the_file_has_none() {
    let material = lambert(json!({"normalTexture": {"index": 0, "scale": 0.5}}));
    let scene = load(&quad_gltf(material, vec![png(1, &[[128, 128, 255, 255]])], None));
    let tangents = &scene.attributes.tangent;
    assert_eq!(tangents.len(), 2);
    for t in tangents.iter().flatten() {
        // u runs along +X; v runs down the image, along −Y, so B = −Y and
        // the sign makes sign·(N × T) = sign·(+Y) point that way.
        assert!((Vec3::from_vec4(*t) - Vec3::X).length() < 1e-5 && t.w == -1.0, "{t}");
    }
    let (slot, scale) = scene.materials[0].textures.as_ref().unwrap().normal.unwrap();
    assert_eq!((slot.texcoord, scale), (0, 0.5));
}

#[test]
fn a_scene_without_textures_carries_no_uvs() {
    let scene = load(&quad_gltf(lambert(json!({})), vec![], None));
    assert!(scene.attributes.uv.iter().all(Vec::is_empty) && scene.attributes.tangent.is_empty() && scene.attributes.color.is_empty());
    assert!(scene.images.is_empty() && scene.materials[0].textures.is_none());
}

#[test]
fn broken_images_warn_and_bad_references_are_errors() {
    // Undecodable bytes: the material keeps its factors, with a warning.
    let material = lambert(json!({"pbr": {"baseColorTexture": {"index": 0}}}));
    let scene = load(&quad_gltf(material, vec!["data:image/png;base64,AAAA".into()], None));
    assert!(scene.materials[0].textures.is_none());
    assert!(scene.warnings.iter().any(|w| w.starts_with("image 0") && w.contains("factors")), "{:?}", scene.warnings);
    // A texture that does not exist: the file is invalid.
    let material = lambert(json!({"pbr": {"baseColorTexture": {"index": 7}}}));
    let err = load_bytes(&quad_gltf(material, vec![], None), None, "quad.gltf", &LoadOptions::default()).unwrap_err().to_string();
    assert_eq!(err, "quad.gltf: material 0: texture 7 does not exist");
}

/// A primitive without a material renders with the request's default
/// surface (Cycles' diffuse 0.8 grey) instead of glTF's white metal.
#[test]
fn the_default_surface_replaces_gltfs_default_material() {
    use glint::job::{prepare, JobOptions, SceneExtras};
    let mut doc: Value = serde_json::from_slice(&quad_gltf(lambert(json!({})), vec![], None)).unwrap();
    doc["meshes"][0]["primitives"][0].as_object_mut().unwrap().remove("material");
    let dir = std::env::temp_dir().join(format!("glint-default-surface-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("quad.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let extras = SceneExtras { default_surface: Some([0.8, 0.8, 0.8]), ..SceneExtras::default() };
    let job = prepare(Some(&path), &JobOptions::default(), extras).unwrap();
    let m = &job.scene.materials[job.scene.default_material.unwrap() as usize];
    assert!(m.is_pure_lambert() && m.base_color == Vec3::splat(0.8), "{m:?}");
    let job = prepare(Some(&path), &JobOptions::default(), SceneExtras::default()).unwrap();
    assert_eq!(job.scene.materials[0].metallic, 1.0, "glTF's default without the request");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An environment image of constant radiance 0.5 × strength 2 lights a
/// Lambertian quad (albedo 0.5) to radiance 0.5 × 1 wherever it is seen,
/// with light sampling of the map MIS-weighted against BSDF sampling (and
/// without MIS). The map is sampled by its table, not the cosine, so the
/// estimate is noisy: light sampling alone has a per-sample standard
/// deviation of about 0.5, so 24² px × 64 spp give σ ≈ 0.0026 and the
/// tolerance 0.015 is ~6 σ.
#[test]
fn an_environment_map_lights_a_diffuse_quad() {
    use glint::environment::EnvironmentMap;
    use glint::texture::{Image, Texels};
    let material = lambert(json!({"pbr": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}));
    let mut scene = load(&quad_gltf(material, vec![], None));
    let image = Image { name: "grey".into(), width: 16, height: 8, texels: Texels::RgbaF32(vec![[0.5, 0.5, 0.5, 1.0]; 128]) };
    scene.environment = Some(EnvironmentMap::new(image, 2.0, 0.4));
    for mis in [true, false] {
        let mut s = settings(24, 24, 64, 4, 3);
        s.mis = mis;
        let (img, stats) = render(&scene, &s, 2);
        assert_clean(&img, &stats, "environment");
        let mean = common::channel_mean(&img);
        assert!((mean - 0.5).abs() < 0.015, "mis {mis}: {mean}");
    }
}

/// KHR_materials_clearcoat's weight and roughness textures, as Blender's
/// exporter writes them (one image, R and G): a black quad whose left
/// texel has a smooth coat and whose right one has none, under a white
/// World. The coat reflects the World, F(μ) of IOR 1.5 (0.04 head-on, a
/// little more off the axis); without it the quad is black. The coat's
/// normal texture is read with its scale (shading.rs bends the coat by
/// it). A texture reference that is not a texture info is no texture.
#[test]
fn coat_textures_scale_the_coat() {
    let coat = json!({"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 1.0, "clearcoatTexture": {"index": 0}, "clearcoatRoughnessTexture": {"index": 0}});
    let material = |coat: Value| json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}, "KHR_materials_clearcoat": coat}
    });
    let mut scene = load(&quad_gltf(material(coat), vec![png(2, &[[255, 0, 0, 255], [0, 0, 0, 255]])], None));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let (left, right) = halves(&mut scene, Vec3::ONE);
    assert!(left.min_element() > 0.04 && left.max_element() < 0.06, "a smooth coat reflects F(μ) of the World: {left}");
    close(right, Vec3::ZERO, "no coat");
    // The coat's normal map, with its scale, and the tangents it needs.
    let bumpy = load(&quad_gltf(material(json!({"clearcoatFactor": 1.0, "clearcoatNormalTexture": {"index": 0, "scale": 0.5}})), vec![png(2, &[RED, BLUE])], None));
    let textures = bumpy.materials[0].textures.as_ref().unwrap();
    assert!(textures.coat_normal.as_ref().is_some_and(|(_, scale)| *scale == 0.5) && !bumpy.attributes.tangent.is_empty());
    let mut untextured = load(&quad_gltf(material(json!({"clearcoatFactor": 1.0, "clearcoatTexture": "image"})), vec![png(2, &[RED, BLUE])], None));
    assert!(untextured.materials[0].textures.is_none());
    let (left, right) = halves(&mut untextured, Vec3::ONE);
    close(left, right, "the coat's factor everywhere");
}
