//! The loader over real outside files: every Khronos glTF-Validator test
//! file (mostly invalid on purpose) must load or fail with a clean one-line
//! error — no panic, no hang — and every Khronos sample model must load
//! and render.
//!
//! The files live in `../shared` beside the repository (CI puts them
//! there); GLINT_SHARED_DIR overrides the location.

use glint::integrator::Context;
use glint::job::{prepare, JobOptions, SceneExtras};
use glint::loader::{inspect_file, load_file, LoadOptions};
use glint::render::{render_pass, Film};
use std::sync::atomic::AtomicBool;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

fn shared_dir() -> PathBuf {
    std::env::var_os("GLINT_SHARED_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"))
}

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

/// Inspect (read everything) in a worker thread so a panic is caught and a
/// hang is detected.
fn load_guarded(path: &Path) -> Outcome {
    let (tx, rx) = mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(|| inspect_file(&p));
        let outcome = match r {
            Ok(Ok(found)) => Outcome::Loaded(found.triangles),
            Ok(Err(e)) => Outcome::Error(e.to_string()),
            Err(panic) => Outcome::Panicked(
                panic.downcast_ref::<String>().cloned().or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default(),
            ),
        };
        let _ = tx.send(outcome);
    });
    rx.recv_timeout(Duration::from_secs(20)).unwrap_or_else(|_| panic!("{}: loading hung for 20 s", path.display()))
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
            assert!(e.to_string().contains("no perspective camera"), "{e}");
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
    // Cameras.gltf carries a perspective camera: it must load with geometry.
    let f = shared_dir().join("gltf-samples/Cameras/Cameras.gltf");
    let scene = load_file(&f, &LoadOptions::default()).unwrap();
    assert!(!scene.triangles.is_empty());
    assert!(scene.camera.yfov > 0.0);
}
