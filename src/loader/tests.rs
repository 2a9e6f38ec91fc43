//! Loader tests: every supported feature and every kind of bad input.

use super::*;
use base64::Engine;
use serde_json::{json, Value};

/// Little-endian bytes of floats / u16s.
fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}
fn u16s(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}
fn data_uri(bytes: &[u8]) -> String {
    format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes))
}

const QUAD: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];

/// One buffer: 4 quad positions (48 bytes), 4 +Z normals (48), 6 u16 indices (12).
fn quad_buffer() -> Vec<u8> {
    let mut b = f32s(&QUAD);
    b.extend(f32s(&[0.0, 0.0, 1.0].repeat(4)));
    b.extend(u16s(&[0, 1, 2, 0, 2, 3]));
    b
}

/// A scene with a camera node and a quad mesh node; tweak the JSON per test.
fn base_doc() -> Value {
    let buf = quad_buffer();
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "Cam", "camera": 0, "translation": [0.5, 0.5, 3.0]},
            {"name": "Quad", "mesh": 0}
        ],
        "cameras": [{"name": "CamData", "type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "aspectRatio": 2.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1.0], "metallicFactor": 0.25, "roughnessFactor": 0.5}}],
        "buffers": [{"byteLength": buf.len(), "uri": data_uri(&buf)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    })
}

fn load(doc: &Value) -> Result<Scene, LoadError> {
    load_bytes(doc.to_string().as_bytes(), None, "test.gltf", &LoadOptions::default())
}

fn load_err(doc: &Value) -> String {
    match load(doc) {
        Ok(_) => panic!("expected an error"),
        Err(e) => {
            let s = e.to_string();
            assert!(s.starts_with("test.gltf: "), "error must name the file: {s}");
            assert!(!s.contains('\n'), "error must be one line: {s}");
            s
        }
    }
}

#[test]
fn loads_the_base_scene() {
    let s = load(&base_doc()).unwrap();
    assert_eq!(s.triangles.len(), 2);
    assert_eq!(s.materials.len(), 1);
    let m = &s.materials[0];
    assert_eq!(m.base_color, Vec3::new(0.2, 0.4, 0.6));
    assert_eq!((m.metallic, m.roughness, m.specular), (0.25, 0.5, 1.0));
    assert_eq!(s.camera.name, "Cam");
    assert_eq!(s.camera.position, Vec3::new(0.5, 0.5, 3.0));
    assert_eq!(s.camera.aspect_ratio, Some(2.0));
    assert!((s.camera.forward - Vec3::NEG_Z).length() < 1e-6);
    // Counter-clockwise quad seen from +Z: the front face is +Z.
    for t in &s.triangles {
        assert!(t.cross().normalize().dot(Vec3::Z) > 0.999);
    }
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn the_embedded_cornell_box_loads_with_outward_shading_normals() {
    let s = load_bytes(crate::DEFAULT_SCENE.as_bytes(), None, "cornell", &LoadOptions::default()).unwrap();
    assert!(s.triangles.len() > 2000);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.materials.iter().filter(|m| m.is_emissive()).count(), 1);
    // Winding and normals agree everywhere (the sphere's smooth normals too).
    for t in &s.triangles {
        let face = t.cross().normalize();
        for n in t.n() {
            assert!(n.dot(face) > 0.5, "shading normal {n} against face {face}");
        }
    }
}

#[test]
fn non_indexed_and_flat_shaded() {
    let mut d = base_doc();
    d["meshes"][0]["primitives"][0] = json!({"attributes": {"POSITION": 0}});
    d["accessors"][0]["count"] = json!(3);
    let s = load(&d).unwrap();
    assert_eq!(s.triangles.len(), 1);
    assert_eq!(s.triangles[0].n(), [Vec3::Z; 3]);
    // No material: glTF's default (white, metallic 1, roughness 1).
    assert_eq!(s.materials[0], Material::default());
}

#[test]
fn world_transforms_through_the_hierarchy_trs_and_matrix() {
    let mut d = base_doc();
    // Parent: translate +10 x via matrix; child: scale 2 and rotate 90° about Z.
    d["nodes"] = json!([
        {"name": "Cam", "camera": 0, "translation": [0, 0, 5]},
        {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1], "children": [2]},
        {"mesh": 0, "scale": [2, 2, 2], "rotation": [0, 0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2]}
    ]);
    let s = load(&d).unwrap();
    // Vertex (1,0,0) → scaled (2,0,0) → rotated (0,2,0) → translated (10,2,0).
    let v = s.triangles[0].p()[1];
    assert!((v - Vec3::new(10.0, 2.0, 0.0)).length() < 1e-5, "{v}");
    // Normals rotate with the node: +Z stays +Z under a Z rotation.
    assert!((s.triangles[0].n()[0] - Vec3::Z).length() < 1e-5);
}

#[test]
fn mirroring_transform_keeps_the_front_face() {
    let mut d = base_doc();
    d["nodes"][1]["scale"] = json!([1, 1, -1]);
    let s = load(&d).unwrap();
    // Mirrored in z, the quad's front now faces -Z; winding is flipped to match.
    for t in &s.triangles {
        assert!(t.cross().normalize().dot(Vec3::NEG_Z) > 0.999);
        assert!(t.n()[0].dot(Vec3::NEG_Z) > 0.999);
    }
}

#[test]
fn emission_strength_double_sided_and_specular() {
    let mut d = base_doc();
    d["materials"][0]["emissiveFactor"] = json!([1.0, 0.5, 0.25]);
    d["materials"][0]["doubleSided"] = json!(true);
    d["materials"][0]["extensions"] = json!({
        "KHR_materials_emissive_strength": {"emissiveStrength": 8.0},
        "KHR_materials_specular": {"specularFactor": 0.0}
    });
    let m = &load(&d).unwrap().materials[0];
    assert_eq!(m.emission, Vec3::new(8.0, 4.0, 2.0));
    assert!(m.double_sided);
    assert_eq!(m.specular, 0.0);
}

#[test]
fn transmission_and_ior() {
    let mut d = base_doc();
    assert_eq!((load(&d).unwrap().materials[0].transmission, load(&d).unwrap().materials[0].ior), (0.0, 1.5));
    d["materials"][0]["extensions"] = json!({
        "KHR_materials_transmission": {"transmissionFactor": 0.75},
        "KHR_materials_ior": {"ior": 1.33}
    });
    let m = &load(&d).unwrap().materials[0];
    assert_eq!((m.transmission, m.ior), (0.75, 1.33));
    assert!(m.is_transmissive() && !m.is_pure_lambert());
    // Out of range: transmission is clamped, an IOR below 1 is the default.
    d["materials"][0]["extensions"] = json!({
        "KHR_materials_transmission": {"transmissionFactor": 7.0},
        "KHR_materials_ior": {"ior": 0.5}
    });
    let m = &load(&d).unwrap().materials[0];
    assert_eq!((m.transmission, m.ior), (1.0, 1.5));
}

/// KHR_materials_volume: σ_a = −ln(attenuationColor) / attenuationDistance
/// where the material has a volume (thicknessFactor > 0); none for a thin
/// wall, an infinite or non-positive distance; a black channel absorbs as
/// 10⁻⁶, finitely.
#[test]
fn volume_absorption_from_attenuation() {
    let mut d = base_doc();
    assert_eq!(load(&d).unwrap().materials[0].absorption, Vec3::ZERO);
    let volume = |v: serde_json::Value| json!({"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_volume": v});
    d["extensionsUsed"] = json!(["KHR_materials_transmission", "KHR_materials_volume"]);
    d["materials"][0]["extensions"] = volume(json!({"thicknessFactor": 0.1, "attenuationDistance": 2.0, "attenuationColor": [1.0, 0.5, 0.25]}));
    let s = load(&d).unwrap();
    let sigma = s.materials[0].absorption;
    assert!((sigma - Vec3::new(0.0, 2f32.ln() / 2.0, 4f32.ln() / 2.0)).abs().max_element() < 1e-6, "{sigma}");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    for v in [
        json!({"thicknessFactor": 0.0, "attenuationDistance": 2.0, "attenuationColor": [0.5, 0.5, 0.5]}),
        json!({"thicknessFactor": 1.0, "attenuationColor": [0.5, 0.5, 0.5]}),
        json!({"thicknessFactor": 1.0, "attenuationDistance": -1.0, "attenuationColor": [0.5, 0.5, 0.5]}),
        json!({"thicknessFactor": 1.0, "attenuationDistance": 0.0, "attenuationColor": [0.5, 0.5, 0.5]}),
    ] {
        d["materials"][0]["extensions"] = volume(v.clone());
        assert_eq!(load(&d).unwrap().materials[0].absorption, Vec3::ZERO, "{v}");
    }
    d["materials"][0]["extensions"] = volume(json!({"thicknessFactor": 1.0, "attenuationDistance": 1e-30, "attenuationColor": [0.0, 2.0, 0.5]}));
    let sigma = load(&d).unwrap().materials[0].absorption;
    assert!(sigma.is_finite() && sigma.x > 1e30 && sigma.y == 0.0, "{sigma}");
    // Malformed: one line, no panic.
    for v in [json!({"thicknessFactor": 1.0, "attenuationColor": "red"}), json!({"attenuationDistance": [1]}), json!(7)] {
        d["materials"][0]["extensions"] = volume(v.clone());
        match load(&d) {
            Ok(s) => assert_eq!(s.materials[0].absorption, Vec3::ZERO, "{v}"),
            Err(e) => assert!(!e.to_string().contains('\n'), "{v}: {e}"),
        }
    }
}

/// KHR_materials_clearcoat's two factors, as Blender's exporter writes
/// Coat Weight and Roughness: read, clamped, 0 where absent or not numbers
/// (its textures: tests/textures.rs).
#[test]
fn clearcoat_factors() {
    let mut d = base_doc();
    assert_eq!((load(&d).unwrap().materials[0].coat, load(&d).unwrap().materials[0].coat_roughness), (0.0, 0.0));
    d["extensionsUsed"] = json!(["KHR_materials_clearcoat"]);
    d["materials"][0]["extensions"] = json!({"KHR_materials_clearcoat": {"clearcoatFactor": 0.7, "clearcoatRoughnessFactor": 0.1}});
    let s = load(&d).unwrap();
    assert_eq!((s.materials[0].coat, s.materials[0].coat_roughness), (0.7, 0.1));
    assert!(s.materials[0].is_coated() && s.warnings.is_empty(), "{:?}", s.warnings);
    d["materials"][0]["extensions"] = json!({"KHR_materials_clearcoat": {"clearcoatFactor": 4.0, "clearcoatRoughnessFactor": "rough"}});
    let s = load(&d).unwrap();
    assert_eq!((s.materials[0].coat, s.materials[0].coat_roughness), (1.0, 0.0));
    d["materials"][0]["extensions"] = json!({"KHR_materials_clearcoat": {"clearcoatFactor": -1.0}});
    assert!(!load(&d).unwrap().materials[0].is_coated());
}

/// KHR_materials_anisotropy as Blender's importer reads it: the strength
/// is Anisotropic (clamped), the rotation in radians Anisotropic Rotation
/// × 2π; and the triangles of an anisotropic material carry Cycles'
/// default tangent field: about the mesh's up axis (glTF +Y), from its
/// bounds' centre (0.5, 0.5, 0) and half-size (0.5, 0.5, and 1 for the
/// flat z), turned as normals are. The quad at x = 1 has (z − 0)/2 = 0
/// and −(x − 0.5)/(2·0.5) = −0.5: (0, 0, −0.5) in local axes, and under
/// a node scaled (2, 1, 4) the inverse transpose makes it (0, 0, −1/8).
#[test]
fn anisotropy_and_its_tangent_field() {
    let mut d = base_doc();
    let s = load(&d).unwrap();
    assert_eq!((s.materials[0].anisotropy, s.materials[0].anisotropy_rotation), (0.0, 0.0));
    assert!(s.attributes.anisotropy_tangent.is_empty(), "an isotropic scene pays nothing");
    d["extensionsUsed"] = json!(["KHR_materials_anisotropy"]);
    d["materials"][0]["extensions"] = json!({"KHR_materials_anisotropy": {"anisotropyStrength": 0.8, "anisotropyRotation": std::f32::consts::FRAC_PI_2}});
    d["nodes"][1]["scale"] = json!([2.0, 1.0, 4.0]);
    let s = load(&d).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials[0];
    assert_eq!(m.anisotropy, 0.8);
    assert!((m.anisotropy_rotation - 0.25).abs() < 1e-7, "{}", m.anisotropy_rotation);
    assert_eq!(s.attributes.anisotropy_tangent.len(), s.triangles.len());
    for (t, field) in s.triangles.iter().zip(&s.attributes.anisotropy_tangent) {
        for (p, v) in t.p().iter().zip(field) {
            // World x = 2 × local x.
            let expected = Vec3::new(0.0, 0.0, -(p.x / 2.0 - 0.5) / 4.0);
            assert!((*v - expected).length() < 1e-6, "at {p}: {v} against {expected}");
        }
    }
    d["materials"][0]["extensions"] = json!({"KHR_materials_anisotropy": {"anisotropyStrength": 3.0, "anisotropyRotation": "turn"}});
    let s = load(&d).unwrap();
    assert_eq!((s.materials[0].anisotropy, s.materials[0].anisotropy_rotation), (1.0, 0.0));
    d["materials"][0]["extensions"] = json!({"KHR_materials_anisotropy": {"anisotropyStrength": -1.0}});
    assert!(load(&d).unwrap().attributes.anisotropy_tangent.is_empty());
    // A texture is named in a warning, its factors rendered.
    d["materials"][0]["name"] = json!("Brushed");
    d["materials"][0]["extensions"] = json!({"KHR_materials_anisotropy": {"anisotropyStrength": 0.5, "anisotropyTexture": {"index": 0}}});
    let s = load(&d).unwrap();
    assert_eq!(s.materials[0].anisotropy, 0.5);
    assert_eq!(s.warnings, ["Brushed: the anisotropy texture is not read yet, only its strength and rotation factors"]);
}

/// A Tangent node's tangent for an anisotropic material, as Cycles' Tangent
/// node gives it: Radial about Blender's X, (0, −d_z, d_y) in glTF's axes,
/// and about Y, (−d_y, d_x, 0), with d the position in the mesh's bounds
/// (here (x − 0.5, y − 0.5, z/2)); a UV map's MikkTSpace tangent (the
/// quad's u runs along +x) turned by the inverse transpose (a node scaled
/// 2× along x halves it). Without UVs the field is zero (Cycles' Tangent
/// node gives none either). A request names one source, else one line.
#[test]
fn a_tangent_node_gives_the_anisotropy_its_tangent() {
    let mut d = base_doc();
    d["extensionsUsed"] = json!(["KHR_materials_anisotropy"]);
    d["materials"][0]["name"] = json!("Brushed");
    d["materials"][0]["extensions"] = json!({"KHR_materials_anisotropy": {"anisotropyStrength": 0.5}});
    let with = |source: TangentSource, d: &Value| {
        let options = LoadOptions { anisotropy_tangents: vec![("Brushed".into(), source)], ..LoadOptions::default() };
        let s = load_bytes(d.to_string().as_bytes(), None, "test.gltf", &options).unwrap();
        assert_eq!(s.materials[0].anisotropy_tangent, source);
        s.triangles.iter().zip(&s.attributes.anisotropy_tangent).flat_map(|(t, f)| t.p().into_iter().zip(*f)).collect::<Vec<_>>()
    };
    for (p, v) in with(TangentSource::Radial(Axis::X), &d) {
        assert!((v - Vec3::new(0.0, 0.0, p.y - 0.5)).length() < 1e-6, "about X at {p}: {v}");
    }
    for (p, v) in with(TangentSource::Radial(Axis::Y), &d) {
        assert!((v - Vec3::new(-(p.y - 0.5), p.x - 0.5, 0.0)).length() < 1e-6, "about Y at {p}: {v}");
    }
    assert!(with(TangentSource::UvMap(0), &d).iter().all(|(_, v)| *v == Vec3::ZERO), "no TEXCOORD_0: no tangent");
    let mut uv = d.clone();
    let mut buf = quad_buffer();
    buf.extend(f32s(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0]));
    uv["buffers"][0] = json!({"byteLength": buf.len(), "uri": data_uri(&buf)});
    uv["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 0, "byteOffset": 108, "byteLength": 32}));
    uv["accessors"].as_array_mut().unwrap().push(json!({"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"}));
    uv["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(3);
    uv["nodes"][1]["scale"] = json!([2.0, 1.0, 1.0]);
    for (p, v) in with(TangentSource::UvMap(0), &uv) {
        assert!((v - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6, "UV map at {p}: {v}");
    }
    let request: crate::request::AnisotropyTangent = serde_json::from_str(r#"{"material": "Brushed", "radial_axis": "Y"}"#).unwrap();
    assert_eq!(request.source(), Ok(TangentSource::Radial(Axis::Y)));
    for bad in [r#"{"material": "Brushed"}"#, r#"{"material": "Brushed", "radial_axis": "X", "uv_map": 0}"#, r#"{"material": "Brushed", "uv_map": 2}"#] {
        let e = serde_json::from_str::<crate::request::AnisotropyTangent>(bad).unwrap().source().unwrap_err();
        assert!(e.starts_with("anisotropy tangent of 'Brushed'") && !e.contains('\n'), "{e}");
    }
}

/// A node hidden from the camera gets copies of its materials marked so,
/// made once per material; another node's triangles keep the original.
#[test]
fn nodes_hidden_from_the_camera_get_hidden_copies_of_their_materials() {
    let mut d = base_doc();
    d["nodes"].as_array_mut().unwrap().push(json!({"name": "Card", "mesh": 0, "translation": [0.0, 0.0, 1.0]}));
    d["scenes"][0]["nodes"] = json!([0, 1, 2]);
    let options = LoadOptions { hidden_from_camera: vec!["Card".into(), "Nothing".into()], ..LoadOptions::default() };
    let s = load_bytes(d.to_string().as_bytes(), None, "test.gltf", &options).unwrap();
    assert_eq!(s.materials.len(), 2);
    let hidden: Vec<bool> = s.triangles.iter().map(|t| s.materials[t.material as usize].hidden_from_camera).collect();
    assert_eq!(hidden, [false, false, true, true]);
    assert_eq!(Material { hidden_from_camera: false, ..s.materials[1].clone() }, s.materials[0]);
    assert!(load(&d).unwrap().materials.iter().all(|m| !m.hidden_from_camera));
}

/// A node hidden from other rays gets its own copies, one per material
/// and set of kinds, hidden from the camera too where both are asked;
/// an emitting material keeps its scattered rays, with a warning naming it.
#[test]
fn nodes_hidden_from_rays_get_copies_and_emitters_keep_their_scattered_rays() {
    use crate::material::Rays;
    let mut d = base_doc();
    d["nodes"].as_array_mut().unwrap().push(json!({"name": "Card", "mesh": 0, "translation": [0.0, 0.0, 1.0]}));
    d["scenes"][0]["nodes"] = json!([0, 1, 2]);
    let shadow_glossy = Rays::SHADOW.union(Rays::GLOSSY);
    let options = LoadOptions { hidden_from_camera: vec!["Card".into()], hidden_from_rays: vec![("Card".into(), Rays::SHADOW), ("Card".into(), Rays::GLOSSY), ("Nothing".into(), Rays::DIFFUSE)], ..LoadOptions::default() };
    let s = load_bytes(d.to_string().as_bytes(), None, "test.gltf", &options).unwrap();
    let hidden: Vec<(bool, Rays)> = s.triangles.iter().map(|t| &s.materials[t.material as usize]).map(|m| (m.hidden_from_camera, m.hidden_from_rays)).collect();
    assert_eq!(hidden, [(false, Rays::NONE), (false, Rays::NONE), (true, shadow_glossy), (true, shadow_glossy)]);
    assert!(s.warnings.iter().all(|w| !w.contains("emits")), "{:?}", s.warnings);
    d["materials"][0]["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    let s = load_bytes(d.to_string().as_bytes(), None, "test.gltf", &options).unwrap();
    let hidden: Vec<Rays> = s.triangles.iter().map(|t| s.materials[t.material as usize].hidden_from_rays).collect();
    assert_eq!(hidden, [Rays::NONE, Rays::NONE, Rays::SHADOW, Rays::SHADOW]);
    let name = &s.materials[0].name;
    assert!(s.warnings.iter().any(|w| w.starts_with(&format!("material '{name}' emits light on an object hidden from diffuse, glossy or transmission rays"))), "{:?}", s.warnings);
}

/// KHR_materials_specular's specularColorFactor is Blender's Specular
/// Tint: read and clamped, for metals and the dielectric layer alike.
#[test]
fn specular_colour_is_the_metal_tint() {
    let mut d = base_doc();
    assert_eq!(load(&d).unwrap().materials[0].specular_tint, Vec3::ONE);
    d["extensionsUsed"] = json!(["KHR_materials_specular"]);
    d["materials"][0]["pbrMetallicRoughness"] = json!({"metallicFactor": 1.0});
    d["materials"][0]["extensions"] = json!({"KHR_materials_specular": {"specularColorFactor": [0.3, 1.6, -1.0]}});
    let s = load(&d).unwrap();
    assert_eq!(s.materials[0].specular_tint, Vec3::new(0.3, 1.0, 0.0));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn factors_outside_gltf_ranges_are_clamped() {
    let mut d = base_doc();
    d["materials"][0]["pbrMetallicRoughness"] = json!({"baseColorFactor": [2.0, -1.0, 0.5, 1.0], "metallicFactor": 3.0, "roughnessFactor": -2.0});
    let m = &load(&d).unwrap().materials[0];
    assert_eq!(m.base_color, Vec3::new(1.0, 0.0, 0.5));
    assert_eq!((m.metallic, m.roughness), (1.0, 0.0));
}

#[test]
fn non_triangle_modes_are_skipped_with_a_count() {
    let mut d = base_doc();
    let p = d["meshes"][0]["primitives"][0].clone();
    let mut lines = p.clone();
    lines["mode"] = json!(1);
    let mut points = p.clone();
    points["mode"] = json!(0);
    d["meshes"][0]["primitives"] = json!([p, lines.clone(), lines, points]);
    let s = load(&d).unwrap();
    assert_eq!(s.triangles.len(), 2);
    assert!(s.warnings.iter().any(|w| w.contains("skipped 2 primitive(s) with mode Lines")), "{:?}", s.warnings);
    assert!(s.warnings.iter().any(|w| w.contains("skipped 1 primitive(s) with mode Points")));
}

#[test]
fn punctual_lights_load_with_their_transform_and_bad_ones_are_counted() {
    use crate::punctual::PunctualKind;
    let mut d = base_doc();
    d["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    d["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "intensity": 10.0, "color": [1.0, 0.5, 0.25]},
        {"type": "spot", "intensity": 2.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.4}},
        {"type": "directional", "intensity": 3.0},
        {"type": "laser", "intensity": 3.0}
    ]}});
    let nodes = d["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "Bulb", "translation": [1.0, 2.0, 3.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    // Rotated −90° about X: −Z turns to −Y, straight down.
    nodes.push(json!({"name": "Spot", "rotation": [-0.70710677, 0.0, 0.0, 0.70710677], "extensions": {"KHR_lights_punctual": {"light": 1}}}));
    nodes.push(json!({"name": "Sun", "extensions": {"KHR_lights_punctual": {"light": 2}}}));
    nodes.push(json!({"name": "Bad", "extensions": {"KHR_lights_punctual": {"light": 3}}}));
    nodes.push(json!({"name": "Missing", "extensions": {"KHR_lights_punctual": {"light": 9}}}));
    d["scenes"][0]["nodes"] = json!([0, 1, 2, 3, 4, 5, 6]);
    let s = load(&d).unwrap();
    assert_eq!(s.punctual.len(), 3);
    let (bulb, spot, sun) = (&s.punctual[0], &s.punctual[1], &s.punctual[2]);
    assert_eq!((bulb.kind, bulb.position, bulb.intensity), (PunctualKind::Point, Vec3::new(1.0, 2.0, 3.0), Vec3::new(10.0, 5.0, 2.5)));
    assert!((spot.direction - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-5, "{}", spot.direction);
    assert!(matches!(spot.kind, PunctualKind::Spot { cos_outer, smooth } if (cos_outer - 0.4f32.cos()).abs() < 1e-6 && smooth > 0.0));
    assert_eq!((sun.kind, sun.direction), (PunctualKind::Sun, Vec3::new(0.0, 0.0, -1.0)));
    assert!(s.warnings.iter().any(|w| w.contains("left out 2 punctual light(s)")), "{:?}", s.warnings);
}

#[test]
fn cameras_first_of_either_kind_by_name_and_errors() {
    let mut d = base_doc();
    d["cameras"] = json!([
        {"name": "Ortho", "type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1, "znear": 0.1, "zfar": 10}},
        {"name": "Persp", "type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}
    ]);
    d["nodes"] = json!([
        {"name": "OrthoNode", "camera": 0},
        {"name": "Quad", "mesh": 0, "children": [2]},
        {"name": "PerspNode", "camera": 1, "translation": [0, 0, 2]}
    ]);
    d["scenes"][0]["nodes"] = json!([0, 1]);
    // Depth first, the orthographic camera comes first.
    let s = load(&d).unwrap();
    assert_eq!(s.camera.name, "OrthoNode");
    assert_eq!(s.camera.projection, Projection::Orthographic { half_height: 1.0 });
    assert_eq!(s.camera.aspect_ratio, Some(2.0));
    let by_name = |d: &serde_json::Value, n: &str| load_bytes(d.to_string().as_bytes(), None, "test.gltf", &LoadOptions { camera: Some(n.into()), ..Default::default() });
    let persp = by_name(&d, "Persp").unwrap().camera;
    assert_eq!((persp.name.as_str(), persp.projection), ("PerspNode", Projection::Perspective { yfov: 0.5 }));
    // znear and zfar are Clip Start and End; a perspective camera without
    // zfar clips nothing far.
    assert_eq!((s.camera.clip, persp.clip), ([0.1, 10.0], [0.1, f32::INFINITY]));
    assert!(by_name(&d, "Nope").unwrap_err().to_string().contains("no camera named 'Nope'"));
    // What the glTF schema forbids or advises against: one line, naming
    // the camera and the value.
    for (field, value, message) in [("ymag", json!(0), "has ymag 0"), ("ymag", json!(-1), "has ymag -1"), ("znear", json!(-0.5), "has znear -0.5"), ("ymag", json!(1e30), "which must be in (0, 1e15] m"), ("zfar", json!(0.05), "has zfar 0.05, which must be beyond znear")] {
        let mut bad = d.clone();
        bad["cameras"][0]["orthographic"][field] = value;
        let e = by_name(&bad, "Ortho").unwrap_err().to_string();
        assert!(e.contains("camera 'OrthoNode'") && e.contains(message) && !e.contains('\n'), "{e}");
    }
    // An unknown type: the one projection object the camera has.
    let mut fisheye = d.clone();
    fisheye["cameras"][0]["type"] = json!("fisheye");
    assert_eq!(load(&fisheye).unwrap().camera.projection, Projection::Orthographic { half_height: 1.0 });
    d["nodes"][2].as_object_mut().unwrap().remove("camera");
    d["nodes"][0].as_object_mut().unwrap().remove("camera");
    assert!(load_err(&d).contains("the scene has no camera"));
}

#[test]
fn scene_index_picks_the_scene() {
    let mut d = base_doc();
    d["scenes"] = json!([{"nodes": [0]}, {"nodes": [0, 1]}]);
    d["scene"] = json!(0);
    assert_eq!(load(&d).unwrap().triangles.len(), 0);
    let two = load_bytes(d.to_string().as_bytes(), None, "t", &LoadOptions { scene_index: Some(1), ..Default::default() }).unwrap();
    assert_eq!(two.triangles.len(), 2);
    let bad = load_bytes(d.to_string().as_bytes(), None, "t", &LoadOptions { scene_index: Some(7), ..Default::default() });
    assert!(bad.unwrap_err().to_string().contains("scene 7 does not exist"));
}

#[test]
fn only_referenced_data_is_read() {
    let mut d = base_doc();
    // An unreferenced mesh with a broken accessor, and an unreferenced
    // buffer pointing at a file that does not exist: neither is touched.
    d["meshes"].as_array_mut().unwrap().push(json!({"primitives": [{"attributes": {"POSITION": 3}}]}));
    d["accessors"].as_array_mut().unwrap().push(json!({"bufferView": 3, "componentType": 5126, "count": 1000, "type": "VEC3"}));
    d["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 1, "byteLength": 12000}));
    d["buffers"].as_array_mut().unwrap().push(json!({"byteLength": 12000, "uri": "missing.bin"}));
    d["materials"].as_array_mut().unwrap().push(json!({"pbrMetallicRoughness": {}}));
    let s = load(&d).unwrap();
    assert_eq!(s.triangles.len(), 2);
    assert_eq!(s.materials.len(), 1, "unused materials are not converted");
}

#[test]
fn bad_inputs_are_one_line_errors() {
    // Malformed JSON.
    let e = load_bytes(b"{\"asset\": ", None, "test.gltf", &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.starts_with("test.gltf: not valid glTF JSON"), "{e}");
    // Out-of-range index.
    let mut d = base_doc();
    let mut buf = quad_buffer();
    buf.splice(96..108, u16s(&[0, 1, 9, 0, 2, 3]));
    d["buffers"][0]["uri"] = json!(data_uri(&buf));
    assert!(load_err(&d).contains("index 9 is out of range (4 vertices)"));
    // Accessor past its view, view past its buffer, short buffer.
    let mut d = base_doc();
    d["accessors"][0]["count"] = json!(5);
    assert!(load_err(&d).contains("runs past its bufferView"));
    let mut d = base_doc();
    d["bufferViews"][2]["byteLength"] = json!(1000);
    assert!(load_err(&d).contains("runs past its buffer"));
    let mut d = base_doc();
    d["buffers"][0]["byteLength"] = json!(4000);
    assert!(load_err(&d).contains("byteLength says 4000"));
    // Huge counts do not allocate.
    let mut d = base_doc();
    d["accessors"][0] = json!({"componentType": 5126, "count": 4_000_000_000u64, "type": "VEC3"});
    assert!(load_err(&d).contains("larger than Glint reads"));
    // Missing POSITION, missing accessor, wrong type.
    let mut d = base_doc();
    d["meshes"][0]["primitives"][0]["attributes"] = json!({"NORMAL": 1});
    assert!(load_err(&d).contains("no POSITION"));
    let mut d = base_doc();
    d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(42);
    assert!(load_err(&d).contains("accessor 42 does not exist"));
    let mut d = base_doc();
    d["accessors"][0]["type"] = json!("VEC2");
    assert!(load_err(&d).contains("expected one of"));
    // An attribute whose count is not POSITION's, named as glTF names it.
    let mut d = base_doc();
    d["accessors"][1]["count"] = json!(3);
    assert!(load_err(&d).contains("NORMAL has 3 elements, POSITION 4"), "{}", load_err(&d));
    // Node cycle.
    let mut d = base_doc();
    d["nodes"][1]["children"] = json!([1]);
    assert!(load_err(&d).contains("reached twice"));
    // Unsupported required extension; wrong version.
    let mut d = base_doc();
    d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    assert!(load_err(&d).contains("KHR_draco_mesh_compression"));
    let mut d = base_doc();
    d["asset"]["version"] = json!("1.0");
    assert!(load_err(&d).contains("version"));
    // External file without a folder; a URI escaping the folder.
    let mut d = base_doc();
    d["buffers"][0]["uri"] = json!("../secret.bin");
    assert!(load_err(&d).contains("has no folder"));
}

#[test]
fn non_finite_and_zero_area_triangles_are_dropped_with_counts() {
    let mut d = base_doc();
    let mut buf = f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, f32::NAN, 1.0, 0.0, 2.0, 0.0, 0.0]);
    buf.extend(f32s(&[0.0, 0.0, 1.0].repeat(4)));
    // Triangle 0-1-2 has a NaN, 0-1-3 is collinear (zero area), 0-1-0 repeats a vertex.
    buf.extend(u16s(&[0, 1, 2, 0, 1, 3]));
    d["buffers"][0] = json!({"byteLength": buf.len(), "uri": data_uri(&buf)});
    let s = load(&d).unwrap();
    assert_eq!(s.triangles.len(), 0);
    assert!(s.warnings.iter().any(|w| w.contains("dropped 1 triangle(s) with NaN")), "{:?}", s.warnings);
    assert!(s.warnings.iter().any(|w| w.contains("dropped 1 zero-area")));
}

#[test]
fn bad_normals_fall_back_to_the_face_normal() {
    let mut d = base_doc();
    let mut buf = f32s(&QUAD);
    buf.extend(f32s(&[0.0, 0.0, 0.0, f32::NAN, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    buf.extend(u16s(&[0, 1, 2, 0, 2, 3]));
    d["buffers"][0]["uri"] = json!(data_uri(&buf));
    let s = load(&d).unwrap();
    for t in &s.triangles {
        for n in t.n() {
            assert!((n - Vec3::Z).length() < 1e-6);
        }
    }
    assert!(s.warnings.iter().any(|w| w.contains("vertex normal")));
}

#[test]
fn glb_with_bin_chunk_and_external_files() {
    let dir = std::env::temp_dir().join(format!("glint-loader-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let buf = quad_buffer();
    // .gltf + .bin in a folder, with a percent-encoded name.
    std::fs::write(dir.join("quad data.bin"), &buf).unwrap();
    let mut d = base_doc();
    d["buffers"][0]["uri"] = json!("quad%20data.bin");
    std::fs::write(dir.join("scene.gltf"), d.to_string()).unwrap();
    assert_eq!(load_file(&dir.join("scene.gltf"), &LoadOptions::default()).unwrap().triangles.len(), 2);
    // The same as GLB with a BIN chunk.
    d["buffers"][0].as_object_mut().unwrap().remove("uri");
    let glb = glb_file(&d, &buf);
    std::fs::write(dir.join("scene.glb"), &glb).unwrap();
    assert_eq!(load_file(&dir.join("scene.glb"), &LoadOptions::default()).unwrap().triangles.len(), 2);
    // Missing file and a folder instead of a file.
    let e = load_file(&dir.join("nope.gltf"), &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("nope.gltf"), "{e}");
    assert!(load_file(&dir, &LoadOptions::default()).unwrap_err().to_string().contains("not a regular file"));
    // A URI that leaves the folder.
    d["buffers"][0]["uri"] = json!("../quad%20data.bin");
    std::fs::write(dir.join("escape.gltf"), d.to_string()).unwrap();
    assert!(load_file(&dir.join("escape.gltf"), &LoadOptions::default()).unwrap_err().to_string().contains("leaves the scene's folder"));
    std::fs::remove_dir_all(&dir).unwrap();
}

fn glb_file(doc: &Value, bin: &[u8]) -> Vec<u8> {
    glb::tests::glb(doc.to_string().as_bytes(), Some(bin), None)
}

/// A file's buffer that also holds data no node references (here 4 MB
/// behind an unused mesh): only the bufferViews the scene uses are read,
/// from a GLB's BIN chunk and from an external .bin alike.
#[test]
fn unreferenced_bytes_of_a_file_stay_on_disk() {
    let dir = std::env::temp_dir().join(format!("glint-loader-unused-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut buf = quad_buffer();
    let used = buf.len() as u64;
    let unused = 4 << 20;
    buf.extend(std::iter::repeat_n(7u8, unused));
    let mut d = base_doc();
    d["buffers"][0] = json!({"byteLength": buf.len()});
    d["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 0, "byteOffset": used, "byteLength": unused}));
    d["accessors"].as_array_mut().unwrap().push(json!({"bufferView": 3, "componentType": 5126, "count": unused / 12, "type": "VEC3"}));
    d["meshes"].as_array_mut().unwrap().push(json!({"primitives": [{"attributes": {"POSITION": 3}}]}));
    std::fs::write(dir.join("scene.glb"), glb_file(&d, &buf)).unwrap();
    std::fs::write(dir.join("data.bin"), &buf).unwrap();
    d["buffers"][0]["uri"] = json!("data.bin");
    std::fs::write(dir.join("scene.gltf"), d.to_string()).unwrap();
    for name in ["scene.glb", "scene.gltf"] {
        let scene = load_file(&dir.join(name), &LoadOptions::default()).unwrap();
        assert_eq!(scene.triangles.len(), 2);
        assert_eq!(scene.bytes_read, used, "{name}: read {} bytes, the scene uses {used}", scene.bytes_read);
        // Checking the whole file does read it all.
        assert_eq!(inspect_file(&dir.join(name)).unwrap().triangles, 2);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sparse_accessor_overrides_values() {
    let mut d = base_doc();
    let mut buf = quad_buffer();
    let sparse_at = buf.len();
    buf.extend(u16s(&[2, 0])); // index 2
    buf.extend(f32s(&[5.0, 5.0, 0.0]));
    d["buffers"][0] = json!({"byteLength": buf.len(), "uri": data_uri(&buf)});
    d["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 0, "byteOffset": sparse_at, "byteLength": 2}));
    d["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 0, "byteOffset": sparse_at + 4, "byteLength": 12}));
    d["accessors"][0]["sparse"] = json!({"count": 1, "indices": {"bufferView": 3, "componentType": 5123}, "values": {"bufferView": 4}});
    let s = load(&d).unwrap();
    assert_eq!(s.triangles[0].p()[2], Vec3::new(5.0, 5.0, 0.0));
}
