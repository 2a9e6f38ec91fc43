//! Where a render's noise is: each sampling strategy's and path depth's
//! share of the image's light and of its variance (README, *Where the
//! noise is*; `glint render --strategies … --depths …` renders one part).
//!
//!   cargo run --release --example noise_parts -- [SCENE] [--request R] [--spp 16] [--seeds 6] [--reference-spp 256]
//!
//! Every part is rendered with seeds 0 … N−1; its variance is the spread of
//! those images per pixel and channel over (ref² + 0.01), averaged, with ref
//! a render of the whole at `--reference-spp` (seed 12345): the benchmark's
//! relMSE, whose expectation is the variance. (The seeds' own mean is no
//! reference: a firefly raises it where it lands, and its part's share
//! came out a third lower.) The shares need not add up to 100%: the parts
//! of one sample are correlated.

use glint::integrator::Context;
use glint::job::{self, JobOptions};
use glint::render::{render_pass, Film, RenderSettings};
use glint::request::RenderRequest;
use glint::strategies::{Strategies, Strategy};
use glint::Vec3;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let scene = args.first().filter(|a| !a.starts_with("--")).map(PathBuf::from);
    let request = match value("--request") {
        Some(path) => RenderRequest::read(std::path::Path::new(&path)).map_err(|e| anyhow::anyhow!("{path}: {e}"))?,
        None => RenderRequest::default(),
    };
    let spp: u32 = value("--spp").map_or(Ok(16), |v| v.parse())?;
    let seeds: u64 = value("--seeds").map_or(Ok(6), |v| v.parse())?;
    anyhow::ensure!(seeds >= 2, "--seeds: at least 2, for a spread");
    let reference_spp: u32 = value("--reference-spp").map_or(Ok(256), |v| v.parse())?;
    let options = JobOptions { samples: Some(spp), ..Default::default() }.or(&JobOptions::from(&request));
    let job = job::prepare(scene.as_deref(), &options, (&request).into()).map_err(anyhow::Error::msg)?;
    let (ctx, _) = Context::new(&job.scene);
    let render = |strategies: Strategies, seed: u64, spp: u32| -> Vec<Vec3> {
        let settings = RenderSettings { seed, strategies, spp, ..job.settings.clone() };
        let mut film = Film::new(settings.width, settings.height);
        render_pass(&ctx, &settings, &mut film, 0..spp, &AtomicBool::new(false), &|_| {}).expect("not cancelled");
        film.mean()
    };
    let images = |strategies: Strategies| -> Vec<Vec<Vec3>> { (0..seeds).map(|seed| render(strategies, seed, spp)).collect() };
    let reference = render(Strategies::ALL, 12345, reference_spp);
    let whole = images(Strategies::ALL);
    let light = |imgs: &[Vec<Vec3>]| imgs.iter().flatten().map(|p| p.element_sum() as f64).sum::<f64>();
    let variance = |imgs: &[Vec<Vec3>]| {
        let mut sum = 0.0f64;
        for (i, r) in reference.iter().enumerate() {
            let mean = imgs.iter().map(|img| img[i].as_dvec3()).sum::<glam::DVec3>() / seeds as f64;
            let spread = imgs.iter().map(|img| (img[i].as_dvec3() - mean).powf(2.0)).sum::<glam::DVec3>() / (seeds - 1) as f64;
            sum += (spread / (r.as_dvec3().powf(2.0) + glam::DVec3::splat(0.01))).element_sum() / 3.0;
        }
        sum / reference.len() as f64
    };
    let (whole_light, whole_variance) = (light(&whole), variance(&whole));
    glint::stdout_line!("{}: {}x{}, {spp} spp, seeds 0-{}, reference {reference_spp} spp", scene.as_ref().map_or("embedded Cornell box".into(), |p| p.display().to_string()), job.settings.width, job.settings.height, seeds - 1);
    glint::stdout_line!("| part | light | variance | share |\n|---|---|---|---|\n| whole | 100% | {whole_variance:.5} | 100% |");
    let only = |s: Strategy| Strategies::only(&[s]);
    let parts = [
        ("camera", only(Strategy::Camera)),
        ("bsdf, depth 1", only(Strategy::Bsdf).with_depths(1, 1)),
        ("bsdf, depths 2-", only(Strategy::Bsdf).with_depths(2, u32::MAX)),
        ("light, depth 1", only(Strategy::Light).with_depths(1, 1)),
        ("light, depth 2", only(Strategy::Light).with_depths(2, 2)),
        ("light, depths 3-", only(Strategy::Light).with_depths(3, u32::MAX)),
        ("connection", only(Strategy::Connection)),
        ("tracing", only(Strategy::Tracing)),
        ("merge", only(Strategy::Merge)),
    ];
    for (name, strategies) in parts {
        let imgs = images(strategies);
        let v = variance(&imgs);
        glint::stdout_line!("| {name} | {:.1}% | {v:.5} | {:.0}% |", 100.0 * light(&imgs) / whole_light, 100.0 * v / whole_variance);
    }
    Ok(())
}
