//! `BodyModel`: template, shape directions, optional pose correctives, joint regressor and
//! skinning weights, posed by SMPL's recipe (shape, correctives, FK, LBS).

use super::kinematics::{Bones, forward_kinematics};
use super::params::BodyParams;
use super::skeleton::NUM_JOINTS;
use super::skinning::{Weights, blend_transform};
use crate::mesh::TriMesh;
use glam::{Mat3, Vec3};

/// Number of SMPL pose-corrective features: 9 entries of (R_j - I) for joints 1..23.
pub const NUM_POSE_FEATURES: usize = 9 * (NUM_JOINTS - 1);

#[derive(Debug, Clone)]
pub struct BodyModel {
    /// Where the model came from ("open body (MakeHuman CC0)" or a file path).
    pub label: String,
    pub v_template: Vec<Vec3>,
    /// Shape directions, `num_betas` per vertex: `shapedirs[v * num_betas + k]`.
    pub shapedirs: Vec<Vec3>,
    pub num_betas: usize,
    /// Pose correctives, `NUM_POSE_FEATURES` per vertex, if the model has them.
    pub posedirs: Option<Vec<Vec3>>,
    /// Sparse joint regressor: for each joint, (vertex, weight) pairs (empty for a frozen body).
    pub j_regressor: Vec<Vec<(u32, f32)>>,
    /// The rest joints of a frozen body (one shape, no regressor: see `frozen.rs`); `None` for
    /// a model, whose joints are regressed from its shaped vertices.
    pub frozen_joints: Option<[Vec3; NUM_JOINTS]>,
    /// Per-vertex skinning weights (rows sum to 1).
    pub weights: Vec<Weights>,
    pub faces: Vec<[u32; 3]>,
    /// Human-readable names of the shape directions (may be empty).
    pub shape_names: Vec<String>,
    /// Sensible range of each shape coefficient (may be empty = unbounded).
    pub shape_limits: Vec<(f32, f32)>,
}

/// A posed body: rest (canonical) and posed vertices plus the skeleton.
#[derive(Debug, Clone)]
pub struct PosedBody {
    /// Shaped vertices with pose correctives, in the rest pose.
    pub rest_vertices: Vec<Vec3>,
    /// Posed vertices in the world.
    pub vertices: Vec<Vec3>,
    pub bones: Bones,
}

impl BodyModel {
    pub fn num_vertices(&self) -> usize {
        self.v_template.len()
    }

    /// Clamp coefficients to the model's documented limits (extra coefficients are dropped).
    pub fn clamp_betas(&self, betas: &[f32]) -> Vec<f32> {
        betas
            .iter()
            .take(self.num_betas)
            .enumerate()
            .map(|(k, &b)| match self.shape_limits.get(k) {
                Some(&(lo, hi)) => b.clamp(lo, hi),
                None => b,
            })
            .collect()
    }

    /// Template plus shape blend shapes.
    pub fn shaped_vertices(&self, betas: &[f32]) -> Vec<Vec3> {
        let k = self.num_betas;
        let n = betas.len().min(k);
        self.v_template
            .iter()
            .enumerate()
            .map(|(v, &t)| {
                let dirs = &self.shapedirs[v * k..v * k + n];
                dirs.iter().zip(betas).fold(t, |acc, (d, &b)| acc + *d * b)
            })
            .collect()
    }

    /// Joints of shaped vertices (a frozen body has one shape: its stored joints).
    pub fn regress_joints(&self, vertices: &[Vec3]) -> [Vec3; NUM_JOINTS] {
        if let Some(joints) = self.frozen_joints {
            return joints;
        }
        let mut joints = [Vec3::ZERO; NUM_JOINTS];
        for (j, row) in self.j_regressor.iter().enumerate() {
            joints[j] = row.iter().fold(Vec3::ZERO, |acc, &(v, w)| acc + vertices[v as usize] * w);
        }
        joints
    }

    /// Rest-pose joints for a shape.
    pub fn rest_joints(&self, betas: &[f32]) -> [Vec3; NUM_JOINTS] {
        self.regress_joints(&self.shaped_vertices(betas))
    }

    /// SMPL pose-corrective features: flattened (R_j - I), row-major, joints 1..23.
    pub fn pose_features(rotations: &[Mat3; NUM_JOINTS]) -> Vec<f32> {
        let mut f = Vec::with_capacity(NUM_POSE_FEATURES);
        for r in &rotations[1..] {
            for row in 0..3 {
                for col in 0..3 {
                    let identity = if row == col { 1.0 } else { 0.0 };
                    f.push(r.col(col)[row] - identity);
                }
            }
        }
        f
    }

    /// Pose the body: shape, pose correctives, forward kinematics, linear blend skinning.
    pub fn pose(&self, params: &BodyParams) -> PosedBody {
        let shaped = self.shaped_vertices(&params.betas);
        let rest_joints = self.regress_joints(&shaped);
        let rotations = params.rotations();
        let rest_vertices = match &self.posedirs {
            Some(posedirs) => {
                let feat = Self::pose_features(&rotations);
                shaped
                    .iter()
                    .enumerate()
                    .map(|(v, &p)| {
                        let dirs = &posedirs[v * NUM_POSE_FEATURES..(v + 1) * NUM_POSE_FEATURES];
                        dirs.iter().zip(&feat).fold(p, |acc, (d, &f)| acc + *d * f)
                    })
                    .collect()
            }
            None => shaped,
        };
        let bones = forward_kinematics(&rest_joints, &rotations, params.trans);
        let vertices = self.skin(&rest_vertices, &bones);
        PosedBody { rest_vertices, vertices, bones }
    }

    /// LBS of this model's vertices (given in the rest pose) by the bone transforms.
    pub fn skin(&self, rest_vertices: &[Vec3], bones: &Bones) -> Vec<Vec3> {
        rest_vertices
            .iter()
            .zip(&self.weights)
            .map(|(&p, w)| blend_transform(&bones.transforms, w).transform_point3(p))
            .collect()
    }

    pub fn mesh(&self, vertices: Vec<Vec3>) -> TriMesh {
        TriMesh::new(vertices, self.faces.clone())
    }
}

impl PosedBody {
    pub fn posed_joints(&self) -> [Vec3; NUM_JOINTS] {
        self.bones.posed_joints()
    }
}
