//! Image files, written atomically: to a temporary name in the same folder,
//! then renamed, so a reader never sees a half-written image and a failed
//! write never destroys the previous one.

use anyhow::{bail, Context as _, Result};
use crate::Vec3;
use std::path::{Path, PathBuf};

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Write through `write` to a temporary name beside `path`, then rename.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot move the finished file into place", path.display()))
}

/// Write `bytes` to `path` atomically.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |tmp| std::fs::write(tmp, bytes).with_context(|| format!("{}: cannot write", path.display())))
}

fn check_size(width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
    if width == 0 || height == 0 || pixels.len() != width as usize * height as usize {
        bail!("image of {width}×{height} with {} pixels cannot be written", pixels.len());
    }
    Ok(())
}

/// A file's alpha, where it has one, is one value a pixel.
fn check_alpha(path: &Path, pixels: &[Vec3], alpha: Option<&[f32]>) -> Result<()> {
    if let Some(a) = alpha.filter(|a| a.len() != pixels.len()) {
        bail!("{}: {} alpha values for {} pixels", path.display(), a.len(), pixels.len());
    }
    Ok(())
}

/// Linear float RGBA EXR (alpha 1, or a transparent film's coverage with
/// the colour premultiplied by it), scene-referred radiance: run-length
/// coded 64×64 tiles (exr's default), in increasing order, so that the
/// same pixels always make the same file (the default order is that in
/// which the parallel compression finishes).
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[Vec3], alpha: Option<&[f32]>) -> Result<()> {
    use exr::prelude::*;
    check_size(width, height, pixels)?;
    check_alpha(path, pixels, alpha)?;
    let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let i = y * width as usize + x;
        let p = pixels[i];
        (p.x, p.y, p.z, alpha.map_or(1.0, |a| a[i]))
    });
    let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
    let image = Image::from_encoded_channels((width as usize, height as usize), encoding, channels);
    write_atomically(path, |tmp| image.write().to_file(tmp).with_context(|| format!("{}: cannot write EXR", path.display())))
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn srgb_encode(linear: f32) -> f32 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// 8-bit sRGB PNG preview, clamped to [0, 1] (no tone mapping); with a
/// transparent film's coverage, RGBA with straight alpha as PNG has it
/// (the EXR's premultiplied colour divided by alpha, black where nothing
/// is covered).
pub fn write_png(path: &Path, width: u32, height: u32, pixels: &[Vec3], alpha: Option<&[f32]>) -> Result<()> {
    check_size(width, height, pixels)?;
    check_alpha(path, pixels, alpha)?;
    let byte = |c: f32| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let (bytes, colour): (Vec<u8>, _) = match alpha {
        None => (pixels.iter().flat_map(|p| p.to_array()).map(|c| byte(srgb_encode(c))).collect(), image::ColorType::Rgb8),
        Some(alpha) => {
            let straight = |p: Vec3, a: f32| if a > 0.0 { p / a } else { Vec3::ZERO };
            let rgba = pixels.iter().zip(alpha).flat_map(|(&p, &a)| {
                let [r, g, b] = straight(p, a).to_array().map(|c| byte(srgb_encode(c)));
                [r, g, b, byte(a)]
            });
            (rgba.collect(), image::ColorType::Rgba8)
        }
    };
    write_atomically(path, |tmp| {
        image::save_buffer_with_format(tmp, &bytes, width, height, colour, image::ImageFormat::Png)
            .with_context(|| format!("{}: cannot write PNG", path.display()))
    })
}

/// Read back an RGBA EXR written by `write_exr` (for tests and tools).
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    read_exr_with_alpha(path).map(|(w, h, px, _)| (w, h, px))
}

/// `read_exr`, and the alpha channel.
pub fn read_exr_with_alpha(path: &Path) -> Result<(u32, u32, Vec<Vec3>, Vec<f32>)> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()], vec![0.0f32; res.width() * res.height()]),
        |(w, px, alpha), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
            alpha[pos.y() * *w + pos.x()] = a;
        },
    )
    .with_context(|| format!("{}: cannot read EXR", path.display()))?;
    let size = image.layer_data.size;
    let (_, px, alpha) = image.layer_data.channel_data.pixels;
    Ok((size.width() as u32, size.height() as u32, px, alpha))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trips_and_leaves_no_temp_file() {
        let dir = std::env::temp_dir().join(format!("glint-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.exr");
        let px: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, 0.5, 1e4)).collect();
        write_exr(&path, 3, 2, &px, None).unwrap();
        let (w, h, back, alpha) = read_exr_with_alpha(&path).unwrap();
        assert_eq!((w, h, alpha), (3, 2, vec![1.0; 6]));
        assert_eq!(back, px);
        let coverage = [0.0, 0.25, 1.0, 0.5, 0.75, 1.0];
        write_exr(&path, 3, 2, &px, Some(&coverage)).unwrap();
        assert_eq!(read_exr_with_alpha(&path).unwrap().3, coverage);
        assert!(write_exr(&path, 3, 2, &px, Some(&coverage[..5])).is_err());
        write_png(&dir.join("a.png"), 3, 2, &px, None).unwrap();
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 2, "{names:?}");
        assert!(write_exr(&path, 0, 2, &[], None).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A transparent film's PNG preview keeps its alpha, with the colour
    /// straight as PNG has it: premultiplied 0.25 at alpha 0.5 is 0.5
    /// (sRGB 188), and an uncovered pixel is black and transparent.
    #[test]
    fn png_preview_keeps_a_transparent_films_alpha() {
        let dir = std::env::temp_dir().join(format!("glint-png-alpha-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.png");
        let px = [Vec3::splat(0.25), Vec3::ZERO, Vec3::ONE];
        write_png(&path, 3, 1, &px, Some(&[0.5, 0.0, 1.0])).unwrap();
        let png = image::open(&path).unwrap().to_rgba8();
        assert_eq!(png.as_raw().as_slice(), &[188, 188, 188, 128, 0, 0, 0, 0, 255, 255, 255, 255]);
        write_png(&path, 3, 1, &px, None).unwrap();
        assert_eq!(image::open(&path).unwrap().color(), image::ColorType::Rgb8);
        assert!(write_png(&path, 3, 1, &px, Some(&[1.0])).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The same pixels make the same file, byte for byte: the EXR's
    /// blocks (64×64 tiles, compressed in parallel) are written in order,
    /// not as their compression finishes.
    #[test]
    fn the_same_pixels_write_the_same_bytes() {
        let dir = std::env::temp_dir().join(format!("glint-out-bytes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (640u32, 384u32);
        let px: Vec<Vec3> = (0..w * h).map(|i| Vec3::new((i % 97) as f32 * 0.01, (i / w) as f32 * 1e-3, ((i * 7919) % 1000) as f32)).collect();
        let bytes: Vec<Vec<u8>> = (0..4)
            .map(|k| {
                let path = dir.join(format!("{k}.exr"));
                write_exr(&path, w, h, &px, None).unwrap();
                std::fs::read(&path).unwrap()
            })
            .collect();
        assert!(bytes.iter().all(|b| b == &bytes[0]));
        assert_eq!(read_exr(&dir.join("0.exr")).unwrap().2, px);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn srgb_curve_endpoints() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
    }
}
