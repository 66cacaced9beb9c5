//! AMASS-style `.npz` motion files as clips, through the capture module's AMASS reader.

use super::clip::MotionClip;
use crate::error::Result;
use std::path::Path;

/// Load an AMASS-style npz as a clip (name = file stem). The sequence is turned from AMASS's
/// Z-up world into the studio's Y-up world.
pub fn load_amass_clip(path: &Path) -> Result<MotionClip> {
    let mut seq = crate::capture::amass::read_amass(path)?;
    crate::capture::amass::z_up_to_y_up(&mut seq, crate::body::open_body_ref());
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "amass".into());
    Ok(MotionClip::new(name, seq.fps, seq.frames))
}
