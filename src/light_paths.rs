//! Light vertices: the surface points y1, y2, … of short light subpaths
//! (an emitter point y0, a cosine-weighted ray from it — or a point
//! light's start, `PointEmission` —, then BSDF samples with Russian
//! roulette), which a camera path's vertex z (its first that
//! is not a glossy metal or glass) connects to with shadow rays. These are
//! bidirectional path tracing's s ≥ 2 strategies for z's t, and they reach light a surface sends on from
//! where only the emitter sees it: the ceiling above a lamp that hangs
//! just below it, whose light leaves the slit between the two only after
//! bounces inside it, or the patch of a floor a sphere reflects a lamp
//! onto. Camera paths find such light only by chance; light subpaths
//! carry it out of the slit and land in proportion to the light.
//!
//! A connection's estimate, with the camera side's throughput β at z:
//!
//!   β · f_z · |cos_z| · |cos_yk|/d² · f_yk · (|ns·wi| / |ng·wi|)_yk · α_k
//!
//! where α_1 = Le·π / p_y0 (Le·|cos_y0| over the density p_y0 of the start
//! and p_ω = |cos_y0|/π of its direction) and each bounce at y_j multiplies
//! α by f(wo → y_{j+1}, wi → y_{j−1}) · |ns·wi| · |ng·wo| / (|ng·wi| · p),
//! f as a camera path through y_j would evaluate it: the ratios of
//! cosines keep the camera side's measure with shading normals.
//!
//! MIS. A path x0 (camera) z=x1 … xn (on an emitter; with z deeper the
//! indices shift, and the vertices before z take no part) can be made by four
//! kinds of strategy: a BSDF sample that hits the emitter (s = 0), light
//! sampling at x_{n−1} (s = 1), and the connection of z to the light
//! vertex x2 = y_{n−2} (s = n − 1). Camera vertices deeper than z do not
//! connect, so the power heuristic has three terms. The ratio of the
//! densities of strategies s − 1 and s is that of generating one vertex
//! from the camera side rather than from the light side, both per unit
//! area there, and the weights are products of such ratios:
//! * a light vertex carries the ones its subpath knows (`prefix`,
//!   `to_unidirectional`, `back`, `generated`), the connection adds the two
//!   that depend on z;
//! * a camera path carries the same product towards the light
//!   (integrator.rs, `Chain`), which needs the reverse BSDF pdf at each
//!   vertex after z.
//!
//! Glass and delta lobes end a subpath and a camera path's chain alike:
//! the strategies through them stay the camera path's alone — except the
//! delta lobes a subpath meets before any other sample (`DeltaStart`):
//! it goes on through them (absorbed by the media they let it into,
//! storing no vertex inside one), so that light a glass sphere focuses onto the
//! floor lands there in proportion to it, and a camera path's BSDF sample
//! through the same lobes to the light weighs itself against that
//! (integrator.rs, `Through`). A camera
//! vertex makes `CONNECTIONS` connections, each to one vertex drawn from
//! all of a sample index's, so each stands for 1/M of bidirectional path
//! tracing's connections (M the mean vertices per subpath) and together
//! for `CONNECTIONS`/M of them; the weights scale the connection's
//! density by that on both sides (`mis_scale`, a constant per render from
//! subpaths of their own, so that the weights do not depend
//! on the vertices they weigh).
//!
//! Subpaths are drawn per sample index, `PER_SAMPLE` of them, each pixel
//! sample taking `CONNECTIONS` vertices: for one pixel sample those are
//! independent draws, so each pixel's noise is what a subpath of its own would give,
//! for a fraction of the rays.

use crate::bsdf::Bsdf;
use crate::caustic_guide::{Aim, Arrival, CausticGuide};
use crate::light_tracing::{LightTracing, Splat};
use crate::photons::Photons;
use std::sync::Arc;
use crate::lights::{EmissionSample, PointEmission, Start};
use crate::integrator::{bsdf_at, bsdf_on, connects_from, surface_facing, RayCounts, same_side, shading_normal_for, Context, SurfaceHit, CONNECTIONS, RR_MAX_SURVIVAL};
use crate::scene::Scene;
use crate::shading::Barycentric;
use crate::material::Surface;
use crate::media::{transmittance, Media};
use crate::rng::Rng;
use crate::sampling::Frame;
use crate::traversal_bench::RayKind;
use crate::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::ops::Range;

/// A light subpath's surface point y_k.
#[derive(Clone)]
pub struct LightVertex {
    /// y_k as its ray met it: `ng` faces y_{k−1}.
    pub hit: SurfaceHit,
    /// The interpolated shading normal on `ng`'s side (zero where none):
    /// the frame is made once the viewer z is known.
    pub ns: Vec3,
    /// Unit direction from y_k back to y_{k−1}.
    pub to_prev: Vec3,
    /// The subpath's throughput up to y_k, Russian roulette included.
    pub alpha: Vec3,
    /// k, its scattering events from the emitter.
    pub depth: u32,
    /// The density per unit area with which the subpath made y_k; for y1
    /// that of the emitter, p_y0·|cos_y1|/(π·p_light), as light sampling
    /// at y1 divides by p_light.
    pub generated: f32,
    /// Times the camera-side pdf at y_k toward y_{k−1} (solid angle), the
    /// ratio of the densities of making y_{k−1} from y_k and from y_{k−2}.
    pub back: f32,
    /// The ratios the subpath knows between light sampling at y1 and the
    /// connection at y_{k−1} (k ≥ 3; 1 below).
    pub prefix: f32,
    /// A BSDF sample at y1 hitting y0 against light sampling there
    /// (k ≥ 2; for y1 it depends on z).
    pub to_unidirectional: f32,
    /// y_k is its subpath's y1: the first vertex stored, from y0 straight
    /// or through delta lobes only (`DeltaStart`).
    pub first: bool,
    /// Light sampling at y1 is one of the strategies: not where y1's light
    /// came through delta lobes, which shadow rays do not follow.
    pub sampled: bool,
}

/// What a connection (integrator.rs) reads of a light vertex, kept in
/// 128 bytes where a `LightVertex` takes 256: a camera path's connections
/// pick among a sample index's thousands of vertices at random, and at
/// 256 bytes each they had not stayed in cache. Positions and directions
/// that are read in every connection stay SIMD vectors; the error bound
/// and the shading normal are read once and kept in 12 bytes. The surface
/// itself is kept only as its material, face and barycentrics: a material
/// whose BSDF is prepared needs no more, and a textured one is looked up
/// again (`bsdf`).
#[derive(Clone, Copy, Debug)]
pub struct ConnectionVertex {
    pub p: Vec3,
    /// Geometric normal, facing y_{k−1}.
    pub ng: Vec3,
    pub to_prev: Vec3,
    pub alpha: Vec3,
    p_error: glam::Vec3,
    ns: glam::Vec3,
    pub triangle: u32,
    material: u32,
    b: [f32; 2],
    pub generated: f32,
    pub back: f32,
    pub prefix: f32,
    pub to_unidirectional: f32,
    pub depth: u32,
    front_face: bool,
    pub first: bool,
    pub sampled: bool,
}

impl ConnectionVertex {
    fn of(v: &LightVertex) -> Self {
        let y = &v.hit;
        ConnectionVertex {
            p: y.p,
            ng: y.ng,
            to_prev: v.to_prev,
            alpha: v.alpha,
            p_error: y.p_error.into(),
            ns: v.ns.into(),
            triangle: y.triangle,
            material: y.material,
            b: [y.b.0[1], y.b.0[2]],
            generated: v.generated,
            back: v.back,
            prefix: v.prefix,
            to_unidirectional: v.to_unidirectional,
            depth: v.depth,
            front_face: y.front_face,
            first: v.first,
            sampled: v.sampled,
        }
    }

    /// A vertex at `p` and nothing more, for tests of what sorts them.
    #[cfg(test)]
    pub(crate) fn at(p: Vec3) -> Self {
        ConnectionVertex { p, ng: Vec3::Y, to_prev: Vec3::Y, alpha: Vec3::ONE, p_error: glam::Vec3::ZERO, ns: glam::Vec3::ZERO, triangle: 0, material: 0, b: [0.0; 2], generated: 1.0, back: 1.0, prefix: 1.0, to_unidirectional: 0.0, depth: 1, front_face: true, first: true, sampled: false }
    }

    pub fn p_error(&self) -> Vec3 {
        self.p_error.into()
    }

    /// The interpolated shading normal on `ng`'s side (zero where none).
    pub fn ns(&self) -> Vec3 {
        self.ns.into()
    }

    /// The BSDF here for outgoing direction `wo` (local), as `bsdf_at`
    /// gives it at the hit the vertex was made from.
    #[inline]
    pub fn bsdf<B: Bsdf>(&self, scene: &Scene, prepared: &[Option<[B::Prepared; 2]>], frame: &Frame, wo: Vec3) -> B {
        bsdf_on::<B>(prepared, self.material, self.front_face, || surface_facing(scene, self.material, self.triangle, Barycentric::new(self.b[0], self.b[1]), self.front_face), frame, wo)
    }
}

/// The light vertices of one sample index.
pub struct LightVertices {
    vertices: Vec<ConnectionVertex>,
    /// Subpaths traced, counting those that made no vertex (a pick of a
    /// punctual light, a ray that left the scene).
    traced: u32,
    /// M over the connections a camera path makes: what the weights divide
    /// the connection's density by.
    pub mis_scale: f32,
    /// The deepest light vertex: the path a connection to it makes has
    /// depth + 1 scattering events, which `max_depth` must allow.
    pub max_vertex_depth: u32,
    /// n_T, the subpaths per sample index that reach the camera
    /// (light_tracing.rs), which the camera side's weights count; 0 without.
    pub tracing: f32,
    /// Where camera paths look for caustics (caustic_guide.rs); None but in
    /// scenes whose subpaths go through glass and mirrors.
    pub guide: Option<Arc<CausticGuide>>,
    /// Where this sample index's subpaths landed beyond delta lobes alone,
    /// for camera vertices to merge with (photons.rs); None where none
    /// did, or merging is off.
    pub photons: Option<Photons>,
}

/// What one task of `for_samples` traced: its vertices, its photons
/// (photons.rs), its splats and its rays.
type TaskTraced = (Vec<ConnectionVertex>, Vec<ConnectionVertex>, Vec<Splat>, RayCounts);

/// Light subpaths per sample index at most; fewer on small images, which
/// have fewer camera vertices to share them.
pub const PER_SAMPLE: u32 = 1024;
/// Bounces before Russian roulette ends subpaths, as for camera paths.
const RR_START_DEPTH: u32 = 2;
/// The throughput under which roulette ends subpaths: higher than the
/// camera paths' (`RR_THRESHOLD`), as a subpath's deep vertices are one
/// light sample among many. Against 0.2 (Cornell box, 256², 64 spp, 4
/// seeds): 0.5 took 5% less time (min of 4 on 1 thread) for the same error
/// (relMSE 0.00327 vs 0.00330, se 0.00002), 0.7 the same, 1.0 8% less for
/// 3% more error; the gold sphere's subpaths end sooner anyway (same time
/// and error).
const SUBPATH_RR_THRESHOLD: f32 = 0.5;
/// Subpaths that estimate `mis_scale`.
const SCALE_SUBPATHS: u32 = 512;
/// Subpaths traced for the caustic guide at most (caustic_guide.rs):
/// 4,096 to 65,536 gave the glass sphere the same error at 16 spp.
const CAUSTIC_SUBPATHS: u32 = 8192;

/// Subpaths a parallel task traces: sample indices are few (one for a
/// 1-spp render), their subpaths many.
const BLOCK: u32 = 1024;

impl LightVertices {
    /// M for a render: the mean vertices per subpath over the connections
    /// a camera path makes (`CONNECTIONS`), from subpaths of a sample
    /// index no pixel uses, and the rays they took. Traced in parallel
    /// blocks: on one thread they were 1% of a 1-spp render's time.
    pub fn mis_scale<B: Bsdf>(ctx: &Context, prepared: &[Option<[B::Prepared; 2]>], seed: u64, max_depth: u32) -> (f32, u64) {
        const SCALE_BLOCK: u32 = 64;
        let (vertices, rays) = (0..SCALE_SUBPATHS.div_ceil(SCALE_BLOCK))
            .into_par_iter()
            .map(|b| {
                let (mut vertices, mut rays) = (0u64, 0u64);
                for j in b * SCALE_BLOCK..((b + 1) * SCALE_BLOCK).min(SCALE_SUBPATHS) {
                    let mut rng = subpath_rng(seed ^ 0x4D49_535F_7363, j, u64::MAX);
                    subpath::<B>(ctx, prepared, None, &mut rng, max_depth.saturating_sub(1), &mut rays, &mut |_, _, _| {
                        vertices += 1;
                        true
                    });
                }
                (vertices, rays)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        ((vertices as f32 / SCALE_SUBPATHS as f32).max(1.0) / CONNECTIONS as f32, rays)
    }

    /// Where `count` subpaths of their own, aimed at the glass and mirrors
    /// (`Aim`), landed beyond delta lobes alone (caustic_guide.rs), and
    /// the rays they took. The same for every seed: the guide only moves
    /// samples, and a render's image stays a function of its seed.
    pub fn caustic_arrivals<B: Bsdf>(ctx: &Context, prepared: &[Option<[B::Prepared; 2]>], count: u32, max_depth: u32) -> (Vec<Arrival>, u64) {
        const BLOCK: u32 = 256;
        let Some(aim) = Aim::toward_caustics(ctx.scene) else { return (Vec::new(), 0) };
        (0..count.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let (mut arrivals, mut rays) = (Vec::new(), 0u64);
                for j in b * BLOCK..((b + 1) * BLOCK).min(count) {
                    let mut rng = subpath_rng(0x4341_5553_5449, j, u64::MAX);
                    subpath::<B>(ctx, prepared, Some(&aim), &mut rng, max_depth.saturating_sub(1), &mut rays, &mut |v, _, _| {
                        if v.first && !v.sampled {
                            arrivals.push(Arrival { p: v.hit.p, dir: v.to_prev });
                            return false;
                        }
                        // On only from a smooth y1 (a mirror, stored as
                        // any surface is), whose delta lobe may lead to
                        // one; nothing after a rough one arrives.
                        v.first && crate::material::is_smooth(v.hit.surface.roughness)
                    });
                }
                (arrivals, rays)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .fold((Vec::new(), 0), |(mut all, rays), (arrivals, r)| {
                all.extend(arrivals);
                (all, rays + r)
            })
    }

    /// The caustic guide's subpaths for a render of `spp` samples: a
    /// thousand a sample, up to `CAUSTIC_SUBPATHS` (a 1-spp image of the
    /// glass sphere spends 2–4 ms on a thousand of them).
    pub fn caustic_subpaths(spp: u32) -> u32 {
        spp.saturating_mul(1024).clamp(1024, CAUSTIC_SUBPATHS)
    }

    /// The subpaths each sample index traces: `count` for their vertices,
    /// or with `tracing`, its n_T if more (light_tracing.rs).
    pub fn subpaths(tracing: Option<&LightTracing>, count: u32) -> u32 {
        tracing.map_or(count, |t| count.max(t.subpaths as u32))
    }

    /// Every sample index of `samples`' vertices, from `count` subpaths
    /// each, traced in parallel; with `tracing`, each sample index traces
    /// its n_T subpaths (the first `count` of them also keep their
    /// vertices) and their vertices seen by the camera (light_tracing.rs)
    /// are returned too, by sample index, in an order fixed by the samples
    /// alone. Only the subpaths numbered `batch` (of `subpaths`) are
    /// traced: a caller that takes n_T in batches holds one batch's
    /// splats at a time.
    #[allow(clippy::too_many_arguments)]
    pub fn for_samples<B: Bsdf>(
        ctx: &Context,
        prepared: &[Option<[B::Prepared; 2]>],
        tracing: Option<&LightTracing>,
        seed: u64,
        samples: Range<u32>,
        batch: Range<u32>,
        count: u32,
        max_depth: u32,
        mis_scale: f32,
        guide: Option<&Arc<CausticGuide>>,
        merge: bool,
    ) -> (Vec<Self>, Vec<Vec<Splat>>, RayCounts) {
        let max_vertex_depth = max_depth.saturating_sub(1);
        let batch = batch.start..batch.end.min(Self::subpaths(tracing, count));
        let blocks = batch.len().div_ceil(BLOCK as usize).max(1);
        let tasks: Vec<(u32, u32)> = samples.clone().flat_map(|s| batch.clone().step_by(BLOCK as usize).map(move |j0| (s, j0))).collect();
        // Every subpath of the batch keeps its photons: a camera vertex
        // merges with all of them, where a connection takes one vertex.
        let merge = merge && ctx.delta_starts();
        let traced: Vec<TaskTraced> = tasks
            .into_par_iter()
            .map(|(s, j0)| {
                let (mut vertices, mut photons, mut splats, mut rays) = (Vec::new(), Vec::new(), Vec::new(), RayCounts::default());
                for j in j0..(j0 + BLOCK).min(batch.end) {
                    let mut rng = subpath_rng(seed, j, s as u64);
                    subpath::<B>(ctx, prepared, None, &mut rng, max_vertex_depth, &mut rays.bounce, &mut |v, rng, _| {
                        if j < count {
                            vertices.push(ConnectionVertex::of(v));
                        }
                        if merge && v.first && !v.sampled && connects_from(&v.hit.surface) {
                            photons.push(ConnectionVertex::of(v));
                        }
                        if let Some(t) = tracing.filter(|t| j < t.subpaths as u32) {
                            t.splat::<B>(ctx, prepared, v, rng, &mut rays.shadow, &mut splats);
                        }
                        true
                    });
                }
                (vertices, photons, splats, rays)
            })
            .collect();
        let mut out: Vec<Self> = samples
            .clone()
            .map(|_| LightVertices { vertices: Vec::new(), traced: count, mis_scale, max_vertex_depth, tracing: tracing.map_or(0.0, |t| t.subpaths), guide: guide.cloned(), photons: None })
            .collect();
        let (mut splats, mut rays) = (vec![Vec::new(); out.len()], RayCounts::default());
        let mut photons = vec![Vec::new(); out.len()];
        for (i, (vertices, p, s, r)) in traced.into_iter().enumerate() {
            out[i / blocks].vertices.extend(vertices);
            photons[i / blocks].extend(p);
            splats[i / blocks].extend(s);
            rays.add(&r);
        }
        for ((vertices, photons), sample) in out.iter_mut().zip(photons).zip(samples) {
            let radius = crate::photons::radius(&photons, sample);
            vertices.photons = Photons::new(photons, radius, batch.len() as u32);
        }
        (out, splats, rays)
    }

    /// One vertex, uniformly over all (`u` a uniform 32-bit number), and
    /// the factor that makes it stand for all of its sample index's
    /// subpaths: vertices / subpaths traced.
    #[inline]
    pub fn pick(&self, u: u32) -> Option<(&ConnectionVertex, f32)> {
        let v = self.vertices.get(self.index(u))?;
        Some((v, self.vertices.len() as f32 / self.traced as f32))
    }

    /// Starts loading the vertex `pick(u)` returns into the cache. A
    /// camera path draws its connections' numbers as it starts, so that
    /// their vertices, random ones among thousands (0.3–0.7 MB, which
    /// share a core's 0.5 MB L2 with the BVH and the rest), arrive while
    /// it finds z: waiting for them had been 6% of the Cornell box's time.
    #[inline]
    pub fn prefetch(&self, u: u32) {
        if let Some(v) = self.vertices.get(self.index(u)) {
            crate::memory::prefetch(v);
        }
    }

    #[inline]
    fn index(&self, u: u32) -> usize {
        ((u as u64 * self.vertices.len() as u64) >> 32) as usize
    }
}

/// Whether a light subpath can have a vertex on a surface and go on from
/// it: not on glass, whose paths stay the camera's alone. A camera path's
/// MIS chain asks the same of its vertices, so the two sides agree on
/// which paths a connection can make.
#[inline]
pub(crate) fn carries_light_paths(surface: &Surface) -> bool {
    surface.transmission == 0.0
}

/// Rays `landing` starts: its shares' standard errors are at most
/// 0.5/√4096 ≈ 0.008, against thresholds of 0.1 and more.
const NEAR_RAYS: u32 = 4096;
/// Light lands "near" its emitter within this multiple of the emitting
/// surface's size (`emitter_sizes`): the ceiling 1 cm above a 50 cm lamp
/// (0.71 m across) is 0.014 of it, 30 cm above it 0.42; the floor 2 m
/// under it 2.8. See `Landing::near` for what it catches.
const NEAR_DISTANCE: f32 = 1.0;
/// A point or spot light's light lands near it within this fraction of
/// the median distance its power lands at (`near_bulbs`). In a closed
/// 4 × 4 × 3 m room, with the bulb 2 cm, 30 cm, 1 m and 1.5 m under the
/// ceiling, light subpaths took 150×, 5×, 1.09× and 0.90× less error ×
/// time (16 spp, 4 seeds, against 512-spp images); the first two land
/// near, the others not.
const NEAR_BULB: f32 = 0.25;
/// Emitters at least this fraction of the scene's diagonal across light
/// no patch: an emissive dome around the scene (18% more error × time at
/// 16 spp with light subpaths, the same at 4) is a sky, not a lamp.
const NEAR_LARGEST: f32 = 0.5;
/// The share of the emitted power landing near its emitters above which
/// light subpaths are traced (`Context::light_paths_pay`). A two-sided
/// lamp under a ceiling sends half its power there.
const NEAR_SHARE: f32 = 0.1;
/// The shares of the emitted power going on from where it lands to
/// another surface (`Landing::onward`) for which light subpaths are
/// traced: a scene open to the World on some sides. Below, almost none of
/// the light bounces on and they cannot pay their time (a bare floor);
/// above, a closed room, whose walls' light reaches a point from every
/// side, where a BSDF sample finds it as well as they do.
const ONWARD_OPEN: std::ops::Range<f32> = 0.01..0.95;
/// The emitters' share of the light where theirs lands
/// (`Landing::emitters`) from which the onward share counts: twice the
/// World's and the suns' together.
const EMITTERS_LIGHT: f32 = 2.0 / 3.0;

/// What becomes of the emitters' light where it first lands (`landing`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Landing {
    /// The share of the power whose first bounce lands near the surface it
    /// left (`NEAR_DISTANCE`): on the ceiling above a two-sided lamp, in a
    /// slit, inside a shade or a recess, on the floor around a glowing
    /// object. That light makes a small bright patch, a second lamp that
    /// light sampling does not know of: camera paths find it only by the
    /// chance of a BSDF sample (or, in a slit, after the bounces that let
    /// it out), and light subpaths land on it in proportion to its light
    /// (README, *How it renders*). Light subpaths, against none (error ×
    /// time, 256², 1–16 spp): 7–10× less in the slit of a lamp 1 cm under
    /// a ceiling, 3.6–4.6× with it 30 cm under, 3.8–5.6× around a glowing
    /// sphere and 1.8–2.6× around a glowing cube resting on a floor; within
    /// ±16% under a 2 m ceiling panel in a 4 m room, which counts as near
    /// too (`NEAR_LARGEST` leaves out domes around the scene). The Cornell
    /// box's and the hall's lamps, whose light lands metres away, stay far.
    /// The rule before, a quarter of √area of the triangle the light left,
    /// caught the slit alone: a finely tessellated sphere's triangles are
    /// small, however large the sphere.
    pub near: f32,
    /// The share of the power that lands on a surface and, scattered from
    /// it once more (cosine-distributed about its normal), reaches another
    /// surface rather than the World: 1 in a closed room, 0 for a lamp
    /// over a bare floor. Where it is in `ONWARD_OPEN` the scene's
    /// indirect light comes from the surfaces on some sides of a point and
    /// the World's darkness on the others, so that a camera path's BSDF
    /// sample finds it only part of the time, where a connection to a
    /// light vertex always lands on lit surface. Light subpaths, against
    /// none (error × time, 256², 4 and 16 spp, Glint references; a 0.6 m
    /// lamp 3 m up over a matte floor, World 0.05): a ball in the corner
    /// of two walls (onward 0.49) 2.2× and 1.8× less, a niche of three
    /// walls and a ceiling (0.92) 1.7×, the diffuse Cornell box lit from
    /// its one-sided lamp (0.67) 1.2× and 1.1×, one matte ball on the
    /// floor (0.017) 1.5× and 1.9×, three balls (0.041) 1.2×, a 2 m ball
    /// (0.043) 1.1× and 1.2×; five balls and cubes (0.065) 0.95× and 0.99×
    /// and three objects under three lamps (0.034) 0.89× and 0.99×, which
    /// the range takes for the others' gains; left out: the bare floor (0)
    /// 0.8×, a closed 4 m room (1.0) 0.89× and 0.93×, the benchmark's hall
    /// (1.0) 0.8× (README, *A scene pays only for what it uses*).
    pub onward: f32,
    /// The emitters' share of the irradiance where their light lands
    /// (point and spot lights among them), against the World's and the
    /// suns' (whose own subpaths, `SunStarts`, this rule leaves out), each landing point weighted by the light landing
    /// there: the onward share counts for light subpaths only from
    /// `EMITTERS_LIGHT` on. The open corner (onward 0.49) under a brighter
    /// and brighter World, light subpaths against none (error × time, 4
    /// and 16 spp): World 0.05 (share 0.99) 2.2× and 1.8× less, 1 (0.81)
    /// 1.6× and 1.4×, 2 (0.68) 1.14× and 1.02×, 3 (0.59) 0.83× and 0.79×,
    /// 5 (0.46) 0.61× and 0.62×, 10 (0.30) 0.56× and 0.57×: a lamp in
    /// daylight lights too little for them to pay.
    pub emitters: f32,
}

impl Landing {
    /// Whether light subpaths pay for this landing: much of the light lands
    /// near its emitter, or the scene is open on some sides and the
    /// emitters give most of the light where theirs lands.
    pub(crate) fn pays(&self) -> bool {
        self.near > NEAR_SHARE || (ONWARD_OPEN.contains(&self.onward) && self.emitters >= EMITTERS_LIGHT)
    }
}

/// Where the emitters' light first lands, and where it goes from there
/// (`Landing`), from rays started as light subpaths start, on numbers of
/// their own, so that it is the same for every render of a scene.
pub(crate) fn landing(ctx: &Context) -> Landing {
    let sizes = emitter_sizes(ctx.scene, &ctx.lights.triangles);
    let (lo, hi) = crate::scene::bounds(&ctx.scene.triangles);
    let largest = NEAR_LARGEST * (hi - lo).length();
    let mut rng = Rng::new(0x7472_6170_7065_6421, 0);
    let (mut near, mut onward, mut total) = (0.0f64, 0.0f64, 0.0f64);
    let (mut emitted, mut other) = (0.0f64, 0.0f64);
    let mut bulbs_landed = Vec::new();
    let suns: Vec<&crate::punctual::PunctualLight> = ctx.scene.punctual.iter().filter(|l| l.kind == crate::punctual::PunctualKind::Sun).collect();
    for _ in 0..NEAR_RAYS {
        let (u_pick, u_point) = rng.next_1d_2d();
        let Some(start) = ctx.lights.sample_start(ctx.scene, u_pick, u_point, rng.next_2d(), None) else { continue };
        // The emitters' light alone: a sun's starts (`SunStarts`) count
        // with the World's, in `other`.
        if matches!(&start, Start::Point(p) if ctx.scene.punctual[p.index as usize].kind == crate::punctual::PunctualKind::Sun) {
            continue;
        }
        // The power this start stands for (a subpath's α, summed over RGB).
        let (origin, dir, power, size) = match &start {
            Start::Emitter(e) => (e.origin, e.dir, e.le.element_sum() as f64 / e.density as f64, sizes[e.triangle as usize]),
            Start::Point(p) => (p.origin, p.dir, p.alpha.element_sum() as f64, f32::INFINITY),
        };
        if !(power.is_finite() && power > 0.0) {
            continue;
        }
        total += power;
        let Some(hit) = ctx.intersect(origin, dir, RayKind::Bounce, &mut rng) else { continue };
        if size < largest && hit.t < NEAR_DISTANCE * size {
            near += power;
        }
        if let Start::Point(_) = start {
            bulbs_landed.push((hit.t, power));
        }
        // On from the side the light landed on (si.ng faces it).
        let (si, _) = SurfaceHit::with_normal(ctx.scene, &hit, dir, &mut rng);
        let dir = Frame::from_normal(si.ng).to_world(crate::sampling::cosine_hemisphere(rng.next_2d()));
        if ctx.intersect(si.spawn_origin(dir), dir, RayKind::Bounce, &mut rng).is_some() {
            onward += power;
        } else {
            // The World's irradiance there, π·L one cosine sample.
            other += PI as f64 * ctx.scene.world_radiance(dir).element_sum() as f64 / 3.0;
        }
        emitted += match &start {
            Start::Emitter(e) => emitters_irradiance(ctx, e, &si, hit.t),
            Start::Point(p) => bulbs_irradiance(p, &si, hit.t),
        };
        other += suns_irradiance(ctx, &suns, &si, &mut rng);
    }
    near += near_bulbs(&mut bulbs_landed);
    let share = |part: f64| if total > 0.0 { (part / total) as f32 } else { 0.0 };
    // An emitter's own light landing on it (t → 0) is no less its own.
    let emitters = if emitted.is_finite() && emitted + other > 0.0 { (emitted / (emitted + other)) as f32 } else { 1.0 };
    Landing { near: share(near), onward: share(onward), emitters }
}

/// The emitters' irradiance (mean over RGB) at `si`, where `start`'s ray
/// landed at distance `t`, from the start's point as an area sample of all
/// of them: Le·cos·cos'/(t²·p_A).
fn emitters_irradiance(ctx: &Context, start: &crate::lights::EmissionSample, si: &SurfaceHit, t: f32) -> f64 {
    let m = ctx.scene.material_of(start.triangle);
    let p_area = ctx.lights.emission_density(m) as f64;
    if !(p_area > 0.0) {
        return 0.0;
    }
    let cosines = (start.normal.dot(start.dir).abs() * si.ng.dot(-start.dir).max(0.0)) as f64;
    start.le.element_sum() as f64 / 3.0 * cosines / (t as f64 * t as f64) / p_area
}

/// The power of the point and spot lights' rays (`landed`: distance and
/// power of each that met a surface) that lands near them: within
/// `NEAR_BULB` of the median distance their power lands at. A bulb has no
/// size its light's reach could be measured by, as an emitter's is, and
/// the scene's would not do (a floor a kilometre wide under a lamp); what
/// light sampling misses is a patch much nearer, and so much brighter,
/// than where the light mostly lands.
fn near_bulbs(landed: &mut [(f32, f64)]) -> f64 {
    landed.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let half = landed.iter().map(|l| l.1).sum::<f64>() / 2.0;
    let mut below = 0.0;
    let Some(&(median, _)) = landed.iter().find(|l| {
        below += l.1;
        below >= half
    }) else {
        return 0.0;
    };
    landed.iter().take_while(|l| l.0 < NEAR_BULB * median).map(|l| l.1).sum()
}

/// The point and spot lights' irradiance (mean over RGB) at `si`, where
/// `start`'s ray landed at distance `t`, as a sample of all of them:
/// I·cos/(t²·p_pick) = α·pdf_dir·cos/t².
fn bulbs_irradiance(start: &PointEmission, si: &SurfaceHit, t: f32) -> f64 {
    let cos = si.ng.dot(-start.dir).max(0.0);
    (start.alpha.element_sum() / 3.0 * start.pdf_dir * cos) as f64 / (t as f64 * t as f64)
}

/// The irradiance (mean over RGB) of the scene's `suns` at `si`, on its
/// side: one picked at random with its shadow ray, times their count.
/// (Point and spot lights start subpaths: their light counts as the
/// emitters'.)
fn suns_irradiance(ctx: &Context, suns: &[&crate::punctual::PunctualLight], si: &SurfaceHit, rng: &mut Rng) -> f64 {
    let count = suns.len();
    if count == 0 {
        return 0.0;
    }
    let light = suns[((rng.next_f32() * count as f32) as usize).min(count - 1)];
    let Some(inc) = light.incident(si.p, rng.next_2d()) else { return 0.0 };
    let cos = si.ng.dot(inc.wi);
    if !(cos > 0.0) || ctx.occluded(si.spawn_origin(inc.wi), inc.wi, inc.distance, u32::MAX, rng) {
        return 0.0;
    }
    count as f64 * (inc.irradiance.element_sum() / 3.0 * cos) as f64
}

/// For each of the `emitting` scene triangles (the lights' emitters, which
/// light subpaths start from), the size of the surface it belongs to (0
/// for the other triangles): the diagonal of the box around the emitting
/// triangles joined to it through shared corners (`scene::joined_parts`),
/// so that a lamp's size does not depend on how finely it is tessellated.
/// A corner shared with another lamp joins the two. Computed once, and
/// only for `auto` where no surface focuses light.
fn emitter_sizes(scene: &Scene, emitting: &[u32]) -> Vec<f32> {
    let parts = crate::scene::joined_parts(scene, emitting);
    let bounds = crate::scene::part_boxes(scene, emitting, &parts);
    let mut sizes = vec![0.0; scene.triangles.len()];
    for (k, &t) in emitting.iter().enumerate() {
        let (lo, hi) = bounds[parts[k] as usize];
        sizes[t as usize] = (hi - lo).length();
    }
    sizes
}

/// Numbers of their own for subpath j of a sample index, apart from the
/// camera paths'.
fn subpath_rng(seed: u64, j: u32, sample: u64) -> Rng {
    Rng::for_sample(seed ^ 0x6C69_6768_745F_7061, j as u64, sample)
}

/// The first surface a subpath's ray from `origin` along `dir` meets: the
/// hit, the surface there (`ng` facing the ray's origin), its shading
/// normal, and the cosine of the way back.
fn first_hit(ctx: &Context, origin: Vec3, dir: Vec3, rng: &mut Rng, rays: &mut u64) -> Option<(crate::accel::Hit, SurfaceHit, Vec3, f32)> {
    *rays += 1;
    let hit = ctx.intersect(origin, dir, RayKind::Bounce, rng)?;
    let (si, ns) = SurfaceHit::with_normal(ctx.scene, &hit, dir, rng);
    let cos_in = -dir.dot(si.ng);
    Some((hit, si, ns, cos_in))
}

/// A subpath's first vertex y1 from a point of an emitting triangle, and
/// its start's `DeltaStart`.
fn first_from_emitter<B: Bsdf>(ctx: &Context, mut start: EmissionSample, rng: &mut Rng, rays: &mut u64) -> Option<(LightVertex, DeltaStart)> {
    if !(start.density > 0.0) {
        return None;
    }
    let emitter = ctx.scene.material_of(start.triangle);
    if let Some(w) = B::emission_weight(emitter, start.normal.dot(start.dir)) {
        start.le *= w;
    }
    let (hit, si, ns, cos_in) = first_hit(ctx, start.origin, start.dir, rng, rays)?;
    let to_prev = -start.dir;
    // Light subpaths are traced only with MIS (Context::traces_light_paths).
    // As a camera vertex's light sample would pick it here: si.ng faces
    // the light.
    let light_pdf = ctx.lights.pdf_emitter(ctx.scene, start.triangle, si.p, si.ng, start.origin, hit.t * hit.t, start.normal.dot(start.dir), true);
    let alpha = start.le * (PI / start.density);
    if !(alpha.is_finite() && light_pdf > 0.0 && light_pdf.is_finite() && cos_in > 0.0) {
        return None;
    }
    let v = LightVertex { hit: si, ns, to_prev, alpha, depth: 1, generated: start.density * cos_in / (PI * light_pdf), back: 1.0 / light_pdf, prefix: 1.0, to_unidirectional: 0.0, first: true, sampled: true };
    Some((v, DeltaStart { emitted: start.density / PI, reached: true, length: hit.t, refractions: 0 }))
}

/// A subpath's first vertex y1 from a point or spot light
/// (`PunctualLight::start`), and its start's `DeltaStart`. Its density
/// over light sampling's at y1: the subpath's per unit area (and, sized,
/// per steradian toward the light) over the light sample's, the pick's
/// probability P there (times, sized, the density of the facing disk's
/// point, `PunctualLight::seen`). A light of radius 0 is reached by no
/// BSDF sample (`back` 0). A sized one's ray that reaches y1 from outside
/// the cone of the disk y1 sees is left out: the disk's light (Blender's
/// Soft Falloff), which every other strategy renders, comes from that
/// cone alone; the sphere's (Soft Falloff off) from all of it.
fn first_from_point(ctx: &Context, start: PointEmission, rng: &mut Rng, rays: &mut u64) -> Option<(LightVertex, DeltaStart)> {
    let light = &ctx.scene.punctual[start.index as usize];
    let (hit, si, ns, cos_in) = first_hit(ctx, start.origin, start.dir, rng, rays)?;
    let to_prev = -start.dir;
    let pick = ctx.lights.punctual_probability(start.index as usize, si.p, si.ng, true);
    let (light_pdf, back) = if light.size > 0.0 {
        let light_pdf = pick * light.seen(si.p, to_prev, 0.0, f32::INFINITY)?.pdf;
        (light_pdf, 1.0 / light_pdf)
    } else {
        (pick, 0.0)
    };
    let spread = ctx.lights.start_spread(ctx.scene, start.index as usize, hit.t * hit.t, start.dir, si.p);
    let generated = start.probability * start.pdf_dir * cos_in / (spread * light_pdf);
    if !(cos_in > 0.0 && generated > 0.0 && generated.is_finite() && back.is_finite()) {
        return None;
    }
    let v = LightVertex { hit: si, ns, to_prev, alpha: start.alpha, depth: 1, generated, back, prefix: 1.0, to_unidirectional: 0.0, first: true, sampled: true };
    Some((v, DeltaStart { emitted: start.probability * start.pdf_dir / spread, reached: light.size > 0.0, length: hit.t, refractions: 0 }))
}

/// A subpath that has sampled only delta lobes since its light left y0
/// (glass, mirrors): what the first vertex it stores after them needs,
/// made as y1 is but for two things. Light sampling does not make that
/// vertex (shadow rays stop at glass, and do not bend), so its weights
/// leave that strategy out (`sampled`). And the densities that make its
/// y1 from y0 and y0 from y1 — the subpath's and a camera path's BSDF
/// sample, through the same delta lobes — share the chain's geometry (the
/// étendue of a beam of rays is kept through mirrors and refractions
/// that leave the glass where they entered it) and the lobes' choices
/// (Fresnel's, the same both ways): their ratio is y1 straight from y0's,
/// with any reference density p_ref in light sampling's place, which
/// cancels. The camera side's weights (integrator.rs, `Through`) take the
/// same ratio, and agree with these on which paths qualify: an even number
/// of refractions, and the depths.
#[derive(Clone, Copy)]
struct DeltaStart {
    /// The start's density over the cosine at y1 that y1's `generated`
    /// multiplies by the cosine and divides by light sampling's density.
    emitted: f32,
    /// A BSDF sample can reach the light: not a point of radius 0, whose
    /// light through a delta lobe no camera path finds (nor Cycles'), and
    /// whose subpaths those lobes end.
    reached: bool,
    /// The way from y0, and the refractions on it.
    length: f32,
    refractions: u32,
}

impl DeltaStart {
    /// The vertex at the end of the delta lobes as the subpath's y1, with
    /// p_ref = emitted·length²: the density light sampling would have
    /// with the emitter at the far end of that way, as y1's scale.
    fn first(&self, v: LightVertex) -> LightVertex {
        let reference = self.emitted * self.length * self.length;
        let cos_in = v.to_prev.dot(v.hit.ng);
        LightVertex { generated: self.emitted * cos_in / reference, back: 1.0 / reference, prefix: 1.0, to_unidirectional: 0.0, first: true, sampled: false, ..v }
    }
}

/// Traces one subpath, handing each vertex to `vertex` as it is made,
/// and going on while `vertex` says so. With `aim` it leaves an emitter
/// toward one of the aim's spheres (`Lights::sample_start`): what it carries is
/// then not an estimate, and only where it goes counts (caustic_guide.rs).
/// Until the subpath's first sample that is not from a delta lobe it goes
/// on through glass and mirrors (`DeltaStart`), where light would
/// otherwise reach the surfaces beyond only along the camera paths' BSDF
/// samples: a glass sphere's caustic on the floor. Glass past that ends
/// it, as a delta lobe does.
fn subpath<B: Bsdf>(ctx: &Context, prepared: &[Option<[B::Prepared; 2]>], aim: Option<&Aim>, rng: &mut Rng, max_vertex_depth: u32, rays: &mut u64, vertex: &mut impl FnMut(&LightVertex, &mut Rng, &mut u64) -> bool) {
    let (u_pick, u_point) = rng.next_1d_2d();
    let Some(start) = ctx.lights.sample_start(ctx.scene, u_pick, u_point, rng.next_2d(), aim) else { return };
    if max_vertex_depth == 0 {
        return;
    }
    let Some((mut v, mut delta_start)) = (match start {
        Start::Emitter(start) => first_from_emitter::<B>(ctx, start, rng, rays),
        Start::Point(start) => first_from_point(ctx, start, rng, rays),
    }) else {
        return;
    };
    // While every sample so far was a delta lobe's.
    let mut through_delta = ctx.delta_starts() && delta_start.reached;
    let mut throughput = Vec3::ONE;
    // The absorbing media the subpath is in (media.rs): none at its light
    // (Context::delta_starts), and only glass, which it passes through
    // delta lobes alone, changes them.
    let absorbing = ctx.absorbs::<B>();
    let mut media = Media::default();
    loop {
        // A surface inside the glass (an odd number of refractions, or in
        // a medium) is left out with what lies beyond it; a camera path's
        // weights leave it out alike (integrator.rs, `Through`).
        let inside = through_delta && (delta_start.refractions % 2 == 1 || !media.is_empty());
        let stored = carries_light_paths(&v.hit.surface) && !inside;
        if stored {
            if !vertex(&v, rng, rays) {
                return;
            }
        } else if !(through_delta && B::GLASS && v.hit.surface.transmission > 0.0) {
            return;
        }
        if v.depth >= max_vertex_depth {
            return;
        }
        let frame = Frame::from_normal(shading_normal_for(v.ns, v.hit.ng, v.to_prev));
        let wo = frame.to_local(v.to_prev);
        if !(wo.z > 0.0) {
            return;
        }
        let bsdf: B = bsdf_at(prepared, &v.hit, &frame, wo);
        let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) else { return };
        let w = frame.to_world(s.wi);
        if !(s.pdf > 0.0) || !same_side(&v.hit, w, s.wi) || (s.delta && !through_delta) || !(s.delta || stored) {
            return;
        }
        // ng faces y_{k−1}.
        let cos_in = v.to_prev.dot(v.hit.ng);
        let cos_out = w.dot(v.hit.ng).abs();
        // The vertex as a camera path through it sees it: wo toward the
        // next vertex, wi toward the light. A delta lobe's value is its
        // sample's (the two sides' factors of a refraction, 1/η² in and η²
        // out, cancel over the glass).
        let (factor, pdf_camera) = if s.delta {
            (s.weight * (wo.z * cos_out / (s.wi.z.abs() * cos_in)), 0.0)
        } else {
            through_delta = false;
            let (f, pdf_camera) = bsdf_at::<B>(prepared, &v.hit, &frame, s.wi).evaluate(s.wi, wo);
            (f * (wo.z * cos_out / (cos_in * s.pdf)), pdf_camera)
        };
        if absorbing {
            media = *v.hit.sides(ctx.scene, &media).toward(w.dot(v.hit.ng));
        }
        throughput *= factor;
        let mut alpha = v.alpha * factor;
        if v.depth >= RR_START_DEPTH {
            let q = (throughput.max_element() / SUBPATH_RR_THRESHOLD).sqrt().min(RR_MAX_SURVIVAL);
            if !(rng.next_f32() < q) {
                return;
            }
            throughput /= q;
            alpha /= q;
        }
        *rays += 1;
        let Some(hit) = ctx.intersect(v.hit.spawn_origin(w), w, RayKind::Bounce, rng) else { return };
        if absorbing {
            let kept = transmittance(media.sigma, hit.t);
            (throughput, alpha) = (throughput * kept, alpha * kept);
        }
        let (si, ns) = SurfaceHit::with_normal(ctx.scene, &hit, w, rng);
        let cos_next = -w.dot(si.ng);
        let t2 = hit.t * hit.t;
        let next = if s.delta {
            delta_start.length += hit.t;
            delta_start.refractions += (s.wi.z < 0.0) as u32;
            delta_start.first(LightVertex { hit: si, ns, to_prev: -w, alpha, depth: v.depth + 1, generated: 0.0, back: 0.0, prefix: 1.0, to_unidirectional: 0.0, first: true, sampled: false })
        } else {
            let (prefix, to_unidirectional) = if v.first { (1.0, pdf_camera * v.back) } else { (v.prefix * pdf_camera * v.back, v.to_unidirectional) };
            LightVertex {
                hit: si,
                ns,
                to_prev: -w,
                alpha,
                depth: v.depth + 1,
                generated: s.pdf * cos_next / t2,
                back: cos_out / (t2 * v.generated),
                prefix,
                to_unidirectional,
                first: false,
                sampled: v.sampled,
            }
        };
        // `to_unidirectional` is 0 after a point light of radius 0, which
        // no BSDF sample reaches.
        let finite = [next.generated, next.back, next.prefix].iter().all(|x| x.is_finite() && *x > 0.0) && next.to_unidirectional.is_finite() && next.to_unidirectional >= 0.0;
        if !(finite && cos_next > 0.0 && alpha.is_finite()) {
            return;
        }
        v = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::scene::Triangle;

    fn diffuse_cornell_box(two_sided: bool) -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box-diffuse.gltf");
        let mut scene = crate::loader::load_file(&path, &Default::default()).unwrap();
        for m in scene.materials.iter_mut().filter(|m| m.is_emissive()) {
            m.double_sided = two_sided;
        }
        scene
    }

    /// The diffuse Cornell box's lamp hangs 1 cm under the ceiling: facing
    /// down only, its light lands metres away, but the box is open at the
    /// front (a third of its light has left it by its second bounce), so
    /// light subpaths are traced for it (`Landing::onward`, 1.1× less
    /// error × time); emitting from both faces, half of it lands in the
    /// slit, and they carry it out (7–10× less error × time there).
    #[test]
    fn light_in_a_slit_lands_near_and_light_paths_pay_for_it() {
        let one_sided = diffuse_cornell_box(false);
        let (ctx, _) = Context::new(&one_sided);
        assert!(!ctx.features.focusing);
        let share = landing(&ctx);
        assert!(share.near < 0.01, "{share:?}");
        assert!((0.6..0.75).contains(&share.onward), "{share:?}");
        assert!(ctx.light_paths_pay());
        let two_sided = diffuse_cornell_box(true);
        let (ctx, _) = Context::new(&two_sided);
        let share = landing(&ctx).near;
        assert!((share - 0.5).abs() < 0.04, "{share}");
        assert!(ctx.light_paths_pay());
    }

    /// A 3° sun straight down on the closed room around the lamp lights
    /// its roof alone, which the camera inside never sees: the sun starts
    /// no subpath, and leaves them all to the lamp (the Cornell box under
    /// such a sun had taken 8% more error at 16 spp with a quarter of the
    /// starts the sun's). Over the open floor, 71% of its starts land
    /// where the camera sees them (sun_cells.rs); 28% with the cells
    /// weighed by whether their light meets a surface alone.
    #[test]
    fn a_sun_starts_subpaths_where_its_light_lands_in_view() {
        use crate::punctual::{PunctualKind, PunctualLight};
        let sun = PunctualLight { name: "sun".into(), kind: PunctualKind::Sun, position: Vec3::ZERO, direction: -Vec3::Y, intensity: Vec3::splat(3.0), size: 0.05, sphere: false, camera_sees: false, shadowless: false };
        for (walls, hidden) in [(&room_walls()[..], true), (&[][..], false)] {
            let mut scene = lamp_over_floor(walls, PI);
            scene.punctual.push(sun.clone());
            let (ctx, _) = Context::new(&scene);
            let p = ctx.lights.point_start_probability(&scene, 0);
            if hidden {
                assert_eq!(p, 0.0);
                continue;
            }
            assert!(p > 0.0);
            let lens = scene.camera.lens(64, 64);
            let mut rng = Rng::new(5, 0);
            let (mut starts, mut seen) = (0, 0);
            while starts < 2000 {
                let (u_pick, u_point) = rng.next_1d_2d();
                let Some(Start::Point(start)) = ctx.lights.sample_start(&scene, u_pick * p, u_point, rng.next_2d(), None) else { continue };
                starts += 1;
                let Some(hit) = ctx.intersect(start.origin, start.dir, RayKind::Bounce, &mut rng) else { continue };
                let (si, _) = SurfaceHit::with_normal(&scene, &hit, start.dir, &mut rng);
                seen += crate::sun_cells::in_sight(&ctx, &lens, &si, &mut rng) as u32;
            }
            let share = seen as f32 / starts as f32;
            println!("sun starts in view: {share}");
            assert!(share > 0.6, "{share}");
        }
        // A ball of rough gold (0.2) a metre across in view, 0.5% of the
        // scene's disk: the finer grid over the surfaces that focus light
        // takes 40% of the starts, and 36% of all starts reach the ball
        // (21% with that share on the coarse cells its light lands in and
        // their neighbours, 1.5% with it left to the cells in view). On a
        // floor a kilometre wide, whose coarse cells are 22 m, 35% (none
        // with the coarse cells alone, whose one ray each missed the ball).
        for floor_scale in [1.0, 100.0] {
            let mut ball = floor_and_sphere(Vec3::new(0.0, 0.5, -2.0), 0.5, 8, true);
            ball.materials[1] = Material { metallic: 1.0, roughness: 0.2, ..Material::default() };
            for t in &mut ball.triangles[..2] {
                *t = Triangle::new(t.p().map(|p| p * Vec3::new(floor_scale, 1.0, floor_scale)), [Vec3::Y; 3], 0);
            }
            let mut scene = Scene::new(ball.triangles, ball.materials, ball.camera);
            scene.punctual.push(sun.clone());
            let (ctx, _) = Context::new(&scene);
            let mut rng = Rng::new(6, 0);
            let on_ball = (0..2000)
                .filter(|_| {
                    let (u_pick, u_point) = rng.next_1d_2d();
                    let Some(Start::Point(start)) = ctx.lights.sample_start(&scene, u_pick, u_point, rng.next_2d(), None) else { return false };
                    ctx.intersect(start.origin, start.dir, RayKind::Bounce, &mut rng).is_some_and(|hit| scene.triangles[hit.triangle as usize].material == 1)
                })
                .count();
            println!("floor × {floor_scale}: {on_ball} of 2000 starts reach the ball");
            assert!(on_ball > 500, "floor × {floor_scale}: {on_ball} of 2000");
        }
    }

    /// A 0.6 m lamp 3 m over a matte floor, with the quads `walls` (corners
    /// in order) about it.
    fn lamp_over_floor(walls: &[[Vec3; 4]], spread: f32) -> Scene {
        use crate::lamps::{add_area_lights, AreaLight, LampShape};
        let mut scene = floor_with_walls(walls);
        let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), glam::Vec3::new(0.0, 3.0, 0.0));
        add_area_lights(&mut scene, &[AreaLight { name: "L".into(), shape: LampShape::Square, size: [0.6, 0.6], matrix: matrix.to_cols_array(), color: [1.0; 3], power: 100.0, visible_camera: false, portal: false, spread, cast_shadow: true }]).unwrap();
        Scene::new(scene.triangles, scene.materials, scene.camera)
    }

    /// The four walls and the ceiling that close the 10 m floor of
    /// `floor_and_sphere` into a room 6 m high, facing in.
    fn room_walls() -> [[Vec3; 4]; 5] {
        let q = |a: [f32; 3], b: [f32; 3], c: [f32; 3], d: [f32; 3]| [a, b, c, d].map(Vec3::from);
        [
            q([-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 6.0, -5.0], [-5.0, 6.0, -5.0]),
            q([-5.0, 0.0, 5.0], [-5.0, 6.0, 5.0], [5.0, 6.0, 5.0], [5.0, 0.0, 5.0]),
            q([-5.0, 0.0, -5.0], [-5.0, 6.0, -5.0], [-5.0, 6.0, 5.0], [-5.0, 0.0, 5.0]),
            q([5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [5.0, 6.0, 5.0], [5.0, 6.0, -5.0]),
            q([-5.0, 6.0, -5.0], [5.0, 6.0, -5.0], [5.0, 6.0, 5.0], [-5.0, 6.0, 5.0]),
        ]
    }

    /// The 10 m matte floor of `floor_and_sphere` and the quads `walls`.
    fn floor_with_walls(walls: &[[Vec3; 4]]) -> Scene {
        let mut scene = floor_and_sphere(Vec3::ZERO, 0.1, 4, false);
        scene.triangles.truncate(2);
        for q in walls {
            let n = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
            scene.triangles.push(Triangle::new([q[0], q[1], q[2]], [n; 3], 0));
            scene.triangles.push(Triangle::new([q[0], q[2], q[3]], [n; 3], 0));
        }
        scene
    }

    /// A bulb (a point light, 5 cm) in a closed 10 × 6 × 10 m room: 10 cm
    /// under its ceiling, much of its light lands far nearer than where it
    /// mostly does, a bright patch only light subpaths find on purpose (in
    /// a 4 × 4 × 3 m room, 2 cm and 30 cm under the ceiling, 150× and 5×
    /// less error × time with them; `NEAR_BULB`); at mid-height none does,
    /// and the closed room sends all of its light on: no light subpaths
    /// (1 m and 1.5 m under that room's ceiling, 1.09× and 0.90×). Over a
    /// floor 2 km wide (a ground plane) and 1 m up, its light lands near
    /// nowhere, whatever the floor's size, and goes no further.
    #[test]
    fn a_bulb_under_a_ceiling_lands_near_and_light_paths_pay_for_it() {
        use crate::punctual::{PunctualKind, PunctualLight};
        let room = room_walls();
        let bulb = |y: f32| PunctualLight { name: "bulb".into(), kind: PunctualKind::Point, position: Vec3::new(0.5, y, 0.5), direction: -Vec3::Y, intensity: Vec3::splat(10.0), size: 0.05, sphere: false, camera_sees: false, shadowless: false };
        let mut ground = floor_with_walls(&[]);
        ground.triangles = ground.triangles.iter().map(|t| Triangle::new(t.p().map(|p| p * 200.0), t.n(), t.material)).collect();
        for (scene, y, near, pays) in [(floor_with_walls(&room), 5.9, 0.3..0.6, true), (floor_with_walls(&room), 3.0, 0.0..0.001, false), (ground, 1.0, 0.0..0.001, false)] {
            let mut scene = Scene::new(scene.triangles, scene.materials, scene.camera);
            scene.punctual.push(bulb(y));
            let (ctx, _) = Context::new(&scene);
            let share = landing(&ctx);
            println!("bulb at {y}: {share:?}");
            assert!(!ctx.features.focusing && near.contains(&share.near), "bulb at {y}: {share:?}");
            assert_eq!(ctx.light_paths_pay(), pays, "bulb at {y}: {share:?}");
        }
    }

    /// Under a lamp 3 m up, a bare floor sends none of its light on, and
    /// goes without light subpaths (1.25× the error × time with them); two
    /// walls meeting 2 m from the lamp take part of it on (the corner pays
    /// them 1.8×); closed into a 10 m box, all of it goes on, where BSDF
    /// samples find the walls' light from every side (a closed room, 0.93×
    /// with them).
    #[test]
    fn light_paths_pay_where_the_scene_is_open_on_some_sides() {
        let q = |a: [f32; 3], b: [f32; 3], c: [f32; 3], d: [f32; 3]| [a, b, c, d].map(Vec3::from);
        let back = q([-5.0, 0.0, -2.0], [5.0, 0.0, -2.0], [5.0, 6.0, -2.0], [-5.0, 6.0, -2.0]);
        let side = q([-2.0, 0.0, -5.0], [-2.0, 6.0, -5.0], [-2.0, 6.0, 5.0], [-2.0, 0.0, 5.0]);
        let box_faces = room_walls();
        for (walls, onward, pays) in [(&[][..], 0.0..0.001, false), (&[back, side][..], 0.3..0.7, true), (&box_faces[..], 0.99..1.001, false)] {
            let scene = lamp_over_floor(walls, PI);
            let (ctx, _) = Context::new(&scene);
            let share = landing(&ctx);
            assert!(!ctx.features.focusing && share.near < NEAR_SHARE, "{} walls: {share:?}", walls.len());
            assert!(onward.contains(&share.onward) && share.emitters == 1.0, "{} walls: {share:?}", walls.len());
            assert_eq!(ctx.light_paths_pay(), pays, "{} walls: {share:?}", walls.len());
        }
        // The same corner under a World of radiance 10, which lights the
        // floor and walls where the lamp's light lands nine times as
        // brightly as the lamp: no longer.
        let mut daylight = lamp_over_floor(&[back, side], PI);
        daylight.background = Vec3::splat(10.0);
        let (ctx, _) = Context::new(&daylight);
        let share = landing(&ctx);
        assert!(ONWARD_OPEN.contains(&share.onward) && (0.05..0.2).contains(&share.emitters), "{share:?}");
        assert!(!ctx.light_paths_pay());
        // Or under a sun, straight down, that does the same; a dim one
        // leaves them in (its light counted only where it reaches).
        for (sun, pays) in [(30.0, false), (0.3, true)] {
            let mut sunlit = lamp_over_floor(&[back, side], PI);
            sunlit.punctual.push(crate::punctual::PunctualLight { name: "sun".into(), kind: crate::punctual::PunctualKind::Sun, position: Vec3::ZERO, direction: -Vec3::Y, intensity: Vec3::splat(sun), size: 0.0, sphere: false, camera_sees: false, shadowless: false });
            let (ctx, _) = Context::new(&sunlit);
            assert_eq!(ctx.light_paths_pay(), pays, "sun {sun}: {:?}", landing(&ctx));
        }
        // The same corner a thousandth and a thousand times the size: the
        // shares are ratios, and the rays' offsets follow the scale.
        let corner = lamp_over_floor(&[back, side], PI);
        let reference = landing(&Context::new(&corner).0);
        for scale in [1e-3f32, 1e3] {
            let triangles = corner.triangles.iter().map(|t| Triangle::new(t.p().map(|p| p * scale), t.n(), t.material)).collect();
            let scaled = Scene::new(triangles, corner.materials.clone(), corner.camera.clone());
            let share = landing(&Context::new(&scaled).0);
            assert!((share.onward - reference.onward).abs() < 0.03 && share.near == reference.near, "×{scale}: {share:?} against {reference:?}");
        }
    }

    /// The same two-sided lamp (0.5 m square, 0.71 m across) hung 30 cm
    /// under the ceiling: the light of its upper face that travels less
    /// than 0.71 m up the 0.3 m gap, cos θ ≥ c = 0.3/0.71, is 1 − c² =
    /// 0.82 of the upper half's (cosine-distributed), minus what leaves
    /// past the walls: 0.42 measured. A bright patch only light subpaths
    /// find on purpose (3.6–4.6× less error × time with them); a quarter
    /// of √area of its triangles, the rule before, counted none of it.
    #[test]
    fn light_landing_near_a_hanging_lamp_pays_for_light_paths() {
        let mut scene = diffuse_cornell_box(true);
        let lamp: Vec<bool> = scene.materials.iter().map(|m| m.is_emissive()).collect();
        for t in scene.triangles.iter_mut().filter(|t| lamp[t.material as usize]) {
            *t = Triangle::new(t.p().map(|p| p - Vec3::new(0.0, 0.29, 0.0)), t.n(), t.material);
        }
        let (ctx, _) = Context::new(&scene);
        let share = landing(&ctx).near;
        assert!((0.35..0.48).contains(&share), "{share}");
        assert!(ctx.light_paths_pay());
    }

    /// A glowing sphere resting on a floor lights the floor around its
    /// foot (3.8–5.6× less error × time with light subpaths): near it for
    /// its size, 0.3 m across, however finely it is tessellated — its
    /// triangles are joined through their shared corners. By the size of
    /// each triangle, as before, the finer sphere's light landed far.
    #[test]
    fn a_glowing_sphere_on_a_floor_is_near_at_any_tessellation() {
        let share = |rings: usize| {
            let scene = floor_and_sphere(Vec3::new(0.0, 0.15, 0.0), 0.15, rings, true);
            let (ctx, _) = Context::new(&scene);
            assert!(ctx.light_paths_pay(), "{rings} rings");
            landing(&ctx).near
        };
        let (coarse, fine) = (share(8), share(48));
        assert!(coarse > 0.3 && fine > 0.3, "{coarse} {fine}");
        assert!((coarse - fine).abs() < 0.05, "{coarse} {fine}");
    }

    /// A 0.6 m lamp 3 m over a bare matte floor lands its light far from
    /// it, none of it goes on to another surface, and it goes without
    /// light subpaths; with a Spread (here 150°) its grid throws the light
    /// onto a patch they find, and they are traced.
    #[test]
    fn a_lamp_with_a_spread_pays_for_light_paths() {
        let lamp = |spread: f32| {
            let scene = lamp_over_floor(&[], spread);
            let (ctx, _) = Context::new(&scene);
            assert!(!ctx.features.focusing && landing(&ctx).near < NEAR_SHARE, "{spread}");
            ctx.light_paths_pay()
        };
        assert!(!lamp(PI));
        assert!(lamp(150f32.to_radians()));
    }

    /// An emissive dome 28 m across around a 10 m floor lands its light
    /// within its size, but is as large as the scene: a sky, not a lamp
    /// beside a bright patch; and it closes the scene (all of its light
    /// bounces on): it gets no light subpaths.
    #[test]
    fn an_emissive_dome_around_the_scene_is_no_patch() {
        let scene = floor_and_sphere(Vec3::ZERO, 14.0, 16, false);
        let (ctx, _) = Context::new(&scene);
        let share = landing(&ctx);
        assert!(share.near == 0.0, "{share:?}");
        assert!(!ctx.light_paths_pay());
    }

    /// A 10 m grey floor at y = 0 and an emitting sphere, its faces' front
    /// out of it or into it.
    fn floor_and_sphere(centre: Vec3, r: f32, rings: usize, outward: bool) -> Scene {
        let floor = [Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 0.0, -5.0), Vec3::new(5.0, 0.0, 5.0), Vec3::new(-5.0, 0.0, 5.0)];
        let mut triangles = vec![Triangle::new([floor[0], floor[2], floor[1]], [Vec3::Y; 3], 0), Triangle::new([floor[0], floor[3], floor[2]], [Vec3::Y; 3], 0)];
        let segments = 2 * rings;
        let at = |i: usize, j: usize| {
            let (theta, phi) = (PI * i as f32 / rings as f32, 2.0 * PI * (j % segments) as f32 / segments as f32);
            centre + r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin())
        };
        for i in 0..rings {
            for j in 0..segments {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                for [p, q, s] in [[a, b, c], [a, c, d]] {
                    // Emission is one-sided: the front faces the way asked.
                    let out = (q - p).cross(s - p).dot(p + q + s - 3.0 * centre) >= 0.0;
                    let corners = if out == outward { [p, q, s] } else { [p, s, q] };
                    let t = Triangle::new(corners, [Vec3::ZERO; 3], 1);
                    if t.area() > 0.0 {
                        triangles.push(Triangle::new(corners, [t.cross().normalize(); 3], 1));
                    }
                }
            }
        }
        let materials = vec![
            Material { metallic: 0.0, specular: 0.0, ..Material::default() },
            Material { metallic: 0.0, specular: 0.0, emission: Vec3::ONE, ..Material::default() },
        ];
        let camera = crate::camera::Camera::from_world("c".into(), &glam::Mat4::from_translation(glam::Vec3::new(0.0, 1.0, 3.0)), 1.0, None).unwrap();
        Scene::new(triangles, materials, camera)
    }

    /// n_T traced in batches gives each sample index the splats, vertices
    /// and rays of n_T traced at once, in the same order: a render that
    /// takes a large image's subpaths a batch at a time (render.rs) adds
    /// the same light, whatever the batches' edges (here across blocks).
    #[test]
    fn subpaths_traced_in_batches_are_those_traced_at_once() {
        use crate::pixel_filter::PixelFilter;
        let scene = diffuse_cornell_box(true);
        let (ctx, _) = Context::new(&scene);
        let prepared = crate::integrator::prepare_materials::<crate::bsdf::principled::PrincipledBsdf>(&scene);
        let lens = scene.camera.lens(32, 32);
        let filter = PixelFilter::default();
        let tracing = LightTracing { lens: &lens, filter: &filter, width: 32, height: 32, subpaths: 3000.0, mis_scale: 0.7, strategies: Default::default() };
        let trace = |batch: Range<u32>| LightVertices::for_samples::<crate::bsdf::principled::PrincipledBsdf>(&ctx, &prepared, Some(&tracing), 5, 3..5, batch, 700, 8, 0.7, None, true);
        let (whole, whole_splats, whole_rays) = trace(0..3000);
        let (first, mut splats, mut rays) = trace(0..1500);
        let (rest, rest_splats, rest_rays) = trace(1500..3000);
        rays.add(&rest_rays);
        for (s, more) in splats.iter_mut().zip(rest_splats) {
            s.extend(more);
        }
        let bits = |v: &[Vec<Splat>]| v.iter().map(|s| s.iter().map(|p| (p.pixel, p.value.to_array().map(f32::to_bits))).collect::<Vec<_>>()).collect::<Vec<_>>();
        assert!(whole_splats.iter().all(|s| s.len() > 100), "{:?}", whole_splats.iter().map(Vec::len).collect::<Vec<_>>());
        assert_eq!(bits(&splats), bits(&whole_splats));
        assert_eq!((rays.bounce, rays.shadow), (whole_rays.bounce, whole_rays.shadow));
        // Vertices come from the first 700 subpaths, all in the first batch.
        assert!(rest.iter().all(|v| v.vertices.is_empty()));
        for (a, b) in first.iter().zip(&whole) {
            assert_eq!(a.vertices.len(), b.vertices.len());
            assert!(a.vertices.iter().zip(&b.vertices).all(|(x, y)| x.p == y.p && x.alpha == y.alpha));
        }
    }

    /// Two cache lines: the size the connections' random picks were
    /// measured with (README, *Speed*).
    #[test]
    fn a_connection_vertex_takes_128_bytes() {
        assert_eq!(std::mem::size_of::<ConnectionVertex>(), 128);
    }
}
