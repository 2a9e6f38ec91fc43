//! What a light tree costs: its build per light, a pick (`sample`) and a
//! light's probability for MIS (`probability`), on 1,000 to 1,000,000
//! small lamps facing random ways in a 100 m cube, picked for random
//! points in it facing random ways, on one thread.
//!
//!   cargo run --release --example light_tree_cost [-- --max 1000000]

use glint::light_tree::{LightTree, TreeLight};
use glint::rng::Rng;
use glint::Vec3;
use std::hint::black_box;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let max: usize = args.iter().position(|a| a == "--max").and_then(|i| args.get(i + 1)).map_or(Ok(1_000_000), |v| v.parse())?;
    let mut rng = Rng::new(11, 0);
    let mut point = |scale: f32| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * scale - Vec3::splat(scale / 2.0);
    println!("| lights | build, µs per light | pick, µs | probability, µs |");
    println!("|---|---|---|---|");
    let mut count = 1_000;
    while count <= max {
        let lights: Vec<TreeLight> = (0..count)
            .map(|_| {
                let c = point(100.0);
                let n = point(2.0).normalize_or(Vec3::Y);
                TreeLight { weight: 1.0 + 99.0 * point(1.0).x.abs(), lo: c - Vec3::splat(0.1), hi: c + Vec3::splat(0.1), facing: Some((n, false)), cos_spread: 0.0 }
            })
            .collect();
        let start = Instant::now();
        let tree = LightTree::new(&lights).expect("lights");
        let build = start.elapsed().as_secs_f64() / count as f64;
        let queries: Vec<(Vec3, Vec3, f32)> = (0..200_000).map(|_| (point(100.0), point(2.0).normalize_or(Vec3::Y), point(1.0).x + 0.5)).collect();
        let start = Instant::now();
        let picked: Vec<usize> = queries.iter().map(|&(p, n, u)| black_box(tree.sample(p, n, u)).0).collect();
        let pick = start.elapsed().as_secs_f64() / queries.len() as f64;
        let start = Instant::now();
        let total: f32 = queries.iter().zip(&picked).map(|(&(p, n, _), &light)| black_box(tree.probability(light, p, n))).sum();
        let probability = start.elapsed().as_secs_f64() / queries.len() as f64;
        anyhow::ensure!(total.is_finite() && total > 0.0, "probabilities summed to {total}");
        println!("| {count} | {:.2} | {:.3} | {:.3} |", build * 1e6, pick * 1e6, probability * 1e6);
        count *= 10;
    }
    Ok(())
}
