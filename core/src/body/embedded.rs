//! The embedded open body: MakeHuman (MPFB2) CC0 assets converted to SMPL's 24-joint layout
//! (see docs/open-body.md). Built into the binary so the studio works with no downloads.

use super::model::BodyModel;
use std::sync::OnceLock;

/// The full open body's npz file, as embedded (`avatar-studio bench` times its loading).
pub const FULL_NPZ: &[u8] = include_bytes!("../../../assets/body/open_body.npz");
const LOWPOLY_NPZ: &[u8] = include_bytes!("../../../assets/body/open_body_lowpoly.npz");
const METADATA: &str = include_str!("../../../assets/body/open_body.json");

#[derive(serde::Deserialize)]
struct Metadata {
    shape_names: Vec<String>,
    shape_limits: Vec<(f32, f32)>,
}

fn build(bytes: &[u8], label: &str) -> BodyModel {
    // The embedded files are checked by the test suite; failing here is a build defect.
    let mut model = BodyModel::from_npz_bytes(bytes, label).expect("embedded open body is valid");
    let meta: Metadata =
        serde_json::from_str(METADATA).expect("embedded open body metadata is valid");
    model.shape_names = meta.shape_names;
    model.shape_limits = meta.shape_limits;
    model
}

/// The full-resolution open body (about 13.4k vertices), loaded once.
pub fn open_body_ref() -> &'static BodyModel {
    static MODEL: OnceLock<BodyModel> = OnceLock::new();
    MODEL.get_or_init(|| build(FULL_NPZ, "open body (MakeHuman CC0)"))
}

/// The low-poly open body (about 1.2k vertices) for fast previews, loaded once.
pub fn open_body_lowpoly_ref() -> &'static BodyModel {
    static MODEL: OnceLock<BodyModel> = OnceLock::new();
    MODEL.get_or_init(|| build(LOWPOLY_NPZ, "open body low-poly (MakeHuman CC0)"))
}

pub fn open_body() -> BodyModel {
    open_body_ref().clone()
}

pub fn open_body_lowpoly() -> BodyModel {
    open_body_lowpoly_ref().clone()
}
