//! What both avatar kinds' headers share: the checks of the fields that describe the subject
//! (shape, normalisation, body model, skinning-field size), run when a file is loaded and
//! before anything is allocated from them, and the mark of a partial (cancelled) fit.

use avatar_core::body::check_betas;
use avatar_core::canonical::{Normalisation, FIELD_CELLS};
use avatar_core::error::{Error, Result};
use serde::{Deserialize, Serialize};


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
pub fn check_subject(normalisation: &Normalisation, betas: &[f32], body_model: &str, field_cells: usize, partial: Option<PartialFit>) -> Result<()> {
    use crate::avatar::body::{OPEN_BODY, SMPL};
    // The embedded open body, or an SMPL-family body stored in the file (avatar_body checks
    // that the two agree).
    if body_model != OPEN_BODY && body_model != SMPL {
        return Err(Error::invalid(format!("\"body_model\" is {body_model:?}: expected {OPEN_BODY:?} or {SMPL:?} (a body stored in the file)")));
    }
    check_betas(betas).map_err(|e| Error::invalid(format!("\"betas\": {e}")))?;
    normalisation.validate()?;
    if !FIELD_CELLS.contains(&field_cells) {
        return Err(Error::invalid(format!("\"field_cells\" {field_cells} is out of range ({} to {})", FIELD_CELLS.start(), FIELD_CELLS.end())));
    }
    if let Some(p) = partial
        && p.steps_done >= p.steps_requested
    {
        return Err(Error::invalid(format!("\"partial\": {} of {} steps is not partial", p.steps_done, p.steps_requested)));
    }
    Ok(())
}
