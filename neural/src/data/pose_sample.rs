//! The unit of training data of the hypernetwork fit: one pose's encoder input and canonical
//! points (what `capture_points` and `meta_data` produce and `hyper_fit` consumes).

use glam::Vec3;

/// One pose's training data: the pose input of the encoder and canonical points with normals
/// (normalised [-1, 1]^3 space).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSample {
    pub pose_input: Vec<f32>,
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Free-space samples of the pose's frame (outside constraints; empty in meta-training).
    pub free_space: Vec<Vec3>,
}
