//! Motion clips: a sequence of body parameters at a frame rate; the procedural clip library; clip files.
//!
//! - [`MotionClip`] with JSON (`save_json` / `load`), AMASS-style npz and BVH motion capture
//!   loading ([`bvh`], retargeted to the SMPL skeleton by [`retarget`]).
//! - [`library`]: procedural clips built from joint-angle curves within documented human joint
//!   limits ([`limits`]), deterministic and C1-smooth, 30 fps, 2-4 s each.
//! - [`library_split`]: the clips used for training vs the ones held out for evaluation.

pub mod amass;
pub mod bvh;
pub mod clip;
pub mod curves;
pub mod library;
pub mod limits;
pub mod open;
pub mod pose_builder;
pub mod retarget;

pub use clip::{MotionClip, MAX_FPS, MIN_FPS};
pub use library::{clip_by_name, clip_names, library, library_split, HELDOUT_CLIPS, LIBRARY_FPS};
pub use limits::{check_clip_limits, JointLimit, JOINT_LIMITS};
pub use open::{clip_file, library_clip, open_clip};
pub use pose_builder::{PoseBuilder, Side};
