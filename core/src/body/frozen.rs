//! A frozen body: one shape of a body model, kept as what posing and skinning need (rest
//! vertices, faces, skinning weights, rest joints), without the model's shape directions, pose
//! correctives or joint regressor. An avatar fitted on a user's own SMPL model carries its
//! frozen body, so it loads without the model file: the user's derived data, never the model.
//! Posed, a frozen body has exactly the model's bones; its bare mesh lacks the pose correctives.

use super::model::BodyModel;
use super::skeleton::NUM_JOINTS;
use super::skinning::Weights;
use crate::error::{Error, Result};
use glam::Vec3;

impl BodyModel {
    /// This model at shape `betas`, frozen.
    pub fn frozen(&self, betas: &[f32]) -> BodyModel {
        let rest = self.shaped_vertices(betas);
        let joints = self.regress_joints(&rest);
        frozen_body(self.label.clone(), rest, self.faces.clone(), self.weights.clone(), joints)
    }

    /// Whether this is a frozen body (one shape, stored joints).
    pub fn is_frozen(&self) -> bool {
        self.frozen_joints.is_some()
    }

    /// A frozen body from its parts, checked: finite values, one weight row per vertex (non-negative,
    /// summing to 1), faces within the vertices.
    pub fn from_frozen_parts(
        label: &str,
        rest: Vec<Vec3>,
        faces: Vec<[u32; 3]>,
        weights: Vec<Weights>,
        joints: [Vec3; NUM_JOINTS],
    ) -> Result<BodyModel> {
        if rest.is_empty() || rest.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("frozen body: no vertices, or a vertex is not finite"));
        }
        if weights.len() != rest.len() {
            return Err(Error::invalid(format!(
                "frozen body: {} skinning-weight rows for {} vertices",
                weights.len(),
                rest.len()
            )));
        }
        if let Some(v) = weights.iter().position(|w| {
            w.iter().any(|x| !(x.is_finite() && *x >= 0.0))
                || (w.iter().sum::<f32>() - 1.0).abs() > 1e-3
        }) {
            return Err(Error::invalid(format!(
                "frozen body: the skinning weights of vertex {v} are negative or do not sum to 1"
            )));
        }
        if let Some(f) = faces.iter().position(|f| f.iter().any(|&i| i as usize >= rest.len())) {
            return Err(Error::invalid(format!(
                "frozen body: face {f} has a vertex index outside 0..{}",
                rest.len()
            )));
        }
        if joints.iter().any(|j| !j.is_finite()) {
            return Err(Error::invalid("frozen body: a rest joint is not finite"));
        }
        Ok(frozen_body(label.to_string(), rest, faces, weights, joints))
    }
}

/// A body of one shape: rest vertices and joints stored, no shape directions, correctives or
/// regressor.
fn frozen_body(
    label: String,
    rest: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    weights: Vec<Weights>,
    joints: [Vec3; NUM_JOINTS],
) -> BodyModel {
    BodyModel {
        label,
        v_template: rest,
        shapedirs: Vec::new(),
        num_betas: 0,
        posedirs: None,
        j_regressor: Vec::new(),
        frozen_joints: Some(joints),
        weights,
        faces,
        shape_names: Vec::new(),
        shape_limits: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use crate::body::{BodyParams, open_body_lowpoly_ref};
    use glam::Vec3;

    #[test]
    fn a_frozen_body_poses_with_the_model_bones_whatever_betas_it_is_given() {
        let body = open_body_lowpoly_ref();
        let betas = vec![0.8, -0.5, 0.3, 0.0, 0.2, -0.4, 0.6];
        let frozen = body.frozen(&betas);
        let mut p = BodyParams {
            betas: betas.clone(),
            trans: Vec3::new(0.1, 0.2, 2.0),
            ..Default::default()
        };
        p.pose[18] = Vec3::new(0.0, 1.1, 0.2);
        p.pose[4] = Vec3::new(0.7, 0.0, 0.0);
        let (a, b) = (body.pose(&p), frozen.pose(&BodyParams { betas: vec![], ..p.clone() }));
        assert_eq!(a.bones, b.bones);
        assert_eq!(frozen.rest_joints(&[3.0]), body.rest_joints(&betas));
        assert_eq!(frozen.shaped_vertices(&[1.0, 2.0]), body.shaped_vertices(&betas));
        let bad = crate::body::BodyModel::from_frozen_parts(
            "x",
            frozen.v_template.clone(),
            vec![[0, 1, 9_999_999]],
            frozen.weights.clone(),
            body.rest_joints(&betas),
        );
        assert!(bad.unwrap_err().to_string().contains("face 0"));
    }
}
