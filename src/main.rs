//! The `glint` command line.

use anyhow::{Context as _, Result};
use clap::{Args, Parser, Subcommand};
use glint::integrator::Context;
use glint::loader::{self, LoadOptions};
use glint::output;
use glint::render::{render_pass, Film, PassStats, RenderSettings};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(name = "glint", version, about = "A physically based path tracer for glTF 2.0 scenes")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene (default: the embedded Cornell box) to a linear EXR.
    Render(RenderArgs),
    /// Read and check everything in a glTF file (every node, mesh, accessor
    /// and buffer) and report what it holds, or the first problem.
    Inspect {
        /// Scene file (.gltf or .glb).
        scene: PathBuf,
    },
}

#[derive(Args)]
struct RenderArgs {
    /// Scene file (.gltf or .glb). Without it, the embedded Cornell box.
    scene: Option<PathBuf>,
    /// Output EXR (linear float RGBA).
    #[arg(short, long, default_value = "render.exr")]
    output: PathBuf,
    /// Also write an 8-bit sRGB PNG preview here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    /// Image width in pixels [default: 512].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=32768))]
    width: Option<u32>,
    /// Image height in pixels [default: from the camera's aspect ratio, else the width].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=32768))]
    height: Option<u32>,
    /// Most scattering events on a path (1 = direct light only; Cycles' "max bounces" + 1).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=1024))]
    max_depth: u32,
    /// Multiple importance sampling of lights and BSDF (off: the seed's rule,
    /// where BSDF-sampled rays ignore emitters).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    mis: String,
    /// Random seed: the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Camera to render, by node or camera name [default: the first perspective camera].
    #[arg(long)]
    camera: Option<String>,
    /// Which of the file's scenes [default: the file's default scene].
    #[arg(long)]
    scene_index: Option<usize>,
    /// Print timings and ray throughput by kind.
    #[arg(long)]
    stats: bool,
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Inspect { scene } => inspect(&scene),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Image size: explicit, else derived from the camera's aspect ratio.
fn resolution(width: Option<u32>, height: Option<u32>, aspect: Option<f32>) -> (u32, u32) {
    let aspect = aspect.unwrap_or(1.0);
    let derive = |v: f32| (v.round() as u32).clamp(1, 32768);
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, derive(w as f32 / aspect)),
        (None, Some(h)) => (derive(h as f32 * aspect), h),
        (None, None) => (512, derive(512.0 / aspect)),
    }
}

fn render(args: RenderArgs) -> Result<()> {
    let options = LoadOptions { scene_index: args.scene_index, camera: args.camera.clone() };
    let load_start = Instant::now();
    let (scene, scene_name) = match &args.scene {
        Some(path) => (loader::load_file(path, &options)?, path.display().to_string()),
        None => (
            loader::load_bytes(glint::DEFAULT_SCENE.as_bytes(), None, glint::DEFAULT_SCENE_NAME, &options)?,
            glint::DEFAULT_SCENE_NAME.to_string(),
        ),
    };
    let load_time = load_start.elapsed();
    for w in &scene.warnings {
        eprintln!("warning: {scene_name}: {w}");
    }
    let (width, height) = resolution(args.width, args.height, scene.camera.aspect_ratio);
    let settings = RenderSettings { width, height, spp: args.spp, max_depth: args.max_depth, seed: args.seed, mis: args.mis == "on" };

    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = args.threads {
        pool = pool.num_threads(t as usize);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let threads = pool.current_num_threads();

    let (ctx, build_time) = Context::new(&scene);
    let progress = ProgressBar::with_draw_target(Some(width as u64 * height as u64 * args.spp as u64), ProgressDrawTarget::hidden());
    progress.set_style(ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed} (eta {eta})").unwrap_or_else(|_| ProgressStyle::default_bar()));
    let started = Instant::now();
    let shown = AtomicBool::new(false);
    let cancel = AtomicBool::new(false);
    let on_progress = |n: u64| {
        progress.inc(n);
        // Only renders that take more than a second get a progress bar.
        if started.elapsed() > Duration::from_secs(1) && !shown.swap(true, std::sync::atomic::Ordering::Relaxed) {
            progress.set_draw_target(ProgressDrawTarget::stderr());
        }
    };
    let mut film = Film::new(width, height);
    let stats: PassStats = pool.install(|| render_pass(&ctx, &settings, &mut film, 0..args.spp, &cancel, &on_progress))?;
    let seconds = started.elapsed().as_secs_f64();
    progress.finish_and_clear();

    let pixels = film.mean();
    write_outputs(&args.output, args.png.as_deref(), width, height, &pixels)?;

    let mrays = stats.rays.total() as f64 / seconds / 1e6;
    eprintln!("{width}x{height}, {} spp, {seconds:.2} s, {mrays:.1} Mrays/s -> {}", args.spp, args.output.display());
    if stats.discarded > 0 {
        eprintln!("warning: {} sample(s) were NaN or infinite and were discarded", stats.discarded);
    }
    if args.stats {
        let r = &stats.rays;
        eprintln!("scene: {} triangles, {} emissive, {} materials; load {:.3} s, BVH build {:.3} s",
            scene.triangles.len(), ctx.lights.triangles.len(), scene.materials.len(), load_time.as_secs_f64(), build_time.as_secs_f64());
        eprintln!("rays: {:.2} M camera, {:.2} M bounce, {:.2} M shadow; {threads} threads", r.camera as f64 / 1e6, r.bounce as f64 / 1e6, r.shadow as f64 / 1e6);
        eprintln!("time: {:.4} s per sample (all pixels), {:.1} Mrays/s", seconds / args.spp as f64, mrays);
        eprintln!("discarded non-finite samples: {}", stats.discarded);
    }
    Ok(())
}

fn inspect(path: &Path) -> Result<()> {
    let found = loader::inspect_file(path)?;
    for w in &found.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    println!("{}: {} triangles, {} accessors, {} camera node(s)", path.display(), found.triangles, found.accessors, found.cameras);
    if let Some(problem) = found.camera_problem {
        println!("{}: cannot render as it is: {problem}", path.display());
    }
    Ok(())
}

fn write_outputs(exr: &Path, png: Option<&Path>, width: u32, height: u32, pixels: &[glam::Vec3]) -> Result<()> {
    output::write_exr(exr, width, height, pixels)?;
    if let Some(png) = png {
        output::write_png(png, width, height, pixels)?;
    }
    Ok(())
}
