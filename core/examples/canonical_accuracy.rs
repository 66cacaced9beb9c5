//! The canonicalization accuracy table of docs/canonicalization.md: per outfit, a noiseless
//! synthetic capture (8 frames of `walk`, subject 101) is canonicalized point by point and each
//! point compared with its true canonical position.
//!
//! cargo run --release -p avatar-core --example canonical_accuracy

use avatar_core::body::BodyModel;
use avatar_core::canonical::{Canonicalizer, FieldOptions};
use avatar_core::capture::Capture;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::motion::clip_by_name;
use avatar_core::synth::{ALL_OUTFITS, GroundTruth, Outfit, SynthJob, generate_capture};
use std::path::Path;
use std::time::Instant;

struct AccuracyRow {
    points: usize,
    median_mm: f32,
    p90_mm: f32,
    dropped_fraction: f32,
    unsolved_fraction: f32,
    seconds: f64,
}

/// Generate the capture of `outfit` in `dir` (removed afterwards), canonicalize every depth
/// point and compare with its true canonical position.
fn accuracy(
    dir: &Path,
    body: &BodyModel,
    outfit: Outfit,
    frames: usize,
    seed: u64,
) -> avatar_core::Result<AccuracyRow> {
    let mut job = SynthJob::new(seed, outfit, clip_by_name("walk").expect("a library clip"));
    job.frames = Some(frames);
    generate_capture(dir, body, &job)?;
    let capture = Capture::open(dir)?;
    let gt = GroundTruth::load(dir)?;
    let _ = std::fs::remove_dir_all(dir);
    let betas = &capture.frames[0].params.betas;
    let canon = Canonicalizer::new(body, betas, &FieldOptions::default(), None)?;
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
        let i = ((errors.len() as f32 * q) as usize).min(errors.len().saturating_sub(1));
        errors.get(i).copied().unwrap_or(f32::NAN)
    };
    Ok(AccuracyRow {
        points: total,
        median_mm: at(0.5),
        p90_mm: at(0.9),
        dropped_fraction: dropped as f32 / total.max(1) as f32,
        unsolved_fraction: unsolved as f32 / total.max(1) as f32,
        seconds,
    })
}

fn main() {
    let body = avatar_core::body::open_body_ref();
    let work = std::env::temp_dir().join(format!("canonical-accuracy-{}", std::process::id()));
    println!(
        "| outfit | loose | points | median error (mm) | 90th pct (mm) | dropped by the 2 cm filter | no root | seconds |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for outfit in ALL_OUTFITS {
        let r =
            accuracy(&work.join(outfit.name()), body, outfit, 8, 101).expect("synthetic capture");
        println!(
            "| {} | {} | {} | {:.2} | {:.2} | {:.2}% | {:.2}% | {:.2} |",
            outfit.name(),
            if outfit.is_loose() { "yes" } else { "no" },
            r.points,
            r.median_mm,
            r.p90_mm,
            r.dropped_fraction * 100.0,
            r.unsolved_fraction * 100.0,
            r.seconds
        );
    }
    let _ = std::fs::remove_dir_all(&work);
}
