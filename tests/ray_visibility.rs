//! Blender's Ray Visibility but the camera's (Object › Visibility › Ray
//! Visibility: Shadow, Diffuse, Glossy, Transmission): each kind of ray
//! passes what is hidden from it and sees everything else, as in Cycles.
//!
//! A floor under a lamp, and between them a black board the camera cannot
//! see (it hangs behind the camera, which looks straight down). The board
//! shades the floor in two ways, which `--strategies` takes apart: light
//! sampling's shadow rays (s = 1) and BSDF samples that reach the lamp
//! (s = 0). So, part by part, a board hidden from a kind of ray must give
//! the image of no board where that part is traced with that kind, and of
//! a seen board elsewhere.

mod common;

use common::{horizontal_quad, look_at, mean_and_standard_error, render, settings};
use glint::material::{Material, Rays};
use glint::render::{LightPaths, RenderSettings};
use glint::scene::Scene;
use glint::strategies::{Strategies, Strategy};
use glint::Vec3;

/// The floor (`floor`), a 1 m lamp 2 m above it, and a 0.8 m board at
/// 1.2 m hidden from `hidden` (no board at all with None).
fn scene(floor: Material, hidden: Option<Rays>) -> Scene {
    let mut triangles = horizontal_quad(Vec3::ZERO, 2.0, 0.0, true, 0);
    triangles.extend(horizontal_quad(Vec3::ZERO, 0.5, 2.0, false, 1));
    let mut materials = vec![floor, common::emitter(Vec3::splat(5.0))];
    if let Some(rays) = hidden {
        materials.push(Material { hidden_from_rays: rays, ..common::diffuse("board", 0.0) });
        triangles.extend(horizontal_quad(Vec3::ZERO, 0.4, 1.2, false, 2));
    }
    // Looking straight down from 0.9 m, below the board.
    Scene::new(triangles, materials, look_at(Vec3::new(0.0, 0.9, 0.0), Vec3::ZERO, 1.2))
}

fn matte() -> Material {
    common::diffuse("floor", 0.5)
}

fn metal() -> Material {
    Material { name: "floor".into(), base_color: Vec3::splat(0.9), metallic: 1.0, roughness: 0.5, ..Material::default() }
}

/// Strategy `part`'s image of `scene` from two seeds, light subpaths off
/// in every scene alike (the hidden boards' turn them off).
fn part(scene: &Scene, part: Strategy) -> Vec<f32> {
    let run = |seed| {
        let s = RenderSettings { mis: true, light_paths: LightPaths::Off, light_tracing: false, strategies: Strategies::only(&[part]), ..settings(32, 32, 64, 4, seed) };
        render(scene, &s, 2).0
    };
    [run(1), run(2)].concat().iter().map(|p| p.element_sum() / 3.0).collect()
}

/// The mean difference of two images of the same pixels, in standard
/// errors (pixels independent); 0 for images equal to the bit, which the
/// same seeds give where the board changes none of a part's numbers.
fn z(a: &[f32], b: &[f32]) -> f64 {
    let diffs: Vec<f32> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let (mean, se) = mean_and_standard_error(&diffs);
    if mean == 0.0 { 0.0 } else { mean / se }
}

/// Each part of each floor: with the board hidden from `rays`, the image
/// of no board where the part's rays are of a kind in `rays`, of a seen
/// board elsewhere. Tolerance 5 standard errors (a false alarm about once
/// in 10⁶ per comparison; the images came out equal to the bit); the seen
/// board and no board differ by 22–220 (at least 8 is checked first), so
/// the test tells them apart.
#[test]
fn each_kind_of_ray_passes_a_board_hidden_from_it_and_only_that_kind() {
    let cases = [
        ("matte floor", matte(), Strategy::Light, Rays::SHADOW),
        ("matte floor", matte(), Strategy::Bsdf, Rays::DIFFUSE),
        ("metal floor", metal(), Strategy::Light, Rays::SHADOW),
        ("metal floor", metal(), Strategy::Bsdf, Rays::GLOSSY),
    ];
    let all = [Rays::SHADOW, Rays::DIFFUSE, Rays::GLOSSY, Rays::TRANSMISSION];
    for (floor_name, floor, strategy, kind) in cases {
        let none = part(&scene(floor.clone(), None), strategy);
        let seen = part(&scene(floor.clone(), Some(Rays::NONE)), strategy);
        let apart = z(&none, &seen);
        assert!(apart > 8.0, "{floor_name}, {strategy:?}: the board takes too little light away to tell ({apart:.1} σ)");
        for hidden in all {
            let image = part(&scene(floor.clone(), Some(hidden)), strategy);
            let (like, expected) = if hidden == kind { (&none, "no board") } else { (&seen, "a seen board") };
            let off = z(&image, like);
            println!("{floor_name}, {strategy:?}, hidden from {:?}: {off:+.2} σ from {expected} (seen board and none {apart:.1} σ apart)", hidden.names());
            assert!(off.abs() < 5.0, "{floor_name}, {strategy:?}, board hidden from {:?}: {off:.1} σ from the image of {expected}", hidden.names());
        }
    }
}

/// Hidden from every kind but the camera's, the board leaves the whole
/// image as without it, light subpaths off by themselves (their rays have
/// no kind); and the features line says what the scene hides.
#[test]
fn a_board_hidden_from_every_ray_leaves_the_image_as_without_it() {
    let every = Rays::SHADOW.union(Rays::SCATTERED);
    let with = scene(metal(), Some(every));
    let s = RenderSettings { mis: true, ..settings(32, 32, 64, 4, 0) };
    let (ctx, _) = glint::integrator::Context::new(&with);
    let line = ctx.features_line(&s);
    assert!(line.contains("hidden from shadow/diffuse/glossy/transmission rays") && !ctx.traces_light_paths(&s), "{line}");
    let run = |scene: &Scene, seed| render(scene, &RenderSettings { seed, light_paths: LightPaths::Off, ..s.clone() }, 2).0;
    let lum = |img: Vec<Vec3>| img.iter().map(|p| p.element_sum() / 3.0).collect::<Vec<f32>>();
    let without = scene(metal(), None);
    let a = lum([run(&with, 1), run(&with, 2)].concat());
    let b = lum([run(&without, 3), run(&without, 4)].concat());
    let off = z(&a, &b);
    assert!(off.abs() < 5.0, "{off:.1} σ from the image without the board");
    for p in &a {
        assert!(p.is_finite());
    }
}

/// The floor lit by a light with Cast Shadow on or off — a 1 m lamp 2 m
/// up, or a point light of radius 0.3 m there —, under a seen board or
/// none.
fn lit_by(light: &str, board: bool, shadowless: bool) -> Scene {
    use glint::punctual::{PunctualKind, PunctualLight};
    let mut s = scene(matte(), board.then_some(Rays::NONE));
    if light == "lamp" {
        s.materials[1] = Material { lamp: true, shadowless, ..s.materials[1].clone() };
        return Scene::new(s.triangles, s.materials, s.camera);
    }
    s.triangles.retain(|t| t.material != 1);
    let point = PunctualLight { name: "bulb".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, 2.0, 0.0), direction: -Vec3::Y, intensity: Vec3::splat(4.0), size: 0.3, sphere: false, camera_sees: false, shadowless };
    let mut s = Scene::new(s.triangles, s.materials, s.camera);
    s.punctual = vec![point];
    s
}

/// Blender's Cast Shadow off: the light's samples trace no shadow ray,
/// so they light the floor as with no board, while BSDF samples that
/// reach the light still meet the board, as in Cycles. Tolerance as
/// above.
#[test]
fn a_light_casting_no_shadow_is_seen_past_the_board_by_its_light_samples_alone() {
    for light in ["lamp", "sized point light"] {
        for (strategy, like_none) in [(Strategy::Light, true), (Strategy::Bsdf, false)] {
            let none = part(&lit_by(light, false, true), strategy);
            let seen = part(&lit_by(light, true, false), strategy);
            let apart = z(&none, &seen);
            assert!(apart > 8.0, "{light}, {strategy:?}: the board takes too little light away to tell ({apart:.1} σ)");
            let (like, expected) = if like_none { (&none, "no board") } else { (&seen, "a board with the shadow cast") };
            let off = z(&part(&lit_by(light, true, true), strategy), like);
            println!("{light}, {strategy:?}, casting no shadow: {off:+.2} σ from {expected} ({apart:.1} σ apart)");
            assert!(off.abs() < 5.0, "{light}, {strategy:?}, casting no shadow: {off:.1} σ from the image of {expected}");
        }
    }
    let s = RenderSettings { mis: true, ..settings(8, 8, 1, 4, 0) };
    let scene = lit_by("lamp", true, true);
    let (ctx, _) = glint::integrator::Context::new(&scene);
    assert!(ctx.features_line(&s).contains("casting no shadow=1") && !ctx.traces_light_paths(&s), "{}", ctx.features_line(&s));
}
