//! White furnace table of the seed BSDF: the directional albedo
//! ∫ f(wo, wi) cos θi dωi of a white metal and a white dielectric, per
//! roughness and viewing angle, estimated from the material's own sampler
//! (1e6 samples each). Below 1 is energy lost, above 1 energy gained.
//! `cargo run --release --example furnace`
use glam::Vec3;
use glint::bsdf::SeedBsdf;
use glint::material::Material;
use glint::rng::Rng;

fn main() {
    let angles = [0.0f32, 45.0, 75.0, 85.0, 89.0];
    for (name, metallic) in [("white metal", 1.0f32), ("white dielectric", 0.0)] {
        println!("{name}: albedo at θo = {angles:?}°");
        for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 0.1, 0.3, 0.5, 0.7, 1.0] {
            let m = Material { base_color: Vec3::ONE, metallic, roughness, ..Material::default() };
            let row: Vec<String> = angles
                .iter()
                .map(|&deg| {
                    let t = deg.to_radians();
                    let wo = Vec3::new(t.sin(), 0.0, t.cos());
                    let bsdf = SeedBsdf::new(&m, wo);
                    let mut rng = Rng::new(1, deg.to_bits() as u64);
                    let n = 1_000_000;
                    let mut sum = 0.0f64;
                    for _ in 0..n {
                        if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
                            sum += s.weight.x as f64;
                        }
                    }
                    format!("{:.3}", sum / n as f64)
                })
                .collect();
            println!("  roughness {roughness:<6}: {}", row.join("  "));
        }
    }
}
