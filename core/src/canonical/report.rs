//! Accuracy and speed of canonicalization on synthetic captures with ground truth (the table
//! in docs/canonicalization.md and the `canonical` bench section).

use super::{Canonicalizer, FieldOptions};
use crate::body::BodyModel;
use crate::capture::Capture;
use crate::error::Result;
use crate::mesh::bvh::Bvh;
use crate::motion::clip_by_name;
use crate::synth::{GroundTruth, Outfit, SynthJob, generate_capture};
use std::time::Instant;

#[derive(Debug, Clone, PartialEq)]
pub struct AccuracyRow {
    pub outfit: Outfit,
    pub points: usize,
    pub median_mm: f32,
    pub p90_mm: f32,
    pub dropped_fraction: f32,
    pub unsolved_fraction: f32,
    pub seconds: f64,
}

/// Generate a noiseless synthetic capture of `outfit` (subject `seed`, `frames` frames of
/// `clip`), canonicalize every depth point and compare with its true canonical position.
pub fn accuracy(
    body: &BodyModel,
    outfit: Outfit,
    clip: &str,
    frames: usize,
    seed: u64,
    field: &FieldOptions,
) -> Result<AccuracyRow> {
    let dir = std::env::temp_dir().join(format!(
        "avatar-studio-canon-{}-{}-{seed}",
        std::process::id(),
        outfit.name()
    ));
    let mut job = SynthJob::new(
        seed,
        outfit,
        clip_by_name(clip).ok_or_else(|| crate::Error::invalid(format!("no clip {clip}")))?,
    );
    job.frames = Some(frames);
    generate_capture(&dir, body, &job)?;
    let capture = Capture::open(&dir)?;
    let gt = GroundTruth::load(&dir)?;
    let _ = std::fs::remove_dir_all(&dir);
    let canon = Canonicalizer::new(body, &capture.frames[0].params.betas, field, None)?;
    let t = Instant::now();
    let canonical: Vec<_> = capture.frames.iter().map(|f| canon.frame(f)).collect();
    let seconds = t.elapsed().as_secs_f64();
    let mut errors = Vec::new();
    let (mut total, mut dropped, mut unsolved) = (0, 0, 0);
    for (f, c) in capture.frames.iter().zip(&canonical) {
        let bvh = Bvh::build(&gt.posed_mesh(f.index));
        for (k, &src) in c.source.iter().enumerate() {
            if let Some(truth) = gt.canonical_of_posed_point(f.index, &bvh, f.points[src]) {
                errors.push((c.points[k] - truth).length() * 1000.0);
            }
        }
        total += c.input_len();
        dropped += c.dropped;
        unsolved += c.unsolved;
    }
    errors.sort_by(f32::total_cmp);
    let at = |q: f32| {
        errors
            .get(((errors.len() as f32 * q) as usize).min(errors.len().saturating_sub(1)))
            .copied()
            .unwrap_or(f32::NAN)
    };
    Ok(AccuracyRow {
        outfit,
        points: total,
        median_mm: at(0.5),
        p90_mm: at(0.9),
        dropped_fraction: dropped as f32 / total.max(1) as f32,
        unsolved_fraction: unsolved as f32 / total.max(1) as f32,
        seconds,
    })
}
