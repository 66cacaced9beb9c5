//! The training path (`avatar_neural::training::step`) against burn's autodiff: the loss and every
//! parameter tensor's gradient agree to a relative 1e-4 (|ours - burn| / |burn| per tensor),
//! on the compact and paper presets, with and without the normal term, the off-surface prior
//! and the residual regulariser, for one and several poses; the static SIREN step likewise.
//! The networks are perturbed away from their initialisation so that every residual, head and
//! base is non-zero. Each check computes burn's reference once and holds every kernel path
//! to it (AVX-512, AVX2 + FMA and the portable loops, those this CPU has), each chosen
//! explicitly with `set_kernel_path`: no environment switch.

use avatar_core::body::{BodyParams, NUM_JOINTS};
use avatar_core::canonical::Normalisation;
use avatar_neural::model::flat_params::{flat_gradients, flatten, load_flat};
use avatar_neural::model::siren::W0;
use avatar_neural::training::hyper_fit::{SampledBatch, batch_loss_of, sample_batch};
use avatar_neural::training::loss::{IgrWeights, igr_loss, scalar};
use avatar_neural::training::step::{
    Adam, HyperBatch, HyperGradient, HyperLayout, IgrPoints, KernelPath, SirenGradient, SirenShape,
    kernel_name_of, set_kernel_path,
};
use avatar_neural::*;
use burn::module::Module;
use burn::optim::GradientsParams;
use burn::tensor::{Tensor, TensorData};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The kernel paths process-wide: one test at a time sets one and computes on it (the burn
/// references run outside the lock, in parallel).
static KERNELS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Run `f` on every kernel path this CPU has (AVX-512, AVX2 + FMA, the portable loops; a path
/// the CPU lacks falls back to one already run and is skipped), each set for the process
/// while `f` runs; `f` gets the kernels' name for its messages.
fn on_every_path(mut f: impl FnMut(&str)) {
    let mut done = Vec::new();
    for path in [KernelPath::Fastest, KernelPath::Avx2, KernelPath::Portable] {
        let name = kernel_name_of(path);
        if done.contains(&name) {
            continue;
        }
        done.push(name);
        let _only = KERNELS.lock().unwrap_or_else(|e| e.into_inner());
        set_kernel_path(path);
        f(name);
        set_kernel_path(KernelPath::Fastest);
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        assert!(done.contains(&"AVX2"), "the AVX2 kernels did not run: {done:?}");
    }
}

fn pose_samples(count: usize, encoding: PoseEncoding, points: usize) -> Vec<PoseSample> {
    let body = avatar_core::body::open_body_ref();
    let rest = body.shaped_vertices(&[]);
    let joints = body.regress_joints(&rest);
    let norm = Normalisation::from_body(&rest);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    (0..count)
        .map(|k| {
            let mut p = BodyParams::default();
            for j in 1..NUM_JOINTS {
                let t = (k * 31 + j * 7) as f32;
                p.pose[j] = Vec3::new((t * 0.37).sin(), (t * 0.71).cos(), (t * 0.13).sin()) * 0.4;
            }
            // Points on a wobbly sphere with its normals (any oriented point set will do).
            let (pts, nrm): (Vec<Vec3>, Vec<Vec3>) = (0..points)
                .map(|_| {
                    let d = Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    )
                    .normalize_or(Vec3::X);
                    (d * (0.5 + 0.05 * (d.x * 5.0).sin()), d)
                })
                .unzip();
            PoseSample {
                pose_input: encoding.input(&p, &joints, &norm),
                points: pts,
                normals: nrm,
                free_space: Vec::new(),
            }
        })
        .collect()
}

/// A network with every parameter moved off its initialisation (so the zero-initialised last
/// head layers predict non-zero residuals).
fn perturbed(config: &HyperConfig, seed: u64) -> HyperNet {
    // Residuals of about a tenth of the SIREN's weights (larger ones make the SIREN chaotic,
    // |grad f| in the hundreds, where float rounding alone moves its values by 1e-3): the
    // heads' outputs sum head_hidden products of activations of about 0.6, and a low-rank
    // residual multiplies them by U (entries 1/sqrt(fan_in), `rank` terms).
    let weight_scale = (6.0 / config.siren.hidden as f32).sqrt() / W0;
    let low_rank = config.rank.map_or(1.0, |r| (r as f32 / config.siren.hidden as f32).sqrt());
    let head_scale = 0.1 * weight_scale / (0.6 * (config.head_hidden as f32).sqrt() * low_rank);
    let device = cpu_training_device();
    let net = config.init(config.siren.init(seed, &device), seed, &device);
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
    let layout = avatar_neural::training::step::HyperLayout::new(config);
    let mut flat = flatten(&net);
    for (i, v) in flat.iter_mut().enumerate() {
        // Small moves for the heads' outputs (their products scale every SIREN weight).
        if layout.sdf_range.contains(&i) {
            // The SIREN keeps its initialisation's scale (a larger one is chaotic at w0 = 30,
            // where float rounding alone moves gradients by 1e-4).
            *v *= 1.0 + rng.random_range(-0.2..0.2);
        } else {
            let scale = if layout.heads_range.contains(&i) { head_scale } else { 1e-2 };
            *v += rng.random_range(-scale..scale);
        }
    }
    load_flat(net, &flat).unwrap()
}

fn relative(ours: &[f32], burn: &[f32]) -> f64 {
    let diff: f64 =
        ours.iter().zip(burn).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>().sqrt();
    let norm: f64 = burn.iter().map(|b| (*b as f64).powi(2)).sum::<f64>().sqrt();
    diff / norm.max(1e-30)
}

/// Compare per parameter tensor (every tensor's gradient must be non-trivial somewhere).
fn assert_tensors_agree(
    net: &HyperNet,
    ours: &[f32],
    burn: &[f32],
    what: &str,
    train_encoder: bool,
) {
    let mut offset = 0;
    let mut sizes = Vec::new();
    struct Sizes<'a>(&'a mut Vec<usize>);
    impl burn::module::ModuleVisitor for Sizes<'_> {
        fn visit_float<const D: usize>(&mut self, p: &burn::module::Param<Tensor<D>>) {
            self.0.push(p.val().shape().num_elements());
        }
    }
    net.visit(&mut Sizes(&mut sizes));
    let encoder = net.encoder.num_params();
    let mut failures = Vec::new();
    for (k, n) in sizes.into_iter().enumerate() {
        let (o, b) = (&ours[offset..offset + n], &burn[offset..offset + n]);
        if offset < encoder && !train_encoder {
            assert!(
                o.iter().all(|v| *v == 0.0),
                "{what}: frozen encoder tensor {k} has a gradient"
            );
        } else {
            let r = relative(o, b);
            if !(r < 1e-4) {
                failures.push(format!("tensor {k} ({n} values) differs from burn by {r:e}"));
            }
        }
        offset += n;
    }
    assert!(failures.is_empty(), "{what}: {}", failures.join("; "));
}

fn check_hyper(
    config: HyperConfig,
    poses: usize,
    options: &HyperFitOptions,
    with_prior: bool,
    train_encoder: bool,
    what: &str,
) {
    let samples = pose_samples(poses, config.encoding, 400);
    let refs: Vec<&PoseSample> = samples.iter().collect();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let drawn: SampledBatch = sample_batch(&refs, options, &mut rng);
    let signs: Option<Vec<f32>> = with_prior.then(|| {
        drawn
            .offs
            .iter()
            .map(|p| {
                if p.length() > 0.55 {
                    1.0
                } else if p.length() < 0.45 {
                    -1.0
                } else {
                    0.0
                }
            })
            .collect()
    });
    let net = perturbed(&config, 1);

    let device = cpu_training_device();
    let (loss, _) = batch_loss_of(&net, &drawn, options, signs.clone(), &device, false);
    let burn_loss = scalar(&loss);
    let burn_grad = flat_gradients(&net, &GradientsParams::from_grads(loss.backward(), &net));

    let (points, normals) = drawn.arrays();
    let batch = drawn.flat_batch(&points, &normals, signs.as_deref(), options);
    let flat = flatten(&net);
    on_every_path(|kernels| {
        let what = format!("{what} ({kernels} kernels)");
        let mut gradient = HyperGradient::new(&config);
        let mut ours = vec![0f32; config.num_params()];
        let l = gradient.compute(&flat, &batch, train_encoder, &mut ours);
        assert!(
            ((l.total - burn_loss) / burn_loss).abs() < 1e-4,
            "{what}: loss {} vs burn {burn_loss}",
            l.total
        );
        assert_tensors_agree(&net, &ours, &burn_grad, &what, train_encoder);
        if with_prior {
            fused_steps_match(&config, &flat, &batch, train_encoder, &what);
        }
    });
}

/// Two steps of `HyperGradient::step` (Adam fused into the heads' output weights' gradient)
/// give the parameters of two steps of `compute` then `Adam::step` to the bit, every
/// parameter (both steps: the first starts the moments, the second decays them).
fn fused_steps_match(
    config: &HyperConfig,
    flat: &[f32],
    batch: &HyperBatch,
    train_encoder: bool,
    what: &str,
) {
    let layout = HyperLayout::new(config);
    let rate = |r: f64| if train_encoder { r } else { 0.0 };
    let groups = [
        (layout.encoder_range.clone(), rate(1e-4)),
        (layout.heads_range.clone(), 3e-5),
        (layout.bases_range.clone(), 3e-5),
        (layout.sdf_range.clone(), 1e-4),
    ];
    let (mut plain, mut fused) = (flat.to_vec(), flat.to_vec());
    let (mut adam_plain, mut adam_fused) = (Adam::default(), Adam::default());
    let (mut g_plain, mut g_fused) = (vec![0f32; flat.len()], vec![0f32; flat.len()]);
    let (mut gradient_plain, mut gradient_fused) =
        (HyperGradient::new(config), HyperGradient::new(config).with_fused_adam(true));
    for step in 0..2 {
        let a = gradient_plain.compute(&plain, batch, train_encoder, &mut g_plain);
        adam_plain.step(&mut plain, &g_plain, &groups);
        let b = gradient_fused.step(
            &mut fused,
            batch,
            train_encoder,
            &mut g_fused,
            &mut adam_fused,
            &groups,
        );
        assert_eq!(a, b, "{what}: the loss of step {step}");
    }
    let moved = plain.iter().zip(flat).filter(|(a, b)| a != b).count();
    assert!(moved > flat.len() / 2, "{what}: {moved} of {} parameters moved", flat.len());
    let differ = plain.iter().zip(&fused).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differ, 0, "{what}: parameters after two fused steps differ from compute + Adam");
}

fn small_step(poses: usize) -> HyperFitOptions {
    HyperFitOptions {
        poses_per_step: poses,
        surface_per_pose: 300,
        off_per_pose: 300,
        ..HyperFitOptions::default()
    }
}

#[test]
fn compact_step_gradients_match_burn_in_every_variant() {
    let config = HyperConfig::compact();
    let with_normals = HyperFitOptions { weights: IgrWeights::default(), ..small_step(3) };
    let no_residual = HyperFitOptions { residual_weight: 0.0, ..small_step(3) };
    check_hyper(
        config,
        3,
        &small_step(3),
        true,
        true,
        "compact, 3 poses, prior, regulariser, encoder",
    );
    check_hyper(
        config,
        3,
        &with_normals,
        false,
        false,
        "compact, 3 poses, normal term, no prior, frozen encoder",
    );
    check_hyper(config, 1, &no_residual, true, true, "compact, 1 pose, no regulariser");
    check_hyper(config, 1, &with_normals, true, false, "compact, 1 pose, normal term");
}

#[test]
fn other_shapes_match_burn_quaternion_encoding_and_full_residuals() {
    let quaternion = HyperConfig { encoding: PoseEncoding::Quaternion, ..HyperConfig::compact() };
    check_hyper(quaternion, 2, &small_step(2), true, true, "quaternion encoding");
    let full = HyperConfig {
        siren: SirenConfig { hidden: 32, layers: 3 },
        head_hidden: 16,
        rank: None,
        encoding: PoseEncoding::Hierarchical,
    };
    let with_normals = HyperFitOptions { weights: IgrWeights::default(), ..small_step(2) };
    check_hyper(full, 2, &with_normals, true, true, "full residuals, normal term");
}

#[test]
fn paper_step_gradients_match_burn() {
    // 85.6 M parameters: few points keep burn's reference step affordable in the test.
    let options = HyperFitOptions {
        poses_per_step: 2,
        surface_per_pose: 256,
        off_per_pose: 256,
        weights: IgrWeights::default(),
        ..HyperFitOptions::default()
    };
    check_hyper(
        HyperConfig::paper(),
        2,
        &options,
        true,
        true,
        "paper, 2 poses, normal term, prior",
    );
    let options = HyperFitOptions {
        poses_per_step: 1,
        surface_per_pose: 48,
        off_per_pose: 48,
        residual_weight: 0.0,
        ..HyperFitOptions::default()
    };
    check_hyper(
        HyperConfig::paper(),
        1,
        &options,
        false,
        false,
        "paper, 1 pose, no normal term, no regulariser",
    );
}

#[test]
fn static_siren_step_gradients_match_burn() {
    let device = cpu_training_device();
    for (config, normal_weight, prior) in [
        (SirenConfig::compact(), 0.0, true),
        (SirenConfig::compact(), 1e2, false),
        (SirenConfig::paper(), 1e2, true),
    ] {
        let siren = config.init(4, &device);
        let samples = pose_samples(1, PoseEncoding::Quaternion, 2000);
        let options = FitOptions {
            batch: 700,
            off_surface: 500,
            weights: IgrWeights { normal: normal_weight, ..IgrWeights::default() },
            ..FitOptions::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (surface, surface_n, off, _) = avatar_neural::training::fit::sample_step(
            &samples[0].points,
            &samples[0].normals,
            &[],
            &options,
            &mut rng,
        );
        let signs: Option<Vec<f32>> =
            prior.then(|| off.iter().map(|p| if p.length() > 0.55 { 1.0 } else { -1.0 }).collect());
        let mut all = surface.clone();
        all.extend(&off);
        let tensor = |v: &[Vec3]| {
            Tensor::<2>::from_data(
                TensorData::new(
                    v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>(),
                    [v.len(), 3],
                ),
                &device,
            )
        };
        let (f, g) = siren.sdf_and_gradient(tensor(&all));
        let sign_tensor = signs.clone().map(|s| {
            (
                Tensor::<2>::from_data(TensorData::new(s, [off.len(), 1]), &device),
                options.prior_weight,
            )
        });
        let loss =
            igr_loss(f, g, tensor(&surface_n), surface.len(), &options.weights, sign_tensor, false);
        let burn_loss = scalar(&loss.total);
        let burn_grad =
            flat_gradients(&siren, &GradientsParams::from_grads(loss.total.backward(), &siren));

        let pts: Vec<[f32; 3]> = all.iter().map(|p| p.to_array()).collect();
        let normals: Vec<[f32; 3]> = surface_n.iter().map(|p| p.to_array()).collect();
        let points = IgrPoints {
            weights: options.weights,
            prior_weight: options.prior_weight,
            groups: 1,
            surface: surface.len(),
            off: off.len(),
            normals: &normals,
            signs: signs.as_deref(),
        };
        let flat = flatten(&siren);
        on_every_path(|kernels| {
            let mut ours = vec![0f32; config.num_params()];
            let l = SirenGradient::new(SirenShape::of(&config))
                .compute(&flat, &pts, &points, &mut ours);
            assert!(
                ((l.total - burn_loss) / burn_loss).abs() < 1e-4,
                "{config:?} ({kernels} kernels): loss {} vs burn {burn_loss}",
                l.total
            );
            let shape = SirenShape::of(&config);
            for k in 0..shape.layers() {
                for r in [shape.w_range(k), shape.b_range(k)] {
                    let rel = relative(&ours[r.clone()], &burn_grad[r.clone()]);
                    assert!(
                        rel < 1e-4,
                        "{config:?} normal {normal_weight} prior {prior} ({kernels} kernels): \
                         layer {k} {r:?} differs by {rel:e}"
                    );
                }
            }
        });
    }
}
