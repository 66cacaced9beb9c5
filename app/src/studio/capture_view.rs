//! A capture as the studio shows it: every frame of the manifest with its fitting; depth
//! thumbnails, points and each frame's check read on demand (`capture_frames`), so a long
//! depth video opens in seconds and holds a bounded amount. Opened off the UI thread.

use crate::studio::capture_frames::{FrameRead, read_frames};
pub use crate::studio::capture_frames::{FrameView, THUMBNAIL_SIZE, depth_thumbnail};
use avatar_core::body::BodyModel;
use avatar_core::capture::{CaptureManifest, CaptureOptions, CaptureSource};
use std::path::Path;
use std::sync::Arc;

/// Frames read (checked, with thumbnails) when a capture opens: all of a short capture, the
/// first screenfuls of a long one; the others are read as they are shown.
pub const FRAMES_READ_AT_OPEN: usize = 48;

pub struct LoadedCapture {
    pub dir: std::path::PathBuf,
    pub name: String,
    pub manifest: CaptureManifest,
    pub body: Arc<BodyModel>,
    pub betas: Vec<f32>,
    pub frames: Vec<FrameView>,
    pub fps: f32,
    /// Where the frames are read from on demand.
    pub source: Arc<CaptureSource>,
    /// The frames read when it opened (the first usable one with its points), taken by the
    /// studio's frame store.
    pub first_reads: Vec<FrameRead>,
    /// The first usable frame.
    pub first_usable: usize,
}

/// Open a capture folder (or its capture.json) for the studio: the manifest and body model,
/// the first [`FRAMES_READ_AT_OPEN`] frames checked with their thumbnails, and frames after
/// those checked until one is usable (a capture with none is an error naming the file).
pub fn load_capture(path: &Path) -> crate::error::Result<LoadedCapture> {
    let source = CaptureSource::open(path, &CaptureOptions::default())?;
    let dir = source.dir.clone();
    let manifest = source.manifest.clone();
    let frames: Vec<FrameView> = manifest
        .frames
        .iter()
        .enumerate()
        .map(|(i, rec)| FrameView {
            index: i,
            file: dir.join(&rec.depth),
            params: rec.params().ok(),
        })
        .collect();
    let n = frames.len();
    let mut first_reads = Vec::new();
    let mut first_usable = None;
    let mut start = 0;
    while first_usable.is_none() && start < n {
        let chunk = if start == 0 { FRAMES_READ_AT_OPEN } else { FRAMES_READ_AT_OPEN * 4 };
        let indices: Vec<usize> = (start..(start + chunk).min(n)).collect();
        let mut reads = read_frames(&source, &indices, false, start == 0)?;
        if let Some(r) = reads.iter().find(|r| r.verdict.is_ok()) {
            first_usable = Some(r.index);
        }
        if start > 0 {
            // Past the first screenfuls only the verdicts are kept.
            reads.iter_mut().for_each(|r| r.thumbnail = None);
        }
        first_reads.extend(reads);
        start += chunk;
    }
    let Some(first_usable) = first_usable else {
        let warnings: Vec<_> = first_reads
            .iter()
            .filter_map(|r| {
                r.verdict.as_ref().err().map(|reason| avatar_core::capture::FrameError {
                    index: r.index,
                    file: frames[r.index].file.clone(),
                    reason: reason.clone(),
                })
            })
            .collect();
        return Err(source.no_usable_frame(&warnings).into());
    };
    // The frame shown first, with its points.
    let shown = read_frames(&source, &[first_usable], true, false)?;
    if let (Some(read), Some(slot)) =
        (shown.into_iter().next(), first_reads.iter_mut().find(|r| r.index == first_usable))
    {
        slot.points = read.points;
    }
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    let betas = frames[first_usable].params.as_ref().map(|p| p.betas.clone()).unwrap_or_default();
    let fps = manifest.fps.filter(|f| f.is_finite() && *f > 0.0).unwrap_or(30.0);
    Ok(LoadedCapture {
        dir,
        name,
        manifest,
        body: source.body.clone(),
        betas,
        frames,
        fps,
        source: Arc::new(source),
        first_reads,
        first_usable,
    })
}
