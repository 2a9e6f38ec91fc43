//! Absorbing media: the inside of a glass mesh whose material absorbs
//! (`Material::absorption`, σ_a per metre of world space), rendered as
//! Cycles renders a Volume Absorption inside a glass surface. Light that
//! crosses a length t of it keeps exp(−σ_a·t) of itself, channel by
//! channel (Beer–Lambert); nothing scatters inside.
//!
//! A path is in one medium at a time. Refracted into a mesh through a
//! front face, it travels in the mesh's medium; refracted out through a
//! back face, in none. Cycles keeps a stack of volumes instead. The two
//! agree wherever absorbing meshes neither overlap nor nest: a liquid in
//! a glass needs a gap of air between them, as it does in Cycles for the
//! right refraction anyway.
//!
//! Shadow rays take the medium on their side of the surface they leave.
//!
//! Light subpaths never enter a medium (they stop at glass), so those of
//! an emitter outside every medium need nothing from this, and a camera
//! path's joins to them from inside one are blocked by the glass between.
//! An emitter inside a medium would need its subpaths absorbed, which
//! nothing tells them: a scene with one traces none
//! (`emitters_inside`, `Context::traces_light_paths`).

use crate::accel::Accel;
use crate::material::Material;
use crate::scene::Scene;
use crate::Vec3;

/// The share of light left after a length `t` of a medium of absorption
/// `sigma`: exp(−σ_a·t) per channel. A channel that does not absorb keeps
/// all of it, over an infinite length too (a ray that leaves the scene).
#[inline]
pub fn transmittance(sigma: Vec3, t: f32) -> Vec3 {
    Vec3::select(sigma.cmpgt(Vec3::ZERO), (-sigma * t).exp(), Vec3::ONE)
}

/// The media on the two sides of a surface point a path reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sides {
    /// The side the path came from (the ray-facing geometric normal's).
    pub here: Vec3,
    /// The other side.
    pub beyond: Vec3,
}

impl Sides {
    /// At a point of `material` the path reached in the medium `here`, on
    /// the mesh's front face or its back face. Beyond an opaque surface is
    /// where the path is: a ray that slips below it (a shading normal's
    /// bounce) has not entered anything.
    #[inline]
    pub fn at(here: Vec3, material: &Material, front_face: bool) -> Self {
        let beyond = match (material.is_transmissive(), front_face) {
            (false, _) => here,
            (true, true) => material.absorption,
            (true, false) => Vec3::ZERO,
        };
        Sides { here, beyond }
    }

    /// The medium a ray leaving along a direction at cosine `cos_ng` to
    /// the ray-facing geometric normal travels in.
    #[inline]
    pub fn toward(&self, cos_ng: f32) -> Vec3 {
        if cos_ng >= 0.0 {
            self.here
        } else {
            self.beyond
        }
    }

    /// What a shadow ray leaving along `cos_ng` keeps over the length `t`.
    #[inline]
    pub fn transmittance(&self, cos_ng: f32, t: f32) -> Vec3 {
        transmittance(self.toward(cos_ng), t)
    }
}

/// Whether a material is glass that absorbs inside.
#[inline]
pub fn absorbs(m: &Material) -> bool {
    m.is_transmissive() && m.absorption != Vec3::ZERO
}

/// Whether some of the emitting triangles `emitters` lies inside an
/// absorbing medium, or is absorbing glass itself. From each one's
/// centroid a ray along one fixed direction finds the nearest absorbing
/// glass; meeting it from behind (a closed mesh's inside is behind its
/// faces), the emitter is inside. One ray an emitter, at load, and only
/// in a scene with absorbing glass.
pub fn emitters_inside(scene: &Scene, surfaces: &Accel, emitters: &[u32]) -> bool {
    let absorbing = |triangle: u32| absorbs(&scene.materials[scene.triangles[triangle as usize].material as usize]);
    // Off every axis, so that it does not run along a box's faces.
    let dir = Vec3::new(0.2673, 0.5345, 0.8018);
    emitters.iter().any(|&e| {
        if absorbing(e) {
            return true;
        }
        let [a, b, c] = scene.triangles[e as usize].p();
        let hit = surfaces.intersect_where((a + b + c) / 3.0, dir, f32::INFINITY, |t, _, _, _| absorbing(t));
        hit.is_some_and(|h| scene.triangles[h.triangle as usize].cross().dot(dir) > 0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beer_lambert_per_channel() {
        let sigma = Vec3::new(0.0, 1.0, 2.0);
        let t = transmittance(sigma, 0.5);
        assert_eq!(t.x, 1.0);
        assert!((t.y - (-0.5f32).exp()).abs() < 1e-7 && (t.z - (-1.0f32).exp()).abs() < 1e-7);
        // Leaving the scene: the absorbing channels keep nothing, the clear
        // one everything, and no NaN from 0 × ∞.
        assert_eq!(transmittance(sigma, f32::INFINITY), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(transmittance(sigma, 0.0), Vec3::ONE);
        assert_eq!(transmittance(Vec3::ZERO, f32::INFINITY), Vec3::ONE);
        // A huge coefficient over a tiny length stays finite.
        let t = transmittance(Vec3::splat(1e30), 1e-30);
        assert!(t.is_finite() && (t.x - (-1.0f32).exp()).abs() < 1e-6);
    }

    #[test]
    fn a_path_enters_through_the_front_and_leaves_through_the_back() {
        let sigma = Vec3::new(0.1, 0.2, 0.3);
        let glass = Material { transmission: 1.0, metallic: 0.0, absorption: sigma, ..Material::default() };
        let entering = Sides::at(Vec3::ZERO, &glass, true);
        assert_eq!((entering.toward(0.5), entering.toward(-0.5)), (Vec3::ZERO, sigma));
        let leaving = Sides::at(sigma, &glass, false);
        assert_eq!((leaving.toward(0.5), leaving.toward(-0.5)), (sigma, Vec3::ZERO));
        // An opaque surface inside the medium: both sides are in it.
        let stone = Material { metallic: 0.0, ..Material::default() };
        let inside = Sides::at(sigma, &stone, true);
        assert_eq!((inside.toward(0.5), inside.toward(-0.5)), (sigma, sigma));
        assert_eq!(inside.transmittance(0.5, 2.0), transmittance(sigma, 2.0));
    }
}
