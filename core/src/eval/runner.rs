//! Running the evaluation end to end: held-out synthetic subjects and outfits generated from
//! seeds; for every setting (capture conditions x protocol) a fine-tuning capture written under
//! its conditions, every row fine-tuned on it and scored at the protocol's evaluation poses;
//! optionally a contact sheet per outfit. The report is in `report`.

use super::conditions::{CaptureConditions, capture_seed};
use super::dataset::*;
use super::metrics::{FrameMetrics, MetricOptions, Regions, Summary, evaluate_frame};
use super::predictor::{FitData, Predictor};
use super::protocol::{Protocol, Shots, heldout_frames, interpolation_frames, training_selection};
use super::report::RowInput;
pub use super::report::{Report, RowResult};
use super::truth::OutfitTruth;
use crate::body::{BodyModel, BodyParams};
use crate::canonical::FieldCache;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::motion::MotionClip;
use crate::synth::cloth::GarmentTrack;
use crate::synth::contact_sheet::write_view_sheet;
use crate::synth::{ALL_OUTFITS, ClothedTemplate, SynthJob, generate_capture, subject_betas};
use glam::Vec3;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, Clone)]
pub struct EvalConfig {
    pub protocols: Vec<Protocol>,
    /// Capture conditions of the fine-tuning captures; each protocol is run under each.
    pub captures: Vec<CaptureConditions>,
    pub subjects: Vec<u64>,
    pub outfits: Vec<crate::synth::Outfit>,
    pub finetune_clips: Vec<String>,
    pub eval_clips: Vec<String>,
    /// Evaluate every n-th frame of the held-out clips.
    pub heldout_stride: usize,
    pub metrics: MetricOptions,
    /// Add the ground truth scored against itself (a sanity row: Dp = Df = 0, NC = 1).
    pub ground_truth_row: bool,
    /// Where fine-tuning captures are written (removed afterwards unless `keep_captures`).
    pub workdir: PathBuf,
    /// Where skinning fields are cached.
    pub field_cache: FieldCache,
    /// Keep the fine-tuning captures in `workdir` (to inspect or fit them by hand).
    pub keep_captures: bool,
    pub seed: u64,
    /// Write `eval-OUTFIT.png` here for every outfit: the truth and every row at
    /// `dataset::SHEET_POSE`, front and side, for the first subject and the first setting.
    pub contact_sheets: Option<PathBuf>,
}

impl EvalConfig {
    /// MetaAvatar's protocol: clean captures, a seen and the unseen outfit; the fine-tuning
    /// captures are written in `workdir`.
    pub fn paper(protocols: Vec<Protocol>, workdir: PathBuf) -> Self {
        EvalConfig {
            protocols,
            captures: vec![CaptureConditions::clean()],
            subjects: EVAL_SUBJECT_SEEDS.to_vec(),
            outfits: EVAL_OUTFITS.to_vec(),
            finetune_clips: FINETUNE_CLIPS.iter().map(|s| s.to_string()).collect(),
            eval_clips: EVAL_CLIPS.iter().map(|s| s.to_string()).collect(),
            heldout_stride: 5,
            metrics: MetricOptions::default(),
            ground_truth_row: true,
            workdir,
            field_cache: FieldCache::none(),
            keep_captures: false,
            seed: 0,
            contact_sheets: None,
        }
    }

    /// Captures as users make them (the default table): 8 frames (one per fine-tuning clip),
    /// scored on the held-out clips, under `user` and then `clean` conditions, every outfit,
    /// the four held-out subjects.
    pub fn user_captures(workdir: PathBuf) -> Self {
        EvalConfig {
            captures: vec![CaptureConditions::user(), CaptureConditions::clean()],
            outfits: ALL_OUTFITS.to_vec(),
            ..Self::paper(vec![Protocol::FewShot(Shots::OnePerClip)], workdir)
        }
    }
}

fn clip(name: &str) -> Result<MotionClip> {
    crate::motion::library_clip(name)
}

pub use super::truth::{ground_truth_mesh, query};

#[derive(Default)]
struct Accum {
    training_frames: usize,
    metrics: Vec<FrameMetrics>,
    seconds: f64,
}

/// Contact-sheet views: front (from +Z, slightly above) and the body's left side.
const SHEET_VIEWS: [Vec3; 2] = [Vec3::new(0.0, 0.15, 1.0), Vec3::new(1.0, 0.15, 0.0)];

pub fn run(
    body: &BodyModel,
    config: &EvalConfig,
    predictors: &mut [Box<dyn Predictor>],
    progress: &dyn Fn(&str),
) -> Result<Report> {
    let finetune: Vec<MotionClip> =
        config.finetune_clips.iter().map(|c| clip(c)).collect::<Result<_>>()?;
    let heldout: Vec<MotionClip> =
        config.eval_clips.iter().map(|c| clip(c)).collect::<Result<_>>()?;
    let lengths: Vec<usize> = finetune.iter().map(|c| c.len()).collect();
    // Settings: every protocol under every capture conditions (conditions outermost).
    let settings: Vec<(&CaptureConditions, &Protocol)> =
        config.captures.iter().flat_map(|c| config.protocols.iter().map(move |p| (c, p))).collect();
    let methods = predictors.len() + config.ground_truth_row as usize;
    let mut acc: Vec<Vec<Vec<Accum>>> = (0..methods)
        .map(|_| {
            (0..settings.len())
                .map(|_| (0..config.outfits.len()).map(|_| Accum::default()).collect())
                .collect()
        })
        .collect();
    let sheet = match &config.contact_sheets {
        Some(_) => Some(sheet_frame()?),
        None => None,
    };
    for (subject_index, &subject) in config.subjects.iter().enumerate() {
        let betas = subject_betas(body, subject);
        for (oi, &outfit) in config.outfits.iter().enumerate() {
            let template = ClothedTemplate::build(body, &betas, outfit);
            let regions = Regions::of_template(&template)?;
            let clips: Vec<&MotionClip> =
                finetune.iter().chain(&heldout).chain(sheet.as_ref().map(|s| &s.0)).collect();
            let truth = OutfitTruth::new(body, &template, subject, &betas, &clips);
            // Truth, then every row, at the sheet pose.
            let mut sheet_meshes: Vec<TriMesh> = Vec::new();
            for (si, (capture, protocol)) in settings.iter().enumerate() {
                progress(&format!(
                    "subject {subject}, {}, {} capture, {}",
                    outfit.name(),
                    capture.name,
                    protocol.label()
                ));
                let train = training_selection(protocol, &lengths);
                // (clip, frame) of every evaluated pose.
                let eval_frames: Vec<(&MotionClip, usize)> = if protocol.evaluates_heldout() {
                    heldout
                        .iter()
                        .flat_map(|c| {
                            heldout_frames(c.len(), config.heldout_stride)
                                .into_iter()
                                .map(move |f| (c, f))
                        })
                        .collect()
                } else {
                    finetune
                        .iter()
                        .flat_map(|c| {
                            interpolation_frames(c.len()).into_iter().map(move |f| (c, f))
                        })
                        .collect()
                };
                let eval_poses: Vec<BodyParams> =
                    eval_frames.iter().map(|(c, f)| query(&c.frames[*f], &betas)).collect();
                let gts: Vec<TriMesh> = eval_frames
                    .par_iter()
                    .zip(&eval_poses)
                    .map(|((c, f), p)| truth.mesh(&c.name, *f, p))
                    .collect::<Result<_>>()?;
                let sheet_query = sheet
                    .as_ref()
                    .filter(|_| subject_index == 0 && si == 0)
                    .map(|(c, f)| (c, *f, query(&c.frames[*f], &betas)));
                if let Some((c, f, p)) = &sheet_query {
                    sheet_meshes.push(truth.mesh(&c.name, *f, p)?);
                }
                // The fine-tuning capture: the selected frames under the setting's conditions.
                let capture_dir = config.workdir.join(format!("s{subject}_{}_{si}", outfit.name()));
                if predictors.iter().any(|p| p.needs_capture()) {
                    let frames: Vec<BodyParams> =
                        train.iter().map(|&(c, f)| finetune[c].frames[f].clone()).collect();
                    let mut job = SynthJob::new(
                        subject,
                        outfit,
                        MotionClip::new("finetune", finetune[0].fps, frames),
                    );
                    if outfit.is_simulated() {
                        let garment = train
                            .iter()
                            .map(|&(c, f)| {
                                Ok(truth.garment(&finetune[c].name, f)?.map(<[_]>::to_vec))
                            })
                            .collect::<Result<Option<Vec<_>>>>()?;
                        job.garment = garment.map(|frames| GarmentTrack { frames });
                    }
                    let seed = capture_seed(config.seed, subject, outfit, capture);
                    capture.prepare(&mut job, seed);
                    job.write_ground_truth = false;
                    generate_capture(&capture_dir, body, &job)?;
                    capture.perturb_fittings(&capture_dir, seed)?;
                }
                for (m, predictor) in predictors.iter_mut().enumerate() {
                    let t = Instant::now();
                    predictor.fit(&FitData {
                        capture_dir: &capture_dir,
                        body,
                        betas: &betas,
                        outfit,
                        field_cache: &config.field_cache,
                    })?;
                    let predictor: &dyn Predictor = &**predictor;
                    let scores: Vec<FrameMetrics> = eval_poses
                        .par_iter()
                        .zip(gts.par_iter())
                        .enumerate()
                        .map(|(k, (p, gt))| {
                            evaluate_frame(
                                &predictor.predict(p)?,
                                gt,
                                &regions,
                                &config.metrics,
                                config.seed + k as u64,
                            )
                        })
                        .collect::<Result<_>>()?;
                    // The subject's share of the row, averaged as the row's summary averages.
                    let mean = |f: fn(&FrameMetrics) -> f32| {
                        Summary::of(&scores.iter().map(f).collect::<Vec<_>>())
                            .map_or(f32::NAN, |s| s.mean)
                    };
                    progress(&format!(
                        "subject {subject}, {}: {} Chamfer-L2 {:.3} cm, NC {:.4}, spurious {:.1} %",
                        outfit.name(),
                        predictor.name(),
                        mean(|s| s.chamfer_cm),
                        mean(|s| s.nc),
                        100.0 * mean(|s| s.surface.spurious)
                    ));
                    let a = &mut acc[m][si][oi];
                    a.training_frames = train.len();
                    a.metrics.extend(scores);
                    a.seconds += t.elapsed().as_secs_f64();
                    if let Some((_, _, p)) = &sheet_query {
                        sheet_meshes.push(predictor.predict(p)?);
                    }
                }
                if config.ground_truth_row {
                    let t = Instant::now();
                    let scores: Vec<FrameMetrics> = gts
                        .par_iter()
                        .enumerate()
                        .map(|(k, gt)| {
                            evaluate_frame(
                                gt,
                                gt,
                                &regions,
                                &config.metrics,
                                config.seed + k as u64,
                            )
                        })
                        .collect::<Result<_>>()?;
                    let a = &mut acc[predictors.len()][si][oi];
                    a.metrics.extend(scores);
                    a.seconds += t.elapsed().as_secs_f64();
                }
                if !config.keep_captures {
                    let _ = std::fs::remove_dir_all(&capture_dir);
                }
            }
            if let (Some(dir), false) = (&config.contact_sheets, sheet_meshes.is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
                write_view_sheet(
                    &dir.join(format!("eval-{}.png", outfit.name())),
                    &sheet_meshes,
                    &SHEET_VIEWS,
                )?;
            }
        }
    }
    let mut names: Vec<String> = predictors.iter().map(|p| p.name()).collect();
    if config.ground_truth_row {
        names.push("ground truth (sanity)".into());
    }
    let mut rows = Vec::new();
    for (m, name) in names.iter().enumerate() {
        for (si, (capture, protocol)) in settings.iter().enumerate() {
            let row =
                |outfit: String, training_frames: usize, metrics: &[FrameMetrics], seconds: f64| {
                    RowResult::summarise(RowInput {
                        method: name.clone(),
                        protocol: protocol.label(),
                        capture: capture.name.clone(),
                        outfit,
                        training_frames,
                        metrics,
                        seconds,
                    })
                };
            for (oi, outfit) in config.outfits.iter().enumerate() {
                let a = &acc[m][si][oi];
                rows.push(row(
                    outfit.name().to_string(),
                    a.training_frames,
                    &a.metrics,
                    a.seconds,
                )?);
            }
            if config.outfits.len() > 1 {
                let all: Vec<FrameMetrics> =
                    acc[m][si].iter().flat_map(|a| a.metrics.iter().copied()).collect();
                rows.push(row(
                    "all".into(),
                    acc[m][si][0].training_frames,
                    &all,
                    acc[m][si].iter().map(|a| a.seconds).sum(),
                )?);
            }
        }
    }
    if !config.keep_captures {
        let _ = std::fs::remove_dir_all(&config.workdir);
    }
    Ok(Report {
        subjects: config.subjects.clone(),
        outfits: config.outfits.iter().map(|o| o.name().to_string()).collect(),
        finetune_clips: config.finetune_clips.clone(),
        eval_clips: config.eval_clips.clone(),
        captures: config.captures.iter().map(|c| c.describe()).collect(),
        seed: config.seed,
        rows,
    })
}
