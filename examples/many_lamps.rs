//! Error against time in a hall of many lamps (`tests/common`'s
//! `lamp_hall`: 32 ceiling lamps and 8 bulbs down a 42 m hall), with the
//! light tree and with lights picked by power alone.
//!
//!   cargo run --release --example many_lamps -- [--size 128] [--max-spp 64] [--seeds 3] [--reference-spp 1024] [--max-depth 17] [--png REFERENCE.png]
//!
//! Each row is the mean over seeds of relMSE (the benchmark's: (x − ref)² /
//! (ref² + 0.01), channel mean) against one reference rendered with the
//! tree, and the median time of the render (2 threads, the machine's).

#[path = "../tests/common/mod.rs"]
mod common;

use glint::render::RenderSettings;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str, default: u32| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).map_or(Ok(default), |v| v.parse());
    let (size, max_spp, seeds, reference_spp, max_depth) = (value("--size", 128)?, value("--max-spp", 64)?, value("--seeds", 3)?, value("--reference-spp", 1024)?, value("--max-depth", 17)?);
    anyhow::ensure!(size > 0 && max_spp > 0 && seeds > 0 && reference_spp > 0, "--size, --max-spp, --seeds and --reference-spp must be positive");
    let scene = common::lamp_hall();
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let base = RenderSettings { mis: true, ..common::settings(size, size, 1, max_depth, 0) };
    let render = |spp: u32, seed: u64, by_power: bool| {
        let settings = RenderSettings { spp, seed, ..base.clone() };
        let (img, _, time) = common::render_prepared(&scene, &settings, threads, |ctx| {
            if by_power {
                ctx.lights.pick_by_power();
            }
        });
        (img, time.as_secs_f64())
    };
    let (reference, _) = render(reference_spp, 12345, false);
    if let Some(path) = args.iter().position(|a| a == "--png").and_then(|i| args.get(i + 1)) {
        glint::output::write_png(std::path::Path::new(path), size, size, &reference, None)?;
    }
    glint::stdout_line!("lamp hall: {size}x{size}, {max_depth} bounces, {threads} threads, {seeds} seeds, reference {reference_spp} spp with the tree");
    glint::stdout_line!("| spp | tree: s | tree: relMSE | by power: s | by power: relMSE | error x time, power / tree |\n|---|---|---|---|---|---|");
    let mut spp = 1;
    while spp <= max_spp {
        let mut row = Vec::new();
        for by_power in [false, true] {
            let runs: Vec<(f64, f64)> = (0..seeds as u64).map(|seed| render(spp, seed, by_power)).map(|(img, t)| (common::relative_mse(&img, &reference), t)).collect();
            let error = runs.iter().map(|r| r.0).sum::<f64>() / seeds as f64;
            let mut times: Vec<f64> = runs.iter().map(|r| r.1).collect();
            times.sort_by(f64::total_cmp);
            row.push((times[times.len() / 2], error));
        }
        let ((t_tree, e_tree), (t_power, e_power)) = (row[0], row[1]);
        glint::stdout_line!("| {spp} | {t_tree:.3} | {e_tree:.4} | {t_power:.3} | {e_power:.4} | {:.2} |", (e_power * t_power) / (e_tree * t_tree));
        spp *= 2;
    }
    Ok(())
}
