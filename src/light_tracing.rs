//! Light tracing: a light subpath's vertex y_k joined to the camera by a
//! shadow ray and added to the pixel it appears in (bidirectional path
//! tracing's t = 1 strategies). It is the one way to a caustic that does not
//! depend on luck: light a gold sphere reflects onto a wall lands there in
//! proportion to it, where a camera path through the wall finds it only when
//! its diffuse bounce happens to meet the small patch of the sphere that
//! mirrors the lamp, and then carries a firefly.
//!
//! A subpath's estimate of the pixel's value ∫ W L dω (camera.rs' W), per
//! subpath of the n_T a sample index traces:
//!
//!   W(ω) · |ng·ω|/d² · f_yk(→ camera, → y_{k−1}) · (|ns·wi| / |ng·wi|)_yk · α_k / n_T
//!
//! with α_k and the ratio of cosines as in light_paths.rs.
//!
//! MIS. The camera path through the same pixel makes the same path from
//! x1 = y_k: the strategies are those of a camera path whose z is x1
//! (light_paths.rs), now four. Their densities over this one's are the
//! ratio of the camera's density per unit area at y_k (W·|ng·ω|/d²) to the
//! subpath's (`generated`), n_T times, and then the same per-vertex ratios
//! a connection from z = y_k to y_{k−1} would use. Only where a camera path
//! would have its z at x1 (a surface that `connects_from`, not glass or a
//! glossy metal) do light vertices reach the camera, so that both sides
//! agree which paths this strategy makes.

use crate::bsdf::Bsdf;
use crate::camera::Lens;
use crate::integrator::{bsdf_at, connects_from, shading_normal_for, Context};
use crate::light_paths::LightVertex;
use crate::pixel_filter::PixelFilter;
use crate::rng::Rng;
use crate::strategies::{Strategies, Strategy};
use crate::sampling::Frame;
use crate::Vec3;

/// Light added to one pixel by one light vertex.
#[derive(Clone, Copy, Debug)]
pub struct Splat {
    pub pixel: u32,
    pub value: Vec3,
}

/// What every splat of a render shares.
pub struct LightTracing<'a> {
    pub lens: &'a Lens<'a>,
    /// The pixel filter: a vertex adds to every pixel whose filter covers
    /// where it appears (pixel_filter.rs).
    pub filter: &'a PixelFilter,
    pub width: u32,
    pub height: u32,
    /// n_T: subpaths per sample index that reach the camera.
    pub subpaths: f32,
    /// M over the connections a camera path makes (light_paths.rs).
    pub mis_scale: f32,
    /// Whether a splat's light counts (strategies.rs): checked last, so
    /// that the splats left out draw the same numbers.
    pub strategies: Strategies,
}

impl LightTracing<'_> {
    /// Vertex `v` seen by the camera, MIS-weighted, added to `out` for
    /// each pixel it reaches, if it is in view and unblocked: with the
    /// one-pixel box, the pixel it appears in; with a wider filter, each
    /// pixel p within reach, the light weighted by F_p there and the
    /// camera's density for p's samples, p_camera·F_p, in its MIS weight
    /// (as the camera path through p weighs it). One shadow ray for all.
    pub fn splat<B: Bsdf>(&self, ctx: &Context, prepared: &[Option<[B::Prepared; 2]>], v: &LightVertex, rng: &mut Rng, rays: &mut u64, out: &mut Vec<Splat>) {
        let y = &v.hit;
        // The camera does not see a surface hidden from it.
        if (v.first && v.sampled) || !connects_from(&y.surface) || (ctx.features.hidden_from_camera > 0 && ctx.scene.materials[y.material as usize].hidden_from_camera) {
            return;
        }
        // A point of the aperture to see y from, where the camera has one.
        let aperture = if self.lens.has_aperture() { rng.next_2d() } else { glam::Vec2::ZERO };
        let unit_box = self.filter.is_unit_box();
        let Some(seen) = self.lens.project(y.p, aperture, if unit_box { 0.0 } else { self.filter.radius() }) else {
            return;
        };
        if unit_box && seen.pixel.is_none() {
            return;
        }
        let w = seen.to_camera;
        let cos_y = w.dot(y.ng);
        // The camera on the side y's light came from, off y's plane by
        // more than its rounding.
        if !(cos_y > 0.0 && seen.distance * cos_y > y.ng.abs().dot(y.p_error)) {
            return;
        }
        let frame = Frame::from_normal(shading_normal_for(v.ns, y.ng, w));
        let (wo_y, wi_y) = (frame.to_local(w), frame.to_local(v.to_prev));
        if !(wi_y.z > 0.0 && wo_y.z > 0.0) {
            return;
        }
        let (f_y, pdf_y) = bsdf_at::<B>(prepared, y, &frame, wo_y).evaluate(wo_y, wi_y);
        if f_y == Vec3::ZERO {
            return;
        }
        // The camera's density per unit area at y, per pixel sample.
        let p_camera = seen.density.at(cos_y, seen.distance * seen.distance);
        let start = out.len();
        match seen.pixel.filter(|_| unit_box) {
            Some(pixel) => {
                let value = f_y * v.alpha * (p_camera * wi_y.z / (v.to_prev.dot(y.ng) * self.subpaths));
                let weight = 1.0 / (1.0 + self.others_over_this(v, p_camera, pdf_y));
                let value = value * weight;
                if crate::render::sample_fits(value) && weight > 0.0 {
                    out.push(Splat { pixel, value });
                }
            }
            None => {
                let light = f_y * v.alpha * (wi_y.z / (v.to_prev.dot(y.ng) * self.subpaths));
                self.filter.reach(seen.image, self.width, self.height, |pixel, f| {
                    let p_pixel = p_camera * f;
                    let value = light * p_pixel / (1.0 + self.others_over_this(v, p_pixel, pdf_y));
                    if crate::render::sample_fits(value) && value != Vec3::ZERO {
                        out.push(Splat { pixel, value });
                    }
                });
            }
        }
        if out.len() == start {
            return;
        }
        *rays += 1;
        if !ctx.clear_to_camera(y.spawn_origin(w), &seen, rng) || !self.strategies.keeps(Strategy::Tracing, v.depth) {
            out.truncate(start);
        }
    }

    /// Σ (p_s/p_T)² over the other strategies that make the path: the
    /// camera path's connection from x1 = y_k to y_{k−1} (C, k ≥ 2), its
    /// light sample (N) and its BSDF sample hitting the emitter (U). c is
    /// the density ratio at y_k; `pdf_y` the camera-side BSDF pdf at y_k
    /// toward y_{k−1}, which with `back` makes the ratio at y_{k−1} a
    /// connection from y_k would see (light_paths.rs' `to_z`).
    /// Where y_k is y1 through delta lobes (light_paths.rs, `DeltaStart`)
    /// only U makes the path too: x1 = y1 joins no vertex through the
    /// lobes, and light sampling does not see through them.
    fn others_over_this(&self, v: &LightVertex, p_camera: f32, pdf_y: f32) -> f32 {
        let c = p_camera / (self.subpaths * v.generated);
        let to_z = pdf_y * v.back;
        if v.first {
            let unidirectional = c * to_z;
            return unidirectional * unidirectional;
        }
        let light = c * to_z * v.prefix;
        let unidirectional = light * v.to_unidirectional;
        let (connection, light) = (c / self.mis_scale, if v.sampled { light } else { 0.0 });
        connection * connection + light * light + unidirectional * unidirectional
    }
}
