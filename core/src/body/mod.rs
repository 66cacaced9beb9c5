//! The articulated body: SMPL's 24-joint skeleton, shape blend shapes, pose correctives,
//! forward kinematics and linear blend skinning. One `BodyModel` serves both the embedded open
//! body (MakeHuman CC0) and a user's own SMPL `.npz`.

pub mod embedded;
pub mod frozen;
pub mod kinematics;
pub mod load;
pub mod model;
pub mod params;
pub mod pose_jacobian;
pub mod save;
pub mod skeleton;
pub mod skinning;

pub use embedded::{open_body, open_body_lowpoly, open_body_lowpoly_ref, open_body_ref};
pub use kinematics::{Bones, forward_kinematics};
pub use model::{BodyModel, PosedBody};
pub use params::{BodyParams, MAX_ABS_BETA, check_betas};
pub use pose_jacobian::{POSE_DOF, PoseCorrection, pose_error, skinned_point_jacobian};
pub use skeleton::{BodyPart, JOINT_NAMES, NUM_JOINTS, SMPL_PARENTS};
pub use skinning::{
    Weights, blend_transform, interpolate_weights, skin_normal, skin_point, unskin_point,
};
