//! The avatar file's optional record of pose refinement (PINA 3.2): for each training frame,
//! the fitting the capture gave and the one the fit refined it to. Files without it (older
//! files, fits with `--refine-poses off`) load without it; the studio shows the refined pose of
//! a capture frame whose given fitting matches.

use avatar_core::body::{BodyParams, pose_error};
use avatar_core::error::{Error, Result};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefinedPose {
    pub given: BodyParams,
    pub refined: BodyParams,
}

/// Check the section of a header that says it holds `frames` training frames.
pub fn check(poses: &[RefinedPose], frames: usize) -> Result<()> {
    if poses.len() != frames {
        return Err(Error::invalid(format!(
            "\"refined_poses\" holds {} frames, the avatar was fitted on {frames}",
            poses.len()
        )));
    }
    for (i, p) in poses.iter().enumerate() {
        p.given
            .validate()
            .and_then(|_| p.refined.validate())
            .map_err(|e| Error::invalid(format!("\"refined_poses\" frame {i}: {e}")))?;
    }
    Ok(())
}

/// Mean correction over frames: joint angle (degrees) and translation (centimetres).
pub fn mean_correction(poses: &[RefinedPose]) -> (f32, f32) {
    let n = poses.len().max(1) as f32;
    let (a, t) = poses
        .iter()
        .map(|p| pose_error(&p.given, &p.refined))
        .fold((0.0, 0.0), |(a, t), (x, y)| (a + x, t + y));
    (a.to_degrees() / n, t * 100.0 / n)
}

/// The refined fitting of a frame whose given fitting is `given` (the same capture's numbers).
pub fn refined_for<'a>(poses: &'a [RefinedPose], given: &BodyParams) -> Option<&'a BodyParams> {
    poses
        .iter()
        .find(|p| p.given.pose == given.pose && p.given.trans == given.trans)
        .map(|p| &p.refined)
}
