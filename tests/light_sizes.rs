//! The request's light_sizes reach the named point, spot and sun lights,
//! and a bad size is a one-line error naming the light.

use glint::job::{prepare, JobOptions, SceneExtras};
use glint::request::LightSize;
use serde_json::json;

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

    let size = |name: &str, radius: f32, soft_falloff: bool, angle: f32| LightSize { name: name.into(), radius, soft_falloff, angle };
    let sizes = [size("Lamp", 0.25, false, 0.0), size("Sun", 0.0, true, 0.02)];
    let job = prepare(Some(&path), &JobOptions::default(), SceneExtras { light_sizes: &sizes, ..SceneExtras::default() }).unwrap();
    let find = |n: &str| job.scene.punctual.iter().find(|l| l.name == n).unwrap();
    assert_eq!((find("Lamp").size, find("Lamp").sphere), (0.25, true));
    assert_eq!((find("Sun").size, find("Sun").sphere), (0.01, false), "a sun's size is half its angle");
    // Without sizes the lights stay punctual.
    let job = prepare(Some(&path), &JobOptions::default(), SceneExtras::default()).unwrap();
    assert!(job.scene.punctual.iter().all(|l| l.size == 0.0));
    let bad = [size("Lamp", -1.0, true, 0.0)];
    let err = prepare(Some(&path), &JobOptions::default(), SceneExtras { light_sizes: &bad, ..SceneExtras::default() }).err().unwrap();
    assert!(err.contains("lights.gltf") && err.contains("Lamp") && !err.contains('\n'), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
