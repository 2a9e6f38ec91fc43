//! The request's light_sizes reach the named point, spot and sun lights,
//! and a bad size is a one-line error naming the light. A sized light is
//! seen by BSDF rays (a mirror shows it) but not by the camera (unless it
//! may: a sun past Clip End too), and
//! weighting its light samples against those rays (MIS) leaves the image
//! what light sampling alone gives.

mod common;

use common::{channel_mean, horizontal_quad, look_at, render, settings};
use glint::Vec3;
use glint::job::{prepare, JobOptions, SceneExtras};
use glint::material::Material;
use glint::punctual::{PunctualKind, PunctualLight};
use glint::request::LightSize;
use glint::scene::Scene;
use serde_json::json;
use std::f32::consts::PI;

/// A metal floor (F0 = 0.9) 20 m wide at y = 0, seen from 5 m straight
/// above, under `light`.
fn metal_floor(roughness: f32, light: PunctualLight) -> Scene {
    let metal = Material { name: "metal".into(), base_color: Vec3::splat(0.9), metallic: 1.0, roughness, ..Material::default() };
    let mut scene = Scene::new(horizontal_quad(Vec3::ZERO, 10.0, 0.0, true, 0), vec![metal], look_at(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, 0.6));
    scene.punctual.push(light);
    scene
}

fn lamp(sphere: bool) -> PunctualLight {
    PunctualLight { name: "lamp".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, 2.0, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(50.0), size: 0.5, sphere, camera_sees: false, shadowless: false }
}

#[test]
fn a_mirror_shows_a_sized_light_the_camera_does_not() {
    for sphere in [false, true] {
        // The camera looks down through the lamp at its reflection: normal
        // incidence, so F = F0 = 0.9 exactly.
        let scene = metal_floor(0.0, lamp(sphere));
        let mut s = settings(9, 9, 4, 2, 1);
        s.mis = true;
        let (img, _) = render(&scene, &s, 1);
        let centre = img[4 * 9 + 4];
        let expected = 0.9 * 50.0 / (PI * 0.25);
        assert!((centre.x - expected).abs() < 1e-3 * expected, "sphere {sphere}: {centre} vs {expected}");
        // The corners see the mirror reflect the black sky.
        assert_eq!(img[0], Vec3::ZERO);
        // Seen by the camera too, the ray passes on through the lamp to
        // its reflection: (1 + 0.9)·L.
        let scene = metal_floor(0.0, PunctualLight { camera_sees: true, ..lamp(sphere) });
        let centre = render(&scene, &s, 1).0[4 * 9 + 4];
        assert!((centre.x - expected / 0.9 * 1.9).abs() < 1e-3 * expected, "sphere {sphere}: {centre} vs {}", expected / 0.9 * 1.9);
    }
    // A punctual light is never seen.
    let scene = metal_floor(0.0, PunctualLight { size: 0.0, ..lamp(false) });
    let mut s = settings(9, 9, 4, 2, 1);
    s.mis = true;
    assert!(render(&scene, &s, 1).0.iter().all(|p| *p == Vec3::ZERO));
}

/// On a rough metal, where BSDF rays find the light often, the MIS image
/// (light samples and BSDF rays, each weighted) has the mean of light
/// sampling alone, within 4 standard errors of the two.
#[test]
fn mis_with_sized_lights_keeps_the_light_sampling_mean() {
    let sun = PunctualLight { kind: PunctualKind::Sun, direction: Vec3::new(0.3, -1.0, 0.0).normalize(), intensity: Vec3::splat(3.0), size: 0.2, ..lamp(false) };
    let spot = PunctualLight { kind: PunctualLight::spot(0.9, 0.5), direction: Vec3::new(0.2, -1.0, 0.0).normalize(), ..lamp(true) };
    for (what, light) in [("disk", lamp(false)), ("sphere", lamp(true)), ("spot", spot), ("sun", sun)] {
        let scene = metal_floor(0.3, light);
        let means = [false, true].map(|mis| {
            (0..4)
                .map(|seed| {
                    let mut s = settings(24, 24, 32, 3, seed);
                    s.mis = mis;
                    channel_mean(&render(&scene, &s, 2).0)
                })
                .collect::<Vec<_>>()
        });
        let stats = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / ((v.len() - 1) * v.len()) as f64)
        };
        let ((a, va), (b, vb)) = (stats(&means[0]), stats(&means[1]));
        let z = (a - b).abs() / (va + vb).sqrt();
        eprintln!("{what}: light sampling {a:.5}, MIS {b:.5}, {z:.1} σ");
        assert!(a > 0.01 && z < 4.0, "{what}: light sampling {a} vs MIS {b} ({z:.1} σ)");
    }
}

#[test]
fn light_sizes_reach_the_named_lights_and_bad_ones_are_errors() {
    let cornell = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box-diffuse.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&cornell).unwrap();
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"name": "Lamp", "type": "point", "intensity": 10.0},
        {"name": "Sun", "type": "directional", "intensity": 2.0}
    ]}});
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "Lamp", "translation": [0.0, 1.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    nodes.push(json!({"name": "Sun", "extensions": {"KHR_lights_punctual": {"light": 1}}}));
    let (lamp, sun) = (nodes.len() - 2, nodes.len() - 1);
    doc["scenes"][0]["nodes"].as_array_mut().unwrap().extend([json!(lamp), json!(sun)]);
    let dir = std::env::temp_dir().join(format!("glint-light-sizes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("lights.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();

    let size = |name: &str, radius: f32, soft_falloff: bool, angle: f32| LightSize { name: name.into(), radius, soft_falloff, angle, visible_camera: false, cast_shadow: true };
    let sizes = [size("Lamp", 0.25, false, 0.0), size("Sun", 0.0, true, 0.02)];
    let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { light_sizes: &sizes, ..SceneExtras::default() }).unwrap();
    let find = |n: &str| job.scene.punctual.iter().find(|l| l.name == n).unwrap();
    assert_eq!((find("Lamp").size, find("Lamp").sphere), (0.25, true));
    assert_eq!((find("Sun").size, find("Sun").sphere), (0.01, false), "a sun's size is half its angle");
    // A radius within 1e-5 of the light's distance from the origin (at
    // least 1 m) is a point's: rounding decides a ray's test against it.
    for (radius, kept) in [(1e-30, 0.0), (1e-8, 0.0), (1e-5, 0.0), (2e-5, 2e-5)] {
        let sizes = [size("Lamp", radius, true, 0.0)];
        let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { light_sizes: &sizes, ..SceneExtras::default() }).unwrap();
        assert_eq!(job.scene.punctual.iter().find(|l| l.name == "Lamp").unwrap().size, kept, "radius {radius}");
    }
    // Without sizes the lights stay punctual.
    let job = prepare(Some(&path), &JobOptions::default(), SceneExtras::default()).unwrap();
    assert!(job.scene.punctual.iter().all(|l| l.size == 0.0));
    let bad = [size("Lamp", -1.0, true, 0.0)];
    let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { light_sizes: &bad, ..SceneExtras::default() }).err().unwrap();
    assert!(err.contains("lights.gltf") && err.contains("Lamp") && !err.contains('\n'), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A camera with a Clip End (Blender's, through glTF's zfar) sees a sun
/// it is allowed to see: a ray that reaches Clip End without a hit has
/// left the scene, as in Cycles, where it shows the World, and the sun's
/// disk is part of that sky (it had been hidden, as if something stood in
/// front of it).
#[test]
fn a_camera_with_a_clip_end_sees_the_sun_it_may_see() {
    let sun = PunctualLight { kind: PunctualKind::Sun, direction: -Vec3::Y, intensity: Vec3::splat(3.0), size: 0.05, camera_sees: true, ..lamp(false) };
    let mut scene = Scene::new(vec![], vec![], look_at(Vec3::ZERO, Vec3::Y, 0.01));
    scene.punctual.push(sun);
    let expected = 3.0 / (PI * 0.05f32.sin().powi(2));
    for clip in [[0.0, f32::INFINITY], [0.1, 100.0]] {
        scene.camera.clip = clip;
        let img = render(&scene, &settings(3, 3, 1, 2, 1), 1).0;
        assert!(img.iter().all(|p| (p.x - expected).abs() < 1e-4 * expected), "clip {clip:?}: {:?} vs {expected}", img[4]);
    }
}

/// A sized point light the camera may see is an object between the clip
/// planes, as in Cycles: 2 m in front of the camera it is seen with Clip
/// Start 0.1 and End 100, not with Start 2.5 (nearer than that) nor with
/// End 1.2 (its sphere starts at 1.5 m).
#[test]
fn a_sized_light_the_camera_sees_is_clipped_as_an_object() {
    let bulb = PunctualLight { position: Vec3::new(0.0, 2.0, 0.0), camera_sees: true, ..lamp(true) };
    let mut scene = Scene::new(vec![], vec![], look_at(Vec3::ZERO, Vec3::Y, 0.01));
    scene.punctual.push(bulb);
    let radiance = 50.0 / (PI * 0.25);
    for (clip, seen) in [([0.1, 100.0], true), ([2.5, 100.0], false), ([0.1, 1.2], false)] {
        scene.camera.clip = clip;
        let centre = render(&scene, &settings(3, 3, 1, 2, 1), 1).0[4];
        let want = if seen { radiance } else { 0.0 };
        assert!((centre.x - want).abs() < 1e-4 * radiance, "clip {clip:?}: {centre} vs {want}");
    }
}
