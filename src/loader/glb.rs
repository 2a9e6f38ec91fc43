//! The binary glTF container (GLB): a 12-byte header, a JSON chunk and an
//! optional BIN chunk. Every length is checked against the bytes really
//! present, since a header can claim gigabytes the file does not hold.

use std::ops::Range;

const MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Where the chunks of a GLB lie, as byte ranges of the file.
#[derive(Debug, PartialEq)]
pub struct Layout {
    pub json: Range<u64>,
    pub bin: Option<Range<u64>>,
}

pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.len() >= 4 && &bytes[..4] == MAGIC
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Find the chunks of a GLB of `file_len` bytes, reading only its headers
/// through `read(offset, len)` (which may return fewer bytes at the end):
/// a file's BIN chunk is then read a bufferView at a time, never whole.
pub fn layout(file_len: u64, read: &mut dyn FnMut(u64, usize) -> Result<Vec<u8>, String>) -> Result<Layout, String> {
    let header = read(0, 12)?;
    let version = u32_at(&header, 4).ok_or("GLB header is shorter than 12 bytes")?;
    let length = u32_at(&header, 8).ok_or("GLB header is shorter than 12 bytes")? as u64;
    if version != 2 {
        return Err(format!("GLB version {version} is not supported (only 2)"));
    }
    if length > file_len {
        return Err(format!("GLB header says {length} bytes but the file has {file_len}"));
    }
    if length < 12 {
        return Err(format!("GLB header length {length} is shorter than the header"));
    }
    let mut at = 12u64;
    let mut json = None;
    let mut bin = None;
    while at < length {
        let chunk = read(at, 8)?;
        let chunk_len = u32_at(&chunk, 0).ok_or("GLB chunk header is truncated")? as u64;
        let chunk_type = u32_at(&chunk, 4).ok_or("GLB chunk header is truncated")?;
        let start = at + 8;
        let end = Some(start + chunk_len)
            .filter(|&e| e <= length)
            .ok_or_else(|| format!("GLB chunk at byte {at} claims {chunk_len} bytes past the end of the file"))?;
        match chunk_type {
            CHUNK_JSON if json.is_none() => {
                if at != 12 {
                    return Err("GLB JSON chunk is not the first chunk".into());
                }
                json = Some(start..end);
            }
            CHUNK_JSON => return Err("GLB has more than one JSON chunk".into()),
            CHUNK_BIN if bin.is_none() => bin = Some(start..end),
            CHUNK_BIN => return Err("GLB has more than one BIN chunk".into()),
            _ => {} // Unknown chunks are skipped, as the spec asks.
        }
        // Chunks are 4-byte aligned.
        at = (end + 3) & !3;
    }
    let json = json.ok_or("GLB has no JSON chunk")?;
    Ok(Layout { json, bin })
}

/// The layout of a GLB held in memory.
pub fn parse(bytes: &[u8]) -> Result<Layout, String> {
    layout(bytes.len() as u64, &mut |offset, len| {
        let start = (offset as usize).min(bytes.len());
        Ok(bytes[start..start.saturating_add(len).min(bytes.len())].to_vec())
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A GLB file of `json` and `bin`, its header claiming `claimed` bytes
    /// (default: the true length).
    pub(in crate::loader) fn glb(json: &[u8], bin: Option<&[u8]>, claimed: Option<u32>) -> Vec<u8> {
        let mut out = Vec::new();
        let pad = |v: &mut Vec<u8>, fill: u8| while !v.len().is_multiple_of(4) { v.push(fill) };
        let mut j = json.to_vec();
        pad(&mut j, b' ');
        let mut body = Vec::new();
        body.extend((j.len() as u32).to_le_bytes());
        body.extend(CHUNK_JSON.to_le_bytes());
        body.extend(&j);
        if let Some(b) = bin {
            let mut b = b.to_vec();
            pad(&mut b, 0);
            body.extend((b.len() as u32).to_le_bytes());
            body.extend(CHUNK_BIN.to_le_bytes());
            body.extend(&b);
        }
        out.extend(MAGIC);
        out.extend(2u32.to_le_bytes());
        out.extend(claimed.unwrap_or(12 + body.len() as u32).to_le_bytes());
        out.extend(body);
        out
    }

    #[test]
    fn reads_json_and_bin() {
        let f = glb(b"{}", Some(&[1, 2, 3]), None);
        let g = parse(&f).unwrap();
        let range = |r: std::ops::Range<u64>| &f[r.start as usize..r.end as usize];
        assert_eq!(range(g.json).trim_ascii(), b"{}");
        assert_eq!(&range(g.bin.unwrap())[..3], &[1, 2, 3]);
    }

    #[test]
    fn rejects_lying_and_truncated_headers() {
        // A 12-byte file whose header claims 4 GiB.
        let mut f = MAGIC.to_vec();
        f.extend(2u32.to_le_bytes());
        f.extend(u32::MAX.to_le_bytes());
        assert!(parse(&f).unwrap_err().contains("says"));
        assert!(parse(b"glTF\x02\x00").is_err());
        let mut g = glb(b"{}", None, None);
        g.truncate(g.len() - 1);
        assert!(parse(&g).is_err());
        assert!(parse(&glb(b"{}", None, Some(8))).is_err());
    }
}
