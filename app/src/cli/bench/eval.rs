//! The eval bench section: scoring a 250-frame held-out sequence.

use avatar_core::body::BodyParams;
use avatar_core::error::Result;
use avatar_core::eval::dataset::{EVAL_CLIPS, EVAL_SUBJECT_SEEDS, UNSEEN_OUTFIT};
use avatar_core::eval::metrics::{FrameMetrics, MetricOptions, Regions, evaluate_frame};
use avatar_core::eval::runner::{ground_truth_mesh, query};
use avatar_core::eval::{NakedBody, Predictor};
use avatar_core::motion::clip_by_name;
use avatar_core::synth::{ClothedTemplate, subject_betas};
use rayon::prelude::*;
use std::time::Instant;

/// The bench section: one evaluation of a 250-frame held-out sequence (the held-out clips
/// back to back), the naked body scored against the clothed ground truth with the default
/// metric settings.
pub fn bench_report() -> String {
    let body = avatar_core::body::open_body_ref();
    let mut out = String::from("## eval\n\n| what | time | note |\n|---|---|---|\n");
    let betas = subject_betas(body, EVAL_SUBJECT_SEEDS[0]);
    let template = ClothedTemplate::build(body, &betas, UNSEEN_OUTFIT);
    let mut poses: Vec<BodyParams> =
        EVAL_CLIPS.iter().filter_map(|c| clip_by_name(c)).flat_map(|c| c.frames).collect();
    while poses.len() < 250 {
        poses.extend(poses.clone());
    }
    poses.truncate(250);
    let Ok(regions) = Regions::of_template(&template) else { return out };
    let naked = NakedBody::new(body.clone());
    let t = Instant::now();
    let scores: Result<Vec<FrameMetrics>> = poses
        .par_iter()
        .enumerate()
        .map(|(k, p)| {
            let q = query(p, &betas);
            let gt = ground_truth_mesh(body, &template, &q, 1);
            evaluate_frame(&naked.predict(&q)?, &gt, &regions, &MetricOptions::default(), k as u64)
        })
        .collect();
    let secs = t.elapsed().as_secs_f64();
    match scores {
        Ok(s) => {
            out += &format!(
                "| evaluate a 250-frame held-out sequence ({} ground-truth vertices, {} scored; Dp, Df, NC, IoU at 128, Chamfer 10k) | {secs:.1} s | target < 60 s on 2 cores; naked-body Df {:.2} cm |\n",
                template.vertices.len(),
                regions.scored.iter().filter(|&&m| m).count(),
                s.iter().map(|m| m.df_cm).sum::<f32>() / s.len() as f32
            )
        }
        Err(e) => out += &format!("| evaluation failed | | {e} |\n"),
    }
    out
}
