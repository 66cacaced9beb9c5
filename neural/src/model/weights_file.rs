//! The container of every weights file the studio writes (avatars, the meta-learned model,
//! meta-training checkpoints): 8 magic bytes, a little-endian u64 header length, a JSON header,
//! then float32 little-endian weights. Written atomically; truncation, NaN and foreign files
//! are refused with a message naming the file.

use crate::error::{Error, Result};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::Path;

const MAGIC: &[u8; 8] = b"AVATAR\0\x01";

/// Largest JSON header read (a header is a few kilobytes).
const MAX_HEADER_BYTES: u64 = 1 << 24;

/// Write `header` and `weights` to `path` atomically. Weights that are NaN or infinite (a
/// diverged fit) are refused: no file is written that the loaders would refuse.
pub fn write<H: Serialize>(path: &Path, header: &H, weights: &[f32]) -> Result<()> {
    if let Some(i) = weights.iter().position(|v| !v.is_finite()) {
        let bad = weights.iter().filter(|v| !v.is_finite()).count();
        return Err(Error::file(
            path,
            format!(
                "not written: {bad} of {} weights are NaN or infinite (the first at {i}); the optimisation diverged",
                weights.len()
            ),
        ));
    }
    let header = serde_json::to_vec(header).map_err(|e| Error::invalid(e.to_string()))?;
    let mut out = Vec::with_capacity(16 + header.len() + 4 * weights.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(header.len() as u64).to_le_bytes());
    out.extend_from_slice(&header);
    for v in weights {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(avatar_core::io::write_bytes_atomic(path, &out)?)
}

/// Read a file written by [`write`] from disk.
pub fn read<H: DeserializeOwned>(path: &Path) -> Result<(H, Vec<f32>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse(&bytes, path)
}

/// Read a weights file whose weight count follows from its header: `expected` checks the header
/// (naming no file: the error is attributed here) and returns the count, which is compared with
/// the file's size before the weights are read, so a corrupt header never allocates.
pub fn read_expecting<H: DeserializeOwned>(
    path: &Path,
    expected: impl FnOnce(&H) -> Result<usize>,
) -> Result<(H, Vec<f32>)> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let size = f.metadata().map_err(|e| Error::io(path, e))?.len();
    let len = header_len(&mut f, path)?;
    let mut header = vec![0u8; len as usize];
    f.read_exact(&mut header).map_err(|_| Error::file(path, "truncated file (header)"))?;
    let header: H = serde_json::from_slice(&header)
        .map_err(|e| Error::file(path, format!("bad header: {e}")))?;
    let n = expected(&header).map_err(|e| e.in_file(path))?;
    let have = size - 16 - len;
    if have != 4 * n as u64 {
        return Err(Error::file(
            path,
            format!(
                "truncated or padded file: {have} bytes of weights, its header needs {n} weights ({} bytes)",
                4 * n as u64
            ),
        ));
    }
    let mut bytes = vec![0u8; have as usize];
    f.read_exact(&mut bytes).map_err(|e| Error::io(path, e))?;
    let weights: Vec<f32> =
        bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect();
    if weights.iter().any(|v| !v.is_finite()) {
        return Err(Error::file(path, "weights contain NaN or infinity"));
    }
    Ok((header, weights))
}

/// The magic and the header length (bounded, and within the file).
fn header_len(f: &mut std::fs::File, path: &Path) -> Result<u64> {
    use std::io::Read;
    let size = f.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut head = [0u8; 16];
    f.read_exact(&mut head).map_err(|_| Error::file(path, "not an Avatar Studio weights file"))?;
    if &head[..8] != MAGIC {
        return Err(Error::file(path, "not an Avatar Studio weights file"));
    }
    let len = u64::from_le_bytes(head[8..16].try_into().expect("8 bytes"));
    if len > MAX_HEADER_BYTES || 16 + len > size {
        return Err(Error::file(path, "bad header length (truncated or corrupt file)"));
    }
    Ok(len)
}

/// Parse the bytes of a weights file (`origin` names it in errors). The header is read
/// first; `weights` are checked for length by the caller (it knows the network) and for NaN here.
pub fn parse<H: DeserializeOwned>(bytes: &[u8], origin: &Path) -> Result<(H, Vec<f32>)> {
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        return Err(Error::file(origin, "not an Avatar Studio weights file"));
    }
    let len = u64::from_le_bytes(bytes[8..16].try_into().expect("8 bytes")) as usize;
    let body = 16usize
        .checked_add(len)
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| Error::file(origin, "truncated file (header)"))?;
    let header: H = serde_json::from_slice(&bytes[16..body])
        .map_err(|e| Error::file(origin, format!("bad header: {e}")))?;
    if !(bytes.len() - body).is_multiple_of(4) {
        return Err(Error::file(origin, "truncated file (weights)"));
    }
    let weights: Vec<f32> = bytes[body..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect();
    if weights.iter().any(|v| !v.is_finite()) {
        return Err(Error::file(origin, "weights contain NaN or infinity"));
    }
    Ok((header, weights))
}

/// Read only the JSON header's `format`, `version` and `kind` fields, to route a file to its
/// loader with a clear message.
#[derive(Debug, Clone, serde::Deserialize)]
pub struct Identity {
    pub format: String,
    pub version: u32,
    pub kind: String,
}

pub fn identity(path: &Path) -> Result<Identity> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let len = header_len(&mut f, path)?;
    let mut header = vec![0u8; len as usize];
    f.read_exact(&mut header).map_err(|_| Error::file(path, "truncated file (header)"))?;
    serde_json::from_slice(&header).map_err(|e| Error::file(path, format!("bad header: {e}")))
}
