//! The avatar, in one place: what a fitted avatar is (the two kinds: a pose-dependent
//! MetaAvatar and a static SDF), how its file is laid out and checked (`header`, `body`), how it
//! is fitted (`MetaAvatar::fit_points_in_chunks`, `StaticAvatar::fit_points`) and loaded
//! (`AnyAvatar::load`, routed by the header's kind). Posing and export see an avatar through
//! `avatar_core::avatar::AvatarSource`, which both kinds implement.

pub mod body;
pub mod header;
pub mod meta_avatar;
pub mod refined_poses;
pub mod static_avatar;

use crate::weights_file;
pub use header::PartialFit;
pub use meta_avatar::{Init, MetaAvatar, META_AVATAR_KIND};
pub use static_avatar::{FitReport, StaticAvatar, STATIC_AVATAR_KIND};

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
            STATIC_AVATAR_KIND => Ok(AnyAvatar::Static(StaticAvatar::load(path)?)),
            META_AVATAR_KIND => Ok(AnyAvatar::Meta(MetaAvatar::load(path)?)),
            other => Err(avatar_core::error::Error::file(path, format!("{other:?} is not an avatar this build can load ({STATIC_AVATAR_KIND} or {META_AVATAR_KIND})"))),
        }
    }

    pub fn source(&self) -> &dyn avatar_core::avatar::AvatarSource {
        match self {
            AnyAvatar::Static(a) => a,
            AnyAvatar::Meta(a) => a,
        }
    }

    /// How far a cancelled fit got (None for a finished avatar).
    pub fn partial(&self) -> Option<PartialFit> {
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
