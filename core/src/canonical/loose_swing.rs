//! The swing of loose cloth that hangs below the hips (a skirt, a coat's tails), learned from
//! a capture's frames.
//!
//! Skinning moves a skirt with the thighs only as far as its weights say, and a skirt swings
//! further: a raised thigh lifts its front, spread legs widen it. The hypernetwork's
//! pose-dependent SDF could carry that, but a meta-model that never saw a kick does not
//! extrapolate to one (docs/evaluation.md, session 9). Here the swing is a pose corrective in
//! canonical space, linear in the thighs' directions like a body model's pose blend shapes,
//! shared by all loose vertices and scaled by how far each hangs below the hip joints:
//!
//! ```text
//! delta(x, pose) = g(x) * (C phi(pose) + r(x) (a . phi(pose)))
//! phi  = each thigh's direction in the pelvis frame minus its rest direction (6 numbers)
//! g(x) = looseness(x) * depth of x below the hip joints (metres; 0 on tight clothing)
//! r(x) = x's horizontal direction away from the pelvis (the flare)
//! ```
//!
//! C (3 x 6) and a (6) are fitted by least squares to the frames' depth points (point to plane,
//! a few rounds of nearest-vertex association, ridge-regularised toward no swing). A capture
//! whose cloth does not swing gets C and a near zero; one without loose cloth below the hips
//! gets none.

use crate::body::{blend_transform, BodyParams, Bones, Weights, NUM_JOINTS};
use crate::mesh::point_index::PointIndex;
use crate::mesh::signed_distance::SignedDistance;
use crate::mesh::TriMesh;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

const PELVIS: usize = 0;
const HIPS: [usize; 2] = [1, 2];
const KNEES: [usize; 2] = [4, 5];
/// Collars, shoulders, elbows, wrists, hands: loose cloth on the arms does not swing with the
/// thighs.
const ARM_JOINTS: [usize; 10] = [13, 14, 16, 17, 18, 19, 20, 21, 22, 23];
/// Number of pose features: both thighs' direction changes.
pub const SWING_FEATURES: usize = 6;
const UNKNOWNS: usize = 4 * SWING_FEATURES;

/// The fitted swing (see the module's documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LooseSwing {
    /// C: each feature's displacement per metre below the hips (rows x, y, z).
    pub along: [[f32; SWING_FEATURES]; 3],
    /// a: each feature's outward displacement per metre below the hips.
    pub outward: [f32; SWING_FEATURES],
}

/// How the swing is fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingOptions {
    /// Distance outside the rest body (metres) where cloth starts to count as loose, and where
    /// it is wholly loose (the garment skinning's).
    pub loose: (f32, f32),
    /// Association rounds, and the farthest a depth point may lie from its nearest vertex
    /// (metres) to take part: in the first round (the swing not yet known, the hem may be far
    /// off) and in the last (the cut narrows in between).
    pub rounds: usize,
    pub max_distance: (f32, f32),
    /// The ridge toward no swing, as a share of the normal equations' mean diagonal.
    pub ridge: f64,
    /// At least this many depth points on swinging cloth, else no swing is fitted.
    pub min_points: usize,
    /// The displacement is at most this share of the depth below the hips.
    pub max_share: f32,
    /// The right thigh moves the cloth as the left one does, mirrored (12 unknowns, not 24).
    pub symmetric: bool,
    /// Only the thighs' horizontal movement drives the swing (their vertical component, second
    /// order in the angle, is left out).
    pub horizontal: bool,
}

impl Default for SwingOptions {
    fn default() -> Self {
        SwingOptions { loose: (0.02, 0.05), rounds: 6, max_distance: (0.08, 0.03), ridge: 0.01, min_points: 500, max_share: 0.5, symmetric: std::env::var_os("AVATAR_SWING_SYMMETRIC").is_some(), horizontal: std::env::var_os("AVATAR_SWING_HORIZONTAL").is_some() }
    }
}

/// The pose features: each thigh's rest direction rotated by its hip's rotation relative to
/// the pelvis, minus the rest direction.
pub fn swing_features(params: &BodyParams, rest_joints: &[Vec3; NUM_JOINTS]) -> [f32; SWING_FEATURES] {
    let rotations = params.rotations();
    let mut phi = [0.0; SWING_FEATURES];
    for (side, (&hip, &knee)) in HIPS.iter().zip(&KNEES).enumerate() {
        let rest = (rest_joints[knee] - rest_joints[hip]).normalize_or(Vec3::NEG_Y);
        let change = rotations[hip] * rest - rest;
        phi[3 * side..3 * side + 3].copy_from_slice(&change.to_array());
    }
    phi
}

/// Where each vertex of a canonical mesh stands for the swing: its depth below the hips times
/// its looseness (0: it does not swing), and its outward direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingProfile {
    pub reach: f32,
    pub outward: Vec3,
}

/// The profile of a canonical mesh's vertices (`weights`: their skinning weights, `body`: the
/// rest body's signed distance).
pub fn swing_profile(positions: &[Vec3], weights: &[Weights], body: &SignedDistance, rest_joints: &[Vec3; NUM_JOINTS], options: &SwingOptions) -> Vec<SwingProfile> {
    let (a, b) = options.loose;
    let hip_y = 0.5 * (rest_joints[HIPS[0]].y + rest_joints[HIPS[1]].y);
    let pelvis = rest_joints[PELVIS];
    positions
        .par_iter()
        .zip(weights)
        .map(|(&x, w)| {
            let looseness = match body.at(x) {
                Some(d) if b > a => ((d - a) / (b - a)).clamp(0.0, 1.0),
                _ => 0.0,
            };
            let on_arms: f32 = ARM_JOINTS.iter().map(|&j| w[j]).sum();
            let reach = looseness * (hip_y - x.y).max(0.0) * (1.0 - on_arms).clamp(0.0, 1.0);
            let outward = Vec3::new(x.x - pelvis.x, 0.0, x.z - pelvis.z).normalize_or_zero();
            SwingProfile { reach, outward }
        })
        .collect()
}

impl LooseSwing {
    fn from_unknowns(theta: &[f64]) -> LooseSwing {
        let mut along = [[0.0; SWING_FEATURES]; 3];
        for (i, row) in along.iter_mut().enumerate() {
            for (k, c) in row.iter_mut().enumerate() {
                *c = theta[i * SWING_FEATURES + k] as f32;
            }
        }
        let mut outward = [0.0; SWING_FEATURES];
        for (k, c) in outward.iter_mut().enumerate() {
            *c = theta[3 * SWING_FEATURES + k] as f32;
        }
        LooseSwing { along, outward }
    }

    /// The canonical displacement of a vertex with this profile at a pose with features `phi`.
    pub fn displacement(&self, profile: &SwingProfile, phi: &[f32; SWING_FEATURES], max_share: f32) -> Vec3 {
        if profile.reach <= 0.0 {
            return Vec3::ZERO;
        }
        let dot = |row: &[f32; SWING_FEATURES]| row.iter().zip(phi).map(|(c, p)| c * p).sum::<f32>();
        let d = (Vec3::new(dot(&self.along[0]), dot(&self.along[1]), dot(&self.along[2])) + profile.outward * dot(&self.outward)) * profile.reach;
        d.clamp_length_max(max_share * profile.reach)
    }

    /// Every vertex's displacement at a pose.
    pub fn displacements(&self, profile: &[SwingProfile], params: &BodyParams, rest_joints: &[Vec3; NUM_JOINTS]) -> Vec<Vec3> {
        let phi = swing_features(params, rest_joints);
        let max_share = SwingOptions::default().max_share;
        profile.iter().map(|p| self.displacement(p, &phi, max_share)).collect()
    }

    /// The largest displacement at a pose (metres), for reports.
    pub fn largest(&self, profile: &[SwingProfile], params: &BodyParams, rest_joints: &[Vec3; NUM_JOINTS]) -> f32 {
        self.displacements(profile, params, rest_joints).iter().map(|d| d.length()).fold(0.0, f32::max)
    }
}

/// One frame of the data the swing is fitted to.
pub struct SwingFrame {
    pub params: BodyParams,
    pub bones: Bones,
    /// The avatar's canonical surface at the frame's pose, its vertices' skinning weights and
    /// profile.
    pub canonical: TriMesh,
    pub weights: Vec<Weights>,
    pub profile: Vec<SwingProfile>,
    /// The frame's depth points (world, metres).
    pub observed: Vec<Vec3>,
}

/// What a fit found: the swing and the point-to-plane residual on swinging cloth before and
/// after (RMS, metres), over the points that took part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingFit {
    pub swing: LooseSwing,
    pub points: usize,
    pub rms_before: f32,
    pub rms_after: f32,
}

/// Fit the swing to the frames (None: too few depth points lie on loose cloth below the hips).
pub fn fit_loose_swing(frames: &[SwingFrame], rest_joints: &[Vec3; NUM_JOINTS], options: &SwingOptions) -> Option<SwingFit> {
    let mut swing = LooseSwing::from_unknowns(&[0.0; UNKNOWNS]);
    let mut first = None;
    let mut last = (0, 0.0);
    let rounds = options.rounds.max(1);
    let cut = |round: usize| {
        let t = if rounds > 1 { round as f32 / (rounds - 1) as f32 } else { 1.0 };
        options.max_distance.0 + (options.max_distance.1 - options.max_distance.0) * t
    };
    let n = if options.symmetric { UNKNOWNS / 2 } else { UNKNOWNS };
    for round in 0..rounds {
        let mut ata = vec![vec![0.0f64; n]; n];
        let mut atb = vec![0.0f64; n];
        let (mut count, mut residual_now) = (0usize, 0.0f64);
        for frame in frames {
            let mut phi = swing_features(&frame.params, rest_joints);
            if options.horizontal {
                // Columns of zeros: the ridge holds their coefficients at zero.
                phi[1] = 0.0;
                phi[4] = 0.0;
            }
            let rows = frame_rows(frame, &swing, &phi, cut(round), options.max_share);
            for (full, target, now) in rows {
                let row = if options.symmetric { fold_mirrored(&full) } else { full.to_vec() };
                for i in 0..n {
                    if row[i] == 0.0 {
                        continue;
                    }
                    atb[i] += row[i] * target;
                    for j in 0..n {
                        ata[i][j] += row[i] * row[j];
                    }
                }
                residual_now += now * now;
                count += 1;
            }
        }
        if count < options.min_points {
            return None;
        }
        let rms = (residual_now / count as f64).sqrt() as f32;
        first.get_or_insert(rms);
        last = (count, rms);
        let mean_diagonal = (0..n).map(|i| ata[i][i]).sum::<f64>() / n as f64;
        for (i, row) in ata.iter_mut().enumerate() {
            row[i] += options.ridge * mean_diagonal + 1e-12;
        }
        let theta = solve(ata, atb)?;
        swing = LooseSwing::from_unknowns(&if options.symmetric { unfold_mirrored(&theta) } else { theta });
    }
    // The residual with the final swing, on the final association.
    let mut after = 0.0f64;
    let mut count = 0usize;
    for frame in frames {
        let phi = swing_features(&frame.params, rest_joints);
        for (_, _, now) in frame_rows(frame, &swing, &phi, cut(rounds - 1), options.max_share) {
            after += now * now;
            count += 1;
        }
    }
    let rms_after = if count > 0 { (after / count as f64).sqrt() as f32 } else { last.1 };
    Some(SwingFit { swing, points: last.0, rms_before: first.unwrap_or(0.0), rms_after })
}

/// One frame's least-squares rows: for each depth point whose nearest posed vertex (with the
/// current swing) swings, the Jacobian of that vertex's offset along its normal with respect
/// to the unknowns, the target (the point's offset along the normal from the vertex without
/// swing) and the residual with the current swing.
fn frame_rows(frame: &SwingFrame, swing: &LooseSwing, phi: &[f32; SWING_FEATURES], max_distance: f32, max_share: f32) -> Vec<([f64; UNKNOWNS], f64, f64)> {
    let normals = frame.canonical.vertex_normals();
    let transforms: Vec<glam::Mat4> = frame.weights.par_iter().map(|w| blend_transform(&frame.bones.transforms, w)).collect();
    let posed: Vec<Vec3> = frame
        .canonical
        .positions
        .par_iter()
        .zip(&frame.profile)
        .zip(&transforms)
        .map(|((&x, p), a)| a.transform_point3(x + swing.displacement(p, phi, max_share)))
        .collect();
    let Ok(index) = PointIndex::new(&posed) else { return Vec::new() };
    frame
        .observed
        .par_iter()
        .filter_map(|&z| {
            let (v, distance) = index.nearest(z);
            let profile = frame.profile[v];
            if profile.reach <= 1e-3 || distance > max_distance {
                return None;
            }
            let rotation = Mat3::from_mat4(transforms[v]);
            let normal = (rotation.inverse().transpose() * normals[v]).normalize_or_zero();
            if normal == Vec3::ZERO {
                return None;
            }
            // The displacement enters the posed vertex through the blend's linear part.
            let pulled = rotation.transpose() * normal;
            let unswung = transforms[v].transform_point3(frame.canonical.positions[v]);
            let target = normal.dot(z - unswung) as f64;
            let now = normal.dot(z - posed[v]) as f64;
            let mut row = [0.0f64; UNKNOWNS];
            let g = profile.reach as f64;
            for k in 0..SWING_FEATURES {
                let f = phi[k] as f64 * g;
                for i in 0..3 {
                    row[i * SWING_FEATURES + k] = pulled[i] as f64 * f;
                }
                row[3 * SWING_FEATURES + k] = pulled.dot(profile.outward) as f64 * f;
            }
            Some((row, target, now))
        })
        .collect()
}

/// The mirror across the body's sagittal plane (x -> -x) as signs of x, y, z.
const MIRROR: [f64; 3] = [-1.0, 1.0, 1.0];

/// A row over the 24 unknowns as a row over the left thigh's 12 when the right thigh's
/// response is the left's mirrored (C_right = M C_left M, a_right = M a_left).
fn fold_mirrored(row: &[f64; UNKNOWNS]) -> Vec<f64> {
    let f = SWING_FEATURES;
    let mut out = vec![0.0; UNKNOWNS / 2];
    for i in 0..3 {
        for k in 0..3 {
            out[i * 3 + k] = row[i * f + k] + MIRROR[i] * MIRROR[k] * row[i * f + 3 + k];
        }
    }
    for k in 0..3 {
        out[9 + k] = row[3 * f + k] + MIRROR[k] * row[3 * f + 3 + k];
    }
    out
}

/// The left thigh's 12 unknowns as all 24 (the inverse of [`fold_mirrored`]'s mapping).
fn unfold_mirrored(theta: &[f64]) -> Vec<f64> {
    let f = SWING_FEATURES;
    let mut out = vec![0.0; UNKNOWNS];
    for i in 0..3 {
        for k in 0..3 {
            out[i * f + k] = theta[i * 3 + k];
            out[i * f + 3 + k] = MIRROR[i] * MIRROR[k] * theta[i * 3 + k];
        }
    }
    for k in 0..3 {
        out[3 * f + k] = theta[9 + k];
        out[3 * f + 3 + k] = MIRROR[k] * theta[9 + k];
    }
    out
}

/// Gaussian elimination with partial pivoting (the normal equations are small and
/// regularised).
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-18 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            for k in col..n {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::{open_body_lowpoly, BodyModel};
    use glam::Quat;

    /// A flared skirt (an open tube) hanging from 5 cm above the pelvis, 60 cm long.
    fn skirt(rest: &[Vec3], pelvis: Vec3) -> TriMesh {
        let (rings, segments) = (16, 48);
        let waist_y = pelvis.y + 0.05;
        let waist: Vec<Vec3> = rest.iter().copied().filter(|p| (p.y - waist_y).abs() < 0.02).collect();
        let (rx, rz) = waist.iter().fold((0f32, 0f32), |(x, z), p| (x.max((p.x - pelvis.x).abs()), z.max((p.z - pelvis.z).abs())));
        let mut positions = Vec::new();
        for r in 0..=rings {
            let t = r as f32 / rings as f32;
            let (ex, ez) = (rx + 0.01 + 0.18 * t, rz + 0.01 + 0.18 * t);
            for s in 0..segments {
                let a = std::f32::consts::TAU * s as f32 / segments as f32;
                positions.push(Vec3::new(pelvis.x + ex * a.sin(), waist_y - 0.6 * t, pelvis.z + ez * a.cos()));
            }
        }
        let idx = |r: usize, s: usize| (r * segments + s % segments) as u32;
        let faces = (0..rings).flat_map(|r| (0..segments).flat_map(move |s| [[idx(r, s), idx(r + 1, s), idx(r + 1, s + 1)], [idx(r, s), idx(r + 1, s + 1), idx(r, s + 1)]])).collect();
        TriMesh::new(positions, faces)
    }

    /// A pose with the left and right thighs turned about the X axis (forward, radians) and
    /// about the Z axis (sideways), and a global translation.
    fn pose(left: (f32, f32), right: (f32, f32)) -> BodyParams {
        let mut p = BodyParams { trans: Vec3::new(0.1, 0.0, 2.0), ..BodyParams::default() };
        p.pose[HIPS[0]] = (Quat::from_rotation_x(-left.0) * Quat::from_rotation_z(left.1)).to_scaled_axis();
        p.pose[HIPS[1]] = (Quat::from_rotation_x(-right.0) * Quat::from_rotation_z(-right.1)).to_scaled_axis();
        p
    }

    struct Scene {
        body: BodyModel,
        joints: [Vec3; NUM_JOINTS],
        sdf: SignedDistance,
        skirt: TriMesh,
        weights: Vec<Weights>,
        profile: Vec<SwingProfile>,
    }

    fn scene() -> Scene {
        let body = open_body_lowpoly();
        let rest = body.shaped_vertices(&[]);
        let joints = body.regress_joints(&rest);
        let sdf = SignedDistance::new(&body.mesh(rest.clone()));
        let skirt = skirt(&rest, joints[PELVIS]);
        // The skirt follows the pelvis alone: posing moves it rigidly, the swing is all that
        // bends it.
        let mut w = [0.0; NUM_JOINTS];
        w[PELVIS] = 1.0;
        let weights = vec![w; skirt.positions.len()];
        let profile = swing_profile(&skirt.positions, &weights, &sdf, &joints, &SwingOptions::default());
        Scene { body, joints, sdf, skirt, weights, profile }
    }

    /// The skirt at a pose, displaced by `swing` and posed: what a depth camera would see of it
    /// (every vertex, a 2 mm wobble).
    fn observed(s: &Scene, swing: &LooseSwing, params: &BodyParams) -> Vec<Vec3> {
        let bones = s.body.pose(params).bones;
        let d = swing.displacements(&s.profile, params, &s.joints);
        s.skirt.positions.iter().zip(&d).zip(&s.weights).enumerate().map(|(i, ((&x, &d), w))| {
            let wobble = 0.002 * ((i as f32 * 12.9898).sin() * 43_758.547).fract();
            blend_transform(&bones.transforms, w).transform_point3(x + d) + Vec3::splat(wobble)
        }).collect()
    }

    fn frames(s: &Scene, truth: &LooseSwing, poses: &[BodyParams]) -> Vec<SwingFrame> {
        poses
            .iter()
            .map(|p| SwingFrame { params: p.clone(), bones: s.body.pose(p).bones, canonical: s.skirt.clone(), weights: s.weights.clone(), profile: s.profile.clone(), observed: observed(s, truth, p) })
            .collect()
    }

    /// Walking strides, a squat and legs apart: the training poses; a kick is held out.
    fn training_poses() -> Vec<BodyParams> {
        vec![pose((0.0, 0.0), (0.0, 0.0)), pose((0.4, 0.0), (-0.3, 0.0)), pose((-0.3, 0.0), (0.4, 0.0)), pose((1.2, 0.0), (1.2, 0.0)), pose((0.0, 0.3), (0.0, 0.3)), pose((0.6, 0.0), (0.2, 0.1))]
    }

    #[test]
    fn the_swing_of_a_skirt_is_learned_from_training_poses_and_carries_to_a_kick() {
        let s = scene();
        // The skirt hangs below the hips: its hem swings, its waist band does not.
        let hem = s.skirt.positions.len() - 48..s.skirt.positions.len();
        assert!(hem.clone().all(|v| s.profile[v].reach > 0.3), "hem reach {:?}", s.profile[hem.start]);
        assert!((0..48).all(|v| s.profile[v].reach == 0.0), "the waist band above the hips does not swing");
        // The truth: the skirt moves forward with the thighs' mean forward swing and widens
        // with their spread.
        let mut truth = LooseSwing { along: [[0.0; SWING_FEATURES]; 3], outward: [0.0; SWING_FEATURES] };
        truth.along[2][2] = 0.2;
        truth.along[2][5] = 0.2;
        truth.outward[0] = 0.15;
        truth.outward[3] = -0.15;
        let fit = fit_loose_swing(&frames(&s, &truth, &training_poses()), &s.joints, &SwingOptions::default()).expect("a swing is fitted");
        assert!(fit.rms_after < 0.005 && fit.rms_after < 0.3 * fit.rms_before, "RMS {} -> {} m", fit.rms_before, fit.rms_after);
        // A kick a little higher than the strides, on one leg (the squat raised both).
        let kick = pose((1.0, 0.0), (-0.2, 0.0));
        let want = truth.displacements(&s.profile, &kick, &s.joints);
        let got = fit.swing.displacements(&s.profile, &kick, &s.joints);
        let worst = hem.clone().map(|v| (want[v] - got[v]).length()).fold(0.0, f32::max);
        let moved = hem.clone().map(|v| want[v].length()).fold(f32::INFINITY, f32::min);
        assert!(moved > 0.05, "the kick moves the hem {moved} m at least");
        assert!(worst < 0.015 && worst < 0.25 * moved, "the learned swing is {worst} m off at the kick's hem (it moves {moved} m)");
    }

    #[test]
    fn a_skirt_that_does_not_swing_learns_no_swing_and_tight_cloth_none_at_all() {
        let s = scene();
        let still = LooseSwing { along: [[0.0; SWING_FEATURES]; 3], outward: [0.0; SWING_FEATURES] };
        let fit = fit_loose_swing(&frames(&s, &still, &training_poses()), &s.joints, &SwingOptions::default()).expect("a swing is fitted");
        let kick = pose((1.5, 0.0), (0.0, 0.0));
        let largest = fit.swing.largest(&s.profile, &kick, &s.joints);
        assert!(largest < 0.005, "a still skirt swings {largest} m at the kick");
        // The body's own surface 5 mm out: nothing is loose, nothing is fitted.
        let rest = s.body.shaped_vertices(&[]);
        let normals = s.body.mesh(rest.clone()).vertex_normals();
        let tight = TriMesh::new(rest.iter().zip(&normals).map(|(p, n)| *p + *n * 0.005).collect(), s.body.faces.clone());
        let weights = s.body.weights.clone();
        let profile = swing_profile(&tight.positions, &weights, &s.sdf, &s.joints, &SwingOptions::default());
        assert!(profile.iter().all(|p| p.reach == 0.0));
        let poses = training_poses();
        let data: Vec<SwingFrame> = poses.iter().map(|p| {
            let bones = s.body.pose(p).bones;
            let observed = tight.positions.iter().zip(&weights).map(|(&x, w)| blend_transform(&bones.transforms, w).transform_point3(x)).collect();
            SwingFrame { params: p.clone(), bones, canonical: tight.clone(), weights: weights.clone(), profile: profile.clone(), observed }
        }).collect();
        assert!(fit_loose_swing(&data, &s.joints, &SwingOptions::default()).is_none());
    }
}
