//! Opening a motion clip: a clip file (`.json`, AMASS `.npz`, BVH `.bvh`) or, by name, a clip of
//! the library. Every command, the evaluation and the studio's timeline open clips through here.

use super::clip::MotionClip;
use super::library::{clip_by_name, clip_names};
use crate::error::{Error, Result};
use std::path::Path;

impl MotionClip {
    /// Load a clip: `.json` (this format), an AMASS-style `.npz` or a BVH file (retargeted).
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("json") => {
                let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
                Self::from_json_str(&text).map_err(|e| e.in_file(path))
            }
            Some("npz") => super::amass::load_amass_clip(path)
                .and_then(|c| c.validate().map(|_| c))
                .map_err(|e| e.in_file(path)),
            Some("bvh") => super::retarget::load_bvh_clip(path),
            _ => Err(Error::file(
                path,
                "unknown motion file type: expected .json (avatar-studio motion), .npz (AMASS) or .bvh (motion capture)",
            )),
        }
    }
}

/// A library clip by name (the error lists the library).
pub fn library_clip(name: &str) -> Result<MotionClip> {
    clip_by_name(name).ok_or_else(|| {
        Error::invalid(format!(
            "unknown motion clip {name:?}: the library has {}",
            clip_names().join(", ")
        ))
    })
}

/// The clip a `--motion` argument names: a library clip, else a clip file.
pub fn open_clip(name_or_file: &str) -> Result<MotionClip> {
    if let Some(c) = clip_by_name(name_or_file) {
        return Ok(c);
    }
    let path = Path::new(name_or_file);
    if !path.exists() {
        return Err(Error::invalid(format!(
            "unknown motion clip {name_or_file:?}: not a file, and the library has {}",
            clip_names().join(", ")
        )));
    }
    MotionClip::load(path)
}

/// The clip file a `--motion` argument names (None for a library clip): an input to guard.
pub fn clip_file(name_or_file: &str) -> Option<&Path> {
    clip_by_name(name_or_file).is_none().then_some(Path::new(name_or_file))
}

/// The clip a `--motion` argument names, resampled to `fps` (`export` and `pose`; see
/// [`MotionClip::resample`]). Errors name the file and the limit.
pub fn open_clip_at(name_or_file: &str, fps: f32) -> Result<MotionClip> {
    let clip = open_clip(name_or_file)?;
    clip.resample(fps).map_err(|e| match clip_file(name_or_file) {
        Some(path) => e.in_file(path),
        None => e,
    })
}
