//! What an animated export is asked for ([`ExportOptions`]), and the 4 skinning weights a
//! glTF vertex carries.

use crate::avatar::PROJECTION_STEPS;
use crate::body::{NUM_JOINTS, Weights};

#[derive(Debug, Clone, PartialEq)]
pub struct ExportOptions {
    /// At most this many morph targets, the constant compensation target included.
    pub max_targets: usize,
    /// Newton steps projecting the reference vertices onto each pose's surface.
    pub newton_steps: usize,
    /// PCA components moving no vertex by more than this (metres) are not exported.
    pub min_target_effect: f32,
    /// The avatar material's base colour (linear RGB): a PBR metallic-roughness material.
    pub color: [f32; 3],
    /// The morph targets' basis is fitted on at most this many frames, spread evenly over the
    /// clip (every frame of a shorter clip); every frame is then projected onto it
    /// (`export::stream`).
    pub sample_frames: usize,
    /// The file's error bound (metres): a frame outside the sample rebuilt worse than this
    /// brings the worst frames into the basis (one more pass).
    pub error_bound: f32,
    /// At most this many frames join the sample in that pass.
    pub refine_frames: usize,
    /// The reference vertices are projected onto the pose's surface every this many frames
    /// and interpolated in between where that is close enough (`export::keyframes`); 1: every
    /// frame projected.
    pub keyframe_spacing: usize,
    /// How far (metres) an interpolated frame's canonical surface may be from its own
    /// projection: the part of `error_bound` the keyframes may take (the compression gets the
    /// rest, [`ExportOptions::compression_bound`]).
    pub interpolation_tolerance: f32,
}

impl ExportOptions {
    /// The error bound left to the morph targets' compression: `error_bound` less the
    /// keyframes' tolerance when frames are interpolated, so that the file stays within
    /// `error_bound` of every frame's own projection.
    pub fn compression_bound(&self) -> f32 {
        match self.keyframe_spacing {
            0 | 1 => self.error_bound,
            _ => (self.error_bound - self.interpolation_tolerance).max(0.0),
        }
    }
}

/// A neutral skin-like base colour (linear RGB), the material's default.
pub const DEFAULT_COLOR: [f32; 3] = [0.80, 0.58, 0.47];

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            max_targets: 64,
            newton_steps: PROJECTION_STEPS,
            min_target_effect: 1e-4,
            color: DEFAULT_COLOR,
            sample_frames: 256,
            error_bound: 2e-3,
            refine_frames: 32,
            keyframe_spacing: 8,
            interpolation_tolerance: 1e-3,
        }
    }
}

/// The 4 largest weights, renormalised so that their float32 sum is 1 as strictly as the
/// validator checks (the residual is folded into the largest weight); unused slots get joint 0.
pub fn top4(w: &Weights) -> ([u8; 4], [f32; 4]) {
    let mut idx: Vec<usize> = (0..NUM_JOINTS).collect();
    idx.sort_by(|&a, &b| w[b].total_cmp(&w[a]).then(a.cmp(&b)));
    let sum: f64 = idx[..4].iter().map(|&j| w[j].max(0.0) as f64).sum();
    let mut joints = [0u8; 4];
    let mut weights = [0f32; 4];
    for k in 0..4 {
        let v = if sum > 0.0 {
            w[idx[k]].max(0.0) as f64 / sum
        } else if k == 0 {
            1.0
        } else {
            0.0
        };
        weights[k] = v as f32;
        if weights[k] > 0.0 {
            joints[k] = idx[k] as u8;
        }
    }
    let residual = 1.0f32 - weights.iter().sum::<f32>();
    weights[0] += residual;
    (joints, weights)
}
