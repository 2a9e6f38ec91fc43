//! Progressive rendering: samples are added in passes that grow while they
//! stay short, so a client sees a first image at once, an update at a steady
//! cadence, and a cancel takes effect within a fraction of a second.

use crate::integrator::Context;
use crate::render::{render_pass, Cancelled, Film, PassStats, RenderSettings};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// A pass is sized to take about this long (measured on the passes so far).
const PASS_TARGET: Duration = Duration::from_millis(500);

pub struct Budget {
    /// Samples per pixel to reach; 0: no limit (then `time` must be set).
    pub samples: u32,
    /// Rendering time after which no further pass starts.
    pub time: Option<Duration>,
    /// Passes sized by their time, for a client that shows each image or a
    /// time limit; else as few as the budget and adaptive sampling's checks
    /// allow, so that the image depends on the settings alone.
    pub paced: bool,
}

/// Where a progressive render is: handed to the caller after every pass.
pub struct Progress<'f> {
    pub film: &'f Film,
    pub elapsed: Duration,
    pub stats: &'f PassStats,
    pub finished: bool,
}

/// Render into `film` until the budget is spent; `after_pass` sees the film
/// after each pass (the last one with `finished` set); `progress` counts
/// pixel samples as tiles finish. A cancel returns
/// `Cancelled` with the film holding the passes completed before it.
pub fn render_progressive(
    ctx: &Context,
    settings: &RenderSettings,
    budget: &Budget,
    film: &mut Film,
    cancel: &AtomicBool,
    progress: &(dyn Fn(u64) + Sync),
    after_pass: &mut dyn FnMut(Progress),
) -> Result<PassStats, Cancelled> {
    let start = Instant::now();
    let mut total = PassStats::default();
    let target = if budget.samples == 0 { u32::MAX } else { budget.samples };
    let mut done = 0u32;
    while done < target {
        let elapsed = start.elapsed();
        let per_sample = if done > 0 { elapsed.as_secs_f64() / done as f64 } else { 0.0 };
        // Double while a pass stays under the target time; never past the
        // budget or the time left.
        let mut pass = if budget.paced { done.max(1) } else { target - done };
        if budget.paced && per_sample > 0.0 {
            pass = pass.min(((PASS_TARGET.as_secs_f64() / per_sample) as u32).max(1));
            if let Some(limit) = budget.time {
                let left = limit.saturating_sub(elapsed).as_secs_f64();
                pass = pass.min(((left / per_sample) as u32).max(1));
            }
        }
        // Adaptive sampling checks the pixels at fixed sample counts
        // (adaptive.rs), where a pass ends.
        if let Some(adaptive) = &settings.adaptive {
            pass = pass.min(adaptive.next_check(done) - done);
        }
        // At least one sample: a pass of none would loop for ever.
        pass = pass.min(target - done).max(1);
        let stats = render_pass(ctx, settings, film, done..done + pass, cancel, progress)?;
        total.add(&stats);
        done += pass;
        let mut converged = false;
        if let (Some(adaptive), Some(convergence)) = (&settings.adaptive, film.convergence.as_mut()) {
            if adaptive.checks_at(done) {
                converged = convergence.check(&film.sum, film.width, film.height, adaptive.threshold) == 0;
            }
        }
        let elapsed = start.elapsed();
        let out_of_time = budget.time.is_some_and(|t| elapsed >= t);
        let finished = done >= target || out_of_time || converged;
        after_pass(Progress { film, elapsed, stats: &total, finished });
        if finished {
            break;
        }
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loader::{load_bytes, LoadOptions};
    use crate::render::LightPaths;
    use std::sync::atomic::Ordering;

    fn cornell() -> crate::scene::Scene {
        load_bytes(crate::DEFAULT_SCENE.as_bytes(), None, "cornell", &LoadOptions::default()).unwrap()
    }

    fn settings(spp: u32) -> RenderSettings {
        RenderSettings { width: 24, height: 24, spp, max_depth: 4, seed: 3, mis: true, bsdf: Default::default(), features: Default::default(), sampler: Default::default(), light_paths: LightPaths::On, light_tracing: true, caustic_guide: true, merge: true, strategies: Default::default(), transparent: false, transparent_glass: None, adaptive: None, pixel_filter: Default::default() }
    }

    #[test]
    fn passes_add_up_to_the_single_pass_image() {
        let scene = cornell();
        let (ctx, _) = Context::new(&scene);
        let mut passes = Vec::new();
        let mut film = Film::new(24, 24);
        let budget = Budget { samples: 13, time: None, paced: true };
        render_progressive(&ctx, &settings(13), &budget, &mut film, &AtomicBool::new(false), &|_| {}, &mut |p| passes.push((p.film.samples, p.finished)))
            .unwrap();
        assert_eq!(passes.last(), Some(&(13, true)));
        assert!(passes.len() >= 3 && passes[..passes.len() - 1].iter().all(|p| !p.1), "{passes:?}");
        let mut one = Film::new(24, 24);
        render_pass(&ctx, &settings(13), &mut one, 0..13, &AtomicBool::new(false), &|_| {}).unwrap();
        // Per-pixel seeding: the same samples whatever the split.
        let diff = film.mean().iter().zip(one.mean()).map(|(a, b)| (*a - b).abs().max_element()).fold(0.0f32, f32::max);
        assert!(diff < 1e-5, "{diff}");
    }

    #[test]
    fn a_time_budget_stops_and_a_cancel_keeps_the_completed_passes() {
        let scene = cornell();
        let (ctx, _) = Context::new(&scene);
        let mut film = Film::new(24, 24);
        let budget = Budget { samples: 0, time: Some(Duration::from_millis(200)), paced: true };
        let start = Instant::now();
        render_progressive(&ctx, &settings(0), &budget, &mut film, &AtomicBool::new(false), &|_| {}, &mut |_| {}).unwrap();
        assert!(film.samples > 1);
        assert!(start.elapsed() < Duration::from_secs(5), "{:?}", start.elapsed());

        let cancel = AtomicBool::new(false);
        let mut film = Film::new(24, 24);
        let budget = Budget { samples: 1000, time: None, paced: true };
        let r = render_progressive(&ctx, &settings(1000), &budget, &mut film, &cancel, &|_| {}, &mut |p| {
            if p.film.samples >= 2 {
                cancel.store(true, Ordering::Relaxed);
            }
        });
        assert!(r.is_err());
        assert!(film.samples >= 2 && film.samples < 1000, "{}", film.samples);
    }

    /// Over several groups of light subpaths (four sample indices each),
    /// the first traced beside the set-up: no phase is counted twice.
    #[test]
    fn a_pass_accounts_for_its_time_phase_by_phase() {
        let scene = cornell();
        let (ctx, _) = Context::new(&scene);
        for light_paths in [LightPaths::On, LightPaths::Off] {
            let settings = RenderSettings { light_paths, ..settings(12) };
            let mut film = Film::new(24, 24);
            let start = Instant::now();
            let stats = render_pass(&ctx, &settings, &mut film, 0..12, &AtomicBool::new(false), &|_| {}).unwrap();
            let wall = start.elapsed();
            let p = stats.phases;
            assert!(p.camera_paths > Duration::ZERO && p.setup + p.light_subpaths + p.camera_paths <= wall, "{p:?} of {wall:?}");
            assert_eq!(p.light_subpaths > Duration::ZERO, light_paths == LightPaths::On, "{p:?}");
        }
    }

    /// The daemon's paced passes end at adaptive sampling's checks too:
    /// its render stops the same pixels at the same counts as `glint
    /// render`'s passes from check to check, the image the same but for
    /// the rounding of sums split otherwise.
    #[test]
    fn paced_passes_end_at_the_adaptive_checks() {
        let scene = cornell();
        let (ctx, _) = Context::new(&scene);
        let settings = RenderSettings { adaptive: Some(crate::adaptive::Adaptive { threshold: 0.05, min_samples: 16 }), ..settings(200) };
        let film_of = |paced| {
            let mut film = Film::new(24, 24);
            let mut passes = Vec::new();
            let budget = Budget { samples: 200, time: None, paced };
            render_progressive(&ctx, &settings, &budget, &mut film, &AtomicBool::new(false), &|_| {}, &mut |p| passes.push(p.film.samples)).unwrap();
            (film, passes)
        };
        let ((paced, passes), (fixed, checks)) = (film_of(true), film_of(false));
        assert!(checks.iter().all(|n| n % 16 == 0 || *n == 200), "{checks:?}");
        assert!(checks.iter().all(|n| passes.contains(n)), "{passes:?} skipped a check of {checks:?}");
        assert!(passes.len() > checks.len(), "{passes:?}");
        let (a, b) = (paced.convergence.as_ref().unwrap(), fixed.convergence.as_ref().unwrap());
        assert_eq!(a.counts, b.counts);
        assert!(a.counts.iter().any(|&n| n < 200), "no pixel stopped: {:?}", a.counts);
        for (p, f) in paced.mean().iter().zip(fixed.mean()) {
            assert!((*p - f).abs().max_element() <= 1e-5 * f.max_element().max(1.0), "{p} vs {f}");
        }
    }

    /// A Noise Threshold so small (or Min Samples so many) that the first
    /// check lies past u32's last multiple of 16: the budget's samples
    /// still end the render, paced or not (the check's count had wrapped
    /// to 0, and passes of no samples looped for ever).
    #[test]
    fn a_first_check_beyond_every_count_still_ends_at_the_budget() {
        let scene = cornell();
        let (ctx, _) = Context::new(&scene);
        for adaptive in [crate::adaptive::Adaptive { threshold: 1e-30, min_samples: 0 }, crate::adaptive::Adaptive { threshold: 0.01, min_samples: u32::MAX }] {
            for paced in [true, false] {
                let mut film = Film::new(24, 24);
                let budget = Budget { samples: 3, time: None, paced };
                let settings = RenderSettings { adaptive: Some(adaptive), ..settings(3) };
                render_progressive(&ctx, &settings, &budget, &mut film, &AtomicBool::new(false), &|_| {}, &mut |_| {}).unwrap();
                assert_eq!(film.samples, 3, "{adaptive:?}, paced {paced}");
            }
        }
    }
}
