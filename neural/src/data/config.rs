//! The data stage's configs check themselves (`config::Check`).

use crate::config::{Check, at_least};
use crate::data::meta_data::MetaDataConfig;
use crate::data::own_data::OwnDataOptions;
use crate::error::{Error, Result};

impl Check for MetaDataConfig {
    /// At least one subject, outfit, pose a group and point a pose.
    fn check(&self) -> Result<()> {
        at_least("subjects", self.subjects, 1)?;
        if self.outfits.is_empty() {
            return Err(Error::option("outfits", &"none", "at least one outfit"));
        }
        at_least("poses_per_group", self.poses_per_group, 1)?;
        at_least("points_per_pose", self.points_per_pose, 1)
    }
}

impl Check for OwnDataOptions {
    /// At least one point a sample and one frame a capture.
    fn check(&self) -> Result<()> {
        at_least("points_per_pose", self.points_per_pose, 1)?;
        at_least("frames_per_capture", self.frames_per_capture, 1)
    }
}
