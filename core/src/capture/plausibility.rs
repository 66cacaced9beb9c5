//! Plausibility of a capture: why most frames have no depth near the fitted body (`units`),
//! and refusing a fit with fewer usable frames than asked, naming the frames. See
//! docs/capture-format.md.

use super::manifest::MANIFEST_FILE;
use super::open::Capture;
use crate::error::{Error, Result};

impl Capture {
    /// Why most frames have no depth near the fitted body, in one line; `None` when most
    /// frames are fine.
    pub fn diagnose(&self) -> Option<String> {
        super::units::diagnose(
            &self.dir,
            &self.manifest,
            &self.body,
            &self.warnings,
            self.frames.len() + self.warnings.len(),
        )
    }
}

/// Refuse a fit that would use fewer frames than asked: `usable` are the frames it would use,
/// `later` frames skipped after opening (too few canonical points), with the reason. The
/// capture having fewer frames than asked is fine; losing frames to errors is not, unless the
/// caller asks for no more than the usable ones.
pub fn require_usable_frames(
    capture: &Capture,
    asked: usize,
    usable: &[usize],
    later: &[(usize, String)],
) -> Result<()> {
    let needed = asked.min(capture.manifest.frames.len());
    if usable.len() >= needed {
        return Ok(());
    }
    let mut skipped: Vec<(usize, String)> =
        capture.warnings.iter().map(|w| (w.index, w.to_string())).collect();
    skipped.extend(later.iter().map(|(i, r)| (*i, format!("frame {i}: {r}"))));
    skipped.sort_by_key(|s| s.0);
    let shown: Vec<&str> = skipped.iter().take(6).map(|s| s.1.as_str()).collect();
    let more = if skipped.len() > shown.len() {
        format!("; and {} more", skipped.len() - shown.len())
    } else {
        String::new()
    };
    let list: Vec<String> = usable.iter().map(|i| i.to_string()).collect();
    let why = capture.diagnose().map(|d| format!(" {d}.")).unwrap_or_default();
    Err(Error::file(
        capture.dir.join(MANIFEST_FILE),
        format!(
            "only {} usable frame{} ({}) of the {needed} asked.{why} Skipped: {}{more}. To fit from the usable frames alone, ask for {} (fit --frames {})",
            usable.len(),
            if usable.len() == 1 { "" } else { "s" },
            if list.is_empty() { "none".into() } else { format!("frame {}", list.join(", ")) },
            shown.join("; "),
            usable.len(),
            usable.len().max(1)
        ),
    ))
}
