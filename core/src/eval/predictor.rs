//! Rows of the evaluation table: anything that, after fine-tuning on a capture, predicts a
//! clothed mesh for a query pose. The neural avatar (meta-learned, from scratch, static SDF)
//! implements this in the neural crate; the reference rows live here.

use crate::body::{BodyModel, BodyParams};
use crate::canonical::FieldOptions;
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::synth::{ClothedTemplate, Outfit, PoseFeatures, canonical_surface, pose_surface};
use std::path::Path;

/// What a row is fine-tuned on: a capture folder of the protocol's fine-tuning frames.
pub struct FitData<'a> {
    pub capture_dir: &'a Path,
    pub body: &'a BodyModel,
    pub betas: &'a [f32],
    /// The synthetic subject's outfit (reference rows that know the ground truth use it).
    pub outfit: Outfit,
    /// Where skinning fields are cached (`EvalConfig::field_cache`).
    pub field_cache: &'a crate::canonical::FieldCache,
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

/// The ground-truth outfit without its pose-dependent deformation: the subject's clothed
/// surface at the zero pose (no folds, panels hanging), posed by the generator's own skinning.
/// An exact pose-independent avatar; its gap to the ground truth is about what the
/// pose-dependent clothing is worth on the table's frames.
pub struct StaticOutfit {
    body: BodyModel,
    /// Pose with the body's diffused skinning field built with these options (inpainted along
    /// loose cloth, as the avatars pose) instead of the generator's garment weights: what an
    /// avatar's skinning costs with the shape exact.
    field_options: Option<FieldOptions>,
    /// The template, its canonical surface at the zero pose and, with the body's field, the
    /// surface's weights (the field's, inpainted along loose cloth as avatars' are).
    fitted: Option<(ClothedTemplate, TriMesh, Option<Vec<crate::body::Weights>>)>,
}

impl StaticOutfit {
    pub fn new(body: BodyModel) -> Self {
        StaticOutfit { body, field_options: None, fitted: None }
    }

    /// The same outfit posed as every avatar is (the body's skinning field,
    /// `canonical::SkinningField`, inpainted along loose cloth by `GarmentSkinner`) instead of
    /// with the garment's own weights.
    pub fn with_body_field(body: BodyModel, options: FieldOptions) -> Self {
        StaticOutfit { body, field_options: Some(options), fitted: None }
    }
}

impl Predictor for StaticOutfit {
    fn name(&self) -> String {
        match self.field_options {
            None => "ground-truth outfit, pose-independent".into(),
            Some(_) => "ground-truth outfit, pose-independent, body's field".into(),
        }
    }
    fn needs_capture(&self) -> bool {
        false
    }
    fn fit(&mut self, data: &FitData) -> Result<()> {
        let template = ClothedTemplate::build(data.body, data.betas, data.outfit);
        let zero = BodyParams { betas: data.betas.to_vec(), ..BodyParams::default() };
        // No joint is bent at the zero pose, so the folds' per-subject phase does not matter.
        let canonical = TriMesh::new(
            canonical_surface(&template, &PoseFeatures::of(&data.body.pose(&zero).bones), 0),
            template.faces.clone(),
        );
        let weights = match &self.field_options {
            Some(o) => {
                let field = crate::canonical::Canonicalizer::new(
                    data.body,
                    data.betas,
                    o,
                    data.field_cache.dir(),
                )?
                .field;
                Some(
                    crate::canonical::GarmentSkinner::new(data.body, data.betas)
                        .weights(&field, &canonical),
                )
            }
            None => None,
        };
        self.fitted = Some((template, canonical, weights));
        Ok(())
    }
    fn predict(&self, params: &BodyParams) -> Result<TriMesh> {
        let (t, canonical, weights) = self
            .fitted
            .as_ref()
            .ok_or_else(|| crate::error::Error::invalid("predict called before fit"))?;
        let bones = self.body.pose(params).bones;
        Ok(match weights {
            Some(weights) => {
                crate::canonical::forward_skin_with_weights(&bones, canonical, weights)
            }
            None => {
                TriMesh::new(pose_surface(t, &canonical.positions, &bones), canonical.faces.clone())
            }
        })
    }
}
