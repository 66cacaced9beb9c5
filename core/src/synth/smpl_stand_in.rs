//! A stand-in for a user's SMPL model, so the SMPL path (captures fitted with the user's own
//! model file, avatars that carry its frozen body) is tested and shown without a licensed file:
//! the low-poly open body re-expressed in SMPL's npz layout with shape directions of its own.
//! Its ten directions are the open body's seven in reverse order and halved, then overall
//! scale, height and girth about the pelvis: coefficients read as the open body's seven
//! MakeHuman directions give another person.

use super::generate::{SynthJob, SynthReport, generate_capture};
use crate::body::{BodyModel, open_body_lowpoly_ref};
use crate::capture::{BodyModelRef, CaptureManifest};
use crate::error::Result;
use glam::Vec3;
use std::path::Path;

/// The stand-in's shape directions beyond the open body's.
const EXTRA_DIRECTIONS: usize = 3;

/// The stand-in model (in memory; `save_npz` writes it as a user's SMPL file).
pub fn smpl_stand_in() -> BodyModel {
    let open = open_body_lowpoly_ref();
    let k0 = open.num_betas;
    let root = open.rest_joints(&[])[0];
    let mut shapedirs = Vec::with_capacity(open.num_vertices() * (k0 + EXTRA_DIRECTIONS));
    for (v, &p) in open.v_template.iter().enumerate() {
        shapedirs.extend((0..k0).map(|k| open.shapedirs[v * k0 + k0 - 1 - k] * 0.5));
        let d = p - root;
        shapedirs.extend([
            d * 0.05,
            Vec3::new(0.0, d.y, 0.0) * 0.05,
            Vec3::new(d.x, 0.0, d.z) * 0.05,
        ]);
    }
    let mut limits: Vec<(f32, f32)> =
        open.shape_limits.iter().rev().map(|&(lo, hi)| (2.0 * lo, 2.0 * hi)).collect();
    limits.extend([(-1.5, 1.5); EXTRA_DIRECTIONS]);
    BodyModel {
        label: "SMPL stand-in (the open body in SMPL layout)".into(),
        shapedirs,
        num_betas: k0 + EXTRA_DIRECTIONS,
        shape_names: Vec::new(),
        shape_limits: limits,
        ..open.clone()
    }
}

/// Render a capture of `job`'s subject from the stand-in (fittings in its coefficients), write
/// the model beside it as `model_file` and name it in capture.json (`{"smpl": model_file}`).
pub fn generate_smpl_capture(dir: &Path, model_file: &str, job: &SynthJob) -> Result<SynthReport> {
    let body = smpl_stand_in();
    let report = generate_capture(dir, &body, job)?;
    body.save_npz(dir.join(model_file))?;
    let mut manifest = CaptureManifest::load(dir)?;
    manifest.body_model = BodyModelRef::Smpl(model_file.into());
    manifest.save(dir)?;
    Ok(report)
}
