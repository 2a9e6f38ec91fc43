//! What a scene uses, found once at load, and the kernel chosen for it.
//!
//! A scene pays only for what it uses: the integrator and the BSDF are
//! compiled once for each combination of the parts below (render.rs
//! dispatches), so a kernel without a part never tests for it per sample:
//!
//! * BSDF: a scene whose every surface is pure Lambert (not metallic and
//!   KHR_materials_specular 0, which Blender exports for Specular IOR Level
//!   0) runs `LambertBsdf` and never evaluates a microfacet term;
//! * emitting triangles (surfaces and area lights): without them there is
//!   no emission lookup at hits and no area-light sampling;
//! * punctual lights: without them light sampling never considers one;
//! * lamps (Blender area lights, which rays pass through): without them no
//!   ray is tested against the lamp BVH;
//! * glass (KHR_materials_transmission): without it the BSDF has no
//!   transmission lobe to weigh (bsdf/transmission.rs);
//! * a clear coat (KHR_materials_clearcoat): without it no coat layer is
//!   weighed (bsdf/coat.rs); the seed model has none;
//! * rough diffuse (a request's Diffuse Roughness): a scene of Lambertian
//!   surfaces with some rough one runs the Principled BSDF rather than
//!   `LambertBsdf`, whose base then tests one tag for it
//!   (bsdf/oren_nayar.rs); the seed model keeps Lambert;
//! * no light at all: no light sampling, no random numbers drawn for it.
//!
//! `FeatureMode::All` forces the general kernel (every part on, the BSDF
//! model's full code) for comparison: for the same seed it gives the same
//! image, bit for bit.
//!
//! Textures, vertex colours, normal maps, anisotropy and alpha are decided
//! per material at the hit (shading.rs): a material without them takes its
//! factors in one branch, and a scene with no alpha anywhere traces its
//! rays without the any-hit test, as one with no object hidden from the
//! camera traces camera rays. An isotropic BSDF tests one tag for
//! anisotropy and calls none of its code, which is kept out of line
//! (bsdf/principled.rs); a scene without it carries no tangent field.

use crate::bsdf::BsdfModel;
use crate::lights::Lights;
use crate::scene::Scene;
use std::fmt;

/// Whether the kernel follows the scene or does everything.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FeatureMode {
    /// The kernel the scene's features need.
    #[default]
    Auto,
    /// The general kernel, whatever the scene uses.
    All,
}

/// What the scene's rendered surfaces and lights use.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// Some surface has a Lambert lobe (is not fully metallic).
    pub diffuse: bool,
    /// Some surface has a GGX lobe (metallic, or specular > 0).
    pub ggx: bool,
    /// Some surface is metallic.
    pub metallic: bool,
    /// Some surface's glossy lobe is sharp enough to focus light
    /// (`Material::focuses_light`): one of the two things that make light
    /// subpaths pay (`Context::light_paths_pay`).
    pub focusing: bool,
    /// Some surface may sample a delta lobe (`Material::may_be_smooth`):
    /// only then do light subpaths and camera paths go on through them
    /// (`Context::delta_starts`).
    pub delta_lobes: bool,
    /// Emitting surface materials and their triangles (lamps excluded).
    pub emitters: usize,
    pub emitter_triangles: usize,
    /// Area lights (lamp materials) and their triangles.
    pub lamps: usize,
    pub lamp_triangles: usize,
    /// Area lights the camera sees (Object › Visibility › Camera, off by
    /// default): camera rays test the lamps only where there is one.
    pub lamps_seen_by_camera: usize,
    pub punctual: usize,
    /// Blender area lights marked Portal (portals.rs).
    pub portals: usize,
    /// The World is not black: a colour, or an environment image.
    pub background: bool,
    pub environment: bool,
    /// Camera rays see a World of their own (`Scene::camera_world`).
    pub camera_world: bool,
    /// Some emitter emits from its front face only.
    pub one_sided_emission: bool,
    /// Materials with textures, and the images they share.
    pub textured_materials: usize,
    pub images: usize,
    /// Materials with a normal map.
    pub normal_maps: usize,
    /// Some primitive has COLOR_0.
    pub vertex_colors: bool,
    /// Materials with alphaMode MASK or BLEND: rays test them as they pass.
    pub alpha: usize,
    /// Materials with some glass (KHR_materials_transmission).
    pub transmission: usize,
    /// Of those, Translucent BSDF nodes' (Lambert through the surface).
    pub translucent: usize,
    /// Glass that absorbs inside (media.rs): paths track the medium they
    /// are in.
    pub absorbing: usize,
    /// Materials with a clear coat (KHR_materials_clearcoat).
    pub coat: usize,
    /// Anisotropic materials (KHR_materials_anisotropy).
    pub anisotropic: usize,
    /// Materials whose diffuse base is rough (Oren–Nayar, from a render
    /// request's Diffuse Roughness): they need the Principled kernel even
    /// with no glossy lobe.
    pub rough_diffuse: usize,
    /// Materials on objects hidden from the camera: camera rays test
    /// them as they pass (`Material::hidden_from_camera`).
    pub hidden_from_camera: usize,
    /// The kinds of rays after the camera's that some surface is hidden
    /// from (`Material::hidden_from_rays`): those rays test what they
    /// meet, and light subpaths are off.
    pub hidden_from_rays: crate::material::Rays,
    /// Lights with Blender's Cast Shadow off (lamps and punctual lights):
    /// light subpaths are off, as with `hidden_from_rays`.
    pub shadowless: usize,
    /// Materials that mix two BSDFs (`Material::mix`): a hit draws one.
    pub mixes: usize,
}

impl Features {
    /// Look at every triangle's material once.
    pub fn of(scene: &Scene) -> Self {
        let mut used = vec![0usize; scene.materials.len()];
        for t in &scene.triangles {
            if let Some(n) = used.get_mut(t.material as usize) {
                *n += 1;
            }
        }
        // A Mix Shader's second half shades the first's triangles.
        let mut mixes = 0;
        for (i, m) in scene.materials.iter().enumerate() {
            let count = used[i];
            if let Some(mix) = m.mix.filter(|_| count > 0) {
                if let Some(n) = used.get_mut(mix.with as usize) {
                    *n += count;
                    mixes += 1;
                }
            }
        }
        let mut f = Features {
            punctual: scene.punctual.len(),
            shadowless: scene.punctual.iter().filter(|l| l.shadowless).count(),
            mixes,
            portals: scene.portals.len(),
            background: scene.has_world(),
            environment: scene.environment.is_some(),
            camera_world: scene.camera_world.is_some(),
            images: scene.images.len(),
            vertex_colors: !scene.attributes.color.is_empty(),
            ..Features::default()
        };
        let mut smallest_roughness: Vec<Option<f32>> = vec![None; scene.images.len()];
        for (m, &count) in scene.materials.iter().zip(&used).filter(|(_, &n)| n > 0) {
            if m.is_emissive() {
                if m.lamp {
                    f.lamps += 1;
                    f.lamp_triangles += count;
                    f.lamps_seen_by_camera += m.camera_sees_lamp as usize;
                    f.shadowless += m.shadowless as usize;
                } else {
                    f.emitters += 1;
                    f.emitter_triangles += count;
                }
                f.one_sided_emission |= !m.double_sided;
            }
            if m.lamp {
                continue;
            }
            if let Some(t) = &m.textures {
                f.textured_materials += 1;
                f.normal_maps += t.normal.is_some() as usize;
            }
            f.alpha += m.has_alpha() as usize;
            f.transmission += m.is_transmissive() as usize;
            f.translucent += (m.is_transmissive() && m.translucent) as usize;
            f.absorbing += crate::media::absorbs(m) as usize;
            f.coat += m.is_coated() as usize;
            f.delta_lobes |= m.may_be_smooth();
            f.anisotropic += (m.anisotropy > 0.0) as usize;
            f.rough_diffuse += (m.metallic < 1.0 && crate::bsdf::oren_nayar::OrenNayar::new(m.diffuse_roughness, m.base_color).is_some()) as usize;
            f.hidden_from_camera += m.hidden_from_camera as usize;
            f.hidden_from_rays = f.hidden_from_rays.union(m.hidden_from_rays);
            f.diffuse |= m.metallic < 1.0;
            f.ggx |= !m.is_pure_lambert();
            f.metallic |= m.metallic > 0.0;
            // Each image scanned at most once, and none once one surface
            // is found to focus light.
            f.focusing = f.focusing
                || m.focuses_light(|image| match (smallest_roughness.get_mut(image as usize), scene.images.get(image as usize)) {
                    (Some(memo), Some(image)) => *memo.get_or_insert_with(|| image.smallest(1)),
                    _ => 1.0,
                });
        }
        f
    }
}

impl fmt::Display for Features {
    fn fmt(&self, out: &mut fmt::Formatter) -> fmt::Result {
        let flags = [(self.diffuse, "diffuse"), (self.ggx, "ggx"), (self.metallic, "metallic"), (self.focusing, "focusing"), (self.delta_lobes, "smooth")];
        let mut on: Vec<String> = flags.iter().filter(|(b, _)| *b).map(|(_, n)| n.to_string()).collect();
        if self.emitters > 0 {
            on.push(format!("emitters={} ({} tris)", self.emitters, self.emitter_triangles));
        }
        if self.lamps > 0 {
            on.push(format!("area lights={} ({} tris)", self.lamps, self.lamp_triangles));
        }
        if self.punctual > 0 {
            on.push(format!("punctual={}", self.punctual));
        }
        if self.environment {
            on.push("environment map".into());
        } else if self.background {
            on.push("background".into());
        }
        if self.camera_world {
            on.push("camera World".into());
        }
        if self.portals > 0 {
            on.push(format!("portals={}", self.portals));
        }
        if self.one_sided_emission {
            on.push("one-sided emission".into());
        }
        if self.textured_materials > 0 {
            on.push(format!("textures ({} materials, {} images)", self.textured_materials, self.images));
        }
        if self.normal_maps > 0 {
            on.push(format!("normal maps={}", self.normal_maps));
        }
        if self.vertex_colors {
            on.push("vertex colours".into());
        }
        if self.alpha > 0 {
            on.push(format!("alpha={}", self.alpha));
        }
        if self.transmission > self.translucent {
            on.push(format!("glass={}", self.transmission - self.translucent));
        }
        if self.translucent > 0 {
            on.push(format!("translucent={}", self.translucent));
        }
        if self.absorbing > 0 {
            on.push(format!("absorbing={}", self.absorbing));
        }
        if self.coat > 0 {
            on.push(format!("coat={}", self.coat));
        }
        if self.anisotropic > 0 {
            on.push(format!("anisotropic={}", self.anisotropic));
        }
        if self.rough_diffuse > 0 {
            on.push(format!("rough diffuse={}", self.rough_diffuse));
        }
        if self.hidden_from_camera > 0 {
            on.push(format!("hidden from camera={}", self.hidden_from_camera));
        }
        if self.mixes > 0 {
            on.push(format!("shader mixes={}", self.mixes));
        }
        if self.shadowless > 0 {
            on.push(format!("casting no shadow={}", self.shadowless));
        }
        if !self.hidden_from_rays.is_empty() {
            on.push(format!("hidden from {} rays", self.hidden_from_rays.names().join("/")));
        }
        if on.is_empty() {
            on.push("nothing".into());
        }
        write!(out, "{}", on.join(", "))
    }
}

/// The BSDF code a kernel runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelBsdf {
    Lambert,
    Principled,
    Seed,
}

/// One compiled kernel: its BSDF and which light parts it has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kernel {
    pub bsdf: KernelBsdf,
    /// Emitting triangles: emission at hits, area-light sampling.
    pub area: bool,
    pub punctual: bool,
    /// Rays are tested against the lamp BVH; only with `area` (lamps are
    /// emitting triangles).
    pub lamps: bool,
    /// The BSDF mixes in glass.
    pub glass: bool,
    /// A clear coat lies over the BSDF (Principled only).
    pub coat: bool,
    /// Some material's diffuse base is rough (Principled only): the
    /// Principled BSDF's base tests for Oren–Nayar.
    pub rough_diffuse: bool,
}

impl Kernel {
    pub fn choose(features: &Features, lights: &Lights, model: BsdfModel, mode: FeatureMode) -> Self {
        let general = match model {
            BsdfModel::Principled => KernelBsdf::Principled,
            BsdfModel::Seed => KernelBsdf::Seed,
        };
        // Only the Principled model has a coat.
        let principled = model == BsdfModel::Principled;
        if mode == FeatureMode::All {
            return Kernel { bsdf: general, area: true, punctual: true, lamps: true, glass: true, coat: principled, rough_diffuse: principled };
        }
        let coat = principled && features.coat > 0;
        // Both models are exactly Lambert for a non-metal with specular 0
        // (and no coat); the Principled one's base may be rough.
        let rough_diffuse = principled && features.rough_diffuse > 0;
        let bsdf = if features.ggx || coat || rough_diffuse { general } else { KernelBsdf::Lambert };
        // The light list decides, not the materials: an emissive triangle
        // of zero power is not sampled and adds nothing.
        let area = !lights.triangles.is_empty();
        Kernel { bsdf, area, punctual: features.punctual > 0 && !lights.is_empty(), lamps: area && features.lamp_triangles > 0, glass: features.transmission > 0, coat, rough_diffuse }
    }
}

impl fmt::Display for Kernel {
    fn fmt(&self, out: &mut fmt::Formatter) -> fmt::Result {
        let bsdf = match self.bsdf {
            KernelBsdf::Lambert => "lambert",
            KernelBsdf::Principled => "principled",
            KernelBsdf::Seed => "seed",
        };
        let mut parts = vec![bsdf];
        if self.glass {
            parts.push("glass");
        }
        if self.coat {
            parts.push("coat");
        }
        if self.rough_diffuse {
            parts.push("rough diffuse");
        }
        if self.area {
            parts.push("emitters");
        }
        if self.lamps {
            parts.push("lamps");
        }
        if self.punctual {
            parts.push("punctual");
        }
        if !self.area && !self.punctual {
            parts.push("no local lights");
        }
        write!(out, "{}", parts.join(" + "))
    }
}

#[cfg(test)]
mod tests {
    use crate::Vec3;
    use super::*;
    use crate::camera::Camera;
    use crate::material::Material;
    use crate::scene::Triangle;

    fn scene(materials: Vec<Material>) -> Scene {
        let tri = |material: u32| Triangle::new([Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z; 3], material);
        let camera = Camera::from_world("c".into(), &glam::Mat4::IDENTITY, 1.0, None).unwrap();
        let triangles = (0..materials.len() as u32).map(tri).collect();
        Scene::new(triangles, materials, camera)
    }

    fn lambert(le: f32) -> Material {
        Material { metallic: 0.0, specular: 0.0, emission: Vec3::splat(le), ..Material::default() }
    }

    #[test]
    fn a_diffuse_scene_gets_the_lambert_kernel() {
        let s = scene(vec![lambert(0.0), lambert(5.0)]);
        let f = Features::of(&s);
        assert!(f.diffuse && !f.ggx && !f.metallic);
        assert_eq!((f.emitters, f.emitter_triangles), (1, 1));
        let lights = Lights::new(&s);
        let k = Kernel::choose(&f, &lights, BsdfModel::Principled, FeatureMode::Auto);
        assert_eq!(k, Kernel { bsdf: KernelBsdf::Lambert, area: true, punctual: false, lamps: false, glass: false, coat: false, rough_diffuse: false });
        assert_eq!(f.to_string(), "diffuse, emitters=1 (1 tris), one-sided emission");
        let all = Kernel::choose(&f, &lights, BsdfModel::Principled, FeatureMode::All);
        assert_eq!(all, Kernel { bsdf: KernelBsdf::Principled, area: true, punctual: true, lamps: true, glass: true, coat: true, rough_diffuse: true });
    }

    /// A rough diffuse surface takes a Lambertian scene to the Principled
    /// kernel, whose base renders it (the Lambert kernel would not); a
    /// rough metal has no base to be rough, and the seed model keeps
    /// Lambert.
    #[test]
    fn rough_diffuse_takes_the_principled_kernel() {
        let rough = Material { diffuse_roughness: 0.5, ..lambert(0.0) };
        let s = scene(vec![lambert(5.0), rough.clone(), Material { diffuse_roughness: 0.5, ..Material::default() }]);
        let f = Features::of(&s);
        assert_eq!(f.rough_diffuse, 1);
        assert!(f.to_string().contains("rough diffuse=1"), "{f}");
        let lights = Lights::new(&s);
        let k = Kernel::choose(&f, &lights, BsdfModel::Principled, FeatureMode::Auto);
        assert_eq!((k.bsdf, k.rough_diffuse), (KernelBsdf::Principled, true));
        assert_eq!(k.to_string(), "principled + rough diffuse + emitters");
        let lambertian = Features::of(&scene(vec![lambert(5.0), lambert(0.0)]));
        assert_eq!(Kernel::choose(&lambertian, &lights, BsdfModel::Principled, FeatureMode::Auto).bsdf, KernelBsdf::Lambert);
        let seed = Features::of(&scene(vec![lambert(5.0), rough]));
        assert_eq!(Kernel::choose(&seed, &lights, BsdfModel::Seed, FeatureMode::Auto).bsdf, KernelBsdf::Lambert);
    }

    #[test]
    fn unused_and_lamp_materials_do_not_count() {
        let lamp = Material { lamp: true, emission: Vec3::ONE, ..Material::default() };
        let mut s = scene(vec![lambert(0.0), lamp, Material::default()]);
        s.triangles.pop(); // the metallic default material is left unused
        let f = Features::of(&s);
        assert!(!f.ggx && !f.metallic, "{f:?}");
        assert_eq!((f.lamps, f.emitters), (1, 0));
        let k = Kernel::choose(&f, &Lights::new(&s), BsdfModel::Seed, FeatureMode::Auto);
        assert_eq!(k, Kernel { bsdf: KernelBsdf::Lambert, area: true, punctual: false, lamps: true, glass: false, coat: false, rough_diffuse: false });
    }

    #[test]
    fn a_scene_without_light_samples_none() {
        let s = scene(vec![Material::default()]);
        let f = Features::of(&s);
        assert!(f.ggx && f.metallic && !f.diffuse);
        assert_eq!((f.emitter_triangles, f.lamp_triangles, f.punctual), (0, 0, 0));
        let k = Kernel::choose(&f, &Lights::new(&s), BsdfModel::Principled, FeatureMode::Auto);
        assert_eq!(k.to_string(), "principled + no local lights");
    }
}
