//! How far refined poses are from the true ones, when those are known (the evaluation's
//! perturbed captures, synthetic tests): the mean joint angle, the translation, the posed
//! joints' positions, and the error split into what the frames share (the part a zero-mean
//! constraint cannot correct) and each joint's twist about its bone and swing of the bone.
//!
//! A fit given a [`PoseTrace`] (`AvatarFit::trace`; `avatar-studio fit --true-poses DIR`)
//! writes these errors after every refinement round to the trace's [`TraceLines`], which the
//! caller chooses (the CLI prints them to stderr).

use avatar_core::body::{
    BodyParams, JOINT_NAMES, NUM_JOINTS, forward_kinematics, skeleton::parent,
};
use avatar_core::capture::CaptureManifest;
use glam::{Quat, Vec3};
use std::sync::Arc;

/// Errors of refined fittings against the truth (means over frames; angles in degrees).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseErrors {
    /// Mean over joints of the angle between the refined and the true rotation.
    pub joint_deg: f32,
    pub trans_cm: f32,
    /// Mean distance of the posed joints (the skeleton at each fitting) from the true ones.
    pub posed_joints_cm: f32,
    /// Mean over joints of the length of the frames' mean error (the shared part).
    pub common_deg: f32,
    /// Length of the frames' mean translation error, and that error (world, cm).
    pub common_trans_cm: f32,
    pub common_trans: Vec3,
    /// Mean over joints of the error's component about the bone (twist) and across it (swing).
    pub twist_deg: f32,
    pub swing_deg: f32,
    pub per_joint_deg: [f32; NUM_JOINTS],
    /// Each frame's translation error (world, cm).
    pub per_frame_trans: Vec<Vec3>,
}

/// A joint's bone direction in its own frame at rest (the rest pose has no rotations): toward
/// its first child, or from its parent for a leaf.
fn bone_axis(rest: &[Vec3; NUM_JOINTS], j: usize) -> Vec3 {
    let d = match (0..NUM_JOINTS).find(|&c| parent(c) == Some(j)) {
        Some(c) => rest[c] - rest[j],
        None => rest[j] - parent(j).map_or(rest[j], |p| rest[p]),
    };
    d.normalize_or_zero()
}

/// Error rotation of a joint (rotation vector, in the joint's frame after the true rotation).
fn joint_error(refined: Vec3, truth: Vec3) -> Vec3 {
    let q = Quat::from_scaled_axis(truth).inverse() * Quat::from_scaled_axis(refined);
    let q = if q.w < 0.0 { -q } else { q };
    q.to_scaled_axis()
}

pub fn pose_errors(
    refined: &[BodyParams],
    truth: &[BodyParams],
    rest_joints: &[Vec3; NUM_JOINTS],
) -> PoseErrors {
    let n = refined.len().min(truth.len()).max(1) as f32;
    let nj = NUM_JOINTS as f32;
    let mut e = PoseErrors {
        joint_deg: 0.0,
        trans_cm: 0.0,
        posed_joints_cm: 0.0,
        common_deg: 0.0,
        common_trans_cm: 0.0,
        common_trans: Vec3::ZERO,
        twist_deg: 0.0,
        swing_deg: 0.0,
        per_joint_deg: [0.0; NUM_JOINTS],
        per_frame_trans: Vec::new(),
    };
    let mut mean_err = [Vec3::ZERO; NUM_JOINTS];
    let mut mean_trans = Vec3::ZERO;
    for (r, t) in refined.iter().zip(truth) {
        for (j, (per_joint, mean)) in
            e.per_joint_deg.iter_mut().zip(mean_err.iter_mut()).enumerate()
        {
            let err = joint_error(r.pose[j], t.pose[j]);
            let angle = err.length().to_degrees();
            let twist = err.dot(bone_axis(rest_joints, j)).abs().to_degrees();
            *per_joint += angle / n;
            e.joint_deg += angle / (n * nj);
            e.twist_deg += twist / (n * nj);
            e.swing_deg += (angle * angle - twist * twist).max(0.0).sqrt() / (n * nj);
            *mean += err / n;
        }
        e.trans_cm += (r.trans - t.trans).length() * 100.0 / n;
        mean_trans += (r.trans - t.trans) / n;
        e.per_frame_trans.push((r.trans - t.trans) * 100.0);
        let (pr, pt) = (
            forward_kinematics(rest_joints, &r.rotations(), r.trans).posed_joints(),
            forward_kinematics(rest_joints, &t.rotations(), t.trans).posed_joints(),
        );
        e.posed_joints_cm +=
            pr.iter().zip(&pt).map(|(a, b)| (*a - *b).length()).sum::<f32>() * 100.0 / (n * nj);
    }
    e.common_deg = mean_err.iter().map(|v| v.length().to_degrees()).sum::<f32>() / nj;
    e.common_trans_cm = mean_trans.length() * 100.0;
    e.common_trans = mean_trans * 100.0;
    e
}

impl std::fmt::Display for PoseErrors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "joint {:.2} deg (shared {:.2}, twist {:.2}, swing {:.2}), translation {:.2} cm (shared {:.2} {:.2?}), posed joints {:.2} cm",
            self.joint_deg,
            self.common_deg,
            self.twist_deg,
            self.swing_deg,
            self.trans_cm,
            self.common_trans_cm,
            self.common_trans.to_array(),
            self.posed_joints_cm
        )
    }
}

impl PoseErrors {
    /// Each joint's mean angle error, by name, and each frame's translation error.
    pub fn per_joint(&self) -> String {
        let joints = (0..NUM_JOINTS)
            .map(|j| format!("{} {:.1}", JOINT_NAMES[j], self.per_joint_deg[j]))
            .collect::<Vec<_>>()
            .join(", ");
        let frames = self
            .per_frame_trans
            .iter()
            .map(|t| format!("[{:.2}, {:.2}, {:.2}]", t.x, t.y, t.z))
            .collect::<Vec<_>>()
            .join(" ");
        format!("{joints}\n  translation per frame (cm): {frames}")
    }
}

/// The true fitting of each given one. `indices` are the given frames' indices in their
/// capture's manifest and `capture_frames` its length: where the truth is a capture of as many
/// frames (the evaluation's captures, a fit that chose some of their frames), by index;
/// otherwise the nearest true fitting (the perturbation is a few degrees).
pub fn match_truth(
    given: &[BodyParams],
    indices: &[usize],
    capture_frames: usize,
    exact: &[BodyParams],
) -> Vec<BodyParams> {
    // By index where it can: matching by nearest pose mixed up two similar frames of one
    // subject (a pelvis 25 deg "off"; 7 deg on average over 32 frames chosen of 72).
    if exact.len() == capture_frames
        && indices.len() == given.len()
        && let Some(matched) = indices.iter().map(|&i| exact.get(i).cloned()).collect()
    {
        return matched;
    }
    given
        .iter()
        .map(|g| {
            let cost = |t: &BodyParams| {
                let (a, d) = avatar_core::body::pose_error(g, t);
                a + d * 10.0
            };
            exact
                .iter()
                .min_by(|a, b| cost(a).total_cmp(&cost(b)))
                .cloned()
                .unwrap_or_else(|| g.clone())
        })
        .collect()
}

/// A diagnostic of pose refinement during a fit, chosen by its caller: the true fittings of the
/// capture's frames (each refinement round then writes the refined fittings' errors against
/// them to `lines`), and optionally joints snapped to the truth.
#[derive(Debug, Clone)]
pub struct PoseTrace {
    /// The exact fittings (a `capture.json`'s records), matched to the given ones by
    /// [`match_truth`].
    pub truth: Vec<BodyParams>,
    /// Set these refined values to the truth after every refinement round, to measure what
    /// their residual error costs.
    pub snap: Option<Snap>,
    /// Where the trace's lines go.
    pub lines: TraceLines,
}

/// Where a [`PoseTrace`]'s lines go: a function of each line, given by the caller.
#[derive(Clone)]
pub struct TraceLines(Arc<dyn Fn(&str) + Send + Sync>);

impl TraceLines {
    pub fn new(write: impl Fn(&str) + Send + Sync + 'static) -> TraceLines {
        TraceLines(Arc::new(write))
    }

    pub fn write(&self, line: &str) {
        (self.0)(line)
    }
}

impl std::fmt::Debug for TraceLines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TraceLines")
    }
}

/// Which refined values [`PoseTrace::snap`] sets to the truth.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Snap {
    /// Joint indices (`JOINT_NAMES`).
    pub joints: Vec<usize>,
    pub translation: bool,
}

impl PoseTrace {
    /// The exact fittings of the capture in `dir` (its `capture.json`), traced to `lines`.
    pub fn from_capture(
        dir: &std::path::Path,
        lines: TraceLines,
    ) -> avatar_core::Result<PoseTrace> {
        let manifest = CaptureManifest::load(dir)?;
        let truth = manifest.frames.iter().filter_map(|r| r.params().ok()).collect();
        Ok(PoseTrace { truth, snap: None, lines })
    }
}

impl Snap {
    /// Joints as comma-separated indices, `t` for the translation (`fit --snap-to-truth`).
    pub fn parse(list: &str) -> Snap {
        let items: Vec<&str> = list.split(',').map(str::trim).filter(|s| !s.is_empty()).collect();
        Snap {
            joints: items.iter().filter_map(|s| s.parse().ok()).collect(),
            translation: items.contains(&"t"),
        }
    }
}
