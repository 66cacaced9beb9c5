//! Captures fitted with a user's own SMPL-family model: a stand-in written by the test (the
//! open body in SMPL layout with shape directions of its own, never a licensed file) is named
//! in capture.json; opening and canonicalizing use that body and its coefficients; a missing or
//! broken model file, and coefficients the model does not have, are errors naming the files.

use avatar_core::body::{BodyModel, open_body_lowpoly_ref};
use avatar_core::canonical::{Canonicalizer, FieldOptions};
use avatar_core::capture::{BodyModelRef, Capture, CaptureManifest, CaptureOptions};
use avatar_core::mesh::bvh::Bvh;
use avatar_core::motion::clip_by_name;
use avatar_core::synth::{GroundTruth, Outfit, SynthJob, generate_smpl_capture, smpl_stand_in};
use std::path::Path;

fn write_capture(dir: &Path) {
    let mut job = SynthJob::new(11, Outfit::TshirtShorts, clip_by_name("walk").unwrap());
    job.frames = Some(2);
    generate_smpl_capture(dir, "my_smpl.npz", &job).unwrap();
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

#[test]
fn a_capture_fitted_with_the_users_smpl_model_opens_and_canonicalizes_with_that_body() {
    let dir = tempfile::tempdir().unwrap();
    write_capture(dir.path());
    let manifest = CaptureManifest::load(dir.path()).unwrap();
    assert_eq!(manifest.body_model, BodyModelRef::Smpl("my_smpl.npz".into()));
    let text = std::fs::read_to_string(dir.path().join("capture.json")).unwrap();
    assert!(text.contains(r#""smpl": "my_smpl.npz""#), "{text}");

    let capture = Capture::open(dir.path()).unwrap();
    let stand_in = smpl_stand_in();
    assert_eq!(capture.body_file.as_deref(), Some(dir.path().join("my_smpl.npz").as_path()));
    assert_eq!((capture.body.num_betas, capture.frames.len()), (stand_in.num_betas, 2));
    let betas = capture.frames[0].params.betas.clone();
    assert_eq!(betas.len(), 10);

    // Canonical points land on the ground-truth canonical clothing (the stand-in's shape): 0.2-0.3 mm median.
    let gt = GroundTruth::load(dir.path()).unwrap();
    let canon = Canonicalizer::new(
        &capture.body,
        &betas,
        &FieldOptions { cells_along_height: 80, ..FieldOptions::default() },
        None,
    )
    .unwrap();
    for (i, f) in capture.frames.iter().enumerate() {
        let c = canon.frame(f);
        assert!(
            c.points.len() > f.points.len() * 8 / 10,
            "frame {i}: {} of {} points kept",
            c.points.len(),
            f.points.len()
        );
        let bvh = Bvh::build(&gt.canonical_mesh(i));
        let d = median(c.points.iter().map(|&p| bvh.closest_point(p).unwrap().distance).collect());
        assert!(
            d < 0.002,
            "frame {i}: median {:.1} mm from the true canonical surface",
            d * 1000.0
        );
    }
    // Read as the open body's seven directions, the coefficients give another person: the
    // heights of the two rest bodies differ by decimetres (1.68 m vs 2.18 m for this subject).
    let height = |v: &[glam::Vec3]| {
        v.iter().map(|p| p.y).fold(f32::MIN, f32::max)
            - v.iter().map(|p| p.y).fold(f32::MAX, f32::min)
    };
    let misread = open_body_lowpoly_ref().shaped_vertices(&betas);
    assert!(
        (height(&canon.rest) - height(&misread)).abs() > 0.1,
        "{} vs {}",
        height(&canon.rest),
        height(&misread)
    );
}

#[test]
fn missing_or_broken_models_and_foreign_coefficients_are_named() {
    let dir = tempfile::tempdir().unwrap();
    write_capture(dir.path());
    let model = dir.path().join("my_smpl.npz");
    let manifest_path = dir.path().join("capture.json");

    // The open body (7 directions) cannot take the stand-in's 10 coefficients.
    let open_npz = dir.path().join("open_body_smpl_layout.npz");
    open_body_lowpoly_ref().save_npz(&open_npz).unwrap();
    let options =
        CaptureOptions { body_model: Some(open_npz.clone()), ..CaptureOptions::default() };
    let err = Capture::open_with(dir.path(), &options).unwrap_err().to_string();
    assert!(
        err.contains(&manifest_path.display().to_string())
            && err.contains("10 shape coefficients")
            && err.contains("has 7"),
        "{err}"
    );
    assert!(err.contains("open_body_smpl_layout.npz"), "{err}");
    let mut m = CaptureManifest::load(dir.path()).unwrap();
    m.body_model = BodyModelRef::OpenBody;
    m.save(dir.path()).unwrap();
    let err = Capture::open(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("capture.json") && err.contains("open body") && err.contains("\"smpl\""),
        "{err}"
    );

    // --body-model overrides the manifest: the stand-in again opens it.
    let options = CaptureOptions { body_model: Some(model.clone()), ..CaptureOptions::default() };
    assert_eq!(Capture::open_with(dir.path(), &options).unwrap().body.num_betas, 10);

    // Missing and broken model files name the model and where it was named.
    m.body_model = BodyModelRef::Smpl("gone.npz".into());
    m.save(dir.path()).unwrap();
    let err = Capture::open(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("gone.npz") && err.contains("capture.json") && err.contains("SMPL body model"),
        "{err}"
    );
    std::fs::write(&model, b"not a zip").unwrap();
    let options = CaptureOptions { body_model: Some(model.clone()), ..CaptureOptions::default() };
    let err = Capture::open_with(dir.path(), &options).unwrap_err().to_string();
    assert!(err.contains("my_smpl.npz"), "{err}");
    assert!(BodyModel::load_npz(&model).is_err());
}
