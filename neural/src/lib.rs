//! The neural avatar (MetaAvatar), one module per stage (docs/architecture.md has the map):
//!
//! - [`model`]: the networks (SIREN SDF, bone encoder, hypernetwork) and their files;
//! - [`data`]: what the networks train on (a capture's canonical points, pose samples,
//!   off-surface points, meta-training data);
//! - [`training`]: the IGR loss, the fits (static SDF, hypernetwork), meta-learning, pose
//!   refinement, and the training step's arithmetic (`training::step`: hand-derived gradients on
//!   the CPU; burn 0.22 as the reference and for the GPU);
//! - [`avatar`]: the avatar itself (its kinds, file, fitting recipe, meshes at a resolution,
//!   posing and the evaluation's rows).
//!
//! Each stage's options check themselves ([`config::Check`]) where they enter the library.

pub mod avatar;
pub mod compute;
pub mod config;
pub mod data;
pub mod error;
pub mod model;
pub mod training;

// Flat paths (`avatar_neural::siren`, `avatar_neural::train`, ...) beside the stage paths, for
// the tests and examples written against them (they cost nothing).
#[doc(hidden)]
pub use avatar::eval_rows;
#[doc(hidden)]
pub use data::{body_sdf, capture_points, meta_data, off_surface, own_data, pose_sample};
#[doc(hidden)]
pub use model::{encoder, flat_params, hyper, model_file, sine, siren, siren_eval, weights_file};
#[doc(hidden)]
pub use training::step as train;
#[doc(hidden)]
pub use training::{collective, fit, hyper_fit, loss, meta_training, pose_refine, pose_trace};

pub use avatar::{AnyAvatar, FitReport, Init, MetaAvatar, PartialFit, StaticAvatar};
pub use config::Check;
pub use data::pose_sample::PoseSample;
pub use error::{Error, Result};
pub use model::encoder::{BoneEncoder, PoseEncoding};
pub use model::hyper::{HyperConfig, HyperNet};
pub use model::model_file::{MetaModel, PriorRef};
pub use model::siren::{Siren, SirenConfig, batched_sdf_and_gradient, sdf_and_gradient};
pub use training::fit::{FitOptions, fit_sdf, sdf_values};
pub use training::hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
pub use training::loss::{IgrWeights, igr_loss};

/// The CPU device with autodiff (gradients for training).
pub fn cpu_training_device() -> burn::tensor::Device {
    burn::tensor::Device::flex().autodiff()
}

/// The CPU device without autodiff (inference).
pub fn cpu_device() -> burn::tensor::Device {
    burn::tensor::Device::flex()
}
