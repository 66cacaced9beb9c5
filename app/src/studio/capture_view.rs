//! A capture as the studio shows it: every frame of the manifest with a depth thumbnail, its
//! back-projected points and fitting, or the reason it was skipped. Loaded off the UI thread.

use avatar_core::body::{BodyModel, BodyParams};
use avatar_core::capture::{Capture, CaptureManifest, read_depth_png};
use eframe::egui;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub const THUMBNAIL_SIZE: usize = 72;

/// One frame of the manifest.
pub struct FrameView {
    pub index: usize,
    pub file: PathBuf,
    /// The depth image as a small colour image (None when it could not be read).
    pub thumbnail: Option<egui::ColorImage>,
    /// Why the frame is not used (None = usable).
    pub problem: Option<String>,
    /// World-space points of the person (empty for flagged frames).
    pub points: Vec<Vec3>,
    /// Unit normals of the points (facing the camera).
    pub normals: Vec<Vec3>,
    pub params: Option<BodyParams>,
}

pub struct LoadedCapture {
    pub dir: PathBuf,
    pub name: String,
    pub manifest: CaptureManifest,
    pub body: Arc<BodyModel>,
    pub betas: Vec<f32>,
    pub frames: Vec<FrameView>,
    pub fps: f32,
}

impl LoadedCapture {
    pub fn usable(&self) -> usize {
        self.frames.iter().filter(|f| f.problem.is_none()).count()
    }

    pub fn flagged(&self) -> usize {
        self.frames.len() - self.usable()
    }

    pub fn first_usable(&self) -> Option<usize> {
        self.frames.iter().position(|f| f.problem.is_none())
    }
}

/// Open a capture folder (or its capture.json) for the studio.
pub fn load_capture(path: &Path) -> crate::error::Result<LoadedCapture> {
    let capture = Capture::open(path)?;
    let dir = capture.dir.clone();
    let manifest = capture.manifest.clone();
    let mut frames: Vec<FrameView> = manifest
        .frames
        .iter()
        .enumerate()
        .map(|(i, rec)| FrameView {
            index: i,
            file: dir.join(&rec.depth),
            thumbnail: None,
            problem: None,
            points: Vec::new(),
            normals: Vec::new(),
            params: None,
        })
        .collect();
    for w in &capture.warnings {
        if let Some(f) = frames.get_mut(w.index) {
            f.problem = Some(w.reason.clone());
        }
    }
    for f in &capture.frames {
        if let Some(v) = frames.get_mut(f.index) {
            v.points = f.points.clone();
            v.normals = f.normals.clone();
            v.params = Some(f.params.clone());
        }
    }
    {
        use rayon::prelude::*;
        let scale = manifest.depth_scale;
        frames.par_iter_mut().for_each(|f| {
            f.thumbnail = read_depth_png(&f.file, scale)
                .ok()
                .map(|d| depth_thumbnail(&d.metres, d.width as usize, d.height as usize))
        });
    }
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    let betas = capture.frames[0].params.betas.clone();
    let fps = manifest.fps.filter(|f| f.is_finite() && *f > 0.0).unwrap_or(30.0);
    Ok(LoadedCapture { dir, name, manifest, body: capture.body.clone(), betas, frames, fps })
}

/// A depth image as a thumbnail: near = warm and bright, far = cool and dark, no depth = black.
pub fn depth_thumbnail(metres: &[f32], width: usize, height: usize) -> egui::ColorImage {
    let valid: Vec<f32> = metres.iter().copied().filter(|z| *z > 0.0 && z.is_finite()).collect();
    let (lo, hi) =
        valid.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &z| (lo.min(z), hi.max(z)));
    let side = width.max(height).max(1);
    let scale = THUMBNAIL_SIZE as f32 / side as f32;
    let (w, h) = (
        ((width as f32 * scale).round() as usize).max(1),
        ((height as f32 * scale).round() as usize).max(1),
    );
    let mut pixels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            // Nearest valid sample of the block the thumbnail pixel covers.
            let (u0, v0) = ((x as f32 / scale) as usize, (y as f32 / scale) as usize);
            let (u1, v1) = (
                (((x + 1) as f32 / scale) as usize).min(width),
                (((y + 1) as f32 / scale) as usize).min(height),
            );
            let mut z = 0.0f32;
            'outer: for v in v0..v1.max(v0 + 1).min(height) {
                for u in u0..u1.max(u0 + 1).min(width) {
                    let d = metres[v * width + u];
                    if d > 0.0 && d.is_finite() {
                        z = d;
                        break 'outer;
                    }
                }
            }
            pixels.push(if z > 0.0 {
                let t = if hi > lo { ((z - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
                ramp(1.0 - t)
            } else {
                egui::Color32::from_rgb(12, 13, 16)
            });
        }
    }
    egui::ColorImage::new([w, h], pixels)
}

/// A perceptual-ish ramp from deep blue (0) through teal to warm white (1).
fn ramp(t: f32) -> egui::Color32 {
    let stops = [
        [20.0, 30.0, 70.0],
        [30.0, 110.0, 150.0],
        [90.0, 190.0, 170.0],
        [240.0, 220.0, 150.0],
        [255.0, 250.0, 235.0],
    ];
    let x = t.clamp(0.0, 1.0) * (stops.len() - 1) as f32;
    let i = (x.floor() as usize).min(stops.len() - 2);
    let f = x - i as f32;
    let c: Vec<u8> =
        (0..3).map(|k| (stops[i][k] + (stops[i + 1][k] - stops[i][k]) * f) as u8).collect();
    egui::Color32::from_rgb(c[0], c[1], c[2])
}
