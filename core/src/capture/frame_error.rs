//! Why a frame of a capture was skipped.

use std::fmt;
use std::path::PathBuf;

/// How the warning of a frame whose depth misses the fitted body begins
/// (`units::diagnose` looks for it).
pub const NO_DEPTH_NEAR_BODY: &str = "no depth point lies within";

/// Why a frame was skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameError {
    pub index: usize,
    pub file: PathBuf,
    pub reason: String,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "frame {} ({}): {}", self.index, self.file.display(), self.reason)
    }
}
