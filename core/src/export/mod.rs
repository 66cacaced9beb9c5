//! Export: animated binary glTF (skinned mesh, PCA morph targets for the pose-dependent
//! clothing, joint and morph-weight animation) and OBJ/PLY sequences. See docs/export.md.

pub mod animated;
pub mod glb;
pub mod morph;
pub mod source;

pub use crate::avatar::AvatarSource;
pub use animated::{DEFAULT_COLOR, ExportOptions, Exported, export_glb, top4, write_mesh_sequence};
pub use morph::{MorphTargets, compress};
pub use source::SyntheticAvatar;
