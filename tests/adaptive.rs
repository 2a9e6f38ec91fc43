//! Adaptive sampling (adaptive.rs) over whole renders: where pixels stop,
//! that the samples it saves buy less error, and that its bookkeeping
//! leaves the estimate alone.

mod common;

use common::*;
use glint::adaptive::Adaptive;
use glint::integrator::Context;
use glint::progressive::{render_progressive, Budget};
use glint::render::{Film, LightPaths, RenderSettings};
use glint::scene::Scene;
use glint::Vec3;
use std::sync::atomic::AtomicBool;

const W: u32 = 48;
const H: u32 = 32;

/// A floor lit by a small lamp, in front of a plain World: the floor's
/// pixels are noisy, those of the World above the horizon never are.
fn floor_under_lamp() -> Scene {
    let mut triangles = horizontal_quad(Vec3::ZERO, 2.0, 0.0, true, 0);
    triangles.extend(horizontal_quad(Vec3::new(0.0, 0.0, -0.5), 0.25, 1.5, false, 1));
    let camera = look_at(Vec3::new(0.0, 0.6, 3.0), Vec3::new(0.0, 0.4, 0.0), 0.8);
    let mut scene = Scene::new(triangles, vec![diffuse("floor", 0.7), emitter(Vec3::splat(20.0))], camera);
    scene.background = Vec3::splat(0.3);
    scene
}

fn adaptive_settings(spp: u32, seed: u64, adaptive: Option<Adaptive>) -> RenderSettings {
    RenderSettings { mis: true, light_paths: LightPaths::On, adaptive, ..settings(W, H, spp, 8, seed) }
}

/// The film of a render as `glint render` makes it: passes up to each
/// convergence check.
fn render_film(scene: &Scene, settings: &RenderSettings) -> Film {
    let (ctx, _) = Context::new(scene);
    let mut film = Film::new(settings.width, settings.height);
    let budget = Budget { samples: settings.spp, time: None, paced: false };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    pool.install(|| render_progressive(&ctx, settings, &budget, &mut film, &AtomicBool::new(false), &|_| {}, &mut |_| {})).unwrap();
    film
}

const THRESHOLD: Adaptive = Adaptive { threshold: 0.005, min_samples: 16 };

#[test]
fn pixels_that_see_only_the_world_stop_at_the_minimum() {
    let film = render_film(&floor_under_lamp(), &adaptive_settings(256, 1, Some(THRESHOLD)));
    let c = film.convergence.as_ref().expect("an adaptive render keeps its convergence");
    let count = |x: u32, y: u32| c.counts[(y * W + x) as usize];
    // The rows above the lamp and between it and the horizon see the
    // World alone: their halves agree from the start.
    for x in 0..W {
        assert_eq!((count(x, 0), count(x, H / 3)), (16, 16), "({x}, 0), ({x}, {})", H / 3);
    }
    // The lit floor towards the horizon, its noisiest part, keeps
    // sampling past the minimum (three times over, when written).
    let floor: Vec<u32> = (H * 17 / 32..H * 24 / 32).flat_map(|y| (0..W).map(move |x| (x, y))).map(|(x, y)| count(x, y)).collect();
    let floor_mean = floor.iter().sum::<u32>() as f64 / floor.len() as f64;
    assert!(floor_mean > 48.0, "{floor_mean} samples a pixel: {floor:?}");
    assert!(c.counts.iter().all(|&n| (16..=256).contains(&n) && n % 16 == 0));
    let mean = film.mean_samples();
    assert!(mean < 0.8 * 256.0, "{mean} samples a pixel");
    assert_clean(&film.mean(), &Default::default(), "adaptive");
}

/// What adaptive sampling is for: at the same mean samples per pixel, less
/// error than every pixel taking the same number. Error is against a
/// 2048-spp render; each relMSE is the mean of three seeds' (their
/// scatter was a few percent of it), and adaptive must beat the fixed
/// count by a fifth (it had a quarter of its error when written: the World
/// above the horizon needs no more than the minimum). Stopping
/// a pixel early biases it where its first samples missed rare light, so
/// this also fails if that bias outweighs the noise saved.
#[test]
fn at_equal_samples_adaptive_sampling_has_less_error() {
    let scene = floor_under_lamp();
    let reference = render_film(&scene, &adaptive_settings(2048, 99, None)).mean();
    let (mut adaptive_error, mut fixed_error) = (0.0, 0.0);
    for seed in 0..3 {
        let film = render_film(&scene, &adaptive_settings(256, seed, Some(THRESHOLD)));
        adaptive_error += relative_mse(&film.mean(), &reference) / 3.0;
        let spp = film.mean_samples().ceil() as u32;
        fixed_error += relative_mse(&render_film(&scene, &adaptive_settings(spp, seed, None)).mean(), &reference) / 3.0;
    }
    assert!(adaptive_error < 0.8 * fixed_error, "relMSE adaptive {adaptive_error:.3e}, fixed {fixed_error:.3e}");
}

/// Under a threshold only pixels without noise meet (those whose samples
/// all saw the World, so that their halves agree exactly), every other
/// pixel takes every sample: the image
/// is the fixed count's, light tracing's splats included, but for the
/// rounding of sums split at the checks.
#[test]
fn where_only_noiseless_pixels_converge_the_image_is_the_fixed_one() {
    let scene = floor_under_lamp();
    let tiny = Adaptive { threshold: 1e-9, min_samples: 8 };
    let film = render_film(&scene, &adaptive_settings(40, 5, Some(tiny)));
    let c = film.convergence.as_ref().unwrap();
    // Checks at 16 and 32; a stopped pixel next to a noisy one samples
    // again after a later check.
    assert!(c.counts.iter().all(|&n| n >= 16 && n % 8 == 0), "{:?}", c.counts);
    assert!(c.counts[(H * 3 / 4 * W) as usize..].iter().all(|&n| n == 40), "the floor stopped");
    let fixed = render_film(&scene, &adaptive_settings(40, 5, None));
    assert!(fixed.convergence.is_none());
    for (a, b) in film.mean().iter().zip(fixed.mean()) {
        assert!((*a - b).abs().max_element() <= 1e-5 * b.max_element().max(1.0), "{a} vs {b}");
    }
}

