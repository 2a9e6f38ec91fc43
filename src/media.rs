//! Absorbing media: the inside of a glass mesh whose material absorbs
//! (`Material::absorption`, σ_a per metre of world space), rendered as
//! Cycles renders a Volume Absorption inside a glass surface. Light that
//! crosses a length t of it keeps exp(−σ_a·t) of itself, channel by
//! channel (Beer–Lambert); nothing scatters inside.
//!
//! A path keeps the media it is in, as Cycles keeps its volume stack:
//! refracted into a mesh of absorbing glass through a front face, it adds
//! the material's medium; refracted out through a back face, it drops it.
//! Where meshes overlap or nest — a liquid modelled into its glass's
//! wall, an ice cube of clear glass in it — their σ_a add up, as Cycles
//! adds the volumes of its stack (clear glass adds nothing and leaves the
//! liquid's in place). Media are told apart by material; a path keeps up
//! to `Media::DEPTH` of them.
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

/// The absorbing media a path is in: the materials of the meshes it has
/// entered and not left, and their summed σ_a.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Media {
    /// Σ σ_a of `materials`, per metre.
    pub sigma: Vec3,
    materials: [u32; Media::DEPTH],
    len: usize,
}

impl Media {
    /// Media a path keeps at once; one entered beyond them is left out.
    pub const DEPTH: usize = 4;

    /// In no absorbing medium.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The media past a surface the path crosses, into its mesh through a
    /// front face or out of it through a back face: the mesh's material
    /// `index` names the medium, and `shading`, the material that shades
    /// the point (`index`, or the half of its Mix Shader drawn there),
    /// says whether it is absorbing glass, the only surface that changes
    /// them. Both halves of a mix are one medium, entered through one
    /// and left through the other.
    pub fn crossing(&self, materials: &[Material], index: u32, shading: u32, front_face: bool) -> Media {
        if !absorbs(&materials[shading as usize]) {
            return *self;
        }
        let mut next = *self;
        let at = self.materials[..self.len].iter().position(|&m| m == index);
        match (front_face, at) {
            (true, None) if self.len < Media::DEPTH => {
                next.materials[self.len] = index;
                next.len += 1;
            }
            (false, Some(i)) => {
                next.materials.copy_within(i + 1..self.len, i);
                next.len -= 1;
            }
            _ => return next,
        }
        next.sigma = next.materials[..next.len].iter().map(|&m| materials[m as usize].absorption).sum();
        next
    }
}

/// The media on the two sides of a surface point a path reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sides {
    /// The side the path came from (the ray-facing geometric normal's).
    pub here: Media,
    /// The other side: past glass, the media crossing it gives; past an
    /// opaque surface, those here (a ray that slips below it, a shading
    /// normal's bounce, has not entered anything).
    pub beyond: Media,
}

impl Sides {
    /// At a point of a mesh of material `index`, shaded by `shading`
    /// (`Media::crossing`), the path reached in the media `here`, on the
    /// mesh's front face or its back face.
    #[inline]
    pub fn at(here: &Media, materials: &[Material], index: u32, shading: u32, front_face: bool) -> Self {
        Sides { here: *here, beyond: here.crossing(materials, index, shading, front_face) }
    }

    /// The media a ray leaving along a direction at cosine `cos_ng` to the
    /// ray-facing geometric normal travels in.
    #[inline]
    pub fn toward(&self, cos_ng: f32) -> &Media {
        if cos_ng >= 0.0 {
            &self.here
        } else {
            &self.beyond
        }
    }

    /// What a shadow ray leaving along `cos_ng` keeps over the length `t`.
    #[inline]
    pub fn transmittance(&self, cos_ng: f32, t: f32) -> Vec3 {
        transmittance(self.toward(cos_ng).sigma, t)
    }
}

/// Whether a material is glass that absorbs inside.
#[inline]
pub fn absorbs(m: &Material) -> bool {
    m.is_transmissive() && m.absorption != Vec3::ZERO
}

/// Whether some of the emitting triangles `emitters` lies inside an
/// absorbing medium, or is absorbing glass itself, or some point or spot
/// light does (a sun is outside everything). From each one's centroid
/// (a light's position) a ray along one fixed direction finds the
/// nearest absorbing glass; meeting it from behind (a closed mesh's
/// inside is behind its faces), the emitter is inside. One ray an
/// emitter, at load, and only in a scene with absorbing glass.
pub fn emitters_inside(scene: &Scene, surfaces: &Accel, emitters: &[u32]) -> bool {
    let absorbing = |triangle: u32| absorbs(scene.material_of(triangle));
    // Off every axis, so that it does not run along a box's faces.
    let dir = Vec3::new(0.2673, 0.5345, 0.8018);
    let inside = |p: Vec3| {
        let hit = surfaces.intersect_where(p, dir, f32::INFINITY, |t, _, _, _| absorbing(t));
        hit.is_some_and(|h| scene.triangles[h.triangle as usize].cross().dot(dir) > 0.0)
    };
    let bulbs = scene.punctual.iter().filter(|l| l.kind != crate::punctual::PunctualKind::Sun);
    emitters.iter().any(|&e| {
        let [a, b, c] = scene.triangles[e as usize].p();
        absorbing(e) || inside((a + b + c) / 3.0)
    }) || bulbs.map(|l| l.position).any(inside)
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
        let (wine, glass) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.0, 0.0, 1.0));
        let absorbing = |absorption| Material { transmission: 1.0, metallic: 0.0, absorption, ..Material::default() };
        let materials = [absorbing(wine), absorbing(glass), absorbing(Vec3::ZERO), Material { metallic: 0.0, ..Material::default() }];
        let (wine_id, glass_id, ice, stone) = (0, 1, 2, 3);
        let air = Media::default();
        let entering = Sides::at(&air, &materials, wine_id, wine_id, true);
        assert_eq!((entering.toward(0.5).sigma, entering.toward(-0.5).sigma), (Vec3::ZERO, wine));
        let in_wine = *entering.toward(-0.5);
        let leaving = Sides::at(&in_wine, &materials, wine_id, wine_id, false);
        assert_eq!((leaving.toward(0.5).sigma, *leaving.toward(-0.5)), (wine, air));
        // An opaque surface inside the medium: both sides are in it.
        let inside = Sides::at(&in_wine, &materials, stone, stone, true);
        assert_eq!((inside.toward(0.5), inside.toward(-0.5)), (&in_wine, &in_wine));
        assert_eq!(inside.transmittance(0.5, 2.0), transmittance(wine, 2.0));
        // The wine modelled into its glass's wall: in both there, the
        // glass's medium left while still in the wine; clear ice in the
        // wine keeps the wine's; a back face never entered changes nothing.
        let crossing = |media: Media, index: u32, front| media.crossing(&materials, index, index, front);
        let both = crossing(crossing(air, glass_id, true), wine_id, true);
        assert_eq!(both.sigma, wine + glass);
        let wine_only = crossing(both, glass_id, false);
        assert_eq!(wine_only.sigma, wine);
        assert_eq!(crossing(wine_only, ice, true), wine_only);
        assert_eq!(crossing(wine_only, glass_id, false), wine_only);
        assert_eq!(crossing(wine_only, wine_id, true), wine_only, "entered twice, counted once");
        assert_eq!(crossing(wine_only, wine_id, false), air);
    }

    /// A Mix Shader's two halves (job.rs) are one medium: entered through
    /// the first half and left through the second, the path is out of it;
    /// an opaque half lets no path cross.
    #[test]
    fn a_mixed_materials_halves_are_one_medium() {
        let wine = Vec3::new(0.1, 0.2, 0.3);
        let glass = Material { transmission: 1.0, metallic: 0.0, absorption: wine, ..Material::default() };
        let materials = [glass.clone(), Material { roughness: 0.2, ..glass.clone() }, Material { transmission: 0.0, ..glass }];
        let air = Media::default();
        let inside = air.crossing(&materials, 0, 0, true);
        assert_eq!(inside.sigma, wine);
        assert_eq!(inside.crossing(&materials, 0, 1, false), air);
        assert_eq!(air.crossing(&materials, 0, 1, true).crossing(&materials, 0, 0, false), air);
        assert_eq!(inside.crossing(&materials, 0, 2, false), inside);
    }
}
