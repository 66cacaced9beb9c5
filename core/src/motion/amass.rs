//! AMASS-style `.npz` motion files, read through the capture module's AMASS reader.

use super::clip::MotionClip;
use crate::error::{Error, Result};
use std::path::Path;

/// Load an AMASS-style npz as a clip (name = file stem).
pub fn load_amass_clip(path: &Path) -> Result<MotionClip> {
    Err(Error::file(path, "AMASS .npz clips need the capture module's AMASS reader, which is not in this build yet"))
}
