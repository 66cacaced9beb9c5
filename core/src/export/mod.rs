//! Export: animated binary glTF (skinned mesh, PCA morph targets for the pose-dependent
//! clothing, joint and morph-weight animation) and OBJ/PLY sequences. See docs/export.md.

pub mod animated;
pub mod glb;
pub mod morph;
pub mod source;

pub use animated::{export_glb, top4, write_mesh_sequence, ExportOptions, Exported, DEFAULT_COLOR};
pub use morph::{compress, MorphTargets};
pub use crate::avatar::AvatarSource;
pub use source::SyntheticAvatar;
