//! Meta-learning (MetaAvatar Sections 3-4): Alg. 1, Reptile on the static SIREN SDF (each
//! task one posed frame), then Alg. 2, Reptile on the hypernetwork initialised from that
//! meta-SDF (each task a random-size subset of one subject's frames in one outfit). Both feed
//! theta - theta' to an outer Adam. Checkpoints after every few iterations make a killed run
//! resume where it stopped; every iteration draws its tasks from its own seeded generator, so a
//! resumed run sees the same tasks as an uninterrupted one (Adam's moments restart at zero).

use crate::error::{Error, Result};
use crate::fit::{FitOptions, fit_sdf};
use crate::flat_params::{flatten, load_flat, reptile_gradients};
use crate::hyper::HyperConfig;
use crate::hyper_fit::{GroupRates, HyperFitOptions, HyperOptimisers, fit_hyper};
use crate::loss::IgrWeights;
use crate::meta_data::MetaData;
use crate::model_file::MetaModel;
use crate::pose_sample::PoseSample;
use crate::weights_file;
use burn::optim::AdamConfig;
use rand::seq::index::sample as sample_indices;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetaOptions {
    pub config: HyperConfig,
    /// Alg. 1: outer iterations, tasks (frames) per iteration, inner Adam steps per task.
    pub sdf_iterations: usize,
    pub sdf_meta_batch: usize,
    pub sdf_inner_steps: usize,
    pub sdf_inner_lr: f64,
    pub sdf_outer_lr: f64,
    /// Alg. 2: outer iterations, the largest task (frames of one group), inner epochs.
    pub hyper_iterations: usize,
    pub hyper_max_task: usize,
    pub hyper_inner_epochs: usize,
    /// Inner fits (learning rates, points, poses per step) of Alg. 2.
    pub hyper_inner: HyperFitOptions,
    pub hyper_outer: RatesConfig,
    /// Points per inner step of Alg. 1 (surface and as many off-surface).
    pub points_per_step: usize,
    pub checkpoint_every: usize,
    pub seed: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RatesConfig {
    pub heads: f64,
    pub encoder: f64,
    pub sdf: f64,
}

impl Default for MetaOptions {
    fn default() -> Self {
        MetaOptions {
            config: HyperConfig::compact(),
            sdf_iterations: 300,
            sdf_meta_batch: 3,
            sdf_inner_steps: 12,
            sdf_inner_lr: 1e-4,
            sdf_outer_lr: 1e-4,
            hyper_iterations: 400,
            hyper_max_task: 8,
            hyper_inner_epochs: 4,
            // The inner fit the shipped model was meta-trained with (heads 1e-5, encoder 1e-4, with
            // the normal term: exact surface normals), pinned here so fine-tuning's defaults can
            // change without touching meta-training or its checkpoints.
            hyper_inner: HyperFitOptions {
                poses_per_step: 4,
                surface_per_pose: 500,
                off_per_pose: 500,
                // Meta-training data has no free-space samples; 0 keeps older checkpoints' config.
                free_space_per_pose: 0,
                // Fine-tuning's alone; 1 keeps older checkpoints' config.
                loose_step_factor: 1.0,
                lr_heads: 1e-5,
                lr_encoder: 1e-4,
                weights: IgrWeights::default(),
                ..HyperFitOptions::default()
            },
            hyper_outer: RatesConfig { heads: 1e-5, encoder: 1e-4, sdf: 1e-5 },
            points_per_step: 1000,
            checkpoint_every: 10,
            seed: 0,
        }
    }
}

/// What a checkpoint holds besides the weights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Checkpoint {
    format: String,
    version: u32,
    kind: String,
    options: MetaOptions,
    /// "sdf" (Alg. 1, weights = the SIREN) or "hyper" (Alg. 2, weights = hypernetwork then the
    /// static meta-SDF of Alg. 1).
    stage: String,
    /// Iterations completed in that stage.
    iteration: usize,
    seconds: f64,
}

impl Checkpoint {
    fn new(options: &MetaOptions, stage: &str, iteration: usize, seconds: f64) -> Checkpoint {
        Checkpoint {
            format: "avatar-studio-checkpoint".into(),
            version: 1,
            kind: "meta-checkpoint".into(),
            options: options.clone(),
            stage: stage.into(),
            iteration,
            seconds,
        }
    }

    /// Check a checkpoint's header before its weights are read; the number of weights it needs.
    /// An unknown stage is an error: silently restarting would throw the run away.
    fn expected_weights(&self) -> Result<usize> {
        if self.format != "avatar-studio-checkpoint"
            || self.version != 1
            || self.kind != "meta-checkpoint"
        {
            return Err(Error::invalid(format!(
                "checkpoint format {:?} version {} kind {:?} is not supported by this build",
                self.format, self.version, self.kind
            )));
        }
        self.options.config.check()?;
        let sdf = self.options.config.siren.num_params();
        match self.stage.as_str() {
            "sdf" => Ok(sdf),
            "hyper" => Ok(self.options.config.num_params() + sdf),
            other => Err(Error::invalid(format!(
                "unknown checkpoint stage {other:?} (sdf or hyper); refusing to restart over it: move it away to start afresh"
            ))),
        }
    }
}

const CHECKPOINT: &str = "checkpoint.bin";
pub const MODEL_FILE: &str = "meta-model.bin";

/// One logged line of progress.
pub struct MetaProgress<'a> {
    pub stage: &'a str,
    pub iteration: usize,
    pub iterations: usize,
    pub loss: f32,
    pub seconds: f64,
}

/// Whether a checkpoint written with `saved` may go on under `asked`: other iteration counts
/// (to extend or shorten a run), nothing else. The inner fit's pose-refinement options are not
/// compared: `fit_hyper` never refines poses (meta-training data has exact ones), and those
/// options gain fields as fine-tuning evolves.
fn resumes(saved: &MetaOptions, asked: &MetaOptions) -> bool {
    let mut same = MetaOptions {
        sdf_iterations: asked.sdf_iterations,
        hyper_iterations: asked.hyper_iterations,
        ..saved.clone()
    };
    same.hyper_inner.refine_poses = asked.hyper_inner.refine_poses;
    same == *asked
}

fn iteration_rng(seed: u64, stage: u64, iteration: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(
        seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ (stage << 40) ^ iteration as u64,
    )
}

/// Meta-train into `out` (checkpoint, loss log, final model). Resumes from `out/checkpoint.bin`
/// when its options match. Returns the model path; a cancelled run returns an error after
/// writing its checkpoint.
pub fn meta_train(
    data: &MetaData,
    options: &MetaOptions,
    out: &Path,
    cancel: Option<&AtomicBool>,
    log: &mut dyn FnMut(&MetaProgress),
) -> Result<PathBuf> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    if data.is_empty() {
        return Err(Error::invalid("meta-training data is empty"));
    }
    let train_device = crate::compute::training_device();
    let ckpt_path = out.join(CHECKPOINT);
    let log_path = out.join("loss.csv");
    let mut resume: Option<(Checkpoint, Vec<f32>)> = None;
    if ckpt_path.exists() {
        let (ck, w): (Checkpoint, Vec<f32>) =
            weights_file::read_expecting(&ckpt_path, Checkpoint::expected_weights)?;
        if !resumes(&ck.options, options) {
            return Err(Error::file(
                &ckpt_path,
                "a checkpoint of a run with other options is in the output folder: use another --out or the same options",
            ));
        }
        resume = Some((ck, w));
    }
    let mut csv = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| Error::io(&log_path, e))?;
    let started = Instant::now();
    let prior_seconds = resume.as_ref().map_or(0.0, |(c, _)| c.seconds);
    let elapsed = |s: &Instant| prior_seconds + s.elapsed().as_secs_f64();

    // ---- Alg. 1: Reptile on the static SDF.
    let sdf_config = options.config.siren;
    let mut meta_sdf = sdf_config.init(options.seed, &train_device);
    let mut start = 0;
    let mut hyper_resume: Option<(usize, Vec<f32>)> = None;
    match &resume {
        Some((ck, w)) if ck.stage == "sdf" => {
            meta_sdf = load_flat(meta_sdf, w).map_err(|e| e.in_file(&ckpt_path))?;
            start = ck.iteration;
        }
        Some((ck, w)) if ck.stage == "hyper" => {
            let n_sdf = sdf_config.num_params();
            meta_sdf =
                load_flat(meta_sdf, &w[w.len() - n_sdf..]).map_err(|e| e.in_file(&ckpt_path))?;
            start = options.sdf_iterations;
            hyper_resume = Some((ck.iteration, w[..w.len() - n_sdf].to_vec()));
        }
        _ => {}
    }
    let mut outer = AdamConfig::new().init();
    for it in start..options.sdf_iterations {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return Err(Error::invalid(
                "meta-training cancelled (checkpoint kept; run again to resume)",
            ));
        }
        let mut rng = iteration_rng(options.seed, 1, it);
        let mut mean = vec![0f32; sdf_config.num_params()];
        let mut loss_sum = 0.0;
        for _ in 0..options.sdf_meta_batch {
            let i = rng.random_range(0..data.len());
            let inner = FitOptions {
                steps: options.sdf_inner_steps,
                learning_rate: options.sdf_inner_lr,
                batch: options.points_per_step,
                off_surface: options.points_per_step,
                seed: rng.random(),
                ..FitOptions::default()
            };
            let mut last = 0.0;
            let adapted = fit_sdf(
                meta_sdf.clone(),
                &data.points[i],
                &data.normals[i],
                &[],
                &inner,
                &train_device,
                None,
                None,
                &mut |_, l, _| last = l,
            );
            loss_sum += last;
            for (m, v) in mean.iter_mut().zip(flatten(&adapted)) {
                *m += v / options.sdf_meta_batch as f32;
            }
        }
        let grads = reptile_gradients(&meta_sdf, &mean);
        meta_sdf = outer.step(options.sdf_outer_lr, meta_sdf, grads);
        let loss = loss_sum / options.sdf_meta_batch as f32;
        let _ = writeln!(csv, "sdf,{},{loss},{:.1}", it + 1, elapsed(&started));
        log(&MetaProgress {
            stage: "sdf",
            iteration: it + 1,
            iterations: options.sdf_iterations,
            loss,
            seconds: elapsed(&started),
        });
        if (it + 1) % options.checkpoint_every == 0 || it + 1 == options.sdf_iterations {
            let ck = Checkpoint::new(options, "sdf", it + 1, elapsed(&started));
            weights_file::write(&ckpt_path, &ck, &flatten(&meta_sdf))?;
        }
    }

    // ---- Alg. 2: Reptile on the hypernetwork, initialised from the meta-SDF.
    let encoding = options.config.encoding;
    let samples: Vec<PoseSample> = (0..data.len()).map(|i| data.sample(i, encoding)).collect();
    let mut model = options.config.init(meta_sdf.clone(), options.seed, &train_device);
    let mut start = 0;
    if let Some((it, w)) = hyper_resume {
        model = load_flat(model, &w).map_err(|e| e.in_file(&ckpt_path))?;
        start = it;
    }
    let static_flat = flatten(&meta_sdf);
    let mut outer = HyperOptimisers::default();
    let rates = GroupRates {
        heads: options.hyper_outer.heads,
        encoder: options.hyper_outer.encoder,
        sdf: options.hyper_outer.sdf,
    };
    for it in start..options.hyper_iterations {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return Err(Error::invalid(
                "meta-training cancelled (checkpoint kept; run again to resume)",
            ));
        }
        let mut rng = iteration_rng(options.seed, 2, it);
        let group = &data.manifest.groups[rng.random_range(0..data.manifest.groups.len())];
        let size = rng.random_range(1..=options.hyper_max_task.min(group.samples).max(1));
        let task: Vec<PoseSample> = sample_indices(&mut rng, group.samples, size)
            .into_iter()
            .map(|k| samples[group.first_sample + k].clone())
            .collect();
        let per_step = options.hyper_inner.poses_per_step.max(1);
        let inner = HyperFitOptions {
            steps: options.hyper_inner_epochs * size.div_ceil(per_step),
            seed: rng.random(),
            ..options.hyper_inner.clone()
        };
        let mut last = 0.0;
        let adapted = fit_hyper(
            model.clone(),
            &task,
            &inner,
            &mut HyperOptimisers::default(),
            &train_device,
            None,
            None,
            &mut |_, l, _| last = l,
        );
        let grads = [
            reptile_gradients(&model.encoder, &flatten(&adapted.encoder)),
            reptile_gradients(&model.heads, &flatten(&adapted.heads)),
            reptile_gradients(&model.bases, &flatten(&adapted.bases)),
            reptile_gradients(&model.sdf, &flatten(&adapted.sdf)),
        ];
        model = outer.step_params(model, grads, rates);
        let _ = writeln!(csv, "hyper,{},{last},{:.1}", it + 1, elapsed(&started));
        log(&MetaProgress {
            stage: "hyper",
            iteration: it + 1,
            iterations: options.hyper_iterations,
            loss: last,
            seconds: elapsed(&started),
        });
        if (it + 1) % options.checkpoint_every == 0 || it + 1 == options.hyper_iterations {
            let ck = Checkpoint::new(options, "hyper", it + 1, elapsed(&started));
            let mut w = flatten(&model);
            w.extend_from_slice(&static_flat);
            weights_file::write(&ckpt_path, &ck, &w)?;
        }
    }
    let path = out.join(MODEL_FILE);
    let meta = MetaModel::from_parts(
        options.config,
        &model,
        &meta_sdf,
        format!(
            "meta-train seed {} ({} + {} iterations, {:.0} s)",
            options.seed,
            options.sdf_iterations,
            options.hyper_iterations,
            elapsed(&started)
        ),
    );
    meta.save(&path)?;
    Ok(path)
}

/// Start a run at Alg. 2 with the static meta-SDF of an existing model (Alg. 1 skipped): writes
/// an Alg. 1-complete checkpoint into `out`, which `meta_train` then resumes from. Refused when
/// `out` already holds a checkpoint (that run resumes as it is) or the model's SDF has another
/// size. Lets Alg. 2 variants share one Alg. 1 result, as the reference's stage configs do.
pub fn start_from_static(
    out: &Path,
    options: &MetaOptions,
    model: &MetaModel,
    model_path: &Path,
) -> Result<()> {
    let ckpt_path = out.join(CHECKPOINT);
    if ckpt_path.exists() {
        return Err(Error::file(
            &ckpt_path,
            "the output folder already holds a checkpoint: resume it without --sdf-from, or use another --out",
        ));
    }
    if model.header.config.siren != options.config.siren {
        return Err(Error::file(
            model_path,
            "its static meta-SDF has another network size than this run's preset",
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    // Alg. 1 complete, as a finished Alg. 1 of this run would have left it.
    let ck = Checkpoint::new(options, "sdf", options.sdf_iterations, 0.0);
    weights_file::write(&ckpt_path, &ck, &model.static_sdf)
}

pub use crate::model_file::{trainable_hyper, trainable_siren};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_resumes_with_other_iteration_counts_or_pose_refinement_but_nothing_else() {
        let saved = MetaOptions::default();
        let longer = MetaOptions {
            sdf_iterations: saved.sdf_iterations * 2,
            hyper_iterations: 7,
            ..saved.clone()
        };
        assert!(resumes(&saved, &longer));
        let mut refined = saved.clone();
        refined.hyper_inner.refine_poses.prealign_upper_body =
            !saved.hyper_inner.refine_poses.prealign_upper_body;
        assert!(resumes(&saved, &refined), "fit_hyper never refines poses");
        assert!(!resumes(&saved, &MetaOptions { seed: 1, ..saved.clone() }));
        assert!(!resumes(
            &saved,
            &MetaOptions { sdf_outer_lr: saved.sdf_outer_lr * 10.0, ..saved.clone() }
        ));
        let mut inner = saved.clone();
        inner.hyper_inner.lr_heads *= 2.0;
        assert!(!resumes(&saved, &inner), "the inner fit's rates are part of the run");
    }
}
