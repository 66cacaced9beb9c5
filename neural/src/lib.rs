//! The neural avatar (MetaAvatar): the networks (SIREN SDF, bone encoder, hypernetwork), the
//! IGR loss, training (`train/`, hand-derived gradients on the CPU; burn 0.22 as the reference
//! and for the GPU), meta-learning (`meta_training`), and the avatar itself (`avatar/`: its
//! kinds, file, fitting and loading).

pub mod avatar;
pub mod body_sdf;
pub mod capture_points;
pub mod collective;
pub mod compute;
pub mod encoder;
pub mod error;
pub mod eval_rows;
pub mod fit;
pub mod flat_params;
pub mod hyper;
pub mod hyper_fit;
pub mod loss;
pub mod meta_data;
pub mod meta_training;
pub mod model_file;
pub mod off_surface;
pub mod own_data;
pub mod pose_refine;
pub mod pose_sample;
pub mod pose_trace;
pub mod sine;
pub mod siren;
pub mod siren_eval;
pub mod train;
pub mod weights_file;

pub use avatar::{AnyAvatar, FitReport, Init, MetaAvatar, PartialFit, StaticAvatar};
pub use encoder::{BoneEncoder, PoseEncoding};
pub use error::{Error, Result};
pub use fit::{FitOptions, fit_sdf, sdf_values};
pub use hyper::{HyperConfig, HyperNet};
pub use hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
pub use loss::{IgrWeights, igr_loss};
pub use model_file::{MetaModel, PriorRef};
pub use pose_sample::PoseSample;
pub use siren::{Siren, SirenConfig, batched_sdf_and_gradient, sdf_and_gradient};

/// The CPU device with autodiff (gradients for training).
pub fn cpu_training_device() -> burn::tensor::Device {
    burn::tensor::Device::flex().autodiff()
}

/// The CPU device without autodiff (inference).
pub fn cpu_device() -> burn::tensor::Device {
    burn::tensor::Device::flex()
}
