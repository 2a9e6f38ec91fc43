//! Resolving buffer URIs. Only `data:` URIs and relative paths that stay
//! inside the scene's folder are read, only regular files, and never more
//! than the buffer's declared byteLength: a scene file must not be able to
//! make Glint read `/etc/passwd`, `../secret.bin` or `/dev/zero`.

use base64::Engine;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Component, Path, PathBuf};

/// Largest buffer Glint will read (glTF byteLength is a u64).
pub const MAX_BUFFER_BYTES: u64 = 4 << 30;

/// Decode the payload of a `data:` URI, or None when `uri` is not one.
pub fn decode_data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    Some((|| {
        let (meta, payload) = rest.split_once(',').ok_or("data URI has no ','")?;
        if !meta.ends_with(";base64") {
            return Err("data URI is not base64-encoded".to_string());
        }
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("data URI is not valid base64: {e}"))
    })())
}

/// The file a relative URI names, if it stays inside `base_dir`.
pub fn resolve_relative(uri: &str, base_dir: &Path) -> Result<PathBuf, String> {
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| format!("URI '{uri}' is not valid UTF-8 after percent-decoding"))?;
    if decoded.contains("://") || decoded.contains('\0') {
        return Err(format!("URI '{uri}' is not a relative path (only data: URIs and relative files are read)"));
    }
    let rel = Path::new(decoded.as_ref());
    for c in rel.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            _ => return Err(format!("URI '{uri}' leaves the scene's folder")),
        }
    }
    let path = base_dir.join(rel);
    // Symlinks could still point outside: compare canonical paths.
    let canon_base = base_dir.canonicalize().map_err(|e| format!("scene folder: {e}"))?;
    let canon = path.canonicalize().map_err(|e| format!("'{}': {e}", path.display()))?;
    if !canon.starts_with(&canon_base) {
        return Err(format!("URI '{uri}' leaves the scene's folder"));
    }
    Ok(canon)
}

/// Open a regular file that holds at least `len` bytes (it may be longer).
pub fn open_at_least(path: &Path, len: u64) -> Result<File, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("'{}': {e}", path.display()))?;
    if !meta.is_file() {
        return Err(format!("'{}' is not a regular file", path.display()));
    }
    if meta.len() < len {
        return Err(format!("'{}' has {} bytes, byteLength says {len}", path.display(), meta.len()));
    }
    File::open(path).map_err(|e| format!("'{}': {e}", path.display()))
}

/// Read `len` bytes at `offset`; fewer only where the file ends (a file
/// can shrink while it is read: the daemon's scene is rewritten by Blender).
pub fn read_range(mut file: &File, offset: u64, len: usize) -> Result<Vec<u8>, String> {
    let mut data = Vec::new();
    data.try_reserve_exact(len).map_err(|e| format!("cannot hold {len} bytes: {e}"))?;
    file.seek(SeekFrom::Start(offset)).map_err(|e| e.to_string())?;
    file.take(len as u64).read_to_end(&mut data).map_err(|e| e.to_string())?;
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris() {
        assert_eq!(decode_data_uri("data:application/octet-stream;base64,AQID").unwrap().unwrap(), vec![1, 2, 3]);
        assert!(decode_data_uri("data:application/octet-stream,AQID").unwrap().is_err());
        assert!(decode_data_uri("data:;base64,@@@").unwrap().is_err());
        assert!(decode_data_uri("model.bin").is_none());
    }

    #[test]
    fn relative_paths_stay_inside() {
        let dir = std::env::temp_dir().join(format!("glint-uri-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("sub/a b.bin"), [0u8; 8]).unwrap();
        assert!(resolve_relative("sub/a%20b.bin", &dir).is_ok());
        assert!(resolve_relative("../secret.bin", &dir).unwrap_err().contains("leaves"));
        assert!(resolve_relative("sub/../../x", &dir).unwrap_err().contains("leaves"));
        assert!(resolve_relative("/etc/passwd", &dir).unwrap_err().contains("leaves"));
        assert!(resolve_relative("%FF.bin", &dir).unwrap_err().contains("UTF-8"));
        assert!(resolve_relative("http://example.com/x.bin", &dir).is_err());
        assert!(open_at_least(&dir.join("sub/a b.bin"), 16).unwrap_err().contains("byteLength"));
        let f = open_at_least(&dir.join("sub/a b.bin"), 4).unwrap();
        assert_eq!(read_range(&f, 6, 4).unwrap().len(), 2);
        assert!(open_at_least(&dir, 4).unwrap_err().contains("regular file"));
        assert!(open_at_least(Path::new("/dev/zero"), 4).unwrap_err().contains("regular file"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
