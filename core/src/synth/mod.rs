//! Synthetic clothed humans: outfits, pose-dependent clothing deformation, depth rendering, ground truth.

pub mod camera;
pub mod noise;
pub mod raster;

pub use camera::{look_at, orbit, PinholeCamera};
pub use noise::DepthNoise;
pub use raster::{render_depth, DepthRender, NO_TRIANGLE};
