//! Render requests with values no add-on writes: each field of a request
//! that uses every feature, replaced (one to three at a time, in a seeded
//! sequence) by an extreme or ill-typed value, must end `glint render` on
//! the default scene with an image or with one line of error and exit 1 —
//! never a panic, a hang or a multi-line error. Found this way: a Noise
//! Threshold of 1e-30 that looped for ever, and a time limit of 1e300 s
//! that panicked.

use glint::rng::Rng;
use serde_json::{json, Value};
use std::process::Command;
use std::time::{Duration, Instant};

/// A request that turns on nearly everything a request can, on the
/// default Cornell box's materials (white, red, green, gold, light), at a
/// size that renders in milliseconds.
fn full_request() -> Value {
    json!({
        "width": 8, "height": 8, "samples": 2, "max_depth": 5, "seed": 1, "time_limit": 0,
        "noise_threshold": 0.01, "adaptive_min_samples": 0, "light_paths": true, "mis": true, "bsdf": "principled",
        "background": [0.1, 0.2, 0.3], "two_sided_emission": true, "default_surface": [0.8, 0.8, 0.8],
        "camera_world": {"background": [0.5, 0.5, 0.5]},
        "single_scatter_materials": ["gold"],
        "diffuse_roughness": [{"material": "gold", "roughness": 0.5}],
        "coat_tints": [{"material": "white", "tint": [0.5, 0.2, 0.1]}],
        "volume_absorption": [{"material": "red", "color": [0.8, 0.1, 0.2], "density": 12}],
        "bsdf_nodes": [{"material": "red", "node": "translucent", "color": [0.5, 0.5, 0.5]}],
        "shader_mixes": [{"weight": 0.5, "mixed": {"material": "white", "node": "glass", "color": [1, 1, 1], "roughness": 0.2, "ior": 1.45}}],
        "hidden_from_camera": ["Cornell box"],
        "hidden_from_rays": [{"object": "Cornell box", "rays": ["shadow", "glossy"]}],
        "anisotropy_tangents": [{"material": "gold", "uv_map": 0}],
        "area_lights": [{"name": "A", "shape": "DISK", "size": [0.5, 0.5], "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1.5, 0, 1], "color": [1, 1, 1], "power": 50, "spread": 1.0, "cast_shadow": true}],
        "light_sizes": [{"name": "Point", "radius": 0.1, "soft_falloff": true, "visible_camera": false, "cast_shadow": true}],
        "lens": {"shift": [0.1, 0], "aperture": {"radius": 0.01, "focus_distance": 2}},
        "transparent_film": true, "transparent_glass": 0.1,
        "pixel_filter": {"type": "gaussian", "width": 1.5}
    })
}

/// Values a field may be given instead of its own.
fn odd_values() -> Vec<Value> {
    json!([0, -1, 1, 2, 65, 4096, 1e-30, -1e-30, 1e9, 1e30, -1e30, 3.4e38, 1e300, 0.5, "x", "glass", "X", null, [], {}, true, [1e30, 1e30, 1e30], [-1, 0, 0], [0, 0]])
        .as_array()
        .unwrap()
        .clone()
}

/// Replace one value somewhere in `v`: a random field (or element), or
/// one inside it.
fn mutate(v: &mut Value, rng: &mut Rng, odd: &[Value]) {
    let pick = |n: usize, rng: &mut Rng| (rng.next_u32() as usize) % n;
    let slot = match v {
        Value::Object(map) if !map.is_empty() => {
            let key = map.keys().nth(pick(map.len(), rng)).unwrap().clone();
            map.get_mut(&key).unwrap()
        }
        Value::Array(items) if !items.is_empty() => {
            let i = pick(items.len(), rng);
            &mut items[i]
        }
        _ => return,
    };
    let nested = matches!(slot, Value::Object(m) if !m.is_empty()) || matches!(slot, Value::Array(a) if !a.is_empty());
    if nested && rng.next_f32() < 0.6 {
        mutate(slot, rng, odd);
    } else if slot.is_number() && rng.next_f32() < 0.7 {
        // Mostly a number for a number: past the parser, into the checks.
        let numbers: Vec<&Value> = odd.iter().filter(|v| v.is_number()).collect();
        *slot = numbers[pick(numbers.len(), rng)].clone();
    } else {
        *slot = odd[pick(odd.len(), rng)].clone();
    }
}

/// The JSON pointers of every leaf of `v` (numbers, strings, booleans,
/// nulls, empty arrays and objects).
fn leaves(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(map) if !map.is_empty() => map.iter().for_each(|(k, v)| leaves(v, format!("{at}/{k}"), out)),
        Value::Array(items) if !items.is_empty() => items.iter().enumerate().for_each(|(i, v)| leaves(v, format!("{at}/{i}"), out)),
        _ => out.push(at),
    }
}

/// `glint render` of the default scene with request `r`: Ok(true) for an
/// image, Ok(false) for one line of error and exit 1, Err(what went
/// wrong) for anything else (a panic's exit 101, several lines, no end
/// within a minute).
fn outcome(r: &Value, request: &std::path::Path, exr: &std::path::Path) -> Result<bool, String> {
    std::fs::write(request, r.to_string()).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(["render", "--request", request.to_str().unwrap(), "-o", exr.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // At most 4096 × 8 pixels × 4096 samples here: a minute is a hang.
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            return Err(format!("no end after a minute: {r}"));
        }
        std::thread::sleep(Duration::from_millis(1));
    };
    let err = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
    match status.code() {
        Some(0) => Ok(true),
        Some(1) if err.lines().count() == 1 && err.starts_with("error: ") => Ok(false),
        code => Err(format!("exit {code:?}, stderr {err:?}, request {r}")),
    }
}

/// Every leaf of the full request, one at a time, given each odd value
/// (a number's only the odd numbers); then 120 requests with one to
/// three random fields replaced at once.
#[test]
fn odd_request_values_end_in_an_image_or_one_line_of_error() {
    let dir = std::env::temp_dir().join(format!("glint-request-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (request, exr) = (dir.join("request.json"), dir.join("out.exr"));
    let (full, odd) = (full_request(), odd_values());
    let mut paths = Vec::new();
    leaves(&full, String::new(), &mut paths);
    let (mut rendered, mut refused, mut failures) = (0, 0, Vec::new());
    let mut tally = |result: Result<bool, String>| match result {
        Ok(true) => rendered += 1,
        Ok(false) => refused += 1,
        Err(e) => failures.push(e),
    };
    for path in &paths {
        let number = full.pointer(path).unwrap().is_number();
        for value in odd.iter().filter(|v| !number || v.is_number()) {
            let mut r = full.clone();
            *r.pointer_mut(path).unwrap() = value.clone();
            tally(outcome(&r, &request, &exr));
        }
    }
    let mut rng = Rng::new(2026, 12);
    for _ in 0..120 {
        let mut r = full.clone();
        for _ in 0..1 + rng.next_u32() % 3 {
            mutate(&mut r, &mut rng, &odd);
        }
        tally(outcome(&r, &request, &exr));
    }
    assert!(failures.is_empty(), "{} of {} failed, the first: {}", failures.len(), rendered + refused + failures.len(), failures[0]);
    // Both outcomes occur: the values are neither all harmless nor all refused.
    assert!(rendered >= 100 && refused >= 100, "{rendered} rendered, {refused} refused");
    std::fs::remove_dir_all(&dir).unwrap();
}
