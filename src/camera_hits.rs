//! Camera rays' first hits without the BVH. Every camera ray starts at the
//! camera's position o, so whether direction d passes through a triangle
//! (a, b, c), seen from o as a' = a − o and so on, is the signs of
//! d·(a'×b'), d·(b'×c') and d·(c'×a'), and where, t = [a' b' c'] over their
//! sum: per triangle constants and three dot products per ray, with no
//! node to visit. Each tile's rays are tested against the triangles whose
//! image overlaps the tile alone, binned once a pass. The nearest
//! triangle a ray passes through is then tested once more as the BVH tests
//! it (`Accel::hit_in_slot`), so the hit is the BVH's to the bit; where
//! that test disagrees (a ray within rounding of an edge) the ray is
//! traced through the BVH after all.
//!
//! The two triangles of a mesh's inner edge give it opposite normals to
//! the bit (a'×b' = −(b'×a')), so a ray on the edge passes through one of
//! them at least: rays never slip between a mesh's triangles.
//!
//! A scene pays for this only where it is cheaper than the BVH: where the
//! binned rectangles add up to more than `MAX_TESTS_PER_PIXEL` tests per
//! pixel (many triangles per pixel, a camera inside a dense mesh) the
//! camera's rays go through the BVH as every other ray does.

use crate::accel::Accel;
use crate::camera::Lens;
use crate::material::Material;
use crate::scene::Triangle;
use crate::Vec3;
use glam::{Vec2, Vec4};
use std::ops::Range;

/// Ray-triangle tests per pixel and sample, as the binned rectangles add
/// up, above which the camera's rays go through the BVH instead.
const MAX_TESTS_PER_PIXEL: f64 = 8.0;

/// Rays `CameraHits::nearest` tests against a triangle at once.
const LANES: usize = 4;

/// Pixels by which a triangle's image is widened on every side against
/// rounding: a corner's projection and a ray's direction are each a few
/// ulps off, and an ulp of a pixel coordinate is at most 0.004 (at
/// 32,768).
const MARGIN: f32 = 0.05;

/// A triangle in the tiles its image overlaps.
#[derive(Clone, Copy, Debug)]
struct Binned {
    /// Where the BVH keeps it (`Accel::slots`), and the scene triangle.
    slot: u32,
    triangle: u32,
    /// The pixels whose samples may fall in its image: x0, y0, x1, y1,
    /// inclusive.
    rect: [u16; 4],
}

/// A triangle as the camera sees it, within one tile.
#[derive(Clone, Copy, Debug)]
struct Facing {
    /// a'×b', b'×c' and c'×a', signed so that a ray through the triangle
    /// has all three dot products ≥ 0.
    edges: [Vec3; 3],
    /// [a' b' c'], signed as the edges: > 0.
    volume: f32,
    slot: u32,
    /// Its pixels in the tile: x0, x1 (exclusive), y0, y1 (exclusive).
    span: [u32; 4],
}

/// The camera's view of a scene's surfaces for one image size.
pub struct CameraHits<'a> {
    triangles: &'a [Triangle],
    origin: Vec3,
    binned: Vec<Binned>,
    /// Tile k's triangles are `binned[bins[start[k]..start[k + 1]]]`.
    start: Vec<u32>,
    bins: Vec<u32>,
    tiles_x: u32,
    tile: u32,
    tests_per_pixel: f32,
}

/// What a camera ray reaches first, as the integrator is told it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FirstHit {
    /// Unknown: trace the ray through the BVH.
    Trace,
    /// Nothing.
    Miss,
    /// The triangle in this slot of the surfaces' BVH (`Accel::slots`), to
    /// be tested as the BVH would (`Accel::hit_in_slot`); where that test
    /// misses, the ray lies within rounding of an edge, and the BVH says.
    Slot(u32),
}

/// One tile's camera rays, row-major: their directions (in lanes, which
/// the tests run over) and, once `CameraHits::nearest` has run, the slot
/// each passes through first (u32::MAX for none); and the tile's
/// triangles as the camera sees them (`CameraHits::face`).
pub struct TileRays {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    t: Vec<f32>,
    slot: Vec<u32>,
    facing: Vec<Facing>,
}

impl TileRays {
    pub fn new(tile: u32) -> Self {
        // Three lanes past the tile's last ray: `nearest` reads a row's
        // span four lanes at a time, its last four reaching past the span.
        let n = (tile * tile) as usize + LANES - 1;
        TileRays { x: vec![0.0; n], y: vec![0.0; n], z: vec![0.0; n], t: vec![0.0; n], slot: vec![0; n], facing: Vec::new() }
    }

    #[inline]
    pub fn set(&mut self, i: usize, d: Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (d.x, d.y, d.z);
    }

    #[inline]
    pub fn dir(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// What `CameraHits::nearest` found for ray `i`.
    #[inline]
    pub fn first(&self, i: usize) -> FirstHit {
        match self.slot[i] {
            u32::MAX => FirstHit::Miss,
            slot => FirstHit::Slot(slot),
        }
    }
}

impl<'a> CameraHits<'a> {
    /// The triangles of `accel` binned to the tiles of `tile` pixels their
    /// images overlap, as `lens` sees them; None where the BVH would find
    /// the hits sooner.
    ///
    /// `samples` per pixel are to be found with it: binning costs about
    /// as much per triangle as the BVH saves per ray, so it waits for
    /// twice as many rays as triangles. The triangles of `materials`
    /// hidden from the camera are not binned, and camera rays pass them;
    /// a scene with none may give no materials.
    /// `spread`: how far past its own pixel a pixel's samples reach (the
    /// pixel filter's radius less half a pixel; 0 for the one-pixel box).
    #[allow(clippy::too_many_arguments)]
    pub fn new(accel: &Accel, triangles: &'a [Triangle], materials: &[Material], lens: &Lens, width: u32, height: u32, tile: u32, samples: u32, spread: f32) -> Option<Self> {
        let rays = width as f64 * height as f64 * samples as f64;
        if accel.triangle_count() as f64 * 2.0 > rays {
            return None;
        }
        Self::within(accel, triangles, materials, lens, width, height, tile, MAX_TESTS_PER_PIXEL, spread)
    }

    /// Binned unless that makes more than `max_tests` tests per pixel.
    #[allow(clippy::too_many_arguments)]
    fn within(accel: &Accel, triangles: &'a [Triangle], materials: &[Material], lens: &Lens, width: u32, height: u32, tile: u32, max_tests: f64, spread: f32) -> Option<Self> {
        // An orthographic camera's rays share a direction, not an origin,
        // and an aperture's rays leave from all over it.
        if width > u16::MAX as u32 || height > u16::MAX as u32 || !lens.pinhole() {
            return None;
        }
        let origin = lens.position();
        let budget = max_tests * width as f64 * height as f64;
        // The BVH's leaves in two halves, one a thread: binning is the
        // serial part of a 1-spp pass (9,028 triangles, about 1 ms alone).
        // The first half's list has room for the second's, which joins it.
        let bin = |leaves: Range<usize>, room: usize| {
            let (mut binned, mut tests) = (Vec::with_capacity(4 * room), 0.0);
            for (slot, triangle) in accel.slots(leaves) {
                let t = &triangles[triangle as usize];
                if materials.get(t.material as usize).is_some_and(|m| m.hidden_from_camera) {
                    continue;
                }
                if let Some(rect) = image_rect(lens, t.p().map(|p| p - origin), width, height, spread) {
                    tests += (rect[2] - rect[0] + 1) as f64 * (rect[3] - rect[1] + 1) as f64;
                    if tests > budget {
                        return None;
                    }
                    binned.push(Binned { slot, triangle, rect: rect.map(|v| v as u16) });
                }
            }
            Some((binned, tests))
        };
        let half = accel.leaf_count() / 2;
        let (first, second) = rayon::join(|| bin(0..half, accel.leaf_count()), || bin(half..accel.leaf_count(), accel.leaf_count() - half));
        let ((mut binned, tests), (rest, more)) = (first?, second?);
        let tests = tests + more;
        if tests > budget {
            return None;
        }
        binned.extend(rest);
        let (tiles_x, tiles_y) = (width.div_ceil(tile), height.div_ceil(tile));
        let mut start = vec![0u32; (tiles_x * tiles_y) as usize + 1];
        for b in &binned {
            for_tiles(b.rect, tile, tiles_x, |k| start[k + 1] += 1);
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill = start.clone();
        let mut bins = vec![0u32; *start.last().unwrap_or(&0) as usize];
        for (i, b) in binned.iter().enumerate() {
            for_tiles(b.rect, tile, tiles_x, |k| {
                bins[fill[k] as usize] = i as u32;
                fill[k] += 1;
            });
        }
        let tests_per_pixel = (tests / (width as f64 * height as f64)) as f32;
        Some(CameraHits { triangles, origin, binned, start, bins, tiles_x, tile, tests_per_pixel })
    }

    /// Ray-triangle tests per pixel sample, as the binned rectangles add up.
    pub fn tests_per_pixel(&self) -> f32 {
        self.tests_per_pixel
    }

    /// The triangles of the tile at (x0, y0), `tw` pixels wide and `th`
    /// high, as the camera sees them, into `rays`: once for the samples a
    /// pass takes of the tile together (four sample indices with light
    /// subpaths, all of them without), recomputed for the next four rather
    /// than kept for every tile: one a binned triangle and tile, about
    /// 13,600 on the 256² gold sphere, against the 262,144 camera rays of
    /// its four samples.
    pub fn face(&self, x0: u32, y0: u32, tw: u32, th: u32, rays: &mut TileRays) {
        rays.facing.clear();
        let k = ((y0 / self.tile) * self.tiles_x + x0 / self.tile) as usize;
        for &i in &self.bins[self.start[k] as usize..self.start[k + 1] as usize] {
            let b = &self.binned[i as usize];
            let [a, b_, c] = self.triangles[b.triangle as usize].p().map(|p| p - self.origin);
            let edges = [a.cross(b_), b_.cross(c), c.cross(a)];
            let volume = a.dot(edges[1]);
            // Edge-on (the camera in its plane), no ray passes through it.
            if volume == 0.0 || !volume.is_finite() {
                continue;
            }
            let sign = volume.signum();
            let [rx0, ry0, rx1, ry1] = b.rect.map(u32::from);
            // Binning put the rectangle over this tile.
            let span = [rx0.max(x0) - x0, rx1.min(x0 + tw - 1) - x0 + 1, ry0.max(y0) - y0, ry1.min(y0 + th - 1) - y0 + 1];
            rays.facing.push(Facing { edges: edges.map(|e| e * sign), volume: volume * sign, slot: b.slot, span });
        }
    }

    /// After `face`, for the tile's rays in `rays` (`tw` pixels a row): the
    /// slot each passes through first.
    pub fn nearest(&self, tw: u32, th: u32, rays: &mut TileRays) {
        let n = (tw * th) as usize;
        rays.t[..n].fill(f32::INFINITY);
        rays.slot[..n].fill(u32::MAX);
        for f in &rays.facing {
            let [e0, e1, e2] = f.edges.map(|e| e.to_array().map(Vec4::splat));
            let volume = Vec4::splat(f.volume);
            let [xa, xb, ya, yb] = f.span.map(|v| v as usize);
            for y in ya..yb {
                // Four rays at a time, in SIMD lanes where the CPU has
                // them: the same operations in the same order as one at a
                // time (the hits are the same to the bit), in a quarter of
                // the instructions. The last four may reach past the span:
                // those lanes take nothing.
                let row = y * tw as usize;
                for x in (xa..xb).step_by(LANES) {
                    let i = row + x;
                    let (dx, dy, dz) = (Vec4::from_slice(&rays.x[i..]), Vec4::from_slice(&rays.y[i..]), Vec4::from_slice(&rays.z[i..]));
                    let t = Vec4::from_slice(&rays.t[i..]);
                    let a = dx * e0[0] + dy * e0[1] + dz * e0[2];
                    let b = dx * e1[0] + dy * e1[1] + dz * e1[2];
                    let c = dx * e2[0] + dy * e2[1] + dz * e2[2];
                    let along = volume / (a + b + c);
                    let zero = Vec4::ZERO;
                    let take = a.cmpge(zero) & b.cmpge(zero) & c.cmpge(zero) & along.cmplt(t);
                    let take = take.bitmask() & (u32::MAX >> (32 - (xb - x).min(LANES)));
                    if take == 0 {
                        continue;
                    }
                    for lane in 0..LANES {
                        if take & (1 << lane) != 0 {
                            (rays.t[i + lane], rays.slot[i + lane]) = (along[lane], f.slot);
                        }
                    }
                }
            }
        }
    }
}

/// Each tile, as its index, that the pixels `rect` (x0, y0, x1, y1,
/// inclusive) overlap.
#[inline]
fn for_tiles(rect: [u16; 4], tile: u32, tiles_x: u32, mut each: impl FnMut(usize)) {
    let [x0, y0, x1, y1] = rect.map(|v| v as u32 / tile);
    for ty in y0..=y1 {
        for tx in x0..=x1 {
            each((ty * tiles_x + tx) as usize);
        }
    }
}

/// The pixels whose samples may land in the image of the triangle with
/// corners `v` (offsets from the camera): those under its image's
/// bounding box, widened by `MARGIN`; None where there are none. A
/// triangle reaching behind the camera is cut at a depth so small that
/// none of it nearer than that can be in view, unless its plane passes
/// that near the camera: then its image may be anywhere.
fn image_rect(lens: &Lens, v: [Vec3; 3], width: u32, height: u32, spread: f32) -> Option<[u32; 4]> {
    let forward = lens.forward();
    let z = v.map(|q| q.dot(forward));
    let whole = Some([0, 0, width - 1, height - 1]);
    let far = z[0].max(z[1]).max(z[2]);
    if !(far > 0.0) {
        return None;
    }
    let mut points = [Vec2::ZERO; 4];
    let mut count = 0;
    // Every point pushed is in front of the camera, bar rounding; one that
    // is not leaves the image unknown, so whole.
    macro_rules! push {
        ($q:expr) => {
            match lens.image_point($q) {
                Some(p) => {
                    points[count] = p;
                    count += 1;
                }
                None => return whole,
            }
        };
    }
    if z.iter().all(|&z| z > 0.0) {
        for q in v {
            push!(q);
        }
    } else {
        // In view, a point at depth z is within z·corner_stretch of the
        // camera: only a plane that near can have points nearer than
        // `near` in view.
        let near = 1e-3 * far;
        let normal = (v[1] - v[0]).cross(v[2] - v[0]);
        if !(normal.dot(v[0]).abs() > 2.0 * near * lens.corner_stretch() * normal.length()) {
            return whole;
        }
        for i in 0..3 {
            let (p, q, zp, zq) = (v[i], v[(i + 1) % 3], z[i], z[(i + 1) % 3]);
            if zp >= near {
                push!(p);
            }
            if (zp >= near) != (zq >= near) {
                push!(p + (q - p) * ((near - zp) / (zq - zp)));
            }
        }
    }
    // A point at an underflowed depth can project to 0/0.
    if points[..count].iter().any(|q| q.is_nan()) {
        return whole;
    }
    let (mut lo, mut hi) = (points[0], points[0]);
    for q in &points[1..count] {
        (lo, hi) = (lo.min(*q), hi.max(*q));
    }
    clamp_rect(lo, hi, width, height, spread)
}

fn clamp_rect(lo: Vec2, hi: Vec2, width: u32, height: u32, spread: f32) -> Option<[u32; 4]> {
    let (w, h) = (width as f32, height as f32);
    let margin = MARGIN + spread;
    if !(hi.x >= -margin && hi.y >= -margin && lo.x < w + margin && lo.y < h + margin) {
        return None;
    }
    // Pixel x's samples lie in [x − spread, x + 1 + spread). `as`
    // saturates: a corner at infinity is the image's edge.
    let (lo, hi) = (lo - Vec2::splat(margin), hi + Vec2::splat(margin));
    let x0 = lo.x.floor().max(0.0) as u32;
    let y0 = lo.y.floor().max(0.0) as u32;
    let x1 = (hi.x.floor().max(0.0) as u32).min(width - 1);
    let y1 = (hi.y.floor().max(0.0) as u32).min(height - 1);
    Some([x0, y0, x1, y1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection};
    use crate::rng::Rng;

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
        Triangle::new([a, b, c], [Vec3::Z; 3], 0)
    }

    fn camera(eye: Vec3, target: Vec3) -> Camera {
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        Camera { name: "test".into(), position: eye, right, up: right.cross(forward), forward, projection: Projection::Perspective { yfov: 0.9 }, aspect_ratio: None, clip: [0.0, f32::INFINITY], shift: Vec2::ZERO, aperture: None }
    }

    /// A closed UV sphere whose neighbours share their corners bit for bit.
    fn sphere(centre: Vec3, radius: f32, rings: usize, segments: usize) -> Vec<Triangle> {
        let point = |i: usize, j: usize| {
            let (theta, phi) = (std::f32::consts::PI * i as f32 / rings as f32, std::f32::consts::TAU * (j % segments) as f32 / segments as f32);
            centre + radius * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        };
        let mut out = Vec::new();
        for i in 0..rings {
            for j in 0..segments {
                let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
                if i > 0 {
                    out.push(tri(a, b, d));
                }
                if i + 1 < rings {
                    out.push(tri(b, c, d));
                }
            }
        }
        out
    }

    /// A room of big quads around the camera (some reach behind it), with
    /// a sphere of small triangles and a wall just beside the camera.
    fn room(scale: f32) -> (Vec<Triangle>, Camera) {
        let s = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * scale;
        let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| [tri(a, b, c), tri(a, c, d)];
        let mut t: Vec<Triangle> = [
            quad(s(-5.0, 0.0, -5.0), s(5.0, 0.0, -5.0), s(5.0, 0.0, 5.0), s(-5.0, 0.0, 5.0)),
            quad(s(-5.0, 4.0, -5.0), s(-5.0, 4.0, 5.0), s(5.0, 4.0, 5.0), s(5.0, 4.0, -5.0)),
            quad(s(-5.0, 0.0, -5.0), s(-5.0, 4.0, -5.0), s(5.0, 4.0, -5.0), s(5.0, 0.0, -5.0)),
            quad(s(-5.0, 0.0, 5.0), s(5.0, 0.0, 5.0), s(5.0, 4.0, 5.0), s(-5.0, 4.0, 5.0)),
            quad(s(-5.0, 0.0, -5.0), s(-5.0, 0.0, 5.0), s(-5.0, 4.0, 5.0), s(-5.0, 4.0, -5.0)),
            // 1 mm from the camera, along its view.
            quad(s(1.001, 0.0, -5.0), s(1.001, 4.0, -5.0), s(1.001, 4.0, 5.0), s(1.001, 0.0, 5.0)),
        ]
        .into_iter()
        .flatten()
        .collect();
        t.extend(sphere(s(-0.5, 1.2, -2.5), 0.8 * scale, 24, 48));
        (t, camera(s(1.0, 1.5, 3.0), s(0.0, 1.0, -3.0)))
    }

    /// Triangles strewn all around the camera: behind it, across the plane
    /// it stands in, a hair away from it.
    fn soup(n: usize, rng: &mut Rng) -> Vec<Triangle> {
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        (0..n).map(|_| (v(), v() * 0.3, v() * 0.3)).map(|(c, d, e)| tri(c, c + d, c + e)).filter(|t| t.area() > 1e-6).collect()
    }

    /// Every camera ray's first hit as binning finds it, against the BVH's:
    /// (rays, rays where they differ other than by a tie of distances,
    /// rays the BVH had to settle).
    fn agreement(triangles: &[Triangle], camera: &Camera, width: u32, height: u32, samples: u32) -> (usize, usize, usize) {
        let (accel, _) = Accel::build(triangles);
        let lens = camera.lens(width, height);
        let hits = CameraHits::within(&accel, triangles, &[], &lens, width, height, 16, f64::INFINITY, 0.0).expect("no budget");
        let mut rays = TileRays::new(16);
        let (mut count, mut differ, mut settled) = (0, 0, 0);
        let mut rng = Rng::new(7, 3);
        for y0 in (0..height).step_by(16) {
            for x0 in (0..width).step_by(16) {
                let (tw, th) = (16.min(width - x0), 16.min(height - y0));
                hits.face(x0, y0, tw, th, &mut rays);
                for _ in 0..samples {
                    for i in 0..tw * th {
                        let pixel = Vec2::new((x0 + i % tw) as f32, (y0 + i / tw) as f32) + rng.next_2d();
                        rays.set(i as usize, lens.ray(pixel, Vec2::ZERO).unwrap().dir);
                    }
                    hits.nearest(tw, th, &mut rays);
                    for i in 0..(tw * th) as usize {
                        let (o, d) = (lens.position(), rays.dir(i));
                        let bvh = accel.intersect(o, d, f32::INFINITY);
                        let binned = match rays.first(i) {
                            FirstHit::Miss => None,
                            FirstHit::Slot(slot) => accel.hit_in_slot(slot, o, d).or_else(|| {
                                settled += 1;
                                bvh
                            }),
                            FirstHit::Trace => unreachable!(),
                        };
                        count += 1;
                        differ += match (binned, bvh) {
                            (None, None) => 0,
                            (Some(a), Some(b)) => (a.triangle != b.triangle && (a.t - b.t).abs() > 1e-5 * b.t) as usize,
                            _ => 1,
                        };
                    }
                }
            }
        }
        (count, differ, settled)
    }

    /// Binning finds the BVH's first hit for every ray, to the bit, in a
    /// room around the camera at 1 m, 1 mm and 1 km a unit. The image's
    /// last tiles are 11 pixels wide and high: rows whose spans end off
    /// `nearest`'s four lanes.
    #[test]
    fn first_hits_are_the_bvhs_at_any_scale() {
        for scale in [1.0, 1e-3, 1e3] {
            let (triangles, camera) = room(scale);
            let (count, differ, settled) = agreement(&triangles, &camera, 75, 43, 4);
            assert_eq!(differ, 0, "scale {scale}: {differ} of {count} rays");
            assert!(settled * 10_000 <= count, "scale {scale}: the BVH settled {settled} of {count}");
        }
    }

    /// The same among triangles all around the camera, cut by the plane it
    /// stands in, behind it and within a hair of it.
    #[test]
    fn first_hits_are_the_bvhs_among_triangles_all_around() {
        let mut rng = Rng::new(5, 9);
        for seed in 0..3 {
            let mut triangles = soup(400, &mut rng);
            let camera = camera(Vec3::new(0.1 * seed as f32, 0.0, 0.0), Vec3::new(0.3, -0.2, -1.0));
            // A corner 2 mm in front of the camera, one far to the right
            // and one behind it: its part nearer than any depth it could
            // be cut at fills much of the image.
            let (o, f, r, u) = (camera.position, camera.forward, camera.right, camera.up);
            triangles.push(tri(o + f * 0.002, o + f * 10.0 + r * 30.0, o - f + u * 0.5));
            let (count, differ, settled) = agreement(&triangles, &camera, 48, 48, 4);
            assert_eq!(differ, 0, "{differ} of {count} rays");
            assert!(settled * 10_000 <= count, "the BVH settled {settled} of {count}");
        }
    }

    /// No ray slips between a closed mesh's triangles: every ray aimed
    /// inside a tessellated sphere's outline passes through one of them.
    #[test]
    fn rays_never_slip_between_a_meshs_triangles() {
        let (centre, radius) = (Vec3::new(0.0, 0.0, -4.0), 1.5);
        // Fine enough that many rays fall near edges and corners.
        let triangles = sphere(centre, radius, 64, 128);
        let camera = camera(Vec3::ZERO, centre);
        let (accel, _) = Accel::build(&triangles);
        let (w, h) = (64, 64);
        let lens = camera.lens(w, h);
        let hits = CameraHits::within(&accel, &triangles, &[], &lens, w, h, 16, f64::INFINITY, 0.0).unwrap();
        let mut rays = TileRays::new(16);
        // Inside the outline of the sphere's inscribed polyhedron.
        let cos_inside = (1.0 - (0.99 * radius / 4.0f32).powi(2)).sqrt();
        let mut aimed = 0;
        for y0 in (0..h).step_by(16) {
            for x0 in (0..w).step_by(16) {
                hits.face(x0, y0, 16, 16, &mut rays);
                // Corners and edges of pixels, where rays meet the mesh's
                // edges most often, and the pixels' centres.
                for offset in [Vec2::ZERO, Vec2::splat(0.5), Vec2::new(0.5, 0.0)] {
                    for i in 0..256u32 {
                        rays.set(i as usize, lens.ray(Vec2::new((x0 + i % 16) as f32, (y0 + i / 16) as f32) + offset, Vec2::ZERO).unwrap().dir);
                    }
                    hits.nearest(16, 16, &mut rays);
                    for i in 0..256 {
                        if rays.dir(i).dot(Vec3::NEG_Z) > cos_inside {
                            aimed += 1;
                            assert!(rays.first(i) != FirstHit::Miss, "ray {} slipped through", rays.dir(i));
                        }
                    }
                }
            }
        }
        assert!(aimed > 1000, "{aimed}");
    }

    /// Rays exactly along a mesh's edges (their dot products with the
    /// edges' normals exactly 0) and through its corners hit it: four
    /// quads meeting on the view axis, under pixel rows and columns whose
    /// rays have a zero component.
    #[test]
    fn rays_along_edges_and_through_corners_hit() {
        let quad = |sx: f32, sy: f32| {
            let p = |x: f32, y: f32| Vec3::new(x, y, -2.0);
            [tri(p(0.0, 0.0), p(sx, 0.0), p(sx, sy)), tri(p(0.0, 0.0), p(sx, sy), p(0.0, sy))]
        };
        let triangles: Vec<Triangle> = [quad(1.0, 1.0), quad(-1.0, 1.0), quad(-1.0, -1.0), quad(1.0, -1.0)].into_iter().flatten().collect();
        let camera = camera(Vec3::ZERO, Vec3::NEG_Z);
        let (accel, _) = Accel::build(&triangles);
        let lens = camera.lens(32, 32);
        let hits = CameraHits::within(&accel, &triangles, &[], &lens, 32, 32, 16, f64::INFINITY, 0.0).unwrap();
        let mut rays = TileRays::new(16);
        let mut on_an_edge = 0;
        for (x0, y0) in [(0, 0), (16, 0), (0, 16), (16, 16)] {
            hits.face(x0, y0, 16, 16, &mut rays);
            // Pixel corners: the image's middle row and column among them.
            for i in 0..256u32 {
                rays.set(i as usize, lens.ray(Vec2::new((x0 + i % 16) as f32, (y0 + i / 16) as f32), Vec2::ZERO).unwrap().dir);
            }
            hits.nearest(16, 16, &mut rays);
            for i in 0..256 {
                let d = rays.dir(i);
                on_an_edge += (d.x == 0.0 || d.y == 0.0) as usize;
                assert!(rays.first(i) != FirstHit::Miss, "the ray {d} slipped through");
            }
        }
        assert_eq!(on_an_edge, 32 + 32 - 1);
    }

    /// Where the triangles would cost more tests than the BVH, or more
    /// binning than the samples repay, the camera's rays go to the BVH.
    #[test]
    fn binning_is_left_out_where_it_does_not_pay() {
        let (triangles, camera) = room(1.0);
        let (accel, _) = Accel::build(&triangles);
        let n = triangles.len() as u32;
        // Large enough for the budget: ~3 tests a pixel.
        let (w, h) = (128, 96);
        let lens = camera.lens(w, h);
        let hits = CameraHits::new(&accel, &triangles, &[], &lens, w, h, 16, 1, 0.0).unwrap();
        assert!(hits.tests_per_pixel() < MAX_TESTS_PER_PIXEL as f32, "{}", hits.tests_per_pixel());
        // The same sphere's triangles at a few pixels each, many a pixel.
        let small = camera.lens(12, 8);
        assert!(CameraHits::new(&accel, &triangles, &[], &small, 12, 8, 16, 1 + 2 * n / 96, 0.0).is_none());
        // Fewer rays than twice the triangles: one sample of a 24×16 image.
        let tiny = camera.lens(24, 16);
        assert!(n > 24 * 16 / 2);
        assert!(CameraHits::new(&accel, &triangles, &[], &tiny, 24, 16, 16, 1, 0.0).is_none());
    }
}
