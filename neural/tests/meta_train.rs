//! Meta-training on a tiny configuration: deterministic for a seed, killed runs resume from
//! their checkpoint without repeating iterations, a checkpoint of other options is refused, and
//! the data folder round-trips; Alg. 2 can start from another model's static meta-SDF.

use avatar_neural::data::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::training::meta_training::{MODEL_FILE, MetaOptions, meta_train};
use avatar_neural::*;
use std::sync::atomic::{AtomicBool, Ordering};

fn options() -> MetaOptions {
    MetaOptions {
        config: HyperConfig {
            siren: SirenConfig { hidden: 16, layers: 2 },
            head_hidden: 8,
            rank: Some(2),
            encoding: PoseEncoding::Hierarchical,
        },
        sdf_iterations: 3,
        sdf_inner_steps: 2,
        hyper_iterations: 4,
        hyper_max_task: 2,
        hyper_inner_epochs: 1,
        hyper_inner: HyperFitOptions {
            poses_per_step: 2,
            surface_per_pose: 100,
            off_per_pose: 100,
            ..HyperFitOptions::default()
        },
        points_per_step: 100,
        checkpoint_every: 1,
        seed: 4,
        ..MetaOptions::default()
    }
}

fn data(dir: &std::path::Path) -> MetaData {
    let config = MetaDataConfig {
        subjects: 1,
        outfits: vec!["tshirt_shorts".into()],
        poses_per_group: 3,
        points_per_pose: 300,
        seed: 1,
    };
    MetaData::load_or_generate(dir, avatar_core::body::open_body_ref(), &config, &|_| {}).unwrap()
}

#[test]
fn meta_training_is_deterministic_and_resumes_after_a_kill() {
    let root = tempfile::tempdir().unwrap();
    let data_dir = root.path().join("data");
    let d = data(&data_dir);
    assert_eq!(d.len(), 3);
    // The saved data reads back identically.
    let back = MetaData::load(&data_dir).unwrap();
    assert_eq!(
        (back.poses.clone(), back.points.clone(), back.normals.clone()),
        (d.poses.clone(), d.points.clone(), d.normals.clone())
    );
    // Every point lies in the normalised cube.
    assert!(d.points.iter().flatten().all(|p| p.abs().max_element() < 1.0));

    let o = options();
    let run = |out: &std::path::Path, cancel_at: Option<(&str, usize)>| {
        let cancel = AtomicBool::new(false);
        let mut seen = Vec::new();
        let r = meta_train(&d, &o, out, Some(&cancel), &mut |p| {
            seen.push((p.stage.to_string(), p.iteration));
            if cancel_at == Some((p.stage, p.iteration)) {
                cancel.store(true, Ordering::Relaxed);
            }
        });
        (r, seen)
    };
    let (a, seen) = run(&root.path().join("a"), None);
    let a = MetaModel::load(&a.unwrap()).unwrap();
    assert_eq!(seen.len(), 7);
    let (a2, _) = run(&root.path().join("a2"), None);
    let a2 = MetaModel::load(&a2.unwrap()).unwrap();
    assert_eq!((&a.hyper, &a.static_sdf), (&a2.hyper, &a2.static_sdf), "same seed, same weights");
    // Meta-training moved the weights away from the initialisation.
    let device = cpu_device();
    let init = avatar_neural::model::flat_params::flatten(&o.config.siren.init(o.seed, &device));
    assert_ne!(a.static_sdf, init);

    // Killed in Alg. 2 after its 2nd iteration: the run stops with a clear error and resumes
    // at the 3rd.
    let b = root.path().join("b");
    let (r, _) = run(&b, Some(("hyper", 2)));
    assert!(r.unwrap_err().to_string().contains("cancelled"));
    assert!(!b.join(MODEL_FILE).exists());
    let (r, seen) = run(&b, None);
    r.unwrap();
    assert_eq!(seen.first(), Some(&("hyper".to_string(), 3)), "{seen:?}");
    // Alg. 1 was not repeated: its result is the uninterrupted run's.
    assert_eq!(MetaModel::load(&b.join(MODEL_FILE)).unwrap().static_sdf, a.static_sdf);
    let log = std::fs::read_to_string(b.join("loss.csv")).unwrap();
    assert_eq!(log.lines().count(), 7, "{log}");

    // A checkpoint of other options is refused, naming the file.
    let other = MetaOptions { seed: 99, ..options() };
    let err = meta_train(&d, &other, &b, None, &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("checkpoint.bin") && err.contains("other options"), "{err}");
}

#[test]
fn alg2_can_start_from_another_models_static_sdf() {
    let root = tempfile::tempdir().unwrap();
    let d = data(&root.path().join("data"));
    let o = options();
    let first =
        MetaModel::load(&meta_train(&d, &o, &root.path().join("a"), None, &mut |_| {}).unwrap())
            .unwrap();
    // Another Alg. 2 (other inner rates) from the first run's static meta-SDF: no Alg. 1
    // iteration runs and the static meta-SDF is carried over unchanged.
    let variant = MetaOptions {
        hyper_inner: HyperFitOptions { lr_heads: 1e-4, ..o.hyper_inner.clone() },
        ..options()
    };
    let out = root.path().join("b");
    let model_path = root.path().join("a").join(MODEL_FILE);
    avatar_neural::training::meta_training::start_from_static(&out, &variant, &first, &model_path)
        .unwrap();
    let mut stages = Vec::new();
    let second = MetaModel::load(
        &meta_train(&d, &variant, &out, None, &mut |p| stages.push(p.stage.to_string())).unwrap(),
    )
    .unwrap();
    assert_eq!(stages, vec!["hyper"; 4]);
    assert_eq!(second.static_sdf, first.static_sdf);
    assert_ne!(second.hyper, first.hyper, "other rates, other hypernetwork");
    // A folder that already holds a run is refused, naming its checkpoint.
    let err = avatar_neural::training::meta_training::start_from_static(
        &out,
        &variant,
        &first,
        &model_path,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("checkpoint.bin") && err.contains("already"), "{err}");
    // So is a model whose SDF has another size.
    let bigger = MetaOptions {
        config: HyperConfig { siren: SirenConfig { hidden: 24, layers: 2 }, ..o.config },
        ..options()
    };
    let err = avatar_neural::training::meta_training::start_from_static(
        &root.path().join("c"),
        &bigger,
        &first,
        &model_path,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("network size"), "{err}");
}

/// A simulated outfit's samples are its garment simulated through training clips and
/// canonicalized by inverse skinning: every point finite and in the unit cube with a unit
/// normal, the long skirt's cloth well off the canonical body, the same data from the same
/// seed; the unseen blazer stays refused.
#[test]
fn simulated_outfits_become_canonical_samples_of_their_cloth() {
    let body = avatar_core::body::open_body_ref();
    let config = MetaDataConfig {
        subjects: 1,
        outfits: vec!["sim_skirt".into()],
        poses_per_group: 2,
        points_per_pose: 400,
        seed: 2,
    };
    let data = MetaData::generate(body, &config).unwrap();
    assert_eq!(data.len(), 2);
    let group = &data.manifest.groups[0];
    let rest = body.shaped_vertices(&group.betas);
    let sdf = avatar_core::mesh::signed_distance::SignedDistance::new(&body.mesh(rest));
    for (points, normals) in data.points.iter().zip(&data.normals) {
        assert_eq!(points.len(), 400);
        assert!(points.iter().all(|p| p.is_finite() && p.abs().max_element() <= 1.0));
        assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
        // The skirt hangs from the waist to the shins: a good share of the surface is cloth
        // more than 3 cm outside the body (a tight outfit has none).
        let off = points
            .iter()
            .filter(|p| sdf.at(group.normalisation.from_unit(**p)).is_some_and(|d| d > 0.03))
            .count();
        assert!(off > 60, "only {off} of 400 points are off the body");
    }
    let again = MetaData::generate(body, &config).unwrap();
    assert_eq!(again.points, data.points);
    let unseen = MetaDataConfig { outfits: vec!["blazer_tails".into()], ..config };
    let refused = MetaData::generate(body, &unseen).err().expect("the unseen outfit is refused");
    assert!(refused.to_string().contains("blazer_tails"), "{refused}");
}
