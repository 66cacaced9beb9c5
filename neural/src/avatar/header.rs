//! What both avatar kinds' headers share: the checks of the fields that describe the subject
//! (shape, normalisation, body model, skinning-field size), run when a file is loaded and
//! before anything is allocated from them, the mark of a partial (cancelled) fit, and the one
//! check of an avatar file's format, version and kind.

use crate::avatar::body as avatar_body;
use crate::error::{Error, Result};
use crate::model::weights_file;
use avatar_core::body::{BodyModel, check_betas};
use avatar_core::canonical::{
    Canonicalizer, FIELD_CELLS, FieldCache, FieldOptions, Normalisation, SkinningField,
};
use avatar_core::mesh::extract::ExtractOptions;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const AVATAR_FORMAT: &str = "avatar-studio-avatar";
/// The newest avatar version this build writes and reads: 1 (open body, no body stored) and 2
/// (the frozen body of a user's SMPL model stored after the weights: avatar_body.rs).
pub const AVATAR_VERSION: u32 = avatar_body::VERSION_WITH_BODY;

/// A fit cancelled before its last step: the avatar is usable but not finished.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartialFit {
    pub steps_done: usize,
    pub steps_requested: usize,
}

impl std::fmt::Display for PartialFit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "partial: {} of {} steps", self.steps_done, self.steps_requested)
    }
}

impl PartialFit {
    /// `Some` when fewer steps ran than were asked for.
    pub fn of(steps_done: usize, steps_requested: usize) -> Option<PartialFit> {
        (steps_done < steps_requested).then_some(PartialFit { steps_done, steps_requested })
    }
}

/// Check the subject fields of an avatar header (errors name no file: the loader adds it).
pub fn check_subject(
    normalisation: &Normalisation,
    betas: &[f32],
    body_model: &str,
    field_cells: usize,
    partial: Option<PartialFit>,
) -> Result<()> {
    use crate::avatar::body::{OPEN_BODY, SMPL};
    // The embedded open body, or an SMPL-family body stored in the file (avatar_body checks
    // that the two agree).
    if body_model != OPEN_BODY && body_model != SMPL {
        return Err(Error::invalid(format!(
            "\"body_model\" is {body_model:?}: expected {OPEN_BODY:?} or {SMPL:?} (a body stored in the file)"
        )));
    }
    check_betas(betas).map_err(|e| Error::invalid(format!("\"betas\": {e}")))?;
    normalisation.validate()?;
    if !FIELD_CELLS.contains(&field_cells) {
        return Err(Error::invalid(format!(
            "\"field_cells\" {field_cells} is out of range ({} to {})",
            FIELD_CELLS.start(),
            FIELD_CELLS.end()
        )));
    }
    if let Some(p) = partial
        && p.steps_done >= p.steps_requested
    {
        return Err(Error::invalid(format!(
            "\"partial\": {} of {} steps is not partial",
            p.steps_done, p.steps_requested
        )));
    }
    Ok(())
}

/// The meshes users get, in cells (`MeshResolution::OUTPUT`, where the choice is explained).
pub const OUTPUT_RESOLUTION: usize = super::MeshResolution::OUTPUT.cells();

/// Taubin iterations on every extracted avatar surface: they take the grid's terraces off
/// (the user-capture evaluation: NC +0.005, Dp -0.04 cm; docs/decisions.md).
pub const MESH_SMOOTHING: usize = 10;

/// How an avatar's canonical surface is extracted over the normalised cube at `resolution`.
/// Only blocks whose corners come within a quarter block diagonal of the surface are refined:
/// the SIREN's far field is flatter than a true distance, so the default margin refines almost
/// every block; a quarter gives the same mesh with 7x fewer evaluations
/// (neural/examples/pose_timing.rs).
pub(crate) fn extract_options(normalisation: &Normalisation, resolution: usize) -> ExtractOptions {
    let (lo, hi) =
        (normalisation.from_unit(Vec3::splat(-1.0)), normalisation.from_unit(Vec3::splat(1.0)));
    let mut options = ExtractOptions::new(lo, hi, resolution);
    options.margin = 0.25;
    options.smoothing_iterations = MESH_SMOOTHING;
    options
}

/// The skinning field of an avatar's body shape (from the cache when it is there).
pub(crate) fn avatar_field(
    body: &BodyModel,
    betas: &[f32],
    cells: usize,
    cache: &FieldCache,
) -> Result<SkinningField> {
    let field_options = FieldOptions { cells_along_height: cells, ..FieldOptions::default() };
    Ok(Canonicalizer::new(body, betas, &field_options, cache.dir())?.field)
}

/// Refuse avatar files of another format, version or kind with a message naming the file
/// (read from the header alone, before the rest of the file is parsed).
pub(crate) fn check_avatar_header(path: &Path, expected_kind: &str) -> Result<()> {
    let weights_file::Identity { format, version, kind } = weights_file::identity(path)?;
    if format != AVATAR_FORMAT
        || !(avatar_body::VERSION_OPEN_BODY..=AVATAR_VERSION).contains(&version)
    {
        return Err(Error::file(
            path,
            format!(
                "avatar format {format:?} version {version} is not supported by this build (it reads {AVATAR_FORMAT:?} versions 1 to {AVATAR_VERSION})"
            ),
        ));
    }
    if kind != expected_kind {
        return Err(Error::file(
            path,
            format!("avatar kind {kind:?} is not a {expected_kind:?} avatar"),
        ));
    }
    Ok(())
}
