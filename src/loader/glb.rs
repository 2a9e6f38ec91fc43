//! The binary glTF container (GLB): a 12-byte header, a JSON chunk and an
//! optional BIN chunk. Every length is checked against the bytes really
//! present, since a header can claim gigabytes the file does not hold.

const MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

#[derive(Debug)]
pub struct Glb<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.len() >= 4 && &bytes[..4] == MAGIC
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

pub fn parse(bytes: &[u8]) -> Result<Glb<'_>, String> {
    let version = u32_at(bytes, 4).ok_or("GLB header is shorter than 12 bytes")?;
    let length = u32_at(bytes, 8).ok_or("GLB header is shorter than 12 bytes")? as usize;
    if version != 2 {
        return Err(format!("GLB version {version} is not supported (only 2)"));
    }
    if length > bytes.len() {
        return Err(format!("GLB header says {length} bytes but the file has {}", bytes.len()));
    }
    if length < 12 {
        return Err(format!("GLB header length {length} is shorter than the header"));
    }
    let data = &bytes[..length];
    let mut at = 12usize;
    let mut json = None;
    let mut bin = None;
    while at < data.len() {
        let chunk_len = u32_at(data, at).ok_or("GLB chunk header is truncated")? as usize;
        let chunk_type = u32_at(data, at + 4).ok_or("GLB chunk header is truncated")?;
        let start = at + 8;
        let end = start
            .checked_add(chunk_len)
            .filter(|&e| e <= data.len())
            .ok_or_else(|| format!("GLB chunk at byte {at} claims {chunk_len} bytes past the end of the file"))?;
        let body = &data[start..end];
        match chunk_type {
            CHUNK_JSON if json.is_none() => {
                if at != 12 {
                    return Err("GLB JSON chunk is not the first chunk".into());
                }
                json = Some(body);
            }
            CHUNK_JSON => return Err("GLB has more than one JSON chunk".into()),
            CHUNK_BIN if bin.is_none() => bin = Some(body),
            CHUNK_BIN => return Err("GLB has more than one BIN chunk".into()),
            _ => {} // Unknown chunks are skipped, as the spec asks.
        }
        // Chunks are 4-byte aligned.
        at = end.checked_add(3).map(|e| e & !3).unwrap_or(usize::MAX);
    }
    let json = json.ok_or("GLB has no JSON chunk")?;
    Ok(Glb { json, bin })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glb(json: &[u8], bin: Option<&[u8]>, claimed: Option<u32>) -> Vec<u8> {
        let mut out = Vec::new();
        let pad = |v: &mut Vec<u8>, fill: u8| while v.len() % 4 != 0 { v.push(fill) };
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
        assert_eq!(g.json.trim_ascii(), b"{}");
        assert_eq!(&g.bin.unwrap()[..3], &[1, 2, 3]);
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
