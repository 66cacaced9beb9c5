//! Evaluation: MetaAvatar's metrics (Dp, Df, NC), IoU, Chamfer, protocols and reports.

pub mod metrics;
pub mod occupancy;
pub mod sampling;
