//! The light list: emissive triangles and punctual lights. Two or more
//! local lights are picked by a light tree (light_tree.rs), by their
//! irradiance bound at the shading point; a lone one, or all of them where
//! `pick_by_power` asks, with probability proportional to their power
//! (luminance-weighted watts: π·A·Le for a triangle, see punctual.rs for
//! the others), which also starts light subpaths. A triangle is then
//! sampled uniformly, so by power a point x' on an emitter of radiance Le
//! has area density pdf_A = p_local · π·lum(Le) / P_total, the same for
//! every emitter of that radiance; with the tree, p_local · P(light | p) /
//! its area.
//!
//! The distant lights — the World and suns — are picked first, as a
//! group, with a probability that depends on the shading point p: their
//! irradiance (lum(E) for a sun; for the World, π times the part of its
//! luminance above its mean, below) against what the other lights give
//! there (`LocalBound`); within the group, by the same weights. A constant
//! World has no part above its mean: light samples of it add nothing a
//! BSDF sample does not already give under MIS (Karlík et al. 2019, "MIS
//! compensation"), while each one taken from a lamp makes that lamp's
//! estimate noisier: beside a lamp or a sun it gets no light samples at
//! all (`DistantWeights`). Without MIS (the seed's rule) only light
//! samples see the World, and it weighs its whole irradiance π·lum(L̄).
//! On the gold sphere (a World of 0.2 and a 300 W key light), weighing
//! the World by its excess instead of all of π·lum(L̄) took 12%, 8% and 5%
//! off the error at 1, 4 and 16 spp, with a twentieth of π·lum(L̄) kept as
//! a floor; dropping that floor under MIS took 9%, 9% and 6% more.
//!
//! Weighing distant lights by a power over the scene's bounding sphere (as
//! before, and pbrt's power sampler) let a large floor hand them most light
//! samples: under a 1 m² lamp on a 20 m floor the World took 57% of them for
//! ~8% of the light, and a sun over a 2 km floor left a 40 W bulb one light
//! sample in 40,000. p_local = 1 − p_distant.
//!
//! A point on the chosen triangle is drawn by area, or, when the shading
//! point is close to the triangle (its longest edge longer than the
//! distance to its centroid), uniformly over the solid angle it covers
//! (spherical_triangle.rs): there cos'/r² would swing by orders
//! of magnitude over the triangle. Densities are given per solid angle at
//! the shading point, the measure MIS compares them in.

use crate::bsdf::luminance;
use crate::caustic_guide::Aim;
use crate::integrator::{offset_origin, point_on_triangle};
use crate::material::Material;
use crate::sampling::{cosine_hemisphere, uniform_triangle, Distribution1D, Frame};
use crate::sun_cells::SunCells;
use crate::shading::{self, Barycentric};
use crate::scene::{Scene, Triangle};
use crate::parallelogram::Parallelogram;
use crate::portals::Portals;
use crate::light_cache::Site;
use crate::light_tree::{Cone, LightTree, TreeLight};
use crate::softbox::{Clip, Reach, RoundSoftbox, Softbox};
use crate::spherical_triangle::{self, SphericalTriangle};
use glam::Vec2;
use crate::Vec3;

pub struct Lights {
    /// Scene triangle index of each emitter; the distribution's entries
    /// are these, then the scene's punctual lights.
    pub triangles: Vec<u32>,
    /// What sampling needs of each, alongside `triangles`.
    emitters: Vec<Emitter>,
    distribution: Distribution1D,
    /// π / Σ of the lights' powers (luminance-weighted watts): an
    /// emitter's area density per unit luminance of its radiance.
    area_pdf_per_luminance: f32,
    /// π·lum(L̄) of the World, its irradiance on an open surface; 0 when
    /// it is black.
    world_irradiance: f32,
    /// The distant group's weights with MIS and without.
    with_mis: DistantWeights,
    alone: DistantWeights,
    /// The local lights as the distant group's share sees them.
    local: LocalBound,
    /// Scene punctual index and luminance irradiance (W·m⁻²) of each sun;
    /// they have no weight in `distribution`.
    suns: Vec<(usize, f32)>,
    /// Each punctual light's `SunDisk`, by scene index: None but for a
    /// sized sun. Its light samples read it: formed at each, it was 1.6%
    /// of the instructions of a 1-spp render of the gold sphere under a
    /// sun.
    pub sun_disks: Vec<Option<crate::punctual::SunDisk>>,
    /// The scene's punctual lights that have a size, which rays can hit.
    pub sized: Vec<usize>,
    /// Whether a point or a spot is among them. Only those can be met
    /// before a surface; a sun only by a ray that leaves the scene, so
    /// under a sun alone the rays that hit a surface skip the test (2.9%
    /// of the instructions of a 1-spp render of the gold sphere under a
    /// sun).
    pub sized_local: bool,
    /// Whether the camera sees one of them (Object › Visibility › Camera,
    /// off for lights by default): camera rays ask only then.
    pub sized_camera_sees: bool,
    /// Light subpaths from suns (`SunStarts`), where some sun shines.
    sun_starts: Option<SunStarts>,
    /// The local lights in a light tree where there are two or more;
    /// else `distribution` picks by power.
    tree: Option<LocalTree>,
    /// Where the World's light comes into an interior (portals.rs).
    pub portals: Portals,
    /// Lamps with a Spread, whose light samples come from the part a point
    /// sees through the grid (softbox.rs); empty without.
    softboxes: Vec<Grid>,
}

/// A lamp with a Spread: a rectangle (two emitters), or a disk or an
/// ellipse (a fan of emitters from `first` on).
enum Grid {
    Rectangle(Softbox),
    Round { lamp: RoundSoftbox, first: usize },
}


/// The local lights as a light tree picks them (light_tree.rs).
struct LocalTree {
    tree: LightTree,
    /// What each of the tree's lights is.
    items: Vec<TreeItem>,
    /// The tree light of each emitter, alongside `triangles`.
    of_emitter: Vec<u32>,
    /// The tree light of each scene punctual light; NOT_IN_TREE for a sun
    /// or one that gives no light.
    of_punctual: Vec<u32>,
}

const NOT_IN_TREE: u32 = u32::MAX;

/// One light of the tree: an emitting triangle, or the two halves of a
/// quad (emitters `first` and `first + 1`), sampled as one, as without
/// the tree, so both halves keep one area density; or a point or spot.
#[derive(Clone, Copy)]
enum TreeItem {
    Emitters { first: usize, count: usize, area: f32 },
    Punctual(usize),
}

impl LocalTree {
    /// None with fewer than two local lights: one needs no picking.
    fn new(scene: &Scene, triangles: &[u32], records: &[Emitter], softboxes: &[Grid], powers: &[f64]) -> Option<Self> {
        let (mut items, mut lights) = (Vec::new(), Vec::new());
        let mut of_emitter = vec![NOT_IN_TREE; triangles.len()];
        let mut k = 0;
        while k < triangles.len() {
            let count = match (records[k].quad, softboxes.get(records[k].softbox as usize)) {
                (Some((_, partner)), _) if partner == k + 1 => 2,
                // A round lamp with a Spread is one light: its samples are
                // drawn over the whole of it (`Lights::point_on_softbox`).
                (_, Some(Grid::Round { lamp, first })) if *first == k => lamp.segments(),
                _ => 1,
            };
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &t in &triangles[k..k + count] {
                scene.triangles[t as usize].p().iter().for_each(|&v| (lo, hi) = (lo.min(v), hi.max(v)));
            }
            of_emitter[k..k + count].fill(items.len() as u32);
            let weight = powers[k..k + count].iter().sum::<f64>() as f32;
            let cos_spread = scene.material_of(triangles[k]).spread.map_or(0.0, |s| s.cos_half());
            lights.push(TreeLight { weight, lo, hi, facing: Some((records[k].normal, double_sided(scene, triangles[k]))), cos_spread });
            items.push(TreeItem::Emitters { first: k, count, area: records[k..k + count].iter().map(|e| e.area).sum() });
            k += count;
        }
        let mut of_punctual = vec![NOT_IN_TREE; scene.punctual.len()];
        for (index, (light, &power)) in scene.punctual.iter().zip(&powers[triangles.len()..]).enumerate() {
            // Suns have power 0 here: they are the distant group's.
            if power > 0.0 {
                of_punctual[index] = items.len() as u32;
                // π·I bounds its irradiance as π·A·Le does an emitter's.
                let weight = std::f32::consts::PI * luminance(light.intensity);
                lights.push(TreeLight { weight, lo: light.position - Vec3::splat(light.size), hi: light.position + Vec3::splat(light.size), facing: None, cos_spread: 0.0 });
                items.push(TreeItem::Punctual(index));
            }
        }
        if items.len() < 2 {
            return None;
        }
        let mut tree = LightTree::new(&lights)?;
        // Shading points lie on the surfaces; a point rounded off their box
        // is the tree's.
        let (lo, hi) = crate::scene::bounds(&scene.triangles);
        let along_axes = || scene.triangles.iter().any(|t| crate::light_cache::axis_of(t.cross().normalize_or_zero()).is_some());
        tree.cache_over(&lights, lo, hi, along_axes);
        Some(LocalTree { tree, items, of_emitter, of_punctual })
    }

    /// The density per unit area of the tree picking emitter `k` and a
    /// point on it by area, for a point at `p` of normal `n`.
    fn area_density(&self, k: usize, p: Vec3, n: Vec3) -> f32 {
        let item = self.of_emitter[k] as usize;
        match self.items[item] {
            TreeItem::Emitters { area, .. } if area > 0.0 => self.tree.probability(item, p, n) / area,
            _ => 0.0,
        }
    }
}

/// The World's weight among the lights, and the distant group's (the
/// World's plus the suns' irradiance). Without MIS (the seed's rule) only
/// light samples see the World, so its weight is all its irradiance. With
/// MIS, a BSDF sample already captures a constant World well, and light
/// samples spent on it only make the other lights' estimates noisier
/// (Karlík et al. 2019, MIS compensation): its weight is π times the mean
/// over the sphere of the luminance above lum(L̄) — zero for a constant
/// World, which then light samples leave to BSDF samples wherever there
/// is another light to sample.
#[derive(Clone, Copy, Debug)]
struct DistantWeights {
    world: f32,
    total: f32,
}

/// An emitting triangle's unit face normal, area and nearness, and the
/// parallelogram it makes with a neighbour (emitter `partner`), if it does.
struct Emitter {
    normal: Vec3,
    area: f32,
    /// The lamp with a Spread (`Lights::softboxes`) this is part of, or
    /// NO_SOFTBOX.
    softbox: u32,
    nearness: Nearness,
    quad: Option<(Parallelogram, usize)>,
}

const NO_SOFTBOX: u32 = u32::MAX;

/// What says whether a point is close to a triangle: its centroid and
/// longest squared edge, kept per emitter because every light sample asks
/// (recomputed from the corners, the test was a sixth of a light sample).
#[derive(Clone, Copy)]
struct Nearness {
    centroid: Vec3,
    longest2: f32,
}

impl Nearness {
    fn of(tri: &Triangle) -> Self {
        let [a, b, c] = tri.p();
        Nearness { centroid: (a + b + c) / 3.0, longest2: (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared()) }
    }

    /// The longest edge is longer than the distance to the centroid.
    fn close(&self, p: Vec3) -> bool {
        self.longest2 > p.distance_squared(self.centroid)
    }
}

/// Whether scene triangle `t` emits from both faces.
fn double_sided(scene: &Scene, t: u32) -> bool {
    scene.material_of(t).double_sided
}

/// The cone of emitting triangles' normals (their `records`), `powers`
/// their weights (Cone::around).
fn emitter_cone(scene: &Scene, triangles: &[u32], records: &[Emitter], powers: &[f64]) -> Option<Cone> {
    Cone::around(triangles.iter().zip(records).zip(powers).map(|((&t, e), &w)| (e.normal, double_sided(scene, t), w as f32)))
}

/// The emitters' records: consecutive emitting triangles of one material
/// that make a parallelogram (a quad as exporters write it) are sampled as
/// one (parallelogram.rs); and the lamps with a Spread (lamps.rs): those
/// quads, one-sided rectangles, and the fans of disk and ellipse lamps.
fn emitters(scene: &Scene, triangles: &[u32]) -> (Vec<Emitter>, Vec<Grid>) {
    let mut out: Vec<Emitter> = triangles.iter().map(|&t| &scene.triangles[t as usize]).map(|t| Emitter { normal: t.cross().normalize(), area: t.area(), softbox: NO_SOFTBOX, nearness: Nearness::of(t), quad: None }).collect();
    let mut softboxes = Vec::new();
    let mut k = 0;
    while k + 1 < triangles.len() {
        let (ta, tb) = (triangles[k], triangles[k + 1]);
        let (a, b) = (&scene.triangles[ta as usize], &scene.triangles[tb as usize]);
        match Parallelogram::of(ta, a, tb, b).filter(|_| a.material == b.material) {
            Some(quad) => {
                out[k].quad = Some((quad, k + 1));
                out[k + 1].quad = Some((quad, k));
                let m = &scene.materials[a.material as usize];
                if let (Some(spread), false) = (m.spread, m.double_sided) {
                    let (corner, e1, e2) = quad.frame(&scene.triangles);
                    if let Some(softbox) = Softbox::new(corner, e1, e2, out[k].normal, spread.tan_half()) {
                        out[k].softbox = softboxes.len() as u32;
                        out[k + 1].softbox = softboxes.len() as u32;
                        softboxes.push(Grid::Rectangle(softbox));
                    }
                }
                k += 2;
            }
            None => k += 1,
        }
    }
    let mut k = 0;
    while k < triangles.len() {
        match round_softbox(scene, &triangles[k..], &out[k..]) {
            Some(lamp) => {
                out[k..k + lamp.segments()].iter_mut().for_each(|e| e.softbox = softboxes.len() as u32);
                softboxes.push(Grid::Round { lamp, first: k });
                k += lamp.segments();
            }
            None => k += 1,
        }
    }
    (out, softboxes)
}

/// The disk or ellipse lamp with a Spread whose fan `triangles` start
/// with: a one-sided lamp's material with a Spread,
/// whole (lamps.rs writes the centre first, then the rim points of each
/// segment, in turn).
fn round_softbox(scene: &Scene, triangles: &[u32], records: &[Emitter]) -> Option<RoundSoftbox> {
    let tri = |k: usize| &scene.triangles[triangles[k] as usize];
    let material = tri(0).material;
    let m = &scene.materials[material as usize];
    let spread = m.spread.filter(|_| m.lamp && !m.double_sided && records[0].quad.is_none())?;
    let centre = tri(0).p()[0];
    let segments = (0..triangles.len()).take_while(|&k| tri(k).material == material && tri(k).p()[0] == centre).count();
    // A rectangle lamp's two triangles share their first corner too; a
    // fan whose segments make no quarter turns `RoundSoftbox::new` refuses.
    if segments < 8 {
        return None;
    }
    // The rim point two neighbouring segments share.
    let shared = |a: usize, b: usize| tri(a).p()[1..].iter().copied().find(|v| tri(b).p()[1..].contains(v));
    let (rim_x, rim_y) = (shared(segments - 1, 0)?, shared(segments / 4 - 1, segments / 4)?);
    let area = records[..segments].iter().map(|e| e.area).sum();
    RoundSoftbox::new(centre, rim_x, rim_y, records[0].normal, spread.tan_half(), segments, area)
}

/// The local lights as a light tree's nodes would see them, emitting
/// triangles and points/spots apart, so that a bulb beside a lamp does not
/// hide which way the lamp shines.
struct LocalBound {
    emitters: Bound,
    points: Bound,
}

impl LocalBound {
    /// An estimate of the local lights' irradiance at `p` on a surface
    /// facing them (W·m⁻²), as the World's π·L̄ is on an open surface.
    fn irradiance(&self, p: Vec3) -> f32 {
        self.emitters.irradiance(p) + self.points.irradiance(p)
    }
}

/// Some lights' power (W), the centre and squared radius of a sphere
/// holding them and, for emitting triangles whose normals lie within 90°
/// of a common axis, that cone (the power is then one face's).
#[derive(Default)]
struct Bound {
    power: f32,
    centre: Vec3,
    radius2: f32,
    cone: Option<Cone>,
}

impl Bound {
    /// `power` watts from points within `lo..hi` (empty: no light).
    fn new(power: f64, lo: Vec3, hi: Vec3, cone: Option<Cone>) -> Self {
        if !(power > 0.0 && lo.x <= hi.x) {
            return Bound::default();
        }
        Bound { power: power as f32, centre: 0.5 * (lo + hi), radius2: (0.5 * (hi - lo)).length_squared(), cone }
    }

    /// A point light gives I/d² = P/(4π d²); a one-sided Lambertian
    /// emitter has I(θ) = (P/π) cos θ, four times that in front of it and
    /// nothing behind, which the isotropic estimate missed: in front of a
    /// Blender area light the World took more light samples than its light
    /// was worth there. A two-sided panel gives (P/π)|cos θ|, P one face's.
    fn irradiance(&self, p: Vec3) -> f32 {
        if !(self.power > 0.0) {
            return 0.0;
        }
        let v = p - self.centre;
        let dist2 = v.length_squared();
        let d2 = dist2.max(self.radius2).max(1e-12);
        let Some(cone) = &self.cone else { return self.power / (4.0 * std::f32::consts::PI * d2) };
        let factor = cone.cos_bound(v, dist2, self.radius2);
        self.power * factor / (std::f32::consts::PI * d2)
    }
}

/// What light sampling picked.
pub enum LightChoice {
    Area(LightSample),
    /// Scene punctual light `index`, picked with this probability.
    Punctual { index: usize, probability: f32 },
    /// The World (environment.rs), picked with this probability.
    World { probability: f32 },
}

/// What `Lights::pick` picked: a light whose sample it is, or an emitter
/// of the local lights (`local` their share) to draw a point on, with its
/// area density once picked (None: by power).
pub enum Picked {
    Chosen(LightChoice),
    Emitter { pick: usize, local: f32, density: Option<f32> },
}

/// A point on an emitter.
pub struct LightSample {
    pub triangle: u32,
    pub b1: f32,
    pub b2: f32,
    pub point: Vec3,
    /// Unit face normal of the emitter (its front side).
    pub normal: Vec3,
    density: Density,
}

/// How a light sample's density is known: per steradian where it was drawn
/// by solid angle, else per unit area of the emitter — the shading point
/// converts it with the distance and cosine it computes anyway (here they
/// had been a square root and three divisions of every light sample).
#[derive(Clone, Copy)]
enum Density {
    SolidAngle(f32),
    Area(f32),
}

impl LightSample {
    /// Density of the direction towards the point, per steradian at a
    /// shading point √`dist2` away that sees the emitter with cosine
    /// `cos_light`; infinite where the emitter is seen edge-on.
    pub fn pdf(&self, dist2: f32, cos_light: f32) -> f32 {
        Self::pdf_of(self.density, dist2, cos_light)
    }

    fn pdf_of(density: Density, dist2: f32, cos_light: f32) -> f32 {
        match density {
            Density::SolidAngle(pdf) => pdf,
            Density::Area(pdf_area) => solid_angle_density(pdf_area, dist2, cos_light),
        }
    }
}

/// The density of a point drawn from `clip` of a softbox picked with
/// probability `picked`: per steradian where the clip is drawn by solid
/// angle, else per unit area.
fn clipped_density(picked: f32, clip: &Clip) -> Density {
    match &clip.view {
        Some(view) => Density::SolidAngle(picked / view.solid_angle),
        None => Density::Area(picked / clip.area),
    }
}

/// The density of a point drawn by area from the circle of `radius` of a
/// round softbox picked with probability `picked`.
fn circle_density(picked: f32, radius: f32) -> Density {
    Density::Area(picked / (std::f32::consts::PI * radius * radius))
}

/// Where a light subpath starts (`Lights::sample_emission`).
pub struct EmissionSample {
    pub triangle: u32,
    /// The point on the emitter, moved off it by its error bound.
    pub origin: Vec3,
    /// Unit normal of the emitting face.
    pub normal: Vec3,
    /// Unit direction of the first ray, cosine-distributed about `normal`
    /// (within a Spread's cone: `Spread::emission_direction`).
    pub dir: Vec3,
    /// Radiance leaving along `dir` (W·sr⁻¹·m⁻²).
    pub le: Vec3,
    /// `Lights::emission_density` of the point and face, times the
    /// density of `dir` over a cosine's (`Material::emission_direction_weight`):
    /// the subpath's α is Le·π over it.
    pub density: f32,
}

/// Where a light subpath starts from a point, spot or sun light
/// (`Lights::sample_start`, `PunctualLight::start`).
pub struct PointEmission {
    /// Scene punctual light index.
    pub index: u32,
    pub origin: Vec3,
    pub dir: Vec3,
    /// The subpath's throughput as it leaves: I(dir) / (p_pick · pdf_dir).
    pub alpha: Vec3,
    /// The probability of picking this light (by power among all local
    /// lights).
    pub probability: f32,
    /// The solid-angle density of `dir`.
    pub pdf_dir: f32,
}

/// The start of a light subpath: a point of an emitting triangle or a
/// point, spot or sun light.
pub enum Start {
    Emitter(EmissionSample),
    Point(PointEmission),
}

/// Where light subpaths start from suns: through a square across a sun's
/// light through the centre of the scene's bounding sphere (of radius R),
/// at a point drawn from cells by where the sun's light through each
/// lands (sun_cells.rs), along the sun's light (or uniformly within its
/// cone, for a sized sun), from outside the sphere. A start stands for
/// the light that crosses the area one over the cells' density there.
/// Each sun is picked
/// by its power E·πR² times the share of its light that lands in view,
/// and the suns together take `share` of all starts. Placed once the
/// scene's BVH is built (`Lights::place_sun_starts`); before, suns start
/// no subpaths.
struct SunStarts {
    /// Of all subpaths: the suns' part of the power where other lights
    /// start some too, at most `MAX_SUN_SHARE`; else all of them.
    share: f32,
    suns: Vec<SunStart>,
    centre: Vec3,
    radius: f32,
}

/// One sun's part of `SunStarts`.
struct SunStart {
    /// The sun's index among the scene's punctual lights.
    index: usize,
    /// Its probability among the suns.
    probability: f32,
    cells: SunCells,
}

/// The suns' share of the light subpaths' starts at most, where other
/// lights start subpaths too: a sun's power over the scene's disk may be
/// light that lands outside, on a roof or a ground plane, and would leave
/// a room's lamps few subpaths. With starts uniform on the disk and the
/// suns' whole power counted, the Cornell box under a sun its roof hides
/// (relMSE at 16 spp, 8 seeds, against the build before suns started
/// subpaths): +8.0% ± 0.4 at a quarter, +20.7% ± 0.4 at a half; the glass
/// sphere with a 5° sun beside its lamp, whose caustic the sun's subpaths
/// carry: at 4 spp −41% ± 23 at a quarter and −68% ± 28 at a half (16
/// seeds), at 16 spp −55% ± 20 at a quarter (8 seeds). Now that a sun's
/// power counts only for its share that lands in view (sun_cells.rs),
/// the roof-hidden sun starts none, and the glass sphere's share is
/// below a quarter (the same image with the bound at 1): the bound stays
/// for a sun whose light lands in view but outside a room, through its
/// window.
const MAX_SUN_SHARE: f32 = 0.25;

impl SunStarts {
    /// The suns' starts, once `ctx`'s BVH is built, beside local lights of
    /// power `local_power`: None without a sun that shines.
    fn new(ctx: &crate::integrator::Context, local_power: f64) -> Option<Self> {
        let scene = ctx.scene;
        let (centre, radius) = scene_sphere(scene);
        let suns: Vec<(usize, f64)> = scene
            .punctual
            .iter()
            .enumerate()
            .filter(|(_, l)| l.kind == crate::punctual::PunctualKind::Sun)
            .map(|(i, l)| (i, l.power(radius)))
            .filter(|&(_, p)| p > 0.0 && p.is_finite())
            .collect();
        if suns.is_empty() {
            return None;
        }
        let placed: Vec<(usize, f64, SunCells, f32)> = suns
            .into_iter()
            .map(|(i, power)| {
                let (cells, seen) = SunCells::new(ctx, scene.punctual[i].direction, centre, radius);
                (i, power, cells, seen)
            })
            .collect();
        // Each sun's power times the share of its light that lands in
        // view; their whole powers where none of it does, without other
        // lights to start subpaths.
        let seen: Vec<f64> = placed.iter().map(|&(_, p, _, f)| p * f as f64).collect();
        let counted = if seen.iter().sum::<f64>() > 0.0 || local_power > 0.0 { seen } else { placed.iter().map(|&(_, p, _, _)| p).collect() };
        let total: f64 = counted.iter().sum();
        let share = if local_power > 0.0 { ((total / (total + local_power)) as f32).min(MAX_SUN_SHARE) } else { 1.0 };
        let suns = placed
            .into_iter()
            .zip(counted)
            .map(|((index, _, cells, _), p)| SunStart { index, probability: if total > 0.0 { (p / total) as f32 } else { 0.0 }, cells })
            .collect();
        Some(SunStarts { share, suns, centre, radius })
    }

    /// Sun `index`'s probability among the suns; 0 for any other light.
    fn probability(&self, index: usize) -> f32 {
        self.suns.iter().find(|s| s.index == index).map_or(0.0, |s| s.probability)
    }
}

impl Lights {
    pub fn new(scene: &Scene) -> Self {
        let (triangles, mut powers): (Vec<u32>, Vec<f64>) = scene
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| (i as u32, std::f64::consts::PI * t.area() as f64 * luminance(scene.materials[t.material as usize].emission) as f64))
            .filter(|&(_, power)| power > 0.0)
            .unzip();
        if !scene.punctual.is_empty() {
            let radius = scene_radius(scene);
            powers.extend(scene.punctual.iter().map(|l| l.power(radius)));
        }
        // Where the local lights are, and their power: emitting triangles
        // and points/spots apart.
        let (mut lo, mut hi, mut emitted, mut suns) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0.0f64, Vec::new());
        for (&t, &power) in triangles.iter().zip(&powers) {
            let tri = &scene.triangles[t as usize];
            tri.p().iter().for_each(|&v| (lo, hi) = (lo.min(v), hi.max(v)));
            emitted += power;
        }
        // Powers count one face; isotropically, a two-sided emitter shines
        // with both.
        let (records, softboxes) = emitters(scene, &triangles);
        let cone = emitter_cone(scene, &triangles, &records, &powers[..triangles.len()]);
        if cone.is_none() {
            emitted += triangles.iter().zip(&powers).filter(|&(&t, _)| double_sided(scene, t)).map(|(_, &p)| p).sum::<f64>();
        }
        let emitter_bound = Bound::new(emitted, lo, hi, cone);
        let (mut lo, mut hi, mut pointed) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0.0f64);
        for (index, (light, power)) in scene.punctual.iter().zip(&mut powers[triangles.len()..]).enumerate() {
            if let crate::punctual::PunctualKind::Sun = light.kind {
                let irradiance = luminance(light.intensity);
                if irradiance > 0.0 && irradiance.is_finite() {
                    suns.push((index, irradiance));
                }
                *power = 0.0;
            } else {
                (lo, hi) = (lo.min(light.position), hi.max(light.position));
                pointed += *power;
            }
        }
        let local = LocalBound { emitters: emitter_bound, points: Bound::new(pointed, lo, hi, None) };
        let world_irradiance = if scene.has_world() { std::f32::consts::PI * luminance(scene.world_mean()) } else { 0.0 };
        let world_excess = if world_irradiance > 0.0 { std::f32::consts::PI * scene.world_excess() } else { 0.0 };
        let sunlight = suns.iter().map(|&(_, e)| e).sum::<f32>();
        let weights = |world: f32| DistantWeights { world, total: world + sunlight };
        let tree = LocalTree::new(scene, &triangles, &records, &softboxes, &powers);
        let distribution = Distribution1D::new(powers);
        let sized: Vec<usize> = scene.punctual.iter().enumerate().filter(|(_, l)| l.size > 0.0).map(|(i, _)| i).collect();
        let sized_local = sized.iter().any(|&i| scene.punctual[i].kind != crate::punctual::PunctualKind::Sun);
        let sized_camera_sees = sized.iter().any(|&i| scene.punctual[i].camera_sees);
        Lights {
            // π/P_total once: a division in f64 had been a tenth of a light sample.
            area_pdf_per_luminance: if distribution.total() > 0.0 { (std::f64::consts::PI / distribution.total()) as f32 } else { 0.0 },
            emitters: records,
            triangles,
            distribution,
            world_irradiance,
            with_mis: weights(world_excess),
            alone: weights(world_irradiance),
            local,
            suns,
            sun_disks: scene.punctual.iter().map(|l| l.sun_disk()).collect(),
            sized,
            sized_local,
            sized_camera_sees,
            sun_starts: None,
            tree,
            portals: Portals::new(scene.portals.clone()),
            softboxes,
        }
    }

    /// Pick local lights by power alone, as with one light, leaving the
    /// light tree out (to measure what it gives).
    pub fn pick_by_power(&mut self) {
        self.tree = None;
    }

    /// How many lights the light tree holds; 0 without one.
    pub fn tree_size(&self) -> usize {
        self.tree.as_ref().map_or(0, |t| t.tree.len())
    }

    /// Whether the tree's picks come from a grid (light_cache.rs).
    pub fn tree_cached(&self) -> bool {
        self.tree.as_ref().is_some_and(|t| t.tree.cached())
    }

    pub fn is_empty(&self) -> bool {
        self.distribution.is_empty() && !self.has_distant()
    }

    /// Whether the World gives light (light sampling may still leave a
    /// constant one to BSDF samples where there are other lights).
    pub fn has_world(&self) -> bool {
        self.world_irradiance > 0.0
    }

    fn has_distant(&self) -> bool {
        self.has_world() || !self.suns.is_empty()
    }

    /// The distant lights' weights at `p`. Where `p` faces portals the
    /// World's light comes in through them, where BSDF samples find it only
    /// by chance, and light samples look at them (portals.rs): the World
    /// then weighs lum(L̄)·Ω, Ω the portals' solid angle from `p`, the most
    /// irradiance a World of that mean luminance could give through them.
    /// Only under MIS: without it light samples alone see the World, and
    /// they must look everywhere.
    fn distant_weights(&self, p: Vec3, mis: bool) -> DistantWeights {
        let weights = if mis { self.with_mis } else { self.alone };
        if !mis || self.portals.is_empty() || !self.has_world() {
            return weights;
        }
        let omega = self.portals.solid_angle(p);
        if omega > 0.0 {
            let world = self.world_irradiance * omega / std::f32::consts::PI;
            DistantWeights { world, total: weights.total - weights.world + world }
        } else {
            weights
        }
    }

    /// The probability of picking the distant group (World and suns) for a
    /// point at `p`: 1 without local lights, 0 where the group weighs
    /// nothing (a constant World under MIS), else its share of the
    /// estimated irradiance, kept in [0.05, 0.95] so that neither side
    /// starves where the estimate is crude.
    fn distant_probability(&self, p: Vec3, mis: bool) -> f32 {
        self.distant_probability_keeping(p, mis, &mut None)
    }

    /// `distant_probability`, leaving in `weights` the group's weights at
    /// `p` where it needed them, so that a caller who needs them too does
    /// not compute them again: behind portals each is their solid angle,
    /// which had been computed two to five times a vertex.
    fn distant_probability_keeping(&self, p: Vec3, mis: bool, weights: &mut Option<DistantWeights>) -> f32 {
        if !self.has_distant() {
            return 0.0;
        }
        if self.distribution.is_empty() {
            return 1.0;
        }
        let weight = weights.get_or_insert_with(|| self.distant_weights(p, mis)).total;
        if !(weight > 0.0) {
            return 0.0;
        }
        let share = weight / (weight + self.local.irradiance(p));
        if share.is_finite() { share.clamp(0.05, 0.95) } else { 0.5 }
    }

    /// `distant_probability` and the group's weights at `p`, each computed
    /// once, for callers that need both.
    fn distant_group(&self, p: Vec3, mis: bool) -> (f32, DistantWeights) {
        let mut weights = None;
        let distant = self.distant_probability_keeping(p, mis, &mut weights);
        (distant, weights.unwrap_or_else(|| self.distant_weights(p, mis)))
    }

    /// The World's share of the distant group's picks: all of them when
    /// the World is the only light.
    fn world_in_group(weights: DistantWeights) -> f32 {
        if weights.total > 0.0 { weights.world / weights.total } else { 1.0 }
    }

    /// The probability of picking the World for a point at `p`.
    pub fn world_probability(&self, p: Vec3, mis: bool) -> f32 {
        if !self.has_world() {
            return 0.0;
        }
        let (distant, weights) = self.distant_group(p, mis);
        distant * Self::world_in_group(weights)
    }

    /// Area density of the points of emitting scene triangle `triangle`,
    /// for a point at `p` whose light counts from above the plane of
    /// normal `n` only (zero: from every side; `LightTree::sample`).
    pub fn pdf_area(&self, scene: &Scene, triangle: u32, p: Vec3, n: Vec3, mis: bool) -> f32 {
        let local = match &self.tree {
            // The emitters are in scene order.
            Some(tree) => self.triangles.binary_search(&triangle).map_or(0.0, |k| tree.area_density(k, p, n)),
            None => self.local_pdf_area(scene.material_of(triangle).emission),
        };
        (1.0 - self.distant_probability(p, mis)) * local
    }

    /// The area density of a point on an emitter of radiance `le` once a
    /// local light is to be picked by power.
    fn local_pdf_area(&self, le: Vec3) -> f32 {
        luminance(le) * self.area_pdf_per_luminance
    }

    /// The probability `sample` picks scene punctual light `index` for a
    /// point at `p` of normal `n`.
    pub fn punctual_probability(&self, index: usize, p: Vec3, n: Vec3, mis: bool) -> f32 {
        if let Some(&(_, irradiance)) = self.suns.iter().find(|&&(i, _)| i == index) {
            let (distant, weights) = self.distant_group(p, mis);
            return distant * (irradiance / weights.total);
        }
        let local = match &self.tree {
            Some(tree) => match tree.of_punctual[index] {
                NOT_IN_TREE => 0.0,
                item => tree.tree.probability(item as usize, p, n),
            },
            None => self.distribution.probability(self.triangles.len() + index) as f32,
        };
        (1.0 - self.distant_probability(p, mis)) * local
    }

    /// A light for a point at `p` of normal `n` (zero: light counts from
    /// every side), picked with the weights `mis` asks for.
    pub fn sample(&self, scene: &Scene, p: Vec3, n: Vec3, u_pick: f32, u: Vec2, mis: bool) -> Option<LightChoice> {
        self.point_on(scene, p, self.pick(p, n, u_pick, mis)?, u)
    }

    /// `sample`'s first half: which light, from `u_pick` alone. Apart so
    /// that a caller can put work of its own between the pick, whose walk
    /// down the light tree is a chain of dependent operations, and what
    /// waits for it.
    #[inline(always)]
    pub fn pick(&self, p: Vec3, n: Vec3, u_pick: f32, mis: bool) -> Option<Picked> {
        self.pick_at(None, p, n, u_pick, mis)
    }

    /// Where a pick at `p` and `n` reads the local lights' grid, where
    /// they have one, its lines asked for: for `pick_at` once the vertex's
    /// BSDF is set up (light_cache.rs).
    #[inline(always)]
    pub fn pick_site(&self, p: Vec3, n: Vec3) -> Option<Site> {
        self.tree.as_ref().and_then(|tree| tree.tree.site_fetched(p, n))
    }

    /// `pick`, with `pick_site(p, n)`'s site where the caller has it.
    #[inline(always)]
    pub fn pick_at(&self, site: Option<Site>, p: Vec3, n: Vec3, u_pick: f32, mis: bool) -> Option<Picked> {
        if self.is_empty() {
            return None;
        }
        let mut weights = None;
        let distant = self.distant_probability_keeping(p, mis, &mut weights);
        if u_pick < distant {
            // Within the group by irradiance: the World, then each sun.
            let weights = weights.unwrap_or_else(|| self.distant_weights(p, mis));
            let world = Self::world_in_group(weights);
            let mut rest = u_pick / distant - world;
            if rest < 0.0 {
                return Some(Picked::Chosen(LightChoice::World { probability: distant * world }));
            }
            for &(index, irradiance) in &self.suns {
                rest -= irradiance / weights.total;
                if rest < 0.0 {
                    return Some(Picked::Chosen(LightChoice::Punctual { index, probability: distant * (irradiance / weights.total) }));
                }
            }
            // Rounding past the last one: it is the last one.
            return Some(Picked::Chosen(match self.suns.last() {
                Some(&(index, irradiance)) => LightChoice::Punctual { index, probability: distant * (irradiance / weights.total) },
                None => LightChoice::World { probability: distant * world },
            }));
        }
        let local = 1.0 - distant;
        let u_local = ((u_pick - distant) / local).min(1.0 - f32::EPSILON);
        // The emitter, and its area density once local lights are picked
        // (None: by power, the same for every emitter of one radiance).
        let (pick, density) = match &self.tree {
            Some(tree) => {
                let (item, probability, rest) = tree.tree.sample_at(site, p, n, u_local);
                match tree.items[item] {
                    TreeItem::Punctual(index) => {
                        let probability = local * probability;
                        return (probability > 0.0).then_some(Picked::Chosen(LightChoice::Punctual { index, probability }));
                    }
                    // A quad's half, or a round lamp's segment, by area.
                    TreeItem::Emitters { first, count, area } => {
                        let k = match count {
                            1 => first,
                            2 => if rest * area >= self.emitters[first].area { first + 1 } else { first },
                            _ => self.segment_by_area(first, count, rest * area),
                        };
                        (k, Some(probability / area))
                    }
                }
            }
            None => {
                let pick = self.distribution.sample(u_local);
                if pick >= self.triangles.len() {
                    let probability = local * self.distribution.probability(pick) as f32;
                    return (probability > 0.0).then_some(Picked::Chosen(LightChoice::Punctual { index: pick - self.triangles.len(), probability }));
                }
                (pick, None)
            }
        };
        Some(Picked::Emitter { pick, local, density })
    }

    /// The emitter of `count` from `first` on whose share of their summed
    /// areas holds `target` (a round lamp's segment; apart from the quads'
    /// one comparison, which a loop inline had made 1.5% more instructions
    /// in the lamp hall).
    #[cold]
    #[inline(never)]
    fn segment_by_area(&self, first: usize, count: usize, target: f32) -> usize {
        let (mut k, mut below) = (first, self.emitters[first].area);
        while k + 1 < first + count && target >= below {
            k += 1;
            below += self.emitters[k].area;
        }
        k
    }

    /// `sample`'s second half: a point on the emitter `picked`, or the
    /// light picked.
    #[inline(always)]
    pub fn point_on(&self, scene: &Scene, p: Vec3, picked: Picked, u: Vec2) -> Option<LightChoice> {
        let (pick, local, density) = match picked {
            Picked::Chosen(choice) => return Some(choice),
            Picked::Emitter { pick, local, density } => (pick, local, density),
        };
        let triangle = self.triangles[pick];
        let emitter = &self.emitters[pick];
        let pdf_area = local * density.unwrap_or_else(|| self.local_pdf_area(scene.material_of(triangle).emission));
        if !(pdf_area > 0.0) {
            return None;
        }
        if !self.softboxes.is_empty() && emitter.softbox != NO_SOFTBOX {
            return self.point_on_softbox(scene, p, pick, pdf_area, u);
        }
        self.point_on_emitter(scene, p, pick, pdf_area, u)
    }

    /// A point on emitter `pick` (on its quad, where it is half of one),
    /// `pdf_area` the density of a point drawn over it.
    #[inline(always)]
    fn point_on_emitter(&self, scene: &Scene, p: Vec3, pick: usize, pdf_area: f32, u: Vec2) -> Option<LightChoice> {
        let mut triangle = self.triangles[pick];
        let emitter = &self.emitters[pick];
        let mut tri = &scene.triangles[triangle as usize];
        let mut normal = emitter.normal;
        let view = close_solid_angle(p, tri, &emitter.nearness).and_then(|omega| SphericalTriangle::new(p, &tri.p(), omega));
        let b = match (&view, &emitter.quad) {
            (Some(view), _) => barycentrics_along(p, view.sample(u), tri),
            // A quad is drawn whole where neither half is sampled by solid
            // angle: the density is the same, pdf_emitter's for either.
            (None, Some((quad, partner))) if close_solid_angle(p, &scene.triangles[quad.partner(triangle) as usize], &self.emitters[*partner].nearness).is_none() => {
                let (t, b) = quad.sample(u);
                if t != triangle {
                    triangle = t;
                    tri = &scene.triangles[t as usize];
                    normal = self.emitters[*partner].normal;
                }
                b
            }
            (None, _) => uniform_triangle(u),
        };
        let [p0, p1, p2] = tri.p();
        let point = p0 * (1.0 - b.x - b.y) + p1 * b.x + p2 * b.y;
        let density = match view {
            Some(view) => Density::SolidAngle(pdf_area * emitter.area / view.solid_angle),
            None => Density::Area(pdf_area),
        };
        Some(LightChoice::Area(LightSample { triangle, b1: b.x, b2: b.y, point, normal, density }))
    }

    /// A point on the lamp with a Spread that emitter `pick` is part of,
    /// from the part `p` sees through its grid; `pdf_area` the density of
    /// a point drawn over the whole lamp, whose pick it scales to the part.
    #[cold]
    #[inline(never)]
    fn point_on_softbox(&self, scene: &Scene, p: Vec3, pick: usize, pdf_area: f32, u: Vec2) -> Option<LightChoice> {
        let emitter = &self.emitters[pick];
        let drawn = match &self.softboxes[emitter.softbox as usize] {
            Grid::Rectangle(softbox) => (|| {
                let (quad, _) = emitter.quad.as_ref()?;
                let clip = softbox.seen_from(p)?;
                let (triangle, b) = quad.sample(clip.sample(softbox, p, u)?);
                Some((triangle, b, clipped_density(pdf_area * softbox.area, &clip)))
            })(),
            Grid::Round { lamp, first, .. } => match lamp.reach(p) {
                Reach::Behind => None,
                Reach::Whole => return self.point_on_emitter(scene, p, pick, pdf_area, u),
                Reach::Circle { foot, radius } => (|| {
                    let point = lamp.in_circle(foot, radius, u);
                    let triangle = self.triangles[first + lamp.segment(point)];
                    // A point beyond the rim is lost, as in Cycles.
                    let b = plane_barycentrics(point, &scene.triangles[triangle as usize]).filter(|b| b.min_element() >= 0.0 && b.x + b.y <= 1.0)?;
                    Some((triangle, b, circle_density(pdf_area * lamp.area, radius)))
                })(),
            },
        };
        drawn.map(|(triangle, b, density)| {
            let [p0, p1, p2] = scene.triangles[triangle as usize].p();
            let point = p0 * (1.0 - b.x - b.y) + p1 * b.x + p2 * b.y;
            LightChoice::Area(LightSample { triangle, b1: b.x, b2: b.y, point, normal: emitter.normal, density })
        })
    }

    /// The lamp with a Spread scene triangle `triangle` is part of, if any.
    #[inline]
    fn softbox_of(&self, triangle: u32) -> Option<&Grid> {
        if self.softboxes.is_empty() {
            return None;
        }
        let k = self.triangles.binary_search(&triangle).ok()?;
        self.softboxes.get(self.emitters[k].softbox as usize)
    }

    /// The area density with which `sample_emission` starts a light
    /// subpath on a point (and face) of an emitter of material `m`: its
    /// pick by power and point by area, halved for a two-sided emitter,
    /// whose face is a coin toss. The same wherever the path is going,
    /// unlike `pdf_area`; and times the share of the starts the suns
    /// leave to the local lights.
    pub fn emission_density(&self, m: &Material) -> f32 {
        let face = if m.double_sided { 0.5 } else { 1.0 };
        self.local_pdf_area(m.emission) * face * self.local_start_share()
    }

    /// The share of the light subpaths' starts on local lights (emitters,
    /// points and spots): what the suns leave (`SunStarts`).
    fn local_start_share(&self) -> f32 {
        self.sun_starts.as_ref().map_or(1.0, |s| 1.0 - s.share)
    }

    /// The start of a light subpath from an emitting triangle
    /// (`sample_start`); None where the pick lands on a punctual light.
    pub fn sample_emission(&self, scene: &Scene, u_pick: f32, u_point: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        match self.sample_start(scene, u_pick, u_point, u_dir, None)? {
            Start::Emitter(start) => Some(start),
            Start::Point(_) => None,
        }
    }

    /// The probability with which `sample_start` picks punctual light
    /// `index`: a point or spot by power among the local lights, a sun by
    /// its power among the suns (`SunStarts`).
    pub fn point_start_probability(&self, scene: &Scene, index: usize) -> f32 {
        match scene.punctual.get(index) {
            Some(light) if light.kind == crate::punctual::PunctualKind::Sun => self.sun_starts.as_ref().map_or(0.0, |s| s.share * s.probability(index)),
            Some(_) => self.distribution.probability(self.triangles.len() + index) as f32 * self.local_start_share(),
            None => 0.0,
        }
    }

    /// Whether any light starts light subpaths: an emitting triangle, a
    /// point or spot light, or a sun.
    pub fn starts_subpaths(&self, scene: &Scene) -> bool {
        self.sun_starts.is_some() || (!self.distribution.is_empty() && (!self.triangles.is_empty() || (0..scene.punctual.len()).any(|i| self.point_start_probability(scene, i) > 0.0)))
    }

    /// What `start_pdf` of punctual light `light` is divided by toward a
    /// point at squared distance `d2` that a start leaving along unit
    /// `travel` reaches (`PunctualLight::start_spread`): for a sun, the
    /// cosine between `travel` and the sun's light over the cells' density
    /// (per unit area) where the line through `p` (the point reached)
    /// along `travel` crosses them (`SunStarts`): infinite where they draw
    /// nothing, or the sun starts no subpaths.
    pub fn start_spread(&self, scene: &Scene, index: usize, d2: f32, travel: Vec3, p: Vec3) -> f32 {
        let light = &scene.punctual[index];
        if light.kind != crate::punctual::PunctualKind::Sun {
            return light.start_spread(d2);
        }
        let density = self.sun_starts.as_ref().and_then(|s| s.suns.iter().find(|s| s.index == index)).map_or(0.0, |s| s.cells.density(p, travel));
        if density > 0.0 { travel.dot(light.direction).max(0.0) / density } else { f32::INFINITY }
    }

    /// Suns' light subpaths (`SunStarts`), once `ctx`'s BVH is built.
    pub fn place_sun_starts(ctx: &mut crate::integrator::Context) {
        ctx.lights.sun_starts = SunStarts::new(ctx, ctx.lights.distribution.total());
    }

    /// A start from a sun (`SunStarts`), `u_pick` picking the sun; with
    /// `aim`, from the disk an aim sphere casts across the sun's light
    /// instead of the scene's (its α then not the start's).
    fn sun_start(&self, scene: &Scene, u_pick: f32, u_point: Vec2, u_dir: Vec2, aim: Option<&Aim>) -> Option<PointEmission> {
        let starts = self.sun_starts.as_ref()?;
        let mut rest = u_pick;
        let sun = starts.suns.iter().find(|s| {
            rest -= s.probability;
            rest < 0.0
        }).or(starts.suns.last())?;
        let (index, within) = (sun.index, sun.probability);
        let light = scene.punctual.get(index)?;
        let travel = light.direction;
        let (dir, pdf_dir, radiance) = match self.sun_disks.get(index).copied().flatten() {
            // Within the cone of the sun's disk, of radiance E/(π sin²θ).
            Some(disk) => (disk.leaving(u_dir), disk.pdf(), disk.radiance(light.intensity)),
            None => (travel, 1.0, light.intensity),
        };
        // A point the start passes, the way back from it to outside the
        // scene's sphere, and the area the start stands for.
        let (through, back, area) = match aim {
            // The aim's point, behind it along the sun's axis; its α, not
            // the start's, as if from the scene's disk.
            Some(aim) => (aim.across(travel, u_point)?, travel, std::f32::consts::PI * starts.radius * starts.radius),
            // The point drawn on the square through the scene's centre,
            // behind it along the start's own way.
            None => {
                let (x, density) = sun.cells.sample(u_point);
                (x, dir, 1.0 / density)
            }
        };
        let origin = through - back * (starts.radius * 1.01 + (through - starts.centre).length());
        let probability = starts.share * within;
        // α = L·cos·A / (p·pdf_dir), the light through the area A a start
        // stands for (E·A/p for a sun without a size): one over the cells'
        // density at the start's point.
        let alpha = radiance * (dir.dot(travel) * area / (probability * pdf_dir));
        (alpha.is_finite() && alpha.max_element() > 0.0 && origin.is_finite()).then_some(PointEmission { index: index as u32, origin, dir, alpha, probability, pdf_dir })
    }

    /// The start of a light subpath (light_paths.rs): a light by power;
    /// on an emitter a point by area, a face, and a cosine-weighted
    /// direction from it (within the cone of a lamp's Spread); from a
    /// point or spot light as `PunctualLight::start` says; from a sun as
    /// `SunStarts` says, for their share. None where the start emits
    /// nothing.
    /// With `aim`, an emitter's direction is drawn toward its sphere
    /// instead (caustic_guide.rs): its density and α are then not the
    /// start's, and only where the subpath goes counts.
    pub fn sample_start(&self, scene: &Scene, u_pick: f32, u_point: Vec2, u_dir: Vec2, aim: Option<&Aim>) -> Option<Start> {
        let mut u_pick = u_pick;
        if let Some(starts) = &self.sun_starts {
            if u_pick < starts.share {
                return self.sun_start(scene, u_pick / starts.share, u_point, u_dir, aim).map(Start::Point);
            }
            u_pick = ((u_pick - starts.share) / (1.0 - starts.share)).min(1.0 - f32::EPSILON);
        }
        if self.distribution.is_empty() {
            return None;
        }
        let (pick, u_face) = self.distribution.sample_remapped(u_pick);
        let Some(&triangle) = self.triangles.get(pick) else {
            return self.point_start(scene, pick - self.triangles.len(), u_point, u_dir, aim).map(Start::Point);
        };
        let tri = &scene.triangles[triangle as usize];
        let m = &scene.materials[tri.material as usize];
        let b = uniform_triangle(u_point);
        let front = !m.double_sided || u_face < 0.5;
        let normal = if front { self.emitters[pick].normal } else { -self.emitters[pick].normal };
        let (point, error) = point_on_triangle(&tri.p(), b.x, b.y);
        let local = match (m.spread, aim) {
            (Some(spread), _) => spread.emission_direction(u_dir),
            (None, Some(aim)) => aim.direction(point, normal, u_dir)?,
            (None, None) => cosine_hemisphere(u_dir),
        };
        let le = shading::emission_at(scene, m, triangle, Barycentric::new(b.x, b.y), front) * m.spread_factor(local.z);
        let weight = m.emission_direction_weight(local.z);
        if le == Vec3::ZERO || !(local.z > 0.0 && weight > 0.0) {
            return None;
        }
        let origin = offset_origin(point, error, normal, normal);
        Some(Start::Emitter(EmissionSample { triangle, origin, normal, dir: Frame::from_normal(normal).to_world(local), le, density: self.emission_density(m) * weight }))
    }

    /// `sample_start` from punctual light `index`; with `aim`, toward the
    /// aim's spheres (what it carries is then not an estimate).
    fn point_start(&self, scene: &Scene, index: usize, u_point: Vec2, u_dir: Vec2, aim: Option<&Aim>) -> Option<PointEmission> {
        let light = scene.punctual.get(index)?;
        let probability = self.point_start_probability(scene, index);
        let start = match aim {
            Some(aim) if light.kind != crate::punctual::PunctualKind::Sun => {
                let (dir, pdf_dir) = aim.world_direction(light.position, u_dir)?;
                light.start_along(u_point, dir, pdf_dir)
            }
            _ => light.start(u_point, u_dir)?,
        };
        let alpha = start.intensity / (probability * start.pdf_dir);
        (alpha.is_finite() && alpha != Vec3::ZERO).then_some(PointEmission { index: index as u32, origin: start.origin, dir: start.dir, alpha, probability, pdf_dir: start.pdf_dir })
    }

    /// The density per steradian with which `sample`, from `p`, reaches
    /// `point` of emitting triangle `triangle` at distance √`dist2`,
    /// where the ray meets it with cosine `cos_light`.
    #[allow(clippy::too_many_arguments)]
    pub fn pdf_emitter(&self, scene: &Scene, triangle: u32, p: Vec3, n: Vec3, point: Vec3, dist2: f32, cos_light: f32, mis: bool) -> f32 {
        let tri = &scene.triangles[triangle as usize];
        let pdf_area = self.pdf_area(scene, triangle, p, n, mis);
        match self.softbox_of(triangle) {
            Some(Grid::Rectangle(softbox)) => {
                return match softbox.seen_from(p).filter(|clip| clip.holds(softbox, point)) {
                    Some(clip) => LightSample::pdf_of(clipped_density(pdf_area * softbox.area, &clip), dist2, cos_light),
                    None => 0.0,
                };
            }
            Some(Grid::Round { lamp, .. }) => match lamp.reach(p) {
                Reach::Behind => return 0.0,
                // A point drawn at the circle's rim rounds a hair outside.
                Reach::Circle { foot, radius } if point.distance_squared(foot) <= radius * radius * (1.0 + 1e-4) => {
                    return LightSample::pdf_of(circle_density(pdf_area * lamp.area, radius), dist2, cos_light);
                }
                Reach::Circle { .. } => return 0.0,
                Reach::Whole => {}
            },
            None => {}
        }
        match close_solid_angle(p, tri, &Nearness::of(tri)) {
            Some(omega) => pdf_area * tri.area() / omega,
            None => solid_angle_density(pdf_area, dist2, cos_light),
        }
    }
}

/// The solid angle of the triangle from `p` when p is close enough for its
/// cos'/r² to vary widely — the longest edge longer than the distance to the
/// centroid — and it covers enough to be sampled by solid angle. (Cycles'
/// rule, the distance to the plane, also takes points far out beside the
/// triangle: on the Cornell box it cost 16% more time than this rule for
/// the same error.)
fn close_solid_angle(p: Vec3, tri: &Triangle, nearness: &Nearness) -> Option<f32> {
    if !nearness.close(p) {
        return None;
    }
    let [a, b, c] = tri.p();
    // A point on the emitter itself (a reflective lamp) lies in its plane
    // only up to rounding; seen from there its inside would read as a
    // solid angle near 2π, and a lamp lit itself (Blender's Cornell box
    // came out 0.45% bright). Within rounding of the plane it is in it.
    let n = tri.cross();
    let rounding = 8.0 * f32::EPSILON * p.abs().max(a.abs()).max(b.abs()).max(c.abs()).max_element();
    if !(n.dot(a - p).abs() > rounding * n.length()) {
        return None;
    }
    spherical_triangle::solid_angle(p, &tri.p())
}

/// Where the ray from `p` along `w` crosses the triangle's plane, as
/// barycentrics (b1, b2) clamped onto the triangle (a direction drawn over
/// its solid angle can stray past an edge by rounding).
fn barycentrics_along(p: Vec3, w: Vec3, tri: &Triangle) -> Vec2 {
    let [p0, p1, p2] = tri.p();
    let n = (p1 - p0).cross(p2 - p0);
    let Some(b) = plane_barycentrics(p + w * (n.dot(p0 - p) / n.dot(w)), tri) else {
        return Vec2::splat(1.0 / 3.0);
    };
    let b = b.max(Vec2::ZERO);
    let sum = b.x + b.y;
    if sum > 1.0 { b / sum } else { b }
}

/// The barycentrics (b1, b2) of `x`, a point of the triangle's plane, not
/// clamped to it; None for a degenerate triangle.
fn plane_barycentrics(x: Vec3, tri: &Triangle) -> Option<Vec2> {
    let [p0, p1, p2] = tri.p();
    let (e1, e2, x) = (p1 - p0, p2 - p0, x - p0);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (x1, x2) = (x.dot(e1), x.dot(e2));
    let det = d11 * d22 - d12 * d12;
    let b = Vec2::new((d22 * x1 - d12 * x2) / det, (d11 * x2 - d12 * x1) / det);
    b.is_finite().then_some(b)
}

/// An area density at a point `dist2` away, met with cosine `cos_light`
/// (signed or not), as a density per steradian: pdf_A·r²/|cos'|, infinite
/// edge-on.
pub fn solid_angle_density(pdf_area: f32, dist2: f32, cos_light: f32) -> f32 {
    let c = cos_light.abs();
    if c > 0.0 { dist2 / (c / pdf_area) } else { f32::INFINITY }
}

/// Radius of a sphere about the bounds' centre that holds every surface,
/// where the sun's and the World's power is counted (at least 1 m).
fn scene_radius(scene: &Scene) -> f32 {
    scene_sphere(scene).1
}

/// `scene_radius`'s sphere: its centre (the origin in an empty scene)
/// and radius.
fn scene_sphere(scene: &Scene) -> (Vec3, f32) {
    let (lo, hi) = crate::scene::bounds(&scene.triangles);
    if lo.x > hi.x { (Vec3::ZERO, 1.0) } else { ((lo + hi) * 0.5, (0.5 * (hi - lo).length()).max(1.0)) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::material::Material;
    use crate::scene::Triangle;
    use crate::punctual::{PunctualKind, PunctualLight};

    /// Without the light tree, emitters are picked by power; with it, by
    /// its probabilities, for a receiver's normal or none. Either way the
    /// density integrates to 1 over the emitters and `sample` picks as
    /// `pdf_area` says.
    #[test]
    fn emitters_are_picked_as_their_density_says_and_it_integrates_to_one() {
        let tri = |x: f32, material: u32| Triangle::new([Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)], [Vec3::Z; 3], material);
        let m = |le: f32| Material { emission: Vec3::splat(le), ..Material::default() };
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let scene = Scene::new(vec![tri(0.0, 0), tri(2.0, 1), tri(4.0, 2)], vec![m(1.0), m(3.0), m(0.0)], camera);
        let mut by_power = Lights::new(&scene);
        assert_eq!(by_power.triangles, vec![0, 1]);
        assert_eq!(by_power.tree_size(), 2);
        by_power.pick_by_power();
        let picks = |lights: &Lights, p: Vec3, n: Vec3| {
            let mut counts = [0u32; 2];
            for k in 0..4000 {
                let Some(LightChoice::Area(s)) = lights.sample(&scene, p, n, (k as f32 + 0.5) / 4000.0, Vec2::splat(0.3), true) else { panic!("no light") };
                counts[s.triangle as usize] += 1;
            }
            counts
        };
        assert_eq!(picks(&by_power, Vec3::ZERO, Vec3::ZERO), [1000, 3000]);
        let tree = Lights::new(&scene);
        for p in [Vec3::ZERO, Vec3::new(0.3, 0.3, 1.0), Vec3::new(2.5, 0.2, 0.5), Vec3::new(1.5, 0.5, -3.0)] {
            for n in [Vec3::ZERO, Vec3::Z, -Vec3::Z, Vec3::new(1.0, 0.0, 0.3).normalize()] {
                for lights in [&by_power, &tree] {
                    // ∫ pdf_A dA over the emitters = Σ pdf_A,i A_i = 1.
                    let pdf = [0, 1].map(|t| lights.pdf_area(&scene, t, p, n, true) * 0.5);
                    assert!((pdf[0] + pdf[1] - 1.0).abs() < 1e-6, "{p} {n}: {pdf:?}");
                    let counts = picks(lights, p, n);
                    assert!((counts[0] as f32 - 4000.0 * pdf[0]).abs() <= 2.0, "{p} {n}: {counts:?} {pdf:?}");
                }
            }
        }
        // Facing away from the brighter triangle, a point leaves it all but
        // the share its sphere's rim above the plane keeps.
        let facing_left = Vec3::new(-1.0, 0.0, 0.2).normalize();
        assert!(tree.pdf_area(&scene, 1, Vec3::new(1.5, 0.3, 0.5), facing_left, true) < 0.5 * tree.pdf_area(&scene, 1, Vec3::new(1.5, 0.3, 0.5), Vec3::ZERO, true));
        // Above the brighter triangle its share is higher than by power.
        assert!(tree.pdf_area(&scene, 1, Vec3::new(2.3, 0.3, 0.5), Vec3::ZERO, true) * 0.5 > 0.9);
    }

    /// Lamps with a Spread, `lamps[0]` the one measured (its area's local
    /// extent `size`, its outline a rectangle or a 64-gon), the others
    /// beside it in the light tree: from each of `points`, its light
    /// samples come from the part of it that point sees through the grid
    /// and give what the whole lamp gives there (a midpoint sum over it,
    /// 1200 × 1200 cells) within 4 standard errors + 0.2% (the sum's own
    /// error at the rim), 200,000 samples a point; every sample's
    /// density is the one `pdf_emitter` gives the same point, which MIS
    /// weighs BSDF rays that reach it with. From each of `dark` the grid
    /// lets no light through: no sample, no density.
    fn assert_softbox_light(lamps: &[crate::lamps::AreaLight], points: &[Vec3], dark: &[Vec3]) {
        use crate::lamps::LampShape;
        use crate::rng::Rng;
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let mut scene = Scene::new(vec![], vec![], camera);
        crate::lamps::add_area_lights(&mut scene, lamps).unwrap();
        let lights = Lights::new(&scene);
        assert_eq!(lights.softboxes.len(), lamps.len());
        let measured = scene.triangles[0].material;
        let m = &scene.materials[measured as usize];
        let le = m.emission.x;
        let matrix = glam::Mat4::from_cols_array(&lamps[0].matrix);
        let [sx, sy] = lamps[0].size;
        let round = matches!(lamps[0].shape, LampShape::Disk | LampShape::Ellipse);
        // The 64-gon of lamps.rs, in units of its rim's radii.
        let k = (std::f32::consts::PI / (32.0 * (std::f32::consts::TAU / 64.0).sin())).sqrt();
        let inside = |a: f32, b: f32| {
            let (r, phi) = ((a * a + b * b).sqrt() / k, b.atan2(a).rem_euclid(std::f32::consts::TAU));
            let mid = ((phi / (std::f32::consts::TAU / 64.0)).floor() + 0.5) * std::f32::consts::TAU / 64.0;
            r * (phi - mid).cos() <= (std::f32::consts::PI / 64.0).cos()
        };
        // ∫ L·f(θ) dω over the lamp seen from p, as a sum over its area.
        let whole = |p: Vec3| {
            let (n, reach) = (1200, if round { k } else { 1.0 });
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let (a, b) = (reach * 2.0 * ((i as f32 + 0.5) / n as f32 - 0.5), reach * 2.0 * ((j as f32 + 0.5) / n as f32 - 0.5));
                    if round && !inside(a, b) {
                        continue;
                    }
                    let x = Vec3::from(matrix.transform_point3(glam::Vec3::new(0.5 * sx * a, 0.5 * sy * b, 0.0)));
                    let to = p - x;
                    let cos_out = -to.z / to.length();
                    sum += (le * m.spread_factor(cos_out) * cos_out.max(0.0) / to.length_squared()) as f64;
                }
            }
            sum * ((reach * reach * sx * sy) as f64 / (n * n) as f64)
        };
        let mut rng = Rng::new(5, 0);
        for &p in points {
            let (n, mut sum, mut squares) = (200_000, 0.0f64, 0.0f64);
            for _ in 0..n {
                let Some(LightChoice::Area(s)) = lights.sample(&scene, p, Vec3::ZERO, rng.next_f32(), rng.next_2d(), true) else { continue };
                let to = p - s.point;
                let (dist2, cos_light) = (to.length_squared(), s.normal.dot(to.normalize()));
                let pdf = s.pdf(dist2, cos_light);
                let again = lights.pdf_emitter(&scene, s.triangle, p, Vec3::ZERO, s.point, dist2, cos_light, true);
                assert!((again - pdf).abs() <= 1e-3 * pdf, "{p}: {again} vs {pdf}");
                if scene.triangles[s.triangle as usize].material == measured {
                    let x = (le * m.spread_factor(cos_light) / pdf) as f64;
                    (sum, squares) = (sum + x, squares + x * x);
                }
            }
            let (estimate, expected) = (sum / n as f64, whole(p));
            let se = ((squares / n as f64 - estimate * estimate) / n as f64).sqrt();
            assert!((estimate - expected).abs() < 4.0 * se + 2e-3 * expected, "{p}: {estimate} vs {expected} (standard error {se})");
        }
        let centre = Vec3::from(matrix.transform_point3(glam::Vec3::ZERO));
        for &p in dark {
            assert!(lights.sample(&scene, p, Vec3::ZERO, 0.5, Vec2::splat(0.5), true).is_none(), "{p}");
            assert_eq!(lights.pdf_emitter(&scene, 0, p, Vec3::ZERO, centre, 1.0, 1.0, true), 0.0);
        }
    }

    fn softbox(shape: crate::lamps::LampShape, size: [f32; 2], matrix: glam::Mat4, degrees: f32) -> crate::lamps::AreaLight {
        crate::lamps::AreaLight { name: "Softbox".into(), shape, size, matrix: matrix.to_cols_array(), color: [1.0; 3], power: 300.0, visible_camera: false, portal: false, spread: degrees.to_radians(), cast_shadow: true }
    }

    /// A rectangular lamp with a 30° Spread (2 × 1.2 m, 1.5 m up, facing
    /// down): its light samples come from the square of the lamp that can
    /// light the point, by solid angle (60 m below, where the lamp covers
    /// under 1e-3 sr, by area).
    #[test]
    fn a_softbox_is_sampled_where_its_light_passes_the_grid() {
        use crate::lamps::LampShape;
        let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_z(0.4), glam::Vec3::new(0.3, -0.2, 1.5));
        let points = [Vec3::new(0.3, -0.2, 0.0), Vec3::new(1.2, 0.3, 0.0), Vec3::new(0.1, 0.0, 1.3), Vec3::new(-0.6, -0.9, 0.4), Vec3::new(0.3, -0.2, -60.0)];
        assert_softbox_light(&[softbox(LampShape::Rectangle, [2.0, 1.2], matrix, 30.0)], &points, &[Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.3, -0.2, 2.0)]);
    }

    /// A disk and an ellipse lamp with a Spread (20° and 40°), alone and
    /// beside a second lamp in the light tree: where the circle that can
    /// light a point is smaller than the lamp, its light samples come from
    /// that circle (those beyond the rim lost), else from the whole lamp.
    #[test]
    fn a_round_softbox_is_sampled_where_its_light_passes_the_grid() {
        use crate::lamps::LampShape;
        let matrix = glam::Mat4::from_rotation_translation(glam::Quat::from_rotation_z(0.4), glam::Vec3::new(0.3, -0.2, 1.5));
        let beside = softbox(LampShape::Rectangle, [1.0, 1.0], glam::Mat4::from_translation(glam::Vec3::new(-2.5, 0.0, 1.5)), 60.0);
        // Under the middle, near the rim, beyond it (the circle part off
        // the lamp), and far below (the whole lamp).
        let points = [Vec3::new(0.3, -0.2, 0.0), Vec3::new(1.0, 0.1, 0.2), Vec3::new(1.4, -0.2, 0.0), Vec3::new(0.3, -0.2, -30.0)];
        let dark = [Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.3, -0.2, 2.0)];
        for lamp in [softbox(LampShape::Disk, [2.0, 2.0], matrix, 20.0), softbox(LampShape::Ellipse, [2.0, 1.2], matrix, 40.0)] {
            assert_softbox_light(std::slice::from_ref(&lamp), &points, &dark);
            assert_softbox_light(&[lamp, beside.clone()], &points, &[]);
        }
    }

    /// A scene pays for the tree only with two or more local lights: a
    /// quad lamp is one light, a sun or a black bulb none.
    #[test]
    fn only_two_or_more_local_lights_build_a_tree() {
        let bulb = |name: &str, kind: PunctualKind, intensity: f32| PunctualLight { name: name.into(), kind, position: Vec3::Y, direction: -Vec3::Y, intensity: Vec3::splat(intensity), size: 0.0, sphere: false, camera_sees: false, shadowless: false };
        let mut scene = lamp_under_a_world();
        let [a, b, c] = scene.triangles[0].p();
        // The lamp's mirror image across its hypotenuse: a quad with it.
        scene.triangles.push(Triangle::new([b + c - a, c, b], [Vec3::Z; 3], 0));
        assert_eq!(Lights::new(&scene).tree_size(), 0, "one quad lamp");
        scene.punctual.push(bulb("sun", PunctualKind::Sun, 3.0));
        scene.punctual.push(bulb("black", PunctualKind::Point, 0.0));
        assert_eq!(Lights::new(&scene).tree_size(), 0, "a quad lamp, a sun and a black bulb");
        scene.punctual.push(bulb("bulb", PunctualKind::Point, 2.0));
        let lights = Lights::new(&scene);
        assert_eq!(lights.tree_size(), 2, "a quad lamp and a bulb");
        let p = Vec3::new(0.2, 0.2, 2.0);
        let local: f32 = [0, 1].iter().map(|&t| lights.pdf_area(&scene, t, p, Vec3::ZERO, true) * 0.5).sum::<f32>() + lights.punctual_probability(2, p, Vec3::ZERO, true);
        let total = local + lights.punctual_probability(0, p, Vec3::ZERO, true) + lights.world_probability(p, true);
        assert!((total - 1.0).abs() < 1e-5, "{total}");
        assert_eq!(lights.punctual_probability(1, p, Vec3::ZERO, true), 0.0);
    }

    /// A one-sided emitter's light is estimated as a Lambertian emitter
    /// gives it, (P/π)·cos θ/d², with nothing behind it; a two-sided panel
    /// as (P/π)|cos θ|/d²; a point light, or emitters one- and two-sided
    /// together, as P/(4π d²) every way. So without MIS the World's share
    /// is small in front of a one-sided lamp and 0.95 behind it; with MIS
    /// a constant World has no share at all.
    #[test]
    fn one_sided_lamps_light_what_is_in_front_of_them() {
        let square = [Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, -0.5, 0.0), Vec3::new(0.5, 0.5, 0.0), Vec3::new(-0.5, 0.5, 0.0)];
        let tris = vec![Triangle::new([square[0], square[1], square[2]], [Vec3::Z; 3], 0), Triangle::new([square[0], square[2], square[3]], [Vec3::Z; 3], 0)];
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let one_sided = Material { emission: Vec3::splat(10.0), ..Material::default() };
        let mut scene = Scene::new(tris, vec![one_sided], camera);
        scene.background = Vec3::splat(0.5);
        let lights = Lights::new(&scene);
        let power = std::f32::consts::PI * 10.0;
        let (front, behind, side) = (Vec3::new(0.0, 0.0, 10.0), Vec3::new(0.0, 0.0, -10.0), Vec3::new(10.0, 0.0, 0.0));
        let on_axis = power / (std::f32::consts::PI * 100.0);
        // On the axis the lamp's whole sphere is within the bound's cone.
        assert!((lights.local.irradiance(front) - on_axis).abs() < 1e-6 * on_axis, "{}", lights.local.irradiance(front));
        assert_eq!(lights.local.irradiance(behind), 0.0);
        // Edge-on, the lamp's angular radius (√0.5/10) still counts.
        let edge_on = lights.local.irradiance(side);
        assert!(edge_on > 0.0 && edge_on < 0.1 * on_axis, "{edge_on}");
        assert_eq!(lights.world_probability(behind, false), 0.95);
        assert!(lights.world_probability(front, false) < lights.world_probability(side, false));
        assert_eq!(lights.world_probability(behind, true), 0.0);
        // A bulb beside the lamp adds its own P/(4π d²) to the lamp's.
        let mut bulb = scene.clone();
        bulb.punctual.push(PunctualLight { name: "bulb".into(), kind: PunctualKind::Point, position: Vec3::new(0.0, 0.0, 0.5), direction: -Vec3::Z, intensity: Vec3::splat(2.0), size: 0.0, sphere: false, camera_sees: false, shadowless: false });
        let with_bulb = Lights::new(&bulb);
        let bulb_power = bulb.punctual[0].power(scene_radius(&bulb)) as f32;
        for p in [front, behind] {
            let expected = lights.local.irradiance(p) + bulb_power / (4.0 * std::f32::consts::PI * (p - Vec3::new(0.0, 0.0, 0.5)).length_squared());
            assert!((with_bulb.local.irradiance(p) - expected).abs() < 1e-5 * expected, "{} {expected}", with_bulb.local.irradiance(p));
        }
        // A two-sided panel shines both ways, a face's power each way.
        let mut two_sided = scene.clone();
        two_sided.materials[0].double_sided = true;
        let lights = Lights::new(&two_sided);
        for p in [front, behind] {
            assert!((lights.local.irradiance(p) - on_axis).abs() < 1e-6 * on_axis, "{}", lights.local.irradiance(p));
        }
        assert!(lights.local.irradiance(side) < 0.1 * on_axis);
        // One-sided and two-sided together: isotropic, both faces counted.
        let mut mixed = two_sided.clone();
        mixed.materials.push(Material { emission: Vec3::splat(10.0), ..Material::default() });
        let far_tri = Triangle::new([Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 1.0, -1.0)], [Vec3::Z; 3], 1);
        mixed.triangles.push(far_tri);
        let lights = Lights::new(&mixed);
        let total = 2.0 * power + std::f32::consts::PI * 0.5 * 10.0;
        let p = Vec3::new(0.0, 0.0, 100.0);
        let d2 = (p - lights.local.emitters.centre).length_squared();
        let isotropic = total / (4.0 * std::f32::consts::PI * d2);
        assert!((lights.local.irradiance(p) - isotropic).abs() < 1e-5 * isotropic, "{} {isotropic}", lights.local.irradiance(p));
    }

    /// An emitting triangle (normal +Z, radiance 10) under a uniform World
    /// of 0.5.
    fn lamp_under_a_world() -> Scene {
        let tri = Triangle::new([Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z; 3], 0);
        let lamp = Material { emission: Vec3::splat(10.0), ..Material::default() };
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let mut scene = Scene::new(vec![tri], vec![lamp], camera);
        scene.background = Vec3::splat(0.5);
        scene
    }

    /// With MIS, a constant World has no weight: beside a lamp or a sun
    /// light samples leave it to BSDF samples. One whose light is uneven
    /// is weighed by the part above its mean (here half the sphere at twice
    /// the mean), which light sampling is for. Without MIS (the seed's
    /// rule) only light samples see the World: it weighs its irradiance.
    /// Either way `sample` picks as the probabilities say, and they sum
    /// to 1.
    #[test]
    fn the_world_is_weighed_by_its_light_above_its_mean() {
        use crate::environment::EnvironmentMap;
        use crate::texture::{Image, Texels};
        let pi = std::f32::consts::PI;
        let mut scene = lamp_under_a_world();
        let p = Vec3::new(0.3, 0.3, 1.0);
        let lights = Lights::new(&scene);
        let local = lights.local.irradiance(p);
        assert_eq!(lights.world_probability(p, true), 0.0);
        assert!((lights.world_probability(p, false) - (pi * 0.5 / (pi * 0.5 + local)).clamp(0.05, 0.95)).abs() < 1e-6);
        let (w, h) = (16u32, 64u32);
        let texels = (0..w * h).map(|i| if i / w < h / 2 { [1.0, 1.0, 1.0, 1.0] } else { [0.0; 4] }).collect();
        scene.environment = Some(EnvironmentMap::new(Image { name: "h".into(), width: w, height: h, texels: Texels::RgbaF32(texels) }, 1.0, 0.0));
        let lights = Lights::new(&scene);
        // Weight π·0.25 against the lamp's estimate at p; without MIS π·0.5.
        for (mis, weight) in [(true, pi * 0.25), (false, pi * 0.5)] {
            let expected = weight / (weight + local);
            assert!((lights.world_probability(p, mis) - expected).abs() < 2e-3, "{mis}: {} {expected}", lights.world_probability(p, mis));
        }
        // A constant World beside a sun of irradiance 3.
        let mut sunny = Scene::new(vec![], vec![], scene.camera.clone());
        sunny.background = Vec3::splat(0.5);
        sunny.punctual.push(PunctualLight { name: "sun".into(), kind: PunctualKind::Sun, position: Vec3::ZERO, direction: -Vec3::Y, intensity: Vec3::splat(3.0), size: 0.0, sphere: false, camera_sees: false, shadowless: false });
        let lights = Lights::new(&sunny);
        for (mis, world) in [(true, 0.0), (false, pi * 0.5 / (pi * 0.5 + 3.0))] {
            assert!((lights.world_probability(p, mis) - world).abs() < 1e-6, "{mis}");
            let n = 100_000;
            let picked = (0..n).filter(|&k| matches!(lights.sample(&sunny, p, Vec3::ZERO, (k as f32 + 0.5) / n as f32, Vec2::splat(0.5), mis), Some(LightChoice::World { .. }))).count();
            assert!((picked as f32 / n as f32 - world).abs() < 1e-4, "{mis}: {picked}");
            assert!((lights.world_probability(p, mis) + lights.punctual_probability(0, p, Vec3::ZERO, mis) - 1.0).abs() < 1e-6);
        }
    }

    /// Without MIS, the World's share is larger far from the other lights
    /// than near them, stays in [0.05, 0.95], is what `sample` picks, and
    /// the densities of all choices still sum to 1 (with MIS as well,
    /// where a constant World's share is 0). A World that is the only
    /// light is always picked.
    #[test]
    fn the_worlds_share_follows_the_distance_to_the_other_lights() {
        let scene = lamp_under_a_world();
        let lights = Lights::new(&scene);
        let (near, far) = (Vec3::new(0.3, 0.3, 0.1), Vec3::new(0.0, 0.0, 30.0));
        let (pn, pf) = (lights.world_probability(near, false), lights.world_probability(far, false));
        assert!((0.05..=0.95).contains(&pn) && (0.05..=0.95).contains(&pf) && pn < pf, "{pn} {pf}");
        for p in [near, far] {
            for mis in [false, true] {
                let n = 20_000;
                let world = (0..n).filter(|&k| matches!(lights.sample(&scene, p, Vec3::ZERO, (k as f32 + 0.5) / n as f32, Vec2::splat(0.5), mis), Some(LightChoice::World { .. }))).count();
                assert!((world as f32 / n as f32 - lights.world_probability(p, mis)).abs() < 1e-3);
                // World share + ∫ pdf_A dA over the emitter = 1.
                let total = lights.world_probability(p, mis) + lights.pdf_area(&scene, 0, p, Vec3::ZERO, mis) * 0.5;
                assert!((total - 1.0).abs() < 1e-5, "{total}");
            }
        }
        // Only a World: it is always picked.
        let mut sky = scene.clone();
        sky.materials[0].emission = Vec3::ZERO;
        for mis in [false, true] {
            assert_eq!(Lights::new(&sky).world_probability(near, mis), 1.0);
        }
    }
}
