//! Blender's Mix Shader (`Material::mix`): each hit is shaded by one half,
//! drawn by its share, so every estimate's expectation is the mix's.
//!
//! A floor under a lamp in a black World is the one surface light meets
//! between the lamp and the camera (the lamp is black, the floor flat), so
//! its image is linear in the floor's BSDF: a floor that mixes a matte and
//! a rough metal BSDF 0.7 : 0.3 must render 0.7 times the matte floor's
//! image plus 0.3 times the metal floor's — with light sampling, BSDF
//! sampling and the light subpaths' connections and splats all on.

mod common;

use common::{horizontal_quad, look_at, mean_and_standard_error, render, settings};
use glint::material::{Material, Mix};
use glint::render::RenderSettings;
use glint::scene::Scene;
use glint::Vec3;

fn matte() -> Material {
    common::diffuse("floor", 0.15)
}

fn metal() -> Material {
    Material { name: "floor".into(), base_color: Vec3::new(0.9, 0.6, 0.3), metallic: 1.0, roughness: 0.5, ..Material::default() }
}

/// The floor (material 0, with `extra` after the lamp), a 1 m lamp 2 m
/// above it, the camera 0.9 m up looking straight down.
fn floor_scene(floor: Material, extra: Option<Material>) -> Scene {
    let mut triangles = horizontal_quad(Vec3::ZERO, 2.0, 0.0, true, 0);
    triangles.extend(horizontal_quad(Vec3::new(0.3, 0.0, 0.2), 0.5, 2.0, false, 1));
    let mut materials = vec![floor, common::emitter(Vec3::splat(5.0))];
    materials.extend(extra);
    Scene::new(triangles, materials, look_at(Vec3::new(0.0, 0.9, 0.0), Vec3::ZERO, 1.4))
}

fn image(scene: &Scene, seed: u64) -> Vec<f32> {
    let s = RenderSettings { mis: true, seed, ..settings(32, 32, 64, 6, 0) };
    let (img, stats) = render(scene, &s, 2);
    common::assert_clean(&img, &stats, "shader mix");
    img.iter().map(|p| p.element_sum() / 3.0).collect()
}

/// The mean per-pixel difference of two images of two seeds each (32²
/// pixels a seed), in standard errors, for each 8 × 8-pixel tile: the
/// largest in size.
fn z(a: &[f32], b: &[f32]) -> f64 {
    let tile_of = |i: usize| ((i % 1024) / 32 / 8) * 4 + (i % 32) / 8;
    (0..16)
        .map(|tile| {
            let diffs: Vec<f32> = a.iter().zip(b).enumerate().filter(|(i, _)| tile_of(*i) == tile).map(|(_, (x, y))| x - y).collect();
            let (mean, se) = mean_and_standard_error(&diffs);
            mean / se
        })
        .max_by(|x, y| x.abs().total_cmp(&y.abs()))
        .unwrap()
}

/// Tolerance 5 standard errors in each of 16 tiles (a false alarm about
/// once in 100,000 runs), over the pixels of two seeds; the matte
/// and the metal floor differ by far more (checked), so a mix drawn with
/// the wrong shares, or one half's numbers used for the other's
/// (a light sample weighed by one half's pdf and the other's value),
/// shows.
#[test]
fn a_mixed_floor_renders_the_mix_of_its_halves_images() {
    let weight = 0.3;
    let mixed = floor_scene(Material { mix: Some(Mix { with: 2, weight }), ..matte() }, Some(metal()));
    let (ctx, _) = glint::integrator::Context::new(&mixed);
    let line = ctx.features_line(&RenderSettings { mis: true, ..settings(32, 32, 64, 6, 0) });
    assert!(line.contains("shader mixes=1") && line.contains("light paths"), "{line}");
    let (a, b) = (floor_scene(matte(), None), floor_scene(metal(), None));
    let blend: Vec<f32> = [image(&a, 3), image(&a, 4)].concat().iter().zip([image(&b, 5), image(&b, 6)].concat()).map(|(x, y)| (1.0 - weight) * x + weight * y).collect();
    let mix = [image(&mixed, 1), image(&mixed, 2)].concat();
    let matte_alone = [image(&a, 7), image(&a, 8)].concat();
    let apart = z(&matte_alone, &blend).abs();
    let off = z(&mix, &blend);
    println!("mixed floor: worst tile {off:+.2} σ from 0.7 matte + 0.3 metal (the matte floor alone {apart:.1} σ from it)");
    assert!(apart > 10.0, "the halves are too alike to tell ({apart:.1} σ)");
    assert!(off.abs() < 5.0, "the mixed floor is {off:.1} σ from the mix of its halves' images");
}
