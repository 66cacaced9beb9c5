//! Synthetic clothed humans: outfits, pose-dependent clothing deformation, depth rendering,
//! ground truth. See docs/synthetic-data.md.

pub mod camera;
pub mod cloth;
pub mod contact_sheet;
pub mod deform;
pub mod generate;
pub mod ground_truth;
pub mod noise;
pub mod outfit;
pub mod raster;
pub mod scans;
pub mod smpl_stand_in;

pub use camera::{PinholeCamera, look_at, orbit};
pub use deform::{PoseFeatures, canonical_surface, pose_surface};
pub use generate::{SynthJob, SynthReport, generate_capture, subject_betas};
pub use ground_truth::{GroundTruth, GtFrame};
pub use noise::DepthNoise;
pub use outfit::{ALL_OUTFITS, ClothedTemplate, Outfit, SIM_OUTFITS};
pub use raster::{DepthRender, NO_TRIANGLE, render_depth};
pub use scans::save_scans;
pub use smpl_stand_in::{generate_smpl_capture, smpl_stand_in};
