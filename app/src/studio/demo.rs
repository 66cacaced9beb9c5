//! The embedded demo capture, written once to the cache folder (a capture is a folder).

use std::path::PathBuf;

include!(concat!(env!("OUT_DIR"), "/demo_files.rs"));

/// A short fingerprint of the embedded files (FNV-1a over names and bytes).
fn fingerprint() -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for (name, bytes) in DEMO_FILES {
        for b in name.as_bytes().iter().chain(bytes.iter()) {
            h ^= *b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    }
    h
}

/// The studio's cache folder: `$XDG_CACHE_HOME/avatar-studio` or `~/.cache/avatar-studio`,
/// else the temporary folder.
pub fn cache_dir() -> PathBuf {
    crate::cache::cache_dir().unwrap_or_else(|| std::env::temp_dir().join("avatar-studio"))
}

/// The demo capture folder, written (atomically, file by file) if missing.
pub fn demo_capture_dir() -> crate::error::Result<PathBuf> {
    let dir = cache_dir().join(format!("demo-{:016x}", fingerprint()));
    for (name, bytes) in DEMO_FILES {
        let path = dir.join(name);
        if std::fs::metadata(&path).map(|m| m.len() == bytes.len() as u64).unwrap_or(false) {
            continue;
        }
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| crate::error::StudioError::io(parent, e))?;
        }
        avatar_core::io::write_bytes_atomic(&path, bytes)?;
    }
    Ok(dir)
}

/// Whether `dir` is the demo capture.
pub fn is_demo(dir: &std::path::Path) -> bool {
    dir.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("demo-"))
        && dir.parent() == Some(cache_dir().as_path())
}
