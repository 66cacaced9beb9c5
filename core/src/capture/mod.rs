//! Captures: the `capture.json` folder format, 16-bit depth PNGs, back-projection to oriented
//! points, cropping to the person, and imports (AMASS-style fittings, TUM depth scale).
//! See docs/capture-format.md.

pub mod amass;
pub mod depth_png;
pub mod manifest;
pub mod open;
pub mod points;

pub use depth_png::{read_depth_png, read_mask_png, write_depth_png, write_mask_png, DepthImage};
pub use manifest::{BodyModelRef, CaptureManifest, FrameRecord, Intrinsics, DEPTH_SCALE_MM, DEPTH_SCALE_TUM, MANIFEST_FILE};
pub use open::{Capture, CaptureFrame, CaptureOptions, FrameError};
pub use points::{backproject, crop_to_body, estimate_normals, CropOptions, CropReport};
