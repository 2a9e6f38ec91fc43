//! Reading accessors with every bound checked: view inside buffer, elements
//! inside view, sparse indices inside the accessor. Arithmetic is checked so
//! a hostile count or offset yields an error, never a panic or a huge
//! allocation.

use super::buffers;
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;
use gltf::json::Root;
use std::fs::File;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

/// More elements than any scene Glint renders; stops runaway allocations for
/// accessors that have no bufferView (those are all zeros, however many).
pub const MAX_ELEMENTS: u64 = 1 << 28;

/// A GLB's BIN chunk: in memory, or a byte range of the open scene file.
#[derive(Clone)]
pub enum BinChunk<'a> {
    Memory(&'a [u8]),
    File(Arc<File>, Range<u64>),
}

/// A buffer's bytes once its URI is resolved.
enum Loaded<'a> {
    /// A decoded data: URI.
    Bytes(Vec<u8>),
    /// Part of a GLB held in memory.
    Slice(&'a [u8]),
    /// Part of a file from `start`, read a bufferView at a time.
    File { file: Arc<File>, start: u64 },
}

/// Buffers, resolved on first use so unreferenced ones are never read; a
/// file's bytes are read one referenced bufferView at a time, so data the
/// scene does not use (other meshes, animations, images) stays on disk.
pub struct Buffers<'a> {
    root: &'a Root,
    bin: Option<BinChunk<'a>>,
    base_dir: Option<&'a Path>,
    loaded: Vec<Option<Loaded<'a>>>,
    views: Vec<Option<Vec<u8>>>,
    /// Bytes read from files or decoded from data: URIs.
    pub bytes_read: u64,
}

impl<'a> Buffers<'a> {
    pub fn new(root: &'a Root, bin: Option<BinChunk<'a>>, base_dir: Option<&'a Path>) -> Self {
        Buffers {
            root,
            bin,
            base_dir,
            loaded: (0..root.buffers.len()).map(|_| None).collect(),
            views: vec![None; root.buffer_views.len()],
            bytes_read: 0,
        }
    }

    /// Resolve buffer `index` and check its length, without reading a
    /// file; the buffer's byteLength.
    pub fn get(&mut self, index: usize) -> Result<u64, String> {
        let buffer = self.root.buffers.get(index).ok_or_else(|| format!("buffer {index} does not exist"))?;
        let len = buffer.byte_length.0;
        if len > buffers::MAX_BUFFER_BYTES {
            return Err(format!("buffer {index} byteLength {len} is larger than Glint reads"));
        }
        if self.loaded[index].is_some() {
            return Ok(len);
        }
        let loaded = match buffer.uri.as_deref() {
            None => {
                let bin = self.bin.clone().ok_or_else(|| format!("buffer {index} has no uri and the file has no GLB BIN chunk"))?;
                if index != 0 {
                    return Err(format!("buffer {index} has no uri; only buffer 0 may use the GLB BIN chunk"));
                }
                let available = match &bin {
                    BinChunk::Memory(b) => b.len() as u64,
                    BinChunk::File(_, range) => range.end - range.start,
                };
                if available < len {
                    return Err(format!("buffer 0: GLB BIN chunk has {available} bytes, byteLength says {len}"));
                }
                match bin {
                    BinChunk::Memory(b) => Loaded::Slice(&b[..len as usize]),
                    BinChunk::File(file, range) => Loaded::File { file, start: range.start },
                }
            }
            Some(uri) => match buffers::decode_data_uri(uri) {
                Some(decoded) => {
                    let mut d = decoded.map_err(|e| format!("buffer {index}: {e}"))?;
                    if (d.len() as u64) < len {
                        return Err(format!("buffer {index}: data URI holds {} bytes, byteLength says {len}", d.len()));
                    }
                    d.truncate(len as usize);
                    self.bytes_read += len;
                    Loaded::Bytes(d)
                }
                None => {
                    let base = self.base_dir.ok_or_else(|| format!("buffer {index}: external file '{uri}' but the scene has no folder"))?;
                    let path = buffers::resolve_relative(uri, base).map_err(|e| format!("buffer {index}: {e}"))?;
                    let file = buffers::open_at_least(&path, len).map_err(|e| format!("buffer {index}: {e}"))?;
                    Loaded::File { file: Arc::new(file), start: 0 }
                }
            },
        };
        self.loaded[index] = Some(loaded);
        Ok(len)
    }

    /// The bytes of a buffer view (an embedded image's, say).
    pub fn view_bytes(&mut self, index: usize) -> Result<&[u8], String> {
        self.view(index).map(|(data, _)| data)
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view(&mut self, index: usize) -> Result<(&[u8], Option<usize>), String> {
        let root = self.root;
        let view = root.buffer_views.get(index).ok_or_else(|| format!("bufferView {index} does not exist"))?;
        let offset = view.byte_offset.map_or(0, |o| o.0);
        let end = offset.checked_add(view.byte_length.0).ok_or_else(|| format!("bufferView {index} range overflows"))?;
        let stride = view.byte_stride.map(|s| s.0);
        let buffer = view.buffer.value();
        let buffer_len = self.get(buffer)?;
        if end > buffer_len {
            return Err(format!("bufferView {index} (bytes {offset}..{end}) runs past its buffer ({buffer_len} bytes)"));
        }
        let (offset, end) = (offset as usize, end as usize);
        let data: &[u8] = match &self.loaded[buffer] {
            Some(Loaded::Bytes(b)) => &b[offset..end],
            Some(Loaded::Slice(b)) => &b[offset..end],
            Some(Loaded::File { file, start }) => {
                if self.views[index].is_none() {
                    let bytes = buffers::read_range(file, start + offset as u64, end - offset).map_err(|e| format!("bufferView {index}: {e}"))?;
                    if bytes.len() < end - offset {
                        return Err(format!("bufferView {index}: the file ended after {} of {} bytes (was it changed while read?)", bytes.len(), end - offset));
                    }
                    self.bytes_read += bytes.len() as u64;
                    self.views[index] = Some(bytes);
                }
                self.views[index].as_deref().unwrap_or(&[])
            }
            None => &[],
        };
        Ok((data, stride))
    }
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

fn decode(c: ComponentType, b: &[u8], normalized: bool) -> f32 {
    match c {
        ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
        ComponentType::I8 => {
            let v = b[0] as i8 as f32;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        ComponentType::U8 => {
            let v = b[0] as f32;
            if normalized { v / 255.0 } else { v }
        }
        ComponentType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f32;
            if normalized { (v / 32767.0).max(-1.0) } else { v }
        }
        ComponentType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f32;
            if normalized { v / 65535.0 } else { v }
        }
    }
}

fn decode_index(c: ComponentType, b: &[u8]) -> Option<u32> {
    match c {
        ComponentType::U8 => Some(b[0] as u32),
        ComponentType::U16 => Some(u16::from_le_bytes([b[0], b[1]]) as u32),
        ComponentType::U32 => Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        _ => None,
    }
}

/// Element `count` elements of `elem_size` bytes, `stride` apart from
/// `offset`, must lie inside `data`.
fn check_span(data_len: usize, offset: u64, stride: u64, elem_size: u64, count: u64) -> Option<()> {
    if count == 0 {
        return Some(());
    }
    let last = stride.checked_mul(count - 1)?.checked_add(offset)?.checked_add(elem_size)?;
    (last <= data_len as u64).then_some(())
}

/// An accessor's values as floats, `components` per element.
pub struct FloatData {
    pub values: Vec<f32>,
    pub components: usize,
}

impl FloatData {
    pub fn count(&self) -> usize {
        self.values.len().checked_div(self.components).unwrap_or(0)
    }
    pub fn get3(&self, i: usize) -> [f32; 3] {
        let v = &self.values[i * self.components..];
        [v[0], v[1], v[2]]
    }
    pub fn get2(&self, i: usize) -> [f32; 2] {
        let v = &self.values[i * self.components..];
        [v[0], v[1]]
    }
    pub fn get4(&self, i: usize) -> [f32; 4] {
        let v = &self.values[i * self.components..];
        [v[0], v[1], v[2], v[3]]
    }
    /// RGB or RGBA as RGBA (alpha 1 for RGB).
    pub fn get4_or_one(&self, i: usize) -> glam::Vec4 {
        let v = &self.values[i * self.components..];
        glam::Vec4::new(v[0], v[1], v[2], if self.components >= 4 { v[3] } else { 1.0 })
    }
}

pub fn read_floats(buffers: &mut Buffers, index: usize, allowed: &[Type]) -> Result<FloatData, String> {
    let root = buffers.root;
    let acc = root.accessors.get(index).ok_or_else(|| format!("accessor {index} does not exist"))?;
    let (Checked::Valid(ty), Checked::Valid(ct)) = (&acc.type_, &acc.component_type) else {
        return Err(format!("accessor {index} has an invalid type or componentType"));
    };
    if !allowed.contains(ty) {
        return Err(format!("accessor {index} has type {ty:?}, expected one of {allowed:?}"));
    }
    let ct = ct.0;
    let comps = ty.multiplicity();
    let csize = component_size(ct);
    let elem = comps * csize;
    let count = acc.count.0;
    if count > MAX_ELEMENTS {
        return Err(format!("accessor {index} count {count} is larger than Glint reads"));
    }
    let mut values = vec![0.0f32; count as usize * comps];
    if let Some(view_index) = acc.buffer_view {
        let (data, stride) = buffers.view(view_index.value())?;
        let stride = stride.unwrap_or(elem);
        if stride < elem {
            return Err(format!("accessor {index}: byteStride {stride} is smaller than its element ({elem} bytes)"));
        }
        let offset = acc.byte_offset.map_or(0, |o| o.0);
        check_span(data.len(), offset, stride as u64, elem as u64, count).ok_or_else(|| {
            format!("accessor {index} ({count} elements from byte {offset}, stride {stride}) runs past its bufferView ({} bytes)", data.len())
        })?;
        for i in 0..count as usize {
            let base = offset as usize + i * stride;
            for c in 0..comps {
                values[i * comps + c] = decode(ct, &data[base + c * csize..], acc.normalized);
            }
        }
    } else if acc.byte_offset.is_some_and(|o| o.0 != 0) {
        return Err(format!("accessor {index} has a byteOffset but no bufferView"));
    }
    if let Some(sparse) = &acc.sparse {
        let n = sparse.count.0;
        if n > count {
            return Err(format!("accessor {index}: sparse count {n} exceeds count {count}"));
        }
        let Checked::Valid(ict) = sparse.indices.component_type else {
            return Err(format!("accessor {index}: sparse indices have an invalid componentType"));
        };
        let ict = ict.0;
        let isize = component_size(ict);
        let idx: Vec<u32> = {
            let (data, _) = buffers.view(sparse.indices.buffer_view.value())?;
            let off = sparse.indices.byte_offset.0;
            check_span(data.len(), off, isize as u64, isize as u64, n)
                .ok_or_else(|| format!("accessor {index}: sparse indices run past their bufferView"))?;
            (0..n as usize)
                .map(|i| decode_index(ict, &data[off as usize + i * isize..]))
                .collect::<Option<_>>()
                .ok_or_else(|| format!("accessor {index}: sparse indices must be unsigned"))?
        };
        let (data, _) = buffers.view(sparse.values.buffer_view.value())?;
        let off = sparse.values.byte_offset.0;
        check_span(data.len(), off, elem as u64, elem as u64, n)
            .ok_or_else(|| format!("accessor {index}: sparse values run past their bufferView"))?;
        for (k, &target) in idx.iter().enumerate() {
            if target as u64 >= count {
                return Err(format!("accessor {index}: sparse index {target} is out of range ({count} elements)"));
            }
            for c in 0..comps {
                values[target as usize * comps + c] = decode(ct, &data[off as usize + k * elem + c * csize..], acc.normalized);
            }
        }
    }
    Ok(FloatData { values, components: comps })
}

pub fn read_indices(buffers: &mut Buffers, index: usize) -> Result<Vec<u32>, String> {
    let root = buffers.root;
    let acc = root.accessors.get(index).ok_or_else(|| format!("index accessor {index} does not exist"))?;
    if acc.sparse.is_some() {
        // Indices are read as integers; route sparse ones through the float
        // reader, which is exact for every u16 and for u32 up to 2^24.
        let data = read_floats(buffers, index, &[Type::Scalar])?;
        return Ok(data.values.iter().map(|&v| v as u32).collect());
    }
    let (Checked::Valid(Type::Scalar), Checked::Valid(ct)) = (&acc.type_, &acc.component_type) else {
        return Err(format!("index accessor {index} must be SCALAR"));
    };
    let ct = ct.0;
    let size = component_size(ct);
    let count = acc.count.0;
    if count > MAX_ELEMENTS {
        return Err(format!("index accessor {index} count {count} is larger than Glint reads"));
    }
    let view_index = acc.buffer_view.ok_or_else(|| format!("index accessor {index} has no bufferView"))?;
    let (data, stride) = buffers.view(view_index.value())?;
    let stride = stride.unwrap_or(size);
    let offset = acc.byte_offset.map_or(0, |o| o.0);
    check_span(data.len(), offset, stride as u64, size as u64, count)
        .ok_or_else(|| format!("index accessor {index} ({count} indices from byte {offset}) runs past its bufferView ({} bytes)", data.len()))?;
    (0..count as usize)
        .map(|i| decode_index(ct, &data[offset as usize + i * stride..]))
        .collect::<Option<Vec<u32>>>()
        .ok_or_else(|| format!("index accessor {index} must use an unsigned componentType"))
}
