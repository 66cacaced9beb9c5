//! One exported frame from its pose: the reference vertices projected onto the pose's surface
//! and smoothed ([`FrameMaker::surface`], the costly part: the avatar's SDF at every vertex,
//! Newton steps), skinned ([`FrameMaker::skin`]) and un-skinned with the file's 4 weights
//! ([`FrameMaker::delta_of`]).

use super::options::top4;
use crate::avatar::AvatarSource;
use crate::body::{BodyParams, NUM_JOINTS, Weights, blend_transform};
use crate::canonical::SurfaceSmoother;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use glam::{Mat4, Vec3};
use rayon::prelude::*;

/// The fixed pieces every frame is made from: the reference mesh, its weights (the avatar's
/// full ones and the file's 4), the smoother.
pub struct FrameMaker<'a> {
    pub source: &'a dyn AvatarSource,
    pub rest: TriMesh,
    pub full_weights: Vec<Weights>,
    pub joints: Vec<[u8; 4]>,
    pub weights: Vec<[f32; 4]>,
    smoother: Option<SurfaceSmoother>,
    betas: Vec<f32>,
    steps: usize,
}

impl<'a> FrameMaker<'a> {
    pub fn new(source: &'a dyn AvatarSource, steps: usize) -> Result<Self> {
        let betas = source.betas().to_vec();
        let rest = source.canonical_mesh(&source.reference_params())?;
        if rest.positions.is_empty() || rest.faces.is_empty() {
            return Err(Error::invalid("the avatar's canonical mesh is empty"));
        }
        let full_weights = source.mesh_skinning_weights(&rest);
        let smoother = source.surface_smoother(&rest);
        let (joints, weights) = full_weights.iter().map(top4).unzip();
        Ok(FrameMaker { source, rest, full_weights, joints, weights, smoother, betas, steps })
    }

    /// A clip frame with the avatar's shape.
    pub fn params(&self, p: &BodyParams) -> BodyParams {
        BodyParams { betas: self.betas.clone(), ..p.clone() }
    }

    /// Newton steps of each projection.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The canonical surface at a pose: the reference vertices projected onto the pose's zero
    /// level, smoothed (the studio's, before skinning).
    pub fn surface(&self, p: &BodyParams) -> Result<Vec<Vec3>> {
        let mut points = self.source.project(&self.params(p), &self.rest.positions, self.steps)?;
        self.finish(&mut points);
        Ok(points)
    }

    /// The avatar's smoothing of projected reference vertices, in place.
    pub fn finish(&self, points: &mut [Vec3]) {
        if let Some(s) = &self.smoother {
            s.smooth(points);
        }
    }

    /// Canonical `points` (one a reference vertex) skinned at a pose with the avatar's full
    /// weights, and the pose's bone transforms.
    pub fn skin(&self, p: &BodyParams, points: &[Vec3]) -> (Vec<Vec3>, [Mat4; NUM_JOINTS]) {
        let bones = self.source.body().pose(&self.params(p)).bones.transforms;
        let posed = points
            .par_iter()
            .zip(&self.full_weights)
            .map(|(v, w)| blend_transform(&bones, w).transform_point3(*v))
            .collect();
        (posed, bones)
    }

    /// The studio's posed mesh at a pose: the reference vertices projected onto the pose's
    /// surface, smoothed, skinned with the avatar's full weights.
    pub fn posed(&self, p: &BodyParams) -> Result<(Vec<Vec3>, [Mat4; NUM_JOINTS])> {
        Ok(self.skin(p, &self.surface(p)?))
    }

    /// The posed mesh and its delta in bind space *with the file's 4-weight skinning*: the
    /// morph targets then also absorb the truncation to 4 influences.
    pub fn delta(&self, p: &BodyParams) -> Result<(Vec<Vec3>, Vec<Vec3>)> {
        Ok(self.delta_of(p, &self.surface(p)?))
    }

    /// [`FrameMaker::delta`] of a canonical surface already made (or interpolated).
    pub fn delta_of(&self, p: &BodyParams, points: &[Vec3]) -> (Vec<Vec3>, Vec<Vec3>) {
        let (posed, bones) = self.skin(p, points);
        let delta = posed
            .par_iter()
            .zip(self.joints.par_iter().zip(&self.weights))
            .zip(&self.rest.positions)
            .map(|((y, (j, w)), r)| {
                let mut m = Mat4::ZERO;
                for k in 0..4 {
                    m += bones[j[k] as usize] * w[k];
                }
                m.inverse().transform_point3(*y) - *r
            })
            .collect();
        (delta, posed)
    }
}
