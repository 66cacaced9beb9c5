//! Evaluation: MetaAvatar's metrics (Dp, Df, NC), IoU, Chamfer, the protocols on held-out
//! synthetic subjects and the reports. See docs/evaluation.md.

pub mod conditions;
pub mod dataset;
pub mod integrity;
pub mod metrics;
pub mod occupancy;
pub mod predictor;
mod prepared;
pub mod protocol;
pub mod report;
pub mod runner;
pub mod sampling;
mod summary;
pub mod surface_error;
pub mod truth;

pub use conditions::CaptureConditions;
pub use metrics::Regions;
pub use predictor::{FitData, NakedBody, Predictor, StaticOutfit};
pub use protocol::{Protocol, Shots};
pub use runner::{EvalConfig, Report, RowResult, run};
