//! Fitting the hypernetwork to posed point sets with the IGR loss: the inner loop of Alg. 2
//! (meta-learning) and the fine-tuning of a personal avatar. Each step takes a minibatch of
//! poses, predicts one SIREN per pose and scores its surface and off-surface points.

use crate::data::off_surface::OffSurface;
use crate::model::hyper::HyperNet;
use crate::training::fit::{Progress, SignPrior};
use crate::training::loss::{IgrWeights, igr_loss, scalar};
use crate::training::step::{Adam, HyperBatch, HyperGradient, IgrPoints, StepLoss};
use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use glam::Vec3;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::data::pose_sample::PoseSample;

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HyperFitOptions {
    pub steps: usize,
    /// A personal avatar that has loose pieces after `steps` (a skirt, a coat's tails:
    /// `SurfaceChoice::WrappedWithLoose`) goes on to this many times `steps` in all: such cloth
    /// is still being reconstructed there while the body-hugging kinds have converged (user
    /// table: dress 0.841 -> 0.829 cm, spurious 10.6 -> 10.3 %; blazer 0.829 -> 0.784 cm,
    /// 6.0 -> 5.0 %; 1,024 steps no better; docs/decisions.md). 1 or less: no more steps.
    #[serde(default = "no_loose_extension")]
    pub loose_step_factor: f32,
    /// Adam learning rates: heads and low-rank bases, bone encoder, the SDF's base weights.
    pub lr_heads: f64,
    pub lr_encoder: f64,
    pub lr_sdf: f64,
    /// Poses per step.
    pub poses_per_step: usize,
    /// Surface and off-surface points per pose and step.
    pub surface_per_pose: usize,
    pub off_per_pose: usize,
    /// Of the off-surface points, how many come from the pose's free-space samples (when it
    /// has any): the rays in front of the measured depth, constrained to be outside.
    #[serde(default)]
    pub free_space_per_pose: usize,
    /// Standard deviation of the near-surface off-surface samples (normalised units).
    pub near_sigma: f32,
    pub weights: IgrWeights,
    pub prior_weight: f32,
    /// Weight of the residual regulariser (MetaAvatar: 1e2 |theta| / parameters).
    pub residual_weight: f32,
    pub seed: u64,
    /// Joint refinement of the frames' poses during a personal avatar's fit (PINA 3.2; on by
    /// default; meta-training ignores it).
    #[serde(default)]
    pub refine_poses: crate::training::pose_refine::PoseRefineOptions,
    /// Where the steps run (a choice of this run, never written with the options).
    #[serde(skip)]
    pub compute: crate::compute::Compute,
}

impl Default for HyperFitOptions {
    /// Fine-tuning a personal avatar on depth points (docs/decisions.md has the measurements
    /// behind each choice).
    fn default() -> Self {
        HyperFitOptions {
            // The reference's 256 epochs: with every frame in every step, one step an epoch.
            steps: 256,
            loose_step_factor: 2.0,
            // The reference's fine-tuning rate for the hypernetwork (1e-6). 1e-5 let the heads
            // fit the training poses' residuals and lose accuracy at held-out poses (eval at
            // 256: 8-frame NC 0.875 at 1e-5, 0.837 at 1e-4).
            lr_heads: 1e-6,
            // The bone encoder stays as meta-learned (the reference fine-tunes it at 1e-4): with
            // 8 frames a moving encoder re-maps the held-out poses and loses accuracy there
            // (8-frame NC 0.878 at 1e-4, 0.881 frozen).
            lr_encoder: 0.0,
            lr_sdf: 1e-4,
            // Every frame in every step (the reference's minibatch of 12 holds all 8 frames):
            // the shared weights see all poses at once; 8 x 500 points as 4 x 1000 before.
            poses_per_step: 8,
            // 1,000 surface and 1,000 off-surface points a pose (500 before the faster training
            // step): user captures, 2 subjects, tight and dress: Chamfer 1.578 -> 1.525 cm,
            // NC 0.719 -> 0.727; 2,000 gives no more (docs/decisions.md).
            surface_per_pose: 1000,
            off_per_pose: 1000,
            free_space_per_pose: 300,
            near_sigma: 0.02,
            weights: IgrWeights::depth(),
            // The sign prior's and the outside constraints' weight (free space, the shells behind
            // loose clothing): at 1,000 a skirt's inside stayed filled, at 5,000 its walls are
            // about 3 cm thin (docs/decisions.md).
            prior_weight: 5000.0,
            residual_weight: 1e2,
            seed: 0,
            refine_poses: crate::training::pose_refine::PoseRefineOptions::default(),
            compute: crate::compute::Compute::Cpu,
        }
    }
}

/// Options written before the loose cloth's longer fit: none.
fn no_loose_extension() -> f32 {
    1.0
}

impl HyperFitOptions {
    /// The steps a fit runs in all when its avatar has loose pieces after `steps`.
    pub fn loose_steps(&self) -> usize {
        if self.loose_step_factor > 1.0 {
            ((self.steps as f64) * self.loose_step_factor as f64).round() as usize
        } else {
            self.steps
        }
    }

    /// The static SDF's fit with the same budget: the same steps, rate of the SDF weights, loss
    /// and points a step (all poses pooled). The static meta-SDF row of the evaluation and
    /// `fit --static` use it, so the two kinds of avatar compare like for like.
    pub fn static_equivalent(&self) -> crate::training::fit::FitOptions {
        crate::training::fit::FitOptions {
            steps: self.steps,
            learning_rate: self.lr_sdf,
            batch: self.surface_per_pose * self.poses_per_step,
            off_surface: self.off_per_pose * self.poses_per_step,
            free_space: self.free_space_per_pose * self.poses_per_step,
            near_sigma: self.near_sigma,
            weights: self.weights,
            prior_weight: self.prior_weight,
            seed: self.seed,
            compute: self.compute,
        }
    }
}

/// Optimisers of the four parameter groups (kept across calls so meta-training and
/// fine-tuning can resume them).
pub struct HyperOptimisers {
    encoder: ModuleOptimizer,
    heads: ModuleOptimizer,
    bases: ModuleOptimizer,
    sdf: ModuleOptimizer,
    /// The CPU training path's step buffers and Adam state.
    flat: Option<(HyperGradient, Adam)>,
}

impl Default for HyperOptimisers {
    fn default() -> Self {
        HyperOptimisers {
            encoder: AdamConfig::new().init(),
            heads: AdamConfig::new().init(),
            bases: AdamConfig::new().init(),
            sdf: AdamConfig::new().init(),
            flat: None,
        }
    }
}

/// Learning rates of the four groups.
#[derive(Debug, Clone, Copy)]
pub struct GroupRates {
    pub heads: f64,
    pub encoder: f64,
    pub sdf: f64,
}

impl HyperOptimisers {
    /// One optimiser step of every group from the gradients of a loss.
    pub fn step(
        &mut self,
        model: HyperNet,
        mut grads: burn::tensor::Gradients,
        rates: GroupRates,
    ) -> HyperNet {
        let g = [
            GradientsParams::from_module(&mut grads, &model.encoder),
            GradientsParams::from_module(&mut grads, &model.heads),
            GradientsParams::from_module(&mut grads, &model.bases),
            GradientsParams::from_module(&mut grads, &model.sdf),
        ];
        self.step_params(model, g, rates)
    }

    /// The same from per-group gradient containers (encoder, heads, bases, SDF), for
    /// Reptile's theta - theta'.
    pub fn step_params(
        &mut self,
        model: HyperNet,
        grads: [GradientsParams; 4],
        rates: GroupRates,
    ) -> HyperNet {
        let [g_enc, g_heads, g_bases, g_sdf] = grads;
        let HyperNet { encoder, heads, bases, sdf } = model;
        HyperNet {
            // A zero rate freezes the group (fine-tuning's bone encoder).
            encoder: if rates.encoder > 0.0 {
                self.encoder.step(rates.encoder, encoder, g_enc)
            } else {
                encoder
            },
            heads: self.heads.step(rates.heads, heads, g_heads),
            bases: self.bases.step(rates.heads, bases, g_bases),
            sdf: self.sdf.step(rates.sdf, sdf, g_sdf),
        }
    }
}

fn tensor3(v: &[Vec3], batch: usize, device: &Device) -> Tensor<3> {
    let flat: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
    Tensor::from_data(TensorData::new(flat, [batch, v.len() / batch, 3]), device)
}

/// One step's sampled data: per pose `surface` rows then `off` rows of points (pose-major),
/// the surface rows' normals, the off-surface points and the encoder inputs.
pub struct SampledBatch {
    pub poses: usize,
    pub inputs: Vec<f32>,
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub offs: Vec<Vec3>,
    /// Indices into `offs` of the free-space samples (known to be outside).
    pub outside: Vec<usize>,
}

impl SampledBatch {
    /// The sign constraint of every off-surface point: the prior's, and +1 on free space.
    pub fn signs(&self, prior: Option<SignPrior>) -> Option<Vec<f32>> {
        let mut is_free = vec![false; self.offs.len()];
        self.outside.iter().for_each(|&i| is_free[i] = true);
        crate::training::fit::off_surface_signs(prior, &self.offs, &is_free)
    }

    /// Points and normals as plain arrays (the training path's layout).
    pub fn arrays(&self) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        (
            self.points.iter().map(|p| p.to_array()).collect(),
            self.normals.iter().map(|p| p.to_array()).collect(),
        )
    }

    /// The step's data for the training path, over `arrays()`' buffers; `signs`: the prior's sign
    /// of each off-surface point.
    pub fn flat_batch<'a>(
        &'a self,
        points: &'a [[f32; 3]],
        normals: &'a [[f32; 3]],
        signs: Option<&'a [f32]>,
        options: &HyperFitOptions,
    ) -> HyperBatch<'a> {
        let rows = options.surface_per_pose + options.off_per_pose;
        HyperBatch {
            inputs: &self.inputs,
            points: points.chunks(rows).collect(),
            loss: IgrPoints {
                weights: options.weights,
                prior_weight: options.prior_weight,
                groups: self.poses,
                surface: options.surface_per_pose,
                off: options.off_per_pose,
                normals,
                signs,
            },
            residual_weight: options.residual_weight,
        }
    }
}

/// Draw a step's points: per pose, surface points with their normals, then off-surface points
/// (half uniform in the cube, half near the surface; `free_space_per_pose` of them from the
/// pose's free-space samples when it has any).
pub fn sample_batch(
    samples: &[&PoseSample],
    options: &HyperFitOptions,
    rng: &mut ChaCha8Rng,
) -> SampledBatch {
    let b = samples.len();
    let (s, o) = (options.surface_per_pose, options.off_per_pose);
    let mut points = Vec::with_capacity(b * (s + o));
    let mut normals = Vec::with_capacity(b * s);
    let mut offs = Vec::with_capacity(b * o);
    let mut outside = Vec::new();
    let mut inputs = Vec::new();
    for sample in samples {
        inputs.extend_from_slice(&sample.pose_input);
        let n = sample.points.len();
        for _ in 0..s {
            let i = rng.random_range(0..n);
            points.push(sample.points[i]);
            normals.push(sample.normals[i]);
        }
        let start = offs.len();
        let spec = OffSurface {
            surface: &sample.points,
            outside: &sample.free_space,
            count: o,
            free_space: options.free_space_per_pose,
            near_sigma: options.near_sigma,
        };
        let free = spec.draw(rng, &mut offs);
        points.extend_from_slice(&offs[start..]);
        outside.extend(start + o - free..start + o);
    }
    SampledBatch { poses: b, inputs, points, normals, offs, outside }
}

/// The loss of one minibatch of poses through burn's autodiff (the reference of the training
/// path, and the GPU path); returns the loss tensor and the 4 IGR terms when `log` is set.
pub fn batch_loss(
    model: &HyperNet,
    samples: &[&PoseSample],
    options: &HyperFitOptions,
    rng: &mut ChaCha8Rng,
    device: &Device,
    prior: Option<SignPrior>,
    log: bool,
) -> (Tensor<1>, [f32; 4]) {
    let batch = sample_batch(samples, options, rng);
    let signs = batch.signs(prior);
    batch_loss_of(model, &batch, options, signs, device, log)
}

/// [`batch_loss`] of drawn data (`signs`: the prior's sign of each off-surface point).
pub fn batch_loss_of(
    model: &HyperNet,
    batch: &SampledBatch,
    options: &HyperFitOptions,
    signs: Option<Vec<f32>>,
    device: &Device,
    log: bool,
) -> (Tensor<1>, [f32; 4]) {
    let b = batch.poses;
    let (s, o) = (options.surface_per_pose, options.off_per_pose);
    let input_len = batch.inputs.len() / b;
    let predicted = model
        .predict(Tensor::from_data(TensorData::new(batch.inputs.clone(), [b, input_len]), device));
    let (f, g) = crate::model::siren::batched_sdf_and_gradient(
        &predicted.weights,
        &predicted.biases,
        tensor3(&batch.points, b, device),
    );
    // Surface rows of every pose first, then the off-surface rows, as igr_loss expects.
    let f = Tensor::cat(
        vec![
            f.clone().slice([0..b, 0..s]).reshape([b * s, 1]),
            f.slice([0..b, s..s + o]).reshape([b * o, 1]),
        ],
        0,
    );
    let g = Tensor::cat(
        vec![
            g.clone().slice([0..b, 0..s]).reshape([b * s, 3]),
            g.slice([0..b, s..s + o]).reshape([b * o, 3]),
        ],
        0,
    );
    let n_off = batch.offs.len();
    let signs = signs
        .map(|v| (Tensor::from_data(TensorData::new(v, [n_off, 1]), device), options.prior_weight));
    let normals: Vec<f32> = batch.normals.iter().flat_map(|n| n.to_array()).collect();
    let loss = igr_loss(
        f,
        g,
        Tensor::from_data(TensorData::new(normals, [b * s, 3]), device),
        b * s,
        &options.weights,
        signs,
        log,
    );
    let params = model.sdf.num_params() as f32;
    // The small epsilon keeps the square root differentiable at zero (the residuals start there).
    let total =
        loss.total + (predicted.residual_sq + 1e-12).sqrt() * (options.residual_weight / params);
    (total, loss.terms)
}

/// Fit `model` to the samples for `options.steps` steps (each a random minibatch of poses,
/// epoch-shuffled). `optimisers` carry Adam's state (fresh for a new fit). Stops early when
/// `cancel` is set and returns the model as it is then. On the CPU the steps run on the
/// training path (`crate::training::step`); on a GPU through burn's autodiff.
#[allow(clippy::too_many_arguments)]
pub fn fit_hyper(
    mut model: HyperNet,
    samples: &[PoseSample],
    options: &HyperFitOptions,
    optimisers: &mut HyperOptimisers,
    device: &Device,
    prior: Option<SignPrior>,
    cancel: Option<&AtomicBool>,
    progress: Progress,
) -> HyperNet {
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let rates =
        GroupRates { heads: options.lr_heads, encoder: options.lr_encoder, sdf: options.lr_sdf };
    let per_step = options.poses_per_step.clamp(1, samples.len().max(1));
    let mut order: Vec<usize> = Vec::new();
    let log_every = (options.steps / 50).max(1);
    let mut flat = options.compute.flat_training().then(|| FlatFit::new(&model, optimisers));
    // The next step's batch, drawn while the step before it runs (the CPU path).
    let mut next: Option<SampledBatch> = None;
    for step in 0..options.steps {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            break;
        }
        let log = step % log_every == 0 || step + 1 == options.steps;
        match flat.as_mut() {
            Some(fit) => {
                let mut draw = || {
                    let batch = next_batch(samples, per_step, &mut order, &mut rng);
                    sample_batch(&batch, options, &mut rng)
                };
                let drawn = next.take().unwrap_or_else(&mut draw);
                // The next draw takes the same random numbers in the same order as one after
                // another: only the time it runs changes, beside this step's sign queries.
                // The prior is asked once a step that runs (the fit counts steps by it).
                let last = step + 1 == options.steps;
                let (loss, following) = rayon::join(
                    || {
                        let signs = drawn.signs(prior);
                        fit.step(&drawn, signs.as_deref(), options, rates, optimisers)
                    },
                    || (!last).then(draw),
                );
                next = following;
                if log {
                    progress(step, loss.total, loss.terms);
                }
            }
            None => {
                let batch = next_batch(samples, per_step, &mut order, &mut rng);
                let (loss, terms) =
                    batch_loss(&model, &batch, options, &mut rng, device, prior, log);
                if log {
                    progress(step, scalar(&loss), terms);
                }
                model = optimisers.step(model, loss.backward(), rates);
            }
        }
    }
    match flat {
        Some(fit) => crate::model::flat_params::load_flat(model, &fit.params)
            .expect("the flat parameters come from this model"),
        None => model,
    }
}

/// The next `per_step` samples of the shuffled epochs in `order` (a new epoch appended when
/// fewer are left).
fn next_batch<'s>(
    samples: &'s [PoseSample],
    per_step: usize,
    order: &mut Vec<usize>,
    rng: &mut ChaCha8Rng,
) -> Vec<&'s PoseSample> {
    if order.len() < per_step {
        let mut epoch: Vec<usize> = (0..samples.len()).collect();
        epoch.shuffle(rng);
        order.extend(epoch);
    }
    order.drain(..per_step).map(|i| &samples[i]).collect()
}

/// The CPU training path's state during a fit: the model's flat parameters and gradient.
struct FlatFit {
    params: Vec<f32>,
    grad: Vec<f32>,
}

impl FlatFit {
    fn new(model: &HyperNet, optimisers: &mut HyperOptimisers) -> FlatFit {
        let config = model.config();
        if optimisers.flat.as_ref().is_none_or(|(g, _)| g.layout().config != config) {
            optimisers.flat = Some((HyperGradient::new(&config), Adam::default()));
        }
        let params = crate::model::flat_params::flatten(model);
        FlatFit { grad: vec![0f32; params.len()], params }
    }

    fn step(
        &mut self,
        drawn: &SampledBatch,
        signs: Option<&[f32]>,
        options: &HyperFitOptions,
        rates: GroupRates,
        optimisers: &mut HyperOptimisers,
    ) -> StepLoss {
        let (gradient, adam) = optimisers.flat.as_mut().expect("set up by FlatFit::new");
        let (points, normals) = drawn.arrays();
        let batch = drawn.flat_batch(&points, &normals, signs, options);
        let lay = gradient.layout();
        let groups = [
            (lay.encoder_range.clone(), rates.encoder),
            (lay.heads_range.clone(), rates.heads),
            (lay.bases_range.clone(), rates.heads),
            (lay.sdf_range.clone(), rates.sdf),
        ];
        let train_encoder = rates.encoder > 0.0;
        gradient.step(&mut self.params, &batch, train_encoder, &mut self.grad, adam, &groups)
    }
}
