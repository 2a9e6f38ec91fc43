//! Peak memory per million triangles, and what load, BVH build and a
//! sample cost as a scene grows.
//!
//!   cargo run --release --example memory [-- --max 2000000]
//!
//! Writes GLBs of one indexed, smooth-shaded sphere (positions, normals and
//! 32-bit indices, as Blender exports a mesh) of 125k to 2M triangles, and
//! for each, in a fresh process (this program started again with
//! `--child FILE`), loads it, builds the BVH, renders 4 samples of a 128²
//! image lit by a grey World (`--camera auto`, 4 bounces) and prints its
//! peak resident set after loading and in all (the BVH build's temporary
//! data, obvhs' binary tree and the plan of its collapse, sets the peak). The slope of a least-squares line through the peaks
//! is the memory a million triangles cost; its intercept, what an empty
//! scene costs.

#[path = "shared/glb.rs"]
mod glb;

use glint::integrator::Context;
use glint::job::{self, JobOptions};
use glint::render::{render_pass, Film};
use serde_json::json;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--child") {
        return child(Path::new(&args[i + 1]));
    }
    let max: usize = args.iter().position(|a| a == "--max").and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(2_000_000);
    let dir = std::env::temp_dir().join(format!("glint-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let exe = std::env::current_exe()?;
    println!("triangles | file MiB | peak RSS after load MiB | peak RSS MiB | load s | BVH build s | s per sample (128², 4 bounces) | Mrays/s");
    let mut points = Vec::new();
    let mut target = 125_000;
    while target <= max {
        let file = dir.join(format!("sphere-{target}.glb"));
        write_sphere(&file, target)?;
        let out = std::process::Command::new(&exe).arg("--child").arg(&file).output()?;
        anyhow::ensure!(out.status.success(), "{}: {}", file.display(), String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        let f: Vec<f64> = text.split_whitespace().map(|v| v.parse()).collect::<Result<_, _>>()?;
        let [tris, loaded, kib, load, build, per_sample, mrays] = f[..] else { anyhow::bail!("child printed {text}") };
        let size = std::fs::metadata(&file)?.len() as f64 / (1 << 20) as f64;
        println!("{tris:>9} | {size:8.1} | {:21.1} | {:12.1} | {load:6.3} | {build:11.3} | {per_sample:.4} | {mrays:.1}", loaded / 1024.0, kib / 1024.0);
        points.push((tris / 1e6, kib / 1024.0));
        std::fs::remove_file(&file)?;
        target *= 2;
    }
    std::fs::remove_dir_all(&dir)?;
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / points.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    println!("peak RSS: {slope:.0} MiB per million triangles (least squares), {:.0} MiB with none", my - slope * mx);
    Ok(())
}

/// Load, build, render; print triangles, peak KiB after loading and in
/// all, load and build seconds, seconds per sample and Mrays/s.
fn child(scene: &Path) -> anyhow::Result<()> {
    let start = Instant::now();
    let options = JobOptions { width: Some(128), height: Some(128), samples: Some(4), max_depth: Some(4), camera: Some("auto".into()), background: Some([0.5; 3]), ..Default::default() };
    let job = job::prepare(Some(scene), &options, Default::default()).map_err(anyhow::Error::msg)?;
    let load = start.elapsed().as_secs_f64();
    let after_load = glint::memory::peak_rss_kib().unwrap_or(0);
    let (ctx, build) = Context::new(&job.scene);
    // Built once per process, as `glint render` does before its clock.
    glint::bsdf::energy::tables();
    let mut film = Film::new(128, 128);
    let start = Instant::now();
    let stats = render_pass(&ctx, &job.settings, &mut film, 0..4, &AtomicBool::new(false), &|_| {}).map_err(anyhow::Error::msg)?;
    let seconds = start.elapsed().as_secs_f64();
    let kib = glint::memory::peak_rss_kib().ok_or_else(|| anyhow::anyhow!("this OS does not report peak memory"))?;
    let mrays = stats.rays.total() as f64 / seconds / 1e6;
    println!("{} {after_load} {kib} {load} {} {} {mrays}", job.scene.triangles.len(), build.as_secs_f64(), seconds / 4.0);
    Ok(())
}

/// A unit UV sphere of about `triangles` triangles as a GLB.
fn write_sphere(path: &Path, triangles: usize) -> anyhow::Result<()> {
    // rings × segments quads, two triangles each, rings = segments / 2.
    let segments = ((triangles as f64).sqrt().round() as usize).max(4);
    let rings = (segments / 2).max(2);
    let mut positions = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            positions.push([theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()]);
        }
    }
    let mut indices: Vec<u32> = Vec::new();
    let row = segments as u32 + 1;
    for r in 0..rings as u32 {
        for s in 0..segments as u32 {
            let (a, b) = (r * row + s, (r + 1) * row + s);
            indices.extend([a, b, a + 1, a + 1, b, b + 1]);
        }
    }
    let mut bin: Vec<u8> = Vec::new();
    for p in &positions {
        p.iter().for_each(|v| bin.extend(v.to_le_bytes()));
    }
    // A unit sphere's normals are its positions.
    for p in &positions {
        p.iter().for_each(|v| bin.extend(v.to_le_bytes()));
    }
    let index_offset = bin.len();
    indices.iter().for_each(|i| bin.extend(i.to_le_bytes()));
    let n = positions.len();
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3", "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 0, "byteOffset": n * 12, "componentType": 5126, "count": n, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": index_offset},
            {"buffer": 0, "byteOffset": index_offset, "byteLength": indices.len() * 4}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    glb::write_glb(path, &doc, bin)
}
