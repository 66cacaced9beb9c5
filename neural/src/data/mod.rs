//! What the networks train on: a capture canonicalized into points (`capture_points`), one
//! frame's points as a pose sample (`pose_sample`), the off-surface points a step draws
//! (`off_surface`), the subject's body as an SDF (`body_sdf`, pre-alignment's target), and
//! meta-training data (`meta_data`: generated subjects; `own_data`: a studio's own scans).
//! Configs: `MetaDataConfig`, `OwnDataOptions` (`config::Check`).

pub mod body_sdf;
pub mod capture_points;
mod config;
pub mod meta_data;
pub mod off_surface;
pub mod own_data;
pub mod pose_sample;
