//! What a scene does not use, it does not pay for: the figures.
//!
//!   cargo run --release --example features [-- --spp 32 --runs 5]
//!
//! 1. Time per sample of the pure-diffuse Cornell box
//!    (scenes/cornell-box-diffuse.gltf, 256×256, up to 16 bounces) on the
//!    kernel its features choose and on the general one (`--features all`),
//!    alternating runs, with a check that the two images are bit-identical;
//!    light subpaths off in both (`auto` traces them in this box, open at
//!    the front), so that the figure is the kernels' alone, and in 2.
//! 2. Peak resident memory of loading and rendering that scene as a GLB, and
//!    as a GLB that also carries ~200 MB the scene does not reference (a mesh
//!    no node uses, an animation, a skin and an image), each in a fresh
//!    process (this program started again with `--child FILE`).

#[path = "shared/glb.rs"]
mod glb;

use glint::features::FeatureMode;
use glint::integrator::Context;
use glint::job::{self, JobOptions};
use glint::render::{render_pass, Film, LightPaths, RenderSettings};
use serde_json::{json, Value};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

const SCENE: &str = "scenes/cornell-box-diffuse.gltf";

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--child") {
        return child(Path::new(&args[i + 1]));
    }
    let flag = |name: &str, default: u32| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(default);
    let (spp, runs) = (flag("--spp", 32), flag("--runs", 5));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    kernel_speed(&root.join(SCENE), spp, runs)?;
    memory(&root.join(SCENE))
}

fn kernel_speed(scene: &Path, spp: u32, runs: u32) -> anyhow::Result<()> {
    let options = JobOptions { width: Some(256), height: Some(256), ..Default::default() };
    let mut job = job::prepare(Some(scene), &options, Default::default()).map_err(anyhow::Error::msg)?;
    job.settings.light_paths = LightPaths::Off;
    let (ctx, _) = Context::new(&job.scene);
    let threads = rayon::current_num_threads();
    println!("## Kernel specialisation: {} at 256x256, {spp} spp, {runs} runs each, {threads} threads", scene.display());
    let render = |mode: FeatureMode| {
        let settings = RenderSettings { spp, features: mode, ..job.settings.clone() };
        let mut film = Film::new(settings.width, settings.height);
        let start = Instant::now();
        render_pass(&ctx, &settings, &mut film, 0..spp, &AtomicBool::new(false), &|_| {}).expect("not cancelled");
        (start.elapsed().as_secs_f64() / spp as f64, film.sum)
    };
    let modes = [FeatureMode::Auto, FeatureMode::All];
    for mode in modes {
        let settings = RenderSettings { features: mode, ..job.settings.clone() };
        println!("{:?}: {}", mode, ctx.features_line(&settings));
    }
    render(FeatureMode::Auto); // warm caches and the thread pool
    let mut times = [Vec::new(), Vec::new()];
    let mut images = [Vec::new(), Vec::new()];
    for _ in 0..runs {
        for (k, mode) in modes.iter().enumerate() {
            let (t, image) = render(*mode);
            times[k].push(t);
            images[k] = image;
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (auto, all) = (median(&mut times[0]), median(&mut times[1]));
    println!("specialised (lambert) kernel: {auto:.4} s/sample (median; runs {:?})", times[0].iter().map(|t| format!("{t:.4}")).collect::<Vec<_>>());
    println!("general kernel (--features all): {all:.4} s/sample (median; runs {:?})", times[1].iter().map(|t| format!("{t:.4}")).collect::<Vec<_>>());
    println!("speed-up: {:.1}% less time per sample", 100.0 * (1.0 - auto / all));
    let identical = images[0].iter().zip(&images[1]).all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits));
    println!("images bit-identical: {identical}");
    anyhow::ensure!(identical, "the specialised and general kernels gave different images");
    Ok(())
}

/// Load, build and render one small pass; report the peak resident set.
fn child(scene: &Path) -> anyhow::Result<()> {
    let options = JobOptions { width: Some(64), height: Some(64), samples: Some(1), ..Default::default() };
    let mut job = job::prepare(Some(scene), &options, Default::default()).map_err(anyhow::Error::msg)?;
    job.settings.light_paths = LightPaths::Off;
    let (ctx, _) = Context::new(&job.scene);
    let mut film = Film::new(64, 64);
    render_pass(&ctx, &job.settings, &mut film, 0..1, &AtomicBool::new(false), &|_| {}).expect("not cancelled");
    let kib = glint::memory::peak_rss_kib().ok_or_else(|| anyhow::anyhow!("this OS does not report peak memory"))?;
    println!("{} {kib}", job.scene.triangles.len());
    Ok(())
}

fn memory(scene: &Path) -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("glint-features-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(scene)?)?;
    let plain = dir.join("plain.glb");
    let bloated = dir.join("unused-data.glb");
    write_glb(&plain, &doc, 0)?;
    write_glb(&bloated, &doc, 200 << 20)?;
    println!("\n## Peak memory (load, BVH build, one 64x64 sample; fresh process each)");
    let exe = std::env::current_exe()?;
    for file in [&plain, &bloated] {
        let out = std::process::Command::new(&exe).arg("--child").arg(file).output()?;
        anyhow::ensure!(out.status.success(), "{}: {}", file.display(), String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        let mut f = text.split_whitespace();
        let (tris, kib): (usize, f64) = (f.next().unwrap_or("0").parse()?, f.next().unwrap_or("0").parse()?);
        let size = std::fs::metadata(file)?.len() as f64 / (1 << 20) as f64;
        println!("{}: file {size:.1} MiB, {tris} triangles rendered, peak RSS {:.1} MiB", file.file_name().unwrap_or_default().to_string_lossy(), kib / 1024.0);
    }
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}

/// The scene as a GLB, its buffer in the BIN chunk; with `unused` > 0 the
/// BIN chunk also holds about that many bytes the scene never references.
fn write_glb(path: &Path, doc: &Value, unused: usize) -> anyhow::Result<()> {
    use base64::Engine;
    let mut doc = doc.clone();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap_or_default();
    let mut bin = base64::engine::general_purpose::STANDARD.decode(uri.split_once(',').map_or("", |(_, b)| b))?;
    if unused > 0 {
        let view = |bytes: usize, bin: &mut Vec<u8>, doc: &mut Value| {
            while !bin.len().is_multiple_of(4) {
                bin.push(0);
            }
            let offset = bin.len();
            // Not zeros: pages of zeros could be left unbacked by the OS.
            bin.extend((0..bytes).map(|i| (i * 7 + 3) as u8));
            let views = doc["bufferViews"].as_array_mut().expect("bufferViews");
            views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes}));
            views.len() - 1
        };
        let accessor = |doc: &mut Value, view: usize, count: usize, ty: &str, ct: u32| {
            let accessors = doc["accessors"].as_array_mut().expect("accessors");
            accessors.push(json!({"bufferView": view, "componentType": ct, "count": count, "type": ty}));
            accessors.len() - 1
        };
        // A mesh no node uses: half the payload.
        let vertices = unused / 2 / 12;
        let pv = view(vertices * 12, &mut bin, &mut doc);
        let pa = accessor(&mut doc, pv, vertices, "VEC3", 5126);
        doc["meshes"].as_array_mut().expect("meshes").push(json!({"name": "unused", "primitives": [{"attributes": {"POSITION": pa}}]}));
        // An animation of the box's node: a quarter.
        let keys = unused / 4 / 16;
        let tv = view(keys * 4, &mut bin, &mut doc);
        let ta = accessor(&mut doc, tv, keys, "SCALAR", 5126);
        let vv = view(keys * 12, &mut bin, &mut doc);
        let va = accessor(&mut doc, vv, keys, "VEC3", 5126);
        doc["animations"] = json!([{"channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}], "samplers": [{"input": ta, "output": va}]}]);
        // A skin's inverse bind matrices and an image: the last quarter.
        let sv = view(unused / 8 / 64 * 64, &mut bin, &mut doc);
        let sa = accessor(&mut doc, sv, unused / 8 / 64, "MAT4", 5126);
        doc["skins"] = json!([{"joints": [0], "inverseBindMatrices": sa}]);
        let iv = view(unused / 8, &mut bin, &mut doc);
        doc["images"] = json!([{"bufferView": iv, "mimeType": "image/png"}]);
        doc["textures"] = json!([{"source": 0}]);
        doc["materials"].as_array_mut().expect("materials").push(json!({"name": "unused", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}));
    }
    doc["buffers"] = json!([{"byteLength": bin.len()}]);
    glb::write_glb(path, &doc, bin)
}
