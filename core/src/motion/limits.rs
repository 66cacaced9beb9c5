//! Human joint limits the procedural clips are held to, as Euler ranges (degrees) in SMPL's
//! joint axes, `R = Rx(x) * Ry(y) * Rz(z)` (elbows: `Ry * Rx * Rz`; see [`super::pose_builder`] for the axis meanings).
//! Ranges are written for the left side; the right side is mirrored (y and z ranges negated).
//!
//! Sources of the anatomical ranges: the usual clinical range-of-motion tables (AAOS): hip
//! flexion 120, extension 30, abduction 45, adduction 30, rotation 45; knee flexion 135-150;
//! ankle dorsiflexion 20 (30 weight-bearing, as in a deep squat), plantar flexion 50; thoracolumbar flexion 80, extension 25, lateral
//! bend 35, rotation 45 (split over three spine joints); cervical flexion/extension 45-50,
//! rotation 60-80; shoulder abduction 180 (90 above the T-pose), flexion 180, extension 60;
//! elbow flexion 145-150.

use super::clip::MotionClip;
use super::pose_builder::{euler_order, quat_euler_ordered};
use crate::body::{JOINT_NAMES, NUM_JOINTS};
use crate::error::{Error, Result};
use glam::{Quat, Vec3};

/// Allowed Euler range of one joint (left-side convention, degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimit {
    pub min: Vec3,
    pub max: Vec3,
}

const fn lim(x: (f32, f32), y: (f32, f32), z: (f32, f32)) -> JointLimit {
    JointLimit { min: Vec3::new(x.0, y.0, z.0), max: Vec3::new(x.1, y.1, z.1) }
}

const FREE: JointLimit = lim((-180.0, 180.0), (-90.0, 90.0), (-180.0, 180.0));
const HIP: JointLimit = lim((-120.0, 30.0), (-45.0, 45.0), (-30.0, 45.0));
const KNEE: JointLimit = lim((0.0, 145.0), (-5.0, 5.0), (-5.0, 5.0));
const ANKLE: JointLimit = lim((-30.0, 50.0), (-25.0, 25.0), (-25.0, 25.0));
const FOOT: JointLimit = lim((-40.0, 30.0), (-5.0, 5.0), (-5.0, 5.0));
const SPINE: JointLimit = lim((-10.0, 30.0), (-15.0, 15.0), (-12.0, 12.0));
const NECK: JointLimit = lim((-35.0, 35.0), (-50.0, 50.0), (-30.0, 30.0));
const HEAD: JointLimit = lim((-20.0, 20.0), (-30.0, 30.0), (-15.0, 15.0));
const COLLAR: JointLimit = lim((-15.0, 15.0), (-20.0, 20.0), (-10.0, 30.0));
// Shoulder (from the T-pose): elevation z from -95 (hanging, against the body) to +95
// (overhead); swing about the left-right axis -x up to 170 forward, 60 back; horizontal
// flexion -y up to 60 forward, 45 back.
const SHOULDER: JointLimit = lim((-170.0, 60.0), (-60.0, 45.0), (-95.0, 95.0));
const ELBOW: JointLimit = lim((-10.0, 10.0), (-150.0, 0.0), (-10.0, 10.0));
const WRIST: JointLimit = lim((-80.0, 80.0), (-70.0, 70.0), (-40.0, 40.0));
const HAND: JointLimit = lim((-20.0, 20.0), (-30.0, 30.0), (-30.0, 30.0));

/// Limits per SMPL joint (left-side convention; pelvis = global orientation, unrestricted
/// except that |y| < 90 keeps the Euler decomposition unique).
pub const JOINT_LIMITS: [JointLimit; NUM_JOINTS] = [
    FREE, HIP, HIP, SPINE, KNEE, KNEE, SPINE, ANKLE, ANKLE, SPINE, FOOT, FOOT, NECK, COLLAR,
    COLLAR, HEAD, SHOULDER, SHOULDER, ELBOW, ELBOW, WRIST, WRIST, HAND, HAND,
];

/// Whether joint `j` is a right-side joint (its Euler y/z are mirrored before the check).
fn is_right(j: usize) -> bool {
    JOINT_NAMES[j].starts_with("right_")
}

/// Euler angles (degrees, left-side convention) of an axis-angle rotation of joint `j`.
pub fn joint_euler(j: usize, axis_angle: Vec3) -> Vec3 {
    let e = quat_euler_ordered(Quat::from_scaled_axis(axis_angle), euler_order(j));
    if is_right(j) { Vec3::new(e.x, -e.y, -e.z) } else { e }
}

/// Check every frame of a clip against [`JOINT_LIMITS`] (with `tol_deg` slack); the error
/// names the clip, frame, joint, axis and angle.
pub fn check_clip_limits(clip: &MotionClip, tol_deg: f32) -> Result<()> {
    for (f, params) in clip.frames.iter().enumerate() {
        for j in 1..NUM_JOINTS {
            let e = joint_euler(j, params.pose[j]);
            let l = JOINT_LIMITS[j];
            for (axis, v, lo, hi) in [
                ("x", e.x, l.min.x, l.max.x),
                ("y", e.y, l.min.y, l.max.y),
                ("z", e.z, l.min.z, l.max.z),
            ] {
                if v < lo - tol_deg || v > hi + tol_deg {
                    return Err(Error::invalid(format!(
                        "clip '{}' frame {f}: {} {axis} = {v:.1} deg outside [{lo}, {hi}]",
                        clip.name, JOINT_NAMES[j]
                    )));
                }
            }
        }
    }
    Ok(())
}
