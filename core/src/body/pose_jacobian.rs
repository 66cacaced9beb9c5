//! Per-frame pose corrections and the derivative of a skinned point with respect to them
//! (PINA's joint optimisation of poses, section 3.2).
//!
//! A correction holds one rotation vector per joint, applied in the joint's own frame after the
//! given rotation (`R_j exp([d_j]x)`), and a translation added to the given one. Turning joint j
//! by a small angle about its local axis `a` turns everything below it about the world axis
//! `G_j a` through the posed joint `P_j` (`G_j`: the joint's global rotation), so for a point
//! skinned with fixed weights, `y = sum_i w_i B_i x`:
//!
//!   dy / dd_j = (G_j a) x s_j,   s_j = sum_{i below or at j} w_i (B_i x - P_j),
//!   dy / dt   = identity.
//!
//! Exact at a zero correction; with a correction `d` of a few degrees the rotation-vector
//! parameterisation adds an error of order |d| / 2 in the derivative, which Gauss-Newton steps
//! tolerate. A test checks both against finite differences of [`forward_kinematics`].

use super::kinematics::{Bones, forward_kinematics};
use super::params::BodyParams;
use super::skeleton::{NUM_JOINTS, parent};
use super::skinning::Weights;
use glam::{Mat3, Quat, Vec3};
use serde::{Deserialize, Serialize};

/// Parameters of one frame's correction: 3 per joint, then 3 of translation.
pub const POSE_DOF: usize = 3 * NUM_JOINTS + 3;

/// One frame's correction of a given fitting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseCorrection {
    /// Rotation vector of each joint (radians), in the joint's frame after its given rotation.
    pub rotations: [Vec3; NUM_JOINTS],
    /// Added to the given translation (metres).
    pub translation: Vec3,
}

impl Default for PoseCorrection {
    fn default() -> Self {
        PoseCorrection { rotations: [Vec3::ZERO; NUM_JOINTS], translation: Vec3::ZERO }
    }
}

impl PoseCorrection {
    /// Add a step of [`POSE_DOF`] values (joint rotations, then translation).
    pub fn add(&mut self, step: &[f32]) {
        for (j, r) in self.rotations.iter_mut().enumerate() {
            *r += Vec3::new(step[3 * j], step[3 * j + 1], step[3 * j + 2]);
        }
        let t = 3 * NUM_JOINTS;
        self.translation += Vec3::new(step[t], step[t + 1], step[t + 2]);
    }

    /// The values as one vector (the layout of [`POSE_DOF`]).
    pub fn to_vec(&self) -> Vec<f32> {
        let mut v: Vec<f32> = self.rotations.iter().flat_map(|r| r.to_array()).collect();
        v.extend(self.translation.to_array());
        v
    }

    /// Joint rotations of `given` with this correction applied.
    pub fn rotations_of(&self, given: &BodyParams) -> [Mat3; NUM_JOINTS] {
        let mut out = given.rotations();
        for (r, d) in out.iter_mut().zip(&self.rotations) {
            *r *= Mat3::from_quat(Quat::from_scaled_axis(*d));
        }
        out
    }

    /// The corrected fitting (shape coefficients kept).
    pub fn apply(&self, given: &BodyParams) -> BodyParams {
        let mut pose = given.pose;
        for (p, d) in pose.iter_mut().zip(&self.rotations) {
            *p = (Quat::from_scaled_axis(*p) * Quat::from_scaled_axis(*d)).to_scaled_axis();
        }
        BodyParams { pose, betas: given.betas.clone(), trans: given.trans + self.translation }
    }

    /// The bones of `given` with this correction, for a subject's rest joints.
    pub fn bones(&self, rest_joints: &[Vec3; NUM_JOINTS], given: &BodyParams) -> Bones {
        forward_kinematics(rest_joints, &self.rotations_of(given), given.trans + self.translation)
    }
}

/// Angle (radians) between two rotations given as rotation vectors.
pub fn rotation_angle_between(a: Vec3, b: Vec3) -> f32 {
    let q = Quat::from_scaled_axis(a).inverse() * Quat::from_scaled_axis(b);
    // atan2 keeps small angles accurate in f32 (acos near 1 does not).
    2.0 * q.xyz().length().atan2(q.w.abs())
}

/// Mean angle over the joints between two fittings (radians) and the distance of their
/// translations (metres).
pub fn pose_error(a: &BodyParams, b: &BodyParams) -> (f32, f32) {
    let sum: f32 = a.pose.iter().zip(&b.pose).map(|(x, y)| rotation_angle_between(*x, *y)).sum();
    (sum / NUM_JOINTS as f32, (a.trans - b.trans).length())
}

/// Columns of d y / d(correction) for `y = sum_i w_i B_i x` at `bones` (the corrected pose),
/// the weights held fixed: one column per joint axis (joint-major), then the translation's.
pub fn skinned_point_jacobian(bones: &Bones, w: &Weights, x: Vec3) -> [Vec3; POSE_DOF] {
    // Weighted posed positions and weights, accumulated from the leaves up: afterwards
    // acc[j] and wsum[j] cover joint j and every joint below it (parents precede children).
    let mut acc = [Vec3::ZERO; NUM_JOINTS];
    let mut wsum = [0f32; NUM_JOINTS];
    for i in 0..NUM_JOINTS {
        if w[i] != 0.0 {
            acc[i] = bones.transforms[i].transform_point3(x) * w[i];
            wsum[i] = w[i];
        }
    }
    for i in (1..NUM_JOINTS).rev() {
        let p = parent(i).expect("every joint but the root has a parent");
        acc[p] += acc[i];
        wsum[p] += wsum[i];
    }
    let mut cols = [Vec3::ZERO; POSE_DOF];
    for j in 0..NUM_JOINTS {
        if wsum[j] == 0.0 {
            continue;
        }
        let world = bones.world[j];
        let s = acc[j] - world.w_axis.truncate() * wsum[j];
        let g = Mat3::from_mat4(world);
        for a in 0..3 {
            cols[3 * j + a] = g.col(a).cross(s);
        }
    }
    let t = 3 * NUM_JOINTS;
    let total: f32 = w.iter().sum();
    cols[t] = Vec3::X * total;
    cols[t + 1] = Vec3::Y * total;
    cols[t + 2] = Vec3::Z * total;
    cols
}
