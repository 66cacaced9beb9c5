//! The neural avatar (MetaAvatar): the networks (SIREN SDF, bone encoder, hypernetwork), the
//! IGR loss, training (`train/`, hand-derived gradients on the CPU; burn 0.22 as the reference
//! and for the GPU), meta-learning (`meta_training`), and the avatar itself (`avatar/`: its
//! kinds, file, fitting and loading).

pub mod avatar;
pub mod body_sdf;
pub mod encoder;
pub mod error;
pub mod eval_rows;
pub mod capture_points;
pub mod compute;
pub mod fit;
pub mod hyper;
pub mod hyper_fit;
pub mod loss;
pub mod pose_refine;
pub mod pose_trace;
pub mod pose_sample;
pub mod meta_training;
pub mod meta_data;
pub mod model_file;
pub mod off_surface;
pub mod flat_params;
pub mod siren;
pub mod siren_eval;
pub mod train;
pub mod weights_file;

pub use fit::{fit_sdf, sdf_values, FitOptions};
pub use loss::{igr_loss, IgrWeights};
pub use encoder::{BoneEncoder, PoseEncoding};
pub use hyper::{HyperConfig, HyperNet};
pub use hyper_fit::{fit_hyper, HyperFitOptions, HyperOptimisers};
pub use pose_sample::PoseSample;
pub use siren::{batched_sdf_and_gradient, sdf_and_gradient, Siren, SirenConfig};
pub use avatar::{AnyAvatar, FitReport, Init, MetaAvatar, PartialFit, StaticAvatar};
pub use model_file::MetaModel;
pub use error::{Error, Result};

/// The CPU device with autodiff (gradients for training).
pub fn cpu_training_device() -> burn::tensor::Device {
    burn::tensor::Device::flex().autodiff()
}

/// The CPU device without autodiff (inference).
pub fn cpu_device() -> burn::tensor::Device {
    burn::tensor::Device::flex()
}
