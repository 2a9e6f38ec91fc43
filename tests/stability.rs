//! Stiff and extreme cases (issue 5): each test states the figure it
//! measured; `cargo test --release --test stability -- --nocapture` prints
//! them all. docs/stability.md lists them.

mod common;

use common::*;
use glint::Vec3;
use glint::camera::Projection;
use glint::material::Material;
use glint::render::RenderSettings;
use glint::scene::{Scene, Triangle};

/// A floor (metal or dielectric) reflecting a small, bright light: the
/// reflection is a narrow lobe that light sampling rarely lands in.
fn glossy_floor_and_small_light(roughness: f32, metallic: f32) -> Scene {
    let mut triangles = horizontal_quad(Vec3::ZERO, 2.0, 0.0, true, 0);
    triangles.extend(horizontal_quad(Vec3::new(0.0, 0.0, -0.5), 0.05, 1.0, false, 1));
    let base = if metallic > 0.0 { 0.9 } else { 0.5 };
    let floor = Material { name: "floor".into(), base_color: Vec3::splat(base), metallic, roughness, ..Material::default() };
    // The camera looks at the light's mirror point on the floor.
    let camera = look_at(Vec3::new(0.0, 1.0, 1.5), Vec3::new(0.0, 0.0, 0.5), 0.5);
    Scene::new(triangles, vec![floor, emitter(Vec3::splat(400.0))], camera)
}

fn mis(on: bool, s: RenderSettings) -> RenderSettings {
    RenderSettings { mis: on, ..s }
}

/// MIS against the seed's rule as estimators, with independent numbers:
/// stratified (Sobol) light samples over a whole quad lamp make light
/// sampling alone converge faster than 1/spp on a small light's glossy
/// reflection (16 spp: seed rule 1.8e-3 against MIS 3.0e-3, both lower than
/// with independent numbers, 7.6e-3 and 5.9e-3), so the comparison of the
/// estimators' variance would read the sampler instead.
fn estimator(on: bool, s: RenderSettings) -> RenderSettings {
    RenderSettings { sampler: glint::rng::Sampler::Random, ..mis(on, s) }
}

#[test]
fn mis_is_unbiased_and_tames_a_glossy_reflection_of_a_small_light() {
    let scene = glossy_floor_and_small_light(0.1, 1.0);
    let (w, h) = (32, 32);
    let reference = render(&scene, &estimator(true, settings(w, h, 4096, 4, 1)), 2).0;
    let ref_off = render(&scene, &estimator(false, settings(w, h, 4096, 4, 2)), 2).0;
    eprintln!("reference mean: MIS {} / seed rule {}", channel_mean(&reference), channel_mean(&ref_off));
    // Both estimators are unbiased: at 4096 spp their means agree (measured
    // 0.4% apart); 2% allows for the seed rule's heavy-tailed noise.
    assert!((channel_mean(&reference) / channel_mean(&ref_off) - 1.0).abs() < 0.02);
    // Measured relMSE (MIS / seed rule): 4 spp 1.9e-2 / 5.1e-2, 16 spp
    // 5.9e-3 / 7.6e-3, 64 spp 1.5e-3 / 2.7e-3. Seeds are fixed, so these
    // are deterministic: MIS must win at every count and converge ~1/spp.
    let mut previous = f64::INFINITY;
    for spp in [4u32, 16, 64] {
        let on = render(&scene, &estimator(true, settings(w, h, spp, 4, 10 + spp as u64)), 2);
        let off = render(&scene, &estimator(false, settings(w, h, spp, 4, 20 + spp as u64)), 2);
        assert_clean(&on.0, &on.1, "MIS");
        assert_clean(&off.0, &off.1, "seed rule");
        let (e_on, e_off) = (relative_mse(&on.0, &reference), relative_mse(&off.0, &reference));
        eprintln!("spp {spp}: relMSE MIS {e_on:.3e}, seed rule {e_off:.3e}");
        assert!(e_on < e_off, "spp {spp}: MIS {e_on} not below the seed rule {e_off}");
        assert!(e_on < previous / 2.5, "spp {spp}: MIS error {e_on} did not fall ~1/spp from {previous}");
        previous = e_on;
    }
}

#[test]
fn roughness_sweep_metal_and_dielectric_mis_against_the_seed_rule() {
    // The light spans ±0.018 rad seen in the floor; a 0.02 rad field of view
    // sees only its reflection, so the error measures the estimators on the
    // stiff part and not the pixel filter's noise at the highlight's edge.
    let (w, h) = (24, 24);
    for metallic in [1.0f32, 0.0] {
        for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 1.0] {
            let mut scene = glossy_floor_and_small_light(roughness, metallic);
            scene.camera.projection = Projection::Perspective { yfov: 0.02 };
            let reference = render(&scene, &estimator(true, settings(w, h, 4096, 3, 1)), 2).0;
            let mut line = format!("metallic {metallic} roughness {roughness}:");
            let mut errors = vec![];
            for spp in [16u32, 64, 256] {
                let (on, s_on, t_on) = render_timed(&scene, &estimator(true, settings(w, h, spp, 3, 10 + spp as u64)), 2);
                let (off, s_off, t_off) = render_timed(&scene, &estimator(false, settings(w, h, spp, 3, 20 + spp as u64)), 2);
                assert_clean(&on, &s_on, "MIS");
                assert_clean(&off, &s_off, "seed rule");
                let (e_on, e_off) = (relative_mse(&on, &reference), relative_mse(&off, &reference));
                let equal_time = e_off / (e_on * t_on.as_secs_f64() / t_off.as_secs_f64());
                line += &format!(" | {spp} spp: MIS {e_on:.2e} ({:.0} ms), seed {e_off:.2e} ({:.0} ms), x{equal_time:.1} at equal time",
                    t_on.as_secs_f64() * 1e3, t_off.as_secs_f64() * 1e3);
                errors.push((e_on, e_off));
            }
            eprintln!("{line}");
            let ((on_16, off_16), (on_256, off_256)) = (errors[0], errors[2]);
            // MIS converges about as 1/spp (ideal: 16× from 16 to 256 spp);
            // a metal mirror filling the view is exact (error ~1e-9) at once.
            if on_16 > 1e-8 {
                assert!(on_256 < on_16 / 8.0, "{line}\nMIS does not converge as 1/spp");
            }
            if roughness <= 0.05 {
                // MIS costs ≤ 10% more per sample (measured ~0–6%), so 12×
                // at equal spp is ≥ 10× at equal time. Measured ≥ 18×.
                assert!(off_256 > 12.0 * on_256, "{line}\nMIS not 10x better than the seed rule");
            } else {
                assert!(on_256 < 1.2 * off_256, "{line}\nMIS worse than the seed rule on a rough lobe");
            }
            if roughness < 0.004 {
                // A mirror (below Cycles' threshold): the seed rule never
                // sees the light in it. Its error is a bias that does not
                // fall with samples (measured relMSE 0.98–1.0 at every spp).
                assert!(off_256 > 0.5 && off_256 > 0.9 * off_16, "{line}\nseed rule should be biased here");
            }
        }
    }
}

// ---------------------------------------------------------------- lights

const FLOOR_ALBEDO: f32 = 0.5;

/// A Lambertian floor (y = 0, half-size `half`, material 0) and a camera
/// looking down at it; the caller adds emitters.
fn floor_scene(half: f32, camera: glint::camera::Camera) -> Scene {
    Scene::new(horizontal_quad(Vec3::ZERO, half, 0.0, true, 0), vec![diffuse("floor", FLOOR_ALBEDO)], camera)
}

/// A small emitting triangle centred at `c`, facing down, of area `area`.
fn small_emitter(scene: &mut Scene, c: Vec3, area: f32, le: f32) {
    // An isosceles right triangle with legs s has area s²/2.
    let s = (2.0 * area).sqrt();
    let p = [c + Vec3::new(-s / 3.0, 0.0, -s / 3.0), c + Vec3::new(2.0 * s / 3.0, 0.0, -s / 3.0), c + Vec3::new(-s / 3.0, 0.0, 2.0 * s / 3.0)];
    // Edges (s, 0, 0) then (0, 0, s): the face normal is −Y, towards the floor.
    scene.triangles.push(triangle(p, scene.materials.len() as u32));
    scene.materials.push(emitter(Vec3::splat(le)));
}

/// The exact pixel means of the floor lit by small emitters, each taken as a
/// point (error ~ (size/distance)², below 1e-3 here): L = ρ/π Σ Le A cosθ cosθ' / r²,
/// averaged over a 6×6 grid inside each pixel as the renderer's jitter does.
fn expected_floor(scene: &Scene, w: u32, h: u32) -> Vec<f32> {
    let emitters: Vec<(Vec3, f32)> = scene
        .triangles
        .iter()
        .filter(|t| scene.materials[t.material as usize].is_emissive())
        .map(|t| (t.p().into_iter().sum::<Vec3>() / 3.0, scene.materials[t.material as usize].emission.x * t.area()))
        .collect();
    let mut out = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            let mut sum = 0.0f64;
            for k in 0..36 {
                let sub = glam::Vec2::new(i as f32 + ((k % 6) as f32 + 0.5) / 6.0, j as f32 + ((k / 6) as f32 + 0.5) / 6.0);
                let glint::camera::CameraRay { origin: o, dir: d, .. } = scene.camera.ray(sub, w, h).expect("a perspective camera has every ray");
                let x = o - d * (o.y / d.y); // the floor y = 0
                for &(c, power) in &emitters {
                    let v = c - x;
                    let r2 = v.length_squared() as f64;
                    let cos = (v.y as f64 / r2.sqrt()).max(0.0); // at the floor (normal +Y) and at the emitter (normal −Y)
                    sum += power as f64 * cos * cos / r2;
                }
            }
            out.push((sum / 36.0 * FLOOR_ALBEDO as f64 / std::f64::consts::PI) as f32);
        }
    }
    out
}

/// Worst and rms relative error of the pixels' red channel (every image
/// here is grey) against exact values.
fn relative_errors(img: &[Vec3], exact: &[f32]) -> (f64, f64) {
    let errors: Vec<f64> = img.iter().zip(exact).map(|(p, &e)| ((p.x - e) / e).abs() as f64).collect();
    let worst = errors.iter().copied().fold(0.0, f64::max);
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    (worst, rms)
}

#[test]
fn tiny_emitter_of_huge_strength_matches_the_point_light_limit() {
    // 1e-6 m² at 1e8 W·sr⁻¹·m⁻² one metre above the floor: 100 W/sr.
    let mut scene = floor_scene(3.0, look_at(Vec3::new(0.0, 0.8, 0.8), Vec3::ZERO, 0.8));
    small_emitter(&mut scene, Vec3::new(0.0, 1.0, 0.0), 1e-6, 1e8);
    let (w, h) = (24, 24);
    let exact = expected_floor(&scene, w, h);
    for on in [true, false] {
        let (img, stats) = render(&scene, &mis(on, settings(w, h, 256, 3, 5)), 2);
        assert_clean(&img, &stats, "tiny emitter");
        // Light sampling of a point-like emitter is noiseless; what is left is
        // the pixel jitter over a steep falloff: measured rms 0.22%, worst
        // pixel 1.1%.
        let (worst, rms) = relative_errors(&img, &exact);
        eprintln!("tiny emitter, MIS {on}: worst pixel error {:.2}%, rms {:.2}%", worst * 100.0, rms * 100.0);
        assert!(worst < 0.03 && rms < 0.005, "MIS {on}: worst pixel {worst}, rms {rms}");
    }
}

/// A scene built past the input checks (job::MAX_RADIANCE) with an emitter
/// of 3·10^38 W·sr⁻¹·m⁻² in view: every sample of it is finite, but two of
/// them sum to infinity in an f32 pixel. The one filter every sample passes
/// (render::sample_fits) drops and counts those above render::MAX_SAMPLE,
/// and no pixel is infinite.
#[test]
fn samples_too_large_to_sum_are_dropped_not_summed_to_infinity() {
    let mut scene = floor_scene(3.0, look_at(Vec3::new(0.0, 0.8, 0.8), Vec3::new(0.0, 1.0, 0.0), 1.2));
    small_emitter(&mut scene, Vec3::new(0.0, 1.0, 0.0), 1e-2, 3e38);
    let last = scene.materials.len() - 1;
    scene.materials[last].double_sided = true;
    let (img, stats) = render(&scene, &settings(16, 16, 8, 3, 1), 2);
    assert!(stats.discarded > 0, "the emitter's own samples are above the bound");
    assert!(img.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
    assert!(glint::render::sample_fits(Vec3::splat(1e24)) && !glint::render::sample_fits(Vec3::new(0.0, 1.1e24, 0.0)));
    assert!(!glint::render::sample_fits(Vec3::new(f32::NAN, 0.0, 0.0)) && !glint::render::sample_fits(Vec3::new(0.0, 0.0, f32::INFINITY)));
}

#[test]
fn a_thousand_emitters_of_different_power() {
    let mut scene = floor_scene(3.0, look_at(Vec3::new(0.0, 0.8, 0.8), Vec3::ZERO, 0.8));
    for k in 0..1000u32 {
        let c = Vec3::new(-2.0 + 0.1 * (k % 40) as f32, 1.0, -1.25 + 0.1 * (k / 40) as f32);
        // Radiance spread over three decades, in a scrambled order.
        small_emitter(&mut scene, c, 1e-4, 10.0 * (1 + (k * 379) % 1000) as f32);
    }
    let (w, h) = (24, 24);
    let exact = expected_floor(&scene, w, h);
    for on in [true, false] {
        let (img, stats) = render(&scene, &mis(on, settings(w, h, 256, 3, 6)), 2);
        assert_clean(&img, &stats, "1000 emitters");
        let (worst, rms) = relative_errors(&img, &exact);
        let (mean, exact_mean) = (channel_mean(&img), exact.iter().map(|&e| e as f64).sum::<f64>() / exact.len() as f64);
        eprintln!("1000 emitters, MIS {on}: image mean {mean:.4} vs exact {exact_mean:.4}, worst pixel error {:.1}%, rms {:.2}%", worst * 100.0, rms * 100.0);
        // Picked by power, the emitters' noise is their 1/r² spread:
        // measured rms 6.5% per pixel at 256 spp (8.6% when picked by area),
        // worst pixel 21%, image mean within 0.01%.
        assert!(rms < 0.09 && worst < 0.4, "MIS {on}: rms {rms}, worst {worst}");
        assert!((mean / exact_mean - 1.0).abs() < 0.005, "MIS {on}: mean {mean} vs {exact_mean}");
    }
}

/// A floor under an emitting ceiling (black, facing down) of half-size
/// `half` at `height`: the ceiling fills all but ~(height/half)² of the
/// floor's hemisphere, so the floor's radiance is ρ·Le.
fn floor_under_ceiling(half: f32, height: f32, le: f32, camera: glint::camera::Camera) -> Scene {
    let mut scene = floor_scene(half, camera);
    scene.triangles.extend(horizontal_quad(Vec3::ZERO, half, height, false, 1));
    scene.materials.push(emitter(Vec3::splat(le)));
    scene
}

#[test]
fn huge_dim_emitter_and_an_emitter_ten_microns_away() {
    let cases = [
        ("huge dim ceiling: 2e4 m wide, Le 1e-3, 1 m up", floor_under_ceiling(1e4, 1.0, 1e-3, look_at(Vec3::new(0.0, 0.8, 0.8), Vec3::ZERO, 0.8))),
        // The camera sits in the 10 µm gap, looking down at 45°.
        ("ceiling 1e-5 m above the floor", floor_under_ceiling(1.0, 1e-5, 1.0, look_at(Vec3::new(0.0, 5e-6, 0.0), Vec3::new(0.0, 0.0, -5e-6), 0.8))),
    ];
    for (what, scene) in cases {
        let le = scene.materials[1].emission.x;
        let exact = FLOOR_ALBEDO * le;
        for on in [true, false] {
            let (img, stats) = render(&scene, &mis(on, settings(16, 16, 64, 3, 8)), 2);
            assert_clean(&img, &stats, what);
            let mean = channel_mean(&img);
            let (worst, rms) = relative_errors(&img, &vec![exact; img.len()]);
            eprintln!("{what}, MIS {on}: mean {mean:.5} (exact {exact}), worst pixel error {:.1}%, rms {:.2}%", worst * 100.0, rms * 100.0);
            // Where the ceiling is this close, light samples are drawn over
            // its solid angle (lights.rs): uniform over the hemisphere here,
            // where cosine sampling alone would be exact, so mixing the two
            // adds noise. Measured rms 3.3% / 3.5%, worst pixel 9.5% / 9.8%
            // (0.21% and 1.6% when light samples fell kilometres away and
            // MIS left it all to cosine sampling). The seed rule (light
            // samples only) now converges: rms 8.4% / 9.0%, worst pixel
            // 26% / 31%, means within
            // 0.3% (0.6% and 0.006% of the answer by area sampling).
            let (rms_limit, worst_limit) = if on { (0.05, 0.15) } else { (0.12, 0.45) };
            assert!(rms < rms_limit && worst < worst_limit, "{what}, MIS {on}: rms {rms}, worst {worst}");
            assert!((mean / exact as f64 - 1.0).abs() < 0.01, "{what}, MIS {on}: mean {mean}");
        }
    }
}

#[test]
fn emitters_of_zero_strength_are_not_lights() {
    let mut scene = floor_scene(3.0, look_at(Vec3::new(0.0, 0.8, 0.8), Vec3::ZERO, 0.8));
    small_emitter(&mut scene, Vec3::new(0.0, 1.0, 0.0), 1e-2, 0.0);
    let (ctx, _) = glint::integrator::Context::new(&scene);
    assert!(ctx.lights.is_empty());
    let (img, stats) = render(&scene, &mis(true, settings(8, 8, 4, 4, 0)), 1);
    assert_eq!(stats.rays.shadow, 0, "no light to sample, no shadow rays");
    assert!(img.iter().all(|p| *p == Vec3::ZERO));
    // Next to a real one it takes no light samples.
    small_emitter(&mut scene, Vec3::new(0.5, 1.0, 0.0), 1e-2, 5.0);
    let (ctx, _) = glint::integrator::Context::new(&scene);
    assert_eq!(ctx.lights.triangles, vec![3]);
}

// ---------------------------------------------------------------- scales

fn transformed(scene: &Scene, scale: f32, shift: Vec3) -> Scene {
    let mut out = scene.clone();
    for t in &mut out.triangles {
        *t = Triangle::new(t.p().map(|p| p * scale + shift), t.n(), t.material);
    }
    out.camera.position = out.camera.position * scale + shift;
    // Clip Start and End are lengths too.
    out.camera.clip = out.camera.clip.map(|d| d * scale);
    out
}

fn cornell_box() -> Scene {
    glint::loader::load_bytes(glint::DEFAULT_SCENE.as_bytes(), None, "cornell", &glint::loader::LoadOptions::default()).unwrap()
}

#[test]
fn scaled_and_translated_cornell_box_renders_the_same_image() {
    let scene = cornell_box();
    let (w, h) = (32, 32);
    let base = mis(true, settings(w, h, 64, 16, 1));
    let original = render(&scene, &base, 2).0;
    // The noise floor: the same scene with another seed.
    let other_seed = render(&scene, &RenderSettings { seed: 2, ..base.clone() }, 2).0;
    let noise = relative_mse(&other_seed, &original);
    eprintln!("noise floor (another seed): relMSE {noise:.3e}");
    for (scale, shift) in [(1e-4f32, Vec3::ZERO), (1e4, Vec3::ZERO), (1.0, Vec3::splat(1e5)), (1e-4, Vec3::new(3.0, -7.0, 1.0))] {
        let moved = transformed(&scene, scale, shift);
        // Radiance does not depend on scale or position, and with the same
        // seed the paths are the same ones until rounding sends one down
        // another branch: the images differ far less than two seeds do.
        // Acne would darken the image, leaks brighten it.
        let (img, stats) = render(&moved, &base, 2);
        assert_clean(&img, &stats, "moved");
        let e = relative_mse(&img, &original);
        let ratio = channel_mean(&img) / channel_mean(&original);
        eprintln!("scale {scale:e} shift {shift}: relMSE {e:.3e} ({:.3}× the noise floor), mean ratio {ratio:.5}", e / noise);
        if shift == Vec3::ZERO {
            // Pure scalings keep nearly every path. Since close emitters
            // are sampled by solid angle (double-precision directions), a
            // few paths round into another branch: measured 0.007× and
            // 0.002× the noise floor (8e-13 and 1e-12 before).
            assert!(e < 0.02 * noise, "scale {scale}: {e}");
        } else {
            // Far from the origin f32 snaps the geometry (1e5 m: to 7.8 mm,
            // 0.4% of the box) and the ray offsets grow with the coordinates,
            // so many paths take other branches: the image may differ as
            // much as another seed's does, but not more (acne or leaks would
            // add their own error) and not in the mean. Measured: 1.01× and
            // 0.96× the noise floor, means +0.79% and +0.72%. The snapped
            // box's own difference does not shrink with the noise: light
            // tracing took the noise floor from 1.0e-2 to 4.2e-3 and the
            // first image's difference from 6.2e-3 to 4.2e-3 (0.60× before).
            assert!(e < 1.5 * noise && (ratio - 1.0).abs() < 0.015, "shift {shift}: relMSE {e}, mean ratio {ratio}");
        }
    }
}

// ---------------------------------------------------------------- normals and leaks

/// Replace every shading normal by one tilted up to ~80° off the face
/// normal, a tenth of them flipped to face backwards.
fn perturb_normals(scene: &mut Scene, seed: u64) {
    let mut rng = glint::rng::Rng::new(seed, 1);
    for t in &mut scene.triangles {
        let face = t.cross().normalize();
        let mut normals = t.n();
        for n in &mut normals {
            let r = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            let mut v = (face + r * 3.0).normalize_or(face);
            if rng.next_f32() < 0.1 {
                v = -v;
            }
            *n = v;
        }
        *t = Triangle::new(t.p(), normals, t.material);
    }
}

#[test]
fn no_light_leaks_into_a_closed_box_whatever_its_normals() {
    for (roughness, metallic, perturbed) in [(1.0f32, 0.0f32, false), (1.0, 0.0, true), (0.2, 1.0, true), (0.0, 1.0, true)] {
        let mut scene = closed_box(0.8, 0.0);
        scene.materials[0].roughness = roughness;
        scene.materials[0].metallic = metallic;
        if perturbed {
            perturb_normals(&mut scene, 3);
        }
        // Bright double-sided emitters outside: one 10 µm behind the +X wall
        // facing in, a large one above the ceiling.
        let light = scene.materials.len() as u32;
        scene.materials.push(Material { double_sided: true, ..emitter(Vec3::splat(1e6)) });
        for p in [
            [Vec3::new(1.0 + 1e-5, -0.9, -0.9), Vec3::new(1.0 + 1e-5, 0.9, -0.9), Vec3::new(1.0 + 1e-5, 0.0, 0.9)],
            [Vec3::new(-5.0, 1.5, -5.0), Vec3::new(5.0, 1.5, -5.0), Vec3::new(0.0, 1.5, 5.0)],
        ] {
            scene.triangles.push(triangle(p, light));
        }
        let (img, stats) = render(&scene, &mis(true, settings(16, 16, 16, 8, 4)), 2);
        let what = format!("roughness {roughness} metallic {metallic} perturbed {perturbed}");
        assert_clean(&img, &stats, &what);
        assert!(img.iter().all(|p| *p == Vec3::ZERO), "{what}: light leaked in: max {}", img.iter().map(|p| p.max_element()).fold(0.0, f32::max));
    }
}

#[test]
fn wild_shading_normals_stay_finite_and_near_the_analytic_answer() {
    // The emitting box of tests/render.rs (exact answer Le/(1−a)) with
    // normals that disagree with the faces. Shading normals are not
    // energy conserving in general; this bounds what they do here.
    let (albedo, emission) = (0.5f32, 0.5f32);
    for on in [true, false] {
        let mut scene = closed_box(albedo, emission);
        perturb_normals(&mut scene, 5);
        let (img, stats) = render(&scene, &mis(on, settings(32, 32, 16, 1000, 9)), 2);
        assert_clean(&img, &stats, "wild normals");
        let exact = (emission / (1.0 - albedo)) as f64;
        let mean = channel_mean(&img);
        eprintln!("wild normals, MIS {on}: mean {mean:.4} vs {exact} flat-shaded");
        // Measured 0.881 (MIS) and 0.872 (seed rule): directions the shading
        // frame offers below the face are dropped, so energy is lost, never
        // gained (standard error of the mean here ~0.3%).
        assert!(mean < 1.01 * exact && mean > 0.8 * exact, "MIS {on}: mean {mean}");
    }
}

// ---------------------------------------------------------------- degenerate data

fn le_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A glTF file full of degenerate data around an ordinary lit floor.
fn degenerate_gltf() -> String {
    use base64::Engine;
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    #[rustfmt::skip]
    let positions: Vec<f32> = vec![
        // 0–3 floor, 4–7 emitter (facing down)
        -1.0, 0.0, 1.0,   1.0, 0.0, 1.0,   1.0, 0.0, -1.0,   -1.0, 0.0, -1.0,
        -0.2, 1.0, 0.2,   -0.2, 1.0, -0.2,  0.2, 1.0, -0.2,   0.2, 1.0, 0.2,
        // 8–10 a needle 1 m long and 1e-7 m wide, 11–13 three collinear points
        -0.5, 0.2, 0.0,   0.5, 0.2, 0.0,   0.0, 0.2 + 1e-7, 0.0,
        -0.5, 0.3, 0.0,   0.0, 0.3, 0.0,   0.5, 0.3, 0.0,
    ];
    #[rustfmt::skip]
    let normals: Vec<f32> = vec![
        nan, 1.0, 0.0,   inf, 1.0, 0.0,   0.0, 0.0, 0.0,   0.0, -1.0, 0.0, // NaN, Inf, zero-length, back-facing
        0.0, -1.0, 0.0,  0.0, -1.0, 0.0,  0.0, -1.0, 0.0,  0.0, -1.0, 0.0,
        0.0, 0.0, 1.0,   0.0, 0.0, 1e-30, 0.0, 0.0, 1.0,
        0.0, 1.0, 0.0,   0.0, 1.0, 0.0,   0.0, 1.0, 0.0,
    ];
    let uvs: Vec<f32> = (0..14).flat_map(|i| if i % 3 == 0 { [nan, inf] } else { [0.5, 0.5] }).collect();
    // floor, emitter, needle + collinear + a triangle repeating a vertex
    let indices: Vec<u16> = vec![0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 8, 9, 10, 11, 12, 13, 8, 8, 9];
    let mut buffer = le_bytes(&positions);
    buffer.extend(le_bytes(&normals));
    buffer.extend(le_bytes(&uvs));
    buffer.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let (np, nn, nt) = (positions.len() * 4, normals.len() * 4, uvs.len() * 4);
    let uri = format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&buffer));
    // Camera 0.8 m up and 2 m back, pitched down by atan(0.8 / 2).
    let half = -(0.8f32 / 2.0).atan() / 2.0;
    serde_json::json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"camera": 0, "translation": [0.0, 0.8, 2.0], "rotation": [half.sin(), 0.0, 0.0, half.cos()]},
            {"mesh": 0}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.01}}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0},
            {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 4, "material": 1},
            {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 5, "material": 2}
        ]}],
        "materials": [
            // Base colour above 1 (clamped, as glTF requires), and a black metal.
            {"pbrMetallicRoughness": {"baseColorFactor": [2.0, 0.5, -1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}},
            {"emissiveFactor": [1.0, 1.0, 1.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20.0}},
             "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.0}}
        ],
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "buffers": [{"byteLength": buffer.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": np},
            {"buffer": 0, "byteOffset": np, "byteLength": nn},
            {"buffer": 0, "byteOffset": np + nn, "byteLength": nt},
            {"buffer": 0, "byteOffset": np + nn + nt, "byteLength": indices.len() * 2}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 14, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 14, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 14, "type": "VEC2"},
            {"bufferView": 3, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 3, "byteOffset": 12, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 3, "byteOffset": 24, "componentType": 5123, "count": 9, "type": "SCALAR"}
        ]
    })
    .to_string()
}

#[test]
fn degenerate_data_loads_with_warnings_and_renders_clean() {
    let scene = glint::loader::load_bytes(degenerate_gltf().as_bytes(), None, "degenerate.gltf", &Default::default()).unwrap();
    eprintln!("warnings: {:?}", scene.warnings);
    // Floor 2 + emitter 2 + needle 1; the collinear and repeated-vertex ones go.
    assert_eq!(scene.triangles.len(), 5);
    assert!(scene.warnings.iter().any(|w| w.contains("zero-area")), "{:?}", scene.warnings);
    assert!(scene.warnings.iter().any(|w| w.contains("normal")), "{:?}", scene.warnings);
    assert_eq!(scene.materials[0].base_color, Vec3::new(1.0, 0.5, 0.0), "{:?}", scene.materials[0]);
    for t in &scene.triangles {
        assert!(t.n().iter().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-5));
    }
    for on in [true, false] {
        let (img, stats) = render(&scene, &mis(on, settings(24, 24, 32, 8, 2)), 2);
        assert_clean(&img, &stats, "degenerate data");
        // The floor is lit: base red clamped to 1 over green 0.5 over blue
        // clamped to 0, which only the white specular layer reflects
        // (measured 0.176, 0.096, 0.016).
        let floor = region_mean(&img, 24, 4..20, 16..23);
        eprintln!("degenerate data, MIS {on}: floor {floor}");
        assert!(floor.x > 1.5 * floor.y && floor.y > 3.0 * floor.z && floor.z > 0.0, "floor {floor}");
    }
}

/// Irradiance at `x` (normal `n`) from a Lambertian polygon of radiance
/// `le`: Lambert's formula, E = (Le/2)·|Σ βᵢ n·γ̂ᵢ| with βᵢ the angle each
/// edge subtends at x and γ̂ᵢ the unit normal of the plane through x and
/// the edge.
fn polygon_irradiance(x: Vec3, n: Vec3, polygon: &[Vec3], le: f64) -> f64 {
    let u: Vec<glam::DVec3> = polygon.iter().map(|&v| (v - x).as_dvec3().normalize()).collect();
    let n = n.as_dvec3();
    let sum: f64 = (0..u.len())
        .map(|i| {
            let (a, b) = (u[i], u[(i + 1) % u.len()]);
            a.cross(b).length().atan2(a.dot(b)) * n.dot(a.cross(b).normalize())
        })
        .sum();
    0.5 * le * sum.abs()
}

/// A floor under a square emitter 0.3 m and 1 cm above it, lit by its
/// front face and (two-sided, turned over) by its back: the image mean
/// against Lambert's formula for the irradiance from a polygon, with MIS
/// and with light samples alone. Near the emitter its light is sampled by
/// solid angle, farther out by area.
#[test]
fn an_emitter_close_over_a_floor_matches_lamberts_formula() {
    let cases = [
        ("0.3 m up, seen from 1.5 m", 0.3f32, Vec3::new(0.0, 0.15, 1.5), Vec3::new(0.0, -0.6, -0.2)),
        ("1 cm up, seen from its edge", 0.01, Vec3::new(0.0, 0.005, 0.52), Vec3::new(0.0, -0.1, 0.3)),
        ("1 cm up, seen from inside", 0.01, Vec3::new(0.0, 0.005, 0.2), Vec3::new(0.0, -0.1, 0.0)),
    ];
    let (w, h, le) = (32u32, 32u32, 2.0f32);
    for (what, height, eye, target) in cases {
        let mut scene = floor_scene(20.0, look_at(eye, target, 0.7));
        scene.triangles.extend(horizontal_quad(Vec3::ZERO, 0.5, height, false, 1));
        scene.materials.push(emitter(Vec3::splat(le)));
        let square = [Vec3::new(-0.5, height, -0.5), Vec3::new(0.5, height, -0.5), Vec3::new(0.5, height, 0.5), Vec3::new(-0.5, height, 0.5)];
        let mut exact = 0.0f64;
        for j in 0..h {
            for i in 0..w {
                for k in 0..16 {
                    let sub = glam::Vec2::new(i as f32 + ((k % 4) as f32 + 0.5) / 4.0, j as f32 + ((k / 4) as f32 + 0.5) / 4.0);
                    let glint::camera::CameraRay { origin: o, dir: d, .. } = scene.camera.ray(sub, w, h).expect("a perspective camera has every ray");
                    let x = o - d * (o.y / d.y);
                    exact += FLOOR_ALBEDO as f64 / std::f64::consts::PI * polygon_irradiance(x, Vec3::Y, &square, le as f64);
                }
            }
        }
        exact /= (w * h * 16) as f64;
        let mut back = scene.clone();
        back.triangles.truncate(2);
        back.triangles.extend(horizontal_quad(Vec3::ZERO, 0.5, height, true, 1));
        back.materials[1].double_sided = true;
        for (side, scene, on) in [("front", &scene, true), ("front", &scene, false), ("back", &back, true), ("back", &back, false)] {
            let means: Vec<f32> = (0..8).map(|seed| {
                let (img, stats) = render(scene, &RenderSettings { seed, ..mis(on, settings(w, h, 256, 2, 3)) }, 2);
                assert_clean(&img, &stats, "close emitter");
                channel_mean(&img) as f32
            }).collect();
            let (mean, se) = mean_and_standard_error(&means);
            eprintln!("{what}, {side}, MIS {on}: mean {mean:.5} ± {se:.5} vs exact {exact:.5} ({:+.3}% ± {:.3}%)", 100.0 * (mean / exact - 1.0), 100.0 * se / exact);
            // Measured within 0.1% (at most 1.5 σ) in all twelve cases. The
            // exact value's 4 × 4 points per pixel stand for the pixel's
            // average to better than 0.01%.
            assert!((mean - exact).abs() < 4.0 * se + 1e-4 * exact, "{what}, {side}, MIS {on}: {mean} vs {exact}");
        }
    }
}

/// Blender's Cornell box: a two-sided, reflective (0.78) lamp 1 cm under
/// the ceiling, where light is trapped between the two and points on the
/// lamp are lit again and again. Light samples alone (`--mis off`) and MIS
/// must agree. They did not (+1.7%, 6 σ) while a point on the lamp, in its
/// plane only up to rounding, drew samples of its own triangle by a solid
/// angle near 2π.
#[test]
fn a_reflective_lamp_under_a_ceiling_agrees_with_and_without_mis() {
    let (w, h) = (32u32, 32u32);
    let mut scene = floor_scene(1.0, look_at(Vec3::new(0.0, 1.0, 2.5), Vec3::new(0.0, 1.6, 0.0), 0.9));
    scene.triangles.extend(horizontal_quad(Vec3::ZERO, 1.0, 2.0, false, 0));
    scene.triangles.extend(horizontal_quad(Vec3::ZERO, 0.25, 1.99, false, 1));
    scene.materials.push(Material { base_color: Vec3::splat(0.78), double_sided: true, ..emitter(Vec3::splat(10.0)) });
    let means = |on: bool| {
        let means: Vec<f32> = (0..8)
            .map(|seed| {
                let (img, stats) = render(&scene, &RenderSettings { seed, ..mis(on, settings(w, h, 512, 8, 3)) }, 2);
                assert_clean(&img, &stats, "lamp under a ceiling");
                channel_mean(&img) as f32
            })
            .collect();
        mean_and_standard_error(&means)
    };
    let ((with, se_with), (without, se_without)) = (means(true), means(false));
    eprintln!("lamp under a ceiling: MIS {with:.5} ± {se_with:.5}, light samples alone {without:.5} ± {se_without:.5}");
    // Measured 0.15287 ± 0.00026 and 0.15281 ± 0.00026 (0.15350 and 0.15633 before the fix).
    assert!((with - without).abs() < 4.0 * se_with.hypot(se_without), "{with} vs {without}");
}
