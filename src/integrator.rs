//! The path tracer, generic over the BSDF model:
//!
//!   L = L_emit + L_dir + L_indir
//!
//! * L_emit: emission seen directly, added at the camera ray's hit only,
//!   and the World (environment.rs) seen by a camera ray that escapes.
//! * L_dir: next-event estimation. A light is picked by the light tree
//!   (by power where there is one), the World by its share of the
//!   irradiance at the point (lights.rs; the seed sampled emitters by area,
//!   1/A_total). On an emitting triangle a point x' has pdf_A =
//!   P(triangle | x)/A (π·lum(Le)/P_total by power) and is joined by a
//!   shadow ray:
//!   `L_e(x'→x) · f(wo, wi) · cosθ · cosθ' / |x' − x|² / pdf_A`
//!   or, where the triangle is close, its direction is drawn over the
//!   triangle's solid angle Ω with p_pick/Ω per steradian:
//!   `L_e(x'→x) · f(wo, wi) · cosθ / pdf_ω`
//!   (lights.rs gives every light sample's density per steradian).
//!   A point, spot or sun light gives f · cosθ · E / p_pick (punctual.rs).
//!   A sized one (a disk, sphere or sun cone) is also hit by BSDF rays and
//!   weighted like an emitter below, p_light = p_pick · pdf_ω.
//!   The World gives L_w(wi) · f · cosθ / (p_pick · pdf(wi)), wi drawn from
//!   its own distribution, with a shadow ray to infinity.
//! * L_indir: a direction sampled from the BSDF, weighted by f·cosθ/pdf and
//!   traced on. A BSDF-sampled ray that hits an emitter adds no emission:
//!   that light was already counted by L_dir.
//! * With MIS, the path's first vertex z that is not a glossy metal or
//!   glass also joins `CONNECTIONS` vertices y_k of light subpaths
//!   (light_paths.rs): a third way to the same light, whose density each
//!   deeper vertex carries in `Chain` for the two strategies' weights.
//! * Russian roulette from depth `RR_START_DEPTH` on, surviving with
//!   probability q = min(√(max channel of the throughput β / 0.2), 0.95):
//!   a path is hardly ever ended while β ≥ 0.2; `max_depth` caps the number
//!   of scattering events (1 = direct light only).
//!
//! With `mis` on (Veach 1997), both strategies count emitters and each
//! contribution is weighted by the power heuristic w = p²/(p² + p_other²),
//! both pdfs in solid angle: p_light = pdf_A r² / |cosθ'| (or p_pick/Ω) for
//! the light sampling above, p_bsdf from the BSDF. At the last vertex
//! `max_depth` allows, the BSDF ray is still traced, for the light it
//! reaches only (Cycles' "terminate after transparent"): without it that
//! vertex's light sample would take the whole weight, and a direct-light-only
//! render (max_depth 1) of a World-lit floor was ~1000× noisier than
//! Cycles'. A ray from a delta
//! lobe (a perfect mirror) is the only strategy that can reach the emitter
//! it hits, so that emission takes weight 1; light samples see f = 0 there.
//!
//! Glass transmits: a light behind the surface counts when the BSDF has a
//! transmission lobe (f is zero below the surface otherwise), every cosine
//! is |cosθ|, and a direction must leave on the side of the geometric
//! surface its shading-frame form says (`same_side`). Shadow rays stop at
//! glass, as in Cycles: light reaches what glass covers only along BSDF
//! samples (caustics).

use crate::accel::{Accel, Hit};
use crate::camera::{CameraDensity, CameraRay};
use crate::camera_hits::FirstHit;
use crate::bsdf::{Bsdf, BsdfSample};
use crate::features::{Features, Kernel};
use crate::caustic_guide::{CausticGuide, Near};
use std::sync::Arc;
use crate::light_paths::{carries_light_paths, ConnectionVertex};
use crate::light_cache::Site;
pub use crate::light_paths::LightVertices;
use crate::lights::{LightChoice, LightSample, Lights, Picked};
use crate::traversal_bench::{RayKind, RayLog, TracedRay};
use crate::punctual::PunctualKind;
use crate::material::{Material, Rays, Surface};
use crate::media::{self, Media, Sides};
use crate::render::{LightPaths, RenderSettings};
use crate::rng::Rng;
use crate::sampling::Frame;
use crate::scene::Scene;
use crate::shading::{self, Barycentric};
use crate::photons::Photons;
use crate::strategies::{Strategies, Strategy};
use crate::environment;
use glam::Vec2;
use crate::Vec3;

pub const RR_START_DEPTH: u32 = 3;
/// Light vertices z joins, each with a shadow ray (light_paths.rs). On the
/// benchmark scenes at 64 spp, two against one: 15% and 4% less error for
/// 5% and no more time; three: 8% and 5% less again for 15% and 5% more.
pub(crate) const CONNECTIONS: u32 = 2;
/// Light vertices z joins where z is not x1, the camera having seen a
/// glossy metal or glass first: there the paths are mostly a caustic seen
/// in a reflection (camera → gold → floor → gold → lamp), which every
/// strategy finds only by luck — a connection when its light vertex lies
/// where the lobe at it points — and only the pixels that show such a
/// surface pay. M (mis_scale) counts connections, so the weights of every
/// path through such a z use M·CONNECTIONS/DEEP_CONNECTIONS. Against 2
/// (256², 64 spp, 4–6 seeds; relMSE, instructions per render): gold sphere
/// 16: −31% error for +6% instructions, 32: −40% for +12%, 64 and 128 no
/// better per unit of time; Cornell box 16: −8% for +4%, 32: −13% for +9%.
pub(crate) const DEEP_CONNECTIONS: u32 = 16;
/// The throughput under which Russian roulette starts ending paths.
pub(crate) const RR_THRESHOLD: f32 = 0.2;
pub(crate) const RR_MAX_SURVIVAL: f32 = 0.95;

/// Everything a render reads: the scene and what is built from it.
pub struct Context<'a> {
    pub scene: &'a Scene,
    /// Surfaces: what rays stop at and what casts shadows.
    pub accel: Accel,
    /// Lamps: seen by camera and BSDF rays for their emission only (empty
    /// without area lights, when a query costs one branch).
    pub lamps: Accel,
    pub lights: Lights,
    /// What the scene uses, which picks the kernel.
    pub features: Features,
    /// Where a benchmark keeps the rays traced (traversal_bench.rs); None
    /// in every render a user asks for.
    pub ray_log: Option<RayLog>,
    /// Find camera rays' first hits among the triangles binned to their
    /// tile (camera_hits.rs) where that is cheaper than the BVH; tests
    /// turn it off to compare.
    pub bin_camera_rays: bool,
    /// `light_paths_pay`, found once when first asked.
    light_paths_pay: std::sync::OnceLock<bool>,
    /// The caustic guide (caustic_guide.rs) of the last render that asked
    /// for one (`KeptGuide`): progressive passes share it.
    caustic_guide: std::sync::Mutex<Option<KeptGuide>>,
    /// Some emitter lies inside an absorbing medium (media.rs).
    emitters_in_media: bool,
}

/// A caustic guide by the subpaths, depth and BSDF kernel it was made
/// for: a render's image is a function of its own settings, whatever the
/// same process rendered before.
type KeptGuide = ((u32, u32, &'static str), Option<Arc<CausticGuide>>);

impl<'a> Context<'a> {
    pub fn new(scene: &'a Scene) -> (Self, std::time::Duration) {
        let (lamps, surfaces): (Vec<u32>, Vec<u32>) = (0..scene.triangles.len() as u32).partition(|&i| scene.is_lamp(&scene.triangles[i as usize]));
        let (accel, surface_time) = Accel::build_subset(&scene.triangles, &surfaces);
        let (lamps, lamp_time) = Accel::build_subset(&scene.triangles, &lamps);
        let lights = Lights::new(scene);
        let features = Features::of(scene);
        let emitters_in_media = features.absorbing > 0 && media::emitters_inside(scene, &accel, &lights.triangles);
        let mut ctx = Context { scene, accel, lamps, lights, features, ray_log: None, bin_camera_rays: true, light_paths_pay: Default::default(), caustic_guide: Default::default(), emitters_in_media };
        // Where suns start light subpaths needs the BVH (sun_cells.rs).
        Lights::place_sun_starts(&mut ctx);
        (ctx, surface_time + lamp_time)
    }

    /// The kernel these settings run on this scene.
    pub fn kernel(&self, settings: &RenderSettings) -> Kernel {
        Kernel::choose(&self.features, &self.lights, settings.bsdf, settings.features)
    }

    /// The line every render starts with: what the scene uses, what runs.
    pub fn features_line(&self, settings: &RenderSettings) -> String {
        let light_paths = if self.traces_light_paths(settings) { " + light paths" } else { "" };
        let tree = match self.lights.tree_size() {
            0 => String::new(),
            n if self.lights.tree_cached() => format!(" + light tree ({n} lights, picked from a grid)"),
            n => format!(" + light tree ({n} lights)"),
        };
        format!("features: {}; kernel: {}{light_paths}{tree}", self.features, self.kernel(settings))
    }

    /// Whether a render connects to light subpaths (light_paths.rs): they
    /// need emitting triangles or point or spot lights to start from, MIS
    /// to weigh them, and room for a connection's two scattering events.
    pub fn traces_light_paths(&self, settings: &RenderSettings) -> bool {
        // Not from an emitter inside an absorbing medium (media.rs), nor
        // where some rays pass surfaces: a subpath's rays have no kind
        // (Blender's Ray Visibility) until the camera's side is known; nor
        // with a light that casts no shadow, whose light samples alone
        // see through what its other strategies meet.
        let kernel = self.kernel(settings);
        let possible = settings.mis && settings.max_depth >= 2 && (kernel.area || kernel.punctual) && self.lights.starts_subpaths(self.scene) && !self.emitters_in_media && self.features.hidden_from_rays.is_empty() && self.features.shadowless == 0;
        possible
            && match settings.light_paths {
                LightPaths::On => true,
                LightPaths::Off => false,
                LightPaths::Auto => self.light_paths_pay(),
            }
    }

    /// Whether light subpaths go on through the delta lobes (glass,
    /// mirrors) their light meets before anything else
    /// (light_paths.rs, `DeltaStart`), and camera paths weigh the light
    /// their BSDF samples reach through such lobes against them
    /// (`Through`): where some surface may have a delta lobe. Through
    /// absorbing glass the subpaths keep what the medium leaves
    /// (`Media`), which starts empty at their lights: none lies inside
    /// one (`emitters_in_media`).
    #[inline]
    pub(crate) fn delta_starts(&self) -> bool {
        self.features.delta_lobes && !self.emitters_in_media
    }

    /// Whether the scene has absorbing glass and a kernel for it, whose
    /// paths keep their media (media.rs).
    #[inline]
    pub(crate) fn absorbs<B: Bsdf>(&self) -> bool {
        B::GLASS && self.features.absorbing > 0
    }

    /// The caustic guide of `count` subpaths of depth up to `max_depth`
    /// (light_paths.rs, `caustic_arrivals`), made once for a render's
    /// passes, and the rays made for it (0 where it was made before).
    pub(crate) fn caustic_guide<B: Bsdf>(&self, prepared: &[Option<[B::Prepared; 2]>], count: u32, max_depth: u32) -> (Option<Arc<CausticGuide>>, u64) {
        let mut kept = self.caustic_guide.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((key, guide)) = kept.as_ref() {
            if *key == (count, max_depth, std::any::type_name::<B>()) {
                return (guide.clone(), 0);
            }
        }
        let (arrivals, rays) = LightVertices::caustic_arrivals::<B>(self, prepared, count, max_depth);
        let guide = CausticGuide::new(&arrivals).map(Arc::new);
        *kept = Some(((count, max_depth, std::any::type_name::<B>()), guide.clone()));
        (guide, rays)
    }

    /// Whether light subpaths find light here that camera paths reach
    /// only by chance, the four ways known: a glossy surface that focuses
    /// light into caustics (`Features::focusing`); emitters whose light
    /// first lands near them — the ceiling above a hanging two-sided lamp,
    /// a slit, a shade, the floor around a glowing object —, a bright patch
    /// light sampling does not know of (`light_paths::Landing::near`); a
    /// scene open to the World on some sides, whose indirect light a BSDF
    /// sample finds only part of the time (`Landing::onward`: a ball in
    /// the corner of two walls under a lamp, 1.8× less error × time with
    /// them at 16 spp), where the emitters give most of the light their
    /// own lands in (`Landing::emitters`: not a lamp in daylight); or a
    /// lamp with a Spread, whose grid throws its light onto
    /// such a patch wherever it lands (a 0.6 m lamp 3 m over a matte floor
    /// and ball, 4 spp: 51×, 13× and 2.4× less error × time with them at
    /// 20°, 90° and 150°, where the near share had left them out).
    /// Elsewhere they cost time for no less error: in the benchmark's hall
    /// (32 area lights under the ceiling, one Lambertian grey) 20% of the
    /// time for error within ±6% at 1–16 spp, in a closed 4 m room 1.07×
    /// the error × time, on a bare floor 1.25×. Where they pay, they can
    /// pay severalfold: the Cornell box with its lamp two-sided had 7–10×
    /// the error × time without them with the lamp 1 cm under the ceiling,
    /// 3.6–4.6× with it 30 cm under.
    /// Found once, before a render's clock starts (its features line asks).
    pub fn light_paths_pay(&self) -> bool {
        *self.light_paths_pay.get_or_init(|| self.features.focusing || self.scene.materials.iter().any(|m| m.spread.is_some()) || crate::light_paths::landing(self).pays())
    }

    /// The closest surface a ray stops at: with alpha in the scene, a
    /// surface it passes through (MASK, BLEND; shading.rs) is skipped as the
    /// traversal meets it.
    #[inline]
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, kind: RayKind, rng: &mut Rng) -> Option<Hit> {
        self.intersect_between(o, d, 0.0, f32::INFINITY, kind, rng)
    }

    /// `intersect`, from `tmin` to `tmax` (a camera ray's Clip Start and
    /// End).
    #[inline]
    pub(crate) fn intersect_between(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, kind: RayKind, rng: &mut Rng) -> Option<Hit> {
        if let Some(log) = &self.ray_log {
            log.push(TracedRay { kind, origin: o, dir: d, tmax, skip: u32::MAX });
        }
        let hidden = kind == RayKind::Camera && self.features.hidden_from_camera > 0;
        if self.features.alpha == 0 && tmin == 0.0 && !hidden {
            return self.accel.intersect(o, d, tmax);
        }
        self.intersect_passing(o, d, tmin, tmax, |triangle| hidden && self.hidden_from_camera(triangle), rng)
    }

    /// `intersect_between` where the ray passes some surfaces: those with
    /// alpha as they decide, before `tmin`, and those `hidden` from it.
    /// Out of line: inlined, it made every bounce's `intersect` too long to
    /// inline in turn (1% more instructions on the benchmark's gold
    /// sphere, which has none of these).
    #[inline(never)]
    fn intersect_passing(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, hidden: impl Fn(u32) -> bool, rng: &mut Rng) -> Option<Hit> {
        self.accel.intersect_where(o, d, tmax, |triangle, t, b1, b2| t >= tmin && self.stops_at(triangle, b1, b2, hidden(triangle), rng))
    }

    /// Whether a ray stops at a point of `triangle` (barycentrics `b1`,
    /// `b2`): not if the triangle is `hidden` from it, and with alpha in
    /// the scene, where the surface draws it opaque there.
    #[inline]
    fn stops_at(&self, triangle: u32, b1: f32, b2: f32, hidden: bool, rng: &mut Rng) -> bool {
        !hidden && (self.features.alpha == 0 || shading::stops_ray(self.scene, triangle, b1, b2, &mut || rng.next_f32()))
    }

    /// The closest surface a BSDF sample's ray of kind `ray` (a set of
    /// one, `Rays`) stops at: it passes those hidden from its kind.
    #[inline]
    pub(crate) fn intersect_scattered(&self, o: Vec3, d: Vec3, ray: Rays, rng: &mut Rng) -> Option<Hit> {
        if !self.features.hidden_from_rays.meets(Rays::SCATTERED) {
            return self.intersect(o, d, RayKind::Bounce, rng);
        }
        if let Some(log) = &self.ray_log {
            log.push(TracedRay { kind: RayKind::Bounce, origin: o, dir: d, tmax: f32::INFINITY, skip: u32::MAX });
        }
        self.intersect_passing(o, d, 0.0, f32::INFINITY, |triangle| self.hidden_from(triangle, ray), rng)
    }

    /// Whether rays of kind `ray` pass triangle `triangle`.
    #[inline]
    fn hidden_from(&self, triangle: u32, ray: Rays) -> bool {
        self.scene.material_of(triangle).hidden_from_rays.meets(ray)
    }

    /// Whether camera rays pass triangle `triangle` (its object is hidden
    /// from the camera).
    #[inline]
    pub(crate) fn hidden_from_camera(&self, triangle: u32) -> bool {
        self.scene.material_of(triangle).hidden_from_camera
    }

    /// Whether nothing blocks the way from `origin` to the lens point a
    /// projection `seen` found, up to Clip Start (camera rays see nothing
    /// nearer): light tracing's test, and the sun cells'.
    pub(crate) fn clear_to_camera(&self, origin: Vec3, seen: &crate::camera::Seen, rng: &mut Rng) -> bool {
        let to_camera = seen.lens_point - origin;
        let length = to_camera.length();
        let clear = length - seen.skipped;
        clear > 0.0 && !self.occluded_toward_camera(origin, to_camera / length, clear, rng)
    }

    /// Whether the way from a point to the camera is blocked: a shadow ray
    /// that passes what is hidden from the camera, as camera rays do.
    #[inline]
    pub(crate) fn occluded_toward_camera(&self, o: Vec3, d: Vec3, tmax: f32, rng: &mut Rng) -> bool {
        if self.features.hidden_from_camera == 0 {
            return self.occluded(o, d, tmax, u32::MAX, rng);
        }
        if let Some(log) = &self.ray_log {
            log.push(TracedRay { kind: RayKind::Shadow, origin: o, dir: d, tmax, skip: u32::MAX });
        }
        self.accel.occluded_except_where(o, d, tmax, u32::MAX, |triangle, b1, b2| self.stops_at(triangle, b1, b2, self.hidden_from_camera(triangle), rng))
    }

    /// Whether a shadow ray is blocked, not counting triangle `skip`.
    #[inline]
    pub(crate) fn occluded(&self, o: Vec3, d: Vec3, tmax: f32, skip: u32, rng: &mut Rng) -> bool {
        if let Some(log) = &self.ray_log {
            log.push(TracedRay { kind: RayKind::Shadow, origin: o, dir: d, tmax, skip });
        }
        let hidden = self.features.hidden_from_rays.meets(Rays::SHADOW);
        if self.features.alpha == 0 && !hidden {
            return self.accel.occluded_except(o, d, tmax, skip);
        }
        self.accel.occluded_except_where(o, d, tmax, skip, |triangle, b1, b2| self.stops_at(triangle, b1, b2, hidden && self.hidden_from(triangle, Rays::SHADOW), rng))
    }
}

#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    pub camera: u64,
    pub bounce: u64,
    pub shadow: u64,
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
    pub fn add(&mut self, o: &RayCounts) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
    }
}

/// γ(n) of Higham / pbrt: a bound on the relative error of n float operations.
fn gamma(n: f32) -> f32 {
    let e = f32::EPSILON * 0.5;
    n * e / (1.0 - n * e)
}

/// Move a point off its surface by its floating-point error bound, to the
/// side `w` leaves on, then one ulp further: the spawned ray cannot hit the
/// surface it starts on, at any scale (pbrt-v4's OffsetRayOrigin). The ulp
/// step follows the normal, not the offset, so an exactly representable
/// point (error bound 0) still leaves its plane.
#[inline]
pub fn offset_origin(p: Vec3, error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let side = if w.dot(n) < 0.0 { -n } else { n };
    ulp_step(p + side * n.abs().dot(error), side)
}

/// The least magnitude `ulp_step` leaves a stepped coordinate at, 2⁻¹⁰⁰.
/// One ulp from 0 is a subnormal float (1.4e-45), and a floor at y = 0
/// sent every ray it spawned from one: each box and triangle test
/// subtracting or multiplying it made another subnormal, which Intel cores
/// compute in microcode, a hundred cycles an operation — the lamp hall
/// took 1.75× as long on a Xeon as with them flushed to zero. Stepped to
/// 2⁻¹⁰⁰ instead, the point is still on the side it leaves to, and its
/// products with any edge or inverse direction longer than 1e-8 stay
/// normal.
const LEAST_STEP: f32 = 7.888_609e-31;

/// Each coordinate of `p` one float further toward the sign of `side`'s
/// (`next_up` / `next_down`, but never nearer 0 than `LEAST_STEP`;
/// unchanged where `side`'s is 0), in all lanes at
/// once: floats' bit patterns, read as sign and magnitude, turned into
/// integers that count ulps monotonically (±0 both 0), stepped, and turned
/// back. The per-coordinate branches had been two thirds of this function
/// and mispredicted as often as not.
#[cfg(target_arch = "x86_64")]
#[inline]
fn ulp_step(p: Vec3, side: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of x86_64's baseline.
    unsafe {
        let bits = _mm_castps_si128(p.into());
        let magnitude = _mm_set1_epi32(i32::MAX);
        let negative = _mm_srai_epi32(bits, 31);
        let m = _mm_sub_epi32(_mm_xor_si128(_mm_and_si128(bits, magnitude), negative), negative);
        // Comparisons give −1 where true: −1 − 0 below zero, 0 − (−1) above.
        let s: __m128 = side.into();
        let zero = _mm_setzero_ps();
        let step = _mm_sub_epi32(_mm_castps_si128(_mm_cmplt_ps(s, zero)), _mm_castps_si128(_mm_cmpgt_ps(s, zero)));
        let m = _mm_add_epi32(m, step);
        let negative = _mm_srai_epi32(m, 31);
        let abs = _mm_sub_epi32(_mm_xor_si128(m, negative), negative);
        let out = _mm_or_si128(abs, _mm_and_si128(negative, _mm_set1_epi32(i32::MIN)));
        // Below LEAST_STEP (magnitudes compare as their bits): ±LEAST_STEP,
        // toward `side`, where the coordinate was stepped.
        let least = _mm_set1_epi32(LEAST_STEP.to_bits() as i32);
        let tiny = _mm_andnot_si128(_mm_cmpeq_epi32(step, _mm_setzero_si128()), _mm_cmplt_epi32(abs, least));
        let toward = _mm_or_si128(least, _mm_and_si128(_mm_castps_si128(s), _mm_set1_epi32(i32::MIN)));
        let out = _mm_or_si128(_mm_and_si128(tiny, toward), _mm_andnot_si128(tiny, out));
        Vec3::from(_mm_castsi128_ps(out))
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline]
fn ulp_step(mut p: Vec3, side: Vec3) -> Vec3 {
    for i in 0..3 {
        if side[i] > 0.0 {
            p[i] = p[i].next_up();
        } else if side[i] < 0.0 {
            p[i] = p[i].next_down();
        } else {
            continue;
        }
        if p[i].abs() < LEAST_STEP {
            p[i] = LEAST_STEP.copysign(side[i]);
        }
    }
    p
}

/// A point on a triangle from barycentrics, with its error bound.
pub fn point_on_triangle(p: &[Vec3; 3], b1: f32, b2: f32) -> (Vec3, Vec3) {
    let b0 = 1.0 - b1 - b2;
    let point = p[0] * b0 + p[1] * b1 + p[2] * b2;
    let error = ((p[0] * b0).abs() + (p[1] * b1).abs() + (p[2] * b2).abs()) * gamma(7.0);
    (point, error)
}

/// What the integrator needs of a ray's hit.
#[derive(Clone)]
pub struct SurfaceHit {
    pub p: Vec3,
    pub p_error: Vec3,
    /// Geometric normal, on the side the ray came from.
    pub ng: Vec3,
    /// Shading frame; its normal is on the same side as `ng`.
    pub frame: Frame,
    /// Whether the ray hit the triangle's front (counter-clockwise) face.
    pub front_face: bool,
    pub material: u32,
    pub triangle: u32,
    pub b: Barycentric,
    /// The material here, textures applied.
    pub surface: Surface,
}

impl SurfaceHit {
    // Inlined, both build the record in the caller's frame: returned, its
    // 176 bytes were copied by a memcpy that was 1.6% of the hall's time
    // (perf); 1–3% less time per sample on the benchmark scenes.
    #[inline(always)]
    pub fn new(scene: &Scene, hit: &Hit, dir: Vec3, rng: &mut Rng) -> Self {
        Self::with_normal(scene, hit, dir, rng).0
    }

    /// `new`, and the interpolated shading normal on `ng`'s side before
    /// the fallback for a viewer below it (zero where there is none): a
    /// light vertex is viewed from elsewhere than its ray came from
    /// (`light_paths.rs`).
    /// On a Mix Shader's material (`Material::mix`) the hit takes one of
    /// its two halves, drawn by their shares: `material` and `surface`
    /// are that half's.
    #[inline(always)]
    pub fn with_normal(scene: &Scene, hit: &Hit, dir: Vec3, rng: &mut Rng) -> (Self, Vec3) {
        let tri = &scene.triangles[hit.triangle as usize];
        let mut id = tri.material;
        if scene.materials[id as usize].mix.is_some() {
            id = half_drawn(scene, id, rng);
        }
        let material = &scene.materials[id as usize];
        let b = Barycentric::new(hit.b1, hit.b2);
        let (p, p_error) = point_on_triangle(&tri.p(), hit.b1, hit.b2);
        let face = tri.cross().normalize();
        let front_face = face.dot(dir) < 0.0;
        let ng = if front_face { face } else { -face };
        let mut ns = b.mix(&tri.n()).normalize_or_zero();
        if ns != Vec3::ZERO {
            ns = shading::mapped_normal(scene, material, hit.triangle, b, ns);
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let surface = surface_facing(scene, id, hit.triangle, b, front_face);
        let frame = Frame::from_normal(shading_normal_for(ns, ng, -dir));
        (SurfaceHit { p, p_error, ng, frame, front_face, material: id, triangle: hit.triangle, b, surface }, ns)
    }

    pub fn spawn_origin(&self, w: Vec3) -> Vec3 {
        offset_origin(self.p, self.p_error, self.ng, w)
    }

    /// The media on either side of this point for a path that reached it
    /// in `here` (media.rs): the triangle's own material names the medium
    /// its mesh encloses, the one shading the point whether it is crossed.
    #[inline]
    pub fn sides(&self, scene: &Scene, here: &Media) -> Sides {
        Sides::at(here, &scene.materials, scene.triangles[self.triangle as usize].material, self.material, self.front_face)
    }
}

/// The half of Mix Shader material `id` a hit takes, drawn by its share.
#[cold]
#[inline(never)]
fn half_drawn(scene: &Scene, id: u32, rng: &mut Rng) -> u32 {
    match scene.materials[id as usize].mix {
        Some(mix) if rng.next_f32() < mix.weight => mix.with,
        _ => id,
    }
}

/// The shading normal a viewer in direction `toward_viewer` sees:
/// interpolated normals can put the viewer below the shading hemisphere
/// near silhouettes; the face normal is the honest fallback.
#[inline]
pub fn shading_normal_for(ns: Vec3, ng: Vec3, toward_viewer: Vec3) -> Vec3 {
    if ns == Vec3::ZERO || ns.dot(toward_viewer) <= 0.0 { ng } else { ns }
}

/// A surface as a ray meets it from one side: leaving a closed object
/// through its back face (glTF's front faces point out), the relative IOR
/// is inverted.
fn facing(mut surface: Surface, front_face: bool) -> Surface {
    if !front_face {
        surface.ior = 1.0 / surface.ior;
    }
    surface
}

/// The material `material` at a point of a triangle as a ray from the
/// `front_face` side meets it, textures applied.
#[inline]
pub(crate) fn surface_facing(scene: &Scene, material: u32, triangle: u32, b: Barycentric, front_face: bool) -> Surface {
    facing(shading::surface_at(scene, &scene.materials[material as usize], triangle, b), front_face)
}

/// The BSDF at a hit for outgoing direction `wo`, local to `frame` (the
/// hit's own, or one a light vertex is viewed in).
#[inline]
pub(crate) fn bsdf_at<B: Bsdf>(prepared: &[Option<[B::Prepared; 2]>], si: &SurfaceHit, frame: &Frame, wo: Vec3) -> B {
    bsdf_on::<B>(prepared, si.material, si.front_face, || si.surface, frame, wo)
}

/// The BSDF of material `material`'s face for outgoing direction `wo`
/// (local to `frame`): prepared where the material is the same
/// everywhere, else built from `surface`, the material at the point, its
/// coat's own normal (world space) turned into the frame.
#[inline]
pub(crate) fn bsdf_on<B: Bsdf>(prepared: &[Option<[B::Prepared; 2]>], material: u32, front_face: bool, surface: impl FnOnce() -> Surface, frame: &Frame, wo: Vec3) -> B {
    match &prepared[material as usize] {
        Some(faces) => B::at(&faces[!front_face as usize], wo),
        None => {
            let mut s = surface();
            if s.coat_normal != Vec3::ZERO {
                let n = frame.to_local(s.coat_normal);
                s.coat_normal = if n.z < 0.0 { -n } else { n };
            }
            if s.anisotropy > 0.0 {
                s.tangent = anisotropy_axis(frame.to_local(s.tangent), s.anisotropy_rotation);
            }
            B::new(&s, wo)
        }
    }
}

/// An anisotropic lobe's axis in the BSDF's frame from its tangent there
/// (`Surface::tangent`): set square to the normal (+z), turned about it
/// by `rotation` turns (Cycles' Anisotropic Rotation: counter-clockwise
/// seen from above), unit. Where the tangent has no part across the
/// normal (the pole of Cycles' radial field, where its own tangent is
/// undefined), any axis serves: +x.
#[inline]
pub(crate) fn anisotropy_axis(local_tangent: Vec3, rotation: f32) -> Vec3 {
    let t = Vec3::new(local_tangent.x, local_tangent.y, 0.0).normalize_or_zero();
    let t = if t == Vec3::ZERO { Vec3::X } else { t };
    let (sin, cos) = (rotation * std::f32::consts::TAU).sin_cos();
    Vec3::new(t.x * cos - t.y * sin, t.x * sin + t.y * cos, 0.0)
}

/// Each material's BSDF prepared for its front and back face
/// (`Bsdf::prepare`), where its surface is the same at every point; None
/// where textures or vertex colours make it vary.
pub fn prepare_materials<B: Bsdf>(scene: &Scene) -> Vec<Option<[B::Prepared; 2]>> {
    scene
        .materials
        .iter()
        .map(|m| (!shading::varies(scene, m)).then(|| [true, false].map(|front| B::prepare(&facing(m.surface(), front)))))
        .collect()
}

/// Whether a direction leaves on the side of the geometric surface its
/// shading-frame form `local` claims: above for reflection, below for
/// transmission. With shading normals the two can disagree, and such a
/// direction would pass through the surface it reflects from (light
/// leaking through thin walls) or reflect off one it is meant to cross.
#[inline]
pub(crate) fn same_side(si: &SurfaceHit, wi: Vec3, local: Vec3) -> bool {
    let g = wi.dot(si.ng);
    (g > 0.0 && local.z > 0.0) || (g < 0.0 && local.z < 0.0)
}

/// A light sample's direction in the shading frame, if it can reach the
/// BSDF: behind an opaque surface it is dropped before any shading work,
/// and it must pass `same_side`.
#[inline]
fn toward_light<B: Bsdf>(si: &SurfaceHit, bsdf: &B, wi: Vec3) -> Option<Vec3> {
    // `light_side` is the normal of this test.
    if wi.dot(si.ng) <= 0.0 && !bsdf.transmits() {
        return None;
    }
    let local = si.frame.to_local(wi);
    same_side(si, wi, local).then_some(local)
}

/// The normal above whose plane light can reach a vertex (`toward_light`):
/// the geometric one, or zero where the BSDF transmits and light counts
/// from both sides. The light tree bounds each light's share by it
/// (`LightTree::sample`); the light sample at a vertex and every later
/// density of one there (`Previous::light_side`) use the same.
#[inline]
fn light_side<B: Bsdf>(si: &SurfaceHit, bsdf: &B) -> Vec3 {
    if bsdf.transmits() { Vec3::ZERO } else { si.ng }
}

/// f(wo, wi) of a light sample, and the BSDF's pdf of wi where MIS needs it.
#[inline]
fn shade<B: Bsdf>(bsdf: &B, wo: Vec3, wi: Vec3, mis: bool) -> (Vec3, f32) {
    if mis { bsdf.evaluate(wo, wi) } else { (bsdf.eval(wo, wi), 0.0) }
}

/// Power heuristic (β = 2) weight of a strategy with pdf `a` against `b`.
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    power_heuristic3(a, b, 0.0)
}

/// The same against two others, `b` and `c` (a light subpath's
/// connection, light_paths.rs, is the third where it can make the path).
pub fn power_heuristic3(a: f32, b: f32, c: f32) -> f32 {
    if a.is_infinite() {
        return 1.0;
    }
    let (a2, sum) = (a * a, a * a + b * b + c * c);
    if sum > 0.0 && sum.is_finite() { a2 / sum } else if a > b.max(c) { 1.0 } else { 0.0 }
}

/// A camera path's side of the connection's MIS weight (light_paths.rs)
/// at vertex x_m (m ≥ 2) for light reached from it: the connection's
/// density in light sampling's measure is
///   p_y0 · |cos_m(wi)| · base · (m ≥ 3: pdf_rev(wi) · rev),
/// `base` the product of the ratios of light-side to camera-side densities
/// at x_2 … x_{m−2} over π·M and the camera's area density of x_m, `rev`
/// that of x_{m−1} without the reverse pdf, pdf_rev the BSDF's at x_m from
/// wi toward x_{m−1}: what the subpath would have sampled there. Where z
/// is x1, light tracing (light_tracing.rs) makes the same paths too.
struct Chain<'a, B: Bsdf> {
    prepared: &'a [Option<[B::Prepared; 2]>],
    si: &'a SurfaceHit,
    wo: Vec3,
    /// 0 where no connection could make the path.
    base: f32,
    rev: Option<f32>,
    tracing: Tracing,
}

/// Light tracing's density over the connection's at a camera vertex, for
/// a path whose z is x1: it makes x1 from x2 as well, with density
/// p_L(x1) = pdf_rev_x2 · |cos_x1|/d² per unit area, n_T times, where the
/// connection has the camera's p_cam(x1) and its 1/M.
#[derive(Clone, Copy)]
enum Tracing {
    /// Not a strategy for the paths through here, nor at x1: light that
    /// reaches x1 straight from an emitter is light sampling's to find.
    Off,
    /// At x2: n_T M |cos_x1|/(d² p_cam(x1)), times pdf_rev(wi).
    Rev(f32),
    /// Deeper: the ratio, fixed by the direction x2 sampled.
    Ratio(f32),
}

impl<B: Bsdf> Chain<'_, B> {
    /// The connection's density over p_y0·|cos| toward a direction `wi`
    /// (local) from x_m, and light tracing's over the connection's, which
    /// the vertices after x_m keep when wi is the direction taken.
    #[inline]
    fn parts(&self, wi: Vec3) -> (f32, f32) {
        if self.base == 0.0 {
            return (0.0, 0.0);
        }
        let needs_pdf = self.rev.is_some() || matches!(self.tracing, Tracing::Rev(_));
        let pdf_rev = if needs_pdf { bsdf_at::<B>(self.prepared, self.si, &self.si.frame, wi).pdf(wi, self.wo) } else { 1.0 };
        let c = self.base * self.rev.map_or(1.0, |rev| rev * pdf_rev);
        let ratio = match self.tracing {
            Tracing::Rev(k) => k * pdf_rev,
            Tracing::Ratio(k) => k,
            Tracing::Off => 0.0,
        };
        (c, ratio)
    }

    /// Both strategies' densities as one for the power heuristic, whose
    /// terms are squares: √(c² + (c·ratio)²).
    #[inline]
    fn toward(&self, wi: Vec3) -> f32 {
        let (c, ratio) = self.parts(wi);
        c * (1.0 + ratio * ratio).sqrt()
    }
}

/// Whether a surface connects to light vertices: not a glossy metal,
/// whose lobe BSDF sampling follows better than a connection's random
/// direction (on the benchmark's gold sphere, connecting from its
/// roughness-0.3 gold had cost time and 4% of the error), nor glass.
/// A camera path's z is its first vertex that does, so the path decides
/// which it is and the MIS weights of a path agree on it.
#[inline]
pub(crate) fn connects_from(surface: &Surface) -> bool {
    (surface.metallic < 0.5 || surface.roughness >= 0.5) && carries_light_paths(surface)
}

/// The connection's density (light_paths.rs) in light sampling's measure
/// at a camera vertex: the subpath density p_y0 of the emitter, times
/// `connect` (`Chain::toward`) and the cosine toward the light, where the
/// light and the previous vertex are on the same side of it (a connection
/// reflects, never transmits); and times the density of the subpath's
/// first direction over a cosine's at `cos_out`, the emitter's cosine
/// toward the vertex (1 but for a lamp with a Spread).
#[inline]
fn connection_density(ctx: &Context, connect: f32, emitter: u32, cos_to_light: f32, cos_out: f32) -> f32 {
    if connect > 0.0 && cos_to_light > 0.0 {
        let m = ctx.scene.material_of(emitter);
        ctx.lights.emission_density(m) * connect * cos_to_light * m.emission_direction_weight(cos_out)
    } else {
        0.0
    }
}

/// L_dir at one surface point: one light sample of the light `pick_light`
/// `picked` and its shadow ray, MIS-weighted against BSDF sampling when
/// `mis` is set.
#[allow(clippy::too_many_arguments)]
fn direct_light<B: Bsdf, const AREA: bool, const PUNCTUAL: bool>(ctx: &Context, si: &SurfaceHit, bsdf: &B, wo: Vec3, mis: bool, chain: &Chain<B>, picked: Option<(Picked, Vec2)>, sides: Option<&Sides>, rng: &mut Rng, rays: &mut RayCounts) -> Vec3 {
    let Some((picked, u)) = picked else { return Vec3::ZERO };
    match ctx.lights.point_on(ctx.scene, si.p, picked, u) {
        None => Vec3::ZERO,
        Some(LightChoice::World { probability }) => world_light(ctx, si, bsdf, wo, mis, probability, u, sides, rng, rays),
        Some(LightChoice::Area(ls)) if AREA => area_light(ctx, si, bsdf, wo, mis, chain, &ls, sides, rng, rays),
        Some(LightChoice::Punctual { index, probability }) if PUNCTUAL => punctual_light(ctx, si, bsdf, wo, mis, chain, index, probability, u, sides, rng, rays),
        // Not in this kernel: Kernel::choose leaves a part out only when
        // the light list has none of it.
        Some(_) => Vec3::ZERO,
    }
}

/// `light`, a light sample's, times what its shadow ray from `si` along
/// `wi` keeps over the length `t` of the medium on its side (media.rs):
/// all of it without media, and in a kernel without glass (`B::GLASS`)
/// not even a multiplication.
#[inline]
fn through_medium<B: Bsdf>(light: Vec3, sides: Option<&Sides>, si: &SurfaceHit, wi: Vec3, t: f32) -> Vec3 {
    match sides {
        Some(s) if B::GLASS => light * s.transmittance(wi.dot(si.ng), t),
        _ => light,
    }
}

/// The light `direct_light` samples at `si`, and the numbers for its point.
/// With no light at all it draws no random numbers, so a kernel that
/// leaves light sampling out sees the same random sequence. `site` is
/// where the pick reads the light grid for si's geometric normal
/// (`Lights::pick_site`), which a BSDF that transmits does not pick for.
fn pick_light<B: Bsdf>(ctx: &Context, si: &SurfaceHit, bsdf: &B, mis: bool, site: Option<Site>, rng: &mut Rng) -> Option<(Picked, Vec2)> {
    if ctx.lights.is_empty() {
        return None;
    }
    // One draw: the light's point stays stratified within each pick.
    let (u_pick, u) = rng.next_1d_2d();
    let n = light_side(si, bsdf);
    Some((ctx.lights.pick_at(site.filter(|_| n == si.ng), si.p, n, u_pick, mis)?, u))
}

/// Solid-angle pdf of light sampling (with MIS: only MIS asks) reaching
/// the World along `dir` from a point `p` with geometric normal `ng`.
fn world_pdf(ctx: &Context, p: Vec3, ng: Vec3, two_sided: bool, dir: Vec3) -> f32 {
    // A World light samples leave alone needs no table looked up.
    let probability = ctx.lights.world_probability(p, true);
    if probability == 0.0 {
        return 0.0;
    }
    probability * world_direction_pdf(ctx, p, ng, two_sided, dir, true)
}

/// The share of light samples of the World from `p` that go through the
/// portals `p` faces (portals.rs): all of them for a plain-colour World;
/// half for an environment image, whose own importance map still finds
/// its sun through a window without a portal; none without MIS (light
/// samples alone see the World then, and must look everywhere) or where
/// `p` faces no portal.
fn portal_share(ctx: &Context, p: Vec3, mis: bool) -> f32 {
    if !mis || ctx.lights.portals.is_empty() || ctx.lights.portals.solid_angle(p) == 0.0 {
        0.0
    } else if ctx.scene.environment.is_some() {
        0.5
    } else {
        1.0
    }
}

/// The solid-angle density of the World's directions drawn over the whole
/// sphere (the environment image's importance, or uniform).
fn sphere_pdf(ctx: &Context, ng: Vec3, two_sided: bool, dir: Vec3, mis: bool) -> f32 {
    match &ctx.scene.environment {
        Some(map) => map.pdf(dir, mis),
        None => environment::uniform_pdf(ng, two_sided, dir),
    }
}

/// The solid-angle density with which `world_direction` draws `dir`.
fn world_direction_pdf(ctx: &Context, p: Vec3, ng: Vec3, two_sided: bool, dir: Vec3, mis: bool) -> f32 {
    match portal_share(ctx, p, mis) {
        0.0 => sphere_pdf(ctx, ng, two_sided, dir, mis),
        1.0 => ctx.lights.portals.pdf(p, dir),
        share => share * ctx.lights.portals.pdf(p, dir) + (1.0 - share) * sphere_pdf(ctx, ng, two_sided, dir, mis),
    }
}

/// A direction toward the World from `si` and its solid-angle density:
/// through the portals for `portal_share` of the draws, else over the
/// sphere (for a uniform World, about the normal, on both sides where
/// the BSDF transmits: `two_sided`).
fn world_direction(ctx: &Context, si: &SurfaceHit, two_sided: bool, u: Vec2, mis: bool) -> Option<(Vec3, f32)> {
    let share = portal_share(ctx, si.p, mis);
    let sphere = |u: Vec2| match &ctx.scene.environment {
        Some(map) => map.sample(u, mis),
        None => Some(environment::sample_uniform(si.ng, two_sided, u)),
    };
    if share == 0.0 {
        return sphere(u);
    }
    if share == 1.0 {
        return ctx.lights.portals.sample(si.p, u);
    }
    let wi = if u.x < share {
        ctx.lights.portals.sample(si.p, Vec2::new(u.x / share, u.y))?.0
    } else {
        sphere(Vec2::new(((u.x - share) / (1.0 - share)).min(1.0 - f32::EPSILON), u.y))?.0
    };
    Some((wi, world_direction_pdf(ctx, si.p, si.ng, two_sided, wi, mis)))
}

/// One direction toward the World and its shadow ray.
#[allow(clippy::too_many_arguments)]
fn world_light<B: Bsdf>(ctx: &Context, si: &SurfaceHit, bsdf: &B, wo: Vec3, mis: bool, probability: f32, u: Vec2, sides: Option<&Sides>, rng: &mut Rng, rays: &mut RayCounts) -> Vec3 {
    let Some((wi, pdf)) = world_direction(ctx, si, bsdf.transmits(), u, mis) else { return Vec3::ZERO };
    let Some(wi_local) = toward_light(si, bsdf, wi).filter(|_| pdf > 0.0) else { return Vec3::ZERO };
    let (f, bsdf_pdf) = shade(bsdf, wo, wi_local, mis);
    let le = ctx.scene.world_radiance(wi);
    if f == Vec3::ZERO || le == Vec3::ZERO {
        return Vec3::ZERO;
    }
    rays.shadow += 1;
    if ctx.occluded(si.spawn_origin(wi), wi, f32::INFINITY, u32::MAX, rng) {
        return Vec3::ZERO;
    }
    let p_light = probability * pdf;
    let weight = if mis { power_heuristic(p_light, bsdf_pdf) } else { 1.0 };
    through_medium::<B>(le * f * (weight * wi_local.z.abs() / p_light), sides, si, wi, f32::INFINITY)
}

/// Where the current ray came from: what MIS weights of the light it
/// reaches need.
#[derive(Clone, Copy)]
struct Previous {
    /// The vertex (the camera for a camera ray, with `depth` 0).
    depth: u32,
    p: Vec3,
    /// Geometric normal there.
    ng: Vec3,
    /// `light_side` there.
    light_side: Vec3,
    /// Solid-angle pdf of the BSDF sample that produced the ray, and
    /// whether it came from a delta lobe (which light sampling cannot match).
    bsdf_pdf: f32,
    delta: bool,
    /// `Chain::toward` of the ray's direction here: the connection's
    /// share of the light the ray reaches (`connection_density`), 0 where
    /// no connection makes the path.
    connect: f32,
    /// The product of light-side to camera-side density ratios a deeper
    /// vertex's `Chain` starts from (1 at z, 0 where no connection can
    /// make the paths through this vertex), and the camera's density per
    /// unit area of this vertex.
    chain: f32,
    area_pdf: f32,
    /// What the next vertex's `Tracing` is made from: at x1 (z),
    /// n_T M / p_cam(x1); after x2, the ratio; 0 where it has no part.
    tracing: f32,
}

/// A camera vertex x_m (not glass) whose BSDF sample went on through
/// delta lobes alone (glass, mirrors): light the ray then reaches from an
/// emitter or a sized light was also made by a light subpath that went
/// through the same lobes, with x_m its y1 (light_paths.rs,
/// `DeltaStart`), by the connection from z to x2 (C) and, where z is x1,
/// by light tracing (T), and not by light sampling. The weights take the
/// ratio of their densities to the BSDF sample's as if x_m saw the light
/// straight along its sample's direction (`connection_density` with x_m's
/// cosine): the lobes' geometry and choices are the same both ways.
#[derive(Clone, Copy)]
struct Through {
    /// x_m's BSDF pdf of the direction (solid angle).
    bsdf_pdf: f32,
    /// C's and T's parts of `Chain::toward` in that direction (at z = x1,
    /// T's alone: n_T / (π p_cam(x1))).
    connection: f32,
    tracing: f32,
    /// The cosine at x_m.
    cos: f32,
    /// The delta lobes each allows: the subpath's vertex joined (x2) or
    /// seen (x1) lies that many scattering events deeper, within
    /// `max_vertex_depth`.
    connection_room: u32,
    tracing_room: u32,
    /// Delta lobes passed since x_m, and the refractions among them: the
    /// subpaths leave out surfaces inside glass.
    passed: u32,
    refractions: u32,
}

/// What the weight of light reached through delta lobes needs of x_m
/// (`Through::seen`).
#[derive(Clone, Copy)]
struct SeenThrough {
    /// `connection_density`'s `connect` for x_m's direction.
    connect: f32,
    /// The cosine there, and the BSDF sample's pdf.
    cos: f32,
    bsdf_pdf: f32,
}

impl SeenThrough {
    /// The BSDF sample's weight against the subpaths' density `q` (in
    /// light sampling's measure at x_m).
    #[inline]
    fn weight(&self, q: f32) -> f32 {
        power_heuristic(self.bsdf_pdf, q)
    }
}

impl Through {
    /// What weighs light reached now, None where no subpath makes the
    /// path.
    fn seen(&self) -> Option<SeenThrough> {
        if self.passed == 0 || self.refractions % 2 == 1 {
            return None;
        }
        let c = if self.passed <= self.connection_room { self.connection } else { 0.0 };
        let t = if self.passed <= self.tracing_room { self.tracing } else { 0.0 };
        Some(SeenThrough { connect: (c * c + t * t).sqrt(), cos: self.cos, bsdf_pdf: self.bsdf_pdf })
    }

    /// Past one more delta lobe, refracted or not.
    fn passing(self, refracted: bool) -> Self {
        Through { passed: self.passed + 1, refractions: self.refractions + refracted as u32, ..self }
    }
}

impl Previous {
    /// The weight of light reached by this ray, which light sampling at
    /// the previous vertex draws with solid-angle pdf `p_light`: whole on
    /// camera rays and after a delta lobe, the power heuristic otherwise,
    /// none under the seed's rule (light sampling alone counts emitters
    /// after the first hit).
    fn weight(&self, mis: bool, p_light: impl FnOnce() -> f32) -> f32 {
        self.weight3(mis, p_light, 0.0)
    }

    /// `weight` where a light subpath's connection, with density `q`
    /// (`connection_density`), could also have made the path.
    fn weight3(&self, mis: bool, p_light: impl FnOnce() -> f32, q: f32) -> f32 {
        if self.depth == 0 || (mis && self.delta) {
            1.0
        } else if mis {
            power_heuristic3(self.bsdf_pdf, p_light(), q)
        } else {
            0.0
        }
    }
}

/// The World seen by a ray that escapes.
fn world_seen(ctx: &Context, dir: Vec3, from: &Previous, mis: bool) -> Vec3 {
    let le = ctx.scene.world_radiance(dir);
    if le == Vec3::ZERO {
        return le;
    }
    // After a delta lobe the seed's rule counts the World too.
    if from.delta {
        return le;
    }
    le * from.weight(mis, || world_pdf(ctx, from.p, from.ng, from.light_side == Vec3::ZERO, dir))
}

/// The connection's density (light_paths.rs) at camera vertex `p` for
/// light from point or spot light `index` arriving from direction
/// `toward_light` at cosine `cos_to_light` (`connection_density`'s for an
/// emitter), in the measure of that light's sample:
/// p_start·π·pdf_dir·cos/d² over the pick's probability for a light of
/// radius 0, p_start·π·pdf_dir·cos/(πr²) over the pick's times the facing
/// disk's solid-angle density for a sized one (`PunctualLight::start`);
/// for a sun, p_start·π·pdf_dir·cos·p_A/cos_d over the same, p_A the
/// density per unit area of its subpaths' starts where the line back
/// along the arriving light crosses their square, and cos_d the cosine
/// between that light and the sun's axis (`Lights::start_spread`).
#[inline]
fn point_connection_density(ctx: &Context, connect: f32, index: usize, toward_light: Vec3, cos_to_light: f32, p: Vec3) -> f32 {
    if !(connect > 0.0 && cos_to_light > 0.0) {
        return 0.0;
    }
    let light = &ctx.scene.punctual[index];
    // A sun's spread is 0 square to its axis, where no start leaves.
    let spread = ctx.lights.start_spread(ctx.scene, index, light.position.distance_squared(p), -toward_light, p);
    if !(spread > 0.0) {
        return 0.0;
    }
    ctx.lights.point_start_probability(ctx.scene, index) * std::f32::consts::PI * light.start_pdf(toward_light) * connect * cos_to_light / spread
}

/// A point light's, spot's or sun's contribution, f·cosθ·E / p_pick, E
/// from one point of it. Only light sampling and the light's subpaths
/// reach a light of radius 0, so its sample takes the whole weight but
/// the connection's; a sized one is MIS-weighted against the BSDF rays
/// that see it (`sized_lights_seen`) too.
#[allow(clippy::too_many_arguments)]
fn punctual_light<B: Bsdf>(ctx: &Context, si: &SurfaceHit, bsdf: &B, wo: Vec3, mis: bool, chain: &Chain<B>, index: usize, probability: f32, u: Vec2, sides: Option<&Sides>, rng: &mut Rng, rays: &mut RayCounts) -> Vec3 {
    let light = &ctx.scene.punctual[index];
    let inc = match &ctx.lights.sun_disks[index] {
        Some(disk) => Some(light.sun_incident(disk, u)),
        None => light.incident(si.p, u),
    };
    let Some(inc) = inc else { return Vec3::ZERO };
    let Some(wi_local) = toward_light(si, bsdf, inc.wi) else { return Vec3::ZERO };
    let (f, bsdf_pdf) = shade(bsdf, wo, wi_local, mis);
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    if !light.shadowless {
        rays.shadow += 1;
        if ctx.occluded(si.spawn_origin(inc.wi), inc.wi, inc.distance, u32::MAX, rng) {
            return Vec3::ZERO;
        }
    }
    let weight = if !mis {
        1.0
    } else {
        let q = point_connection_density(ctx, chain.toward(wi_local), index, inc.wi, inc.wi.dot(si.ng), si.p);
        if inc.pdf.is_finite() { power_heuristic3(probability * inc.pdf, bsdf_pdf, q) } else { power_heuristic3(probability, 0.0, q) }
    };
    through_medium::<B>(f * inc.irradiance * (weight * wi_local.z.abs() / probability), sides, si, inc.wi, inc.distance)
}

/// The sized point, spot and sun lights a ray from `o` sees: a sun if it
/// leaves the scene (`hit_t` None; past a camera's Clip End too, as the
/// World is seen there), the others between `t_min` and the first surface
/// or `reach` (a camera ray's Clip Start and End); a camera ray only those
/// the camera sees (Blender hides lights from it by default).
#[allow(clippy::too_many_arguments)]
fn sized_lights_seen(ctx: &Context, o: Vec3, d: Vec3, hit_t: Option<f32>, t_min: f32, reach: f32, from: &Previous, through: Option<SeenThrough>, mis: bool, medium: Vec3) -> Vec3 {
    if from.depth > 0 && !mis {
        return Vec3::ZERO;
    }
    let mut l = Vec3::ZERO;
    for &index in &ctx.lights.sized {
        let light = &ctx.scene.punctual[index];
        if from.depth == 0 && !light.camera_sees {
            continue;
        }
        let t_max = match (light.kind, hit_t) {
            (_, Some(t)) => t,
            (PunctualKind::Sun, None) => f32::INFINITY,
            (_, None) => reach,
        };
        if let Some(seen) = light.seen(o, d, t_min, t_max) {
            l += sized_light_weighted(ctx, index, seen, o, d, from, through, mis, medium);
        }
    }
    l
}

/// The light of sized light `index` that a ray from `o` along `d` sees,
/// MIS-weighted. Out of line: most rays see none, and inlined, its
/// set-up was hoisted above the loop of `sized_lights_seen`, where every
/// ray that leaves the scene under a sun paid for it (1.1% of the
/// instructions of a 1-spp render of the gold sphere under a sun, 2.4%
/// under a bulb, where every ray asks).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn sized_light_weighted(ctx: &Context, index: usize, seen: crate::punctual::Seen, o: Vec3, d: Vec3, from: &Previous, through: Option<SeenThrough>, mis: bool, medium: Vec3) -> Vec3 {
    let light = &ctx.scene.punctual[index];
    let mut radiance = seen.radiance;
    // In an absorbing medium, over the way to the light's centre (a
    // sun's: all the way out), within its radius of the point seen.
    if medium != Vec3::ZERO {
        let t = if light.kind == PunctualKind::Sun { f32::INFINITY } else { (light.position - o).length() };
        radiance *= media::transmittance(medium, t);
    }
    radiance
        * match through {
            Some(x) => x.weight(point_connection_density(ctx, x.connect, index, d, x.cos, from.p)),
            None => {
                let q = point_connection_density(ctx, from.connect, index, d, d.dot(from.ng), from.p);
                from.weight3(mis, || ctx.lights.punctual_probability(index, from.p, from.light_side, mis) * seen.pdf, q)
            }
        }
}

/// Whether the shadow ray from `si` along `w` reaches `target`, a point of
/// triangle `skip` (normal `n`, error bound `error`). The ray ends at the
/// target moved off its surface by that bound and skips the target's own
/// triangle, so it can run its full length and a wall 10 µm in front of a
/// light still casts its shadow.
#[allow(clippy::too_many_arguments)]
#[inline]
fn unblocked(ctx: &Context, si: &SurfaceHit, w: Vec3, target: Vec3, error: Vec3, n: Vec3, skip: u32, rng: &mut Rng, rays: &mut RayCounts) -> bool {
    let origin = si.spawn_origin(w);
    let segment = offset_origin(target, error, n, -w) - origin;
    let length = segment.length();
    rays.shadow += 1;
    length > 0.0 && !ctx.occluded(origin, segment / length, length, skip, rng)
}

/// One point on an emitting triangle and its shadow ray.
#[allow(clippy::too_many_arguments)]
fn area_light<B: Bsdf>(ctx: &Context, si: &SurfaceHit, bsdf: &B, wo: Vec3, mis: bool, chain: &Chain<B>, ls: &LightSample, sides: Option<&Sides>, rng: &mut Rng, rays: &mut RayCounts) -> Vec3 {
    let to_light = ls.point - si.p;
    let dist2 = to_light.length_squared();
    if !(dist2 > 0.0) {
        return Vec3::ZERO;
    }
    let dist = dist2.sqrt();
    let wi = to_light / dist;
    let cos_light = ls.normal.dot(-wi);
    let pdf = ls.pdf(dist2, cos_light);
    // An emitter seen edge-on has an infinite density and gives nothing.
    if !(pdf > 0.0 && pdf.is_finite()) {
        return Vec3::ZERO;
    }
    let Some(wi_local) = toward_light(si, bsdf, wi) else { return Vec3::ZERO };
    let light_tri = &ctx.scene.triangles[ls.triangle as usize];
    let light_material = &ctx.scene.materials[light_tri.material as usize];
    let mut le = shading::emission_at(ctx.scene, light_material, ls.triangle, Barycentric::new(ls.b1, ls.b2), cos_light > 0.0) * light_material.spread_factor(cos_light);
    if let Some(w) = B::emission_weight(light_material, cos_light) {
        le *= w;
    }
    let (f, bsdf_pdf) = shade(bsdf, wo, wi_local, mis);
    if le == Vec3::ZERO || f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let (_, light_error) = point_on_triangle(&light_tri.p(), ls.b1, ls.b2);
    if !(light_material.shadowless || unblocked(ctx, si, wi, ls.point, light_error, ls.normal, ls.triangle, rng, rays)) {
        return Vec3::ZERO;
    }
    let weight = if mis { power_heuristic3(pdf, bsdf_pdf, connection_density(ctx, chain.toward(wi_local), ls.triangle, wi.dot(si.ng), cos_light)) } else { 1.0 };
    through_medium::<B>(le * f * (weight * wi_local.z.abs() / pdf), sides, si, wi, dist)
}

/// A lamp's light (`Context::lamps`) that a ray along `d` passes, weighed
/// as `emission_seen` weighs it.
#[inline(always)]
fn lamp_seen(ctx: &Context, lamp: &Hit, d: Vec3, from: &Previous, through: Option<SeenThrough>, mis: bool) -> Vec3 {
    let tri = &ctx.scene.triangles[lamp.triangle as usize];
    let material = &ctx.scene.materials[tri.material as usize];
    let cos_light = tri.cross().normalize().dot(d);
    let le = material.emitted(cos_light < 0.0) * material.spread_factor(-cos_light);
    emission_seen(ctx, lamp.triangle, le, lamp.t, d, cos_light, from, through, mis)
}

/// The light surface `si` (its triangle's own material `material`)
/// emits toward a ray along `d` that reached it from `from` at distance
/// `t`, weighed as `emission_seen` weighs it.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn surface_emission_seen<B: Bsdf>(ctx: &Context, material: &Material, si: &SurfaceHit, t: f32, d: Vec3, from: &Previous, through: Option<SeenThrough>, mis: bool) -> Vec3 {
    let mut le = shading::emission_at(ctx.scene, material, si.triangle, si.b, si.front_face);
    if let Some(w) = B::emission_weight(material, si.ng.dot(d)) {
        le *= w;
    }
    emission_seen(ctx, si.triangle, le, t, d, si.ng.dot(d), from, through, mis)
}

/// Emission `le` of emitting triangle `triangle` seen by a ray at distance
/// `t`, cosine `cos_light` at the emitter.
/// `d` the ray's direction.
#[allow(clippy::too_many_arguments)]
fn emission_seen(ctx: &Context, triangle: u32, le: Vec3, t: f32, d: Vec3, cos_light: f32, from: &Previous, through: Option<SeenThrough>, mis: bool) -> Vec3 {
    if le == Vec3::ZERO {
        return le;
    }
    if let Some(x) = through {
        return le * x.weight(connection_density(ctx, x.connect, triangle, x.cos, -cos_light));
    }
    let q = connection_density(ctx, from.connect, triangle, d.dot(from.ng), -cos_light);
    le * from.weight3(mis, || ctx.lights.pdf_emitter(ctx.scene, triangle, from.p, from.light_side, from.p + d * t, t * t, cos_light, mis), q)
}

/// The light of the photons around camera vertex `si` (BSDF `bsdf`,
/// outgoing direction `wo` in its frame), a vertex deeper than x1 that
/// no connection or splat joins to a light subpath: the path's z, or one
/// reached through a delta lobe. The density estimate
///
///   Σ f(wo, wi_p) · α_p · (|ns·wi_p| / |ng·wi_p|) / (N π r²)
///
/// over photons p within r that arrived on the side the camera sees and
/// make paths of at most `room` more scattering events, each MIS-weighted
/// against the BSDF sample from `si` back through the same delta lobes,
/// the one other strategy that makes the path: p_bsdf / p_merge =
/// pdf(wo → wi_p)·back_p / (N π r² · generated_p), as light tracing's at
/// x1 with the disk's area in place of 1 / p_camera (`Through` on the
/// camera side counts N r² where light tracing counts n_T / (π p_camera)).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn merged<B: Bsdf>(si: &SurfaceHit, bsdf: &B, wo: Vec3, photons: &Photons, room: u32, depth: u32, strategies: Strategies) -> Vec3 {
    let disk = photons.subpaths * std::f32::consts::PI * photons.radius * photons.radius;
    let mut sum = Vec3::ZERO;
    photons.near(si.p, |v| {
        let cos_in = v.to_prev.dot(si.ng);
        if v.depth > room || !(cos_in > 0.0 && v.ng.dot(si.ng) > 0.0) || !strategies.keeps(Strategy::Merge, depth + v.depth) {
            return;
        }
        let wi = si.frame.to_local(v.to_prev);
        if !(wi.z > 0.0) {
            return;
        }
        let (f, pdf) = bsdf.evaluate(wo, wi);
        let ratio = pdf * v.back / (disk * v.generated);
        let value = f * v.alpha * (wi.z / (cos_in * (1.0 + ratio * ratio)));
        if value.is_finite() {
            sum += value;
        }
    });
    sum / disk
}

/// Light vertex `v`'s light, reaching camera vertex `si` (BSDF `bsdf`,
/// outgoing direction `wo` in its frame) along one connection
/// (light_paths.rs), `scale` times (the vertices it stands for),
/// MIS-weighted against the camera path's two ways to the same light and,
/// with `tracing` (n_T M / p_cam(z) where z is x1 and light tracing can
/// make the path, else 0), against light tracing's. The caller has asked
/// `off_planes` of the two.
#[allow(clippy::too_many_arguments)]
fn connection<B: Bsdf>(ctx: &Context, prepared: &[Option<[B::Prepared; 2]>], si: &SurfaceHit, bsdf: &B, wo: Vec3, v: &ConnectionVertex, scale: f32, mis_scale: f32, tracing: f32, rng: &mut Rng, rays: &mut RayCounts) -> Vec3 {
    let to_y = v.p - si.p;
    let d2 = to_y.length_squared();
    if !(d2 > 0.0) {
        return Vec3::ZERO;
    }
    let w = to_y / d2.sqrt();
    let cos_y = -w.dot(v.ng);
    if !(cos_y > 0.0) {
        return Vec3::ZERO;
    }
    let Some(wi_z) = toward_light(si, bsdf, w) else { return Vec3::ZERO };
    let (f_z, pdf_z) = bsdf.evaluate(wo, wi_z);
    if f_z == Vec3::ZERO || !(pdf_z > 0.0) {
        return Vec3::ZERO;
    }
    // y as a camera path through z would shade it.
    let frame = Frame::from_normal(shading_normal_for(v.ns(), v.ng, -w));
    let (wo_y, wi_y) = (frame.to_local(-w), frame.to_local(v.to_prev));
    if !(wi_y.z > 0.0 && wo_y.z > 0.0) {
        return Vec3::ZERO;
    }
    let (f_y, pdf_y) = v.bsdf::<B>(ctx.scene, prepared, &frame, wo_y).evaluate(wo_y, wi_y);
    if f_y == Vec3::ZERO {
        return Vec3::ZERO;
    }
    // Light tracing makes z from y as the subpath would go on: the pdf
    // at y of the direction to z, arriving from y_{k−1}.
    let traced = if tracing > 0.0 { tracing * v.bsdf::<B>(ctx.scene, prepared, &frame, wi_y).pdf(wi_y, wo_y) * w.dot(si.ng).abs() / d2 } else { 0.0 };
    let contribution = f_z * f_y * v.alpha * (scale * wi_z.z.abs() * cos_y / d2 * wi_y.z / v.to_prev.dot(v.ng));
    // The densities of light sampling at y1 (s = 1) and of a BSDF sample
    // there hitting y0 (s = 0) over this connection's: the ratio of z's
    // making y to the subpath's, that of y's making y_{k−1} to y_{k−2}'s,
    // and what the subpath knows beyond.
    let to_z = pdf_z * cos_y / d2 / v.generated;
    let at_y = pdf_y * v.back;
    let (light, unidirectional) = if v.first {
        (to_z, to_z * at_y)
    } else {
        let light = to_z * at_y * v.prefix;
        (light, light * v.to_unidirectional)
    };
    // Light sampling is no strategy where y1's light came through delta
    // lobes; the ratio still leads to the BSDF sample's.
    let (light, unidirectional) = (if v.sampled { light * mis_scale } else { 0.0 }, unidirectional * mis_scale);
    let weight = 1.0 / (1.0 + light * light + unidirectional * unidirectional + traced * traced);
    if !(contribution * weight).is_finite() || !(weight > 0.0) {
        return Vec3::ZERO;
    }
    if !unblocked(ctx, si, w, v.p, v.p_error(), v.ng, v.triangle, rng, rays) {
        return Vec3::ZERO;
    }
    contribution * weight
}

/// Whether z (`si`) and light vertex `v`, `to_y` apart, each lie off the
/// other's plane by more than their rounding, y on the side its light
/// came from: a point of a corner can sit on the plane of the wall it
/// meets, and a ray between the two would pass the wall's edge (light
/// from outside a closed box). The paths this drops from the
/// connection's reach have no measure. Asked before `connection` is
/// called: most picks on a floor are of vertices on the same floor
/// (97.7% on the gold sphere), which this refuses without the call or a
/// square root.
#[inline(always)]
fn off_planes(si: &SurfaceHit, v: &ConnectionVertex, to_y: Vec3) -> bool {
    let rounding = v.ng.abs().dot(v.p_error()) + si.ng.abs().dot(si.p_error);
    -to_y.dot(v.ng) > rounding && to_y.dot(si.ng).abs() > rounding
}

/// Where a path goes from a vertex: the BSDF's sample, its direction in
/// world space, the next ray's origin, and the throughput past it.
struct Step {
    sample: BsdfSample,
    wi: Vec3,
    origin: Vec3,
    beta: Vec3,
}

/// The step from vertex `si` (BSDF `bsdf`, throughput `beta` up to it,
/// `depth` bounces before it); None where the path ends there: no sample,
/// one through the wrong side of the surface, or Russian roulette. Where
/// the caustic guide has arrivals near `si`, the direction is drawn from
/// its mixture with the BSDF (`guided_sample`).
#[inline(always)]
fn next_step<B: Bsdf>(si: &SurfaceHit, bsdf: &B, wo: Vec3, beta: Vec3, depth: u32, guide: Option<&CausticGuide>, rng: &mut Rng) -> Option<Step> {
    let (u_lobe, u) = (rng.next_f32(), rng.next_2d());
    let near = match guide {
        Some(g) if guided_surface(&si.surface) => g.near(si.p).map(|n| (g, n)),
        _ => None,
    };
    let s = match near {
        Some((g, near)) => guided_sample(si, bsdf, wo, g, &near, u_lobe, u)?,
        None => bsdf.sample(wo, u_lobe, u)?,
    };
    let wi = si.frame.to_world(s.wi);
    if !same_side(si, wi, s.wi) {
        return None;
    }
    let mut beta = beta * s.weight;
    if depth + 1 >= RR_START_DEPTH {
        // A path is ended only once its throughput is well below the
        // camera's: each survivor's weight grows to √(β·RR_THRESHOLD)
        // at most, where Cycles' q = √β let a dim survivor reach √β and
        // carry a firefly. Against that rule, at 64 spp on the
        // benchmark scenes (Cornell box, gold sphere): 24% and 2% more
        // time per sample, 44% and 19% less error, so 1.44× and 1.22×
        // less time for equal error. The cap ends paths in a white furnace.
        let q = (beta.max_element() / RR_THRESHOLD).sqrt().min(RR_MAX_SURVIVAL);
        if !(rng.next_f32() < q) {
            return None;
        }
        beta /= q;
    }
    Some(Step { sample: s, wi, origin: si.spawn_origin(wi), beta })
}


/// Surfaces the caustic guide samples at: neither glass nor smooth, whose
/// delta lobes no mixture with a density can hold, nor coated.
#[inline]
fn guided_surface(s: &Surface) -> bool {
    s.transmission <= 0.0 && s.coat <= 0.0 && !crate::material::is_smooth(s.roughness)
}

/// A direction from the caustic guide's mixture at `si` (caustic_guide.rs):
/// with probability `SHARE` from the cones about the arrivals `near`, else
/// the BSDF's, and the path's factor f·cos/p for the mixture's density p.
/// The sample keeps the BSDF's own pdf, which every MIS weight reads: the
/// weights of a path's strategies still sum to 1, and the estimate stays
/// unbiased whatever the guide's density.
#[inline(never)]
fn guided_sample<B: Bsdf>(si: &SurfaceHit, bsdf: &B, wo: Vec3, guide: &CausticGuide, near: &Near, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
    use crate::caustic_guide::SHARE;
    if u_lobe < SHARE {
        let wi = guide.sample(near, u_lobe / SHARE, u);
        let wi_local = si.frame.to_local(wi);
        let (f, pdf) = bsdf.evaluate(wo, wi_local);
        let mixture = (1.0 - SHARE) * pdf + SHARE * guide.pdf(near, wi);
        if !(pdf > 0.0 && mixture > 0.0) || f == Vec3::ZERO {
            return None;
        }
        return Some(BsdfSample { wi: wi_local, f, pdf, weight: f * (wi_local.z.abs() / mixture), delta: false, diffuse: true });
    }
    let s = bsdf.sample(wo, (u_lobe - SHARE) / (1.0 - SHARE), u)?;
    let mixture = (1.0 - SHARE) * s.pdf + SHARE * guide.pdf(near, si.frame.to_world(s.wi));
    if s.delta || !(mixture > 0.0) {
        return None;
    }
    Some(BsdfSample { weight: s.weight * (s.pdf / mixture), ..s })
}

/// Radiance arriving along a camera ray: the kernel for BSDF `B` and the
/// light parts that are on (features.rs; a part that is off is not tested
/// for at all). `first` is what the ray reaches first where the caller
/// has found it (camera_hits.rs). With it, the sample's coverage for a
/// transparent film: 0 where the camera ray left the scene, 1 where it met
/// a surface — but with Transparent Glass, where the path went on through
/// glass alone (transmissions of roughness up to the threshold, as Cycles'
/// LABEL_TRANSMIT_TRANSPARENT) and then left, 1 − the mean of its
/// throughput: the World seen through glass becomes transparency rather
/// than colour.
#[allow(clippy::too_many_arguments)]
pub fn radiance<B: Bsdf, const AREA: bool, const PUNCTUAL: bool, const LAMPS: bool>(
    ctx: &Context,
    prepared: &[Option<[B::Prepared; 2]>],
    light_vertices: Option<&LightVertices>,
    camera: &CameraRay,
    density: CameraDensity,
    settings: &RenderSettings,
    rng: &mut Rng,
    rays: &mut RayCounts,
    first: FirstHit,
) -> (Vec3, f32) {
    let max_depth = settings.max_depth;
    let guide = light_vertices.and_then(|v| v.guide.as_deref());
    let photons = light_vertices.and_then(|v| v.photons.as_ref());
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let (mut o, mut d) = (camera.origin, camera.dir);
    let mut from = Previous { depth: 0, p: camera.origin, ng: Vec3::ZERO, light_side: Vec3::ZERO, bsdf_pdf: 0.0, delta: false, connect: 0.0, chain: 0.0, area_pdf: 0.0, tracing: 0.0 };
    // Whether light subpaths pass delta lobes here, and after a lobe that
    // is not a delta, its vertex's part in the paths the ray makes through
    // delta lobes alone; after a delta lobe, that of the last such vertex
    // before it (`Through`). Scenes without a smooth surface never set it;
    // they still run 1.2–1.7% more instructions (callgrind, the gold
    // sphere at 1 spp) for the code around it, in the same time, whether
    // it is kept here or in `from` and its update inline or not.
    let delta_starts = light_vertices.is_some() && ctx.delta_starts();
    let mut through: Option<Through> = None;
    let (mis_scale, max_vertex_depth, subpaths_traced) = light_vertices.map_or((1.0, 0, 0.0), |v| (v.mis_scale, v.max_vertex_depth, v.tracing));
    // n_T M / p_cam(x1) where light tracing (light_tracing.rs) makes the
    // paths through x1: z is x1, which needs x1 to connect.
    let mut tracing_over = 0.0;
    // The depth of the path's z, once it has one, and M over the
    // connections made there (light_paths.rs), which every weight of the
    // paths through z divides the connection's density by.
    let mut z_depth = None;
    let mut z_mis_scale = mis_scale;
    // The first connections' picks, drawn now so that their vertices load
    // while the path finds z (LightVertices::prefetch).
    let picks: [u32; CONNECTIONS as usize] = std::array::from_fn(|_| match light_vertices {
        Some(vertices) => {
            let u = rng.next_u32();
            vertices.prefetch(u);
            u
        }
        None => 0,
    });
    rays.camera += 1;
    // Whether the World this ray may reach is the film's transparency:
    // the camera ray's own, on a transparent film, and with Transparent
    // Glass the rays after glass alone.
    let mut see_through = settings.transparent;
    // The absorbing media the ray travels in (media.rs): none for the
    // camera's, and always none in a scene without them (a kernel without
    // glass has no code for them).
    let absorbing = ctx.absorbs::<B>();
    let mut media = Media::default();
    // The kind of the ray after a bounce (Blender's Ray Visibility).
    let mut scattered = Rays::NONE;
    // depth == max_depth: the ray after the last vertex, which only
    // gathers the light it reaches.
    for depth in 0..=max_depth {
        // Whether what this ray reaches counts (strategies.rs): the
        // camera's own, or a BSDF sample's after `depth` bounces.
        let seen_kept = settings.strategies.keeps(if depth == 0 { Strategy::Camera } else { Strategy::Bsdf }, depth);
        let seen_through = if settings.mis && from.delta { through.as_ref().and_then(Through::seen) } else { None };
        // A camera ray sees only what lies between Clip Start and End.
        let (skip, reach) = if depth == 0 { (camera.tmin, camera.tmax) } else { (0.0, f32::INFINITY) };
        let hit = match (depth, first) {
            (0, FirstHit::Miss) => None,
            // The binned hit is the first along the whole ray: past Clip
            // End, there is none; before Clip Start, the BVH finds what
            // lies beyond it.
            (0, FirstHit::Slot(slot)) => match ctx.accel.hit_in_slot(slot, o, d) {
                Some(h) if h.t >= skip => (h.t <= reach).then_some(h),
                _ => ctx.intersect_between(o, d, skip, reach, RayKind::Camera, rng),
            },
            (0, FirstHit::Trace) => ctx.intersect_between(o, d, skip, reach, RayKind::Camera, rng),
            _ => ctx.intersect_scattered(o, d, scattered, rng),
        };
        // A lamp in front of the surface adds its light; the ray goes on.
        // Lamps before Clip Start are tested for only where there is one:
        // the test on every lamp a ray meets cost the hall 0.6% of its
        // instructions. A camera ray tests none where the camera sees
        // none, as by Blender's default: that test (the lamps' BVH, for a
        // ray that could only pass them) was 2% of a 1-spp gold sphere's.
        let lamp = if !LAMPS || (depth == 0 && ctx.features.lamps_seen_by_camera == 0) {
            None
        } else if skip > 0.0 {
            ctx.lamps.intersect_where(o, d, hit.map_or(reach, |h| h.t), |_, t, _, _| t >= skip)
        } else {
            ctx.lamps.intersect_few(o, d, hit.map_or(reach, |h| h.t))
        };
        // What the path keeps of light reaching it from a distance t along
        // this ray, in an absorbing medium.
        let absorbed = |beta: Vec3, t: f32| if absorbing { beta * media::transmittance(media.sigma, t) } else { beta };
        if let Some(lamp) = lamp {
            // Blender hides lights from the camera unless told otherwise.
            if (depth > 0 || ctx.scene.material_of(lamp.triangle).camera_sees_lamp) && seen_kept {
                l += absorbed(beta, lamp.t) * lamp_seen(ctx, &lamp, d, &from, seen_through, settings.mis);
            }
        }
        if PUNCTUAL && !ctx.lights.sized.is_empty() && seen_kept && (hit.is_none() || ctx.lights.sized_local) && (depth > 0 || ctx.lights.sized_camera_sees) {
            l += beta * sized_lights_seen(ctx, o, d, hit.map(|h| h.t), skip, reach, &from, seen_through, settings.mis, if absorbing { media.sigma } else { Vec3::ZERO });
        }
        let Some(hit) = hit else {
            // Film › Transparent: the camera does not see the World (it
            // still lights what the camera sees).
            if seen_kept && !see_through {
                // Through nothing but transparency this is still the
                // camera's ray (Cycles' Is Camera Ray), which may see a
                // World of its own; no strategy but this one reaches it.
                let le = if depth == 0 { ctx.scene.world_seen_by_camera(d) } else { world_seen(ctx, d, &from, settings.mis) };
                l += absorbed(beta, f32::INFINITY) * le;
            }
            let coverage = match (depth, see_through) {
                (0, _) => 0.0,
                (_, true) => 1.0 - (beta.x + beta.y + beta.z) / 3.0,
                (_, false) => 1.0,
            };
            return (l, coverage);
        };
        beta = absorbed(beta, hit.t);
        let si = SurfaceHit::new(ctx.scene, &hit, d, rng);
        let site = if AREA || PUNCTUAL { ctx.lights.pick_site(si.p, si.ng) } else { None };
        // The triangle's own material emits, whichever half of a Mix
        // Shader shades the hit (the halves' emission is the same, but
        // only the first has textures), and names its medium.
        let own = ctx.scene.triangles[si.triangle as usize].material;
        let material = &ctx.scene.materials[own as usize];
        let sides = absorbing.then(|| si.sides(ctx.scene, &media));
        if AREA && seen_kept {
            l += beta * surface_emission_seen::<B>(ctx, material, &si, hit.t, d, &from, seen_through, settings.mis);
        }
        if depth == max_depth {
            break;
        }
        let wo = si.frame.to_local(-d);
        let bsdf: B = bsdf_at(prepared, &si, &si.frame, wo);
        // The connection's side of this vertex's MIS weights: it could be
        // a light vertex of a connection from z where every vertex after z
        // could be (light_paths.rs).
        let t2 = hit.t * hit.t;
        let area_pdf = from.bsdf_pdf * -d.dot(si.ng) / t2;
        let after_z = z_depth.map_or(0, |z| depth - z);
        let joins = from.chain > 0.0 && area_pdf > 0.0 && carries_light_paths(&si.surface) && after_z <= max_vertex_depth;
        let connects = (AREA || PUNCTUAL) && z_depth.is_none() && depth + 2 <= max_depth && light_vertices.is_some() && connects_from(&si.surface);
        // The photons around a vertex no other strategy joins to the light
        // beyond it through delta lobes: z deeper than x1, or a vertex
        // after a delta lobe (`merged`).
        let merges = photons.filter(|_| depth > 0 && media.is_empty() && (connects || (from.delta && connects_from(&si.surface))));
        if depth == 0 && connects && subpaths_traced > 0.0 {
            let p_camera = density.at(d.dot(si.ng).abs(), t2);
            tracing_over = if p_camera > 0.0 && p_camera.is_finite() { subpaths_traced * mis_scale / p_camera } else { 0.0 };
        }
        // Light tracing makes paths whose x1 … x_{depth+1} are a subpath's
        // vertices, as deep as they go.
        let traced = tracing_over > 0.0 && depth + 2 <= max_depth;
        let tracing = match depth {
            1 if traced => Tracing::Rev(from.tracing * from.ng.dot(d).abs() / t2),
            2.. if traced => Tracing::Ratio(from.tracing),
            _ => Tracing::Off,
        };
        let chain = Chain::<B> {
            prepared,
            si: &si,
            wo,
            base: if joins { from.chain / (std::f32::consts::PI * z_mis_scale * area_pdf) } else { 0.0 },
            rev: (after_z >= 2).then(|| from.ng.dot(d).abs() / (t2 * from.area_pdf)),
            tracing,
        };
        let lit = AREA || PUNCTUAL || ctx.lights.has_world();
        let picked = if lit { pick_light(ctx, &si, &bsdf, settings.mis, site, rng) } else { None };
        // The path's next step is drawn between the light's pick and its
        // sample: the pick (a walk down the light tree) is a chain of
        // dependent operations that what follows it waits on, the BSDF
        // sample and the roulette are not, and side by side in program
        // order the processor runs them while the chain completes. Against
        // drawing the step after the light sample and the connections (8
        // spp, median of 8–10 runs): the lamp hall 5% less time a sample,
        // the window room 7%, the gold sphere 2–3%, the Cornell box 1%;
        // tracing the next ray there too gained nothing more.
        // Under the seed's rule a ray after the last vertex could only see
        // the World behind a mirror: paths end here, as the seed's did.
        let ends = depth + 1 == max_depth && !settings.mis;
        let step = if ends { None } else { next_step(&si, &bsdf, wo, beta, depth, guide, rng) };
        if lit {
            let direct = direct_light::<B, AREA, PUNCTUAL>(ctx, &si, &bsdf, wo, settings.mis, &chain, picked, sides.as_ref(), rng, rays);
            if settings.strategies.keeps(Strategy::Light, depth + 1) {
                l += beta * direct;
            }
        }
        if connects {
            z_depth = Some(depth);
            let connections = if depth == 0 { CONNECTIONS } else { DEEP_CONNECTIONS };
            z_mis_scale = mis_scale * CONNECTIONS as f32 / connections as f32;
            // Numbers of the sample's own stream (the first drawn as the
            // path started): the Sobol sets stay with the light sample and
            // the BSDF's.
            for k in 0..connections as usize {
                let u = picks.get(k).copied().unwrap_or_else(|| rng.next_u32());
                if let Some((v, scale)) = light_vertices.and_then(|vertices| vertices.pick(u)) {
                    if v.depth + depth < max_depth && off_planes(&si, v, v.p - si.p) {
                        let tracing = if v.depth + 2 <= max_depth { tracing_over } else { 0.0 };
                        let joined = connection(ctx, prepared, &si, &bsdf, wo, v, scale / connections as f32, z_mis_scale, tracing, rng, rays);
                        if settings.strategies.keeps(Strategy::Connection, depth + 1 + v.depth) {
                            l += beta * joined;
                        }
                    }
                }
            }
        }
        if let Some(photons) = merges {
            l += beta * merged(&si, &bsdf, wo, photons, max_depth - depth, depth, settings.strategies);
        }
        let Some(Step { sample: s, wi, origin, beta: next_beta }) = step else { break };
        beta = next_beta;
        // Light subpaths store no vertex inside an absorbing medium
        // (light_paths.rs): neither is one a y1 here.
        let outside_media = media.is_empty();
        if let Some(sides) = &sides {
            media = *sides.toward(wi.dot(si.ng));
        }
        // The next ray's kind, by the lobe that sent it (Cycles' labels).
        scattered = if s.wi.z < 0.0 {
            Rays::TRANSMISSION
        } else if s.diffuse {
            Rays::DIFFUSE
        } else {
            Rays::GLOSSY
        };
        see_through = see_through && settings.transparent_glass.is_some_and(|threshold| s.wi.z < 0.0 && !si.surface.translucent && si.surface.roughness <= threshold);
        o = origin;
        d = wi;
        // What the next vertex's Chain starts from; a delta lobe here is
        // one no subpath samples.
        // The vertex's `Chain::parts` toward the sample, for `Through`.
        let mut parts = None;
        let (chain, connect, tracing) = if s.delta {
            (0.0, 0.0, 0.0)
        } else if connects {
            // Nonzero only where z is x1, the one vertex light tracing
            // counts from.
            (1.0, 0.0, tracing_over)
        } else if joins {
            let (c, ratio) = chain.parts(s.wi);
            if delta_starts {
                parts = Some((c, ratio));
            }
            let next = from.chain * c / chain.base;
            if next.is_finite() { (next, c * (1.0 + ratio * ratio).sqrt(), ratio) } else { (0.0, 0.0, 0.0) }
        } else {
            (0.0, 0.0, 0.0)
        };
        if delta_starts {
            through = if s.delta {
                through.map(|t| t.passing(s.wi.z < 0.0))
            } else if !outside_media {
                None
            } else {
                // This vertex as the y1 of subpaths through the lobes
                // ahead: z = x1 for light tracing alone, or a vertex the
                // connection reaches too.
                let start = Through { bsdf_pdf: s.pdf, connection: 0.0, tracing: 0.0, cos: wi.dot(si.ng).abs(), connection_room: 0, tracing_room: max_depth.saturating_sub(2).saturating_sub(depth), passed: 0, refractions: 0 };
                if depth == 0 && tracing_over > 0.0 {
                    Some(Through { tracing: tracing_over / (std::f32::consts::PI * mis_scale), ..start })
                } else if let Some(photons) = merges {
                    // The vertex merges with the photons that landed
                    // around it (`merged`): N r² in light tracing's
                    // n_T / (π p_cam).
                    Some(Through { tracing: photons.subpaths * photons.radius * photons.radius, tracing_room: (max_depth - depth).saturating_sub(1), ..start })
                } else {
                    parts.filter(|_| connect > 0.0).map(|(c, ratio)| Through { connection: c, tracing: c * ratio, connection_room: max_vertex_depth - after_z, tracing_room: if ratio > 0.0 { start.tracing_room } else { 0 }, ..start })
                }
            };
        }
        from = Previous { depth: depth + 1, p: si.p, ng: si.ng, light_side: light_side(&si, &bsdf), bsdf_pdf: s.pdf, delta: s.delta, connect, chain, area_pdf, tracing };
        rays.bounce += 1;
    }
    (l, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{PrincipledBsdf, WithGlass};
    use crate::camera::Camera;
    use crate::material::Material;
    use crate::scene::Triangle;

    /// The tangent set square to the normal, turned counter-clockwise seen
    /// from above (a quarter turn takes +x to +y), and +x at the pole of
    /// the field, where the tangent is along the normal or zero.
    #[test]
    fn anisotropy_axis_is_square_to_the_normal_and_turned() {
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-6;
        assert!(close(anisotropy_axis(Vec3::new(2.0, 0.0, 5.0), 0.0), Vec3::X));
        assert!(close(anisotropy_axis(Vec3::new(2.0, 0.0, 5.0), 0.25), Vec3::Y));
        assert!(close(anisotropy_axis(Vec3::new(0.0, -3.0, 1.0), 0.125), Vec3::new(0.5f32.sqrt(), -(0.5f32.sqrt()), 0.0)));
        assert_eq!(anisotropy_axis(Vec3::new(0.0, 0.0, 1.0), 0.0), Vec3::X);
        assert_eq!(anisotropy_axis(Vec3::ZERO, 0.0), Vec3::X);
        assert!((anisotropy_axis(Vec3::new(1e-30, 3e-31, 1.0), 0.37).length() - 1.0).abs() < 1e-6);
    }

    /// A BSDF made from a material's prepared part is the one a hit would
    /// build from its surface, on either face (the back face inverts the
    /// IOR), bit for bit; vertex colours make every material vary, so none
    /// is prepared.
    #[test]
    fn prepared_materials_give_the_bsdf_a_hit_builds() {
        let tri = Triangle::new([Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z; 3], 0);
        let materials = vec![
            Material { base_color: Vec3::new(0.8, 0.3, 0.1), metallic: 0.3, roughness: 0.4, ior: 1.45, ..Material::default() },
            Material { base_color: Vec3::splat(0.5), metallic: 0.0, roughness: 0.0, specular: 0.6, ..Material::default() },
        ];
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let mut scene = Scene::new(vec![tri], materials, camera);
        let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
        // Reflected, and transmitted (where glass's IOR shows).
        let directions = [Vec3::new(-0.5, 0.1, 0.6).normalize(), Vec3::new(-0.4, 0.3, -0.7).normalize()];
        fn check<B: Bsdf>(scene: &Scene, wo: Vec3, directions: &[Vec3]) {
            for (m, faces) in scene.materials.iter().zip(prepare_materials::<B>(scene)) {
                let faces = faces.expect("a plain material is prepared");
                for (face, front) in faces.iter().zip([true, false]) {
                    let (a, b) = (B::at(face, wo), B::new(&facing(m.surface(), front), wo));
                    for &wi in directions {
                        let ((fa, pa), (fb, pb)) = (a.evaluate(wo, wi), b.evaluate(wo, wi));
                        assert_eq!((fa.to_array().map(f32::to_bits), pa.to_bits()), (fb.to_array().map(f32::to_bits), pb.to_bits()), "{} front {front} wi {wi}", m.name);
                    }
                }
            }
        }
        check::<PrincipledBsdf>(&scene, wo, &directions);
        scene.materials.push(Material { name: "glass".into(), metallic: 0.0, roughness: 0.3, transmission: 1.0, ior: 1.5, ..Material::default() });
        check::<WithGlass<PrincipledBsdf>>(&scene, wo, &directions);
        scene.attributes.color = vec![[glam::Vec4::ONE; 3]];
        assert!(prepare_materials::<PrincipledBsdf>(&scene).iter().all(Option::is_none));
    }

    #[test]
    fn ulp_step_is_next_up_and_next_down() {
        // One float toward s, or ±LEAST_STEP where that is smaller (never
        // subnormal: see LEAST_STEP).
        let toward = |x: f32, s: f32| {
            let y = if s > 0.0 { x.next_up() } else if s < 0.0 { x.next_down() } else { return x };
            if y.abs() < LEAST_STEP { LEAST_STEP.copysign(s) } else { y }
        };
        let values = [0.0f32, -0.0, 1.0, -1.0, 1e-40, -1e-40, f32::MIN_POSITIVE, -f32::MIN_POSITIVE, 3.5e7, -2.25e-3, f32::MAX, -f32::MAX, 123.456];
        for &x in &values {
            for s in [1.0f32, -1.0, 0.0] {
                let got = ulp_step(Vec3::new(x, -x, x), Vec3::new(s, -s, 0.0));
                let want = Vec3::new(toward(x, s), toward(-x, -s), x);
                // == leaves a zero's sign free: only a zero that stays put may lose it.
                assert!(got.x == want.x && got.y == want.y && got.z == want.z, "{x} toward {s}: {got} against {want}");
                assert!(got.x.to_bits() == want.x.to_bits() || (s == 0.0 && x == 0.0), "{x} toward {s}: sign");
                if s != 0.0 {
                    assert!(!got.x.is_subnormal() && !got.y.is_subnormal() && got.x != 0.0 && (got.x - x) * s > 0.0, "{x} toward {s}: {got}");
                }
            }
        }
    }

    #[test]
    fn offset_leaves_the_surface_at_every_scale() {
        for scale in [1e-4f32, 1.0, 1e4] {
            for shift in [0.0f32, 1e5] {
                let p = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]
                    .map(|v| v * scale + Vec3::splat(shift));
                let (point, error) = point_on_triangle(&p, 0.3, 0.3);
                let up = offset_origin(point, error, Vec3::Z, Vec3::Z);
                let down = offset_origin(point, error, Vec3::Z, -Vec3::Z);
                // The triangle's plane is z = shift exactly.
                assert!(up.z > shift && down.z < shift, "scale {scale} shift {shift}: {up} {down}");
            }
        }
    }
}
