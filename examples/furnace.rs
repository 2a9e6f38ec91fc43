//! White furnace table of both BSDF models: the directional albedo
//! ∫ f(wo, wi) cos θi dωi of a white metal and a white dielectric, per
//! roughness and viewing angle, estimated from the material's own sampler
//! (1e6 samples each). Below 1 is energy lost, above 1 energy gained.
//! `cargo run --release --example furnace`
use glint::Vec3;
use glint::bsdf::{Bsdf, PrincipledBsdf, SeedBsdf};
use glint::material::{Material, Surface};
use glint::rng::Rng;

fn albedo<B: Bsdf>(m: &Surface, deg: f32) -> f64 {
    let t = deg.to_radians();
    let wo = Vec3::new(t.sin(), 0.0, t.cos());
    let bsdf = B::new(m, wo);
    let mut rng = Rng::new(1, deg.to_bits() as u64);
    let n = 1_000_000;
    let mut sum = 0.0f64;
    for _ in 0..n {
        if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
            sum += s.weight.x as f64;
        }
    }
    sum / n as f64
}

fn table<B: Bsdf>(model: &str) {
    let angles = [0.0f32, 45.0, 75.0, 85.0, 89.0];
    for (name, metallic) in [("white metal", 1.0f32), ("white dielectric", 0.0)] {
        println!("--bsdf {model}, {name}: albedo at θo = {angles:?}°");
        for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 0.1, 0.3, 0.5, 0.7, 1.0] {
            let m = Material { base_color: Vec3::ONE, metallic, roughness, ..Material::default() }.surface();
            let row: Vec<String> = angles.iter().map(|&deg| format!("{:.3}", albedo::<B>(&m, deg))).collect();
            println!("  roughness {roughness:<6}: {}", row.join("  "));
        }
    }
}

fn main() {
    table::<PrincipledBsdf>("principled");
    table::<SeedBsdf>("seed");
}
