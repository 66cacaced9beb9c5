//! What an animatable avatar is, as posing and export see it: a body with a shape, the clothed
//! surface and its signed distance at any pose in canonical space, and skinning weights. The
//! neural avatars (crate avatar-neural) and the synthetic subjects of `export::source`
//! implement it; the exporter and the studio's poser only ever talk to this trait.

use crate::body::{BodyModel, BodyParams, Weights};
use crate::error::Result;
use crate::mesh::TriMesh;
use glam::Vec3;

pub trait AvatarSource: Sync {
    fn body(&self) -> &BodyModel;
    fn betas(&self) -> &[f32];
    /// The clothed surface at a pose, in canonical (unposed) body space.
    fn canonical_mesh(&self, params: &BodyParams) -> Result<TriMesh>;
    /// Signed distance (metres, negative inside) of canonical points to the surface at a pose.
    fn sdf(&self, params: &BodyParams, points: &[Vec3]) -> Result<Vec<f32>>;
    /// Skinning weights at canonical points.
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights>;

    /// Project canonical points onto the zero level set at a pose: Newton steps along the SDF
    /// gradient (central differences here; an avatar with analytic gradients overrides it).
    fn project(&self, params: &BodyParams, points: &[Vec3], steps: usize) -> Result<Vec<Vec3>> {
        const H: f32 = 5e-4;
        let mut x = points.to_vec();
        for _ in 0..steps {
            let mut probe = Vec::with_capacity(x.len() * 7);
            for &p in &x {
                probe.push(p);
                for a in [Vec3::X, Vec3::Y, Vec3::Z] {
                    probe.push(p + a * H);
                    probe.push(p - a * H);
                }
            }
            let f = self.sdf(params, &probe)?;
            for (i, p) in x.iter_mut().enumerate() {
                let v = &f[i * 7..i * 7 + 7];
                let g = Vec3::new(v[1] - v[2], v[3] - v[4], v[5] - v[6]) / (2.0 * H);
                if g.length_squared() > 1e-8 && v[0].is_finite() {
                    *p -= g * (v[0] / g.length_squared());
                }
            }
        }
        Ok(x)
    }
}
