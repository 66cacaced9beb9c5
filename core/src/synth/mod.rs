//! Synthetic clothed humans: outfits, pose-dependent clothing deformation, depth rendering,
//! ground truth. See docs/synthetic-data.md.

pub mod camera;
pub mod contact_sheet;
pub mod deform;
pub mod generate;
pub mod ground_truth;
pub mod noise;
pub mod outfit;
pub mod raster;
pub mod smpl_stand_in;

pub use camera::{look_at, orbit, PinholeCamera};
pub use deform::{canonical_surface, pose_surface, PoseFeatures};
pub use generate::{generate_capture, subject_betas, SynthJob, SynthReport};
pub use ground_truth::{GroundTruth, GtFrame};
pub use noise::DepthNoise;
pub use outfit::{ClothedTemplate, Outfit, ALL_OUTFITS};
pub use raster::{render_depth, DepthRender, NO_TRIANGLE};
pub use smpl_stand_in::{generate_smpl_capture, smpl_stand_in};
