//! What ray traversal costs inside a render, against obvhs on its own
//! (`glint render --traversal`). A one-sample pass is rendered with its
//! rays recorded; they are then traced again on one thread, by kind,
//! through Glint's queries (accel.rs: its own triangle test, the fixes for
//! obvhs' pitfalls, the emitter skip of shadow rays) and through obvhs
//! queried as its examples do. The render's own rays per kind, at those
//! rates, give the share of its time spent in traversal.
//!
//! Only surface queries are recorded: the separate lamp BVH of Blender
//! area lights, when a scene has one, is left out.

use crate::integrator::{Context, RayCounts};
use crate::Vec3;
use std::hint::black_box;
use std::sync::Mutex;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    Camera,
    Bounce,
    Shadow,
}

pub const KINDS: [RayKind; 3] = [RayKind::Camera, RayKind::Bounce, RayKind::Shadow];

/// One surface query as the integrator made it.
#[derive(Clone, Copy, Debug)]
pub struct TracedRay {
    pub kind: RayKind,
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmax: f32,
    /// The triangle a shadow ray ignores (its emitter), or u32::MAX.
    pub skip: u32,
}

/// The rays of a render, when it is asked to keep them (a benchmark, never
/// a user's render: a lock per ray).
#[derive(Default)]
pub struct RayLog(Mutex<Vec<TracedRay>>);

impl RayLog {
    pub fn push(&self, ray: TracedRay) {
        if let Ok(mut rays) = self.0.lock() {
            rays.push(ray);
        }
    }

    pub fn take(&self) -> Vec<TracedRay> {
        self.0.lock().map(|mut rays| std::mem::take(&mut *rays)).unwrap_or_default()
    }
}

/// Replay timings of one kind of ray.
#[derive(Clone, Copy, Debug, Default)]
pub struct KindRates {
    pub rays: usize,
    /// Million rays per second on one thread.
    pub glint: f64,
    pub obvhs: f64,
    /// Rays on which both found the same thing (a hit within 1e-3 relative
    /// of the same distance, or none): obvhs alone loses hits closer than
    /// 1e-4 and rays with a −0.0 direction component.
    pub agree: usize,
}

/// Trace `rays` again through both, each kind timed on its own; the best of
/// `repeats` runs.
pub fn replay(ctx: &Context, rays: &[TracedRay], repeats: usize) -> Vec<(RayKind, KindRates)> {
    let Some(alone) = ctx.accel.obvhs_alone(&ctx.scene.triangles) else { return Vec::new() };
    KINDS
        .iter()
        .map(|&kind| {
            let of_kind: Vec<TracedRay> = rays.iter().filter(|r| r.kind == kind).copied().collect();
            let glint_t = |r: &TracedRay| -> Option<f32> {
                if r.kind == RayKind::Shadow {
                    ctx.accel.occluded_except(r.origin, r.dir, r.tmax, r.skip).then_some(0.0)
                } else {
                    ctx.accel.intersect(r.origin, r.dir, r.tmax).map(|h| h.t)
                }
            };
            let obvhs_t = |r: &TracedRay| -> Option<f32> {
                if r.kind == RayKind::Shadow {
                    alone.blocked(r.origin, r.dir, r.tmax).then_some(0.0)
                } else {
                    alone.closest(r.origin, r.dir, r.tmax)
                }
            };
            let best = |f: &dyn Fn(&TracedRay) -> Option<f32>| {
                (0..repeats.max(1))
                    .map(|_| {
                        let start = Instant::now();
                        for r in &of_kind {
                            black_box(f(black_box(r)));
                        }
                        start.elapsed().as_secs_f64()
                    })
                    .fold(f64::INFINITY, f64::min)
            };
            let rate = |seconds: f64| if seconds > 0.0 { of_kind.len() as f64 / seconds / 1e6 } else { 0.0 };
            let agree = of_kind
                .iter()
                .filter(|r| match (glint_t(r), obvhs_t(r)) {
                    (Some(a), Some(b)) => (a - b).abs() <= 1e-3 * a.abs().max(b.abs()).max(1e-3),
                    (None, None) => true,
                    _ => false,
                })
                .count();
            let (glint, obvhs) = (rate(best(&glint_t)), rate(best(&obvhs_t)));
            (kind, KindRates { rays: of_kind.len(), glint, obvhs, agree })
        })
        .collect()
}

/// The share of a render's thread time spent in traversal: its rays of
/// each kind at the replayed one-thread rates, over `seconds` × `threads`.
pub fn traversal_share(rates: &[(RayKind, KindRates)], counts: &RayCounts, seconds: f64, threads: usize) -> f64 {
    let traced = |kind: RayKind| match kind {
        RayKind::Camera => counts.camera,
        RayKind::Bounce => counts.bounce,
        RayKind::Shadow => counts.shadow,
    };
    let traversal: f64 = rates.iter().filter(|(_, r)| r.glint > 0.0).map(|&(kind, r)| traced(kind) as f64 / (r.glint * 1e6)).sum();
    traversal / (seconds * threads as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{render_pass, Film, LightPaths, RenderSettings};
    use std::sync::atomic::AtomicBool;

    /// The log holds what the render traced, kind by kind, and both
    /// traversals find the same hits on the Cornell box's rays.
    #[test]
    fn a_recorded_pass_replays_through_both_traversals() {
        let scene = crate::loader::load_bytes(crate::DEFAULT_SCENE.as_bytes(), None, "cornell", &crate::loader::LoadOptions::default()).unwrap();
        let (mut ctx, _) = Context::new(&scene);
        ctx.ray_log = Some(RayLog::default());
        let settings = RenderSettings { width: 16, height: 16, spp: 2, max_depth: 8, seed: 1, mis: true, bsdf: Default::default(), features: Default::default(), sampler: Default::default(), light_paths: LightPaths::On, light_tracing: true, caustic_guide: true, merge: true, strategies: Default::default(), transparent: false, transparent_glass: None, adaptive: None, pixel_filter: Default::default() };
        let mut film = Film::new(16, 16);
        let stats = render_pass(&ctx, &settings, &mut film, 0..2, &AtomicBool::new(false), &|_| {}).unwrap();
        let rays = ctx.ray_log.as_ref().unwrap().take();
        let count = |kind| rays.iter().filter(|r| r.kind == kind).count() as u64;
        assert_eq!((count(RayKind::Camera), count(RayKind::Bounce), count(RayKind::Shadow)), (stats.rays.camera, stats.rays.bounce, stats.rays.shadow));
        for (kind, r) in replay(&ctx, &rays, 1) {
            assert!(r.rays > 0 && r.glint > 0.0 && r.obvhs > 0.0, "{kind:?}: {r:?}");
            assert!(r.agree as f64 >= 0.99 * r.rays as f64, "{kind:?}: {} of {} agree", r.agree, r.rays);
        }
        let share = traversal_share(&replay(&ctx, &rays, 1), &stats.rays, 1.0, 1);
        assert!(share > 0.0 && share.is_finite());
    }
}
