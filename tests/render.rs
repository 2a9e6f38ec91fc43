//! Whole-render tests: an analytic scene with a known answer, the default
//! Cornell box, and reproducibility.

mod common;

use common::{closed_box, mean_and_standard_error, region_mean, render, settings};
use glint::Vec3;
use glint::integrator::Context;
use glint::loader::{load_bytes, LoadOptions};
use glint::render::{render_pass, Film, LightPaths, PassStats, RenderSettings};
use glint::scene::Scene;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Inside a closed box whose walls all emit Le and reflect diffusely with
/// albedo a, radiance is Le/(1−a) everywhere: Le + a·Le + a²·Le + …
/// Every bounce's light arrives by next-event estimation over the walls.
#[test]
fn analytic_emitting_box_matches_le_over_one_minus_a() {
    for (albedo, emission, mis) in [(0.5f32, 0.5f32, false), (0.8, 0.2, false), (0.5, 0.5, true), (0.8, 0.2, true)] {
        let scene = closed_box(albedo, emission);
        // max_depth 1000: truncation bias a^1000 is nil; Russian roulette ends paths.
        let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(48, 48, 16, 1000, 7) }, 2);
        assert_eq!(stats.discarded, 0);
        // Pixels are independent estimates: their spread gives the noise.
        let values: Vec<f32> = img.iter().map(|p| p.x).collect();
        let (mean, se) = mean_and_standard_error(&values);
        let expected = (emission / (1.0 - albedo)) as f64;
        // The noise must be small enough for the test to mean something,
        // and the mean within 5 standard errors of the exact answer.
        assert!(se < 0.01 * expected, "a {albedo}: standard error {se} too large");
        assert!((mean - expected).abs() < 5.0 * se, "a {albedo}: mean {mean} vs exact {expected} (se {se})");
        // A grey scene stays grey.
        for p in &img {
            assert!(p.is_finite() && (p.x - p.y).abs() < 1e-6 && (p.y - p.z).abs() < 1e-6);
        }
    }
}

fn cornell_box() -> Scene {
    load_bytes(glint::DEFAULT_SCENE.as_bytes(), None, "cornell", &LoadOptions::default()).unwrap()
}

#[test]
fn cornell_box_renders_with_colour_bleeding_and_no_bad_pixels() {
    let scene = cornell_box();
    let (w, h) = (64, 64);
    let (img, stats) = render(&scene, &settings(w, h, 64, 16, 1), 2);
    assert_eq!(stats.discarded, 0, "non-finite samples");
    assert!(img.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));

    // Mean image luminance: measured 0.206 at 1024 spp (`glint render
    // --width 64 --height 64 --spp 1024 --seed 99`, then `cargo run
    // --example exr_stats`). The band is ±15%: wide against the ~1% noise
    // at 64 spp, narrow enough to catch a lost bounce or a doubled path.
    let mean = img.iter().copied().sum::<Vec3>() / img.len() as f32;
    let lum = mean.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    assert!((0.175..0.237).contains(&lum), "mean luminance {lum} (mean {mean})");

    // The red wall is on the left, the green on the right.
    let left = region_mean(&img, w, 1..6, 20..40);
    let right = region_mean(&img, w, 58..63, 20..40);
    assert!(left.x > 3.0 * left.y, "left wall {left}");
    // Measured 10× (red) and 1.8× (green: its reflectance is less saturated).
    assert!(right.y > 1.5 * right.x, "right wall {right}");
    // Colour bleeding: the white ceiling and floor are tinted by the near wall.
    let ceiling_left = region_mean(&img, w, 8..16, 2..6);
    let ceiling_right = region_mean(&img, w, 48..56, 2..6);
    let redness = |c: Vec3| c.x / (c.x + c.y + c.z);
    let greenness = |c: Vec3| c.y / (c.x + c.y + c.z);
    assert!(redness(ceiling_left) > redness(ceiling_right) + 0.03, "{ceiling_left} vs {ceiling_right}");
    assert!(greenness(ceiling_right) > greenness(ceiling_left) + 0.03, "{ceiling_left} vs {ceiling_right}");
    // The light itself (radiance (17, 12, 4)) is seen directly: it projects
    // to rows 7.2–10.3 and columns 26–38 of a 64² image.
    let light = region_mean(&img, w, 29..35, 8..10);
    assert!((light - Vec3::new(17.0, 12.0, 4.0)).abs().max_element() < 0.5, "light {light}");
}

#[test]
fn images_are_reproducible_across_threads_and_pass_splits() {
    let scene = cornell_box();
    let s = settings(32, 24, 4, 8, 42);
    let (a, _) = render(&scene, &s, 1);
    let (b, _) = render(&scene, &s, 2);
    assert_eq!(a, b, "thread count changed the image");
    let (c, _) = render(&scene, &s, 2);
    assert_eq!(b, c, "same settings, different image");

    // 0..4 in one pass equals 0..1 then 1..4.
    let (ctx, _) = Context::new(&scene);
    let mut film = Film::new(32, 24);
    render_pass(&ctx, &s, &mut film, 0..1, &AtomicBool::new(false), &|_| {}).unwrap();
    render_pass(&ctx, &s, &mut film, 1..4, &AtomicBool::new(false), &|_| {}).unwrap();
    let d = film.mean();
    for (x, y) in a.iter().zip(&d) {
        assert!((*x - *y).abs().max_element() <= 1e-5 * x.max_element().max(1.0));
    }

    let (e, _) = render(&scene, &settings(32, 24, 4, 8, 43), 2);
    assert_ne!(a, e, "a different seed must give different noise");
}

/// A pixel of a 1-spp render has no other samples for Sobol's sets to be
/// spread over, so such a render draws PCG32's numbers (rng.rs): the same
/// image as the Random sampler's. Past one sample the two differ.
#[test]
fn a_one_sample_render_draws_independent_numbers() {
    use glint::rng::Sampler;
    let scene = cornell_box();
    for (spp, same) in [(1, true), (2, false)] {
        let with = |sampler| render(&scene, &RenderSettings { sampler, ..settings(32, 24, spp, 8, 5) }, 2).0;
        assert_eq!(with(Sampler::Sobol) == with(Sampler::Random), same, "{spp} spp");
    }
}

/// Camera rays' first hits found among the triangles binned to their tile
/// (camera_hits.rs) give the BVH's image: the Cornell box, and the lamp
/// hall, whose camera stands inside and whose walls reach behind it.
/// Pixels may differ only where a ray meets two surfaces at the same
/// distance to rounding (either is right): at most 1 in 1,000.
#[test]
fn binned_camera_rays_give_the_bvhs_image() {
    use glint::pixel_filter::{FilterKind, PixelFilter};
    // A wide filter's rays reach 3 pixels past their own: the bins widen
    // by as much (camera_hits.rs), or rays near a tile's edge miss.
    let wide = PixelFilter::new(FilterKind::Gaussian, 2.0).unwrap();
    for (scene, what, filter) in [(cornell_box(), "Cornell box", PixelFilter::default()), (common::lamp_hall(), "lamp hall", PixelFilter::default()), (common::lamp_hall(), "lamp hall, Gaussian 2", wide)] {
        let s = RenderSettings { mis: true, pixel_filter: filter, ..settings(96, 64, 4, 8, 9) };
        let (binned, with) = render(&scene, &s, 2);
        let (traced, without, _) = common::render_prepared(&scene, &s, 2, |ctx| ctx.bin_camera_rays = false);
        assert!(with.camera_tests > 0.0 && without.camera_tests == 0.0, "{what}: {} / {}", with.camera_tests, without.camera_tests);
        let differ = binned.iter().zip(&traced).filter(|(a, b)| a != b).count();
        assert!(differ * 1000 <= binned.len(), "{what}: {differ} pixels differ");
    }
}

#[test]
fn cancelled_pass_leaves_the_film_untouched() {
    let scene = cornell_box();
    let s = settings(32, 32, 2, 4, 0);
    let (ctx, _) = Context::new(&scene);
    let mut film = Film::new(32, 32);
    let cancel = AtomicBool::new(true);
    assert!(render_pass(&ctx, &s, &mut film, 0..2, &cancel, &|_| {}).is_err());
    assert_eq!(film.samples, 0);
    assert!(film.sum.iter().all(|p| *p == Vec3::ZERO));
    // An image whose light tracing takes two batches (600²), the first
    // added to the pass's sums before the tiles find the cancel: none of
    // its light is kept.
    let mut film = Film::new(600, 600);
    let large = RenderSettings { light_paths: LightPaths::On, mis: true, ..settings(600, 600, 2, 4, 0) };
    assert!(render_pass(&ctx, &large, &mut film, 0..2, &cancel, &|_| {}).is_err());
    assert!(film.samples == 0 && film.sum.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn pass_cancelled_after_its_first_light_subpaths_leaves_an_empty_film_empty() {
    // Light subpaths are traced four sample indices at a time: cancelling
    // in the second group's tiles leaves the first group's sums and the
    // second's splats in the pass, which the film must not keep.
    let scene = cornell_box();
    let s = RenderSettings { mis: true, ..settings(32, 32, 8, 4, 0) };
    let (ctx, _) = Context::new(&scene);
    assert!(ctx.traces_light_paths(&s));
    let mut film = Film::new(32, 32);
    let cancel = AtomicBool::new(false);
    let done = AtomicU64::new(0);
    let progress = |n: u64| {
        if done.fetch_add(n, Ordering::Relaxed) + n > 32 * 32 * 5 {
            cancel.store(true, Ordering::Relaxed);
        }
    };
    assert!(render_pass(&ctx, &s, &mut film, 0..8, &cancel, &progress).is_err());
    assert_eq!((film.samples, film.sum.len()), (0, 32 * 32));
    assert!(film.sum.iter().all(|p| *p == Vec3::ZERO));
    // A film that has samples keeps them through a cancelled pass.
    cancel.store(false, Ordering::Relaxed);
    render_pass(&ctx, &s, &mut film, 0..2, &cancel, &|_| {}).unwrap();
    let kept = film.sum.clone();
    cancel.store(true, Ordering::Relaxed);
    assert!(render_pass(&ctx, &s, &mut film, 2..4, &cancel, &|_| {}).is_err());
    assert_eq!(film.samples, 2);
    assert_eq!(film.sum, kept);
}

#[test]
fn scene_without_lights_or_geometry_renders_black() {
    let mut scene = closed_box(0.5, 0.0);
    let (img, stats) = render(&scene, &settings(8, 8, 2, 4, 0), 1);
    assert!(img.iter().all(|p| *p == Vec3::ZERO));
    assert_eq!(stats.discarded, 0);
    scene.triangles.clear();
    let (img, _) = render(&scene, &settings(8, 8, 2, 4, 0), 1);
    assert!(img.iter().all(|p| *p == Vec3::ZERO));
}

/// A Lambertian floor under a uniform World of radiance B has radiance ρ·B:
/// every direction above it sees the World. Its light arrives only through
/// BSDF sampling (the World is not light-sampled), with and without MIS.
#[test]
fn a_floor_under_a_uniform_world_has_radiance_albedo_times_world() {
    let b = Vec3::new(0.2, 0.5, 1.0);
    let mut scene = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e4, 0.0, true, 0),
        vec![common::diffuse("floor", 0.6)],
        common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, 0.5),
    );
    scene.background = b;
    for mis in [true, false] {
        let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(24, 24, 32, 8, 1) }, 2);
        common::assert_clean(&img, &stats, "floor under a uniform World");
        assert_each_channel_near(&img, 0.6 * b);
    }
    // Looking up, a ray that leaves the scene sees the World itself.
    scene.camera = common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0.5);
    let (img, _) = render(&scene, &settings(8, 8, 1, 8, 1), 1);
    assert!(img.iter().all(|p| *p == b));
}

/// A Translucent BSDF sheet of albedo ρ in a uniform World B: from above
/// it shows what it passes of the World below, ρ·B, and reflects nothing
/// — light samples, BSDF samples through it and their MIS, with and
/// without MIS; its features line names it.
#[test]
fn a_translucent_sheet_passes_albedo_times_the_world_behind_it() {
    let b = Vec3::new(0.2, 0.5, 1.0);
    let sheet = glint::material::Material { transmission: 1.0, translucent: true, metallic: 0.0, specular: 0.0, base_color: Vec3::new(0.9, 0.6, 0.3), ..Default::default() };
    let mut scene = Scene::new(common::horizontal_quad(Vec3::ZERO, 1e4, 0.0, true, 0), vec![sheet], common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, 0.5));
    scene.background = b;
    for mis in [true, false] {
        let settings = RenderSettings { mis, ..settings(24, 24, 32, 8, 1) };
        let (img, stats) = render(&scene, &settings, 2);
        common::assert_clean(&img, &stats, "translucent sheet");
        assert_each_channel_near(&img, Vec3::new(0.9, 0.6, 0.3) * b);
        assert!(Context::new(&scene).0.features_line(&settings).contains("translucent=1"), "{}", Context::new(&scene).0.features_line(&settings));
    }
}

/// Each channel's mean over the image is `expected`'s within 5 standard
/// errors (and 10⁻⁴ of it, for a channel without noise).
fn assert_each_channel_near(img: &[Vec3], expected: Vec3) {
    for c in 0..3 {
        let values: Vec<f32> = img.iter().map(|p| p[c]).collect();
        let (mean, se) = mean_and_standard_error(&values);
        let expected = expected[c] as f64;
        assert!((mean - expected).abs() < 5.0 * se + 1e-4 * expected, "channel {c}: {mean} vs {expected} (se {se})");
    }
}

/// Blender's Light Path › Is Camera Ray mixing two World shaders: camera
/// rays that leave the scene see one (`camera_world`), also through a card
/// of alpha 0 (Cycles keeps a ray the camera's through transparency), and
/// every other ray the other. A floor under it has radiance ρ·B of the
/// lighting World B alone, and a mirror shows B.
#[test]
fn a_world_only_the_camera_sees_lights_nothing() {
    let (b, seen) = (Vec3::new(0.2, 0.5, 1.0), Vec3::new(3.0, 0.0, 0.25));
    let card = glint::material::Material { alpha: 0.0, alpha_mode: glint::material::AlphaMode::Blend, ..common::diffuse("card", 0.9) };
    let mut triangles = common::horizontal_quad(Vec3::ZERO, 1e4, 0.0, true, 0);
    triangles.extend(common::horizontal_quad(Vec3::new(0.0, 1.5, 0.0), 10.0, 1.5, false, 1));
    let mut scene = Scene::new(triangles, vec![common::diffuse("floor", 0.6), card], common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, 0.5));
    (scene.background, scene.camera_world) = (b, Some(glint::scene::Backdrop::Colour(seen)));
    let (img, stats) = render(&scene, &RenderSettings { mis: true, ..settings(24, 24, 32, 8, 1) }, 2);
    common::assert_clean(&img, &stats, "floor under a World the camera does not see");
    assert_each_channel_near(&img, 0.6 * b);
    // Looking up through the card, the camera sees its own World.
    scene.camera = common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0.5);
    let (img, _) = render(&scene, &settings(8, 8, 1, 8, 1), 1);
    assert!(img.iter().all(|p| *p == seen), "{:?}", img[0]);
    // A mirror shows the World that lights the scene.
    scene.materials[0] = glint::material::Material { name: "mirror".into(), base_color: Vec3::ONE, metallic: 1.0, roughness: 0.0, ..Default::default() };
    scene.camera = common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, -1.0), 0.3);
    let (img, _) = render(&scene, &RenderSettings { mis: true, ..settings(8, 8, 4, 2, 1) }, 1);
    assert!(img.iter().all(|p| (*p - b).abs().max_element() < 1e-4), "{:?}", img[0]);
}

/// A Blender area light from a render request: a disk of radius r, power P,
/// h above a floor, facing down. Its radiance is L = P/(π·πr²); directly
/// below it the floor receives E = π·L·r²/(r² + h²) and has radiance ρE/π.
/// Seen from above, the lamp is not there: no back face, no shadow.
/// The camera sees its face only when the request says so.
#[test]
fn an_area_light_lights_the_floor_as_its_power_says_and_is_invisible_from_behind() {
    let (r, h, power, albedo) = (0.5f32, 1.0f32, 50.0f32, 0.5f32);
    let base = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e3, 0.0, true, 0),
        vec![common::diffuse("floor", albedo)],
        // Above the lamp, looking straight down through it at a small spot.
        common::look_at(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, 0.01),
    );
    // Blender's lamp emits along its local −Z. An unrotated lamp in Blender
    // points down; the addon's Z-up → Y-up turn (−90° about X) makes that
    // world −Y, as here.
    let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), glam::Vec3::new(0.0, h, 0.0));
    let request = format!(
        r#"{{"area_lights": [{{"name": "Disk", "shape": "DISK", "size": [{}, 0], "matrix": {:?}, "color": [1, 1, 1], "power": {power}}}]}}"#,
        2.0 * r,
        matrix.to_cols_array()
    );
    let request = glint::request::RenderRequest::parse(request.as_bytes()).unwrap();
    let mut scene = base.clone();
    glint::lamps::add_area_lights(&mut scene, &request.area_lights).unwrap();
    let l = power / (std::f32::consts::PI * std::f32::consts::PI * r * r);
    let expected = (albedo * l * r * r / (r * r + h * h)) as f64;
    for mis in [true, false] {
        let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(16, 16, 64, 4, 2) }, 2);
        common::assert_clean(&img, &stats, "area light");
        let values: Vec<f32> = img.iter().map(|p| p.x).collect();
        let (mean, se) = mean_and_standard_error(&values);
        // The spot is 1.5 cm wide: E varies by < 0.01% across it.
        assert!((mean - expected).abs() < 5.0 * se + 1e-3 * expected, "mis {mis}: {mean} vs {expected} (se {se})");
        assert!(se < 0.01 * expected, "se {se}");
    }
    // From below, the camera does not see the lamp's face (Blender hides
    // lights from the camera) unless the request says it does: radiance L.
    scene.camera = common::look_at(Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.0, h, 0.0), 0.01);
    let (img, _) = render(&scene, &settings(4, 4, 1, 1, 2), 1);
    assert!(img.iter().all(|p| *p == Vec3::ZERO), "{:?}", img[0]);
    let mut lamps = request.area_lights.clone();
    lamps[0].visible_camera = true;
    let mut seen = Scene { camera: scene.camera.clone(), ..base.clone() };
    glint::lamps::add_area_lights(&mut seen, &lamps).unwrap();
    let (img, _) = render(&seen, &settings(4, 4, 1, 1, 2), 1);
    assert!(img.iter().all(|p| (p.x - l).abs() < 1e-4 * l), "{:?} vs {l}", img[0]);
}

/// A World and a lamp together: light sampling picks the World with a
/// probability that changes from point to point (lights.rs), so its MIS
/// weights must use the same one. Below a disk lamp of radiance L, radius
/// r, at height h, under a uniform World Lw, a floor of albedo ρ has
/// radiance ρ/π·(π·L·r²/(r² + h²) + π·Lw), with MIS and without.
#[test]
fn a_world_and_a_lamp_add_up_whatever_the_world_is_picked_with() {
    let (r, h, power, albedo, sky) = (0.5f32, 1.0f32, 50.0f32, 0.5f32, 0.3f32);
    let mut scene = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e3, 0.0, true, 0),
        vec![common::diffuse("floor", albedo)],
        common::look_at(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, 0.01),
    );
    scene.background = Vec3::splat(sky);
    let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), glam::Vec3::new(0.0, h, 0.0));
    let disk = glint::lamps::AreaLight { name: "Disk".into(), shape: glint::lamps::LampShape::Disk, size: [2.0 * r, 0.0], matrix: matrix.to_cols_array(), color: [1.0; 3], power, visible_camera: false, portal: false, spread: std::f32::consts::PI, cast_shadow: true };
    glint::lamps::add_area_lights(&mut scene, &[disk]).unwrap();
    let l = power / (std::f32::consts::PI * std::f32::consts::PI * r * r);
    let expected = (albedo / std::f32::consts::PI * (std::f32::consts::PI * l * r * r / (r * r + h * h) + std::f32::consts::PI * sky)) as f64;
    for mis in [true, false] {
        let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(32, 32, 256, 2, 3) }, 2);
        common::assert_clean(&img, &stats, "world and lamp");
        assert_red_mean_within_noise(&img, expected, &format!("mis {mis}"));
    }
}

/// The red channel's image mean within 5 standard errors of its pixels
/// (independent estimates) of `expected`, + 0.1% for float sums.
fn assert_red_mean_within_noise(img: &[Vec3], expected: f64, what: &str) {
    let values: Vec<f32> = img.iter().map(|p| p.x).collect();
    let (mean, se) = mean_and_standard_error(&values);
    eprintln!("{what}: {mean:.5} vs {expected:.5} (se {se:.5})");
    assert!((mean - expected).abs() < 5.0 * se + 1e-3 * expected, "{what}: {mean} vs {expected} (se {se})");
}

/// An environment image whose light is far from even — one bright column
/// (a stripe of 200 from pole to pole) in a sky of 0.1 — over a floor of
/// albedo ρ: radiance that depends on φ alone gives an upward surface the
/// irradiance π·mean(L) (bilinear lookups between columns keep the mean),
/// so the floor shows ρ·mean(L) with direct light only. With MIS the light
/// samples go only to the stripe and its bilinear halo (the texels above
/// the mean) and BSDF samples carry the rest; without MIS light samples
/// carry it all. Both agree with the analytic value within 5 standard
/// errors of the image mean (+0.1%).
#[test]
fn an_uneven_environment_lights_a_floor_with_and_without_mis() {
    use glint::environment::EnvironmentMap;
    use glint::texture::{Image, Texels};
    let (w, h, albedo) = (32u32, 16u32, 0.5f32);
    let column = |x: u32| if x == 11 { 200.0 } else { 0.1 };
    let texels = (0..w * h).map(|i| [column(i % w), column(i % w), column(i % w), 1.0]).collect();
    let mut scene = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e3, 0.0, true, 0),
        vec![common::diffuse("floor", albedo)],
        common::look_at(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, 0.5),
    );
    scene.environment = Some(EnvironmentMap::new(Image { name: "stripe".into(), width: w, height: h, texels: Texels::RgbaF32(texels) }, 1.0, 0.3));
    let mean = (0..w).map(column).sum::<f32>() / w as f32;
    let expected = (albedo * mean) as f64;
    for mis in [true, false] {
        let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(32, 32, 64, 1, 9) }, 2);
        common::assert_clean(&img, &stats, "uneven environment");
        assert_red_mean_within_noise(&img, expected, &format!("mis {mis}"));
    }
}

/// The last vertex `max_depth` allows still traces its BSDF ray, for the
/// light it reaches only, as Cycles does ("terminate after transparent"):
/// its light sample is MIS-weighted, not left to carry the whole estimate.
/// A direct-light-only render (max_depth 1) of glossy metal (roughness 0.3)
/// under a World and a disk lamp: light sampling alone (the seed's rule,
/// `mis` off), which the last vertex used before whatever `mis` said, draws
/// the World uniformly over the hemisphere, mostly where the lobe is not.
/// Both are unbiased, so their means agree; with MIS the noise per pixel
/// is 0.35× that of light sampling alone (measured: 0.93 against 2.6 at
/// 16 spp; before, the two were the same estimator, ratio 1).
#[test]
fn direct_light_only_weighs_both_strategies_at_the_last_vertex() {
    let (r, h, power, sky) = (0.5f32, 1.0f32, 50.0f32, 0.3f32);
    let metal = glint::material::Material { name: "metal".into(), base_color: Vec3::splat(0.9), metallic: 1.0, roughness: 0.3, ..Default::default() };
    let mut scene = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e3, 0.0, true, 0),
        vec![metal],
        common::look_at(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, 0.6),
    );
    scene.background = Vec3::splat(sky);
    let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), glam::Vec3::new(0.0, h, 0.0));
    let disk = glint::lamps::AreaLight { name: "Disk".into(), shape: glint::lamps::LampShape::Disk, size: [2.0 * r, 0.0], matrix: matrix.to_cols_array(), color: [1.0; 3], power, visible_camera: false, portal: false, spread: std::f32::consts::PI, cast_shadow: true };
    glint::lamps::add_area_lights(&mut scene, &[disk]).unwrap();
    // The noise of a pixel, from the difference of two seeds' images; the
    // mean over both.
    let mut estimates = Vec::new();
    for mis in [true, false] {
        let [a, b] = [5, 6].map(|seed| {
            let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(32, 32, 16, 1, seed) }, 2);
            common::assert_clean(&img, &stats, "direct light only");
            img
        });
        let n = a.len() as f64;
        let mean = a.iter().chain(&b).map(|p| p.x as f64).sum::<f64>() / (2.0 * n);
        let noise = (a.iter().zip(&b).map(|(p, q)| ((p.x - q.x) as f64).powi(2) / 2.0).sum::<f64>() / n).sqrt();
        let se = noise / (2.0 * n).sqrt();
        eprintln!("mis {mis}: mean {mean:.5} (se {se:.5}), noise per pixel {noise:.5}");
        estimates.push((mean, se, noise));
    }
    let ((a, sa, na), (b, sb, nb)) = (estimates[0], estimates[1]);
    assert!((a - b).abs() < 5.0 * (sa * sa + sb * sb).sqrt(), "with MIS {a} ± {sa}, light sampling alone {b} ± {sb}");
    assert!(na < 0.5 * nb, "noise per pixel with MIS {na} against light sampling alone {nb}");
}

/// With one scattering event allowed, a perfect mirror still shows what
/// its BSDF ray reaches, as in Cycles with Max Bounces 0: light samples
/// cannot follow a delta lobe, so before the last vertex traced its ray the
/// mirror came out black. Under a World of radiance Lw a mirror of F0 = 1
/// shows Lw exactly.
#[test]
fn a_mirror_shows_the_world_with_direct_light_only() {
    let sky = Vec3::new(0.2, 0.5, 1.0);
    let mirror = glint::material::Material { name: "mirror".into(), base_color: Vec3::ONE, metallic: 1.0, roughness: 0.0, ..Default::default() };
    let mut scene = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e3, 0.0, true, 0),
        vec![mirror],
        common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, -1.0), 0.3),
    );
    scene.background = sky;
    let (img, stats) = render(&scene, &RenderSettings { mis: true, ..settings(8, 8, 4, 1, 1) }, 1);
    common::assert_clean(&img, &stats, "mirror");
    for p in &img {
        assert!((*p - sky).abs().max_element() < 1e-4, "{p} vs {sky}");
    }
}

/// Punctual lights on a Lambertian floor of albedo ρ: below a point light of
/// intensity I at height h the floor's radiance is ρ/π · I/h²; under a sun
/// of irradiance E at 60° from the zenith, ρ/π · E cos 60°. Each alone and
/// both together (light picking by power must not bias the sum).
#[test]
fn point_and_sun_light_a_floor_as_the_inverse_square_and_cosine_laws_say() {
    use glint::punctual::{PunctualKind, PunctualLight};
    let (albedo, h, intensity, sun_e) = (0.5f32, 2.0f32, 40.0f32, 3.0f32);
    let mut scene = Scene::new(
        common::horizontal_quad(Vec3::ZERO, 1e3, 0.0, true, 0),
        vec![common::diffuse("floor", albedo)],
        common::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, 0.01),
    );
    let point = PunctualLight { name: "bulb".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, h, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(intensity), size: 0.0, sphere: false, camera_sees: false, shadowless: false };
    let tilt = 60f32.to_radians();
    let sun = PunctualLight { name: "sun".into(), kind: PunctualKind::Sun, position: Vec3::ZERO, direction: Vec3::new(tilt.sin(), -tilt.cos(), 0.0), intensity: Vec3::splat(sun_e), size: 0.0, sphere: false, camera_sees: false, shadowless: false };
    let from_point = albedo / std::f32::consts::PI * intensity / (h * h);
    let from_sun = albedo / std::f32::consts::PI * sun_e * tilt.cos();
    for (lights, expected) in [(vec![point.clone()], from_point), (vec![sun.clone()], from_sun), (vec![point, sun], from_point + from_sun)] {
        scene.punctual = lights;
        let (img, stats) = render(&scene, &settings(8, 8, 256, 1, 3), 2);
        common::assert_clean(&img, &stats, "punctual lights");
        let values: Vec<f32> = img.iter().map(|p| p.x).collect();
        let (mean, se) = mean_and_standard_error(&values);
        // The camera sees a 1 cm spot: the light varies by < 1e-5 over it.
        assert!((mean - expected as f64).abs() < 5.0 * se + 1e-4 * expected as f64, "{mean} vs {expected} (se {se})");
        // Both lights get samples: the sun is picked by its irradiance
        // share, not by a power over the 2 km floor's bounding sphere,
        // which left the bulb one sample in 40,000 (and, on a bad seed, a
        // mean of the sun alone with a standard error of 0).
        eprintln!("{} lights: {mean:.5} vs {expected:.5} (se {se:.6})", scene.punctual.len());
        assert!(se > 0.0 || scene.punctual.len() == 1, "one light was never picked");
        assert!(se < 0.01 * expected as f64, "standard error {se}");
    }
}

/// A scene pays only for what it uses (features.rs): every kernel the
/// features choose renders the general kernel's image bit for bit, for the
/// same seed, whatever parts it leaves out.
#[test]
fn specialised_kernels_render_the_general_kernels_image() {
    use common::{diffuse, horizontal_quad, look_at};
    use glint::features::{FeatureMode, KernelBsdf};
    use glint::lamps::{AreaLight, LampShape};
    use glint::material::Material;
    use glint::punctual::{PunctualKind, PunctualLight};

    let floor = |material: Material| {
        let camera = look_at(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, 0.9);
        Scene::new(horizontal_quad(Vec3::ZERO, 2.0, 0.0, true, 0), vec![material], camera)
    };
    let metal = Material { name: "metal".into(), base_color: Vec3::new(0.9, 0.6, 0.3), metallic: 1.0, roughness: 0.4, ..Material::default() };
    let mut sky = floor(diffuse("floor", 0.5));
    sky.background = Vec3::new(0.2, 0.3, 0.4);
    let mut point = floor(diffuse("floor", 0.5));
    point.punctual.push(PunctualLight { name: "p".into(), kind: PunctualKind::Point, position: Vec3::new(0.3, 1.0, 0.2), direction: -Vec3::Y, intensity: Vec3::splat(3.0), size: 0.0, sphere: false, camera_sees: false, shadowless: false });
    let mut lamp = floor(metal.clone());
    let m = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), glam::Vec3::new(0.0, 1.0, 0.0));
    let light = AreaLight { name: "a".into(), shape: LampShape::Square, size: [0.5, 0.5], matrix: m.to_cols_array(), color: [1.0; 3], power: 20.0, visible_camera: false, portal: false, spread: std::f32::consts::PI, cast_shadow: true };
    glint::lamps::add_area_lights(&mut lamp, &[light]).unwrap();
    let cornell = load_bytes(glint::DEFAULT_SCENE.as_bytes(), None, "cornell", &LoadOptions::default()).unwrap();
    let cases = [
        ("closed diffuse box", closed_box(0.5, 0.5), "lambert + emitters"),
        ("floor under a sky", sky, "lambert + no local lights"),
        ("floor under a point light", point, "lambert + punctual"),
        ("metal under an area light", lamp, "principled + emitters + lamps"),
        ("Cornell box", cornell, "principled + emitters"),
    ];
    for (what, scene, kernel) in cases {
        let (ctx, _) = Context::new(&scene);
        let base = RenderSettings { mis: true, ..settings(24, 24, 8, 6, 5) };
        let auto = RenderSettings { features: FeatureMode::Auto, ..base.clone() };
        let all = RenderSettings { features: FeatureMode::All, ..base };
        assert_eq!(ctx.kernel(&auto).to_string(), kernel, "{what}");
        assert_ne!(ctx.kernel(&all).bsdf, KernelBsdf::Lambert);
        let (a, _) = render(&scene, &auto, 2);
        let (b, _) = render(&scene, &all, 2);
        assert!(a.iter().any(|p| p.max_element() > 0.0), "{what}: black image");
        let bits = |img: &[Vec3]| img.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        assert!(bits(&a) == bits(&b), "{what}: the {kernel} kernel's image differs from the general kernel's");
    }
}

/// A two-sided lamp hanging 2 cm below the ceiling of a closed box, and a
/// metal plate on the floor: light leaves the gap above the lamp only
/// through the slit, after bounces inside it, the case light subpaths are
/// for (light_paths.rs). Their connections, MIS-weighted against light and
/// BSDF sampling, must leave the image's expectation where it was, and
/// here they must lower its noise: from the plate where it is rough, from
/// the camera path's next vertex where it is a glossy metal that does not
/// connect.
#[test]
fn light_paths_keep_the_image_and_lower_the_noise_of_a_lamp_under_a_ceiling() {
    // The glossy plate covers the floor, so that many camera paths start
    // on it.
    for (roughness, centre, half) in [(0.6, Vec3::new(0.2, 0.0, -0.4), 0.3), (0.2, Vec3::ZERO, 0.95)] {
        let mut scene = closed_box(0.6, 0.0);
        scene.materials.push(common::emitter(Vec3::splat(20.0)));
        scene.materials[1].double_sided = true;
        scene.materials.push(glint::material::Material { name: "plate".into(), base_color: Vec3::new(0.9, 0.6, 0.3), metallic: 1.0, roughness, ..glint::material::Material::default() });
        scene.triangles.extend(common::horizontal_quad(Vec3::ZERO, 0.3, 0.98, false, 1));
        scene.triangles.extend(common::horizontal_quad(centre, half, -0.99, true, 2));
        let scene = Scene::new(scene.triangles, scene.materials, scene.camera);
        let with = RenderSettings { mis: true, ..settings(24, 24, 64, 6, 0) };
        let without = RenderSettings { light_paths: LightPaths::Off, ..with.clone() };
        let (v_on, v_off) = same_image_less_noise(&scene, &with, &without, &format!("light paths, roughness {roughness}"));
        assert!(v_on < 0.8 * v_off, "roughness {roughness}: light paths {v_on} vs without {v_off}");
    }
}

/// A softbox (a 1 × 0.6 m area light with a 30° Spread) under the ceiling
/// of a closed box: its light subpaths leave within the grid's cone
/// (`Spread::emission_direction`), and their connections and the light
/// they trace to the camera, weighed with that cone's density, must leave
/// the image's expectation where camera paths alone put it, and lower its
/// noise: the patch the lamp lights on the floor lights the rest of the
/// box, light that camera paths find by chance.
#[test]
fn light_paths_keep_the_image_of_a_softbox_and_lower_its_noise() {
    use glint::lamps::{add_area_lights, AreaLight, LampShape};
    let mut scene = closed_box(0.6, 0.0);
    let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), glam::Vec3::new(0.1, 0.9, -0.2));
    let lamp = AreaLight { name: "Softbox".into(), shape: LampShape::Rectangle, size: [1.0, 0.6], matrix: matrix.to_cols_array(), color: [1.0; 3], power: 40.0, visible_camera: false, portal: false, spread: 30f32.to_radians(), cast_shadow: true };
    add_area_lights(&mut scene, &[lamp]).unwrap();
    let scene = Scene::new(scene.triangles, scene.materials, scene.camera);
    let with = RenderSettings { mis: true, light_paths: LightPaths::On, ..settings(24, 24, 64, 6, 0) };
    let without = RenderSettings { light_paths: LightPaths::Off, ..with.clone() };
    let (v_on, v_off) = same_image_less_noise(&scene, &with, &without, "a softbox's light paths");
    assert!(v_on < 0.8 * v_off, "light paths {v_on} vs without {v_off}");
}

/// A bulb (a point light) 10 cm under the ceiling of a closed box, over
/// a glossy metal plate: light subpaths start from it (light_paths.rs,
/// `PointEmission`), and their connections and the light they trace to
/// the camera, MIS-weighted against its light samples and, for a sized
/// bulb, the BSDF rays that meet it, must leave the image's expectation
/// where camera paths alone put it — a bulb of radius 0, one of 5 cm
/// drawn as a disk facing the point it lights (Blender's Soft Falloff),
/// and one drawn as a sphere — and lower its noise: the ceiling the bulb
/// lights from 10 cm, which lights the rest of the box, and the plate's
/// caustic on it are light camera paths find by chance. The same of a
/// spot (50°, blend 0.3) of radius 0 and 5 cm, shining down.
#[test]
fn light_paths_from_a_bulb_keep_the_image_and_lower_its_noise() {
    use glint::punctual::{PunctualKind, PunctualLight};
    let mut scene = closed_box(0.6, 0.0);
    scene.materials.push(glint::material::Material { name: "plate".into(), base_color: Vec3::new(0.9, 0.6, 0.3), metallic: 1.0, roughness: 0.2, ..glint::material::Material::default() });
    scene.triangles.extend(common::horizontal_quad(Vec3::new(0.2, 0.0, -0.4), 0.4, -0.99, true, 1));
    let mut scene = Scene::new(scene.triangles, scene.materials, scene.camera);
    let spot = PunctualLight::spot(50f32.to_radians(), 35f32.to_radians());
    for (kind, size, sphere) in [(PunctualKind::Point, 0.0, false), (PunctualKind::Point, 0.05, false), (PunctualKind::Point, 0.05, true), (spot, 0.0, false), (spot, 0.05, false)] {
        let bulb = PunctualLight { name: "bulb".into(), kind, position: Vec3::new(-0.3, 0.9, 0.1), direction: -Vec3::Y, intensity: Vec3::splat(2.0), size, sphere, camera_sees: false, shadowless: false };
        scene.punctual = vec![bulb];
        let with = RenderSettings { mis: true, light_paths: LightPaths::On, ..settings(24, 24, 64, 6, 0) };
        let without = RenderSettings { light_paths: LightPaths::Off, ..with.clone() };
        let what = format!("a bulb's light paths, {kind:?}, radius {size}, sphere {sphere}");
        let (v_on, v_off) = same_image_less_noise(&scene, &with, &without, &what);
        assert!(v_on < 0.8 * v_off, "{what}: light paths {v_on} vs without {v_off}");
    }
}

/// Renders `scene` twice each `with` and `without` a strategy (seeds 1–4),
/// asserts that the strategy leaves the image's expectation where it was,
/// and returns the variance per pixel with and without it.
fn same_image_less_noise(scene: &Scene, with: &RenderSettings, without: &RenderSettings, what: &str) -> (f64, f64) {
    let run = |settings: &RenderSettings, seed: u64| render(scene, &RenderSettings { seed, ..settings.clone() }, 2);
    same_image_less_noise_of(|seed| run(with, seed), |seed| run(without, seed), what, |on, off| assert!(on.rays.shadow > off.rays.shadow, "{what}: the strategy traces shadow rays"))
}

/// `same_image_less_noise` of two scenes meant to render the same image,
/// one `with` a sampling aid.
fn same_scene_less_noise(with: &Scene, without: &Scene, settings: &RenderSettings, what: &str) -> (f64, f64) {
    let run = |scene: &Scene, seed: u64| render(scene, &RenderSettings { seed, ..settings.clone() }, 2);
    same_image_less_noise_of(|seed| run(with, seed), |seed| run(without, seed), what, |_, _| {})
}

/// `same_image_less_noise` of two ways to render an image (`with(seed)`
/// and `without(seed)`), `check` given their first renders' statistics.
fn same_image_less_noise_of(with: impl Fn(u64) -> (Vec<Vec3>, PassStats), without: impl Fn(u64) -> (Vec<Vec3>, PassStats), what: &str, check: impl FnOnce(&PassStats, &PassStats)) -> (f64, f64) {
    let ((on1, s_on), (on2, _), (off1, s_off), (off2, _)) = (with(1), with(2), without(3), without(4));
    common::assert_clean(&on1, &s_on, what);
    check(&s_on, &s_off);
    // Unbiased: per pixel, (on − off) has mean 0; pixels are independent.
    let lum = |p: &Vec3| p.dot(Vec3::ONE) / 3.0;
    let diffs: Vec<f32> = on1.iter().zip(&off1).chain(on2.iter().zip(&off2)).map(|(a, b)| lum(a) - lum(b)).collect();
    let (mean_diff, se) = mean_and_standard_error(&diffs);
    let level = common::channel_mean(&off1);
    assert!(se < 0.02 * level, "{what}: standard error {se} against a mean of {level}");
    assert!(mean_diff.abs() < 5.0 * se, "{what}: the strategy moves the image by {mean_diff} (se {se}, mean {level})");
    // Noise per pixel from two seeds: Var = mean((x1 − x2)²) / 2.
    let noise = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).map(|(x, y)| ((lum(x) - lum(y)) as f64).powi(2)).sum::<f64>() / (2.0 * a.len() as f64);
    let (v_on, v_off) = (noise(&on1, &on2), noise(&off1, &off2));
    println!("{what}: diff {mean_diff} se {se}; variance per pixel: with {v_on:.3e}, without {v_off:.3e}");
    (v_on, v_off)
}

/// The light tree picks the lamps near a point: in a hall of 32 ceiling
/// lamps and 8 bulbs it must leave the image's expectation where picking
/// by power puts it, and make it less noisy (direct light and one bounce,
/// where the pick matters most).
#[test]
fn the_light_tree_keeps_the_image_and_lowers_the_noise_of_a_lamp_hall() {
    let scene = common::lamp_hall();
    // Without light subpaths, whose connections (from the bulbs too) pick
    // their vertices without the tree: the light samples alone show what
    // the pick does.
    let settings = RenderSettings { mis: true, light_paths: LightPaths::Off, ..common::settings(32, 32, 64, 2, 0) };
    let run = |seed: u64, by_power: bool| {
        let (img, stats, _) = common::render_prepared(&scene, &RenderSettings { seed, ..settings.clone() }, 2, |ctx| {
            assert_eq!(ctx.lights.tree_size(), 16 * 2 + 8, "a quad lamp is one light of the tree");
            assert!(ctx.features_line(&settings).ends_with("kernel: lambert + emitters + punctual + light tree (40 lights)"), "{}", ctx.features_line(&settings));
            if by_power {
                ctx.lights.pick_by_power();
            }
        });
        (img, stats)
    };
    let (v_tree, v_power) = same_image_less_noise_of(|seed| run(seed, false), |seed| run(seed, true), "light tree", |_, _| {});
    assert!(v_tree < 0.5 * v_power, "light tree {v_tree} vs by power {v_power}");
}

/// A lamp under the ceiling of a closed box and a glossy metal plate on
/// the floor, tilted 45° so that it throws the lamp's light onto the back
/// wall the camera looks at: a caustic, which camera paths find only when a
/// diffuse bounce from the wall meets the plate where it mirrors the lamp.
fn caustic_box() -> Scene {
    let mut scene = closed_box(0.6, 0.0);
    scene.materials.push(common::emitter(Vec3::splat(20.0)));
    scene.materials.push(glint::material::Material { name: "plate".into(), base_color: Vec3::new(0.9, 0.6, 0.3), metallic: 1.0, roughness: 0.15, ..glint::material::Material::default() });
    scene.triangles.extend(common::horizontal_quad(Vec3::new(0.0, 0.0, -0.2), 0.15, 0.98, false, 1));
    // Normal (0, 1, −1)/√2: light falling straight down leaves along −Z.
    let (c, x, t) = (Vec3::new(0.0, -0.7, -0.2), Vec3::X * 0.3, Vec3::new(0.0, 1.0, 1.0).normalize() * 0.3);
    let corners = [c - x - t, c + x - t, c + x + t, c - x + t];
    scene.triangles.push(common::triangle([corners[0], corners[2], corners[1]], 2));
    scene.triangles.push(common::triangle([corners[0], corners[3], corners[2]], 2));
    Scene::new(scene.triangles, scene.materials, scene.camera)
}

/// Light tracing (light_tracing.rs) must leave the image's expectation of
/// the caustic box where it was and lower its noise.
#[test]
fn light_tracing_keeps_the_image_and_lowers_the_noise_of_a_caustic() {
    let scene = caustic_box();
    // 24² pixels trace 144 subpaths per sample index to the camera, fewer
    // than the 256 whose vertices z connects to; 256 spp resolve a bias of
    // 1% of the image at 5 standard errors.
    let with = RenderSettings { mis: true, ..settings(24, 24, 256, 6, 0) };
    let without = RenderSettings { light_tracing: false, ..with.clone() };
    let (v_on, v_off) = same_image_less_noise(&scene, &with, &without, "light tracing");
    assert!(v_on < 0.5 * v_off, "light tracing {v_on} vs without {v_off}");
}

/// A large image traces its n_T (a quarter of its pixels) in batches of
/// 65,536 (render.rs), each added to the image in turn: at 560² (78,400
/// subpaths per sample index, two batches) light tracing must still leave
/// the caustic box's image where camera paths alone put it. Without the
/// second batch the caustic it carries loses a fifth: −0.7% over the image,
/// 9 standard errors.
#[test]
fn light_tracing_a_large_image_in_batches_keeps_the_image() {
    let scene = caustic_box();
    let with = RenderSettings { mis: true, ..settings(560, 560, 4, 6, 0) };
    let without = RenderSettings { light_tracing: false, ..with.clone() };
    same_image_less_noise(&scene, &with, &without, "light tracing in batches");
}

/// An object hidden from the camera (Blender's Ray Visibility › Camera
/// off): camera rays pass it, and so must light tracing's way to the
/// camera. A black card 1 cm in front of the camera, filling its view and
/// hidden from it, leaves the image of the caustic box as it was
/// (it takes a 2 × 2 cm patch's light out of the box); had the card
/// blocked light tracing's shadow rays, the caustic, which light tracing
/// carries, would go dark (−4%, 17 standard errors); had camera rays
/// through the BVH stopped at it, the image would be black.
#[test]
fn a_card_hidden_from_the_camera_leaves_its_image_as_it_was() {
    let (mut scene, without) = (caustic_box(), caustic_box());
    // The camera sits at (0.1, −0.2, 0.3) looking down −Z, 1.2 rad across.
    scene.materials.push(glint::material::Material { hidden_from_camera: true, ..common::diffuse("card", 0.0) });
    let (o, h) = (Vec3::new(0.1, -0.2, 0.29), 0.01);
    let card = [o + Vec3::new(-h, -h, 0.0), o + Vec3::new(h, -h, 0.0), o + Vec3::new(h, h, 0.0), o + Vec3::new(-h, h, 0.0)];
    scene.triangles.push(common::triangle([card[0], card[1], card[2]], 3));
    scene.triangles.push(common::triangle([card[0], card[2], card[3]], 3));
    let with = Scene::new(scene.triangles, scene.materials, scene.camera);
    let settings = RenderSettings { mis: true, ..settings(24, 24, 256, 6, 0) };
    assert!(Context::new(&with).0.features_line(&settings).contains("hidden from camera=1; kernel: principled + emitters + light paths"), "{}", Context::new(&with).0.features_line(&settings));
    same_scene_less_noise(&with, &without, &settings, "a card hidden from the camera");
    // Camera rays through the BVH too, not only binned (camera_hits.rs).
    let through_bvh = |scene: &Scene, seed: u64| {
        let (img, stats, _) = common::render_prepared(scene, &RenderSettings { seed, ..settings.clone() }, 2, |ctx| ctx.bin_camera_rays = false);
        (img, stats)
    };
    same_image_less_noise_of(|seed| through_bvh(&with, seed), |seed| through_bvh(&without, seed), "a card hidden from camera rays through the BVH", |_, _| {});
}

/// The four ways to a path of the Cornell box (BSDF sampling, light
/// sampling, a connection to a light vertex, light tracing) must weigh each
/// path with weights that sum to one, each side computing the others'
/// densities; a weight that leaves one strategy out (light tracing in the
/// connection's, say) makes the paths both reach count more than once. On
/// this scene's gold sphere and walls the strategies overlap on most paths,
/// so such a slip moves the whole image by 0.6–1.6%: the image with all
/// four must equal camera paths alone (BSDF and light sampling, whose MIS
/// the analytic box checks) in every colour channel, at 5 standard errors.
#[test]
fn the_cornell_box_is_the_same_with_all_four_strategies_as_with_camera_paths_alone() {
    let scene = cornell_box();
    let run = |light_paths: bool, seed: u64| render(&scene, &RenderSettings { mis: true, light_paths: if light_paths { LightPaths::On } else { LightPaths::Off }, light_tracing: light_paths, ..settings(64, 64, 128, 16, seed) }, 2).0;
    let (all, camera) = ([run(true, 11), run(true, 12)].concat(), [run(false, 13), run(false, 14)].concat());
    for c in 0..3 {
        let diffs: Vec<f32> = all.iter().zip(&camera).map(|(a, b)| a[c] - b[c]).collect();
        let (diff, se) = mean_and_standard_error(&diffs);
        let level = camera.iter().map(|p| p[c] as f64).sum::<f64>() / camera.len() as f64;
        println!("channel {c}: mean {level:.5}, all four − camera paths {diff:.6} (se {se:.6}, {:.2}%)", 100.0 * diff / level);
        // The resolution the test claims: 5 se below 1% of the image.
        assert!(5.0 * se < 0.01 * level, "channel {c}: standard error {se} against a mean of {level}");
        assert!(diff.abs() < 5.0 * se, "channel {c}: all four strategies move the image by {diff} (se {se}, mean {level})");
    }
}

/// Taking a render apart (`--strategies`, `--depths`; strategies.rs): the
/// images of each strategy alone, and of depths 0, 1, 2 and 3–, add up to
/// the whole render, and each part holds light of its own, so a
/// contribution counted by no part or by two would show. The Cornell box
/// with a World behind its open side makes every strategy count: the
/// camera sees the lamp and the World, BSDF samples and light samples
/// reach both, and the light paths connect and splat; its gold ball made a
/// smooth mirror, the floor seen in it merges with the photons the ball
/// reflects onto it (the caustic guide off: it would move the first
/// bounce's BSDF samples, which the render of max depth 1 below, with no
/// light subpaths, draws unguided). Tolerance: the parts
/// add their samples in another order, a relative rounding of ~1e-7 per
/// addition; 1e-4 of each pixel leaves room for a few hundred.
#[test]
fn a_render_taken_apart_by_strategy_or_depth_adds_up_to_the_whole() {
    use glint::strategies::{Strategies, Strategy};
    let mut scene = cornell_box();
    scene.background = Vec3::splat(0.3);
    let gold = scene.materials.iter_mut().find(|m| m.name == "gold").expect("the Cornell box's gold ball");
    gold.roughness = 0.0;
    let base = RenderSettings { mis: true, caustic_guide: false, ..settings(32, 32, 8, 8, 5) };
    let whole = render(&scene, &base, 2).0;
    let part = |strategies: Strategies| render(&scene, &RenderSettings { strategies, ..base.clone() }, 2).0;
    let by_strategy: Vec<_> = Strategy::ALL.iter().map(|&s| (format!("{s:?}"), part(Strategies::only(&[s])))).collect();
    let by_depth: Vec<_> = [(0, 0), (1, 1), (2, 2), (3, u32::MAX)].iter().map(|&(a, b)| (format!("depths {a}-{b}"), part(Strategies::ALL.with_depths(a, b)))).collect();
    let total = |img: &[Vec3]| img.iter().map(|p| p.element_sum() as f64).sum::<f64>();
    for parts in [by_strategy, by_depth] {
        for (name, img) in &parts {
            assert!(total(img) > 1e-3 * total(&whole), "{name} adds no light: {} of {}", total(img), total(&whole));
        }
        for (i, w) in whole.iter().enumerate() {
            let sum: Vec3 = parts.iter().map(|(_, img)| img[i]).sum();
            assert!((sum - *w).abs().max_element() <= 1e-4 * w.max_element() + 1e-6, "pixel {i}: parts add to {sum}, the whole is {w}");
        }
    }
    // Depths are counted as --max-depth counts them: depths 0–1 are what
    // a direct-light-only render sees, drawn from the same numbers
    // (measured equal to 4e-9; light sampling counted a bounce deeper
    // than it is, 4.7% more).
    let (direct, capped) = (total(&part(Strategies::ALL.with_depths(0, 1))), total(&render(&scene, &RenderSettings { max_depth: 1, ..base.clone() }, 2).0));
    assert!((direct - capped).abs() <= 1e-4 * capped, "depths 0-1 hold {direct}, a render of max depth 1 {capped}");
}

/// A closed 2 m room (albedo 0.5) whose right wall, x = 1, has a window
/// 1 m wide and 0.8 m high, lit only by the World through it; with a
/// Blender portal (a RECTANGLE area light marked Portal, its −Z into the
/// room) in the window when `portal`, given as the render request gives it.
fn room_with_a_window(portal: bool) -> Scene {
    use glint::lamps::{AreaLight, LampShape};
    let mut scene = closed_box(0.5, 0.0);
    scene.triangles.retain(|t| t.p().iter().any(|p| p.x < 0.999));
    let (y0, y1, z0, z1) = (-0.2, 0.6, -0.5, 0.5);
    for (ya, yb, za, zb) in [(-1.0, y0, -1.0, 1.0), (y1, 1.0, -1.0, 1.0), (y0, y1, -1.0, z0), (y0, y1, z1, 1.0)] {
        let c = |y: f32, z: f32| Vec3::new(1.0, y, z);
        // Wound to face the room (−X).
        scene.triangles.push(common::triangle([c(ya, za), c(yb, zb), c(yb, za)], 0));
        scene.triangles.push(common::triangle([c(ya, za), c(ya, zb), c(yb, zb)], 0));
    }
    assert!(scene.triangles.iter().all(|t| t.cross().x <= 0.0 || t.p().iter().all(|p| p.x < 1.0)), "the wall's pieces face the room");
    if portal {
        // Local X along world −Z, local Y along Y, local Z along +X: −Z,
        // where an area light shines, is into the room.
        let m = glam::Mat4::from_cols(glam::Vec4::new(0.0, 0.0, -1.0, 0.0), glam::Vec4::Y, glam::Vec4::X, glam::Vec4::new(1.0, 0.5 * (y0 + y1), 0.0, 1.0));
        let light = AreaLight { name: "window".into(), shape: LampShape::Rectangle, size: [z1 - z0, y1 - y0], matrix: m.to_cols_array(), color: [1.0; 3], power: 1000.0, visible_camera: false, portal: true, spread: std::f32::consts::PI, cast_shadow: true };
        glint::lamps::add_area_lights(&mut scene, &[light]).unwrap();
        assert_eq!(scene.portals.len(), 1);
    }
    scene.background = Vec3::new(1.0, 0.9, 0.8);
    scene
}

/// A portal in a window keeps the image where it was without one (it
/// emits nothing, blocks nothing) and, as light samples of the World now
/// go through the window, lowers its noise severalfold: without it, under
/// MIS a plain World is left to BSDF samples, which find the window by
/// chance.
#[test]
fn a_portal_keeps_the_image_and_lowers_the_noise_of_a_room_lit_through_a_window() {
    let (with, without) = (room_with_a_window(true), room_with_a_window(false));
    assert_eq!((with.triangles.len(), with.materials.len()), (without.triangles.len(), without.materials.len()), "a portal adds no lamp");
    let settings = RenderSettings { mis: true, ..settings(24, 24, 32, 6, 0) };
    let (v_on, v_off) = same_scene_less_noise(&with, &without, &settings, "portal");
    assert!(v_on < 0.3 * v_off, "portal {v_on} vs without {v_off}");
    // Closer: the mean of a 1,024-spp image without the portal, whose
    // standard error is about 0.2% (from the variance above), against the
    // portal's at 32 spp (0.1%): within 1%, some 4 standard errors.
    let (a, b) = (common::channel_mean(&render(&with, &settings, 2).0), common::channel_mean(&render(&without, &RenderSettings { spp: 1024, seed: 7, ..settings.clone() }, 2).0));
    assert!((a / b - 1.0).abs() < 0.01, "portal {a} vs without {b}");
    // Without MIS (the seed's rule) the portal is left out: the same image.
    let seed_rule = RenderSettings { mis: false, ..settings.clone() };
    assert_eq!(render(&with, &seed_rule, 2).0, render(&without, &seed_rule, 2).0);
    // Under a black World the portal gives no light of its own.
    let mut dark = with;
    dark.background = Vec3::ZERO;
    assert!(render(&dark, &settings, 2).0.iter().all(|p| *p == Vec3::ZERO));
}

/// With an environment image, half the World's light samples go through
/// the portal and half follow the image's own importance; the image stays
/// where it is without a portal.
#[test]
fn a_portal_under_an_environment_image_keeps_the_image() {
    use glint::environment::EnvironmentMap;
    use glint::texture::{Image, Texels};
    let (w, h) = (32u32, 16u32);
    let texel = |i: u32| if i % w == 5 && i / w < 6 { 40.0 } else { 0.5 };
    let map = || EnvironmentMap::new(Image { name: "sky".into(), width: w, height: h, texels: Texels::RgbaF32((0..w * h).map(|i| [texel(i), texel(i), texel(i), 1.0]).collect()) }, 1.0, 0.0);
    let (mut with, mut without) = (room_with_a_window(true), room_with_a_window(false));
    (with.environment, without.environment) = (Some(map()), Some(map()));
    let settings = RenderSettings { mis: true, ..settings(24, 24, 32, 6, 0) };
    let (v_on, v_off) = same_scene_less_noise(&with, &without, &settings, "portal and environment");
    assert!(v_on < v_off, "portal {v_on} vs without {v_off}");
}

/// An orthographic camera (glTF `ymag` 1 m, `znear` 0.1 m) straight above
/// a 1 m square of albedo 0.5 under a white World: the square fills the
/// middle half of the image in each direction, pixel for pixel, at
/// radiance 0.5 (a Lambertian surface under a uniform World, as in
/// `a_floor_under_a_uniform_world_has_radiance_albedo_times_world`), and
/// every other pixel sees the World, 1. A black card between the camera
/// and its near plane is not seen, as Cycles clips it; it shades the
/// square by 5·10⁻⁴ of the sky (0.04 m² at 4.95 m), within the tolerance.
#[test]
fn an_orthographic_camera_sees_a_square_at_its_size_and_clips_before_its_near_plane() {
    use glint::camera::Projection;
    let mut triangles = common::horizontal_quad(Vec3::ZERO, 0.5, 0.0, true, 0);
    triangles.extend(common::horizontal_quad(Vec3::ZERO, 0.1, 4.95, false, 1));
    let mut camera = common::look_at(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, 0.5);
    camera.projection = Projection::Orthographic { half_height: 1.0 };
    camera.clip = [0.1, f32::INFINITY];
    let mut scene = Scene::new(triangles, vec![common::diffuse("square", 0.5), common::diffuse("card", 0.0)], camera);
    scene.background = Vec3::ONE;
    let (w, h) = (64, 64);
    for mis in [true, false] {
        let (img, stats) = render(&scene, &RenderSettings { mis, ..settings(w, h, 16, 4, 1) }, 2);
        common::assert_clean(&img, &stats, "orthographic view");
        let inside = |x: u32, y: u32| (16..48).contains(&x) && (16..48).contains(&y);
        let mut square = vec![];
        for (i, p) in img.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            if inside(x, y) {
                assert!(p.x > 0.3, "mis {mis}: pixel ({x}, {y}) is {p}, not the square");
                square.push(p.x);
            } else {
                assert_eq!(*p, Vec3::ONE, "mis {mis}: pixel ({x}, {y}) is not the World");
            }
        }
        let (mean, se) = mean_and_standard_error(&square);
        assert!((mean - 0.5).abs() < 5.0 * se + 1e-3, "mis {mis}: the square's mean {mean} (se {se})");
    }
}

/// Light subpaths under an orthographic camera: their connections and
/// light tracing keep the Cornell box's image. Light tracing joins a
/// vertex to the camera along its one direction, as a sun is joined to a
/// point it lights, and weighs it by the camera's density per unit area
/// there, cos/A (`CameraDensity::PerArea`); it lowers the noise on top of
/// the connections (measured: 1.0e-4 per pixel against 5.1e-4 without it
/// and 6.5e-4 without light subpaths).
#[test]
fn light_paths_keep_the_image_under_an_orthographic_camera() {
    use glint::camera::Projection;
    let mut scene = cornell_box();
    scene.camera.projection = Projection::Orthographic { half_height: 1.1 };
    scene.camera.clip = [0.0, f32::INFINITY];
    let with = RenderSettings { mis: true, light_paths: LightPaths::On, ..settings(24, 24, 64, 6, 0) };
    let without = RenderSettings { light_paths: LightPaths::Off, ..with.clone() };
    let (v_on, v_off) = same_image_less_noise(&scene, &with, &without, "light paths under an orthographic camera");
    let connections = RenderSettings { light_tracing: false, ..with.clone() };
    let (v_tracing, v_connections) = same_image_less_noise(&scene, &with, &connections, "light tracing under an orthographic camera");
    assert!(v_on < v_off && v_tracing < 0.7 * v_connections, "light paths {v_on} vs without {v_off}; without light tracing {v_connections}");
}

/// Light subpaths through a Blender camera: a lens shift, an aperture
/// (six blades, focused on the sphere) and a Clip Start past a wall that
/// closes the box, which cuts its front half away as well. Light tracing
/// joins each vertex to a point of the aperture, and only where camera
/// rays would see it (between the clip planes, the stretch before Clip
/// Start free to be blocked): the image must stay where camera paths alone
/// put it. With the wall blocking light tracing's rays to the lens the
/// image came out 3.4% dark (10 standard errors). Only the expectation is
/// asserted: the closed box's noise with and without them swapped order
/// between 64 and 256 spp (two seeds' variance is itself noisy).
#[test]
fn light_paths_keep_the_image_through_a_shifted_aperture_with_clip_start() {
    let mut scene = cornell_box();
    let wall = [Vec3::new(-1.0, 0.0, 1.9), Vec3::new(1.0, 0.0, 1.9), Vec3::new(1.0, 2.0, 1.9), Vec3::new(-1.0, 2.0, 1.9)];
    let first = scene.triangles[0].material;
    scene.triangles.extend([[wall[0], wall[1], wall[2]], [wall[0], wall[2], wall[3]]].map(|p| common::triangle(p, first)));
    let mut scene = Scene::new(scene.triangles, scene.materials, scene.camera);
    scene.camera.clip = [3.3, 100.0];
    let aperture = glint::camera::Aperture { radius: 0.08, focus_distance: 4.0, blades: 6, rotation: 0.2, ratio: 1.3 };
    scene.camera.set_lens(glam::Vec2::new(0.05, -0.03), Some(aperture), None).unwrap();
    let with = RenderSettings { mis: true, light_paths: LightPaths::On, ..settings(24, 24, 256, 6, 0) };
    let without = RenderSettings { light_paths: LightPaths::Off, ..with.clone() };
    same_image_less_noise(&scene, &with, &without, "light paths through an aperture");
}

/// Film › Transparent: an orthographic camera above a 1 m square of
/// albedo 0.5 under a white World sees the square as before (0.5: the
/// World still lights it) with alpha 1, and nothing else: colour 0, alpha
/// 0; a pixel the square's edge halves has alpha 0.5 and colour 0.25
/// (premultiplied, as Cycles writes it). An opaque film keeps no coverage.
#[test]
fn a_transparent_film_hides_the_world_from_the_camera_and_keeps_coverage() {
    use glint::camera::Projection;
    let mut camera = common::look_at(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, 0.5);
    camera.projection = Projection::Orthographic { half_height: 1.0 };
    // The square from x = −0.5 to 0.515625 (z from −0.5 to 0.5), facing
    // up: its right edge halves column 48.
    let corner = |x: f32, z: f32| Vec3::new(x, 0.0, z);
    let (a, b, c, d) = (corner(-0.5, -0.5), corner(-0.5, 0.5), corner(0.515625, 0.5), corner(0.515625, -0.5));
    let triangles = vec![common::triangle([a, b, c], 0), common::triangle([a, c, d], 0)];
    let mut scene = Scene::new(triangles, vec![common::diffuse("square", 0.5)], camera);
    scene.background = Vec3::ONE;
    let (w, h) = (64u32, 64u32);
    let transparent = RenderSettings { transparent: true, ..settings(w, h, 16, 4, 1) };
    let mut film = Film::new(w, h);
    let stats = render_pass(&Context::new(&scene).0, &transparent, &mut film, 0..16, &AtomicBool::new(false), &|_| {}).unwrap();
    let (img, alpha) = (film.mean(), film.alpha().expect("a transparent film keeps coverage"));
    common::assert_clean(&img, &stats, "transparent film");
    for (i, (p, a)) in img.iter().zip(&alpha).enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let (rows, inside) = ((16..48).contains(&y), (16..48).contains(&x));
        let (want_alpha, want_colour) = match (rows, inside, x == 48) {
            (true, true, _) => (1.0, 0.5),
            (true, false, true) => (0.5, 0.25),
            _ => (0.0, 0.0),
        };
        // Coverage is a count of samples: the 16 Sobol points of a pixel
        // split 8 to 8 between its halves, give or take one. The colour
        // is the square's exact radiance under a uniform World, 0.5 a
        // sample that meets it.
        let tolerance = if want_alpha == 0.5 { 1.0 / 16.0 } else { 0.0 };
        assert!((a - want_alpha).abs() <= tolerance + 1e-6, "({x}, {y}): alpha {a}, not {want_alpha}");
        assert!((p.x - 0.5 * a).abs() < 1e-4, "({x}, {y}): {p} is not 0.5 × alpha {a} (want {want_colour})");
    }
    let mut opaque = Film::new(w, h);
    render_pass(&Context::new(&scene).0, &settings(w, h, 1, 4, 1), &mut opaque, 0..1, &AtomicBool::new(false), &|_| {}).unwrap();
    assert!(opaque.alpha().is_none() && opaque.mean()[0] == Vec3::ONE);
}

/// A panoramic camera (a request's `lens.panorama`) inside a cube whose
/// six faces emit six colours, looking down −Z: each mapping sees the
/// face Cycles' does at points of its view well inside a face, exactly
/// (one bounce, black emitters). Outside a fisheye's circle the pixel is
/// black and, on a transparent film, opaque, as Cycles leaves it; with the
/// cube gone, the World inside the circle is transparent.
#[test]
fn panoramic_cameras_see_the_faces_around_them() {
    use glint::panorama::Panorama;
    use std::f32::consts::{FRAC_PI_2, PI};
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // Each face's corners, and its colour: +X red, −X cyan, +Y green, −Y
    // magenta, +Z blue, −Z yellow.
    let faces = [
        ([c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.), c(1., -1., 1.)], c(1., 0., 0.)),
        ([c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.), c(-1., -1., -1.)], c(0., 1., 1.)),
        ([c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.), c(-1., 1., -1.)], c(0., 1., 0.)),
        ([c(-1., -1., -1.), c(1., -1., -1.), c(1., -1., 1.), c(-1., -1., 1.)], c(1., 0., 1.)),
        ([c(1., -1., 1.), c(1., 1., 1.), c(-1., 1., 1.), c(-1., -1., 1.)], c(0., 0., 1.)),
        ([c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.), c(1., -1., -1.)], c(1., 1., 0.)),
    ];
    let mut triangles = Vec::new();
    let mut materials = Vec::new();
    for (i, (f, colour)) in faces.iter().enumerate() {
        for p in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            triangles.push(common::triangle(p, i as u32));
        }
        materials.push(glint::material::Material { double_sided: true, ..common::emitter(*colour) });
    }
    let (w, h) = (64u32, 32u32);
    let render_with = |panorama: Panorama, scene_triangles: Vec<glint::scene::Triangle>| {
        let mut camera = common::look_at(Vec3::ZERO, Vec3::NEG_Z, 1.0);
        camera.set_lens(glam::Vec2::ZERO, None, Some(panorama)).unwrap();
        let mut scene = Scene::new(scene_triangles, materials.clone(), camera);
        scene.background = Vec3::splat(0.5);
        let transparent = RenderSettings { transparent: true, ..settings(w, h, 4, 1, 1) };
        let mut film = Film::new(w, h);
        let stats = render_pass(&Context::new(&scene).0, &transparent, &mut film, 0..4, &AtomicBool::new(false), &|_| {}).unwrap();
        let img = film.mean();
        common::assert_clean(&img, &stats, &format!("{panorama:?}"));
        (img, film.alpha().unwrap())
    };
    // The pixel at (u, v) of the view, from its bottom-left corner.
    let pixel = |u: f32, v: f32| (((1.0 - v) * h as f32) as u32).min(h - 1) * w + ((u * w as f32) as u32).min(w - 1);
    let (red, cyan, green, magenta, blue, yellow) = (faces[0].1, faces[1].1, faces[2].1, faces[3].1, faces[4].1, faces[5].1);
    let full = Panorama::Equirectangular { latitude: [-FRAC_PI_2, FRAC_PI_2], longitude: [-PI, PI] };
    let fisheye = Panorama::FisheyeEquidistant { fov: PI };
    // A panorama and the colours it sees at points (u, v) of the view.
    type Case<'a> = (Panorama, &'a [((f32, f32), Vec3)]);
    let cases: [Case; 5] = [
        // Forward (−Z) in the middle, right (+X) at three quarters, left at
        // one, behind at the edges, the ceiling along the top.
        (full, &[((0.5, 0.5), yellow), ((0.76, 0.5), red), ((0.24, 0.5), cyan), ((0.02, 0.5), blue), ((0.98, 0.5), blue), ((0.3, 0.97), green), ((0.6, 0.03), magenta)]),
        // 45° either side of forward and up: the front face only.
        (Panorama::EquiangularCubemapFace {}, &[((0.1, 0.1), yellow), ((0.9, 0.9), yellow), ((0.5, 0.5), yellow)]),
        // 90° off the axis at the circle: right at the right, up at the top.
        (fisheye, &[((0.5, 0.5), yellow), ((0.97, 0.5), red), ((0.5, 0.03), magenta), ((0.5, 0.97), green), ((0.03, 0.5), cyan)]),
        // The rim reflects what is behind the camera.
        (Panorama::Mirrorball {}, &[((0.5, 0.5), yellow), ((0.995, 0.5), blue), ((0.5, 0.71), green), ((0.29, 0.5), cyan)]),
        (Panorama::CentralCylindrical { u_range: [-PI, PI], v_range: [-0.1, 0.1], radius: 1.0 }, &[((0.5, 0.5), yellow), ((0.75, 0.5), red), ((0.01, 0.5), blue)]),
    ];
    for (panorama, expected) in cases {
        let (img, alpha) = render_with(panorama, triangles.clone());
        for &((u, v), colour) in expected {
            let p = img[pixel(u, v) as usize];
            assert!((p - colour).abs().max_element() < 1e-5, "{panorama:?} at ({u}, {v}): {p}, not {colour}");
        }
        assert!(alpha.iter().all(|a| *a == 1.0), "{panorama:?}: the cube covers everything");
    }
    // Outside the circle, black and opaque; inside it, with no cube, the
    // World, transparent.
    let (img, alpha) = render_with(fisheye, Vec::new());
    let (corner, centre) = (pixel(0.02, 0.02) as usize, pixel(0.5, 0.5) as usize);
    assert_eq!((img[corner], alpha[corner]), (Vec3::ZERO, 1.0));
    assert_eq!((img[centre], alpha[centre]), (Vec3::ZERO, 0.0));
}

/// An emitter under a clear coat (Cycles lays its Coat over Emission): a
/// tinted coat of roughness 0.3 over a two-sided emitting panel under the
/// ceiling of a closed box, and another facing the camera. Seen head-on,
/// the panel's radiance is Emission × what the coat lets through
/// (`coat::emission_weight`: 1 − E_layer(1, 0.3), times the tint); and
/// every way the integrator finds the panel — light sampling, BSDF-sampled
/// rays that hit it, light subpaths leaving it — must weigh it so, or the
/// MIS-weighted render (all of them) would leave the image that light
/// sampling alone gives (`--mis off`).
#[test]
fn an_emitter_under_a_coat_is_dimmed_and_tinted_by_every_strategy() {
    use glint::bsdf::coat::emission_weight;
    let mut scene = closed_box(0.6, 0.0);
    let coated = glint::material::Material { double_sided: true, coat: 1.0, coat_roughness: 0.3, coat_tint: Vec3::new(0.5, 0.7, 1.0), ..common::emitter(Vec3::splat(4.0)) };
    scene.materials.push(coated);
    scene.triangles.extend(common::horizontal_quad(Vec3::new(0.0, 0.0, -0.3), 0.4, 0.9, false, 1));
    // Facing the camera (at z = 0.3, looking down −Z), in the middle of
    // the view: x, y in ±0.2 at z = −0.9.
    let c = |x: f32, y: f32| Vec3::new(x, y, -0.9);
    let (a, b, d, e) = (c(-0.1, -0.4), c(0.3, -0.4), c(0.3, 0.0), c(-0.1, 0.0));
    scene.triangles.extend([common::triangle([a, b, d], 1), common::triangle([a, d, e], 1)]);
    let scene = Scene::new(scene.triangles, scene.materials, scene.camera);
    let (img, stats) = render(&scene, &RenderSettings { mis: true, ..settings(24, 24, 4, 1, 3) }, 2);
    common::assert_clean(&img, &stats, "coated emitter");
    let centre = img[12 * 24 + 12];
    let seen = Vec3::splat(4.0) * emission_weight(&scene.materials[1], 1.0);
    assert!(seen.x < 0.85 * seen.z && seen.z < 4.0 * 0.97, "the coat dims and tints: {seen}");
    assert!((centre - seen).abs().max_element() < 0.01 * seen.max_element(), "seen head-on: {centre}, not {seen}");
    let with = RenderSettings { mis: true, light_paths: LightPaths::On, ..settings(24, 24, 64, 4, 0) };
    let without = RenderSettings { mis: false, ..with.clone() };
    same_image_less_noise(&scene, &with, &without, "coated emitter, every strategy against light sampling alone");
}

/// Blender's Film › Pixel Filter (pixel_filter.rs): a white emitter
/// covering the right half of the view, its edge on the boundary between
/// the two middle columns. With the one-pixel box the columns are 0 and 1;
/// a Blackman-Harris filter of Width 1.5 (Cycles' default) reaches 1.5
/// pixels each side, so the column whose centre is 0.5 px from the edge
/// takes the filter's mass beyond 0.5 px, and the one 1.5 px away nothing
/// — integrated here from Cycles' formula, not from Glint's table. A
/// uniform jitter in the pixel would leave the near column at 0, 16 se
/// away.
#[test]
fn a_pixel_filter_spreads_a_sharp_edge_as_its_shape_says() {
    use glint::pixel_filter::{FilterKind, PixelFilter};
    let camera = common::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 0.5);
    let (c, x, y) = (Vec3::new(5.0, 0.0, -1.0), Vec3::X * 5.0, Vec3::Y * 5.0);
    let quad = [common::triangle([c - x - y, c + x - y, c + x + y], 0), common::triangle([c - x - y, c + x + y, c - x + y], 0)];
    let scene = Scene::new(quad.to_vec(), vec![common::emitter(Vec3::ONE)], camera);
    let (w, h) = (16u32, 16u32);
    let column = |img: &[Vec3], col: u32| (0..h).map(|r| img[(r * w + col) as usize].x as f64).sum::<f64>() / h as f64;
    let (boxed, _) = render(&scene, &settings(w, h, 64, 2, 1), 2);
    assert_eq!((column(&boxed, 7), column(&boxed, 8)), (0.0, 1.0));
    let filter = PixelFilter::new(FilterKind::BlackmanHarris, 1.5).unwrap();
    let (img, stats) = render(&scene, &RenderSettings { pixel_filter: filter, ..settings(w, h, 256, 2, 1) }, 2);
    common::assert_clean(&img, &stats, "filtered edge");
    // Cycles' window over [−1.5, 1.5]: 0.35875 − 0.48829 cos(2π(x/3 + ½)) + …
    let bh = |x: f64| {
        let v = 2.0 * std::f64::consts::PI * (x / 3.0 + 0.5);
        0.35875 - 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() - 0.01168 * (3.0 * v).cos()
    };
    let integral = |a: f64, b: f64| (0..10_000).map(|i| bh(a + (b - a) * (i as f64 + 0.5) / 10_000.0)).sum::<f64>() * (b - a) / 10_000.0;
    let near = integral(0.5, 1.5) / integral(-1.5, 1.5);
    // Each pixel's sample lands past the edge with probability `near`:
    // the column's standard error over 16 × 256 samples.
    let se = (near * (1.0 - near) / (16.0 * 256.0)).sqrt();
    for (col, expected) in [(5, 0.0), (6, 0.0), (7, near), (8, 1.0 - near), (9, 1.0)] {
        let got = column(&img, col);
        assert!((got - expected).abs() < 5.0 * se + 1e-6, "column {col}: {got} against {expected} (se {se})");
    }
    assert!(near > 16.0 * se, "{near}");
}

/// With a pixel filter wider than a pixel, light tracing adds a vertex to
/// every pixel whose filter covers where it lands, weighing its MIS by the
/// camera's density for that pixel's samples: the caustic box's image
/// (light tracing carries its caustic) keeps its expectation and light
/// tracing still lowers its noise. Measured when it was written: light
/// tracing's MIS weight from the unfiltered density moves the image by
/// −2.9% (15 se), the camera side's by +2.9% (15 se).
#[test]
fn light_tracing_keeps_the_image_under_a_pixel_filter() {
    use glint::pixel_filter::{FilterKind, PixelFilter};
    let scene = caustic_box();
    for kind in [FilterKind::BlackmanHarris, FilterKind::Gaussian] {
        let with = RenderSettings { mis: true, pixel_filter: PixelFilter::new(kind, 1.5).unwrap(), ..settings(24, 24, 256, 6, 0) };
        let without = RenderSettings { light_tracing: false, ..with.clone() };
        let (v_on, v_off) = same_image_less_noise(&scene, &with, &without, "light tracing, filtered");
        assert!(v_on < 0.5 * v_off, "{kind:?}: light tracing {v_on} vs without {v_off}");
    }
}
