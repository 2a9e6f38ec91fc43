//! Light vertices: the first surface point y1 of short light subpaths
//! (an emitter point y0, a cosine-weighted ray from it, the surface it
//! meets), which camera vertices z connect to with a shadow ray. This is
//! bidirectional path tracing's s = 2 strategy, and the one that reaches
//! light a surface sends on from where only the emitter sees it: the
//! ceiling above a lamp that hangs just below it, which the room sees only
//! through the slit, or the patch of a floor a sphere reflects a lamp onto.
//! Camera paths find such a patch only by chance; light subpaths land on it
//! in proportion to the light it gets.
//!
//! A connection's estimate, with the camera side's throughput β at z:
//!
//!   β · f_z · |cos_z| · |cos_y1|/d² · f_y1 · (|ns·wi| / |ng·wi|)_y1 · α
//!
//! where α = Le·π / p_y0 is the subpath's weight (Le·|cos_y0| over the
//! density p_y0 of its start and p_ω = |cos_y0|/π of its direction; the
//! ratio of cosines at y1 keeps the camera side's measure with shading
//! normals), and f_y1 is evaluated with wo toward z, as a camera path
//! through z and y1 would. It is weighted by the power heuristic against
//! the two strategies of a camera path that reaches the same y1 from z:
//! light sampling at y1 (pdf p_light) and a BSDF sample at y1 that hits
//! y0 (p_bsdf). In y1's solid angle towards y0 the three densities are
//! p_light, p_bsdf and q = p_y0 · d² / (π · p_z), p_z being z's BSDF
//! density of the direction to y1 (integrator.rs carries the same q).
//!
//! Subpaths are drawn per sample index, `PER_SAMPLE` of them, each camera
//! vertex taking one at random: for one pixel sample that is one
//! independent subpath, so each pixel's noise is what a subpath of its
//! own would give, for a fraction of the rays.

use crate::accel::Hit;
use crate::integrator::{Context, SurfaceHit};
use crate::rng::Rng;
use crate::traversal_bench::RayKind;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// A light subpath's first surface point.
pub struct LightVertex {
    /// y1 as its ray met it: `ng` faces the emitter.
    pub hit: SurfaceHit,
    /// The interpolated shading normal on `ng`'s side (zero where none):
    /// the frame is made once the viewer z is known.
    pub ns: Vec3,
    /// Unit direction from y1 back to y0.
    pub to_light: Vec3,
    /// Le·π / p_y0, the subpath's throughput.
    pub alpha: Vec3,
    /// Light sampling's density per steradian at y1 of reaching y0.
    pub light_pdf: f32,
    /// p_y0: `Lights::emission_density` of the emitter.
    pub emission_density: f32,
}

/// The light vertices of one sample index.
pub struct LightVertices {
    vertices: Vec<LightVertex>,
    /// Subpaths traced, counting those that made no vertex (a pick of a
    /// punctual light, a ray that left the scene).
    traced: u32,
}

/// Light subpaths per sample index at most; fewer on small images, which
/// have fewer camera vertices to share them.
pub const PER_SAMPLE: u32 = 1024;

impl LightVertices {
    /// One sample index's subpaths, from `count` starts.
    pub fn trace(ctx: &Context, seed: u64, sample: u64, count: u32, rays: &mut u64) -> Self {
        let mut vertices = Vec::with_capacity(count as usize);
        for j in 0..count {
            // Numbers of their own, apart from the camera paths'.
            let mut rng = Rng::for_sample(seed ^ 0x6C69_6768_745F_7061, j as u64, sample);
            let (u_pick, u_point) = rng.next_1d_2d();
            let Some(start) = ctx.lights.sample_emission(ctx.scene, u_pick, u_point, rng.next_2d()) else { continue };
            *rays += 1;
            let Some(hit) = ctx.intersect(start.origin, start.dir, RayKind::Bounce, &mut rng) else { continue };
            if let Some(v) = vertex(ctx, &start, &hit) {
                vertices.push(v);
            }
        }
        LightVertices { vertices, traced: count }
    }

    /// Every sample index of `samples`' vertices, traced in parallel.
    pub fn for_samples(ctx: &Context, seed: u64, samples: Range<u32>, count: u32) -> (Vec<Self>, u64) {
        let traced: Vec<(Self, u64)> = samples
            .into_par_iter()
            .map(|s| {
                let mut rays = 0;
                (Self::trace(ctx, seed, s as u64, count, &mut rays), rays)
            })
            .collect();
        let rays = traced.iter().map(|t| t.1).sum();
        (traced.into_iter().map(|t| t.0).collect(), rays)
    }

    /// One subpath's vertex, uniformly over those traced (`u` a uniform
    /// 32-bit number): None for a subpath that made none, so that each
    /// vertex stands for one subpath's worth of light.
    #[inline]
    pub fn pick(&self, u: u32) -> Option<&LightVertex> {
        self.vertices.get(((u as u64 * self.traced as u64) >> 32) as usize)
    }
}

/// The vertex a subpath's ray makes where it hits.
fn vertex(ctx: &Context, start: &crate::lights::EmissionSample, hit: &Hit) -> Option<LightVertex> {
    let (hit_point, ns) = SurfaceHit::with_normal(ctx.scene, hit, start.dir);
    let to_light = -start.dir;
    let cos_light = start.normal.dot(start.dir);
    let dist2 = hit.t * hit.t;
    let light_pdf = ctx.lights.pdf_emitter(ctx.scene, start.triangle, hit_point.p, dist2, cos_light);
    let alpha = start.le * (std::f32::consts::PI / start.density);
    (alpha.is_finite() && light_pdf.is_finite() && start.density > 0.0).then_some(LightVertex {
        hit: hit_point,
        ns,
        to_light,
        alpha,
        light_pdf,
        emission_density: start.density,
    })
}
