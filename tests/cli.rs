//! The `glint` binary as a user runs it: outputs, summary line, and one-line
//! errors with a non-zero exit for bad input.

mod common;

use common::shared_dir;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn glint(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_glint")).args(args).output().expect("run glint")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("glint-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn renders_the_embedded_default_scene_to_exr_and_png() {
    let dir = temp_dir("default");
    let exr = dir.join("out.exr");
    let png = dir.join("out.png");
    let o = glint(&["render", "-o", exr.to_str().unwrap(), "--png", png.to_str().unwrap(), "--spp", "2", "--width", "40", "--height", "30", "--stats"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("40x30, 2 spp,") && err.contains("Mrays/s"), "summary line missing: {err}");
    assert!(err.contains("discarded samples (non-finite or above 1e24): 0"), "{err}");
    // The set-up outside the render's time, reported apart.
    assert!(err.lines().any(|l| l.starts_with("scene: ") && l.contains(" s, BVH build ") && l.contains(" s, lights and the rest of the set-up ")), "{err}");
    let (w, h, px, alpha) = glint::output::read_exr_with_alpha(&exr).unwrap();
    assert_eq!((w, h), (40, 30));
    assert!(px.iter().all(|p| p.is_finite()) && px.iter().any(|p| p.x > 0.0) && alpha.iter().all(|a| *a == 1.0));
    let png_img = image::open(&png).unwrap();
    assert_eq!((png_img.width(), png_img.height()), (40, 30));
    // Only the two outputs: no temp files left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
    // A transparent film: the box's open front lets some camera rays
    // out, whose pixels lose alpha; the box's walls keep theirs.
    let o = glint(&["render", "-o", exr.to_str().unwrap(), "--png", png.to_str().unwrap(), "--spp", "2", "--width", "40", "--height", "30", "--transparent-film"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let alpha = glint::output::read_exr_with_alpha(&exr).unwrap().3;
    assert!(alpha.iter().any(|a| *a < 1.0) && alpha.iter().filter(|a| **a == 1.0).count() > alpha.len() / 2, "{alpha:?}");
    // The preview keeps that alpha, in 8 bits.
    let preview = image::open(&png).unwrap().to_rgba8();
    assert!(preview.pixels().zip(&alpha).all(|(p, a)| (p.0[3] as f32 - a * 255.0).abs() <= 0.5), "the PNG's alpha is not the EXR's");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--repeat N` renders N times in one process and writes the last
/// image, which is the one a single render gives (same seed, bit for
/// bit), and reports the earlier renders' times; zero renders is an error.
#[test]
fn repeated_renders_write_the_one_image_and_report_each_time() {
    let dir = temp_dir("repeat");
    let (once, thrice) = (dir.join("once.exr"), dir.join("thrice.exr"));
    let common = ["--spp", "2", "--width", "24", "--height", "16", "--stats"];
    let o = glint(&[&["render", "-o", once.to_str().unwrap()][..], &common].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("earlier renders"), "{}", stderr(&o));
    let o = glint(&[&["render", "-o", thrice.to_str().unwrap(), "--repeat", "3"][..], &common].concat());
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let line = err.lines().find(|l| l.starts_with("earlier renders of the 3: ")).unwrap_or_else(|| panic!("{err}"));
    let times: Vec<f64> = line.trim_start_matches("earlier renders of the 3: ").trim_end_matches(" s per sample").split(", ").map(|t| t.parse().unwrap()).collect();
    assert!(times.len() == 2 && times.iter().all(|&t| t > 0.0), "{line}");
    assert_eq!(std::fs::read(&once).unwrap(), std::fs::read(&thrice).unwrap());
    let o = glint(&["render", "-o", dir.join("none.exr").to_str().unwrap(), "--repeat", "0"]);
    assert!(!o.status.success() && stderr(&o).contains("--repeat"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The profile-guided build's training (tests/pgo-build) renders every
/// kernel `render_pass` can choose, each with the kernel it names: one it
/// left out would be compiled as cold code, and run slower than without
/// a profile.
#[test]
fn the_pgo_training_renders_every_kernel() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = temp_dir("pgo-training");
    let o = Command::new("python3").arg(root.join("tests/pgo_training.py")).arg(env!("CARGO_BIN_EXE_glint")).arg(&dir).arg(shared_dir()).output().expect("run python3");
    let (out, err) = (String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(o.status.success(), "{out}{err}");
    let trained: std::collections::BTreeSet<&str> = out.lines().filter_map(|l| l.strip_prefix("trained kernel: ")).collect();
    let bsdfs = ["lambert", "seed", "seed + glass", "principled", "principled + glass", "principled + coat"];
    let lights = ["no local lights", "punctual", "emitters", "emitters + lamps", "emitters + punctual", "emitters + lamps + punctual"];
    let every: std::collections::BTreeSet<String> = bsdfs.iter().flat_map(|b| lights.iter().map(move |l| format!("{b} + {l}"))).collect();
    assert_eq!(trained, every.iter().map(String::as_str).collect(), "{out}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn default_resolution_follows_the_camera_aspect_ratio() {
    let dir = temp_dir("aspect");
    let exr = dir.join("out.exr");
    let scene = dir.join("wide.gltf");
    let text = glint::DEFAULT_SCENE.replace("\"aspectRatio\": 1.0", "\"aspectRatio\": 2.0");
    std::fs::write(&scene, text).unwrap();
    let o = glint(&["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--spp", "1", "--width", "64", "--max-depth", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (w, h, _) = glint::output::read_exr(&exr).unwrap();
    assert_eq!((w, h), (64, 32));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_input_gives_one_line_errors_and_keeps_old_output() {
    let dir = temp_dir("bad");
    let exr = dir.join("out.exr");
    std::fs::write(&exr, b"previous good image").unwrap();
    let broken = dir.join("broken.gltf");
    std::fs::write(&broken, b"{\"asset\": {\"version\": \"2.0\"}, \"scenes\": [").unwrap();
    let missing = dir.join("missing.gltf");
    for (scene, expect) in [(&broken, "not valid glTF JSON"), (&missing, "No such file")] {
        let o = glint(&["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap()]);
        let err = stderr(&o);
        assert!(!o.status.success());
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(err.starts_with("error: ") && err.contains(scene.to_str().unwrap()) && err.contains(expect), "{err}");
        assert!(!err.contains("panicked"));
    }
    assert_eq!(std::fs::read(&exr).unwrap(), b"previous good image");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An emitter, a light or a World brighter than job::MAX_RADIANCE (1e20
/// W·sr⁻¹·m⁻²) is refused in one line naming the file and what is too
/// bright: an emission strength of 3e38, which glTF allows, had rendered
/// infinite pixels.
#[test]
fn emitters_too_bright_to_sum_are_refused() {
    let dir = temp_dir("too-bright");
    let exr = dir.join("out.exr");
    let mut cornell: serde_json::Value = serde_json::from_str(glint::DEFAULT_SCENE).unwrap();
    let light = cornell["materials"].as_array_mut().unwrap().iter_mut().find(|m| m["name"] == "light").unwrap();
    light["extensions"] = serde_json::json!({"KHR_materials_emissive_strength": {"emissiveStrength": 3e38}});
    cornell["extensionsUsed"] = serde_json::json!(["KHR_materials_emissive_strength"]);
    let bright = dir.join("bright.gltf");
    std::fs::write(&bright, serde_json::to_string(&cornell).unwrap()).unwrap();
    let lit = common::default_scene_with_lights(
        serde_json::json!([{"name": "Bulb", "type": "point", "intensity": 1e30}]),
        vec![serde_json::json!({"translation": [0, 1, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}})],
    );
    let bulb = dir.join("bulb.gltf");
    std::fs::write(&bulb, serde_json::to_string(&lit).unwrap()).unwrap();
    let sky = dir.join("sky.png");
    image::RgbImage::from_pixel(4, 2, image::Rgb([255, 255, 255])).save(&sky).unwrap();
    let (bright, bulb, sky) = (bright.to_str().unwrap(), bulb.to_str().unwrap(), sky.to_str().unwrap());
    for (args, expect) in [
        (&[bright][..], "material 'light' emits 3e38 W·sr⁻¹·m⁻²; Glint renders emitters up to 1e20"),
        (&[bulb], "light 'Bulb' has an intensity of 1e30 W·sr⁻¹"),
        (&["--background", "3.4e38", "0", "0"], "the World's colour is 3.4e38"),
        (&["--environment", sky, "--environment-strength", "1e25"], "brightest texel × strength is 1e25"),
    ] {
        let o = glint(&[&["render", "-o", exr.to_str().unwrap()][..], args].concat());
        let err = stderr(&o);
        assert!(!o.status.success() && err.lines().count() == 1 && err.contains(expect), "{args:?}: {err}");
        // A scene file's error names it.
        assert!(!args[0].ends_with(".gltf") || err.contains(args[0]), "{err}");
    }
    // At the bound itself it renders, every pixel finite.
    let o = glint(&["render", "--background", "1e20", "0", "0", "--spp", "4", "--width", "8", "--height", "8", "-o", exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(glint::output::read_exr(&exr).unwrap().2.iter().all(|p| p.is_finite()));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A request's `camera_world` (Blender's Light Path › Is Camera Ray in the
/// World): a scene with nothing in it shows it in every pixel, as a colour
/// or an image × strength; a bad one is refused in one line.
#[test]
fn a_request_gives_the_camera_a_world_of_its_own() {
    let dir = temp_dir("camera-world");
    let (scene, request, exr) = (dir.join("empty.gltf"), dir.join("request.json"), dir.join("out.exr"));
    std::fs::write(&scene, r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"camera": 0}], "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}]}"#).unwrap();
    let sky = dir.join("sky.png");
    image::RgbImage::from_pixel(4, 2, image::Rgb([255, 255, 255])).save(&sky).unwrap();
    let sky = sky.to_str().unwrap().replace('\\', "/");
    let render = |json: &str| {
        std::fs::write(&request, json).unwrap();
        glint(&["render", scene.to_str().unwrap(), "--request", request.to_str().unwrap(), "--spp", "2", "--width", "4", "--height", "4", "--stats", "-o", exr.to_str().unwrap()])
    };
    for (json, seen) in [
        (r#"{"background": [1, 1, 1], "camera_world": {"background": [0.5, 0.25, 2]}}"#.to_string(), [0.5, 0.25, 2.0]),
        (format!(r#"{{"background": [1, 1, 1], "camera_world": {{"environment": {{"image": "{sky}", "strength": 3}}}}}}"#), [3.0; 3]),
        (r#"{"background": [1, 1, 1], "camera_world": {}}"#.to_string(), [0.0; 3]),
    ] {
        let o = render(&json);
        assert!(o.status.success() && stderr(&o).contains("camera World"), "{json}: {}", stderr(&o));
        let pixels = glint::output::read_exr(&exr).unwrap().2;
        assert!(pixels.iter().all(|p| (p[0] - seen[0]).abs() < 1e-5 && (p[1] - seen[1]).abs() < 1e-5 && (p[2] - seen[2]).abs() < 1e-5), "{json}: {:?}", pixels[0]);
    }
    for (json, expect) in [
        (r#"{"camera_world": {"background": [-1, 0, 0]}}"#.to_string(), "camera World: background must be finite and ≥ 0"),
        (r#"{"camera_world": {"background": [1e25, 0, 0]}}"#.to_string(), "the World the camera sees is 1e25"),
        (r#"{"camera_world": {"environment": {"image": "/nonexistent/sky.hdr"}}}"#.to_string(), "camera World: environment image '/nonexistent/sky.hdr'"),
        (r#"{"camera_world": {"colour": [1, 1, 1]}}"#.to_string(), "unknown field `colour`"),
    ] {
        let o = render(&json);
        let err = stderr(&o);
        assert!(!o.status.success() && err.lines().count() == 1 && err.contains(expect), "{json}: {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A request's lens the camera cannot have is refused in one line, naming
/// the scene and the value; a good one renders (a panoramic one too).
#[test]
fn a_request_lens_out_of_range_is_refused() {
    let dir = temp_dir("lens");
    let exr = dir.join("out.exr");
    let request = dir.join("request.json");
    for (lens, expect) in [
        (r#"{"aperture": {"radius": -1, "focus_distance": 2}}"#, "lens: aperture radius -1 must be in [0, 1e15] m"),
        (r#"{"aperture": {"radius": 0.1, "focus_distance": 0}}"#, "lens: focus distance 0 must be in (0, 1e15] m"),
        (r#"{"aperture": {"radius": 0.1, "focus_distance": 2, "ratio": 0}}"#, "lens: aperture ratio 0 must be in [0.001, 1000]"),
        (r#"{"shift": [1e9, 0]}"#, "lens: lens shift [1000000000, 0] must be within ±1000 image sizes"),
        (r#"{"shift": [0.2, -0.1], "aperture": {"radius": 0.05, "focus_distance": 3.8, "blades": 5}}"#, ""),
        (r#"{"panorama": {"type": "FISHEYE_EQUIDISTANT", "fov": 0}}"#, "lens: panorama fov 0 must be in (0, 2π]"),
        (r#"{"panorama": {"type": "MIRRORBALL"}, "aperture": {"radius": 0.1, "focus_distance": -2}}"#, "lens: focus distance -2 must be in (0, 1e15] m"),
        (r#"{"panorama": {"type": "EQUIRECTANGULAR", "latitude": [-1, 1], "longitude": [-3, 3]}, "aperture": {"radius": 0.1, "focus_distance": 2}}"#, ""),
        (r#"{"shift": [0.1, 0], "panorama": {"type": "FISHEYE_EQUISOLID", "fov": 3.14, "lens": 10.5, "sensor": [36, 24]}}"#, ""),
    ] {
        std::fs::write(&request, format!(r#"{{"width": 8, "height": 8, "samples": 2, "lens": {lens}}}"#)).unwrap();
        let o = glint(&["render", "--request", request.to_str().unwrap(), "-o", exr.to_str().unwrap()]);
        let err = stderr(&o);
        if expect.is_empty() {
            assert!(o.status.success(), "{lens}: {err}");
        } else {
            assert!(!o.status.success() && err.lines().count() == 1 && err.contains(expect) && err.contains(glint::DEFAULT_SCENE_NAME), "{lens}: {err}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn zero_sized_images_and_unknown_cameras_are_rejected() {
    for args in [&["render", "--width", "0"][..], &["render", "--height", "0"], &["render", "--spp", "0"]] {
        let o = glint(args);
        assert!(!o.status.success());
        assert!(!stderr(&o).contains("panicked"));
    }
    let o = glint(&["render", "--camera", "Nope", "-o", "/nonexistent/x.exr"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no camera named 'Nope'"), "{}", stderr(&o));
}

#[test]
fn unwritable_output_is_a_clean_error() {
    let o = glint(&["render", "--spp", "1", "--width", "4", "--height", "4", "-o", "/nonexistent-dir/x.exr"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("/nonexistent-dir/x.exr") && !err.contains("panicked"), "{err}");
}

#[test]
fn inspect_reports_a_sample_model() {
    let f = shared_dir().join("gltf-samples/Box/Box.gltf");
    let o = Command::new(env!("CARGO_BIN_EXE_glint")).args(["inspect", f.to_str().unwrap()]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("12 triangles") && out.contains("the scene has no camera"), "{out}");
}

/// Every render starts with one line saying what the scene uses and which
/// kernel runs; `--features all` forces the general kernel, and for the
/// same seed both write the same pixels (light subpaths off in both). The
/// diffuse box, open at the front, gets light subpaths from `auto`
/// (`Landing::onward`); the glossy one for its caustics.
#[test]
fn the_features_line_and_the_general_kernel() {
    let dir = temp_dir("features");
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box-diffuse.gltf");
    let mut images = Vec::new();
    for (mode, kernel) in [("auto", "kernel: lambert + emitters"), ("all", "kernel: principled + glass + coat + rough diffuse + emitters + lamps + punctual")] {
        let exr = dir.join(format!("{mode}.exr"));
        let o = glint(&["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--spp", "3", "--width", "24", "--height", "24", "--features", mode, "--light-paths", "off"]);
        let err = stderr(&o);
        assert!(o.status.success(), "{err}");
        let line = err.lines().next().unwrap_or_default();
        assert_eq!(line, format!("features: diffuse, emitters=1 (2 tris), one-sided emission; {kernel}"));
        images.push(glint::output::read_exr(&exr).unwrap().2);
    }
    let bits = |img: &[glint::Vec3]| img.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert!(bits(&images[0]) == bits(&images[1]), "the general kernel's pixels differ");
    let o = glint(&["render", scene.to_str().unwrap(), "--features", "some"]);
    assert!(!o.status.success() && stderr(&o).contains("--features"));
    let first_line = |scene: &PathBuf, extra: &[&str]| {
        let exr = dir.join("paths.exr");
        let o = glint(&[&["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--spp", "1", "--width", "8", "--height", "8"], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o).lines().next().unwrap_or_default().to_string()
    };
    assert!(first_line(&scene, &[]).ends_with("kernel: lambert + emitters + light paths"));
    assert!(first_line(&scene, &["--light-paths", "off"]).ends_with("kernel: lambert + emitters"));
    let glossy = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf");
    let line = first_line(&glossy, &[]);
    assert!(line.contains("focusing") && line.ends_with("+ light paths"), "{line}");
    assert!(!first_line(&glossy, &["--light-paths", "off"]).contains("light paths"));
    assert!(first_line(&glossy, &["--light-paths", "auto"]).ends_with("+ light paths"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A request's `light_paths` (the add-on's Light Paths setting) decides
/// where the command line does not: false leaves out the light subpaths
/// `auto` traces in the diffuse Cornell box, and `--light-paths auto`
/// given on the command line brings them back.
#[test]
fn a_request_sets_light_paths_and_the_command_line_overrides_it() {
    let dir = temp_dir("request-light-paths");
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box-diffuse.gltf");
    let first_line = |request: &str, extra: &[&str]| {
        let (req, exr) = (dir.join("request.json"), dir.join("out.exr"));
        std::fs::write(&req, request).unwrap();
        let o = glint(&[&["render", scene.to_str().unwrap(), "--request", req.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--spp", "1", "--width", "8", "--height", "8"], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o).lines().next().unwrap_or_default().to_string()
    };
    assert!(first_line("{}", &[]).ends_with("+ light paths"));
    assert!(!first_line(r#"{"light_paths": false}"#, &[]).contains("light paths"));
    assert!(first_line(r#"{"light_paths": false}"#, &["--light-paths", "auto"]).ends_with("+ light paths"));
    assert!(first_line(r#"{"light_paths": true}"#, &["--mis", "off"]).ends_with("kernel: lambert + emitters"), "light subpaths need MIS");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--noise-threshold` (or the request's `noise_threshold`) renders
/// adaptively and says how many samples the pixels took; the same
/// settings give the same image, bit for bit, from the command line or the
/// request; a threshold that is not a number above 0 is refused.
#[test]
fn noise_threshold_renders_adaptively_and_reproducibly() {
    let dir = temp_dir("adaptive");
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |args: &[&str], exr: &str| {
        let o = glint(&[&["render", "--spp", "48", "--width", "24", "--height", "24", "-o", &out(exr)], args].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        (stderr(&o), std::fs::read(out(exr)).unwrap())
    };
    let (log, first) = run(&["--noise-threshold", "0.5", "--min-samples", "16"], "a.exr");
    let line = log.lines().find(|l| l.starts_with("adaptive sampling: ")).unwrap_or_else(|| panic!("{log}"));
    let mean: f64 = line["adaptive sampling: ".len()..].split(' ').next().unwrap().parse().unwrap();
    assert!((16.0..48.0).contains(&mean), "{line}");
    let (_, again) = run(&["--noise-threshold", "0.5", "--min-samples", "16"], "b.exr");
    assert!(first == again, "the same settings gave a different image");
    let request = dir.join("request.json");
    std::fs::write(&request, r#"{"noise_threshold": 0.5, "adaptive_min_samples": 16}"#).unwrap();
    let (_, from_request) = run(&["--request", request.to_str().unwrap()], "c.exr");
    assert!(first == from_request, "the request's threshold gave a different image");
    let (log, _) = run(&[], "d.exr");
    assert!(!log.contains("adaptive sampling"), "{log}");
    for bad in ["0", "-1", "nan", "inf", "x"] {
        let o = glint(&["render", &format!("--noise-threshold={bad}"), "-o", &out("e.exr")]);
        assert!(!o.status.success() && stderr(&o).contains("noise threshold"), "{bad}: {}", stderr(&o));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A time limit longer than a Duration holds is no limit: the samples end
/// the render (it had panicked converting the seconds), from the command
/// line or a request.
#[test]
fn an_endless_time_limit_is_no_limit() {
    let dir = temp_dir("endless");
    let (exr, request) = (dir.join("out.exr"), dir.join("request.json"));
    std::fs::write(&request, r#"{"time_limit": 1e308, "samples": 2}"#).unwrap();
    for args in [&["--time-limit", "1e300", "--spp", "2"][..], &["--request", request.to_str().unwrap()]] {
        let o = glint(&[&["render", "--width", "8", "--height", "8", "--stats", "-o", exr.to_str().unwrap()][..], args].concat());
        assert!(o.status.success() && stderr(&o).contains("2 spp"), "{args:?}: {}", stderr(&o));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_missing_environment_image_is_a_one_line_error() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(["render", "--environment", "/nonexistent/sky.hdr", "--spp", "1", "--width", "8", "--output"])
        .arg(std::env::temp_dir().join("glint-env-missing.exr"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.lines().count() == 1 && err.contains("/nonexistent/sky.hdr"), "{err}");
}

/// A reader that goes away (`glint render … 2>&1 | head -1`) costs the lines
/// it would have read, not the render: printing to the closed pipe panicked
/// (exit 101) before the image was written.
#[test]
fn a_closed_output_pipe_does_not_lose_the_render() {
    let dir = temp_dir("pipe");
    let exr = dir.join("out.exr");
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(["render", "-o", exr.to_str().unwrap(), "--spp", "2", "--width", "40", "--height", "30", "--stats"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run glint");
    // Closed before the first line: loading the scene comes first.
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert!(status.success(), "{status}");
    let (w, h, _) = glint::output::read_exr(&exr).unwrap();
    assert_eq!((w, h), (40, 30));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--pixel-filter` and `--filter-width` (Blender's Film › Pixel Filter):
/// a Gaussian render of the default scene is clean and differs from the
/// box's; a width below 0.01 pixels is a one-line error, and a width
/// without a filter is refused by the parser.
#[test]
fn the_pixel_filter_options_render_and_bad_widths_are_errors() {
    let dir = temp_dir("filter");
    let (boxed, gaussian) = (dir.join("box.exr"), dir.join("gaussian.exr"));
    let common = ["--spp", "4", "--width", "16", "--height", "16", "--seed", "3"];
    let o = glint(&[&["render", "-o", boxed.to_str().unwrap()][..], &common].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = glint(&[&["render", "-o", gaussian.to_str().unwrap(), "--pixel-filter", "gaussian", "--filter-width", "2"][..], &common].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (glint::output::read_exr(&boxed).unwrap().2, glint::output::read_exr(&gaussian).unwrap().2);
    assert!(b.iter().all(|p| p.is_finite()) && a != b);
    let o = glint(&[&["render", "-o", dir.join("bad.exr").to_str().unwrap(), "--pixel-filter", "box", "--filter-width", "0"][..], &common].concat());
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("pixel filter") && err.trim().lines().count() == 1, "{err}");
    assert!(!glint(&["render", "--filter-width", "2", "-o", dir.join("x.exr").to_str().unwrap()]).status.success());
}
