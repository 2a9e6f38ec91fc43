//! glTF images and texture references → `texture::Image` and `TextureSlot`.
//!
//! An image is decoded the first time a material the scene renders uses it,
//! once, whatever the number of textures and materials sharing it. An
//! image that cannot be read or decoded is a warning, not an error: the
//! material renders with its factors, as Blender shows a missing image.

use super::accessor::Buffers;
use super::{buffers, finite_or};
use crate::texture::{Image, Sampler, TextureSlot, Texels, UvTransform, Wrap};
use glam::Vec2;
use gltf::json::extensions::texture::TextureTransform;
use gltf::json::texture::{MagFilter, WrappingMode};
use gltf::json::validation::Checked;
use gltf::json::Root;
use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

/// The largest image side Glint decodes (GPU texture limits are 16k–32k).
const MAX_IMAGE_SIDE: u32 = 32768;
/// The largest decoded image, in bytes.
const MAX_IMAGE_BYTES: u64 = 4 << 30;

/// Decoded images by glTF image index; failures remembered with their reason.
#[derive(Default)]
pub struct ImageCache {
    ids: HashMap<usize, Result<u32, String>>,
    pub images: Vec<Image>,
    /// One line per image that could not be used.
    pub failures: Vec<String>,
    /// Texture coordinate sets above 1, which Glint does not read.
    pub unsupported_sets: usize,
}

/// A texture reference as glTF writes it, for any of the material's slots.
pub struct TextureRef<'a> {
    pub index: usize,
    pub tex_coord: u32,
    pub transform: Option<&'a TextureTransform>,
}

fn wrap(mode: &Checked<WrappingMode>) -> Wrap {
    match mode {
        Checked::Valid(WrappingMode::ClampToEdge) => Wrap::ClampToEdge,
        Checked::Valid(WrappingMode::MirroredRepeat) => Wrap::MirroredRepeat,
        _ => Wrap::Repeat,
    }
}

impl ImageCache {
    /// Resolve a texture reference. Err for references to what does not
    /// exist (the file is invalid); Ok(None) when its image cannot be used.
    pub fn slot(&mut self, root: &Root, buffers: &mut Buffers, base_dir: Option<&Path>, r: &TextureRef) -> Result<Option<TextureSlot>, String> {
        let texture = root.textures.get(r.index).ok_or_else(|| format!("texture {} does not exist", r.index))?;
        let sampler = match texture.sampler {
            None => Sampler::default(),
            Some(s) => {
                let s = root.samplers.get(s.value()).ok_or_else(|| format!("texture {}: sampler {} does not exist", r.index, s.value()))?;
                Sampler { wrap_s: wrap(&s.wrap_s), wrap_t: wrap(&s.wrap_t), nearest: s.mag_filter == Some(Checked::Valid(MagFilter::Nearest)) }
            }
        };
        let source = texture.source.value();
        if source >= root.images.len() {
            return Err(format!("texture {}: image {source} does not exist", r.index));
        }
        let image = match self.image(root, buffers, base_dir, source) {
            Some(id) => id,
            None => return Ok(None),
        };
        let tex_coord = r.transform.and_then(|t| t.tex_coord).unwrap_or(r.tex_coord);
        if tex_coord > 1 {
            self.unsupported_sets += 1;
        }
        let transform = r.transform.map(|t| UvTransform {
            offset: Vec2::from(t.offset.0.map(|v| finite_or(v, 0.0))),
            rotation: finite_or(t.rotation.0, 0.0),
            scale: Vec2::from(t.scale.0.map(|v| finite_or(v, 1.0))),
        });
        Ok(Some(TextureSlot { image, sampler, texcoord: tex_coord.min(1) as u8, transform }))
    }

    fn image(&mut self, root: &Root, buffers: &mut Buffers, base_dir: Option<&Path>, index: usize) -> Option<u32> {
        if let Some(known) = self.ids.get(&index) {
            return known.as_ref().ok().copied();
        }
        let gltf_image = &root.images[index];
        let name = gltf_image.name.clone().unwrap_or_else(|| format!("image {index}"));
        let result = read_image_bytes(root, buffers, base_dir, index).and_then(|bytes| decode(&bytes, &name));
        let id = match result {
            Ok(image) => {
                self.images.push(image);
                Ok(self.images.len() as u32 - 1)
            }
            Err(e) => {
                self.failures.push(format!("image {index} ('{name}') not used: {e}; its materials render with their factors"));
                Err(e)
            }
        };
        let out = id.as_ref().ok().copied();
        self.ids.insert(index, id);
        out
    }
}

fn read_image_bytes(root: &Root, buffers: &mut Buffers, base_dir: Option<&Path>, index: usize) -> Result<Vec<u8>, String> {
    let image = &root.images[index];
    if let Some(view) = image.buffer_view {
        return buffers.view_bytes(view.value()).map(|b| b.to_vec());
    }
    let uri = image.uri.as_deref().ok_or("it has neither a uri nor a bufferView")?;
    if let Some(decoded) = buffers::decode_data_uri(uri) {
        return decoded;
    }
    let base = base_dir.ok_or_else(|| format!("external file '{uri}' but the scene has no folder"))?;
    let path = buffers::resolve_relative(uri, base)?;
    let len = std::fs::metadata(&path).map_err(|e| format!("'{}': {e}", path.display()))?.len();
    if len > buffers::MAX_BUFFER_BYTES {
        return Err(format!("'{}' is {len} bytes", path.display()));
    }
    let file = buffers::open_at_least(&path, len)?;
    buffers::read_range(&file, 0, len as usize)
}

/// PNG or JPEG bytes → an image: 8-bit images stay 8-bit (sRGB decoded at
/// lookup), deeper ones become f32.
pub fn decode(bytes: &[u8], name: &str) -> Result<Image, String> {
    let mut reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_IMAGE_BYTES);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| e.to_string())?;
    let (width, height) = (decoded.width(), decoded.height());
    if width == 0 || height == 0 {
        return Err("it has no pixels".into());
    }
    let texels = match decoded.color() {
        image::ColorType::L8 | image::ColorType::La8 | image::ColorType::Rgb8 | image::ColorType::Rgba8 => {
            Texels::Rgba8(decoded.into_rgba8().pixels().map(|p| p.0).collect())
        }
        _ => Texels::RgbaF32(decoded.into_rgba32f().pixels().map(|p| p.0).collect()),
    };
    Ok(Image { name: name.to_string(), width, height, texels })
}
