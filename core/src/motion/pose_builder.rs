//! Anatomical pose construction: joint angles in degrees with anatomical meanings (hip flexion,
//! shoulder elevation, ...) mapped onto SMPL's joint axes.
//!
//! SMPL's rest frames are aligned with the world at the T-pose: Y up, the body faces +Z, +X is
//! the body's left, arms along +-X. Each joint stores Euler angles `(x, y, z)` in degrees with
//! rotation `R = Rx(x) * Ry(y) * Rz(z)` (so `z` acts first), written for the LEFT side; the right
//! side is the mirror image (x kept, y and z negated). Sign conventions (left side):
//!
//! | joint | +x | +y | +z |
//! |---|---|---|---|
//! | hip | extension (thigh back) | external rotation | abduction (leg out) |
//! | knee | flexion (shin back) | - | - |
//! | ankle | plantar flexion (toe down) | - | - |
//! | spine1-3 | forward flexion | twist to the left | lateral bend to the right |
//! | shoulder | swing back (arm down) / twist | horizontal extension | elevation (arm up) |
//! | elbow | - | extension (flexion is -y) | - |
//! | collar | - | - | shrug up |

use crate::body::{BodyParams, NUM_JOINTS};
use glam::{EulerRot, Mat3, Quat, Vec3};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

impl Side {
    pub const BOTH: [Side; 2] = [Side::Left, Side::Right];

    /// SMPL joint index of this side, given the left joint.
    pub fn joint(self, left: usize) -> usize {
        match self {
            Side::Left => left,
            Side::Right => left + 1,
        }
    }

    pub fn other(self) -> Side {
        match self {
            Side::Left => Side::Right,
            Side::Right => Side::Left,
        }
    }
}

/// Joint indices (left side; the right side is the next index).
pub mod joints {
    pub const PELVIS: usize = 0;
    pub const HIP: usize = 1;
    pub const SPINE1: usize = 3;
    pub const KNEE: usize = 4;
    pub const SPINE2: usize = 6;
    pub const ANKLE: usize = 7;
    pub const SPINE3: usize = 9;
    pub const NECK: usize = 12;
    pub const COLLAR: usize = 13;
    pub const HEAD: usize = 15;
    pub const SHOULDER: usize = 16;
    pub const ELBOW: usize = 18;
    pub const WRIST: usize = 20;
}
use joints::*;

/// Nominal thigh and shin lengths (metres) used to keep the feet near the ground. They match the
/// open body's neutral shape (0.39 m hip-knee, 0.41 m knee-ankle) to within a few centimetres
/// for every shape within its limits.
pub const NOMINAL_THIGH: f32 = 0.39;
pub const NOMINAL_SHIN: f32 = 0.41;

/// Euler order of joint `j`: `Rx * Ry * Rz` for every joint except the elbows, whose hinge is
/// the y axis and bends past 90 degrees: they use `Ry * Rx * Rz` (y first, so the
/// decomposition stays unique for any flexion).
pub fn euler_order(j: usize) -> EulerRot {
    if j == ELBOW || j == ELBOW + 1 { EulerRot::YXZ } else { EulerRot::XYZ }
}

/// Rotation of Euler angles `(x, y, z)` in degrees, composed in `order` (XYZ or YXZ).
pub fn euler_quat_ordered(deg: Vec3, order: EulerRot) -> Quat {
    let r = deg * (std::f32::consts::PI / 180.0);
    let (qx, qy, qz) =
        (Quat::from_rotation_x(r.x), Quat::from_rotation_y(r.y), Quat::from_rotation_z(r.z));
    match order {
        EulerRot::YXZ => qy * qx * qz,
        _ => qx * qy * qz,
    }
}

/// Inverse of [`euler_quat_ordered`]: `(x, y, z)` in degrees, unique while the middle angle
/// is within (-90, 90).
pub fn quat_euler_ordered(q: Quat, order: EulerRot) -> Vec3 {
    let d = 180.0 / std::f32::consts::PI;
    match order {
        EulerRot::YXZ => {
            let (y, x, z) = q.to_euler(EulerRot::YXZ);
            Vec3::new(x, y, z) * d
        }
        _ => {
            let (x, y, z) = q.to_euler(EulerRot::XYZ);
            Vec3::new(x, y, z) * d
        }
    }
}

/// Rotation of Euler angles in degrees, `Rx(x) * Ry(y) * Rz(z)`.
pub fn euler_quat(deg: Vec3) -> Quat {
    euler_quat_ordered(deg, EulerRot::XYZ)
}

/// Inverse of [`euler_quat`] (degrees), unique while |y| < 90.
pub fn quat_euler(q: Quat) -> Vec3 {
    quat_euler_ordered(q, EulerRot::XYZ)
}

/// Mirror a left-side Euler triple to the right side (and back).
pub fn mirror(deg: Vec3) -> Vec3 {
    Vec3::new(deg.x, -deg.y, -deg.z)
}

/// Builds one frame's pose from anatomical angles (degrees).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseBuilder {
    /// Euler angles per joint in SMPL axes (already mirrored for right joints).
    pub euler_deg: [Vec3; NUM_JOINTS],
    pub trans: Vec3,
}

impl Default for PoseBuilder {
    fn default() -> Self {
        PoseBuilder { euler_deg: [Vec3::ZERO; NUM_JOINTS], trans: Vec3::ZERO }
    }
}

impl PoseBuilder {
    /// The T-pose (every joint at zero).
    pub fn tpose() -> Self {
        Self::default()
    }

    /// Relaxed standing: arms hanging 15 degrees from the body, elbows slightly bent.
    pub fn relaxed() -> Self {
        let mut p = Self::default();
        for s in Side::BOTH {
            p.shoulder(s, -75.0, 0.0, 0.0).elbow(s, 12.0);
        }
        p
    }

    fn add_side(&mut self, left_joint: usize, side: Side, deg: Vec3) -> &mut Self {
        let j = side.joint(left_joint);
        self.euler_deg[j] += match side {
            Side::Left => deg,
            Side::Right => mirror(deg),
        };
        self
    }

    fn set_side(&mut self, left_joint: usize, side: Side, deg: Vec3) -> &mut Self {
        self.euler_deg[side.joint(left_joint)] = Vec3::ZERO;
        self.add_side(left_joint, side, deg)
    }

    /// Hip: flexion (thigh forward), abduction (leg out), external rotation.
    pub fn hip(&mut self, side: Side, flex: f32, abd: f32, ext_rot: f32) -> &mut Self {
        self.set_side(HIP, side, Vec3::new(-flex, ext_rot, abd))
    }

    /// Knee flexion (0 = straight).
    pub fn knee(&mut self, side: Side, flex: f32) -> &mut Self {
        self.set_side(KNEE, side, Vec3::new(flex, 0.0, 0.0))
    }

    /// Ankle dorsiflexion (toes up; negative = plantar flexion).
    pub fn ankle(&mut self, side: Side, dorsi: f32) -> &mut Self {
        self.set_side(ANKLE, side, Vec3::new(-dorsi, 0.0, 0.0))
    }

    /// Shoulder: `elev` raises the arm in the frontal plane from the T-pose (-90 = hanging,
    /// +90 = overhead); then `horiz` swings it forward in the horizontal plane; then `swing`
    /// swings it forward about the body's left-right axis (for hanging arms: forward flexion).
    pub fn shoulder(&mut self, side: Side, elev: f32, swing: f32, horiz: f32) -> &mut Self {
        self.set_side(SHOULDER, side, Vec3::new(-swing, -horiz, elev))
    }

    /// Elbow flexion (0 = straight; the forearm comes forward in the T-pose).
    pub fn elbow(&mut self, side: Side, flex: f32) -> &mut Self {
        self.set_side(ELBOW, side, Vec3::new(0.0, -flex, 0.0))
    }

    /// Collar bone shrug (positive = up).
    pub fn collar(&mut self, side: Side, shrug: f32) -> &mut Self {
        self.set_side(COLLAR, side, Vec3::new(0.0, 0.0, shrug))
    }

    /// Wrist flexion (palm side) and deviation.
    pub fn wrist(&mut self, side: Side, flex: f32, dev: f32) -> &mut Self {
        self.set_side(WRIST, side, Vec3::new(0.0, flex, dev))
    }

    /// Trunk: forward flexion, lateral bend to the right, twist to the left; spread evenly
    /// over the three spine joints.
    pub fn spine(&mut self, flex: f32, lateral_right: f32, twist_left: f32) -> &mut Self {
        let each = Vec3::new(flex, twist_left, lateral_right) / 3.0;
        for j in [SPINE1, SPINE2, SPINE3] {
            self.euler_deg[j] = each;
        }
        self
    }

    /// Neck flexion (chin down) and turn to the left; the head takes a third of each.
    pub fn neck(&mut self, flex: f32, turn_left: f32) -> &mut Self {
        self.euler_deg[NECK] = Vec3::new(flex, turn_left, 0.0) * (2.0 / 3.0);
        self.euler_deg[HEAD] = Vec3::new(flex, turn_left, 0.0) / 3.0;
        self
    }

    /// Global orientation: forward pitch, yaw to the left (about +Y), roll.
    pub fn root(&mut self, pitch_fwd: f32, yaw_left: f32, roll: f32) -> &mut Self {
        self.euler_deg[PELVIS] = Vec3::new(pitch_fwd, yaw_left, roll);
        self
    }

    fn rotation(&self, j: usize) -> Mat3 {
        Mat3::from_quat(euler_quat_ordered(self.euler_deg[j], euler_order(j)))
    }

    /// Vertical extent of one leg (hip to ankle, metres) with the nominal segment lengths.
    pub fn leg_extent(&self, side: Side) -> f32 {
        let root = self.rotation(PELVIS);
        let hip = root * self.rotation(side.joint(HIP));
        let knee = hip * self.rotation(side.joint(KNEE));
        let down = Vec3::NEG_Y;
        let v = hip * down * NOMINAL_THIGH + knee * down * NOMINAL_SHIN;
        -v.y
    }

    /// Lower the body so that the lower ankle stays where it is in the T-pose. The two legs'
    /// extents are combined with a smooth maximum (1 cm blend) so that the root's height stays
    /// C1 when the support switches legs.
    pub fn ground(&mut self) -> &mut Self {
        let (a, b) = (self.leg_extent(Side::Left), self.leg_extent(Side::Right));
        let eps = 0.01;
        let extent = 0.5 * (a + b + ((a - b) * (a - b) + eps * eps).sqrt()) - 0.5 * eps;
        self.trans.y = extent - (NOMINAL_THIGH + NOMINAL_SHIN);
        self
    }

    pub fn build(&self) -> BodyParams {
        let mut pose = [Vec3::ZERO; NUM_JOINTS];
        for (j, p) in pose.iter_mut().enumerate() {
            *p = euler_quat_ordered(self.euler_deg[j], euler_order(j)).to_scaled_axis();
        }
        BodyParams { pose, betas: Vec::new(), trans: self.trans }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::forward_kinematics;
    use crate::body::skeleton::parent;

    /// A skeleton with the open body's proportions, built by hand.
    fn skeleton() -> [Vec3; NUM_JOINTS] {
        let mut j = [Vec3::ZERO; NUM_JOINTS];
        let set = |j: &mut [Vec3; NUM_JOINTS], k: usize, v: Vec3| j[k] = v;
        set(&mut j, 1, Vec3::new(0.1, -0.01, 0.0));
        set(&mut j, 2, Vec3::new(-0.1, -0.01, 0.0));
        set(&mut j, 4, Vec3::new(0.1, -0.40, 0.0));
        set(&mut j, 5, Vec3::new(-0.1, -0.40, 0.0));
        set(&mut j, 7, Vec3::new(0.1, -0.81, 0.0));
        set(&mut j, 8, Vec3::new(-0.1, -0.81, 0.0));
        for (k, y) in [(3, 0.1), (6, 0.25), (9, 0.4), (12, 0.55), (15, 0.65)] {
            set(&mut j, k, Vec3::new(0.0, y, 0.0));
        }
        for s in [1.0f32, -1.0] {
            let o = if s > 0.0 { 0 } else { 1 };
            set(&mut j, 13 + o, Vec3::new(0.03 * s, 0.5, 0.0));
            set(&mut j, 16 + o, Vec3::new(0.17 * s, 0.5, 0.0));
            set(&mut j, 18 + o, Vec3::new(0.42 * s, 0.5, 0.0));
            set(&mut j, 20 + o, Vec3::new(0.65 * s, 0.5, 0.0));
            set(&mut j, 22 + o, Vec3::new(0.75 * s, 0.5, 0.0));
            set(&mut j, 10 + o, Vec3::new(0.1 * s, -0.85, 0.12));
        }
        j
    }

    fn posed(p: &PoseBuilder) -> [Vec3; NUM_JOINTS] {
        let params = p.build();
        forward_kinematics(&skeleton(), &params.rotations(), params.trans).posed_joints()
    }

    #[test]
    fn euler_matches_glam_intrinsic_xyz_and_inverts() {
        let d = Vec3::new(-35.0, 20.0, 70.0);
        let r = d * std::f32::consts::PI / 180.0;
        let q = Quat::from_euler(glam::EulerRot::XYZ, r.x, r.y, r.z);
        assert!(euler_quat(d).abs_diff_eq(q, 1e-6));
        assert!(quat_euler(euler_quat(d)).abs_diff_eq(d, 1e-3));
        let elbow = Vec3::new(5.0, -140.0, 3.0);
        let q = euler_quat_ordered(elbow, euler_order(18));
        assert!(quat_euler_ordered(q, euler_order(18)).abs_diff_eq(elbow, 1e-3));
    }

    #[test]
    fn anatomical_signs_move_limbs_the_documented_way() {
        let j0 = skeleton();
        // Hip flexion brings the knee forward (+z) for both legs.
        let mut p = PoseBuilder::tpose();
        p.hip(Side::Left, 60.0, 0.0, 0.0).hip(Side::Right, 60.0, 0.0, 0.0);
        let j = posed(&p);
        assert!(j[4].z > 0.3 && j[5].z > 0.3, "{:?} {:?}", j[4], j[5]);
        // Knee flexion brings the ankle back (-z) relative to the knee.
        let mut p = PoseBuilder::tpose();
        p.knee(Side::Left, 90.0).knee(Side::Right, 90.0);
        let j = posed(&p);
        assert!(j[7].z < -0.35 && j[8].z < -0.35);
        // Abduction moves each leg outward.
        let mut p = PoseBuilder::tpose();
        p.hip(Side::Left, 0.0, 30.0, 0.0).hip(Side::Right, 0.0, 30.0, 0.0);
        let j = posed(&p);
        assert!(j[7].x > j0[7].x + 0.3 && j[8].x < j0[8].x - 0.3);
        // Shoulder elevation -90 hangs the arms, swing then brings them forward.
        let mut p = PoseBuilder::tpose();
        p.shoulder(Side::Left, -90.0, 0.0, 0.0).shoulder(Side::Right, -90.0, 0.0, 0.0);
        let j = posed(&p);
        assert!((j[18] - Vec3::new(0.17, 0.25, 0.0)).length() < 1e-4, "{}", j[18]);
        assert!((j[19] - Vec3::new(-0.17, 0.25, 0.0)).length() < 1e-4, "{}", j[19]);
        p.shoulder(Side::Left, -90.0, 90.0, 0.0).shoulder(Side::Right, -90.0, 90.0, 0.0);
        let j = posed(&p);
        assert!((j[18] - Vec3::new(0.17, 0.5, 0.25)).length() < 1e-4, "{}", j[18]);
        assert!((j[19] - Vec3::new(-0.17, 0.5, 0.25)).length() < 1e-4, "{}", j[19]);
        // Elbow flexion brings the forearm forward in the T-pose.
        let mut p = PoseBuilder::tpose();
        p.elbow(Side::Left, 90.0).elbow(Side::Right, 90.0);
        let j = posed(&p);
        assert!(j[20].z > 0.2 && j[21].z > 0.2);
        // Spine flexion moves the neck forward; twist to the left turns the left collar back.
        let mut p = PoseBuilder::tpose();
        p.spine(60.0, 0.0, 0.0);
        assert!(posed(&p)[12].z > 0.2);
        let mut p = PoseBuilder::tpose();
        p.spine(0.0, 0.0, 45.0);
        assert!(posed(&p)[16].z < -0.05);
    }

    #[test]
    fn grounding_keeps_the_lower_ankle_at_rest_height() {
        let rest_ankle = skeleton()[7].y;
        let mut p = PoseBuilder::tpose();
        p.hip(Side::Left, 90.0, 0.0, 0.0).knee(Side::Left, 100.0);
        p.hip(Side::Right, 90.0, 0.0, 0.0).knee(Side::Right, 100.0);
        p.ground();
        let j = posed(&p);
        // The test skeleton's thigh/shin are 0.39/0.41 m like the nominal lengths.
        assert!((j[7].y - rest_ankle).abs() < 0.01, "{} vs {}", j[7].y, rest_ankle);
        assert!(p.trans.y < -0.3);
        let _ = parent(1);
    }
}
