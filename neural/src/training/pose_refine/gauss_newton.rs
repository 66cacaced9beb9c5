//! The Gauss-Newton round of one frame: its residuals' normal equations over an even subset
//! of its points, the damped step toward the priors (solved by Cholesky), each joint's step
//! clamped. The frames' rounds are independent and run in parallel.

use super::{Frame, FrameSdf, PoseRefineOptions, PoseRefiner, RoundPoints, RoundReport};
use avatar_core::body::{
    NUM_JOINTS, POSE_DOF, PoseCorrection, blend_transform, skinned_point_jacobian,
};
use glam::{Mat3, Vec3};
use rayon::prelude::*;

/// An even subsample of `count` of `n` points.
pub(super) fn subset(n: usize, count: usize) -> Vec<usize> {
    let m = count.min(n);
    (0..m).map(|i| i * n / m).collect()
}

impl PoseRefiner<'_> {
    /// An even subsample of `count` of frame `k`'s points.
    pub(super) fn subset(&self, k: usize, count: usize) -> Vec<usize> {
        subset(self.frames[k].posed.len(), count)
    }

    /// `iterations` Gauss-Newton steps of every frame (in parallel: each frame's steps read
    /// only its own points); residuals outside `keep` (metres, below and above) are left out.
    /// The reports in the frames' order.
    pub(super) fn refine_frames(
        &mut self,
        sdf: FrameSdf,
        iterations: usize,
        keep: (f32, f32),
        points: RoundPoints,
    ) -> Vec<RoundReport> {
        let round = FrameRound {
            capture: self.capture,
            rest_joints: &self.rest_joints,
            options: &self.options,
            measure_after: self.measure_after || self.lines.is_some(),
            sdf,
            iterations,
            keep,
            points,
        };
        self.frames.par_iter_mut().enumerate().map(|(k, f)| round.refine(k, f)).collect()
    }
}

/// What a frame's Gauss-Newton round reads besides the frame itself.
struct FrameRound<'r> {
    capture: &'r crate::data::capture_points::CapturePoints,
    rest_joints: &'r [Vec3; NUM_JOINTS],
    options: &'r PoseRefineOptions,
    /// Whether to measure the residual after the last step (one more SDF evaluation).
    measure_after: bool,
    sdf: FrameSdf<'r>,
    iterations: usize,
    keep: (f32, f32),
    points: RoundPoints,
}

impl FrameRound<'_> {
    /// The round's steps of frame `k`.
    fn refine(&self, k: usize, frame: &mut Frame) -> RoundReport {
        let (field, points, keep, sdf) = (&self.capture.field, self.points, self.keep, self.sdf);
        let count = if points == RoundPoints::All {
            self.options.points_per_frame
        } else {
            self.options.prealign_points_per_frame
        };
        // The round's points and their skinning weights, held fixed.
        let (idx, weights): (Vec<usize>, Vec<_>) = subset(frame.posed.len(), count)
            .into_iter()
            .map(|i| (i, field.weights_at(frame.canonical[i])))
            .filter(|(_, w)| points.takes(w))
            .unzip();
        let posed: Vec<Vec3> = idx.iter().map(|&i| frame.posed[i]).collect();
        let mut before = None;
        for _ in 0..self.iterations.max(1) {
            let bones = frame.correction.bones(self.rest_joints, &frame.given);
            let blends: Vec<_> =
                weights.iter().map(|w| blend_transform(&bones.transforms, w)).collect();
            let xc: Vec<Vec3> =
                blends.iter().zip(&posed).map(|(a, &y)| a.inverse().transform_point3(y)).collect();
            let (f, g) = sdf(k, &xc);
            let mean_abs = f.iter().map(|v| v.abs()).sum::<f32>() / f.len().max(1) as f32;
            before.get_or_insert(mean_abs);
            let huber = self.options.huber;
            // Normal equations of the weighted residuals, summed over the points in parallel;
            // only the lower triangle of `h`, the one `cholesky_solve` reads.
            let (h, b) = (0..xc.len())
                .into_par_iter()
                .fold(
                    || (vec![0f64; POSE_DOF * POSE_DOF], vec![0f64; POSE_DOF]),
                    |(mut h, mut b), p| {
                        let r = f[p];
                        if r < keep.0 || r > keep.1 || !r.is_finite() {
                            return (h, b);
                        }
                        let rho = if r.abs() <= huber { 1.0 } else { huber / r.abs() };
                        let a3 = Mat3::from_mat4(blends[p]);
                        let v = -(a3.inverse().transpose() * g[p]);
                        let cols = skinned_point_jacobian(&bones, &weights[p], xc[p]);
                        let row: [f64; POSE_DOF] = std::array::from_fn(|i| v.dot(cols[i]) as f64);
                        let mut nz = [0usize; POSE_DOF];
                        let mut count = 0;
                        for (i, value) in row.iter().enumerate() {
                            if *value != 0.0 {
                                nz[count] = i;
                                count += 1;
                            }
                        }
                        let nz = &nz[..count];
                        for (k, &i) in nz.iter().enumerate() {
                            b[i] += rho as f64 * row[i] * r as f64;
                            for &j in &nz[..=k] {
                                h[i * POSE_DOF + j] += rho as f64 * row[i] * row[j];
                            }
                        }
                        (h, b)
                    },
                )
                .reduce(
                    || (vec![0f64; POSE_DOF * POSE_DOF], vec![0f64; POSE_DOF]),
                    |(mut h1, mut b1), (h2, b2)| {
                        h1.iter_mut().zip(&h2).for_each(|(x, y)| *x += y);
                        b1.iter_mut().zip(&b2).for_each(|(x, y)| *x += y);
                        (h1, b1)
                    },
                );
            let mut step = solve_step(self.options, &frame.correction, h, b, xc.len());
            step.iter_mut()
                .enumerate()
                .filter(|(i, _)| !points.moves(*i))
                .for_each(|(_, v)| *v = 0.0);
            frame.correction.add(&step);
        }
        // The residual after the last step (one more evaluation), when it is asked for.
        if !self.measure_after {
            let before = before.unwrap_or(f32::NAN);
            return RoundReport { residual_before: before, residual_after: f32::NAN };
        }
        let bones = frame.correction.bones(self.rest_joints, &frame.given);
        let xc: Vec<Vec3> = weights
            .iter()
            .zip(&posed)
            .map(|(w, &y)| blend_transform(&bones.transforms, w).inverse().transform_point3(y))
            .collect();
        let (f, _) = sdf(k, &xc);
        let after = f.iter().map(|v| v.abs()).sum::<f32>() / f.len().max(1) as f32;
        RoundReport { residual_before: before.unwrap_or(after), residual_after: after }
    }
}

/// The damped Gauss-Newton step from a frame's `current` correction, by the normal equations of
/// `n` points.
fn solve_step(
    o: &PoseRefineOptions,
    current: &PoseCorrection,
    mut h: Vec<f64>,
    mut b: Vec<f64>,
    n: usize,
) -> Vec<f32> {
    let scale = 1.0 / n.max(1) as f64;
    h.iter_mut().for_each(|x| *x *= scale);
    b.iter_mut().for_each(|x| *x *= scale);
    let current = current.to_vec();
    for i in 0..POSE_DOF {
        let prior = if i < 3 * NUM_JOINTS { o.rotation_prior } else { o.translation_prior } as f64;
        // Levenberg-Marquardt damping on the data's diagonal, then the prior toward zero.
        h[i * POSE_DOF + i] *= 1.0 + 1e-3;
        h[i * POSE_DOF + i] += prior;
        b[i] += prior * current[i] as f64;
    }
    let mut step: Vec<f32> = match cholesky_solve(&h, &b, POSE_DOF) {
        Some(x) => x.iter().map(|v| -*v as f32).collect(),
        None => return vec![0.0; POSE_DOF],
    };
    for j in 0..=NUM_JOINTS {
        let limit = if j < NUM_JOINTS { o.max_step_rad } else { o.max_step_m };
        let s = Vec3::from_slice(&step[3 * j..3 * j + 3]);
        let len = s.length();
        if !len.is_finite() {
            return vec![0.0; POSE_DOF];
        }
        if len > limit {
            let c = s * (limit / len);
            step[3 * j..3 * j + 3].copy_from_slice(&c.to_array());
        }
    }
    step
}

/// Solve the symmetric positive definite system `h x = b` (row-major `n x n`, of which only
/// the lower triangle, `h[i * n + j]` with `j <= i`, is read) by Cholesky; `None` when it is
/// not positive definite.
fn cholesky_solve(h: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = vec![0f64; n * n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = h[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k];
            }
            if i == j {
                if s <= 0.0 || !s.is_finite() {
                    return None;
                }
                l[i * n + i] = s.sqrt();
            } else {
                l[i * n + j] = s / l[j * n + j];
            }
        }
    }
    let mut y = vec![0f64; n];
    for i in 0..n {
        let s: f64 = (0..i).map(|k| l[i * n + k] * y[k]).sum();
        y[i] = (b[i] - s) / l[i * n + i];
    }
    let mut x = vec![0f64; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| l[k * n + i] * x[k]).sum();
        x[i] = (y[i] - s) / l[i * n + i];
    }
    Some(x)
}
