//! Running a protocol end to end: held-out synthetic subjects and outfits generated from seeds,
//! every row fine-tuned on the protocol's frames and scored on its evaluation frames; a JSON
//! report and a Markdown table like the paper's Tables 1 and 3.

use super::dataset::*;
use super::metrics::{clothed_mask, evaluate_frame, FrameMetrics, MetricOptions, Summary};
use super::predictor::{FitData, Predictor};
use super::protocol::{heldout_frames, interpolation_frames, training_selection, Protocol};
use crate::body::{BodyModel, BodyParams};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::motion::{clip_by_name, MotionClip};
use crate::synth::{canonical_surface, generate_capture, pose_surface, subject_betas, ClothedTemplate, Outfit, PoseFeatures, SynthJob};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, Clone)]
pub struct EvalConfig {
    pub protocols: Vec<Protocol>,
    pub subjects: Vec<u64>,
    pub outfits: Vec<Outfit>,
    pub finetune_clips: Vec<String>,
    pub eval_clips: Vec<String>,
    /// Evaluate every n-th frame of the held-out clips.
    pub heldout_stride: usize,
    pub metrics: MetricOptions,
    /// Add the ground truth scored against itself (a sanity row: Dp = Df = 0, NC = 1).
    pub ground_truth_row: bool,
    /// Where fine-tuning captures are written (removed afterwards).
    pub workdir: PathBuf,
    pub seed: u64,
}

impl EvalConfig {
    pub fn paper(protocols: Vec<Protocol>) -> Self {
        EvalConfig {
            protocols,
            subjects: EVAL_SUBJECT_SEEDS.to_vec(),
            outfits: EVAL_OUTFITS.to_vec(),
            finetune_clips: FINETUNE_CLIPS.iter().map(|s| s.to_string()).collect(),
            eval_clips: EVAL_CLIPS.iter().map(|s| s.to_string()).collect(),
            heldout_stride: 5,
            metrics: MetricOptions::default(),
            ground_truth_row: true,
            workdir: std::env::temp_dir().join(format!("avatar-studio-eval-{}", std::process::id())),
            seed: 0,
        }
    }
}

/// One cell of the table: a method under a protocol, over all subjects, outfits and frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RowResult {
    pub method: String,
    pub protocol: String,
    pub training_frames: usize,
    pub evaluated_frames: usize,
    pub dp_cm: Summary,
    pub df_cm: Summary,
    pub nc: Summary,
    pub iou: Summary,
    pub chamfer_cm: Summary,
    pub seconds: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    pub subjects: Vec<u64>,
    pub outfits: Vec<String>,
    pub finetune_clips: Vec<String>,
    pub eval_clips: Vec<String>,
    pub seed: u64,
    pub rows: Vec<RowResult>,
}

fn clip(name: &str) -> Result<MotionClip> {
    clip_by_name(name).ok_or_else(|| Error::invalid(format!("unknown motion clip {name:?}")))
}

/// The query pose of a clip frame for a subject: the subject's shape, horizontal drift removed
/// (as in the synthetic captures), facing the camera.
fn query(p: &BodyParams, betas: &[f32]) -> BodyParams {
    let mut q = p.clone();
    q.betas = betas.to_vec();
    q.trans.x = 0.0;
    q.trans.z = 0.0;
    q
}

/// The ground-truth clothed mesh of one pose.
pub fn ground_truth_mesh(body: &BodyModel, template: &ClothedTemplate, params: &BodyParams, subject: u64) -> TriMesh {
    let bones = body.pose(params).bones;
    let canonical = canonical_surface(template, &PoseFeatures::of(&bones), subject);
    TriMesh::new(pose_surface(template, &canonical, &bones), template.faces.clone())
}

struct Accum {
    training_frames: usize,
    metrics: Vec<FrameMetrics>,
    seconds: f64,
}

pub fn run(body: &BodyModel, config: &EvalConfig, predictors: &mut [Box<dyn Predictor>], progress: &dyn Fn(&str)) -> Result<Report> {
    let finetune: Vec<MotionClip> = config.finetune_clips.iter().map(|c| clip(c)).collect::<Result<_>>()?;
    let heldout: Vec<MotionClip> = config.eval_clips.iter().map(|c| clip(c)).collect::<Result<_>>()?;
    let lengths: Vec<usize> = finetune.iter().map(|c| c.len()).collect();
    let methods = predictors.len() + config.ground_truth_row as usize;
    let mut acc: Vec<Vec<Accum>> = (0..methods).map(|_| config.protocols.iter().map(|_| Accum { training_frames: 0, metrics: Vec::new(), seconds: 0.0 }).collect()).collect();
    for &subject in &config.subjects {
        let betas = subject_betas(body, subject);
        for &outfit in &config.outfits {
            let template = ClothedTemplate::build(body, &betas, outfit);
            let mask = clothed_mask(&template.vertex_joint, None)?;
            for (pi, protocol) in config.protocols.iter().enumerate() {
                progress(&format!("subject {subject}, {}, {}", outfit.name(), protocol.label()));
                let train = training_selection(protocol, &lengths);
                let eval_poses: Vec<BodyParams> = if protocol.evaluates_heldout() {
                    heldout.iter().flat_map(|c| heldout_frames(c.len(), config.heldout_stride).into_iter().map(move |f| c.frames[f].clone())).collect()
                } else {
                    finetune.iter().flat_map(|c| interpolation_frames(c.len()).into_iter().map(move |f| c.frames[f].clone())).collect()
                };
                let eval_poses: Vec<BodyParams> = eval_poses.iter().map(|p| query(p, &betas)).collect();
                let gts: Vec<TriMesh> = eval_poses.par_iter().map(|p| ground_truth_mesh(body, &template, p, subject)).collect();
                // The fine-tuning capture: the selected frames, rendered with the turn protocol.
                let capture_dir = config.workdir.join(format!("s{subject}_{}_{pi}", outfit.name()));
                if predictors.iter().any(|p| p.needs_capture()) {
                    let frames: Vec<BodyParams> = train.iter().map(|&(c, f)| finetune[c].frames[f].clone()).collect();
                    let mut job = SynthJob::new(subject, outfit, MotionClip::new("finetune", finetune[0].fps, frames));
                    job.noise_seed = config.seed;
                    job.write_ground_truth = false;
                    generate_capture(&capture_dir, body, &job)?;
                }
                for (m, predictor) in predictors.iter_mut().enumerate() {
                    let t = Instant::now();
                    predictor.fit(&FitData { capture_dir: &capture_dir, body, betas: &betas, outfit })?;
                    let predictor: &dyn Predictor = &**predictor;
                    let scores: Vec<FrameMetrics> = eval_poses
                        .par_iter()
                        .zip(gts.par_iter())
                        .enumerate()
                        .map(|(k, (p, gt))| evaluate_frame(&predictor.predict(p)?, gt, &mask, &config.metrics, config.seed + k as u64))
                        .collect::<Result<_>>()?;
                    let a = &mut acc[m][pi];
                    a.training_frames = train.len();
                    a.metrics.extend(scores);
                    a.seconds += t.elapsed().as_secs_f64();
                }
                if config.ground_truth_row {
                    let t = Instant::now();
                    let scores: Vec<FrameMetrics> =
                        gts.par_iter().enumerate().map(|(k, gt)| evaluate_frame(gt, gt, &mask, &config.metrics, config.seed + k as u64)).collect::<Result<_>>()?;
                    let a = &mut acc[predictors.len()][pi];
                    a.training_frames = 0;
                    a.metrics.extend(scores);
                    a.seconds += t.elapsed().as_secs_f64();
                }
                let _ = std::fs::remove_dir_all(&capture_dir);
            }
        }
    }
    let mut names: Vec<String> = predictors.iter().map(|p| p.name()).collect();
    if config.ground_truth_row {
        names.push("ground truth (sanity)".into());
    }
    let mut rows = Vec::new();
    for (m, name) in names.iter().enumerate() {
        for (pi, protocol) in config.protocols.iter().enumerate() {
            let a = &acc[m][pi];
            let s = |f: fn(&FrameMetrics) -> f32| Summary::of(&a.metrics.iter().map(f).collect::<Vec<_>>()).ok_or_else(|| Error::invalid("no frames evaluated"));
            rows.push(RowResult {
                method: name.clone(),
                protocol: protocol.label(),
                training_frames: a.training_frames,
                evaluated_frames: a.metrics.len(),
                dp_cm: s(|m| m.dp_cm)?,
                df_cm: s(|m| m.df_cm)?,
                nc: s(|m| m.nc)?,
                iou: s(|m| m.iou)?,
                chamfer_cm: s(|m| m.chamfer_cm)?,
                seconds: a.seconds,
            });
        }
    }
    let _ = std::fs::remove_dir_all(&config.workdir);
    Ok(Report {
        subjects: config.subjects.clone(),
        outfits: config.outfits.iter().map(|o| o.name().to_string()).collect(),
        finetune_clips: config.finetune_clips.clone(),
        eval_clips: config.eval_clips.clone(),
        seed: config.seed,
        rows,
    })
}

impl Report {
    /// A Markdown table like the paper's: mean over frames (Dp, Df, Chamfer in cm).
    pub fn markdown(&self) -> String {
        let mut s = format!(
            "Subjects {:?}, outfits {}, fine-tuning clips {}, evaluation clips {}, seed {}.\n\n",
            self.subjects,
            self.outfits.join(", "),
            self.finetune_clips.join(", "),
            self.eval_clips.join(", "),
            self.seed
        );
        s += "| method | protocol | training frames | evaluated frames | Dp (cm) | Df (cm) | NC | IoU | Chamfer-L2 (cm) |\n";
        s += "|---|---|---|---|---|---|---|---|---|\n";
        for r in &self.rows {
            s += &format!(
                "| {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |\n",
                r.method, r.protocol, r.training_frames, r.evaluated_frames, r.dp_cm.mean, r.df_cm.mean, r.nc.mean, r.iou.mean, r.chamfer_cm.mean
            );
        }
        s
    }

    pub fn save_json(&self, path: impl AsRef<std::path::Path>) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::write_bytes_atomic(path, text.as_bytes())
    }
}

/// The bench section: one evaluation of a 250-frame held-out sequence (the held-out clips
/// back to back), the naked body scored against the clothed ground truth with the default
/// metric settings.
pub fn bench_report() -> String {
    let body = crate::body::open_body_ref();
    let mut out = String::from("## eval\n\n| what | time | note |\n|---|---|---|\n");
    let betas = subject_betas(body, EVAL_SUBJECT_SEEDS[0]);
    let template = ClothedTemplate::build(body, &betas, UNSEEN_OUTFIT);
    let mut poses: Vec<BodyParams> = EVAL_CLIPS.iter().filter_map(|c| clip_by_name(c)).flat_map(|c| c.frames).collect();
    while poses.len() < 250 {
        poses.extend(poses.clone());
    }
    poses.truncate(250);
    let Ok(mask) = clothed_mask(&template.vertex_joint, None) else { return out };
    let naked = super::predictor::NakedBody::new(body.clone());
    let t = Instant::now();
    let scores: Result<Vec<FrameMetrics>> = poses
        .par_iter()
        .enumerate()
        .map(|(k, p)| {
            let q = query(p, &betas);
            let gt = ground_truth_mesh(body, &template, &q, 1);
            evaluate_frame(&naked.predict(&q)?, &gt, &mask, &MetricOptions::default(), k as u64)
        })
        .collect();
    let secs = t.elapsed().as_secs_f64();
    match scores {
        Ok(s) => {
            out += &format!(
                "| evaluate a 250-frame held-out sequence ({} ground-truth vertices, {} scored; Dp, Df, NC, IoU at 128, Chamfer 10k) | {secs:.1} s | target < 60 s on 2 cores; naked-body Df {:.2} cm |\n",
                template.vertices.len(),
                mask.iter().filter(|&&m| m).count(),
                s.iter().map(|m| m.df_cm).sum::<f32>() / s.len() as f32
            )
        }
        Err(e) => out += &format!("| evaluation failed | | {e} |\n"),
    }
    out
}
