//! Rows of the evaluation table: anything that, after fine-tuning on a capture, predicts a
//! clothed mesh for a query pose. The neural avatar (meta-learned, from scratch, static SDF)
//! implements this in the neural crate; the reference rows live here.

use crate::body::{BodyModel, BodyParams};
use crate::error::Result;
use crate::mesh::TriMesh;
use std::path::Path;

/// What a row is fine-tuned on: a capture folder of the protocol's fine-tuning frames.
pub struct FitData<'a> {
    pub capture_dir: &'a Path,
    pub body: &'a BodyModel,
    pub betas: &'a [f32],
}

pub trait Predictor: Send + Sync {
    fn name(&self) -> String;
    /// Whether `fit` reads the capture (reference rows do not, which saves writing one).
    fn needs_capture(&self) -> bool {
        true
    }
    fn fit(&mut self, data: &FitData) -> Result<()>;
    /// The clothed mesh at a pose (world space, like the ground truth).
    fn predict(&self, params: &BodyParams) -> Result<TriMesh>;
}

/// The naked body posed by LBS: a lower bound any avatar must beat (it has no clothing).
pub struct NakedBody {
    body: BodyModel,
    betas: Vec<f32>,
}

impl NakedBody {
    pub fn new(body: BodyModel) -> Self {
        NakedBody { body, betas: Vec::new() }
    }
}

impl Predictor for NakedBody {
    fn name(&self) -> String {
        "naked body (LBS)".into()
    }
    fn needs_capture(&self) -> bool {
        false
    }
    fn fit(&mut self, data: &FitData) -> Result<()> {
        self.betas = data.betas.to_vec();
        Ok(())
    }
    fn predict(&self, params: &BodyParams) -> Result<TriMesh> {
        let mut p = params.clone();
        p.betas = self.betas.clone();
        Ok(self.body.mesh(self.body.pose(&p).vertices))
    }
}
