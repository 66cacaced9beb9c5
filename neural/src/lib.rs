//! The neural avatar (MetaAvatar): a SIREN SDF with forward-mode spatial gradients, the IGR
//! loss and SDF fitting (burn 0.22, flex CPU backend). The hypernetwork, meta-learning,
//! fine-tuning of captures and posing build on these (issue 6).

pub mod fit;
pub mod loss;
pub mod siren;
pub mod static_avatar;

pub use fit::{fit_sdf, sdf_values, FitOptions};
pub use loss::{igr_loss, IgrWeights};
pub use siren::{sdf_and_gradient, Siren, SirenConfig};
pub use static_avatar::{StaticAvatar, FitReport};

/// The CPU device with autodiff (gradients for training).
pub fn cpu_training_device() -> burn::tensor::Device {
    burn::tensor::Device::flex().autodiff()
}

/// The CPU device without autodiff (inference).
pub fn cpu_device() -> burn::tensor::Device {
    burn::tensor::Device::flex()
}
