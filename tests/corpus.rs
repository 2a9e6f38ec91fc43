//! The loader over real outside files: every Khronos glTF-Validator test
//! file (mostly invalid on purpose) must load or fail with a clean one-line
//! error — no panic, no hang — and every Khronos sample model must load.
//!
//! The files live in `../shared` beside the repository (CI puts them
//! there); GLINT_SHARED_DIR overrides the location.

use glint::loader::{inspect_file, load_file, LoadOptions};
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

#[test]
fn khronos_sample_models_load() {
    let dir = shared_dir().join("gltf-samples");
    assert!(dir.is_dir(), "{} is missing", dir.display());
    let mut files = Vec::new();
    files_with_extension(&dir, &["gltf", "glb"], &mut files);
    assert_eq!(files.len(), 11, "expected the eleven sample models");
    for f in &files {
        match load_guarded(f) {
            Outcome::Loaded(n) => assert!(n > 0, "{}: no triangles", f.display()),
            Outcome::Error(e) => panic!("{e}"),
            Outcome::Panicked(msg) => panic!("{}: panicked: {msg}", f.display()),
        }
        // Rendering needs a camera; most samples have none (--camera auto
        // comes with scene coverage), which must be the clean error.
        if let Err(e) = load_file(f, &LoadOptions::default()) {
            assert!(e.to_string().contains("no perspective camera"), "{e}");
        }
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
