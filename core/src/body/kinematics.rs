//! Forward kinematics: joint rotations and rest joints -> rigid bone transforms (rest -> posed).

use super::skeleton::{NUM_JOINTS, parent};
use glam::{Affine3A, Mat3, Mat4, Vec3, Vec3A};

/// The posed skeleton.
#[derive(Debug, Clone, PartialEq)]
pub struct Bones {
    /// Rest -> posed transform of each joint: the LBS matrices, global translation included.
    pub transforms: [Mat4; NUM_JOINTS],
    /// Each joint's frame in the posed world (global rotation, posed position).
    pub world: [Mat4; NUM_JOINTS],
    /// Joint positions in the rest pose.
    pub rest_joints: [Vec3; NUM_JOINTS],
}

impl Bones {
    /// The identity skeleton: every bone transform is the identity.
    pub fn rest(rest_joints: [Vec3; NUM_JOINTS]) -> Self {
        forward_kinematics(&rest_joints, &[Mat3::IDENTITY; NUM_JOINTS], Vec3::ZERO)
    }

    pub fn posed_joints(&self) -> [Vec3; NUM_JOINTS] {
        self.world.map(|m| m.w_axis.truncate())
    }

    /// Global rotation of each joint.
    pub fn global_rotations(&self) -> [Mat3; NUM_JOINTS] {
        self.world.map(Mat3::from_mat4)
    }
}

/// SMPL forward kinematics. `rotations[j]` is joint j's rotation relative to its parent
/// (joint 0: global orientation about the root joint); `trans` is added at the end.
pub fn forward_kinematics(
    rest_joints: &[Vec3; NUM_JOINTS],
    rotations: &[Mat3; NUM_JOINTS],
    trans: Vec3,
) -> Bones {
    let mut world = [Affine3A::IDENTITY; NUM_JOINTS];
    for j in 0..NUM_JOINTS {
        let local_offset = match parent(j) {
            Some(p) => rest_joints[j] - rest_joints[p],
            None => rest_joints[j],
        };
        let local = Affine3A::from_mat3_translation(rotations[j], local_offset);
        world[j] = match parent(j) {
            Some(p) => world[p] * local,
            None => local,
        };
    }
    let shift = Affine3A::from_translation(trans);
    let mut transforms = [Mat4::IDENTITY; NUM_JOINTS];
    let mut world_out = [Mat4::IDENTITY; NUM_JOINTS];
    for j in 0..NUM_JOINTS {
        let g = shift * world[j];
        world_out[j] = Mat4::from(g);
        // Rest -> posed: undo the rest joint position, then apply the joint's world frame.
        let a = Affine3A {
            matrix3: g.matrix3,
            translation: g.translation - g.matrix3 * Vec3A::from(rest_joints[j]),
        };
        transforms[j] = Mat4::from(a);
    }
    Bones { transforms, world: world_out, rest_joints: *rest_joints }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    fn chain_joints() -> [Vec3; NUM_JOINTS] {
        // A simple skeleton: each joint 10 cm along +x from its parent, except the left arm.
        let mut j = [Vec3::ZERO; NUM_JOINTS];
        for k in 1..NUM_JOINTS {
            j[k] = j[parent(k).unwrap()] + Vec3::new(0.0, 0.1, 0.0);
        }
        // Left arm: collar (13) -> shoulder (16) -> elbow (18) -> wrist (20) along +x.
        j[16] = j[13] + Vec3::new(0.15, 0.0, 0.0);
        j[18] = j[16] + Vec3::new(0.25, 0.0, 0.0);
        j[20] = j[18] + Vec3::new(0.25, 0.0, 0.0);
        j[22] = j[20] + Vec3::new(0.08, 0.0, 0.0);
        j
    }

    #[test]
    fn rest_pose_is_identity() {
        let bones = Bones::rest(chain_joints());
        for t in bones.transforms {
            assert!(t.abs_diff_eq(Mat4::IDENTITY, 1e-6));
        }
    }

    #[test]
    fn elbow_bend_moves_wrist_by_hand_computed_amount() {
        let joints = chain_joints();
        let mut rot = [Mat3::IDENTITY; NUM_JOINTS];
        // Bend the left elbow 90 degrees about +y: the forearm (+x) turns to -z.
        rot[18] = Mat3::from_rotation_y(FRAC_PI_2);
        let trans = Vec3::new(1.0, 2.0, 3.0);
        let bones = forward_kinematics(&joints, &rot, trans);
        let posed = bones.posed_joints();
        let expected_wrist = joints[18] + Vec3::new(0.0, 0.0, -0.25) + trans;
        assert!(posed[20].abs_diff_eq(expected_wrist, 1e-6), "{} vs {}", posed[20], expected_wrist);
        assert!(posed[18].abs_diff_eq(joints[18] + trans, 1e-6));
        // The hand continues along the forearm.
        assert!(posed[22].abs_diff_eq(expected_wrist + Vec3::new(0.0, 0.0, -0.08), 1e-6));
        // A vertex rigidly attached to the forearm, 10 cm past the elbow, moves with it.
        let v = joints[18] + Vec3::new(0.1, 0.02, 0.0);
        let moved = bones.transforms[18].transform_point3(v);
        assert!(moved.abs_diff_eq(joints[18] + Vec3::new(0.0, 0.02, -0.1) + trans, 1e-6));
    }

    #[test]
    fn global_rotation_composes_down_the_chain() {
        let joints = chain_joints();
        let mut rot = [Mat3::IDENTITY; NUM_JOINTS];
        rot[0] = Mat3::from_rotation_y(FRAC_PI_2);
        rot[16] = Mat3::from_rotation_z(FRAC_PI_2);
        let bones = forward_kinematics(&joints, &rot, Vec3::ZERO);
        let g = bones.global_rotations();
        assert!(g[20].abs_diff_eq(rot[0] * rot[16], 1e-6));
        // Elbow: shoulder + R0 * Rz(90) * (0.25, 0, 0) = shoulder + R0 * (0, 0.25, 0).
        let p = bones.posed_joints();
        assert!(p[18].abs_diff_eq(p[16] + Vec3::new(0.0, 0.25, 0.0), 1e-6), "{}", p[18] - p[16]);
    }
}
