//! [`SyntheticAvatar`]: a synthetic clothed subject with its pose-dependent clothing, skinned
//! with the diffused field, as an avatar (`crate::avatar::AvatarSource`) for tests, benchmarks
//! and the command line until a neural avatar is given.

use crate::avatar::AvatarSource;
use crate::body::{BodyModel, BodyParams, Weights};
use crate::canonical::{Canonicalizer, FieldOptions};
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::mesh::bvh::Bvh;
use crate::synth::{ClothedTemplate, Outfit, PoseFeatures, canonical_surface};
use glam::Vec3;

/// A synthetic subject in an outfit: the exact pose-dependent canonical clothing of the
/// generator, with the diffused skinning field of its body.
pub struct SyntheticAvatar {
    body: BodyModel,
    betas: Vec<f32>,
    template: ClothedTemplate,
    field: crate::canonical::SkinningField,
    subject: u64,
}

impl SyntheticAvatar {
    pub fn new(
        body: BodyModel,
        subject: u64,
        outfit: Outfit,
        field: &FieldOptions,
    ) -> Result<Self> {
        let betas = crate::synth::subject_betas(&body, subject);
        let template = ClothedTemplate::build(&body, &betas, outfit);
        let field = Canonicalizer::new(&body, &betas, field, None)?.field;
        Ok(SyntheticAvatar { body, betas, template, field, subject })
    }

    fn surface(&self, params: &BodyParams) -> TriMesh {
        let bones = self.body.pose(params).bones;
        TriMesh::new(
            canonical_surface(&self.template, &PoseFeatures::of(&bones), self.subject),
            self.template.faces.clone(),
        )
    }
}

impl AvatarSource for SyntheticAvatar {
    fn body(&self) -> &BodyModel {
        &self.body
    }
    fn betas(&self) -> &[f32] {
        &self.betas
    }
    fn canonical_mesh(&self, params: &BodyParams) -> Result<TriMesh> {
        Ok(self.surface(params))
    }
    fn sdf(&self, params: &BodyParams, points: &[Vec3]) -> Result<Vec<f32>> {
        // Distance to the surface, signed by the side of the nearest face (the panels are
        // open sheets: their "inside" is the side facing the body).
        let mesh = self.surface(params);
        let bvh = Bvh::build(&mesh);
        let normals = mesh.face_normals();
        Ok(points
            .iter()
            .map(|&p| match bvh.closest_point(p) {
                Some(h) => {
                    let s = (p - h.point).dot(normals[h.face as usize]);
                    if s < 0.0 { -h.distance } else { h.distance }
                }
                None => f32::INFINITY,
            })
            .collect())
    }
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights> {
        points.iter().map(|&p| self.field.weights_at(p)).collect()
    }
    /// The SDF is an exact distance: one Newton step lands on the closest surface point.
    fn project(&self, params: &BodyParams, points: &[Vec3], _steps: usize) -> Result<Vec<Vec3>> {
        use rayon::prelude::*;
        let mesh = self.surface(params);
        let bvh = Bvh::build(&mesh);
        Ok(points.par_iter().map(|&p| bvh.closest_point(p).map_or(p, |h| h.point)).collect())
    }
}
