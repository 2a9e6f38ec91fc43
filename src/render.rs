//! The image loop: tiles of pixels in parallel, every sample filtered in one
//! place. Each pixel sample draws from its own generator (seed, pixel,
//! sample index), so an image is the same for any thread count, and for any
//! split of its samples into passes up to the rounding of the sums.

use crate::bsdf::{Bsdf, BsdfModel, LambertBsdf, PrincipledBsdf, RoughPrincipledBsdf, SeedBsdf, WithCoat, WithGlass};
use crate::camera::{CameraRay, Lens};
use crate::camera_hits::{CameraHits, FirstHit, TileRays};
use crate::features::{FeatureMode, KernelBsdf};
use crate::material::Material;
use crate::integrator::{prepare_materials, radiance, Context, LightVertices, RayCounts};
use crate::light_paths::PER_SAMPLE;
use crate::light_tracing::LightTracing;
use crate::caustic_guide::CausticGuide;
use std::sync::Arc;
use crate::strategies::Strategies;
use crate::adaptive::{Adaptive, Convergence};
use crate::pixel_filter::PixelFilter;
use crate::rng::{in_first_half, Rng, Sampler};
use glam::Vec2;
use crate::Vec3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub const TILE: u32 = 16;
/// Sample indices whose light subpaths are traced together: 4 × 1,024
/// vertices (0.7 MB) stay in cache; 16 × 4,096 (11 MB) took 10–15% more
/// time for the same error.
const SAMPLES_PER_LIGHT_TRACE: u32 = 4;

/// Light subpaths per sample index that reach the camera: a quarter of
/// the pixels, traced `TRACED_BATCH` at a time. On the benchmark scenes
/// (256², 64 spp, 16 bounces, 4 seeds; s per sample, relMSE), against
/// none: Cornell box 0.115, 0.0101 → 0.145, 0.0034; gold sphere 0.025,
/// 0.0037 → 0.026, 0.0023. Measured again at 2026-12-06's code (256², 16
/// spp, 6–8 seeds, relMSE × seconds against a 512-spp image): Cornell
/// box, one per pixel (as bidirectional path tracing draws one per pixel
/// sample) 1.51e-2, a half 1.45e-2, a third
/// 1.49e-2, a quarter 1.57e-2, an eighth 1.87e-2; gold sphere a half
/// 1.60e-3, a third 1.56e-3, a quarter 1.59e-3, an eighth 1.76e-3, a
/// sixteenth 1.92e-3, one subpath 3.04e-3. A quarter stays within 8% of
/// the best on both, with the cheaper sample (gold sphere 18.2 ms against
/// 20.4 at a half). At most 65,536 had been traced, which bounded the
/// splats a pass held: above 512² fewer than a quarter (1920 × 1080: one
/// pixel in 32). At 1024² (8 spp, 3 seeds, against a 128–256-spp image)
/// the quarter takes the Cornell box's relMSE × seconds from 0.381 to
/// 0.269 and the gold sphere's from 0.0290 to 0.0237; 1920 × 1080's peak
/// RSS 74.1 → 77.1 MiB.
fn traced_per_sample(w: u32, h: u32) -> u32 {
    (w * h / 4).max(1)
}
/// Light subpaths per sample index traced at once, whose splats a pass
/// holds (a few MB) before adding them to the image.
const TRACED_BATCH: u32 = 65_536;

/// Image size: explicit, else derived from the camera's aspect ratio.
pub fn resolution(width: Option<u32>, height: Option<u32>, aspect: Option<f32>) -> (u32, u32) {
    let aspect = aspect.unwrap_or(1.0);
    let derive = |v: f32| (v.round() as u32).clamp(1, 32768);
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, derive(w as f32 / aspect)),
        (None, Some(h)) => (derive(h as f32 * aspect), h),
        (None, None) => (512, derive(512.0 / aspect)),
    }
}

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u64,
    /// Combine light and BSDF sampling by multiple importance sampling;
    /// off is the seed's rule (BSDF-sampled rays ignore emitters).
    pub mis: bool,
    pub bsdf: BsdfModel,
    /// The kernel the scene needs, or the general one (features.rs).
    pub features: FeatureMode,
    /// Where each pixel sample's numbers come from (rng.rs).
    pub sampler: Sampler,
    /// Connect camera vertices to light subpaths' vertices
    /// (light_paths.rs) where MIS is on and emitting triangles exist.
    pub light_paths: LightPaths,
    /// Also add light subpaths' vertices to the pixels they appear in
    /// (light_tracing.rs), where light paths are on.
    pub light_tracing: bool,
    /// Let camera paths look for caustics where light subpaths found them
    /// (caustic_guide.rs), in scenes with smooth glass or mirrors.
    pub caustic_guide: bool,
    /// Let camera vertices seen through glass or in a mirror merge with
    /// the photons light subpaths landed there (photons.rs), in scenes
    /// with smooth glass or mirrors.
    pub merge: bool,
    /// Whose light reaches the image: all of it but when taking a render
    /// apart (strategies.rs).
    pub strategies: Strategies,
    /// Blender's Film › Transparent: the camera does not see the World,
    /// which still lights the scene, and the film keeps each pixel's
    /// coverage as alpha.
    pub transparent: bool,
    /// Film › Transparent Glass (with `transparent`): the World seen
    /// through glass of roughness up to this is transparency too.
    pub transparent_glass: Option<f32>,
    /// Adaptive sampling (adaptive.rs): Noise Threshold and Min Samples;
    /// None, every pixel takes every sample.
    pub adaptive: Option<Adaptive>,
    /// Film › Pixel Filter (pixel_filter.rs): a one-pixel box by default.
    pub pixel_filter: PixelFilter,
}

/// Whether light subpaths are traced (light_paths.rs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightPaths {
    /// Where they find light that camera paths reach only by chance
    /// (`Context::light_paths_pay`).
    #[default]
    Auto,
    On,
    Off,
}

/// Sums of radiance samples per pixel, row-major from the top-left.
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub sum: Vec<Vec3>,
    /// Sums of the samples' coverage (1 where the camera ray met a
    /// surface, 0 where it left the scene), kept only for a transparent
    /// film (`RenderSettings::transparent`); empty otherwise.
    pub coverage: Vec<f32>,
    /// Sample indices rendered: every pixel's samples, but with adaptive
    /// sampling, where a pixel has `convergence.counts` of them.
    pub samples: u32,
    /// With adaptive sampling (`RenderSettings::adaptive`), what decides
    /// which pixels take more samples; made by the first pass.
    pub convergence: Option<Convergence>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film { width, height, sum: crate::memory::zeroed_vec3s(width as usize * height as usize), coverage: Vec::new(), samples: 0, convergence: None }
    }

    /// The per-pixel mean: the Monte Carlo estimate.
    pub fn mean(&self) -> Vec<Vec3> {
        self.per_sample(&self.sum)
    }

    /// The per-pixel alpha of a transparent film (its mean coverage; the
    /// colour is premultiplied by it, as Cycles writes it), None for an
    /// opaque one.
    pub fn alpha(&self) -> Option<Vec<f32>> {
        (!self.coverage.is_empty()).then(|| self.per_sample(&self.coverage))
    }

    /// Per-pixel sums over each pixel's samples: `samples`, or with
    /// adaptive sampling its own count.
    fn per_sample<T: Copy + std::ops::Mul<f32, Output = T>>(&self, sums: &[T]) -> Vec<T> {
        match &self.convergence {
            Some(c) => sums.iter().zip(&c.counts).map(|(s, &n)| *s * inverse(n)).collect(),
            None => {
                let inv = inverse(self.samples);
                sums.iter().map(|s| *s * inv).collect()
            }
        }
    }

    /// Mean samples per pixel: `samples`, but with adaptive sampling.
    pub fn mean_samples(&self) -> f64 {
        match &self.convergence {
            Some(c) => c.total_samples() as f64 / self.sum.len().max(1) as f64,
            None => self.samples as f64,
        }
    }
}

fn inverse(samples: u32) -> f32 {
    if samples > 0 { 1.0 / samples as f32 } else { 0.0 }
}

/// The largest sample (per channel, W·sr⁻¹·m⁻²) a pixel's sum takes.
/// Sums are f32: two samples near f32::MAX, each finite, sum to infinity,
/// where 2^48 samples of at most this stay finite — more than a pixel's
/// samples and light tracing's splats into it can number. It is 10^17
/// times the Sun's radiance; the inputs are bounded well below it
/// (`job::MAX_RADIANCE`), so only a path that multiplies its light by 10^4
/// or more reaches it.
pub const MAX_SAMPLE: f32 = 1e24;

/// Whether a sample (or a splat) may be added to a pixel's sum: finite and
/// at most `MAX_SAMPLE` in every channel.
#[inline]
pub fn sample_fits(l: Vec3) -> bool {
    l.is_finite() && l.abs().max_element() <= MAX_SAMPLE
}

#[derive(Clone, Copy, Debug, Default)]
pub struct PassStats {
    pub rays: RayCounts,
    /// Samples whose radiance was NaN, infinite or above `MAX_SAMPLE`,
    /// dropped here. A correct integrator never produces one from bounded
    /// inputs; the tests assert this stays zero.
    pub discarded: u64,
    /// Ray-triangle tests per pixel sample that found the camera rays'
    /// first hits (camera_hits.rs); 0 where the BVH found them.
    pub camera_tests: f32,
    pub phases: Phases,
    /// The caustic guide's directions, cells and cell edge (m), where the
    /// render had one (`CausticGuide::summary`).
    pub caustic_guide: Option<(usize, usize, f32)>,
    /// Caustic photons (photons.rs): their number over the sample indices
    /// that kept some, those indices, and the merge radius (m) of the
    /// first of them.
    pub photons: (u64, u32, Option<f32>),
}

/// Where a pass's wall time went, phase by phase (`--stats`): what a
/// 1-spp render's time is made of, which per-sample figures hide.
#[derive(Clone, Copy, Debug, Default)]
pub struct Phases {
    /// Once a pass: the materials' prepared lobes, the MIS scale of the
    /// connections (its own subpaths) and the camera rays' triangle bins;
    /// the wall time they add beside the first light subpaths, which run
    /// with the bins.
    pub setup: Duration,
    /// Tracing light subpaths and adding light tracing's splats.
    pub light_subpaths: Duration,
    /// Of the set-up, the caustic guide's (caustic_guide.rs).
    pub caustic_guide: Duration,
    /// The tiles: camera paths, their light samples and connections.
    pub camera_paths: Duration,
}

impl PassStats {
    pub fn add(&mut self, o: &PassStats) {
        self.rays.add(&o.rays);
        self.discarded += o.discarded;
        self.camera_tests = self.camera_tests.max(o.camera_tests);
        self.phases.setup += o.phases.setup;
        self.phases.light_subpaths += o.phases.light_subpaths;
        self.phases.caustic_guide += o.phases.caustic_guide;
        self.caustic_guide = self.caustic_guide.or(o.caustic_guide);
        self.count_photons(o.photons);
        self.phases.camera_paths += o.phases.camera_paths;
    }

    /// Adds caustic photons (their number, the sample indices that kept
    /// them, a merge radius) to `photons`, whose radius stays the first's.
    pub fn count_photons(&mut self, (photons, indices, radius): (u64, u32, Option<f32>)) {
        self.photons = (self.photons.0 + photons, self.photons.1 + indices, self.photons.2.or(radius));
    }
}

#[derive(Debug, thiserror::Error)]
#[error("render cancelled")]
pub struct Cancelled;

/// Render samples `samples` of every pixel and add them to `film`. A
/// cancelled pass leaves the film untouched. `progress` receives the number
/// of pixel samples done, from worker threads.
pub fn render_pass(
    ctx: &Context,
    settings: &RenderSettings,
    film: &mut Film,
    samples: Range<u32>,
    cancel: &AtomicBool,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<PassStats, Cancelled> {
    // One monomorphised kernel per BSDF and set of light parts: the choice
    // is made once a pass, never per sample.
    let kernel = ctx.kernel(settings);
    macro_rules! run {
        ($b:ty, $area:literal, $punctual:literal, $lamps:literal) => {
            render_pass_with::<$b, $area, $punctual, $lamps>(ctx, settings, film, samples, cancel, progress)
        };
    }
    // Lamps are emitting triangles, so a kernel has them only with `area`.
    macro_rules! lights {
        ($b:ty) => {
            match (kernel.area, kernel.punctual, kernel.lamps) {
                (false, false, _) => run!($b, false, false, false),
                (false, true, _) => run!($b, false, true, false),
                (true, false, false) => run!($b, true, false, false),
                (true, false, true) => run!($b, true, false, true),
                (true, true, false) => run!($b, true, true, false),
                (true, true, true) => run!($b, true, true, true),
            }
        };
    }
    // Glass and coats are never Lambert: Kernel::choose picks a model for
    // them. A coated scene's one kernel mixes in glass too, which costs a
    // surface without any one branch: one kernel fewer to compile. A rough
    // diffuse base has a kernel of its own, as general, whose Principled
    // BSDF tests a tag for it (in the coat's, that cost a coated Cornell
    // box 3.7% more instructions).
    match (kernel.bsdf, kernel.glass, kernel.coat) {
        (KernelBsdf::Principled, _, _) if kernel.rough_diffuse => lights!(WithCoat<WithGlass<RoughPrincipledBsdf>>),
        (KernelBsdf::Lambert, _, _) => lights!(LambertBsdf),
        (KernelBsdf::Seed, false, _) => lights!(SeedBsdf),
        (KernelBsdf::Seed, true, _) => lights!(WithGlass<SeedBsdf>),
        (KernelBsdf::Principled, false, false) => lights!(PrincipledBsdf),
        (KernelBsdf::Principled, true, false) => lights!(WithGlass<PrincipledBsdf>),
        (KernelBsdf::Principled, _, true) => lights!(WithCoat<WithGlass<RoughPrincipledBsdf>>),
    }
}

/// Pixel (x, y)'s camera ray for one sample, its image point drawn from
/// the pixel filter, and the filter's density there: the camera's density
/// scales by it (pixel_filter.rs), 1 for the one-pixel box, which a pass
/// tests for once (`unit_box`). Always inlined: out of line, with the
/// filter's tests inside, the gold sphere's 1-spp render took 1.6% more
/// instructions.
#[inline(always)]
fn camera_ray(lens: &Lens, filter: &PixelFilter, unit_box: bool, x: u32, y: u32, rng: &mut Rng) -> (Option<CameraRay>, f32) {
    let pixel = Vec2::new(x as f32, y as f32);
    let u = rng.next_2d();
    let (at, density) = if unit_box { (pixel + u, 1.0) } else { filter.sample_with_density(pixel, u) };
    let aperture = if lens.has_aperture() { rng.next_2d() } else { Vec2::ZERO };
    (lens.ray(at, aperture), density)
}

fn render_pass_with<B: Bsdf, const AREA: bool, const PUNCTUAL: bool, const LAMPS: bool>(
    ctx: &Context,
    settings: &RenderSettings,
    film: &mut Film,
    samples: Range<u32>,
    cancel: &AtomicBool,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<PassStats, Cancelled> {
    let started = Instant::now();
    let (w, h) = (settings.width, settings.height);
    assert_eq!((film.width, film.height), (w, h), "film does not match the settings");
    let prepared = prepare_materials::<B>(ctx.scene);
    let lens = ctx.scene.camera.lens(w, h);
    let sampler = settings.sampler.for_samples(settings.spp);
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE))).collect();
    // Light subpaths (light_paths.rs) where there are emitters to start
    // them and MIS to weigh their connections; traced for a few sample
    // indices at a time, which bounds their memory.
    // With adaptive sampling, their numbers scale with the share of the
    // pixels still sampling: what a stopped pixel would have used is lost
    // (a splat on it, a vertex only it would join), and each sample
    // index's counts are its own (its camera paths' weights count the
    // same n_T and vertices).
    let (still, all) = film.convergence.as_ref().map_or((1, 1), |c| (c.active.iter().filter(|a| **a).count() as u64, c.active.len().max(1) as u64));
    let share = |n: u32, least: u32| ((n as u64 * still).div_ceil(all) as u32).max(least.min(n));
    let per_sample = share((w * h / 16).clamp(256, PER_SAMPLE), 64);
    let connect = (AREA || PUNCTUAL) && ctx.traces_light_paths(settings);
    let chunk = if connect { SAMPLES_PER_LIGHT_TRACE } else { samples.len().max(1) as u32 };
    let mut total = PassStats::default();
    // Light tracing (light_tracing.rs): subpaths per sample index that
    // reach the camera, n_T.
    // Not every camera can be joined to a point (`Lens::joinable`).
    let traced = share(traced_per_sample(w, h), 1);
    let tracing_for = |mis_scale| (connect && settings.light_tracing && lens.joinable()).then_some(LightTracing { lens: &lens, filter: &settings.pixel_filter, width: w, height: h, subpaths: traced as f32, mis_scale, strategies: settings.strategies });
    // Where light subpaths go through glass and mirrors, where camera
    // paths look for what they focus (caustic_guide.rs).
    let make_guide = || {
        let started = Instant::now();
        let (guide, rays) = if connect && settings.caustic_guide && ctx.delta_starts() {
            ctx.caustic_guide::<B>(&prepared, LightVertices::caustic_subpaths(settings.spp), settings.max_depth)
        } else {
            (None, 0)
        };
        (guide, rays, started.elapsed())
    };
    // One batch of each sample index's subpaths; the first holds the
    // vertices connections take (`per_sample` ≤ TRACED_BATCH of them).
    // The subpaths do not read the guide, which their vertices carry to
    // the camera paths.
    let trace_lights = |range: Range<u32>, batch: Range<u32>, mis_scale: f32, guide: Option<&Arc<CausticGuide>>| {
        let started = Instant::now();
        // Photons from the first batch alone, whose vertices are kept.
        let merge = settings.merge && batch.start == 0;
        let traced = LightVertices::for_samples::<B>(ctx, &prepared, tracing_for(mis_scale).as_ref(), settings.seed, range, batch, per_sample, settings.max_depth, mis_scale, guide, merge);
        (traced, started.elapsed())
    };
    // Camera rays' first hits found without the BVH where that is
    // cheaper; a benchmark's ray log wants every ray through the BVH, and
    // surfaces with alpha are decided ray by ray.
    // The materials only where some are hidden from the camera: binning
    // then leaves their triangles out.
    let hiding: &[Material] = if ctx.features.hidden_from_camera > 0 { &ctx.scene.materials } else { &[] };
    let bin_camera_rays = || (ctx.bin_camera_rays && ctx.ray_log.is_none() && ctx.features.alpha == 0).then(|| CameraHits::new(&ctx.accel, &ctx.scene.triangles, hiding, &lens, w, h, TILE, samples.len() as u32, (settings.pixel_filter.radius() - 0.5).max(0.0))).flatten();
    // The pass's sums, added to the film once it is complete. A film
    // without samples holds zeros: its own sums serve, and a cancel zeroes
    // them again (a 1-spp render spent 1% of its time on a second buffer).
    let empty = film.samples == 0;
    let mut pass_sum = if empty { std::mem::take(&mut film.sum) } else { crate::memory::zeroed_vec3s(film.sum.len()) };
    // A transparent film's coverage, beside the sums; nothing otherwise.
    let pixels = (w * h) as usize;
    let mut pass_coverage = if settings.transparent { vec![0.0f32; pixels] } else { Vec::new() };
    // Adaptive sampling: which pixels take this pass's samples, and the
    // sums and counts of those in the first half (adaptive.rs); the film's
    // state comes back to it when the pass is done or cancelled. (A film
    // with samples from settings without it counts them for every pixel:
    // its means stay right, its pixels stop later, the halves of those
    // samples unknown.)
    let convergence = settings.adaptive.map(|_| film.convergence.take().unwrap_or_else(|| Convergence::new(pixels, film.samples)));
    let active = convergence.as_ref().map(|c| &c.active[..]);
    let mut pass_half = if convergence.is_some() { crate::memory::zeroed_vec3s(pixels) } else { Vec::new() };
    let mut pass_in_half = if convergence.is_some() { vec![0u32; pixels] } else { Vec::new() };
    // The bins and the sums' pages mapped, the caustic guide, and the
    // connections' MIS scale and first light subpaths, side by side: each
    // has a serial part (the bins, the guide's aim and grid) that left the
    // other thread idle where it ran alone (a 1-spp render's set-up had
    // run no faster on two threads than on one; the glass sphere's guide,
    // made first, had been 8–10% of its 1-spp render).
    let ((camera_hits, (guide, guide_rays, guide_took)), (mis_scale, mut first_lights)) = rayon::join(
        || {
            rayon::join(
                || {
                    crate::memory::map_for_writing(&mut pass_sum);
                    bin_camera_rays()
                },
                make_guide,
            )
        },
        || {
            if !connect {
                return ((1.0, 0), None);
            }
            let scale = LightVertices::mis_scale::<B>(ctx, &prepared, settings.seed, settings.max_depth);
            let first = samples.start..(samples.start + chunk).min(samples.end);
            let traced = (!first.is_empty()).then(|| trace_lights(first, 0..TRACED_BATCH, scale.0, None));
            (scale, traced)
        },
    );
    if let Some(((vertices, _, _), _)) = first_lights.as_mut() {
        for v in vertices {
            v.guide.clone_from(&guide);
        }
    }
    total.rays.bounce += guide_rays;
    total.caustic_guide = guide.as_ref().map(|g| g.summary());
    let (mis_scale, scale_rays) = mis_scale;
    total.rays.bounce += scale_rays;
    total.camera_tests = camera_hits.as_ref().map_or(0.0, |hits| hits.tests_per_pixel());
    // What the set-up added to the wall clock beside the first subpaths.
    total.phases.setup = started.elapsed().saturating_sub(first_lights.as_ref().map_or(Duration::ZERO, |(_, took)| *took));
    total.phases.caustic_guide = guide_took;
    let shared = PassShared::<B> { ctx, prepared: &prepared, lens: &lens, settings, camera_hits: camera_hits.as_ref(), sampler };
    let mut start = samples.start;
    while start < samples.end {
        let range = start..(start + chunk).min(samples.end);
        start = range.end;
        let light_vertices = if connect {
            let ((vertices, splats, rays), took) = match first_lights.take() {
                Some(first) => first,
                None => trace_lights(range.clone(), 0..TRACED_BATCH, mis_scale, guide.as_ref()),
            };
            let rest_started = Instant::now();
            let mut merge = |splats: Vec<Vec<crate::light_tracing::Splat>>, rays: &RayCounts| {
                total.rays.add(rays);
                // A stopped pixel takes no sample index's light either.
                for (k, splats) in splats.into_iter().enumerate() {
                    let s = (range.start + k as u32) as u64;
                    for splat in splats {
                        let p = splat.pixel as usize;
                        if let Some(active) = active {
                            if !active[p] {
                                continue;
                            }
                            if in_first_half(sampler, settings.seed, p as u64, s) {
                                pass_half[p] += splat.value;
                            }
                        }
                        pass_sum[p] += splat.value;
                    }
                }
            };
            merge(splats, &rays);
            // The rest of n_T, a batch at a time, each merged in order
            // (the image the same however many threads traced it).
            let all = LightVertices::subpaths(tracing_for(mis_scale).as_ref(), per_sample);
            for j0 in (TRACED_BATCH..all).step_by(TRACED_BATCH as usize) {
                // A 4K image's are seconds of work: a cancel ends them
                // (the tiles then find it too, and the pass is dropped).
                if cancel.load(Ordering::Relaxed) {
                    break;
                }
                let ((_, splats, rays), _) = trace_lights(range.clone(), j0..j0 + TRACED_BATCH, mis_scale, guide.as_ref());
                merge(splats, &rays);
            }
            total.phases.light_subpaths += took + rest_started.elapsed();
            for photons in vertices.iter().filter_map(|v| v.photons.as_ref()) {
                total.count_photons((photons.len() as u64, 1, Some(photons.radius)));
            }
            Some(vertices)
        } else {
            None
        };
        let tiles_started = Instant::now();
        // Each tile adds its sums into the pass's rows itself, under its
        // band's lock (a band is a row of tiles, so pixels never share a
        // lock holder): the pages of a fresh film are first touched by both
        // threads, and no serial merge follows the tiles.
        let bands: Vec<Mutex<&mut [Vec3]>> = pass_sum.chunks_mut((w * TILE) as usize).map(Mutex::new).collect();
        let coverage_bands: Vec<Mutex<&mut [f32]>> = pass_coverage.chunks_mut((w * TILE) as usize).map(Mutex::new).collect();
        let half_bands: Vec<Mutex<&mut [Vec3]>> = pass_half.chunks_mut((w * TILE) as usize).map(Mutex::new).collect();
        let in_half_bands: Vec<Mutex<&mut [u32]>> = pass_in_half.chunks_mut((w * TILE) as usize).map(Mutex::new).collect();
        let results: Vec<Option<PassStats>> = tiles
            .par_iter()
            .map_init(|| (TileRays::new(TILE), Vec::with_capacity((TILE * TILE) as usize)), |(rays, rngs), &(x0, y0)| {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let mut stats = PassStats::default();
                let tw = (x1 - x0) as usize;
                let band = (y0 / TILE) as usize;
                // Adaptive sampling's tiles go their own way, which leaves
                // this loop as it was (the bookkeeping in it had cost a
                // render without a threshold 2.9% more instructions on the
                // 1-spp gold sphere, profile-guided).
                if let Some(active) = active {
                    let into = TileSums { sum: &bands[band], coverage: coverage_bands.get(band), half: &half_bands[band], in_half: &in_half_bands[band] };
                    let sampling = adaptive_tile::<B, AREA, PUNCTUAL, LAMPS>(&shared, light_vertices.as_deref(), range.clone(), active, (x0, y0, x1, y1), rays, into, &mut stats);
                    progress(sampling as u64 * range.len() as u64);
                    return Some(stats);
                }
                let mut sums = [Vec3::ZERO; (TILE * TILE) as usize];
                let mut covered = [0.0f32; (TILE * TILE) as usize];
                // Sample index by sample index over the tile: the light
                // vertices a sample index's connections pick from at random
                // (light_paths.rs) stay in cache for the whole tile, where
                // going through a pixel's samples first had every pick read
                // from a different sample index's set. Each pixel's sum
                // adds its samples in the same order either way.
                let tile_pixels = (tw as u32 * (y1 - y0)) as usize;
                let unit_box = settings.pixel_filter.is_unit_box();
                for s in range.clone() {
                    let vertices = light_vertices.as_ref().map(|v| &v[(s - range.start) as usize]);
                    // The tile's camera rays first: their numbers are
                    // chains of hashes and multiplies (rng.rs), which run
                    // side by side here; then their first hits, together
                    // where camera_hits.rs finds them.
                    rngs.clear();
                    for i in 0..tile_pixels as u32 {
                        let (x, y) = (x0 + i % tw as u32, y0 + i / tw as u32);
                        let mut rng = Rng::for_pixel_sample(sampler, settings.seed, y as u64 * w as u64 + x as u64, s as u64);
                        let (ray, filtered) = camera_ray(&lens, &settings.pixel_filter, unit_box, x, y, &mut rng);
                        rays.set(i as usize, ray.map_or(Vec3::ZERO, |r| r.dir));
                        rngs.push((rng, ray, filtered));
                    }
                    if let Some(hits) = &camera_hits {
                        if s == range.start {
                            hits.face(x0, y0, tw as u32, y1 - y0, rays);
                        }
                        hits.nearest(tw as u32, y1 - y0, rays);
                    }
                    for (i, ((sum, covered), (rng, ray, filtered))) in sums[..tile_pixels].iter_mut().zip(covered.iter_mut()).zip(rngs.iter_mut()).enumerate() {
                        let (l, coverage) = match ray {
                            Some(ray) => {
                                let first = camera_hits.as_ref().map_or(FirstHit::Trace, |_| rays.first(i));
                                radiance::<B, AREA, PUNCTUAL, LAMPS>(ctx, &prepared, vertices, ray, lens.density(ray.dir).scaled(*filtered), settings, rng, &mut stats.rays, first)
                            }
                            // Outside a fisheye's circle: black and opaque,
                            // as Cycles leaves it.
                            None => (Vec3::ZERO, 1.0),
                        };
                        if sample_fits(l) {
                            *sum += l;
                        } else {
                            stats.discarded += 1;
                        }
                        *covered += coverage;
                    }
                }
                add_tile(&bands[band], &sums[..tile_pixels], tw, x0, w);
                if let Some(band) = coverage_bands.get(band) {
                    add_tile(band, &covered[..tile_pixels], tw, x0, w);
                }
                progress(tw as u64 * (y1 - y0) as u64 * range.len() as u64);
                Some(stats)
            })
            .collect();
        total.phases.camera_paths += tiles_started.elapsed();
        drop(bands);
        drop(coverage_bands);
        drop(half_bands);
        drop(in_half_bands);
        if cancel.load(Ordering::Relaxed) || results.iter().any(Option::is_none) {
            if empty {
                pass_sum.fill(Vec3::ZERO);
                film.sum = pass_sum;
            }
            film.convergence = convergence;
            return Err(Cancelled);
        }
        for stats in results.into_iter().flatten() {
            total.add(&stats);
        }
    }
    // An empty film's sums were taken as the pass's own (empty) and come
    // back whole; so does a first pass's coverage.
    add_pass(&mut film.sum, pass_sum);
    add_pass(&mut film.coverage, pass_coverage);
    if let Some(mut c) = convergence {
        add_pass(&mut c.half, pass_half);
        add_pass(&mut c.in_half, pass_in_half);
        for (count, _) in c.counts.iter_mut().zip(&c.active).filter(|(_, a)| **a) {
            *count += samples.len() as u32;
        }
        film.convergence = Some(c);
    }
    film.samples += samples.len() as u32;
    Ok(total)
}

/// What every tile of a pass shares, for `adaptive_tile`.
struct PassShared<'a, B: Bsdf> {
    ctx: &'a Context<'a>,
    prepared: &'a [Option<[B::Prepared; 2]>],
    lens: &'a Lens<'a>,
    settings: &'a RenderSettings,
    camera_hits: Option<&'a CameraHits<'a>>,
    sampler: Sampler,
}

/// Where a tile adds its sums: its band of each of the pass's buffers.
struct TileSums<'b, 'a> {
    sum: &'b Mutex<&'a mut [Vec3]>,
    coverage: Option<&'b Mutex<&'a mut [f32]>>,
    half: &'b Mutex<&'a mut [Vec3]>,
    in_half: &'b Mutex<&'a mut [u32]>,
}

/// A tile's samples `range` (x0, y0 to x1, y1, exclusive) under adaptive
/// sampling: only of its pixels still `active`, each sample added to its
/// half's sums too (adaptive.rs). Otherwise the tile loop's work. A tile
/// with fewer than half its pixels still sampling traces its camera rays
/// through the BVH: binning costs per pixel of the tile, sampled or not.
/// Returns the pixels it sampled.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn adaptive_tile<B: Bsdf, const AREA: bool, const PUNCTUAL: bool, const LAMPS: bool>(
    shared: &PassShared<B>,
    light_vertices: Option<&[LightVertices]>,
    range: Range<u32>,
    active: &[bool],
    (x0, y0, x1, y1): (u32, u32, u32, u32),
    rays: &mut TileRays,
    into: TileSums,
    stats: &mut PassStats,
) -> usize {
    let PassShared { ctx, prepared, lens, settings, camera_hits, sampler } = *shared;
    let w = settings.width;
    let tw = (x1 - x0) as usize;
    let tile_pixels = tw * (y1 - y0) as usize;
    let pixel = |i: usize| (y0 as usize + i / tw) * w as usize + x0 as usize + i % tw;
    let sampled: Vec<usize> = (0..tile_pixels).filter(|&i| active[pixel(i)]).collect();
    if sampled.is_empty() {
        return 0;
    }
    let (mut sums, mut covered) = (vec![Vec3::ZERO; tile_pixels], vec![0.0f32; tile_pixels]);
    let (mut halves, mut in_half) = (vec![Vec3::ZERO; tile_pixels], vec![0u32; tile_pixels]);
    let binned = camera_hits.filter(|_| sampled.len() * 2 >= tile_pixels);
    let mut rngs = Vec::with_capacity(sampled.len());
    let unit_box = settings.pixel_filter.is_unit_box();
    for s in range.clone() {
        let vertices = light_vertices.map(|v| &v[(s - range.start) as usize]);
        rngs.clear();
        for &i in &sampled {
            let p = pixel(i) as u64;
            let (x, y) = (x0 + (i % tw) as u32, y0 + (i / tw) as u32);
            let mut rng = Rng::for_pixel_sample(sampler, settings.seed, p, s as u64);
            let (ray, filtered) = camera_ray(lens, &settings.pixel_filter, unit_box, x, y, &mut rng);
            rays.set(i, ray.map_or(Vec3::ZERO, |r| r.dir));
            rngs.push((i, rng, ray, filtered, in_first_half(sampler, settings.seed, p, s as u64)));
        }
        if let Some(hits) = binned {
            if s == range.start {
                hits.face(x0, y0, tw as u32, y1 - y0, rays);
            }
            hits.nearest(tw as u32, y1 - y0, rays);
        }
        for (i, rng, ray, filtered, first) in rngs.iter_mut() {
            let i = *i;
            let (l, coverage) = match ray {
                Some(ray) => {
                    let first_hit = binned.map_or(FirstHit::Trace, |_| rays.first(i));
                    radiance::<B, AREA, PUNCTUAL, LAMPS>(ctx, prepared, vertices, ray, lens.density(ray.dir).scaled(*filtered), settings, rng, &mut stats.rays, first_hit)
                }
                None => (Vec3::ZERO, 1.0),
            };
            if *first {
                in_half[i] += 1;
            }
            if sample_fits(l) {
                sums[i] += l;
                if *first {
                    halves[i] += l;
                }
            } else {
                stats.discarded += 1;
            }
            covered[i] += coverage;
        }
    }
    add_tile(into.sum, &sums, tw, x0, w);
    if let Some(band) = into.coverage {
        add_tile(band, &covered, tw, x0, w);
    }
    add_tile(into.half, &halves, tw, x0, w);
    add_tile(into.in_half, &in_half, tw, x0, w);
    sampled.len()
}

/// Add a tile's per-pixel sums (rows of `tw`, its left edge at `x0`) into
/// its band of an image `w` wide, under the band's lock.
fn add_tile<T: Copy + std::ops::AddAssign>(band: &Mutex<&mut [T]>, tile: &[T], tw: usize, x0: u32, w: u32) {
    let mut band = band.lock().unwrap_or_else(|e| e.into_inner());
    for (row, tile_row) in tile.chunks_exact(tw).enumerate() {
        let start = row * w as usize + x0 as usize;
        for (p, s) in band[start..start + tw].iter_mut().zip(tile_row) {
            *p += *s;
        }
    }
}

/// Add a pass's per-pixel sums into the film's, or make them the film's
/// where it has none.
fn add_pass<T: Copy + std::ops::AddAssign>(film: &mut Vec<T>, pass: Vec<T>) {
    if film.is_empty() {
        *film = pass;
    } else {
        for (f, p) in film.iter_mut().zip(&pass) {
            *f += *p;
        }
    }
}
