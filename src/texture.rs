//! Images and their lookup: glTF textures (base colour, metallic-roughness,
//! emissive, normal) and the World's environment map.
//!
//! An image is decoded once and shared by every material that uses it.
//! 8-bit images stay 8-bit, as in Cycles, and like Cycles Glint filters an
//! 8-bit sRGB image in its encoded values and decodes the result (a red and
//! blue checker came out 14% brighter in red than Cycles' when texels were
//! decoded first); 16-bit and float images are kept as linear f32 and
//! filtered there. Colour is filtered premultiplied by alpha, also as in
//! Cycles (straight filtering let a hole's colour bleed onto the opaque
//! texels around it: 9% off in green and blue in the suite's alpha scene).
//!
//! Lookups follow glTF (and Cycles' image texture): uv (0, 0) is the image's
//! top-left corner, texel centres sit at (i + ½)/width, bilinear filtering
//! unless the sampler asks for NEAREST, no mipmaps — a path tracer
//! averages many samples per pixel, which filters minification itself.

use glam::{Vec2, Vec4};
use std::sync::OnceLock;

#[derive(Clone, Debug)]
pub enum Texels {
    Rgba8(Vec<[u8; 4]>),
    RgbaF32(Vec<[f32; 4]>),
}

#[derive(Clone, Debug)]
pub struct Image {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub texels: Texels,
}

/// glTF's wrap modes (sampler wrapS / wrapT).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    #[default]
    Repeat,
    ClampToEdge,
    MirroredRepeat,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampler {
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    /// glTF magFilter NEAREST (Blender's "Closest"); else bilinear.
    pub nearest: bool,
}

/// KHR_texture_transform: uv' = offset + R(rotation) · (scale ∘ uv), with
/// R = [[cos, sin], [−sin, cos]] as the extension defines it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub offset: Vec2,
    pub rotation: f32,
    pub scale: Vec2,
}

impl UvTransform {
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let (s, c) = self.rotation.sin_cos();
        let p = uv * self.scale;
        self.offset + Vec2::new(c * p.x + s * p.y, -s * p.x + c * p.y)
    }
}

/// A material's use of one texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureSlot {
    /// Index into `Scene::images`.
    pub image: u32,
    pub sampler: Sampler,
    /// Which TEXCOORD_n set (0 or 1).
    pub texcoord: u8,
    pub transform: Option<UvTransform>,
}

/// Whether a texel's RGB is sRGB-encoded colour (base colour, emissive) or
/// linear data (metallic-roughness, normals, HDR images).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Srgb,
    Linear,
}

/// IEC 61966-2-1 sRGB decoding.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// Texel coordinate along one axis after wrapping, for an integer index.
fn wrap_index(i: i64, n: u32, wrap: Wrap) -> u32 {
    let n = n as i64;
    let w = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let period = i.rem_euclid(2 * n);
            if period < n { period } else { 2 * n - 1 - period }
        }
    };
    w as u32
}

impl Image {
    /// The smallest value of one channel (0 = R … 3 = A) over all texels,
    /// as linear data (the metallic-roughness texture's encoding); 1 for
    /// an image without texels. A NaN texel is passed over.
    pub fn smallest(&self, channel: usize) -> f32 {
        let channel = channel.min(3);
        match &self.texels {
            Texels::Rgba8(t) => t.iter().map(|texel| texel[channel]).min().map_or(1.0, |v| v as f32 / 255.0),
            Texels::RgbaF32(t) => t.iter().map(|texel| texel[channel]).fold(f32::INFINITY, f32::min).min(1.0),
        }
    }

    /// One texel, decoded to linear float.
    pub fn texel(&self, x: u32, y: u32, encoding: Encoding) -> Vec4 {
        let i = (y as usize) * (self.width as usize) + x as usize;
        match &self.texels {
            Texels::Rgba8(t) => {
                let [r, g, b, a] = t[i];
                let alpha = a as f32 / 255.0;
                match encoding {
                    Encoding::Srgb => {
                        let lut = srgb_table();
                        Vec4::new(lut[r as usize], lut[g as usize], lut[b as usize], alpha)
                    }
                    Encoding::Linear => Vec4::new(r as f32 / 255.0, g as f32 / 255.0, b as f32 / 255.0, alpha),
                }
            }
            Texels::RgbaF32(t) => {
                let v = Vec4::from(t[i]);
                match encoding {
                    Encoding::Srgb => Vec4::new(srgb_to_linear(v.x), srgb_to_linear(v.y), srgb_to_linear(v.z), v.w),
                    Encoding::Linear => v,
                }
            }
        }
    }

    /// The image at `uv` (glTF convention: v = 0 is the top row).
    pub fn sample(&self, uv: Vec2, sampler: Sampler, encoding: Encoding) -> Vec4 {
        let (w, h) = (self.width, self.height);
        // Non-finite coordinates (from broken UVs) read texel (0, 0).
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        // f64 keeps the texel index exact for large repeat counts; the
        // clamp keeps index arithmetic far from overflow.
        let x = (uv.x as f64 * w as f64).clamp(-1e12, 1e12);
        let y = (uv.y as f64 * h as f64).clamp(-1e12, 1e12);
        if sampler.nearest {
            let xi = wrap_index(x.floor() as i64, w, sampler.wrap_s);
            let yi = wrap_index(y.floor() as i64, h, sampler.wrap_t);
            return self.texel(xi, yi, encoding);
        }
        let (x, y) = (x - 0.5, y - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [wrap_index(x0, w, sampler.wrap_s), wrap_index(x0 + 1, w, sampler.wrap_s)];
        let ys = [wrap_index(y0, h, sampler.wrap_t), wrap_index(y0 + 1, h, sampler.wrap_t)];
        // 8-bit texels are filtered encoded, then decoded (Cycles' byte
        // images); float texels decoded, then filtered.
        // Colour is filtered premultiplied by alpha, as Cycles does, so a
        // transparent texel's colour does not bleed into an opaque one's.
        let filter_encoded = matches!(self.texels, Texels::Rgba8(_));
        let at = |x, y| {
            let t = if filter_encoded { self.texel(x, y, Encoding::Linear) } else { self.texel(x, y, encoding) };
            (t.truncate() * t.w).extend(t.w)
        };
        let row = |y| at(xs[0], y) * (1.0 - fx) + at(xs[1], y) * fx;
        let premultiplied = row(ys[0]) * (1.0 - fy) + row(ys[1]) * fy;
        let v = if premultiplied.w > 0.0 { (premultiplied.truncate() / premultiplied.w).extend(premultiplied.w) } else { premultiplied };
        match encoding {
            Encoding::Srgb if filter_encoded => Vec4::new(srgb_to_linear(v.x), srgb_to_linear(v.y), srgb_to_linear(v.z), v.w),
            _ => v,
        }
    }
}

impl TextureSlot {
    /// The texture at a point whose texture coordinate sets are `uv`.
    pub fn sample(&self, images: &[Image], uv: &[Vec2; 2], encoding: Encoding) -> Vec4 {
        let mut st = uv[(self.texcoord as usize).min(1)];
        if let Some(t) = &self.transform {
            st = t.apply(st);
        }
        images[self.image as usize].sample(st, self.sampler, encoding)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, texels: Vec<[u8; 4]>) -> Image {
        Image { name: "test".into(), width: w, height: h, texels: Texels::Rgba8(texels) }
    }

    /// A 2 × 1 image: black, then white.
    fn black_white() -> Image {
        image(2, 1, vec![[0, 0, 0, 255], [255, 255, 255, 255]])
    }

    #[test]
    fn srgb_decoding_of_8_bit_texels_matches_the_formula() {
        let lut = srgb_table();
        for i in 0..=255u8 {
            assert_eq!(lut[i as usize], srgb_to_linear(i as f32 / 255.0));
        }
        let img = image(1, 1, vec![[128, 64, 255, 51]]);
        let v = img.texel(0, 0, Encoding::Srgb);
        assert!((v.x - 0.2158605).abs() < 1e-6 && (v.z - 1.0).abs() < 1e-7, "{v}");
        assert!((v.w - 0.2).abs() < 1e-7, "alpha stays linear: {v}");
        assert_eq!(img.texel(0, 0, Encoding::Linear).x, 128.0 / 255.0);
    }

    #[test]
    fn bilinear_between_texel_centres_and_exact_at_them() {
        let img = black_white();
        let s = Sampler { wrap_s: Wrap::ClampToEdge, ..Sampler::default() };
        let at = |u: f32| img.sample(Vec2::new(u, 0.5), s, Encoding::Linear).x;
        assert_eq!(at(0.25), 0.0);
        assert_eq!(at(0.75), 1.0);
        assert!((at(0.5) - 0.5).abs() < 1e-6);
        assert_eq!(at(0.0), 0.0, "clamped at the edge");
        assert_eq!(at(1.0), 1.0);
    }

    #[test]
    fn eight_bit_srgb_is_filtered_encoded_then_decoded_as_cycles_does() {
        let img = black_white();
        let s = Sampler { wrap_s: Wrap::ClampToEdge, ..Sampler::default() };
        let mid = img.sample(Vec2::new(0.5, 0.5), s, Encoding::Srgb).x;
        assert!((mid - srgb_to_linear(0.5)).abs() < 1e-6, "{mid}");
        // Float images are linear already: filtered as they are.
        let float = Image { name: "f".into(), width: 2, height: 1, texels: Texels::RgbaF32(vec![[0.0, 0.0, 0.0, 1.0], [1.0; 4]]) };
        assert!((float.sample(Vec2::new(0.5, 0.5), s, Encoding::Linear).x - 0.5).abs() < 1e-6);
    }

    /// Between an opaque white texel and a transparent red one, colour is
    /// weighted by alpha (premultiplied filtering, as Cycles does): the
    /// red, at alpha 0, adds nothing to the colour, half to the coverage.
    #[test]
    fn colour_is_filtered_premultiplied_by_alpha() {
        let img = image(2, 1, vec![[255, 255, 255, 255], [255, 0, 0, 0]]);
        let s = Sampler { wrap_s: Wrap::ClampToEdge, ..Sampler::default() };
        let mid = img.sample(Vec2::new(0.5, 0.5), s, Encoding::Linear);
        assert!((mid - Vec4::new(1.0, 1.0, 1.0, 0.5)).abs().max_element() < 1e-6, "{mid}");
        let clear = img.sample(Vec2::new(0.75, 0.5), s, Encoding::Linear);
        assert_eq!(clear.w, 0.0, "fully transparent: {clear}");
    }

    #[test]
    fn wrap_modes_repeat_clamp_and_mirror() {
        assert_eq!((-1..5).map(|i| wrap_index(i, 2, Wrap::Repeat)).collect::<Vec<_>>(), [1, 0, 1, 0, 1, 0]);
        assert_eq!((-1..5).map(|i| wrap_index(i, 2, Wrap::ClampToEdge)).collect::<Vec<_>>(), [0, 0, 1, 1, 1, 1]);
        assert_eq!((-2..6).map(|i| wrap_index(i, 2, Wrap::MirroredRepeat)).collect::<Vec<_>>(), [1, 0, 0, 1, 1, 0, 0, 1]);
        let img = black_white();
        let repeat = Sampler { nearest: true, ..Sampler::default() };
        // u = 1.25 is the first texel again; u = -0.25 the last.
        assert_eq!(img.sample(Vec2::new(1.25, 0.0), repeat, Encoding::Linear).x, 0.0);
        assert_eq!(img.sample(Vec2::new(-0.25, 0.0), repeat, Encoding::Linear).x, 1.0);
        // Bilinear across the seam of a repeating texture blends both ends.
        let seam = img.sample(Vec2::new(0.0, 0.5), Sampler::default(), Encoding::Linear).x;
        assert!((seam - 0.5).abs() < 1e-6, "{seam}");
    }

    #[test]
    fn v_zero_is_the_top_row() {
        let img = image(1, 2, vec![[255, 0, 0, 255], [0, 0, 255, 255]]);
        let nearest = Sampler { nearest: true, ..Sampler::default() };
        assert_eq!(img.sample(Vec2::new(0.5, 0.1), nearest, Encoding::Linear).x, 1.0);
        assert_eq!(img.sample(Vec2::new(0.5, 0.9), nearest, Encoding::Linear).z, 1.0);
    }

    #[test]
    fn texture_transform_as_the_extension_defines_it() {
        // The extension's example: offset (0, 1), rotation π/2, scale (2, 2)
        // maps (1, 0) to (0, 1) + R(π/2)·(2, 0) = (0, 1) + (0, −2).
        let t = UvTransform { offset: Vec2::new(0.0, 1.0), rotation: std::f32::consts::FRAC_PI_2, scale: Vec2::splat(2.0) };
        let p = t.apply(Vec2::new(1.0, 0.0));
        assert!((p - Vec2::new(0.0, -1.0)).length() < 1e-6, "{p}");
    }

    #[test]
    fn broken_coordinates_read_a_texel_not_garbage() {
        let img = black_white();
        for uv in [Vec2::NAN, Vec2::new(f32::INFINITY, 0.0), Vec2::splat(1e30), Vec2::splat(-1e30)] {
            for s in [Sampler::default(), Sampler { nearest: true, ..Sampler::default() }, Sampler { wrap_s: Wrap::MirroredRepeat, wrap_t: Wrap::ClampToEdge, nearest: false }] {
                let v = img.sample(uv, s, Encoding::Srgb);
                assert!(v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0, "{uv} {s:?}: {v}");
            }
        }
    }
}
