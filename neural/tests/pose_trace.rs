//! The pose-refinement diagnostic's measures: errors against the truth split into what the
//! frames share, twist and swing; the snap list as `fit --snap-to-truth` parses it; a traced fit
//! writes to the caller's lines and fits what an untraced one does.

use avatar_core::body::{BodyParams, open_body_lowpoly};
use avatar_neural::training::pose_trace::{Snap, match_truth, pose_errors};
use glam::Vec3;

#[test]
fn pose_errors_split_shared_twist_and_swing() {
    let body = open_body_lowpoly();
    let joints = body.rest_joints(&[]);
    let truth: Vec<BodyParams> = (0..4)
        .map(|k| BodyParams { trans: Vec3::new(0.0, 0.9, 2.0 + k as f32), ..BodyParams::default() })
        .collect();
    // The left elbow (18) twisted by 4 degrees about its bone (toward the wrist, 20) in every
    // frame: a shared, pure twist; the right knee (5) swung by +-2 degrees across its bone,
    // alternating: per-frame, nothing shared.
    let axis = (joints[20] - joints[18]).normalize();
    let across = (joints[8] - joints[5]).normalize().any_orthonormal_vector();
    let refined: Vec<BodyParams> = truth
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let mut p = t.clone();
            p.pose[18] = axis * 4f32.to_radians();
            p.pose[5] = across * if k % 2 == 0 { 2f32 } else { -2.0 }.to_radians();
            p
        })
        .collect();
    let e = pose_errors(&refined, &truth, &joints);
    let n = 24.0;
    assert!((e.joint_deg - 6.0 / n).abs() < 1e-3, "{e}");
    assert!((e.twist_deg - 4.0 / n).abs() < 1e-3 && (e.swing_deg - 2.0 / n).abs() < 1e-3, "{e}");
    assert!((e.common_deg - 4.0 / n).abs() < 1e-3 && e.trans_cm == 0.0, "{e}");
    assert!((e.per_joint_deg[18] - 4.0).abs() < 1e-3 && (e.per_joint_deg[5] - 2.0).abs() < 1e-3);
    // The swing moves the ankle.
    assert!(e.posed_joints_cm > 0.0);
}

#[test]
fn snap_lists_name_joints_and_the_translation() {
    assert_eq!(Snap::parse("1, 16,t"), Snap { joints: vec![1, 16], translation: true });
    assert_eq!(Snap::parse(""), Snap::default());
    assert_eq!(Snap::parse("x,3"), Snap { joints: vec![3], translation: false });
}

#[test]
fn the_truth_of_the_same_frames_is_matched_by_index() {
    let frames: Vec<BodyParams> = (0..3)
        .map(|k| BodyParams { trans: Vec3::new(k as f32, 0.0, 0.0), ..BodyParams::default() })
        .collect();
    let given: Vec<BodyParams> = frames.iter().rev().cloned().collect();
    assert_eq!(match_truth(&given, &[0, 1, 2], 3, &frames), frames);
    // Some frames of the capture chosen: by their manifest index, not the nearest pose.
    assert_eq!(
        match_truth(&given[..2], &[0, 2], 3, &frames),
        vec![frames[0].clone(), frames[2].clone()]
    );
    // A truth of another length: each matched to the nearest true one.
    assert_eq!(match_truth(&given[..1], &[0], 4, &frames), vec![frames[2].clone()]);
}

/// A fit traced against the demo capture's exact fittings writes its lines to the caller's
/// `TraceLines` (the given fittings' errors first, the refined ones last) and fits the same
/// avatar as the fit without a trace: the trace only watches.
#[test]
fn a_traced_fit_writes_to_the_callers_lines_and_fits_the_same_avatar() {
    use avatar_core::avatar::AvatarSource;
    use avatar_core::canonical::FieldCache;
    use avatar_neural::avatar::{AnyAvatar, AvatarFit, FitKind, fit_avatar};
    use avatar_neural::data::capture_points::CapturePoints;
    use avatar_neural::training::pose_trace::{PoseTrace, TraceLines};
    use avatar_neural::{HyperFitOptions, Init, MetaModel};
    use std::sync::{Arc, Mutex};

    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let cache = FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"));
    let capture = CapturePoints::open(&demo, 2, &cache).unwrap();
    let model = MetaModel::shipped();
    let options = HyperFitOptions {
        steps: 2,
        surface_per_pose: 200,
        off_per_pose: 200,
        ..HyperFitOptions::default()
    };
    let lines = Arc::new(Mutex::new(Vec::<String>::new()));
    let sink = lines.clone();
    let trace = PoseTrace::from_capture(
        &demo,
        TraceLines::new(move |l| sink.lock().unwrap().push(l.to_string())),
    )
    .unwrap();
    let fit = |trace: Option<&PoseTrace>| {
        let fit = AvatarFit {
            kind: FitKind::Meta(Init::MetaLearned(&model)),
            options: options.clone(),
            chunk: 0,
            cancel: None,
            trace,
        };
        match fit_avatar(&capture, &fit, &mut |_| {}).unwrap().0 {
            AnyAvatar::Meta(a) => a,
            AnyAvatar::Static(_) => panic!("a meta fit gives a meta avatar"),
        }
    };
    let traced = fit(Some(&trace));
    let lines = lines.lock().unwrap().clone();
    assert!(lines.first().is_some_and(|l| l.starts_with("given fittings: joint ")), "{lines:?}");
    assert!(lines.last().is_some_and(|l| l.starts_with("refined: joint ")), "{lines:?}");
    assert!(lines.iter().all(|l| !l.starts_with("pose trace")), "the caller adds its prefix");

    let plain = fit(None);
    assert_eq!(traced.header.refined_poses, plain.header.refined_poses);
    let pose = &capture.frames[0].params;
    let probe: Vec<Vec3> =
        (0..64).map(|i| Vec3::new(0.0, 0.3 + i as f32 * 0.02, 0.05 * (i % 3) as f32)).collect();
    assert_eq!(traced.sdf(pose, &probe).unwrap(), plain.sdf(pose, &probe).unwrap());
}
