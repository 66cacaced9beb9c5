//! The pose-refinement diagnostic's measures: errors against the truth split into what the
//! frames share, twist and swing; the snap list as `fit --snap-to-truth` parses it.

use avatar_core::body::{BodyParams, open_body_lowpoly};
use avatar_neural::pose_trace::{Snap, match_truth, pose_errors};
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
    assert_eq!(match_truth(&given, &frames), frames);
    // Fewer frames given: each matched to the nearest true one.
    assert_eq!(match_truth(&given[..1], &frames), vec![frames[2].clone()]);
}
