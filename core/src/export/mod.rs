//! Export: animated binary glTF (skinned mesh, PCA morph targets for the pose-dependent
//! clothing, joint and morph-weight animation) and OBJ/PLY sequences. See docs/export.md.

pub mod animated;
mod frame;
pub mod glb;
pub mod keyframes;
pub mod morph;
mod options;
pub mod source;
pub mod stream;

pub use crate::avatar::AvatarSource;
pub use animated::{
    DEFAULT_COLOR, ExportOptions, Exported, check_clip, export_glb, export_glb_streaming,
    export_glb_with, top4, write_mesh_sequence,
};
pub use morph::{Basis, MorphTargets, compress};
pub use source::SyntheticAvatar;
pub use stream::{CANCELLED, Control, FrameMaker, Progress, for_each_posed};
