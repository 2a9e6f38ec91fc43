//! The loader over real outside files: every Khronos glTF-Validator test
//! file (mostly invalid on purpose) must load or fail with a clean one-line
//! error — no panic, no hang — and every Khronos sample model must load
//! and render.
//!
//! The files live in `../shared` beside the repository (CI puts them
//! there); GLINT_SHARED_DIR overrides the location.

mod common;

use common::{default_scene_with_lights, shared_dir};
use glint::camera::Projection;
use glint::integrator::Context;
use glint::job::{prepare, JobOptions, SceneExtras};
use glint::request::RenderRequest;
use glint::loader::{inspect_file, load_file, LoadOptions};
use glint::render::{render_pass, Film};
use std::sync::atomic::AtomicBool;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

fn files_with_extension(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())).map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files_with_extension(&p, exts, out);
        } else if p.extension().and_then(|e| e.to_str()).is_some_and(|e| exts.contains(&e)) {
            out.push(p);
        }
    }
}

enum Outcome {
    Loaded(usize),
    Error(String),
    Panicked(String),
}

/// What a caught panic said.
fn panic_message(panic: Box<dyn std::any::Any + Send>) -> String {
    panic.downcast_ref::<String>().cloned().or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default()
}

/// `work` on `path` in a worker thread, so that a panic is caught (its
/// message is the Err) and a hang is detected.
fn guarded<T: Send + 'static>(path: &Path, work: impl FnOnce(&Path) -> T + Send + std::panic::UnwindSafe + 'static) -> Result<T, String> {
    let (tx, rx) = mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let _ = tx.send(std::panic::catch_unwind(move || work(&p)).map_err(panic_message));
    });
    rx.recv_timeout(Duration::from_secs(20)).unwrap_or_else(|_| panic!("{}: hung for 20 s", path.display()))
}

/// Inspect (read everything) in a worker thread.
fn load_guarded(path: &Path) -> Outcome {
    match guarded(path, inspect_file) {
        Ok(Ok(found)) => Outcome::Loaded(found.triangles),
        Ok(Err(e)) => Outcome::Error(e.to_string()),
        Err(panic) => Outcome::Panicked(panic),
    }
}

#[test]
fn validator_corpus_loads_or_fails_cleanly() {
    let dir = shared_dir().join("gltf-validator-corpus");
    assert!(dir.is_dir(), "{} is missing: the corpus travels with CI in ../shared", dir.display());
    let mut files = Vec::new();
    files_with_extension(&dir, &["gltf", "glb"], &mut files);
    assert!(files.len() > 200, "only {} corpus files found", files.len());
    let (mut loaded, mut errors) = (0, 0);
    let mut panics = Vec::new();
    for f in &files {
        match load_guarded(f) {
            Outcome::Loaded(_) => loaded += 1,
            Outcome::Error(e) => {
                errors += 1;
                assert!(!e.contains('\n'), "{}: multi-line error: {e}", f.display());
                assert!(e.starts_with(&f.display().to_string()), "error does not name the file: {e}");
            }
            Outcome::Panicked(msg) => panics.push(format!("{}: {msg}", f.display())),
        }
    }
    eprintln!("validator corpus: {} files, {loaded} loaded, {errors} clean errors", files.len());
    assert!(panics.is_empty(), "{} file(s) panicked the loader:\n{}", panics.len(), panics.join("\n"));
}

/// What each sample model exercises, as its features line names it (and
/// the warnings it must give: none of them uses anything unsupported).
const SAMPLES: &[(&str, &[&str])] = &[
    ("Box", &["metallic"]),
    ("BoxTextured", &["textures (1 materials, 1 images)"]),
    ("BoxVertexColors", &["vertex colours"]),
    ("Cameras", &["ggx"]),
    ("MultiUVTest", &["textures (1 materials, 2 images)", "emitters=1"]),
    ("OrientationTest", &["diffuse", "metallic"]),
    ("SimpleMeshes", &["ggx"]),
    ("TextureCoordinateTest", &["textures (4 materials, 1 images)"]),
    ("TextureSettingsTest", &["textures (9 materials, 3 images)"]),
    ("Triangle", &["ggx"]),
    ("TriangleWithoutIndices", &["ggx"]),
];

#[test]
fn khronos_sample_models_load_and_render() {
    let dir = shared_dir().join("gltf-samples");
    assert!(dir.is_dir(), "{} is missing", dir.display());
    let mut files = Vec::new();
    files_with_extension(&dir, &["gltf", "glb"], &mut files);
    assert_eq!(files.len(), SAMPLES.len(), "expected the eleven sample models");
    for (name, features) in SAMPLES {
        let f = dir.join(format!("{name}/{name}.gltf"));
        match load_guarded(&f) {
            Outcome::Loaded(n) => assert!(n > 0, "{}: no triangles", f.display()),
            Outcome::Error(e) => panic!("{e}"),
            Outcome::Panicked(msg) => panic!("{}: panicked: {msg}", f.display()),
        }
        // Most have no camera: that is the clean error, and --camera auto
        // frames them, lit by a white World where they have no lights.
        if let Err(e) = load_file(&f, &LoadOptions::default()) {
            assert!(e.to_string().contains("the scene has no camera"), "{e}");
        }
        let options = JobOptions { camera: Some("auto".into()), width: Some(32), height: Some(32), samples: Some(4), ..JobOptions::default() };
        let job = prepare(Some(&f), &options, SceneExtras::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(job.scene.warnings.is_empty(), "{name}: {:?}", job.scene.warnings);
        let (ctx, _) = Context::new(&job.scene);
        let line = ctx.features_line(&job.settings);
        for feature in *features {
            assert!(line.contains(feature), "{name}: '{feature}' missing from {line}");
        }
        let mut film = Film::new(32, 32);
        let stats = render_pass(&ctx, &job.settings, &mut film, 0..4, &AtomicBool::new(false), &|_| {}).unwrap();
        let img = film.mean();
        assert_eq!(stats.discarded, 0, "{name}: non-finite samples");
        assert!(img.iter().all(|p| p.is_finite() && p.min_element() >= 0.0), "{name}: a bad pixel");
        assert!(img.iter().any(|p| p.max_element() > 0.0), "{name}: black image");
    }
}

#[test]
fn sample_models_with_a_camera_render_their_geometry() {
    // Cameras.gltf carries a perspective camera, then an orthographic one:
    // the first loads, with geometry.
    let f = shared_dir().join("gltf-samples/Cameras/Cameras.gltf");
    let scene = load_file(&f, &LoadOptions::default()).unwrap();
    assert!(!scene.triangles.is_empty());
    assert!(matches!(scene.camera.projection, Projection::Perspective { yfov } if yfov > 0.0));
}

/// Values a mutation puts in place of one of a file's numbers, of the
/// same kind, so that the file still parses and reaches the loader's own
/// checks and the renderer: indices and counts at and past their ends,
/// component types of the wrong kind, and huge, tiny, negative and zero
/// factors, positions and angles.
const HOSTILE_INTEGERS: &[u64] = &[0, 1, 2, 3, 7, 100_000, 2_147_483_648, 4_294_967_295, 5121, 5123, 5125, 5126, 34962, 34963];
const HOSTILE_FLOATS: &[f64] = &[0.0, -1.0, 1e-30, 1e30, -1e30, 3.4e38, -0.0, 1e-7];

/// Values of any kind in place of any member, which the JSON schema
/// mostly refuses.
fn hostile_values() -> Vec<serde_json::Value> {
    use serde_json::json;
    vec![json!(-1), json!(""), json!([]), json!({}), json!(null), json!("VEC3"), json!("SCALAR"), json!("MAT4"), json!([0, 0, 0]), json!([1e30, 0, 0, 1])]
}

/// The JSON pointer of every member and element of `v`, skipping long
/// strings (the data: URIs, whose bytes the validator corpus covers).
fn pointers(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    let mut visit = |child: &serde_json::Value, key: String| {
        if child.as_str().is_some_and(|s| s.len() > 200) {
            return;
        }
        let pointer = format!("{at}/{key}");
        out.push(pointer.clone());
        pointers(child, pointer, out);
    };
    match v {
        serde_json::Value::Object(m) => m.iter().for_each(|(k, child)| visit(child, k.replace('~', "~0").replace('/', "~1"))),
        serde_json::Value::Array(a) => a.iter().enumerate().for_each(|(i, child)| visit(child, i.to_string())),
        _ => {}
    }
}

/// The mutation tests' numbers, from a fixed seed: `pick(n)` draws below n.
fn picker() -> impl FnMut(usize) -> usize {
    let mut rng = glint::rng::Rng::new(2026, 12);
    move |n| ((rng.next_u32() as u64 * n as u64) >> 32) as usize
}

/// How many files a mutation test makes: GLINT_MUTATIONS, else `default`.
fn mutation_count(default: usize) -> usize {
    std::env::var("GLINT_MUTATIONS").ok().and_then(|n| n.parse().ok()).unwrap_or(default)
}

/// Replace one value under `root` (a JSON pointer; "" for all) of `doc`:
/// mostly a number by a hostile number of its kind or a scaled one, now and
/// then anything anywhere by a value of the wrong type. `pick(n)` draws
/// below n. Returns "pointer = value", for the failure's message.
fn mutate(doc: &mut serde_json::Value, root: &str, hostile: &[serde_json::Value], pick: &mut impl FnMut(usize) -> usize) -> String {
    let mut all = Vec::new();
    pointers(doc.pointer(root).unwrap(), root.to_string(), &mut all);
    let numbers: Vec<&String> = all.iter().filter(|p| doc.pointer(p).is_some_and(|v| v.is_number())).collect();
    let pointer = if pick(5) > 0 && !numbers.is_empty() { numbers[pick(numbers.len())].clone() } else { all[pick(all.len())].clone() };
    let target = doc.pointer_mut(&pointer).unwrap();
    let value = match (target.as_u64(), target.as_f64()) {
        (Some(_), _) if pick(4) > 0 => serde_json::json!(HOSTILE_INTEGERS[pick(HOSTILE_INTEGERS.len())]),
        (None, Some(x)) if pick(4) > 0 => serde_json::json!(if pick(2) == 0 { HOSTILE_FLOATS[pick(HOSTILE_FLOATS.len())] } else { x * [-1.0, 0.5, 2.0, 1000.0][pick(4)] }),
        _ => hostile[pick(hostile.len())].clone(),
    };
    let what = format!("{pointer} = {value}");
    *target = value;
    what
}

/// Inspect, load and render a file 12² at `samples` samples, with a render
/// request beside it where given, in a worker thread: the outcome, or the
/// panic's message.
fn render_guarded(path: &Path, camera: Option<&str>, request: Option<&Path>, samples: u32) -> Result<Result<(), String>, String> {
    let camera = camera.map(str::to_string);
    let request = request.map(Path::to_path_buf);
    guarded(path, move |p| -> Result<(), String> {
        inspect_file(p).map_err(|e| e.to_string())?;
        let request = match &request {
            Some(file) => RenderRequest::read(file).map_err(|e| format!("{}: {e}", file.display()))?,
            None => RenderRequest::default(),
        };
        let options = JobOptions { camera, width: Some(12), height: Some(12), samples: Some(samples), ..JobOptions::default() }.or(&JobOptions::from(&request));
        let job = prepare(Some(p), &options, (&request).into())?;
        let (ctx, _) = Context::new(&job.scene);
        let mut film = Film::new(12, 12);
        let stats = render_pass(&ctx, &job.settings, &mut film, 0..samples, &AtomicBool::new(false), &|_| {}).map_err(|e| e.to_string())?;
        assert!(film.mean().iter().all(|p| p.is_finite()), "a pixel is not finite ({} samples dropped)", stats.discarded);
        Ok(())
    })
}

/// What the mutation tests count of `render_guarded`'s outcomes: renders,
/// clean refusals (one line naming one of the files), and failures.
#[derive(Default)]
struct Tally {
    rendered: usize,
    refused: usize,
    failures: Vec<String>,
}

impl Tally {
    fn add(&mut self, outcome: Result<Result<(), String>, String>, files: &[&Path], what: &str) {
        match outcome {
            Ok(Ok(())) => self.rendered += 1,
            Ok(Err(e)) => {
                self.refused += 1;
                if e.contains('\n') || !files.iter().any(|f| e.contains(&f.display().to_string())) {
                    self.failures.push(format!("{what}: not a one-line error naming the file: {e}"));
                }
            }
            Err(panic) => self.failures.push(format!("{what}: panicked: {panic}")),
        }
    }
}

/// The mutation tests' sources: the eleven sample models and the default
/// Cornell box, by name, as text.
fn sample_sources() -> Vec<(String, String)> {
    let dir = shared_dir().join("gltf-samples");
    SAMPLES
        .iter()
        .map(|(name, _)| (name.to_string(), std::fs::read_to_string(dir.join(format!("{name}/{name}.gltf"))).unwrap_or_else(|e| panic!("{name}: {e}"))))
        .chain([("cornell-box".to_string(), glint::DEFAULT_SCENE.to_string())])
        .collect()
}

/// Write mutated file `json` to `path`, render it at `samples` samples
/// (`render_guarded`) into `tally` under `what`, and remove it.
fn render_mutated(tally: &mut Tally, path: &Path, json: &serde_json::Value, camera: Option<&str>, samples: u32, what: &str) {
    std::fs::write(path, serde_json::to_string(json).unwrap()).unwrap();
    tally.add(render_guarded(path, camera, None, samples), &[path], what);
    std::fs::remove_file(path).unwrap();
}

/// Files that are plausible glTF but wrong in one to three places: the
/// eleven sample models and the default Cornell box, each with numbers
/// replaced by hostile numbers of their kind (or scaled by −1, 0.5, 2 or
/// 1000), and now and then a member by a value of the wrong type, must
/// load and render or fail with a clean one-line error naming the file —
/// never panic or hang. 600 files from a fixed seed (GLINT_MUTATIONS=N for
/// more), rendered at 12² with 1 sample, with their own camera or framed
/// by `--camera auto`: about a quarter render, the rest are refused by the
/// loader's checks (an index past its array, an accessor past its buffer,
/// a wrong component type). A loader that panicked on a missing
/// bufferView instead of refusing it failed on 24 of the 600; 20,000 files
/// (5,167 rendered) found no panic, hang or dropped non-finite sample.
#[test]
fn mutated_sample_models_load_or_fail_cleanly() {
    let sources = sample_sources();
    let out_dir = std::env::temp_dir().join(format!("glint-mutations-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let hostile = hostile_values();
    let mut pick = picker();
    let mut tally = Tally::default();
    let count = mutation_count(600);
    for i in 0..count {
        let (name, text) = &sources[pick(sources.len())];
        let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
        let mut what = Vec::new();
        for _ in 0..1 + pick(3) {
            what.push(mutate(&mut json, "", &hostile, &mut pick));
        }
        // The file's own camera where it has one, every other time.
        let camera = if i % 2 == 1 && json.get("cameras").is_some() { None } else { Some("auto") };
        render_mutated(&mut tally, &out_dir.join(format!("{name}-{i}.gltf")), &json, camera, 1, &format!("{name} {what:?}"));
    }
    std::fs::remove_dir(&out_dir).unwrap();
    eprintln!("mutated sample models: {count} files, {} rendered, {} clean errors", tally.rendered, tally.refused);
    assert!(tally.failures.is_empty(), "{} of {count} mutated files:\n{}", tally.failures.len(), tally.failures.join("\n"));
}

/// Words a buffer mutation writes over the data, as little-endian bytes:
/// floats a position, normal or texture coordinate cannot sensibly hold,
/// and integers past any index or count.
fn hostile_words() -> Vec<[u8; 4]> {
    let floats = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 1e-45, -0.0, 1e30];
    let integers = [u32::MAX, 0x7fff_ffff, 0xffff, 0x1_0000, 65_535 << 16];
    floats.iter().map(|f| f.to_le_bytes()).chain(integers.iter().map(|i| i.to_le_bytes())).collect()
}

/// Files whose JSON is sound but whose binary data is not: the sample
/// models and the default Cornell box with 1 to 16 aligned words of their
/// base64 buffers overwritten by NaN, ±Inf, ±f32::MAX, a denormal or an
/// integer past any index (or, one time in eight, a random byte), must load
/// and render or fail with a clean one-line error naming the file. This is
/// what `mutated_sample_models_load_or_fail_cleanly` leaves alone (it skips
/// the data: URIs): positions of NaN and 1e38 reaching the BVH build and
/// the light tree, indices past the vertices. 300 files from a fixed seed
/// (GLINT_MUTATIONS=N for more), rendered at 12² with 2 samples, each by
/// its own camera where it has one; every pixel must stay finite. A
/// command-line fuzz of the same kind over the benchmark scenes' GLBs and
/// these files (1,300 renders, 2026-12-05) found no panic.
#[test]
fn mutated_buffers_load_or_fail_cleanly() {
    use base64::Engine;
    const PREFIX: &str = "data:application/octet-stream;base64,";
    let mut sources: Vec<(String, serde_json::Value)> = sample_sources().into_iter().map(|(name, text)| (name, serde_json::from_str(&text).unwrap())).collect();
    // Only models whose buffers are embedded data: every source has them.
    sources.retain(|(_, json)| json["buffers"].as_array().is_some_and(|b| b.iter().any(|b| b["uri"].as_str().is_some_and(|u| u.starts_with(PREFIX)))));
    assert!(sources.len() >= 10, "the samples' buffers are no longer embedded");
    let out_dir = std::env::temp_dir().join(format!("glint-buffer-mutations-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    let words = hostile_words();
    let mut pick = picker();
    let mut tally = Tally::default();
    let count = mutation_count(300);
    let engine = &base64::engine::general_purpose::STANDARD;
    for i in 0..count {
        let (name, source) = &sources[pick(sources.len())];
        let mut json = source.clone();
        let buffers = json["buffers"].as_array_mut().unwrap();
        let embedded: Vec<usize> = (0..buffers.len()).filter(|&b| buffers[b]["uri"].as_str().is_some_and(|u| u.starts_with(PREFIX))).collect();
        let b = embedded[pick(embedded.len())];
        let mut data = engine.decode(&buffers[b]["uri"].as_str().unwrap()[PREFIX.len()..]).unwrap();
        let mut what = Vec::new();
        for _ in 0..[1, 2, 4, 16][pick(4)] {
            let at = pick(data.len() / 4) * 4;
            if pick(8) == 0 {
                let byte = pick(256) as u8;
                data[at] = byte;
                what.push(format!("byte {at} = {byte}"));
            } else {
                let word = words[pick(words.len())];
                data[at..at + 4].copy_from_slice(&word);
                what.push(format!("word {at} = {word:02x?}"));
            }
        }
        buffers[b]["uri"] = format!("{PREFIX}{}", engine.encode(&data)).into();
        let camera = if json.get("cameras").is_some() { None } else { Some("auto") };
        render_mutated(&mut tally, &out_dir.join(format!("{name}-buffer-{i}.gltf")), &json, camera, 2, &format!("{name} buffer {b}: {what:?}"));
    }
    std::fs::remove_dir(&out_dir).unwrap();
    eprintln!("mutated buffers: {count} files, {} rendered, {} clean errors", tally.rendered, tally.refused);
    assert!(tally.failures.is_empty(), "{} of {count} files with mutated buffers:\n{}", tally.failures.len(), tally.failures.join("\n"));
}

/// The default Cornell box with a point, a spot and a sun
/// (KHR_lights_punctual), and a render request that uses every field the
/// add-on writes: each area light shape, a Spread, a portal, visible
/// lamps, the three lights' sizes, an environment image or a World colour,
/// and the camera's lens shift and aperture and a transparent film (with
/// every other request; the caller gives half of the rest a panorama).
fn lit_box_and_request(environment: Option<&Path>) -> (serde_json::Value, serde_json::Value) {
    use serde_json::json;
    let scene = default_scene_with_lights(
        json!([
            {"name": "Point", "type": "point", "color": [1, 0.9, 0.8], "intensity": 20},
            {"name": "Spot", "type": "spot", "color": [1, 1, 1], "intensity": 30, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
            {"name": "Sun", "type": "directional", "color": [1, 1, 1], "intensity": 2}]),
        vec![
            json!({"name": "PointNode", "translation": [0.2, 1.5, 0.3], "extensions": {"KHR_lights_punctual": {"light": 0}}}),
            json!({"name": "SpotNode", "translation": [-0.3, 1.6, 0.2], "rotation": [-std::f32::consts::FRAC_1_SQRT_2, 0, 0, std::f32::consts::FRAC_1_SQRT_2], "extensions": {"KHR_lights_punctual": {"light": 1}}}),
            json!({"name": "SunNode", "rotation": [-0.5, 0.2, 0.1, 0.84], "extensions": {"KHR_lights_punctual": {"light": 2}}}),
        ],
    );
    // Column-major, turned by `turn` about y and moved to `at`.
    let matrix = |at: [f32; 3], turn: f32| json!([turn.cos(), 0, -turn.sin(), 0, 0, 1, 0, 0, turn.sin(), 0, turn.cos(), 0, at[0], at[1], at[2], 1]);
    let mut request = json!({
        "job": "mutated", "width": 12, "height": 12, "samples": 1, "max_depth": 6, "seed": 3, "mis": true, "bsdf": "principled",
        "light_paths": true, "background": [0.1, 0.2, 0.3], "two_sided_emission": true, "default_surface": [0.8, 0.8, 0.8],
        "single_scatter_materials": ["white"], "coat_tints": [{"material": "white", "tint": [0.9, 0.6, 0.3]}],
        "diffuse_roughness": [{"material": "red", "roughness": 0.7}], "pixel_filter": {"type": "gaussian", "width": 2.0},
        "area_lights": [
            {"name": "Square", "shape": "SQUARE", "size": [0.3, 0.3], "matrix": matrix([0.0, 1.7, 0.0], 0.0), "color": [1, 1, 1], "power": 40, "spread": 0.8},
            {"name": "Rectangle", "shape": "RECTANGLE", "size": [0.4, 0.2], "matrix": matrix([0.3, 1.5, -0.2], 0.4), "color": [1, 0.5, 0.2], "power": 20},
            {"name": "Disk", "shape": "DISK", "size": [0.3, 0.3], "matrix": matrix([-0.3, 1.6, 0.1], 0.0), "color": [0.2, 0.5, 1], "power": 15, "spread": 1.2, "visible_camera": true},
            {"name": "Ellipse", "shape": "ELLIPSE", "size": [0.4, 0.1], "matrix": matrix([0.1, 1.2, 0.4], 1.0), "color": [1, 1, 1], "power": 10},
            {"name": "Window", "shape": "RECTANGLE", "size": [1, 1.2], "matrix": matrix([0.0, 1.0, 1.2], 0.0), "color": [1, 1, 1], "power": 500, "portal": true}],
        "light_sizes": [{"name": "Point", "radius": 0.1, "soft_falloff": true}, {"name": "Spot", "radius": 0.05, "soft_falloff": false, "visible_camera": true}, {"name": "Sun", "angle": 0.05}]});
    if let Some(image) = environment {
        request["environment"] = json!({"image": image, "strength": 2.0, "rotation": 0.5});
        request["lens"] = json!({"shift": [0.1, -0.05], "aperture": {"radius": 0.02, "focus_distance": 3.5, "blades": 6, "rotation": 0.3, "ratio": 1.5}});
        request["transparent_film"] = json!(true);
        request["transparent_glass"] = json!(0.1);
    }
    (scene, request)
}

/// Render requests wrong in one to three places, beside a scene whose
/// lights they size (sometimes the scene's lights are what is wrong):
/// numbers replaced by hostile numbers of their kind or scaled, members by
/// values of the wrong type. Each must render 12² at 2 samples (a sum)
/// with finite pixels, or fail with a one-line error naming the file; never panic or
/// hang. 2,000 from a fixed seed (GLINT_MUTATIONS=N for more; about 3 s).
/// A World of 3.4·10^38, finite and ≥ 0 as the request's check asked, made
/// pixels infinite (their f32 sums overflowed) in 1 of these 2,000 before
/// `job::MAX_RADIANCE`; 20,000 found nothing else.
#[test]
fn mutated_render_requests_render_or_fail_cleanly() {
    let dir = std::env::temp_dir().join(format!("glint-mutated-requests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sky = dir.join("sky.png");
    image::RgbImage::from_fn(8, 4, |x, y| image::Rgb([(x * 30) as u8, (y * 60) as u8, 200])).save(&sky).unwrap();
    let hostile = hostile_values();
    let mut pick = picker();
    let mut tally = Tally::default();
    let count = mutation_count(2000);
    for i in 0..count {
        let (mut scene, mut request) = lit_box_and_request((i % 2 == 1).then_some(sky.as_path()));
        // Every other request without an environment sees through a
        // panoramic camera, whose settings are numbers to mutate too.
        if i % 4 == 2 {
            request["lens"] = serde_json::json!({"shift": [0.05, 0], "panorama": {"type": "FISHEYE_LENS_POLYNOMIAL", "fov": 3.0, "k": [-1e-5, -0.02, -3e-6, 1e-8, -4e-11], "sensor": [36, 24]}});
        } else if i % 4 == 0 {
            request["lens"] = serde_json::json!({"panorama": {"type": "EQUIRECTANGULAR", "latitude": [-1.2, 1.5], "longitude": [-3.0, 2.0]}});
        }
        let mut what = Vec::new();
        for _ in 0..1 + pick(3) {
            // A fifth of the mutations go to the scene's lights and nodes.
            let (doc, root) = if pick(5) > 0 { (&mut request, "") } else { (&mut scene, ["/extensions/KHR_lights_punctual", "/nodes"][pick(2)]) };
            what.push(mutate(doc, root, &hostile, &mut pick));
        }
        let (scene_path, request_path) = (dir.join(format!("scene-{i}.gltf")), dir.join(format!("request-{i}.json")));
        std::fs::write(&scene_path, serde_json::to_string(&scene).unwrap()).unwrap();
        std::fs::write(&request_path, serde_json::to_string(&request).unwrap()).unwrap();
        // Two samples: the pixels' sums, where finite samples can overflow.
        let outcome = render_guarded(&scene_path, None, Some(&request_path), 2);
        tally.add(outcome, &[&scene_path, &request_path], &format!("{what:?}"));
        std::fs::remove_file(&scene_path).unwrap();
        std::fs::remove_file(&request_path).unwrap();
    }
    std::fs::remove_dir_all(&dir).unwrap();
    eprintln!("mutated render requests: {count} pairs, {} rendered, {} clean errors", tally.rendered, tally.refused);
    assert!(tally.failures.is_empty(), "{} of {count} mutated requests:\n{}", tally.failures.len(), tally.failures.join("\n"));
}
