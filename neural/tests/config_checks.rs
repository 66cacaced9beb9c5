//! Every stage's config refuses a value out of range with an error that names the option and
//! its bound (`config::Check`), and the library's entry points check before they work: a bad
//! value is an error, never a panic (`checkpoint_every = 0` divided by zero) or a silent clamp.

use avatar_neural::config::Check;
use avatar_neural::data::meta_data::{MetaData, MetaDataConfig};
use avatar_neural::data::own_data::OwnDataOptions;
use avatar_neural::training::meta_training::{MetaOptions, RatesConfig};
use avatar_neural::training::pose_refine::PoseRefineOptions;
use avatar_neural::*;

/// `config` is refused naming `option`; its message says the bound.
fn refused<C: Check>(config: &C, option: &str, bound: &str) {
    match config.check() {
        Err(Error::Option { option: o, bound: b, .. }) => {
            assert_eq!(o, option);
            assert!(b.contains(bound), "{option}: bound {b:?}, expected {bound:?}");
        }
        Err(other) => panic!("{option}: not an option error: {other}"),
        Ok(()) => panic!("{option}: accepted"),
    }
}

#[test]
fn defaults_and_presets_pass_their_checks() {
    SirenConfig::paper().check().unwrap();
    SirenConfig::compact().check().unwrap();
    HyperConfig::paper().check().unwrap();
    HyperConfig::compact().check().unwrap();
    MetaDataConfig::default().check().unwrap();
    OwnDataOptions::default().check().unwrap();
    FitOptions::default().check().unwrap();
    HyperFitOptions::default().check().unwrap();
    HyperFitOptions::default().static_equivalent().check().unwrap();
    PoseRefineOptions::default().check().unwrap();
    PoseRefineOptions::default().without_prealignment(8, 8).check().unwrap();
    PoseRefineOptions::default().without_prealignment(32, 8).check().unwrap();
    MetaOptions::default().check().unwrap();
}

#[test]
fn model_configs_refuse_sizes_by_name() {
    refused(&SirenConfig { hidden: 0, layers: 4 }, "siren.hidden", "from 1 to 4096");
    refused(&SirenConfig { hidden: 128, layers: 65 }, "siren.layers", "from 1 to 64");
    refused(&HyperConfig { head_hidden: 5000, ..HyperConfig::compact() }, "head_hidden", "4096");
    refused(&HyperConfig { rank: Some(0), ..HyperConfig::compact() }, "rank", "from 1 to 4096");
}

#[test]
fn data_configs_refuse_empty_counts_by_name() {
    refused(&MetaDataConfig { subjects: 0, ..Default::default() }, "subjects", "at least 1");
    refused(&MetaDataConfig { outfits: vec![], ..Default::default() }, "outfits", "one outfit");
    refused(&MetaDataConfig { points_per_pose: 0, ..Default::default() }, "points_per_pose", "1");
    refused(
        &OwnDataOptions { frames_per_capture: 0, ..Default::default() },
        "frames_per_capture",
        "at least 1",
    );
    // The generator checks before it makes anything.
    let body = avatar_core::body::embedded::open_body_lowpoly();
    let err =
        MetaData::generate(&body, &MetaDataConfig { poses_per_group: 0, ..Default::default() })
            .err()
            .expect("refused");
    assert!(err.to_string().contains("poses_per_group"), "{err}");
}

#[test]
fn training_configs_refuse_values_by_name() {
    refused(&FitOptions { batch: 0, ..Default::default() }, "batch", "at least 1");
    refused(
        &FitOptions { learning_rate: f64::NAN, ..Default::default() },
        "learning_rate",
        "above 0",
    );
    let h = HyperFitOptions::default();
    refused(&HyperFitOptions { steps: 0, ..h.clone() }, "steps", "at least 1");
    refused(&HyperFitOptions { poses_per_step: 0, ..h.clone() }, "poses_per_step", "at least 1");
    refused(&HyperFitOptions { near_sigma: f32::NAN, ..h.clone() }, "near_sigma", "above 0");
    refused(&HyperFitOptions { lr_sdf: -1e-4, ..h.clone() }, "lr_sdf", "at least 0");
    refused(
        &HyperFitOptions { weights: IgrWeights { eikonal: -1.0, ..h.weights }, ..h.clone() },
        "weights.eikonal",
        "at least 0",
    );
    let r = PoseRefineOptions::default();
    let bad_refine = PoseRefineOptions { iterations: 0, ..r };
    refused(&bad_refine, "refine_poses.iterations", "at least 1");
    refused(
        &HyperFitOptions { refine_poses: bad_refine, ..h.clone() },
        "refine_poses.iterations",
        "1",
    );
    refused(&PoseRefineOptions { huber: 0.0, ..r }, "refine_poses.huber", "above 0");
    // Off, refinement's other values are not read.
    PoseRefineOptions { iterations: 0, ..PoseRefineOptions::off() }.check().unwrap();
    let m = MetaOptions::default();
    refused(&MetaOptions { checkpoint_every: 0, ..m.clone() }, "checkpoint_every", "at least 1");
    refused(&MetaOptions { hyper_meta_batch: 0, ..m.clone() }, "hyper_meta_batch", "at least 1");
    refused(
        &MetaOptions {
            hyper_outer: RatesConfig { sdf: f64::INFINITY, ..m.hyper_outer },
            ..m.clone()
        },
        "hyper_outer.sdf",
        "finite",
    );
}

#[test]
fn meta_training_refuses_bad_options_before_it_writes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let data = MetaData {
        manifest: avatar_neural::data::meta_data::Manifest {
            format: avatar_neural::data::meta_data::DATA_FORMAT.into(),
            version: avatar_neural::data::meta_data::DATA_VERSION,
            config: MetaDataConfig::default(),
            groups: Vec::new(),
            source: None,
        },
        poses: Vec::new(),
        points: Vec::new(),
        normals: Vec::new(),
    };
    let options = MetaOptions { checkpoint_every: 0, ..MetaOptions::default() };
    let err = avatar_neural::training::meta_training::meta_train(
        &data,
        &options,
        &out,
        None,
        &mut |_| {},
    )
    .expect_err("refused");
    assert!(err.to_string().contains("checkpoint_every"), "{err}");
    assert!(!out.exists(), "nothing is written for refused options");
}

#[test]
fn mesh_resolution_out_of_bounds_is_refused_by_name() {
    use avatar_neural::avatar::MeshResolution;
    let err = MeshResolution::new(8).unwrap_err();
    assert!(matches!(&err, Error::Option { option: "resolution", .. }), "{err}");
    assert!(err.to_string().contains("from 16 to 512"), "{err}");
}
