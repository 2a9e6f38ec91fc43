//! Stiff and extreme cases (issue 5): each test states the figure it
//! measured; `cargo test --release --test stability -- --nocapture` prints
//! them all. docs/stability.md lists them.

mod common;

use common::*;
use glam::Vec3;
use glint::material::Material;
use glint::render::RenderSettings;
use glint::scene::Scene;

/// A floor (metal or dielectric) reflecting a small, bright light: the
/// reflection is a narrow lobe that light sampling rarely lands in.
fn glossy_floor_and_small_light(roughness: f32, metallic: f32) -> Scene {
    let mut triangles = horizontal_quad(Vec3::ZERO, 2.0, 0.0, true, 0);
    triangles.extend(horizontal_quad(Vec3::new(0.0, 0.0, -0.5), 0.05, 1.0, false, 1));
    let base = if metallic > 0.0 { 0.9 } else { 0.5 };
    let floor = Material { name: "floor".into(), base_color: Vec3::splat(base), metallic, roughness, ..Material::default() };
    // The camera looks at the light's mirror point on the floor.
    let camera = look_at(Vec3::new(0.0, 1.0, 1.5), Vec3::new(0.0, 0.0, 0.5), 0.5);
    Scene { triangles, materials: vec![floor, emitter(Vec3::splat(400.0))], camera, warnings: vec![] }
}

fn mis(on: bool, s: RenderSettings) -> RenderSettings {
    RenderSettings { mis: on, ..s }
}

#[test]
fn mis_is_unbiased_and_tames_a_glossy_reflection_of_a_small_light() {
    let scene = glossy_floor_and_small_light(0.1, 1.0);
    let (w, h) = (32, 32);
    let reference = render(&scene, &mis(true, settings(w, h, 4096, 4, 1)), 2).0;
    let ref_off = render(&scene, &mis(false, settings(w, h, 4096, 4, 2)), 2).0;
    eprintln!("reference mean: MIS {} / seed rule {}", channel_mean(&reference), channel_mean(&ref_off));
    // Both estimators are unbiased: at 4096 spp their means agree (measured
    // 0.4% apart); 2% allows for the seed rule's heavy-tailed noise.
    assert!((channel_mean(&reference) / channel_mean(&ref_off) - 1.0).abs() < 0.02);
    // Measured relMSE (MIS / seed rule): 4 spp 1.9e-2 / 5.1e-2, 16 spp
    // 5.9e-3 / 7.6e-3, 64 spp 1.5e-3 / 2.7e-3. Seeds are fixed, so these
    // are deterministic: MIS must win at every count and converge ~1/spp.
    let mut previous = f64::INFINITY;
    for spp in [4u32, 16, 64] {
        let on = render(&scene, &mis(true, settings(w, h, spp, 4, 10 + spp as u64)), 2);
        let off = render(&scene, &mis(false, settings(w, h, spp, 4, 20 + spp as u64)), 2);
        assert_clean(&on.0, &on.1, "MIS");
        assert_clean(&off.0, &off.1, "seed rule");
        let (e_on, e_off) = (relative_mse(&on.0, &reference), relative_mse(&off.0, &reference));
        eprintln!("spp {spp}: relMSE MIS {e_on:.3e}, seed rule {e_off:.3e}");
        assert!(e_on < e_off, "spp {spp}: MIS {e_on} not below the seed rule {e_off}");
        assert!(e_on < previous / 2.5, "spp {spp}: MIS error {e_on} did not fall ~1/spp from {previous}");
        previous = e_on;
    }
}

#[test]
fn roughness_sweep_metal_and_dielectric_mis_against_the_seed_rule() {
    // The light spans ±0.018 rad seen in the floor; a 0.02 rad field of view
    // sees only its reflection, so the error measures the estimators on the
    // stiff part and not the pixel filter's noise at the highlight's edge.
    let (w, h) = (24, 24);
    for metallic in [1.0f32, 0.0] {
        for roughness in [0.0f32, 1e-4, 1e-3, 0.01, 0.05, 1.0] {
            let mut scene = glossy_floor_and_small_light(roughness, metallic);
            scene.camera.yfov = 0.02;
            let reference = render(&scene, &mis(true, settings(w, h, 4096, 3, 1)), 2).0;
            let mut line = format!("metallic {metallic} roughness {roughness}:");
            let mut errors = vec![];
            for spp in [16u32, 64, 256] {
                let (on, s_on, t_on) = render_timed(&scene, &mis(true, settings(w, h, spp, 3, 10 + spp as u64)), 2);
                let (off, s_off, t_off) = render_timed(&scene, &mis(false, settings(w, h, spp, 3, 20 + spp as u64)), 2);
                assert_clean(&on, &s_on, "MIS");
                assert_clean(&off, &s_off, "seed rule");
                let (e_on, e_off) = (relative_mse(&on, &reference), relative_mse(&off, &reference));
                let equal_time = e_off / (e_on * t_on.as_secs_f64() / t_off.as_secs_f64());
                line += &format!(" | {spp} spp: MIS {e_on:.2e} ({:.0} ms), seed {e_off:.2e} ({:.0} ms), x{equal_time:.1} at equal time",
                    t_on.as_secs_f64() * 1e3, t_off.as_secs_f64() * 1e3);
                errors.push((e_on, e_off));
            }
            eprintln!("{line}");
            let ((on_16, off_16), (on_256, off_256)) = (errors[0], errors[2]);
            // MIS converges about as 1/spp (ideal: 16× from 16 to 256 spp);
            // a metal mirror filling the view is exact (error ~1e-9) at once.
            if on_16 > 1e-8 {
                assert!(on_256 < on_16 / 8.0, "{line}\nMIS does not converge as 1/spp");
            }
            if roughness <= 0.05 {
                // MIS costs ≤ 10% more per sample (measured ~0–6%), so 12×
                // at equal spp is ≥ 10× at equal time. Measured ≥ 18×.
                assert!(off_256 > 12.0 * on_256, "{line}\nMIS not 10x better than the seed rule");
            } else {
                assert!(on_256 < 1.2 * off_256, "{line}\nMIS worse than the seed rule on a rough lobe");
            }
            if roughness < 0.004 {
                // A mirror (below Cycles' threshold): the seed rule never
                // sees the light in it. Its error is a bias that does not
                // fall with samples (measured relMSE 0.98–1.0 at every spp).
                assert!(off_256 > 0.5 && off_256 > 0.9 * off_16, "{line}\nseed rule should be biased here");
            }
        }
    }
}
