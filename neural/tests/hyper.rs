//! The hypernetwork on tiny configurations: at initialisation it reproduces the meta-SDF for
//! every pose; its batched forward-mode gradients match finite differences; the parameter
//! counts of the presets; a short fine-tune on the demo capture lowers the loss; a saved and
//! reloaded avatar gives identical SDF values and bad files are refused.

use avatar_core::body::{BodyParams, NUM_JOINTS};
use avatar_core::canonical::FieldCache;
use avatar_core::canonical::Normalisation;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::model::flat_params::{flatten, load_flat};
use avatar_neural::training::hyper_fit::batch_loss;
use avatar_neural::*;
use burn::module::Module;
use burn::tensor::{Tensor, TensorData};
use glam::Vec3;
use rand::SeedableRng;
use std::path::Path;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn tiny(rank: Option<usize>, encoding: PoseEncoding) -> HyperConfig {
    HyperConfig { siren: SirenConfig { hidden: 24, layers: 2 }, head_hidden: 16, rank, encoding }
}

fn poses() -> Vec<BodyParams> {
    (0..4)
        .map(|k| {
            let mut p = BodyParams::default();
            for j in 1..NUM_JOINTS {
                let t = (k * 31 + j * 7) as f32;
                p.pose[j] = Vec3::new((t * 0.37).sin(), (t * 0.71).cos(), (t * 0.13).sin()) * 0.4;
            }
            p
        })
        .collect()
}

fn joints() -> ([Vec3; NUM_JOINTS], Normalisation) {
    let body = avatar_core::body::open_body_ref();
    let rest = body.shaped_vertices(&[]);
    (body.regress_joints(&rest), Normalisation::from_body(&rest))
}

fn probe(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            Vec3::new(
                (i as f32 * 0.37).sin() * 0.7,
                (i as f32 * 0.11).cos() * 0.9,
                (i as f32 * 0.23).sin() * 0.5,
            )
        })
        .collect()
}

fn sdf_of(layers: &(Vec<Tensor<2>>, Vec<Tensor<1>>), x: &[Vec3]) -> Vec<f32> {
    let device = cpu_device();
    let t = Tensor::from_data(
        TensorData::new(x.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>(), [x.len(), 3]),
        &device,
    );
    avatar_neural::model::siren::sdf_only(&layers.0, &layers.1, t)
        .into_data()
        .as_slice::<f32>()
        .unwrap()
        .to_vec()
}

#[test]
fn at_initialisation_every_pose_gets_the_meta_sdf() {
    let device = cpu_device();
    let (rest_joints, norm) = joints();
    let x = probe(64);
    for config in [
        tiny(Some(4), PoseEncoding::Hierarchical),
        tiny(None, PoseEncoding::Hierarchical),
        tiny(Some(4), PoseEncoding::Quaternion),
    ] {
        let meta = config.siren.init(3, &device);
        let expected = sdf_values(&meta, &x);
        let net = config.init(meta, 5, &device);
        for p in poses() {
            let input = config.encoding.input(&p, &rest_joints, &norm);
            assert_eq!(input.len(), config.encoding.input_len());
            let got = sdf_of(&net.siren_for(&input, &device), &x);
            for (a, b) in got.iter().zip(&expected) {
                assert!((a - b).abs() < 1e-6, "{config:?}: {a} vs meta-SDF {b}");
            }
        }
    }
}

/// A network whose heads' last layers are no longer zero: the SDF then depends on the pose.
fn perturbed(config: HyperConfig) -> HyperNet {
    let device = cpu_device();
    let net = config.init(config.siren.init(3, &device), 5, &device);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let flat: Vec<f32> = flatten(&net)
        .into_iter()
        .map(|v| if v == 0.0 { rand::Rng::random_range(&mut rng, -0.02..0.02) } else { v })
        .collect();
    load_flat(net, &flat).unwrap()
}

#[test]
fn batched_forward_mode_gradients_match_finite_differences_and_poses_differ() {
    let device = cpu_device();
    let config = tiny(Some(4), PoseEncoding::Hierarchical);
    let net = perturbed(config);
    let (rest_joints, norm) = joints();
    let ps = poses();
    let inputs: Vec<f32> =
        ps.iter().flat_map(|p| config.encoding.input(p, &rest_joints, &norm)).collect();
    let predicted = net.predict(Tensor::from_data(
        TensorData::new(inputs, [ps.len(), config.encoding.input_len()]),
        &device,
    ));
    let x = probe(10);
    let xs: Vec<f32> = (0..ps.len()).flat_map(|_| x.iter().flat_map(|p| p.to_array())).collect();
    let (f, g) = batched_sdf_and_gradient(
        &predicted.weights,
        &predicted.biases,
        Tensor::from_data(TensorData::new(xs, [ps.len(), x.len(), 3]), &device),
    );
    let f = f.into_data().as_slice::<f32>().unwrap().to_vec();
    let g = g.into_data().as_slice::<f32>().unwrap().to_vec();
    let h = 1e-3;
    for (b, p) in ps.iter().enumerate() {
        let layers = net.siren_for(&config.encoding.input(p, &rest_joints, &norm), &device);
        let plain = sdf_of(&layers, &x);
        for (i, q) in x.iter().enumerate() {
            assert!(
                (f[b * x.len() + i] - plain[i]).abs() < 1e-5,
                "batched and single-pose values differ"
            );
            for a in 0..3 {
                let mut e = Vec3::ZERO;
                e[a] = h;
                let fd =
                    (sdf_of(&layers, &[*q + e])[0] - sdf_of(&layers, &[*q - e])[0]) / (2.0 * h);
                let an = g[(b * x.len() + i) * 3 + a];
                assert!(
                    (fd - an).abs() < 2e-2 * (1.0 + an.abs()),
                    "pose {b} point {i} axis {a}: {an} vs {fd}"
                );
            }
        }
    }
    let spread = (0..x.len()).map(|i| (f[i] - f[x.len() + i]).abs()).fold(0f32, f32::max);
    assert!(spread > 1e-4, "a perturbed hypernetwork should give pose-dependent values ({spread})");
}

#[test]
fn preset_parameter_counts() {
    // The paper's heads and encoder: 85,599,489 + 13,734 (reference implementation).
    let paper = HyperConfig::paper();
    assert_eq!(paper.num_params() - paper.siren.num_params(), 85_599_489 + 13_734);
    assert_eq!(paper.siren.num_params(), 330_241);
    // The analytic counts match the modules for the compact preset and the tiny ones.
    let device = cpu_device();
    for config in [
        HyperConfig::compact(),
        tiny(Some(4), PoseEncoding::Quaternion),
        tiny(None, PoseEncoding::Hierarchical),
    ] {
        let net = config.init(config.siren.init(0, &device), 0, &device);
        assert_eq!(net.num_params(), config.num_params(), "{config:?}");
    }
    // The shipped checkpoint stays under 25 MB.
    assert!(
        4 * (HyperConfig::compact().num_params() + SirenConfig::compact().num_params())
            < 25_000_000
    );
}

#[test]
fn a_short_fine_tune_lowers_the_loss_on_the_demo_capture() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let capture = CapturePoints::open(&demo, 3, &field_cache()).unwrap();
    let config = HyperConfig {
        siren: SirenConfig { hidden: 32, layers: 3 },
        head_hidden: 16,
        rank: Some(4),
        encoding: PoseEncoding::Hierarchical,
    };
    let options = HyperFitOptions {
        steps: 80,
        poses_per_step: 3,
        surface_per_pose: 400,
        off_per_pose: 400,
        seed: 1,
        ..HyperFitOptions::default()
    };
    let init = Init::Scratch { config, seed: 2 };
    // The loss of a fixed evaluation batch before and after.
    let samples = capture.pose_samples(config.encoding);
    let refs: Vec<&PoseSample> = samples.iter().collect();
    let device = cpu_training_device();
    let score = |net: &HyperNet| {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77);
        let (loss, _) = batch_loss(net, &refs, &options, &mut rng, &device, None, false);
        avatar_neural::training::loss::scalar(&loss)
    };
    let before = score(&config.init(config.siren.init(2, &device), 2, &device));
    let mut logged = Vec::new();
    let (avatar, report) =
        MetaAvatar::fit_points(&capture, &init, &options, None, &mut |_, l, _| logged.push(l));
    assert_eq!(report.frames, 3);
    let trained = avatar_neural::training::meta_training::trainable_hyper(
        &config,
        &flatten(&avatar.model),
        0,
    )
    .unwrap();
    let after = score(&trained);
    assert!(after < 0.6 * before, "loss {before} -> {after}");
    assert!(logged.iter().all(|l| l.is_finite()));
}

#[test]
fn a_saved_and_reloaded_meta_avatar_gives_identical_sdf_values_and_bad_files_are_refused() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let config = HyperConfig {
        siren: SirenConfig { hidden: 16, layers: 2 },
        head_hidden: 8,
        rank: Some(2),
        encoding: PoseEncoding::Hierarchical,
    };
    let options = HyperFitOptions {
        steps: 3,
        poses_per_step: 2,
        surface_per_pose: 200,
        off_per_pose: 200,
        ..HyperFitOptions::default()
    };
    let (avatar, _) = MetaAvatar::fit_capture(
        &demo,
        2,
        &field_cache(),
        &Init::Scratch { config, seed: 0 },
        &options,
        None,
        &mut |_, _, _| {},
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("me.avatar");
    avatar.save(&path).unwrap();
    let back = MetaAvatar::load(&path, &field_cache()).unwrap();
    use avatar_core::avatar::AvatarSource;
    let x: Vec<Vec3> = probe(100).into_iter().map(|p| p * 0.8).collect();
    for p in poses() {
        assert_eq!(avatar.sdf(&p, &x).unwrap(), back.sdf(&p, &x).unwrap());
    }
    assert!(matches!(AnyAvatar::load(&path, &field_cache()).unwrap(), AnyAvatar::Meta(_)));

    let bytes = std::fs::read(&path).unwrap();
    let at = bytes.windows(11).position(|w| w == b"\"version\":1").unwrap();
    let mut other = bytes.clone();
    other[at + 10] = b'9';
    let p = dir.path().join("other.avatar");
    std::fs::write(&p, &other).unwrap();
    let err = MetaAvatar::load(&p, &field_cache()).err().unwrap().to_string();
    assert!(err.contains("other.avatar") && err.contains("version 9"), "{err}");
    let cut = dir.path().join("cut.avatar");
    std::fs::write(&cut, &bytes[..bytes.len() - 40]).unwrap();
    let err = MetaAvatar::load(&cut, &field_cache()).err().unwrap().to_string();
    assert!(err.contains("cut.avatar") && err.contains("truncated"), "{err}");
    // Absurd layer sizes in the header: a clean error naming the file, no overflow.
    let mut absurd = avatar.header.clone();
    absurd.config.siren.hidden = usize::MAX / 3;
    let p = dir.path().join("absurd.avatar");
    avatar_neural::model::weights_file::write(&p, &absurd, &[0.0f32; 16]).unwrap();
    let err = MetaAvatar::load(&p, &field_cache()).err().unwrap().to_string();
    assert!(err.contains("absurd.avatar") && err.contains("out of range"), "{err}");
    // A static avatar is not a meta avatar.
    let err = StaticAvatar::load(&path, &field_cache()).err().unwrap().to_string();
    assert!(err.contains("me.avatar") && err.contains("meta-hyper"), "{err}");
}

#[test]
fn the_shipped_model_parses_with_the_compact_configuration() {
    let m = MetaModel::shipped();
    assert_eq!(m.header.config, HyperConfig::compact());
    assert_eq!(
        (m.hyper.len(), m.static_sdf.len()),
        (HyperConfig::compact().num_params(), SirenConfig::compact().num_params())
    );
    assert!(m.header.provenance.contains("meta-train seed 0"), "{}", m.header.provenance);
}
