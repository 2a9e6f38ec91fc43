//! Helpers shared by the whole-render test files: rendering a scene built in
//! code, small geometry builders and image error measures.
#![allow(dead_code)] // each test file uses its own subset

use glam::Mat4;
use glint::Vec3;
use glint::camera::{Camera, Projection};
use glint::integrator::Context;
use glint::material::Material;
use glint::render::{render_pass, Film, LightPaths, PassStats, RenderSettings};
use glint::scene::{Scene, Triangle};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// Khronos' test files: `../shared` beside the repository (CI puts them
/// there), or GLINT_SHARED_DIR.
pub fn shared_dir() -> std::path::PathBuf {
    std::env::var_os("GLINT_SHARED_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"))
}

/// Render all of `settings.spp` in one pass on `threads` threads; the image
/// is the per-pixel mean. The duration is of rendering only (no BVH build).
pub fn render_timed(scene: &Scene, settings: &RenderSettings, threads: usize) -> (Vec<Vec3>, PassStats, Duration) {
    render_prepared(scene, settings, threads, |_| {})
}

/// `render_timed`, with `prepare` changing the render's context first
/// (picking lights by power alone, say).
pub fn render_prepared(scene: &Scene, settings: &RenderSettings, threads: usize, prepare: impl FnOnce(&mut Context)) -> (Vec<Vec3>, PassStats, Duration) {
    let (mut ctx, _) = Context::new(scene);
    prepare(&mut ctx);
    let mut film = Film::new(settings.width, settings.height);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let start = Instant::now();
    let stats = pool
        .install(|| render_pass(&ctx, settings, &mut film, 0..settings.spp, &AtomicBool::new(false), &|_| {}))
        .unwrap();
    (film.mean(), stats, start.elapsed())
}

pub fn render(scene: &Scene, settings: &RenderSettings, threads: usize) -> (Vec<Vec3>, PassStats) {
    let (img, stats, _) = render_timed(scene, settings, threads);
    (img, stats)
}

pub fn settings(width: u32, height: u32, spp: u32, max_depth: u32, seed: u64) -> RenderSettings {
    RenderSettings { width, height, spp, max_depth, seed, mis: false, bsdf: Default::default(), features: Default::default(), sampler: Default::default(), light_paths: LightPaths::On, light_tracing: true, caustic_guide: true, merge: true, strategies: Default::default(), transparent: false, transparent_glass: None, adaptive: None, pixel_filter: Default::default() }
}

/// Two triangles of the square |x − cx|, |z − cz| ≤ half in the plane
/// y = `y`, front face up (+Y) or down.
pub fn horizontal_quad(c: Vec3, half: f32, y: f32, facing_up: bool, material: u32) -> Vec<Triangle> {
    let p = [
        Vec3::new(c.x - half, y, c.z - half),
        Vec3::new(c.x - half, y, c.z + half),
        Vec3::new(c.x + half, y, c.z + half),
        Vec3::new(c.x + half, y, c.z - half),
    ];
    let mut tris = vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]];
    if !facing_up {
        tris.iter_mut().for_each(|t| t.swap(1, 2));
    }
    tris.into_iter().map(|p| triangle(p, material)).collect()
}

/// A flat-shaded triangle.
pub fn triangle(p: [Vec3; 3], material: u32) -> Triangle {
    let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
    Triangle::new(p, [n; 3], material)
}

pub fn look_at(eye: Vec3, target: Vec3, yfov: f32) -> Camera {
    let forward = (target - eye).normalize();
    // Straight down or up: any horizontal right vector will do.
    let right = forward.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
    Camera { name: "cam".into(), position: eye, right, up: right.cross(forward), forward, projection: Projection::Perspective { yfov }, aspect_ratio: None, clip: [0.0, f32::INFINITY], shift: glam::Vec2::ZERO, aperture: None }
}

pub fn diffuse(name: &str, albedo: f32) -> Material {
    // KHR_materials_specular 0: a pure Lambertian surface.
    Material { name: name.into(), base_color: Vec3::splat(albedo), metallic: 0.0, specular: 0.0, ..Material::default() }
}

/// A black, single-sided emitter of radiance `le` (W·sr⁻¹·m⁻²).
pub fn emitter(le: Vec3) -> Material {
    Material { name: "light".into(), base_color: Vec3::ZERO, metallic: 0.0, specular: 0.0, emission: le, ..Material::default() }
}

/// Mean over pixels of (a − r)² / (r² + 0.01) on the channel mean: relative
/// squared error, with 0.01 keeping black pixels from dominating.
pub fn relative_mse(img: &[Vec3], reference: &[Vec3]) -> f64 {
    img.iter()
        .zip(reference)
        .map(|(a, r)| {
            let (a, r) = (a.dot(Vec3::ONE) as f64 / 3.0, r.dot(Vec3::ONE) as f64 / 3.0);
            (a - r).powi(2) / (r * r + 1e-2)
        })
        .sum::<f64>()
        / img.len() as f64
}

pub fn mean_and_standard_error(values: &[f32]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().map(|&v| v as f64).sum::<f64>() / n;
    let var = values.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

pub fn region_mean(img: &[Vec3], w: u32, x: std::ops::Range<u32>, y: std::ops::Range<u32>) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut n = 0.0;
    for j in y.clone() {
        for i in x.clone() {
            sum += img[(j * w + i) as usize];
            n += 1.0;
        }
    }
    sum / n
}

pub fn channel_mean(img: &[Vec3]) -> f64 {
    img.iter().map(|p| p.dot(Vec3::ONE) as f64 / 3.0).sum::<f64>() / img.len() as f64
}

/// Every pixel finite and non-negative.
pub fn assert_clean(img: &[Vec3], stats: &PassStats, what: &str) {
    assert_eq!(stats.discarded, 0, "{what}: non-finite samples were discarded");
    for (i, p) in img.iter().enumerate() {
        assert!(p.is_finite() && p.min_element() >= 0.0, "{what}: pixel {i} is {p}");
    }
}

/// The inside of the cube [-1, 1]³: 12 triangles facing inwards.
pub fn closed_box(albedo: f32, emission: f32) -> Scene {
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // Each face's 4 corners in order around it.
    let faces = [
        [c(-1., -1., -1.), c(1., -1., -1.), c(1., -1., 1.), c(-1., -1., 1.)], // floor, +Y
        [c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.), c(-1., 1., -1.)],     // ceiling, -Y
        [c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.), c(1., -1., -1.)], // back z=-1, +Z
        [c(1., -1., 1.), c(1., 1., 1.), c(-1., 1., 1.), c(-1., -1., 1.)],     // front z=1, -Z
        [c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.), c(-1., -1., -1.)], // left x=-1, +X
        [c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.), c(1., -1., 1.)],     // right x=1, -X
    ];
    let mut triangles = Vec::new();
    for f in faces {
        for mut p in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            // Wind each triangle so its front face looks at the centre.
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            if (p[1] - p[0]).cross(p[2] - p[0]).dot(-centroid) < 0.0 {
                p.swap(1, 2);
            }
            triangles.push(triangle(p, 0));
        }
    }
    let material = Material {
        name: "wall".into(),
        base_color: Vec3::splat(albedo),
        metallic: 0.0,
        roughness: 1.0,
        specular: 0.0, // KHR_materials_specular 0: a pure Lambertian wall
        emission: Vec3::splat(emission),
        double_sided: false,
        lamp: false,
        ..Material::default()
    };
    let camera = Camera::from_world("inside".into(), &Mat4::from_translation(glam::Vec3::new(0.1, -0.2, 0.3)), 1.2, None).unwrap();
    Scene::new(triangles, vec![material], camera)
}

/// A hall 8 m wide, 3 m high and 42 m long down −Z, lit by 32 square
/// ceiling lamps of 0.4 m (two rows, 2.5 m apart, radiance 20–60 in
/// turn) and 8 small point lights along the walls: a scene of many lights
/// where only the near ones matter to a point. The camera stands at one
/// end and looks down the hall.
pub fn lamp_hall() -> Scene {
    use glint::punctual::{PunctualKind, PunctualLight};
    let mut materials = vec![diffuse("floor", 0.6), diffuse("walls", 0.8)];
    let (x0, x1, z0, z1, h) = (-4.0f32, 4.0f32, -40.0f32, 2.0f32, 3.0f32);
    let c = Vec3::new;
    let mut triangles = Vec::new();
    let mut quad = |p: [Vec3; 4], material: u32| {
        triangles.push(triangle([p[0], p[1], p[2]], material));
        triangles.push(triangle([p[0], p[2], p[3]], material));
    };
    // Counter-clockwise seen from inside the hall.
    quad([c(x0, 0.0, z1), c(x1, 0.0, z1), c(x1, 0.0, z0), c(x0, 0.0, z0)], 0); // floor, +Y
    quad([c(x0, h, z0), c(x1, h, z0), c(x1, h, z1), c(x0, h, z1)], 1); // ceiling, −Y
    quad([c(x0, 0.0, z0), c(x0, h, z0), c(x0, h, z1), c(x0, 0.0, z1)], 1); // left, +X
    quad([c(x1, 0.0, z1), c(x1, h, z1), c(x1, h, z0), c(x1, 0.0, z0)], 1); // right, −X
    quad([c(x0, 0.0, z0), c(x1, 0.0, z0), c(x1, h, z0), c(x0, h, z0)], 1); // far end, +Z
    for k in 0..3 {
        materials.push(emitter(Vec3::new(1.0, 0.9, 0.8) * (20.0 + 20.0 * k as f32)));
    }
    for i in 0..16 {
        for (j, x) in [-2.0f32, 2.0].into_iter().enumerate() {
            let (z, material) = (-1.0 - 2.5 * i as f32, 2 + ((i + j) % 3) as u32);
            triangles.extend(horizontal_quad(c(x, 0.0, z), 0.2, h - 0.05, false, material));
        }
    }
    let camera = look_at(c(0.0, 1.6, 1.5), c(0.0, 1.2, -40.0), 60f32.to_radians());
    let mut scene = Scene::new(triangles, materials, camera);
    for i in 0..8 {
        let x = if i % 2 == 0 { x0 + 0.3 } else { x1 - 0.3 };
        scene.punctual.push(PunctualLight { name: format!("bulb {i}"), kind: PunctualKind::Point, position: c(x, 1.0, -3.0 - 5.0 * i as f32), direction: -Vec3::Y, intensity: Vec3::new(1.0, 0.6, 0.3) * 5.0, size: 0.0, sphere: false, camera_sees: false, shadowless: false });
    }
    scene
}

/// The embedded default scene (the Cornell box) as JSON, with `lights`
/// (KHR_lights_punctual's list) and `nodes` that hold them added to its
/// scene's root.
pub fn default_scene_with_lights(lights: serde_json::Value, nodes: Vec<serde_json::Value>) -> serde_json::Value {
    let mut scene: serde_json::Value = serde_json::from_str(glint::DEFAULT_SCENE).unwrap();
    scene["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
    scene["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": lights}});
    let root = scene["scene"].as_u64().unwrap_or(0) as usize;
    for node in nodes {
        let index = scene["nodes"].as_array().unwrap().len();
        scene["nodes"].as_array_mut().unwrap().push(node);
        scene["scenes"][root]["nodes"].as_array_mut().unwrap().push(serde_json::json!(index));
    }
    scene
}
