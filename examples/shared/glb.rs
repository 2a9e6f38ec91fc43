//! A GLB file from a glTF document and its binary chunk, for the examples
//! that write scenes.

use std::path::Path;

/// `doc` as the JSON chunk (its `buffers` should be `[{"byteLength": n}]`
/// for `bin`), `bin` as the BIN chunk, both padded to 4 bytes.
pub fn write_glb(path: &Path, doc: &serde_json::Value, mut bin: Vec<u8>) -> anyhow::Result<()> {
    let mut json_bytes = serde_json::to_vec(doc)?;
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json_bytes.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(&json_bytes);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(&bin);
    std::fs::write(path, out)?;
    Ok(())
}
