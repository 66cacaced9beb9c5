//! Motion clips: a sequence of body parameters at a frame rate; the procedural clip library; clip files.
//!
//! - [`MotionClip`] with JSON (`save_json` / `load`), AMASS-style npz and BVH motion capture
//!   loading ([`bvh`], retargeted to the SMPL skeleton by [`retarget`]).
//! - [`library`]: procedural clips built from joint-angle curves within documented human joint
//!   limits ([`limits`]), deterministic and C1-smooth, 30 fps, 2-4 s each.
//! - [`library_split`]: the clips used for training vs the ones held out for evaluation.

pub mod amass;
pub mod bvh;
pub mod bvh_write;
pub mod clip;
pub mod curves;
pub mod library;
pub mod limits;
pub mod open;
pub mod pose_builder;
pub mod resample;
pub mod retarget;

pub use clip::{MAX_CLIP_FRAMES, MAX_FPS, MIN_FPS, MotionClip};
pub use library::{HELDOUT_CLIPS, LIBRARY_FPS, clip_by_name, clip_names, library, library_split};
pub use limits::{JOINT_LIMITS, JointLimit, check_clip_limits};
pub use open::{clip_file, library_clip, open_clip, open_clip_at};
pub use pose_builder::{PoseBuilder, Side};
pub use resample::{DEFAULT_TARGET_FPS, MAX_TARGET_FPS, MIN_TARGET_FPS, resampled_len};
