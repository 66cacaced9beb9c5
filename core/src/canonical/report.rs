//! Accuracy and speed of canonicalization on synthetic captures with ground truth (the table
//! in docs/canonicalization.md and the `canonical` bench section).

use super::{Canonicalizer, FieldOptions};
use crate::body::BodyModel;
use crate::capture::Capture;
use crate::error::Result;
use crate::mesh::bvh::Bvh;
use crate::synth::{generate_capture, GroundTruth, Outfit, SynthJob};
use crate::motion::clip_by_name;
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
pub fn accuracy(body: &BodyModel, outfit: Outfit, clip: &str, frames: usize, seed: u64, field: &FieldOptions) -> Result<AccuracyRow> {
    let dir = std::env::temp_dir().join(format!("avatar-studio-canon-{}-{}-{seed}", std::process::id(), outfit.name()));
    let mut job = SynthJob::new(seed, outfit, clip_by_name(clip).ok_or_else(|| crate::Error::invalid(format!("no clip {clip}")))?);
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
    let at = |q: f32| errors.get(((errors.len() as f32 * q) as usize).min(errors.len().saturating_sub(1))).copied().unwrap_or(f32::NAN);
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

/// The bench section: field build time, and canonicalizing 8 frames x 5,000 points.
pub fn bench_report() -> String {
    let body = crate::body::open_body_ref();
    let mut out = String::from("## canonical\n\n| what | time | note |\n|---|---|---|\n");
    let t = Instant::now();
    let canon = match Canonicalizer::new(body, &[], &FieldOptions::default(), None) {
        Ok(c) => c,
        Err(e) => return out + &format!("| build failed | | {e} |\n"),
    };
    out += &format!(
        "| build the diffused skinning field ({}x{}x{} nodes, {:.1} cm cells) | {:.2} s | once per body shape, then cached |\n",
        canon.field.dims[0], canon.field.dims[1], canon.field.dims[2], canon.field.cell * 100.0, t.elapsed().as_secs_f64()
    );
    let dir = std::env::temp_dir().join(format!("avatar-studio-canon-bench-{}", std::process::id()));
    let mut job = SynthJob::new(3, Outfit::LongsleeveTrousers, clip_by_name("walk").expect("library clip"));
    job.frames = Some(8);
    job.write_ground_truth = false;
    let frames = generate_capture(&dir, body, &job).and_then(|_| Capture::open(&dir));
    let _ = std::fs::remove_dir_all(&dir);
    let Ok(mut capture) = frames else { return out + "| synthetic capture failed | | |\n" };
    for f in &mut capture.frames {
        // Exactly 5,000 points a frame, evenly spread.
        let n = f.points.len();
        let keep: Vec<usize> = (0..5000).map(|i| i * n / 5000).collect();
        f.points = keep.iter().map(|&i| f.points[i]).collect();
        f.normals = keep.iter().map(|&i| f.normals[i]).collect();
    }
    let t = Instant::now();
    let results: Vec<_> = capture.frames.iter().map(|f| canon.frame(f)).collect();
    let secs = t.elapsed().as_secs_f64();
    let dropped: usize = results.iter().map(|r| r.dropped + r.unsolved).sum();
    out += &format!(
        "| canonicalize 8 frames x 5,000 points (9 Broyden starts each) | {secs:.2} s | target < 2 s on 2 cores; {dropped} of 40,000 dropped |\n"
    );
    out
}
