//! Meta-learning (MetaAvatar Sections 3-4): Alg. 1, Reptile on the static SIREN SDF (each
//! task one posed frame), then Alg. 2, Reptile on the hypernetwork initialised from that
//! meta-SDF (each task a random-size subset of one subject's frames in one outfit). Both feed
//! theta - theta' to an outer Adam. Checkpoints after every few iterations make a killed run
//! resume where it stopped; every iteration draws its tasks from its own seeded generator, so a
//! resumed run sees the same tasks as an uninterrupted one (Adam's moments restart at zero).

mod checkpoint;
mod tasks;

use crate::data::meta_data::MetaData;
use crate::data::pose_sample::PoseSample;
use crate::error::{Error, Result};
use crate::model::flat_params::{flatten, load_flat, reptile_gradients};
use crate::model::hyper::{HyperConfig, HyperNet};
use crate::model::model_file::MetaModel;
use crate::model::weights_file;
use crate::training::collective::Collective;
use crate::training::fit::{FitOptions, fit_sdf};
use crate::training::hyper_fit::{GroupRates, HyperFitOptions, HyperOptimisers, fit_hyper};
use crate::training::loss::IgrWeights;
use burn::optim::AdamConfig;
use burn::optim::GradientsParams;
use checkpoint::Checkpoint;
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
    /// Alg. 2: tasks per outer iteration, their updates averaged (the paper's Reptile: 1; more
    /// give ranks of a data-parallel run a task each). Older checkpoints lack it: 1.
    #[serde(default = "one")]
    pub hyper_meta_batch: usize,
    pub hyper_inner_epochs: usize,
    /// Inner fits (learning rates, points, poses per step) of Alg. 2.
    pub hyper_inner: HyperFitOptions,
    pub hyper_outer: RatesConfig,
    /// Points per inner step of Alg. 1 (surface and as many off-surface).
    pub points_per_step: usize,
    pub checkpoint_every: usize,
    pub seed: u64,
    /// Where the steps run, the inner fits' too (a choice of this run: a checkpoint resumes on
    /// any device).
    #[serde(skip)]
    pub compute: crate::compute::Compute,
}

fn one() -> usize {
    1
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
            hyper_meta_batch: 1,
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
            compute: crate::compute::Compute::Cpu,
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
        compute: asked.compute,
        ..saved.clone()
    };
    same.hyper_inner.refine_poses = asked.hyper_inner.refine_poses;
    same.hyper_inner.compute = asked.hyper_inner.compute;
    same == *asked
}

/// Meta-train into `out` (checkpoint, loss log, final model). Resumes from `out/checkpoint.bin`
/// when its options match. Returns the model path; a cancelled run returns an error after
/// writing its checkpoint. One process: `meta_train_collective` with `Collective::single()`.
pub fn meta_train(
    data: &MetaData,
    options: &MetaOptions,
    out: &Path,
    cancel: Option<&AtomicBool>,
    log: &mut dyn FnMut(&MetaProgress),
) -> Result<PathBuf> {
    meta_train_collective(data, options, out, cancel, log, &Collective::single())
}

/// `meta_train` as one rank of a data-parallel run: every rank adapts its share of each outer
/// iteration's tasks (`tasks::mine`) and the mean adapted weights are all-reduced, so every
/// rank takes the same outer step, the one a single process would take (up to the order of the
/// float sums). Rank 0 alone reads and writes `out` (checkpoint, loss log, model); on a restart
/// it hands the checkpoint to the others. Every rank must run with the same options and data
/// (checked). Returns the model's path (on rank 0's disk). A rank that fails leaves the
/// others waiting in the next all-reduce: the launcher (srun, a shell) ends the run.
pub fn meta_train_collective(
    data: &MetaData,
    options: &MetaOptions,
    out: &Path,
    cancel: Option<&AtomicBool>,
    log: &mut dyn FnMut(&MetaProgress),
    collective: &Collective,
) -> Result<PathBuf> {
    crate::config::Check::check(options)?;
    let root = collective.is_root();
    if root {
        std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    }
    if data.is_empty() {
        return Err(Error::invalid("meta-training data is empty"));
    }
    if collective.world() > 1 {
        checkpoint::check_same_run(collective, fingerprint(data, options))?;
    }
    let train_device = options.compute.training_device();
    let ckpt_path = out.join(CHECKPOINT);
    let resume =
        checkpoint::share(collective, options, || checkpoint::read(&ckpt_path, options, resumes))?;
    let mut csv = match root {
        true => {
            let log_path = out.join("loss.csv");
            let file = std::fs::OpenOptions::new().create(true).append(true).open(&log_path);
            Some(file.map_err(|e| Error::io(&log_path, e))?)
        }
        false => None,
    };
    let started = Instant::now();
    let prior_seconds = resume.as_ref().map_or(0.0, |r| r.seconds);
    let static_from = resume.as_ref().and_then(|r| r.static_from.clone());
    let elapsed = |s: &Instant| prior_seconds + s.elapsed().as_secs_f64();
    let stop = || -> Result<()> {
        match collective.any(cancel.is_some_and(|c| c.load(Ordering::Relaxed)))? {
            true => Err(Error::invalid(
                "meta-training cancelled (checkpoint kept; run again to resume)",
            )),
            false => Ok(()),
        }
    };

    // ---- Alg. 1: Reptile on the static SDF.
    let sdf_config = options.config.siren;
    let mut meta_sdf = sdf_config.init(options.seed, &train_device);
    let mut start = 0;
    let mut hyper_resume: Option<(usize, Vec<f32>)> = None;
    match &resume {
        Some(r) if r.stage == "sdf" => {
            meta_sdf = load_flat(meta_sdf, &r.weights).map_err(|e| e.in_file(&ckpt_path))?;
            start = r.iteration;
        }
        Some(r) => {
            let w = &r.weights;
            let n_sdf = sdf_config.num_params();
            meta_sdf =
                load_flat(meta_sdf, &w[w.len() - n_sdf..]).map_err(|e| e.in_file(&ckpt_path))?;
            start = options.sdf_iterations;
            hyper_resume = Some((r.iteration, w[..w.len() - n_sdf].to_vec()));
        }
        None => {}
    }
    let mut outer = AdamConfig::new().init();
    let n_sdf = sdf_config.num_params();
    for it in start..options.sdf_iterations {
        stop()?;
        let tasks = tasks::sdf_tasks(options, data, it);
        // The mean adapted SIREN over the iteration's tasks, then the mean loss.
        let mut mean = vec![0f32; n_sdf + 1];
        for (_, task) in tasks::mine(&tasks, collective) {
            let inner = FitOptions {
                steps: options.sdf_inner_steps,
                learning_rate: options.sdf_inner_lr,
                batch: options.points_per_step,
                off_surface: options.points_per_step,
                seed: task.seed,
                compute: options.compute,
                ..FitOptions::default()
            };
            let mut last = 0.0;
            let adapted = fit_sdf(
                meta_sdf.clone(),
                &data.points[task.sample],
                &data.normals[task.sample],
                &[],
                &inner,
                &train_device,
                None,
                None,
                &mut |_, l, _| last = l,
            );
            tasks::add_mean(&mut mean[..n_sdf], &flatten(&adapted), tasks.len());
            mean[n_sdf] += last;
        }
        collective.all_reduce_sum(&mut mean)?;
        let grads = reptile_gradients(&meta_sdf, &mean[..n_sdf]);
        meta_sdf = outer.step(options.sdf_outer_lr, meta_sdf, grads);
        let loss = mean[n_sdf] / tasks.len() as f32;
        if let Some(csv) = &mut csv {
            let _ = writeln!(csv, "sdf,{},{loss},{:.1}", it + 1, elapsed(&started));
        }
        log(&MetaProgress {
            stage: "sdf",
            iteration: it + 1,
            iterations: options.sdf_iterations,
            loss,
            seconds: elapsed(&started),
        });
        if root && ((it + 1) % options.checkpoint_every == 0 || it + 1 == options.sdf_iterations) {
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
    let n = hyper_flat(&model).len();
    for it in start..options.hyper_iterations {
        stop()?;
        let tasks = tasks::hyper_tasks(options, data, it);
        // The mean adapted hypernetwork (`hyper_flat`), then the mean loss.
        let mut mean = vec![0f32; n + 1];
        for (_, task) in tasks::mine(&tasks, collective) {
            let task_samples: Vec<PoseSample> =
                task.samples.iter().map(|&i| samples[i].clone()).collect();
            let per_step = options.hyper_inner.poses_per_step.max(1);
            let inner = HyperFitOptions {
                steps: options.hyper_inner_epochs * task_samples.len().div_ceil(per_step),
                seed: task.seed,
                compute: options.compute,
                ..options.hyper_inner.clone()
            };
            let mut last = 0.0;
            let adapted = fit_hyper(
                model.clone(),
                &task_samples,
                &inner,
                &mut HyperOptimisers::default(),
                &train_device,
                None,
                None,
                &mut |_, l, _| last = l,
            );
            tasks::add_mean(&mut mean[..n], &hyper_flat(&adapted), tasks.len());
            mean[n] += last;
        }
        collective.all_reduce_sum(&mut mean)?;
        let grads = hyper_reptile_gradients(&model, &mean[..n]);
        model = outer.step_params(model, grads, rates);
        let loss = mean[n] / tasks.len() as f32;
        if let Some(csv) = &mut csv {
            let _ = writeln!(csv, "hyper,{},{loss},{:.1}", it + 1, elapsed(&started));
        }
        log(&MetaProgress {
            stage: "hyper",
            iteration: it + 1,
            iterations: options.hyper_iterations,
            loss,
            seconds: elapsed(&started),
        });
        if root && ((it + 1) % options.checkpoint_every == 0 || it + 1 == options.hyper_iterations)
        {
            let ck = Checkpoint::new(options, "hyper", it + 1, elapsed(&started))
                .with_static_from(static_from.clone());
            let mut w = flatten(&model);
            w.extend_from_slice(&static_flat);
            weights_file::write(&ckpt_path, &ck, &w)?;
        }
    }
    let path = out.join(MODEL_FILE);
    if root {
        let meta = MetaModel::from_parts(
            options.config,
            &model,
            &meta_sdf,
            match &static_from {
                None => format!(
                    "meta-train seed {} ({} + {} iterations, {:.0} s)",
                    options.seed,
                    options.sdf_iterations,
                    options.hyper_iterations,
                    elapsed(&started)
                ),
                Some(from) => format!(
                    "meta-train seed {} (static meta-SDF of {from}, {} iterations, {:.0} s)",
                    options.seed,
                    options.hyper_iterations,
                    elapsed(&started)
                ),
            },
        );
        meta.save(&path)?;
    }
    Ok(path)
}

/// The hypernetwork's weights as Alg. 2 averages them: encoder, heads, bases, SDF.
fn hyper_flat(model: &HyperNet) -> Vec<f32> {
    [flatten(&model.encoder), flatten(&model.heads), flatten(&model.bases), flatten(&model.sdf)]
        .concat()
}

/// Reptile's outer gradients of each parameter group from the mean adapted model (`hyper_flat`).
fn hyper_reptile_gradients(model: &HyperNet, adapted: &[f32]) -> [GradientsParams; 4] {
    let sizes = [
        flatten(&model.encoder).len(),
        flatten(&model.heads).len(),
        flatten(&model.bases).len(),
        flatten(&model.sdf).len(),
    ];
    let mut at = 0;
    let mut part = |size: usize| {
        at += size;
        &adapted[at - size..at]
    };
    [
        reptile_gradients(&model.encoder, part(sizes[0])),
        reptile_gradients(&model.heads, part(sizes[1])),
        reptile_gradients(&model.bases, part(sizes[2])),
        reptile_gradients(&model.sdf, part(sizes[3])),
    ]
}

/// What every rank of a run must share: the options and the data, to the bit.
fn fingerprint(data: &MetaData, options: &MetaOptions) -> u64 {
    let json = serde_json::to_vec(options).unwrap_or_default();
    let mut h = checkpoint::fnv1a(checkpoint::FNV_START, &json);
    for (points, normals) in data.points.iter().zip(&data.normals) {
        for p in points.iter().chain(normals) {
            for v in p.to_array() {
                h = checkpoint::fnv1a(h, &v.to_bits().to_le_bytes());
            }
        }
    }
    h
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
    let ck = Checkpoint::new(options, "sdf", options.sdf_iterations, 0.0).with_static_from(Some(
        model.prior().map_or_else(
            || model_path.display().to_string(),
            |p| format!("the prior {}", p.label()),
        ),
    ));
    weights_file::write(&ckpt_path, &ck, &model.static_sdf)
}

pub use crate::model::model_file::{trainable_hyper, trainable_siren};

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
