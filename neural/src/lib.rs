//! The neural avatar (MetaAvatar): a SIREN SDF with forward-mode spatial gradients, the IGR
//! loss and SDF fitting (burn 0.22, flex CPU backend). The hypernetwork, meta-learning,
//! fine-tuning of captures and posing build on these (issue 6).

pub mod avatar_header;
pub mod avatar_body;
pub mod encoder;
pub mod eval_rows;
pub mod bench;
pub mod capture_points;
pub mod compute;
pub mod fit;
pub mod hyper;
pub mod hyper_fit;
pub mod loss;
pub mod meta;
pub mod meta_avatar;
pub mod meta_data;
pub mod model_file;
pub mod params;
pub mod siren;
pub mod siren_eval;
pub mod static_avatar;
pub mod train;
pub mod weights_file;

pub use fit::{fit_sdf, sdf_values, FitOptions};
pub use loss::{igr_loss, IgrWeights};
pub use encoder::{BoneEncoder, PoseEncoding};
pub use hyper::{HyperConfig, HyperNet};
pub use hyper_fit::{fit_hyper, HyperFitOptions, HyperOptimisers, PoseSample};
pub use siren::{batched_sdf_and_gradient, sdf_and_gradient, Siren, SirenConfig};
pub use meta_avatar::{Init, MetaAvatar};
pub use model_file::MetaModel;
pub use static_avatar::{FitReport, StaticAvatar};
pub use avatar_header::PartialFit;

/// The CPU device with autodiff (gradients for training).
pub fn cpu_training_device() -> burn::tensor::Device {
    burn::tensor::Device::flex().autodiff()
}

/// The CPU device without autodiff (inference).
pub fn cpu_device() -> burn::tensor::Device {
    burn::tensor::Device::flex()
}

/// An avatar file of either kind, routed by its header.
pub enum AnyAvatar {
    Static(StaticAvatar),
    Meta(MetaAvatar),
}

impl AnyAvatar {
    pub fn load(path: impl AsRef<std::path::Path>) -> avatar_core::error::Result<AnyAvatar> {
        let path = path.as_ref();
        let id = weights_file::identity(path)?;
        match id.kind.as_str() {
            "static-sdf" => Ok(AnyAvatar::Static(StaticAvatar::load(path)?)),
            meta_avatar::META_AVATAR_KIND => Ok(AnyAvatar::Meta(MetaAvatar::load(path)?)),
            other => Err(avatar_core::error::Error::file(path, format!("{other:?} is not an avatar this build can load (static-sdf or meta-hyper)"))),
        }
    }

    pub fn source(&self) -> &dyn avatar_core::export::AvatarSource {
        match self {
            AnyAvatar::Static(a) => a,
            AnyAvatar::Meta(a) => a,
        }
    }

    /// How far a cancelled fit got (None for a finished avatar).
    pub fn partial(&self) -> Option<avatar_header::PartialFit> {
        match self {
            AnyAvatar::Static(a) => a.header.partial,
            AnyAvatar::Meta(a) => a.header.partial,
        }
    }

    pub fn set_resolution(&mut self, resolution: usize) {
        match self {
            AnyAvatar::Static(a) => a.resolution = resolution,
            AnyAvatar::Meta(a) => a.resolution = resolution,
        }
    }
}
