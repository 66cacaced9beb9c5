//! What an animatable avatar is, as posing and export see it: a body with a shape, the clothed
//! surface and its signed distance at any pose in canonical space, and skinning weights. The
//! neural avatars (crate avatar-neural) and the synthetic subjects of `export::source`
//! implement it; the exporter and the studio's poser only ever talk to this trait.

use crate::body::{BodyModel, BodyParams, NUM_JOINTS, Weights, blend_transform};
use crate::canonical::SurfaceSmoother;
use crate::error::Result;
use crate::mesh::TriMesh;
use glam::{Mat4, Vec3};
use rayon::prelude::*;

/// Newton steps projecting a reference mesh onto a pose's surface (`PoseSurface::project`):
/// the exporter's default and the studio poser's, so the viewport shows what the glTF holds.
pub const PROJECTION_STEPS: usize = 4;

/// An avatar's canonical surface at a pose on a fixed topology: the vertices of a reference
/// mesh (extracted once at the rest pose) projected onto the pose's surface; each keeps its
/// reference vertex's skinning weights (`AvatarSource::mesh_skinning_weights` of the
/// reference, computed once: a slider move or an exported frame does not pay for them again).
/// The exporter's recipe (its morph targets are these surfaces skinned) and the studio
/// poser's for a pose-dependent avatar.
pub struct PoseSurface {
    pub points: Vec<Vec3>,
    pub weights: Vec<Weights>,
}

impl PoseSurface {
    /// `smoother`: the avatar's `surface_smoother` for this reference, if it has one.
    pub fn project(
        source: &dyn AvatarSource,
        params: &BodyParams,
        reference: &[Vec3],
        weights: &[Weights],
        smoother: Option<&SurfaceSmoother>,
        steps: usize,
    ) -> Result<PoseSurface> {
        let mut points = source.project(params, reference, steps)?;
        if let Some(smoother) = smoother {
            smoother.smooth(&mut points);
        }
        Ok(PoseSurface { points, weights: weights.to_vec() })
    }

    /// Linear blend skinning by the pose's bone transforms: the posed points.
    pub fn skin(&self, bones: &[Mat4; NUM_JOINTS]) -> Vec<Vec3> {
        self.points
            .par_iter()
            .zip(&self.weights)
            .map(|(v, w)| blend_transform(bones, w).transform_point3(*v))
            .collect()
    }
}

/// An avatar's rest surface, made once, and what posing it needs: its skinning weights and
/// its smoother. Every pose is this surface moved onto the pose's surface
/// ([`PoseSurface::project`]: the moves bounded and smoothed, `canonical::pose_displacement`)
/// and skinned, so a surface that is whole at rest is whole at every pose (FITE's explicit
/// template): how the exporter and the studio's poser pose (`export::stream::FrameMaker`), here
/// for one mesh at a time (`examples/posed_errors`).
pub struct PoseTemplate {
    pub rest: TriMesh,
    pub weights: Vec<Weights>,
    pub smoother: Option<SurfaceSmoother>,
}

impl PoseTemplate {
    /// The template of `source`: its canonical surface at its reference pose.
    pub fn new(source: &dyn AvatarSource) -> Result<PoseTemplate> {
        let rest = source.canonical_mesh(&source.reference_params())?;
        let weights = source.mesh_skinning_weights(&rest);
        let smoother = source.surface_smoother(&rest);
        Ok(PoseTemplate { rest, weights, smoother })
    }

    /// The posed mesh (world) at `params`, with the avatar's shape.
    pub fn posed_mesh(&self, source: &dyn AvatarSource, params: &BodyParams) -> Result<TriMesh> {
        let params = BodyParams { betas: source.betas().to_vec(), ..params.clone() };
        let mut points = source.project(&params, &self.rest.positions, PROJECTION_STEPS)?;
        if let Some(smoother) = &self.smoother {
            smoother.smooth(&mut points);
        }
        let bones = source.body().pose(&params).bones.transforms;
        let posed = points
            .par_iter()
            .zip(&self.weights)
            .map(|(v, w)| blend_transform(&bones, w).transform_point3(*v))
            .collect();
        Ok(TriMesh::new(posed, self.rest.faces.clone()))
    }
}

pub trait AvatarSource: Sync {
    fn body(&self) -> &BodyModel;
    fn betas(&self) -> &[f32];
    /// The pose whose canonical surface is the avatar's reference mesh, which every pose moves
    /// and skins (`PoseTemplate`, the exporter, the studio's poser): by default the zero pose,
    /// with the avatar's shape.
    fn reference_params(&self) -> BodyParams {
        BodyParams { betas: self.betas().to_vec(), ..Default::default() }
    }
    /// The clothed surface at a pose, in canonical (unposed) body space.
    fn canonical_mesh(&self, params: &BodyParams) -> Result<TriMesh>;
    /// Signed distance (metres, negative inside) of canonical points to the surface at a pose.
    fn sdf(&self, params: &BodyParams, points: &[Vec3]) -> Result<Vec<f32>>;
    /// Skinning weights at canonical points.
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights>;
    /// Skinning weights of a canonical mesh's vertices: by default each vertex's own; an
    /// avatar may use the mesh (the neural avatars inpaint loose clothing's weights along it,
    /// `canonical::garment_skinning`).
    fn mesh_skinning_weights(&self, mesh: &TriMesh) -> Vec<Weights> {
        self.skinning_weights(&mesh.positions)
    }
    /// The smoothing an avatar gives its canonical surfaces (`canonical::offset_smoothing`),
    /// measured once for a reference mesh whose projections onto each pose's surface
    /// ([`PoseSurface::project`]) should come out as `canonical_mesh` does; `None`: none.
    fn surface_smoother(&self, _reference: &TriMesh) -> Option<SurfaceSmoother> {
        None
    }

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
