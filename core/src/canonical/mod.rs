//! Canonicalization: the diffused skinning field, inverse skinning of depth points by root
//! finding with the 2 cm filter, forward skinning of canonical meshes, and the [-1, 1]^3
//! normalisation. See docs/canonicalization.md.

pub mod cache;
pub mod canonicalize;
pub mod field;
pub mod normalise;
pub mod report;
pub mod root_finding;

pub use cache::{cached_field, default_cache_dir};
pub use canonicalize::{canonicalize_points, choose_by_agreement, forward_skin_mesh, CanonicalFrame, REPROJECTION_THRESHOLD};
pub use field::{FieldOptions, SkinningField, FIELD_CELLS};
pub use normalise::Normalisation;
pub use root_finding::{find_roots, forward_point, start_bones, Root, RootOptions};

use crate::body::BodyModel;
use crate::capture::CaptureFrame;
use crate::error::Result;
use glam::Vec3;
use std::path::Path;

/// Everything needed to canonicalize the frames of one subject: the body, its shape and the
/// field built (or loaded from the cache) for that shape.
pub struct Canonicalizer<'a> {
    pub body: &'a BodyModel,
    pub betas: Vec<f32>,
    pub rest: Vec<Vec3>,
    pub field: SkinningField,
    pub normalisation: Normalisation,
    pub options: RootOptions,
    /// Set when a cache file was bad and rebuilt.
    pub cache_warning: Option<String>,
}

impl<'a> Canonicalizer<'a> {
    pub fn new(body: &'a BodyModel, betas: &[f32], field_options: &FieldOptions, cache_dir: Option<&Path>) -> Result<Self> {
        field_options.validate()?;
        crate::body::check_betas(betas)?;
        let rest = body.shaped_vertices(betas);
        let (field, cache_warning) = cached_field(body, &rest, field_options, cache_dir)?;
        let normalisation = Normalisation::from_body(&rest);
        Ok(Canonicalizer { body, betas: betas.to_vec(), rest, field, normalisation, options: RootOptions::default(), cache_warning })
    }

    /// Canonicalize one capture frame's points and normals.
    pub fn frame(&self, frame: &CaptureFrame) -> CanonicalFrame {
        let posed = self.body.pose(&frame.params);
        canonicalize_points(&self.field, &posed.bones, &posed.vertices, &self.body.weights, &frame.points, &frame.normals, &self.options, None)
    }
}
