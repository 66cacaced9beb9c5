//! How posing, export and the studio see a meta-learned avatar (`AvatarSource`).

use super::MetaAvatar;
use avatar_core::avatar::{AvatarSource, PROJECTION_STEPS};
use avatar_core::body::{BodyModel, BodyParams, Weights};
use avatar_core::canonical::SurfaceChoice;
use avatar_core::mesh::TriMesh;
use glam::Vec3;

impl AvatarSource for MetaAvatar {
    fn body(&self) -> &BodyModel {
        &self.body
    }
    fn betas(&self) -> &[f32] {
        &self.header.betas
    }
    fn canonical_mesh(&self, params: &BodyParams) -> avatar_core::Result<TriMesh> {
        Ok(self.canonical_mesh_at(params, self.resolution)?)
    }
    fn sdf(&self, params: &BodyParams, points: &[Vec3]) -> avatar_core::Result<Vec<f32>> {
        Ok(self.sdf_at(params).sdf(points))
    }
    /// Newton steps with the analytic gradient (reverse mode, `siren_eval`).
    fn project(
        &self,
        params: &BodyParams,
        points: &[Vec3],
        steps: usize,
    ) -> avatar_core::Result<Vec<Vec3>> {
        Ok(self.sdf_at(params).project(points, steps))
    }
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights> {
        points.iter().map(|&p| self.field.weights_at(p)).collect()
    }
    fn mesh_skinning_weights(&self, mesh: &TriMesh) -> Vec<Weights> {
        self.mesh_weights(mesh)
    }
    /// The reference (the rest pose's, as the studio and the exporter take it) is moved by
    /// what each pose changes in the projection (`SurfaceSmoother::relative_to`); a wrapped
    /// body's keeps the body vertices its surface swallowed where they are at every pose.
    fn surface_smoother(
        &self,
        reference: &TriMesh,
    ) -> Option<avatar_core::canonical::SurfaceSmoother> {
        let rest = self.sdf_at(&self.rest_params());
        let smoother = self
            .skinner
            .surface_smoother(reference)
            .relative_to(&rest.project(&reference.positions, PROJECTION_STEPS));
        let outside = match self.surface_kind() {
            SurfaceChoice::WrappedBody => self.wrap.options.outside,
            SurfaceChoice::WrappedWithLoose => self.wrap.options.tight_outside,
            _ => return Some(smoother),
        };
        if reference.positions.len() < self.wrap.vertex_count() {
            return Some(smoother);
        }
        let mut swallowed: Vec<bool> =
            self.wrap.wrap_within(|p| rest.sdf(p), outside).found.iter().map(|f| !f).collect();
        swallowed.resize(reference.positions.len(), false);
        Some(smoother.pin(reference, &swallowed))
    }
}
