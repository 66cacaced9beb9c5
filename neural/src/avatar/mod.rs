//! The avatar, in one place. A newcomer's map:
//!
//! | what | where |
//! |---|---|
//! | defined: the two kinds, and either one | `meta_avatar.rs` (pose-dependent MetaAvatar), `static_avatar.rs` (static SDF), [`AnyAvatar`] (routed by the header's kind) |
//! | what posing and export need of an avatar | `avatar_core::avatar::AvatarSource` (re-exported here; both kinds implement it) |
//! | fitted | `fitting.rs`: [`fit_avatar`], one chunked entry point for both kinds (the CLI's `fit`, the studio's job, the evaluation's rows) |
//! | saved and loaded | `save`/`load` of each kind, [`AnyAvatar::load`]; the file's header and its one check in `header.rs`, the stored body in `body.rs` |
//! | posed | `MetaAvatar::posed_mesh`; a reference mesh projected and skinned at a pose: [`PoseSurface`] (the studio's poser and the exporter) |
//! | exported | [`export_glb`] (animated glTF) |
//!
//! Posing and export are written once in `avatar_core` (the exporter needs no burn) and
//! re-exported here.

pub mod body;
pub mod eval_rows;
mod fit_once;
pub mod fit_plan;
pub mod fitting;
pub mod header;
pub mod meta_avatar;
pub mod refined_poses;
pub mod resolution;
pub mod static_avatar;

use crate::model::weights_file;
pub use avatar_core::avatar::{AvatarSource, PROJECTION_STEPS, PoseSurface};
pub use avatar_core::export::{ExportOptions, export_glb};
pub use fit_plan::{FitPhase, FitPlan, TimeLeft};
pub use fitting::{AvatarFit, FitEvent, FitKind, FitReport, fit_avatar};
pub use header::PartialFit;
pub use meta_avatar::{Init, META_AVATAR_KIND, MetaAvatar};
pub use resolution::MeshResolution;
pub use static_avatar::{STATIC_AVATAR_KIND, StaticAvatar};

/// An avatar file of either kind, routed by its header.
// Made once per fit or load and then kept in place: boxing the larger kind buys nothing.
#[allow(clippy::large_enum_variant)]
pub enum AnyAvatar {
    Static(StaticAvatar),
    Meta(MetaAvatar),
}

impl AnyAvatar {
    /// Read an avatar file of either kind (its skinning field from `field_cache` when it is
    /// there).
    pub fn load(
        path: impl AsRef<std::path::Path>,
        field_cache: &avatar_core::canonical::FieldCache,
    ) -> crate::error::Result<AnyAvatar> {
        let path = path.as_ref();
        let id = weights_file::identity(path)?;
        match id.kind.as_str() {
            STATIC_AVATAR_KIND => Ok(AnyAvatar::Static(StaticAvatar::load(path, field_cache)?)),
            META_AVATAR_KIND => Ok(AnyAvatar::Meta(MetaAvatar::load(path, field_cache)?)),
            other => Err(crate::error::Error::AvatarKind {
                path: path.into(),
                kind: other.into(),
                known: format!("{STATIC_AVATAR_KIND} or {META_AVATAR_KIND}"),
            }),
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

    pub fn save(&self, path: impl AsRef<std::path::Path>) -> crate::error::Result<()> {
        match self {
            AnyAvatar::Static(a) => a.save(path),
            AnyAvatar::Meta(a) => a.save(path),
        }
    }

    /// Mesh it at `resolution` from now on (posing, export).
    pub fn set_mesh_resolution(&mut self, resolution: MeshResolution) {
        match self {
            AnyAvatar::Static(a) => a.set_mesh_resolution(resolution),
            AnyAvatar::Meta(a) => a.set_mesh_resolution(resolution),
        }
    }
}
