//! Fitting a SIREN SDF to oriented points with the IGR loss (Adam): the inner loop of
//! meta-learning and of fine-tuning the static SDF.

use crate::data::off_surface::OffSurface;
use crate::model::siren::Siren;
use crate::training::loss::{IgrWeights, igr_loss};
use crate::training::step::{Adam, IgrPoints, SirenGradient, SirenShape};
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::atomic::{AtomicBool, Ordering};

#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    pub steps: usize,
    pub learning_rate: f64,
    /// Surface points per step (sampled from the given points).
    pub batch: usize,
    /// Off-surface points per step: half uniform in [-1, 1]^3, half near the surface ...
    pub off_surface: usize,
    /// ... less this many drawn from the free-space samples (when there are any), which
    /// must be outside.
    pub free_space: usize,
    /// Standard deviation of the near-surface samples (normalised units).
    pub near_sigma: f32,
    pub weights: IgrWeights,
    /// Weight of the off-surface sign prior (when a prior is given).
    pub prior_weight: f32,
    pub seed: u64,
    /// Where the steps run.
    pub compute: crate::compute::Compute,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            steps: 500,
            learning_rate: 1e-4,
            batch: 2000,
            off_surface: 2000,
            free_space: 0,
            near_sigma: 0.02,
            weights: IgrWeights::default(),
            prior_weight: 1000.0,
            seed: 0,
            compute: crate::compute::Compute::Cpu,
        }
    }
}

/// Sign constraints of off-surface points (+1 outside, -1 inside, 0 unknown).
pub type SignPrior<'a> = &'a (dyn Fn(&[Vec3]) -> Vec<f32> + Sync);

/// The sign constraint of every off-surface point: +1 where `free` (a free-space sample: known
/// to be outside), else the prior's (0 without one); `None` when neither constrains anything.
/// The prior is asked once (a fit counts its calls as steps), and only for the other points:
/// its closest-point queries are a tenth of a training step.
pub fn off_surface_signs(
    prior: Option<SignPrior>,
    offs: &[Vec3],
    free: &[bool],
) -> Option<Vec<f32>> {
    if prior.is_none() && !free.contains(&true) {
        return None;
    }
    let asked: Vec<Vec3> = offs.iter().zip(free).filter(|(_, f)| !**f).map(|(p, _)| *p).collect();
    let mut from_prior = prior.map_or_else(|| vec![0.0; asked.len()], |p| p(&asked)).into_iter();
    Some(free.iter().map(|&f| if f { 1.0 } else { from_prior.next().unwrap_or(0.0) }).collect())
}

/// Progress of a fit: step, total loss and the four IGR terms.
pub type Progress<'a> = &'a mut dyn FnMut(usize, f32, [f32; 4]);

fn to_tensor(v: &[Vec3], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
    Tensor::from_data(TensorData::new(flat, [v.len(), 3]), device)
}

/// Adam's state of a SIREN fit, kept across calls so that a fit can run in chunks
/// (`crate::avatar::fitting`); a fresh one starts a new fit.
#[derive(Default)]
pub struct SdfOptimiser {
    burn: Option<ModuleOptimizer>,
    flat: Option<(SirenGradient, Adam)>,
}

/// Fit `model` to points (normalised space) with normals, and free-space samples `outside`
/// (constrained to be outside; may be empty). Stops early when `cancel` is set and
/// returns the model as it is then (the partial result stays usable).
#[allow(clippy::too_many_arguments)]
pub fn fit_sdf(
    model: Siren,
    points: &[Vec3],
    normals: &[Vec3],
    outside: &[Vec3],
    options: &FitOptions,
    device: &Device,
    prior: Option<SignPrior>,
    cancel: Option<&AtomicBool>,
    progress: Progress,
) -> Siren {
    fit_sdf_resuming(
        model,
        points,
        normals,
        outside,
        options,
        &mut SdfOptimiser::default(),
        device,
        prior,
        cancel,
        progress,
    )
}

/// [`fit_sdf`] continuing from `optimiser`'s state (Adam's moments and step count).
#[allow(clippy::too_many_arguments)]
pub fn fit_sdf_resuming(
    mut model: Siren,
    points: &[Vec3],
    normals: &[Vec3],
    outside: &[Vec3],
    options: &FitOptions,
    optimiser: &mut SdfOptimiser,
    device: &Device,
    prior: Option<SignPrior>,
    cancel: Option<&AtomicBool>,
    progress: Progress,
) -> Siren {
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let optim = optimiser.burn.get_or_insert_with(|| AdamConfig::new().init());
    let log_every = (options.steps / 50).max(1);
    // On the CPU the steps run on the training path (`crate::training::step`), on a GPU through burn.
    let mut flat = options.compute.flat_training().then(|| {
        let (gradient, adam) = optimiser.flat.get_or_insert_with(|| {
            (SirenGradient::new(SirenShape::of(&model.config())), Adam::default())
        });
        let params = crate::model::flat_params::flatten(&model);
        (gradient, adam, vec![0f32; params.len()], params)
    });
    for step in 0..options.steps {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            break;
        }
        let (surface, surface_n, off, free) =
            sample_step(points, normals, outside, options, &mut rng);
        // The free-space samples are the last `free` off-surface points.
        let is_free: Vec<bool> = (0..off.len()).map(|k| k >= off.len() - free).collect();
        let signs = off_surface_signs(prior, &off, &is_free);
        let log = step % log_every == 0 || step + 1 == options.steps;
        if let Some((gradient, adam, grad, params)) = flat.as_mut() {
            let mut all: Vec<[f32; 3]> = surface.iter().map(|p| p.to_array()).collect();
            all.extend(off.iter().map(|p| p.to_array()));
            let normals: Vec<[f32; 3]> = surface_n.iter().map(|n| n.to_array()).collect();
            let loss = IgrPoints {
                weights: options.weights,
                prior_weight: options.prior_weight,
                groups: 1,
                surface: surface.len(),
                off: off.len(),
                normals: &normals,
                signs: signs.as_deref(),
            };
            let l = gradient.compute(params, &all, &loss, grad);
            if log {
                progress(step, l.total, l.terms);
            }
            let all = 0..params.len();
            adam.step(params, grad, &[(all, options.learning_rate)]);
            continue;
        }
        let signs = signs.map(|s| {
            (Tensor::from_data(TensorData::new(s, [off.len(), 1]), device), options.prior_weight)
        });
        let mut all = surface.clone();
        all.extend(off);
        let x = to_tensor(&all, device);
        let (f, g) = model.sdf_and_gradient(x);
        let loss = igr_loss(
            f,
            g,
            to_tensor(&surface_n, device),
            surface.len(),
            &options.weights,
            signs,
            log,
        );
        if log {
            progress(step, crate::training::loss::scalar(&loss.total), loss.terms);
        }
        let grads = loss.total.backward();
        let grads = GradientsParams::from_grads(grads, &model);
        model = optim.step(options.learning_rate, model, grads);
    }
    match flat {
        Some((_, _, _, params)) => crate::model::flat_params::load_flat(model, &params)
            .expect("the flat parameters come from this model"),
        None => model,
    }
}

/// A step's points: surface points with their normals, and off-surface points (half uniform
/// in [-1, 1]^3, half near the surface, then `free_space` from `outside`), with the count of
/// free-space points at the end of the off-surface points.
pub fn sample_step(
    points: &[Vec3],
    normals: &[Vec3],
    outside: &[Vec3],
    options: &FitOptions,
    rng: &mut ChaCha8Rng,
) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec3>, usize) {
    let idx: Vec<usize> =
        (0..options.batch.min(points.len())).map(|_| rng.random_range(0..points.len())).collect();
    let surface: Vec<Vec3> = idx.iter().map(|&i| points[i]).collect();
    let surface_n: Vec<Vec3> = idx.iter().map(|&i| normals[i]).collect();
    let mut off = Vec::new();
    let spec = OffSurface {
        surface: points,
        outside,
        count: options.off_surface,
        free_space: options.free_space,
        near_sigma: options.near_sigma,
    };
    let free = spec.draw(rng, &mut off);
    (surface, surface_n, off, free)
}

/// SDF values of points (no gradient), through the fast evaluation path (`siren_eval`).
pub fn sdf_values(model: &Siren, points: &[Vec3]) -> Vec<f32> {
    crate::model::siren_eval::SirenEval::of(model)
        .sdf(&points.iter().map(|p| p.to_array()).collect::<Vec<_>>())
}
