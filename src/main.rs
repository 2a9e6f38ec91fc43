//! The `glint` command line.

use anyhow::{Context as _, Result};
use clap::{Args, Parser, Subcommand};
use glint::bsdf::BsdfModel;
use glint::features::{FeatureMode, KernelBsdf};
use glint::integrator::Context;
use glint::job::{self, Job, JobOptions};
use glint::loader;
use glint::output;
use glint::pixel_filter::{FilterKind, FilterRequest};
use glint::progressive::{render_progressive, Budget};
use glint::render::{render_pass, Film, LightPaths, PassStats};
use glint::request::EnvironmentRequest;
use glint::request::RenderRequest;
use glint::rng::Sampler;
use glint::strategies::Strategies;
use glint::watch::WatchOptions;
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
    /// Follow a job folder (or one scene file) and render it every time it
    /// changes, writing the EXR and a status file atomically.
    Watch(WatchArgs),
    /// Read and check everything in a glTF file (every node, mesh, accessor
    /// and buffer) and report what it holds, or the first problem.
    Inspect {
        /// Scene file (.gltf or .glb).
        scene: PathBuf,
    },
}

/// How to render; shared by `render` and `watch`.
#[derive(Args)]
struct RenderOptions {
    /// Samples per pixel [default: 64; with --time-limit: as many as fit].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: Option<u32>,
    /// Stop starting new samples after this many seconds of rendering.
    #[arg(long, value_parser = parse_seconds)]
    time_limit: Option<f64>,
    /// Adaptive sampling, as Blender's Noise Threshold: a pixel stops taking samples once its noise is below this (Cycles' default 0.01; typical 0.1 to 0.001); the sample count is then the most a pixel takes [default: off]
    #[arg(long, value_parser = parse_threshold)]
    noise_threshold: Option<f32>,
    /// Adaptive sampling's Min Samples: every pixel takes these before the first check [default: from the threshold, as Cycles: 0.1 → 32, 0.01 → 64, 0.001 → 128]
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    min_samples: Option<u32>,
    /// Image width in pixels [default: 512].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=32768))]
    width: Option<u32>,
    /// Image height in pixels [default: from the camera's aspect ratio, else the width].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=32768))]
    height: Option<u32>,
    /// Most scattering events on a path (1 = direct light only; Cycles' "max bounces" + 1) [default: 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    max_depth: Option<u32>,
    /// Multiple importance sampling of lights and BSDF (off: the seed's rule,
    /// where BSDF-sampled rays ignore emitters) [default: on].
    #[arg(long, value_parser = ["on", "off"])]
    mis: Option<String>,
    /// Connections of camera vertices to light subpaths, and light tracing
    /// (needs MIS and emitting surfaces); auto: on where they pay, where
    /// some surface is glossy enough to focus light into caustics
    /// (roughness below 0.6), an emitter's light lands near it (the
    /// ceiling above a hanging two-sided lamp, a slit, a shade), a lamp has
    /// a Spread, or the scene is open to the World on some sides (a corner,
    /// a niche, a box open at the front) [default: the request's, else auto].
    #[arg(long, value_parser = ["auto", "on", "off"])]
    light_paths: Option<String>,
    /// BSDF model: what Cycles' Principled BSDF does, or the seed's formulas [default: principled].
    #[arg(long, value_parser = ["principled", "seed"])]
    bsdf: Option<String>,
    /// Random seed: the same seed gives the same image [default: 0].
    #[arg(long)]
    seed: Option<u64>,
    /// Where each pixel sample's numbers come from: Owen-scrambled Sobol
    /// points, or independent random numbers (the seed's) [default: sobol].
    #[arg(long, value_parser = ["sobol", "random"])]
    sampler: Option<String>,
    /// Camera to render, by node or camera name, or `auto`: one that frames
    /// the scene (lit by a white World when it has no lights) [default: the
    /// first camera, depth first].
    #[arg(long)]
    camera: Option<String>,
    /// Which of the file's scenes [default: the file's default scene].
    #[arg(long)]
    scene_index: Option<usize>,
    /// World radiance R,G,B in W·sr⁻¹·m⁻² seen by rays that leave the scene [default: black].
    #[arg(long, value_delimiter = ',', num_args = 3)]
    background: Option<Vec<f32>>,
    /// Blender's Film › Transparent: the camera does not see the World
    /// (which still lights the scene), and the EXR's alpha is each pixel's
    /// coverage, its colour premultiplied [default: the request's, else off].
    #[arg(long)]
    transparent_film: bool,
    /// Blender's Film › Transparent Glass, with its Roughness Threshold:
    /// with --transparent-film, the World seen through glass no rougher
    /// than this is transparency too [default: the request's, else off].
    #[arg(long, value_name = "ROUGHNESS")]
    transparent_glass: Option<f32>,
    /// Blender's Film › Pixel Filter: box, gaussian or blackman-harris,
    /// drawn by importance as Cycles draws it [default: the request's,
    /// else box].
    #[arg(long, value_parser = ["box", "gaussian", "blackman-harris"])]
    pixel_filter: Option<String>,
    /// The pixel filter's Width in pixels, as Blender's [default: 1 for
    /// the box, 1.5 for the others].
    #[arg(long, requires = "pixel_filter", value_name = "PIXELS")]
    filter_width: Option<f32>,
    /// World as an equirectangular environment image (HDR, EXR, PNG, JPEG),
    /// mapped as Blender's Environment Texture; replaces --background.
    #[arg(long)]
    environment: Option<PathBuf>,
    /// Strength the environment image is multiplied by [default: 1].
    #[arg(long, requires = "environment")]
    environment_strength: Option<f32>,
    /// Turn the environment about the up axis, in degrees (Blender's
    /// Mapping node Z rotation) [default: 0].
    #[arg(long, requires = "environment")]
    environment_rotation: Option<f32>,
    /// Kernel: the one the scene's features need, or the general one that
    /// does everything (same image for the same seed; for comparison) [default: auto].
    #[arg(long, value_parser = ["auto", "all"])]
    features: Option<String>,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
}

impl RenderOptions {
    fn job_options(&self) -> JobOptions {
        JobOptions {
            width: self.width,
            height: self.height,
            samples: self.spp,
            time_limit: self.time_limit,
            noise_threshold: self.noise_threshold,
            adaptive_min_samples: self.min_samples,
            max_depth: self.max_depth,
            seed: self.seed,
            mis: self.mis.as_deref().map(|m| m == "on"),
            light_paths: self.light_paths.as_deref().map(|m| match m {
                "on" => LightPaths::On,
                "off" => LightPaths::Off,
                _ => LightPaths::Auto,
            }),
            sampler: self.sampler.as_deref().map(|s| if s == "random" { Sampler::Random } else { Sampler::Sobol }),
            camera: self.camera.clone(),
            scene_index: self.scene_index,
            background: self.background.as_ref().map(|b| [b[0], b[1], b[2]]),
            environment: self.environment.as_ref().map(|image| EnvironmentRequest {
                image: image.clone(),
                strength: self.environment_strength.unwrap_or(1.0),
                rotation: self.environment_rotation.unwrap_or(0.0).to_radians(),
            }),
            camera_world: None,
            bsdf: self.bsdf.as_deref().map(|b| if b == "seed" { BsdfModel::Seed } else { BsdfModel::Principled }),
            two_sided_emission: None,
            features: self.features.as_deref().map(|f| if f == "all" { FeatureMode::All } else { FeatureMode::Auto }),
            transparent: self.transparent_film.then_some(true),
            transparent_glass: self.transparent_glass,
            pixel_filter: self.pixel_filter.as_deref().map(|f| {
                let kind = match f {
                    "gaussian" => FilterKind::Gaussian,
                    "blackman-harris" => FilterKind::BlackmanHarris,
                    _ => FilterKind::Box,
                };
                let default = if kind == FilterKind::Box { 1.0 } else { 1.5 };
                FilterRequest { kind, width: self.filter_width.unwrap_or(default) }
            }),
        }
    }
}

/// A finite number > 0, or an error saying `s` is not `what` > 0.
fn parse_positive<T: std::str::FromStr + Copy + Into<f64>>(s: &str, what: &str) -> Result<T, String> {
    match s.parse::<T>() {
        Ok(t) if t.into().is_finite() && t.into() > 0.0 => Ok(t),
        _ => Err(format!("'{s}' is not {what} > 0")),
    }
}

fn parse_threshold(s: &str) -> Result<f32, String> {
    parse_positive(s, "a noise threshold")
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    parse_positive(s, "a number of seconds")
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
    /// A render request (JSON, as the Blender addon writes it: size, samples,
    /// World colour, area lights); options given here override it.
    #[arg(long)]
    request: Option<PathBuf>,
    #[command(flatten)]
    options: RenderOptions,
    /// Print timings and ray throughput by kind.
    #[arg(long)]
    stats: bool,
    /// Then trace the rays of one more sample per pixel again on one
    /// thread, through Glint's traversal and through obvhs alone, and print
    /// both rates by ray kind and the share of the render spent traversing.
    #[arg(long)]
    traversal: bool,
    /// Render the image this many times in this one process, each from a
    /// new film, and report the last (its image is the one written): from
    /// the second on, a render's time is what the daemon the Blender add-on
    /// keeps running gives after its first (the threads started, the
    /// memory mapped). For benchmarks.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    repeat: u32,
    /// Add only these strategies' light to the image, to see which carries
    /// the noise: camera (what the camera ray sees), bsdf (light a BSDF
    /// sample reaches), light (light sampling), connection, tracing (light
    /// tracing), merge (photons around a vertex seen through glass or in a
    /// mirror). Images of strategies apart add up to the whole [default:
    /// all].
    #[arg(long, value_parser = Strategies::parse_list)]
    strategies: Option<Strategies>,
    /// Add only the light of paths with this many scattering events: N,
    /// N-M, or N- (N and more) [default: all].
    #[arg(long, value_parser = Strategies::parse_depths)]
    depths: Option<(u32, u32)>,
    /// Camera paths look for caustics where light subpaths through smooth
    /// glass and mirrors found them (scenes with such surfaces and light
    /// paths); off, to measure what that gives [default: on].
    #[arg(long, value_parser = ["on", "off"])]
    caustic_guide: Option<String>,
    /// Camera vertices seen through smooth glass or in a mirror merge with
    /// the photons light subpaths landed around them (scenes with such
    /// surfaces and light paths); off, to measure what that gives
    /// [default: on].
    #[arg(long, value_parser = ["on", "off"])]
    merge: Option<String>,
}

#[derive(Args)]
struct WatchArgs {
    /// A job folder (scene.glb or scene.gltf, request.json) or a scene file
    /// (its request: NAME.request.json beside it).
    target: PathBuf,
    /// Defaults for what a render request leaves out.
    #[command(flatten)]
    options: RenderOptions,
    /// Quit when standard input closes: a parent process (the Blender addon)
    /// holds a pipe open, so the daemon never outlives it.
    #[arg(long)]
    exit_with_stdin: bool,
}

fn main() {
    // First, before code compiled for the build's instruction sets runs.
    let missing = glint::cpu::missing_features();
    if !missing.is_empty() {
        glint::stderr_line!("error: this CPU lacks {}, which this build of glint was compiled to use (the project builds for x86-64-v2, as Blender 4.5 does); build it for this CPU with RUSTFLAGS=\"-C target-cpu=native\" cargo build --release", missing.join(", "));
        std::process::exit(1);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Watch(args) => watch(args),
        Command::Inspect { scene } => inspect(&scene),
    };
    if let Err(e) = result {
        glint::stderr_line!("error: {e:#}");
        std::process::exit(1);
    }
}

fn thread_pool(threads: Option<u32>) -> Result<rayon::ThreadPool> {
    // As many workers as CPUs unless told (rayon's default, named here
    // for the pinning below).
    let workers = threads.map_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()), |t| t as usize);
    let mut pool = rayon::ThreadPoolBuilder::new().num_threads(workers);
    // One worker to a CPU where the pool fills the CPUs (affinity.rs).
    if let Some(allowed) = glint::affinity::allowed_cpus() {
        pool = pool.start_handler(move |i| {
            if let Some(cpu) = glint::affinity::cpu_for(i, workers, &allowed) {
                glint::affinity::pin_current_thread(cpu);
            }
        });
    }
    pool.build().context("cannot start worker threads")
}

fn render(args: RenderArgs) -> Result<()> {
    let request = match &args.request {
        Some(path) => RenderRequest::read(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
        None => RenderRequest::default(),
    };
    let options = args.options.job_options().or(&JobOptions::from(&request));
    let load_start = Instant::now();
    let Job { scene, mut settings, budget } = job::prepare(args.scene.as_deref(), &options, (&request).into()).map_err(anyhow::Error::msg)?;
    let load_time = load_start.elapsed();
    let (min, max) = args.depths.unwrap_or((0, u32::MAX));
    settings.strategies = args.strategies.unwrap_or_default().with_depths(min, max);
    settings.caustic_guide = args.caustic_guide.as_deref() != Some("off");
    settings.merge = args.merge.as_deref() != Some("off");
    let scene_name = args.scene.as_ref().map_or(glint::DEFAULT_SCENE_NAME.to_string(), |p| p.display().to_string());
    for w in &scene.warnings {
        glint::stderr_line!("warning: {scene_name}: {w}");
    }
    let (width, height) = (settings.width, settings.height);
    let pool = thread_pool(args.options.threads)?;
    let threads = pool.current_num_threads();

    // On the render's own workers, as is all that runs in parallel before
    // the render (a light grid's cells, light_cache.rs; the features
    // line's light-path rule, light_paths::landing): outside the pool it
    // would start rayon's global one beside it.
    let prepare_start = Instant::now();
    let (mut ctx, build_time) = pool.install(|| Context::new(&scene));
    glint::stderr_line!("{}", pool.install(|| ctx.features_line(&settings)));
    if !settings.strategies.is_all() {
        glint::stderr_line!("a part of the image: the light of {}", settings.strategies);
    }
    // The Principled energy tables are read from the binary once per
    // process (bsdf/baked.rs), and only for a kernel that has a glossy
    // layer: before the clock starts, with the rest of the set-up.
    if ctx.kernel(&settings).bsdf == KernelBsdf::Principled {
        glint::bsdf::energy::tables();
    }
    // The rest of the set-up beside the BVH: the lights' tree and grid,
    // the light-path rule's rays, the energy tables.
    let lights_time = prepare_start.elapsed().saturating_sub(build_time);
    let total = (budget.samples > 0).then(|| width as u64 * height as u64 * budget.samples as u64);
    let progress = ProgressBar::with_draw_target(total, ProgressDrawTarget::hidden());
    progress.set_style(ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed} (eta {eta})").unwrap_or_else(|_| ProgressStyle::default_bar()));
    let opened = Instant::now();
    let shown = AtomicBool::new(false);
    let cancel = AtomicBool::new(false);
    let on_progress = |n: u64| {
        progress.inc(n);
        // Only renders that take more than a second get a progress bar.
        if opened.elapsed() > Duration::from_secs(1) && !shown.swap(true, std::sync::atomic::Ordering::Relaxed) {
            progress.set_draw_target(ProgressDrawTarget::stderr());
        }
    };
    // A fixed sample count renders in one pass: the per-pixel sums are then
    // grouped the same way however fast the kernel is, so the image depends
    // on the settings alone, bit for bit (a time limit needs passes; so
    // does adaptive sampling, whose passes end where it checks, whatever
    // the speed).
    let render_once = |film: &mut Film| {
        pool.install(|| match budget.time {
            None if settings.adaptive.is_none() => render_pass(&ctx, &settings, film, 0..budget.samples, &cancel, &on_progress),
            time => render_progressive(&ctx, &settings, &Budget { paced: time.is_some(), ..budget }, film, &cancel, &on_progress, &mut |_| {}),
        })
    };
    // `--repeat`: the earlier renders' seconds per sample; the last one's
    // film, stats and time are the ones written and reported.
    let mut earlier = Vec::new();
    let (film, stats, seconds) = loop {
        let started = Instant::now();
        let mut film = Film::new(width, height);
        let stats: PassStats = render_once(&mut film)?;
        let seconds = started.elapsed().as_secs_f64();
        if earlier.len() + 1 >= args.repeat as usize {
            break (film, stats, seconds);
        }
        earlier.push(seconds / film.samples.max(1) as f64);
        progress.reset();
    };
    progress.finish_and_clear();

    let pixels = film.mean();
    write_outputs(&args.output, args.png.as_deref(), width, height, &pixels, film.alpha().as_deref())?;

    let mrays = stats.rays.total() as f64 / seconds / 1e6;
    glint::stderr_line!("{width}x{height}, {} spp, {seconds:.3} s, {mrays:.1} Mrays/s -> {}", film.samples, args.output.display());
    if let Some(c) = &film.convergence {
        let stopped = c.active.iter().filter(|a| !**a).count() as f64 / c.active.len().max(1) as f64;
        glint::stderr_line!("adaptive sampling: {:.1} samples a pixel on average, {:.0}% of the pixels converged", film.mean_samples(), stopped * 100.0);
    }
    if stats.discarded > 0 {
        glint::stderr_line!("warning: {} sample(s) were NaN, infinite or above {:e} W·sr⁻¹·m⁻² and were discarded", stats.discarded, glint::render::MAX_SAMPLE);
    }
    if args.stats {
        let r = &stats.rays;
        glint::stderr_line!("scene: {} triangles, {} emissive, {} materials; load {:.3} s, BVH build {:.3} s, lights and the rest of the set-up {:.3} s",
            scene.triangles.len(), ctx.lights.triangles.len(), scene.materials.len(), load_time.as_secs_f64(), build_time.as_secs_f64(), lights_time.as_secs_f64());
        glint::stderr_line!("rays: {:.2} M camera, {:.2} M bounce, {:.2} M shadow; {threads} threads", r.camera as f64 / 1e6, r.bounce as f64 / 1e6, r.shadow as f64 / 1e6);
        match stats.camera_tests {
            0.0 => glint::stderr_line!("camera rays' first hits: through the BVH"),
            tests => glint::stderr_line!("camera rays' first hits: binned triangles, {tests:.1} tests a pixel sample"),
        }
        glint::stderr_line!("time: {:.5} s per sample (all pixels), {:.1} Mrays/s", seconds / film.samples.max(1) as f64, mrays);
        if !earlier.is_empty() {
            let times: Vec<String> = earlier.iter().map(|t| format!("{t:.5}")).collect();
            glint::stderr_line!("earlier renders of the {}: {} s per sample", args.repeat, times.join(", "));
        }
        let phases = &stats.phases;
        let (setup, subpaths, paths) = (phases.setup.as_secs_f64(), phases.light_subpaths.as_secs_f64(), phases.camera_paths.as_secs_f64());
        glint::stderr_line!("time by phase: set-up {setup:.5} s (what the caustic guide, MIS scale, camera rays' bins and the sums' pages add beside the first light subpaths), light subpaths {subpaths:.5} s, camera paths {paths:.5} s, the rest {:.5} s (the film, passes)",
            (seconds - setup - subpaths - paths).max(0.0));
        if let (photons, indices @ 1.., Some(radius)) = stats.photons {
            glint::stderr_line!("caustic photons: {} a sample index, merged within {radius:.4} m at the first (shrinking as i^-1/6)", photons / indices as u64);
        }
        if let Some((directions, cells, edge)) = stats.caustic_guide {
            glint::stderr_line!("caustic guide: {directions} directions in {cells} cells of {edge:.3} m, made in {:.5} s beside the bins and the first light subpaths", phases.caustic_guide.as_secs_f64());
        }
        glint::stderr_line!("discarded samples (non-finite or above {:e}): {}", glint::render::MAX_SAMPLE, stats.discarded);
        if let Some(kib) = glint::memory::peak_rss_kib() {
            glint::stderr_line!("memory: peak RSS {:.1} MiB", kib as f64 / 1024.0);
        }
    }
    if args.traversal {
        traversal_report(&mut ctx, &settings, &pool, &stats, seconds, threads)?;
    }
    Ok(())
}

/// `--traversal`: see traversal_bench.rs.
fn traversal_report(ctx: &mut Context, settings: &glint::render::RenderSettings, pool: &rayon::ThreadPool, stats: &PassStats, seconds: f64, threads: usize) -> Result<()> {
    use glint::traversal_bench::{replay, traversal_share, RayLog};
    ctx.ray_log = Some(RayLog::default());
    let mut film = Film::new(settings.width, settings.height);
    pool.install(|| render_pass(ctx, settings, &mut film, 0..1, &AtomicBool::new(false), &|_| {}))?;
    let rays = ctx.ray_log.take().map(|log| log.take()).unwrap_or_default();
    let rates = replay(ctx, &rays, 3);
    glint::stderr_line!("traversal on 1 thread, the rays of one more sample per pixel: Glint's queries against obvhs alone");
    for (kind, r) in &rates {
        let share = if r.obvhs > 0.0 { 100.0 * r.glint / r.obvhs } else { 0.0 };
        let same = 100.0 * r.agree as f64 / r.rays.max(1) as f64;
        glint::stderr_line!("  {:<6} {:>9} rays: {:.2} Mrays/s, obvhs alone {:.2} ({share:.0}%); same result on {same:.2}%", format!("{kind:?}").to_lowercase(), r.rays, r.glint, r.obvhs);
    }
    // The render found its camera rays' first hits without the BVH where
    // it binned them (camera_hits.rs): they are no part of its traversal.
    let binned = stats.camera_tests > 0.0;
    let counts = glint::integrator::RayCounts { camera: if binned { 0 } else { stats.rays.camera }, ..stats.rays };
    let note = if binned { " (camera rays left out: the render binned them)" } else { "" };
    glint::stderr_line!("traversal share of the render's thread time: {:.0}%{note}", 100.0 * traversal_share(&rates, &counts, seconds, threads));
    Ok(())
}

fn watch(args: WatchArgs) -> Result<()> {
    let pool = thread_pool(args.options.threads)?;
    let options = WatchOptions { target: args.target, defaults: args.options.job_options(), exit_with_stdin: args.exit_with_stdin };
    glint::watch::run(&options, &pool)
}

fn inspect(path: &Path) -> Result<()> {
    let found = loader::inspect_file(path)?;
    for w in &found.warnings {
        glint::stderr_line!("warning: {}: {w}", path.display());
    }
    glint::stdout_line!("{}: {} triangles, {} accessors, {} camera node(s)", path.display(), found.triangles, found.accessors, found.cameras);
    if let Some(problem) = found.camera_problem {
        glint::stdout_line!("{}: cannot render as it is: {problem}", path.display());
    }
    Ok(())
}

fn write_outputs(exr: &Path, png: Option<&Path>, width: u32, height: u32, pixels: &[glint::Vec3], alpha: Option<&[f32]>) -> Result<()> {
    output::write_exr(exr, width, height, pixels, alpha)?;
    if let Some(png) = png {
        output::write_png(png, width, height, pixels, alpha)?;
    }
    Ok(())
}
