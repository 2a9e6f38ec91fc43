//! Print an EXR's mean radiance and luminance, and the mean of regions given
//! as x0 x1 y0 y1 (pixels): `cargo run --example exr_stats -- img.exr [x0 x1 y0 y1]…`
fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (w, h, px) = glint::output::read_exr(std::path::Path::new(&args[0]))?;
    let mean = px.iter().copied().sum::<glint::Vec3>() / px.len() as f32;
    println!("{w}x{h} mean {mean} luminance {}", mean.dot(glint::Vec3::new(0.2126, 0.7152, 0.0722)));
    for r in args[1..].chunks(4) {
        let v: Vec<u32> = r.iter().map(|s| s.parse().unwrap()).collect();
        let mut s = glint::Vec3::ZERO;
        for y in v[2]..v[3] { for x in v[0]..v[1] { s += px[(y * w + x) as usize]; } }
        println!("region {v:?}: {}", s / ((v[1] - v[0]) * (v[3] - v[2])) as f32);
    }
    Ok(())
}
