//! Pose-dependent clothing: what the avatar model must learn. Given a pose, the clothed
//! surface changes in canonical (T-pose) space, deterministically:
//! - folds gather at bent elbows and knees, their depth growing with the flexion angle;
//! - the shirt's hem slides up when the arms rise;
//! - free panels (skirt, tails) swing with the thighs and flare when the legs spread.
//!
//! The canonical surface is then posed by linear blend skinning with the garment's weights.

use super::outfit::{ClothedTemplate, joint::*};
use crate::body::{Bones, NUM_JOINTS, blend_transform};
use glam::{Mat3, Vec3};

/// Pose quantities the clothing responds to, read off the posed skeleton (so they do not
/// depend on Euler conventions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFeatures {
    /// Flexion beyond the rest pose (radians): left/right elbow, left/right knee.
    pub elbow_flex: [f32; 2],
    pub knee_flex: [f32; 2],
    /// Upper-arm direction along the torso's up axis (-1 arms down, 0 T-pose, 1 overhead).
    pub arm_elevation: [f32; 2],
    /// Thigh directions in the pelvis frame (rest: straight down).
    pub thigh: [Vec3; 2],
}

fn angle(a: Vec3, b: Vec3) -> f32 {
    a.normalize_or_zero().dot(b.normalize_or_zero()).clamp(-1.0, 1.0).acos()
}

impl PoseFeatures {
    pub fn of(bones: &Bones) -> PoseFeatures {
        let j = bones.posed_joints();
        let r = bones.rest_joints;
        let bend = |p: usize, m: usize, c: usize| {
            (angle(j[m] - j[p], j[c] - j[m]) - angle(r[m] - r[p], r[c] - r[m])).max(0.0)
        };
        let up = (j[SPINE3] - j[PELVIS]).normalize_or(Vec3::Y);
        let pelvis: Mat3 = bones.global_rotations()[PELVIS];
        let thigh =
            |h: usize, k: usize| pelvis.transpose() * (j[k] - j[h]).normalize_or(Vec3::NEG_Y);
        PoseFeatures {
            elbow_flex: [bend(L_SHOULDER, L_ELBOW, L_WRIST), bend(R_SHOULDER, R_ELBOW, R_WRIST)],
            knee_flex: [bend(L_HIP, L_KNEE, L_ANKLE), bend(R_HIP, R_KNEE, R_ANKLE)],
            arm_elevation: [
                (j[L_ELBOW] - j[L_SHOULDER]).normalize_or_zero().dot(up),
                (j[R_ELBOW] - j[R_SHOULDER]).normalize_or_zero().dot(up),
            ],
            thigh: [thigh(L_HIP, L_KNEE), thigh(R_HIP, R_KNEE)],
        }
    }
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Fold parameters: wavelength along the limb, width of the band around the joint, depth at
/// 90 degrees of flexion (metres).
const FOLD_WAVELENGTH: f32 = 0.045;
const FOLD_BAND: f32 = 0.07;
const FOLD_DEPTH: f32 = 0.025;

/// The clothed surface in canonical space for this pose (same vertex order as the template).
/// `phase_seed` shifts the folds per subject so two subjects do not wrinkle identically.
pub fn canonical_surface(
    t: &ClothedTemplate,
    features: &PoseFeatures,
    phase_seed: u64,
) -> Vec<Vec3> {
    let spec = t.outfit.spec();
    let lift = spec.hem_lift
        * 0.5
        * (smoothstep(-0.7, 0.9, features.arm_elevation[0])
            + smoothstep(-0.7, 0.9, features.arm_elevation[1]));
    let offsets = t.offsets(lift);
    let joints = rest_joints_of(t);
    // (joint, parent, child, flexion) of every fold site.
    let sites = [
        (L_ELBOW, L_SHOULDER, L_WRIST, features.elbow_flex[0]),
        (R_ELBOW, R_SHOULDER, R_WRIST, features.elbow_flex[1]),
        (L_KNEE, L_HIP, L_ANKLE, features.knee_flex[0]),
        (R_KNEE, R_HIP, R_ANKLE, features.knee_flex[1]),
    ];
    let phase = |k: usize| {
        ((phase_seed
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add((k as u64).wrapping_mul(0x632B_E59B_D9B4_E019)))
            >> 40) as f32
            / (1u64 << 24) as f32
            * std::f32::consts::TAU
    };
    let mut out = Vec::with_capacity(t.vertices.len());
    for v in 0..t.body_vertices {
        let p = t.body_rest[v];
        let mut d = offsets[v];
        if d > 0.002 {
            for (k, &(jt, parent, child, flex)) in sites.iter().enumerate() {
                if flex < 0.05 {
                    continue;
                }
                let w = t.weights[v][jt] + t.weights[v][parent];
                if w < 0.3 {
                    continue;
                }
                let axis = (joints[child] - joints[parent]).normalize_or_zero();
                let s = (p - joints[jt]).dot(axis);
                let envelope = (-(s / FOLD_BAND).powi(2)).exp();
                let wave =
                    0.5 + 0.5 * (std::f32::consts::TAU * s / FOLD_WAVELENGTH + phase(k)).sin();
                d += FOLD_DEPTH
                    * (flex / std::f32::consts::FRAC_PI_2).min(1.4)
                    * envelope
                    * wave
                    * w.min(1.0);
            }
        }
        out.push(p + t.normals[v] * d);
    }
    if let Some(panel) = spec.panel {
        let rest_dir = Vec3::NEG_Y;
        let mean = (features.thigh[0] + features.thigh[1]) * 0.5;
        let swing = Vec3::new(mean.x - rest_dir.x, 0.0, mean.z - rest_dir.z).clamp_length_max(0.8);
        // Legs apart (left thigh towards +X, right towards -X) widen the skirt.
        let spread = (features.thigh[0].x - features.thigh[1].x).max(0.0);
        for (i, &(h, a)) in t.panel.iter().enumerate() {
            let v = t.body_vertices + i;
            let dir = Vec3::new(a.sin(), 0.0, a.cos());
            let reach = panel.length * h.powf(1.5);
            let mut p = t.vertices[v] + swing * (0.4 * reach) + dir * (0.35 * reach * spread);
            // Swinging forward lifts the hem a little (the panel keeps its length).
            p.y += 0.3 * reach * (swing.length() * 0.6).min(1.0).powi(2);
            out.push(p);
        }
    }
    // Garments without a pose rule (a simulated cape) keep their rest shape here; the
    // simulation (`synth::cloth`) gives their real motion.
    out.extend_from_slice(&t.vertices[out.len()..]);
    out
}

fn rest_joints_of(t: &ClothedTemplate) -> [Vec3; NUM_JOINTS] {
    t.rest_joints
}

/// Pose a canonical surface by LBS with the template's weights.
pub fn pose_surface(t: &ClothedTemplate, canonical: &[Vec3], bones: &Bones) -> Vec<Vec3> {
    canonical
        .iter()
        .zip(&t.weights)
        .map(|(&p, w)| blend_transform(&bones.transforms, w).transform_point3(p))
        .collect()
}
