//! Captures: the `capture.json` folder format, 16-bit depth PNGs, back-projection to oriented
//! points, free-space samples on the camera rays, the frames a fit takes from a long capture, cropping to the person, units and plausibility checks, and imports (a depth folder
//! with AMASS-style or JSON fittings, TUM depth scale, OBJ scans).
//! See docs/capture-format.md.

pub mod amass;
pub mod depth_png;
pub mod frame_choice;
pub mod frame_error;
pub mod free_space;
pub mod import;
pub mod manifest;
pub mod open;
pub mod plausibility;
pub mod points;
pub mod scan;
pub mod units;

pub use depth_png::{DepthImage, read_depth_png, read_mask_png, write_depth_png, write_mask_png};
pub use frame_choice::FrameChoice;
pub use free_space::{FreeSpaceOptions, free_space_samples};
pub use manifest::{
    BodyModelRef, CaptureManifest, DEPTH_SCALE_MM, DEPTH_SCALE_TUM, FrameRecord, Intrinsics,
    MANIFEST_FILE,
};
pub use open::{
    Capture, CaptureFrame, CaptureOptions, CaptureSource, FrameError, MAX_OPEN_BYTES,
    NO_DEPTH_NEAR_BODY,
};
pub use points::{CropOptions, CropReport, backproject, crop_to_body, estimate_normals};
