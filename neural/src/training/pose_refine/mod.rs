//! Joint refinement of per-frame poses (PINA, section 3.2): the fittings of real captures are
//! off by a few degrees per joint and centimetres of translation, and each frame's canonical
//! points then disagree with the others'. Every few fitting steps, with the SDF frozen, each
//! frame's correction (24 joint rotations and the translation, `PoseCorrection`) takes a few
//! Gauss-Newton steps on
//!
//!   mean_k huber(f(x_c,k)) + rotation_prior |d|^2 + translation_prior |t|^2,
//!   x_c,k = (sum_i w_ik B_i(theta))^-1 x_d,k
//!
//! (`x_d`: the frame's depth point, `w`: its skinning weights held fixed during the round, `f`:
//! the avatar's SDF for the frame's pose, in metres); the priors pull toward the given fitting.
//! Then the frame's depth points are canonicalised anew for the corrected pose, as the
//! capture's were for the given one (root finding, the root nearest the rest body, the 2 cm
//! filter), and its pose input for the hypernetwork recomputed. Pre-alignment's rounds move the
//! canonical points by fixed-point iterations of the same inverse instead (cheaper; they start
//! nearer the truth). The derivative of the skinned point comes from
//! `avatar_core::body::pose_jacobian`; `dx_c = -A^-1 dy` with `A` the blended linear part.

use crate::data::capture_points::{CapturePoints, shell_samples_of};
use crate::data::pose_sample::PoseSample;
use crate::model::encoder::PoseEncoding;
use crate::model::siren_eval::SirenEval;
use crate::training::pose_trace::{PoseTrace, TraceLines};
use avatar_core::body::{BodyParams, NUM_JOINTS, POSE_DOF, PoseCorrection, blend_transform};
use avatar_core::canonical::ShellOptions;
use glam::{Mat3, Vec3};
use rayon::prelude::*;

mod gauss_newton;
mod options;
mod prealign;
mod recanonicalise;
pub use options::PoseRefineOptions;
use prealign::on_extremity;

/// A frame's SDF (metres) and its spatial gradient at canonical points (metres).
pub type FrameSdf<'a> = &'a (dyn Fn(usize, &[Vec3]) -> (Vec<f32>, Vec<Vec3>) + Sync);

struct Frame {
    given: BodyParams,
    correction: PoseCorrection,
    /// The correction pre-alignment found: the zero-mean constraint holds the later rounds'
    /// corrections relative to it.
    anchor: PoseCorrection,
    /// Depth points and normals (world, metres).
    posed: Vec<Vec3>,
    posed_normals: Vec<Vec3>,
    /// Whether root finding found each depth point more than one root (all `true` when not
    /// known): those are searched in full each round, the others solved from their root.
    ambiguous: Vec<bool>,
    /// Their current canonical points (metres).
    canonical: Vec<Vec3>,
    /// The frame's outside constraints (world, metres) and their current canonical points:
    /// free space, then from `shells_from` on the shell samples.
    free_posed: Vec<Vec3>,
    free_canonical: Vec<Vec3>,
    shells_from: usize,
}

/// What one round did: the mean |SDF| of the round's points before and after (metres; after:
/// NaN when the refiner does not measure it, [`PoseRefiner::measure_after`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundReport {
    pub residual_before: f32,
    pub residual_after: f32,
}

/// The corrections of every frame of a capture during a fit.
pub struct PoseRefiner<'a> {
    capture: &'a CapturePoints,
    rest_joints: [Vec3; NUM_JOINTS],
    frames: Vec<Frame>,
    pub options: PoseRefineOptions,
    /// The true fittings when known (`pose_trace`): each round then traces its errors.
    pub truth: Option<Vec<BodyParams>>,
    /// Where the trace's lines go (`PoseTrace::lines`; none: the errors are not written).
    lines: Option<TraceLines>,
    rounds_done: usize,
    /// Whether each round measures the residual after its last step (one more SDF evaluation
    /// of every frame's points: a third of a round against the avatar's SDF). On by default; a
    /// fit that reads no report turns it off (a trace measures it regardless).
    pub measure_after: bool,
}

/// Which of a frame's points a Gauss-Newton round takes.
#[derive(Debug, Clone, Copy, PartialEq)]
enum RoundPoints {
    /// Every point (the rounds against the avatar's SDF).
    All,
    /// The extremities left out (pre-alignment against the naked body).
    Body,
    /// The pelvis and the legs left out too (pre-alignment under a skirt).
    UpperBody,
    /// The trunk's points alone, and only the trunk's joints and the translation move
    /// (pre-alignment's first stage).
    Trunk,
}

impl RoundPoints {
    fn takes(self, w: &avatar_core::body::Weights) -> bool {
        match self {
            RoundPoints::All => true,
            RoundPoints::Body => !on_extremity(w),
            RoundPoints::UpperBody => !on_extremity(w) && !prealign::on_lower_body(w),
            RoundPoints::Trunk => prealign::on_trunk(w),
        }
    }

    /// Whether the correction's degree of freedom `i` moves in a round on these points.
    fn moves(self, i: usize) -> bool {
        match self {
            RoundPoints::Trunk => i >= 3 * NUM_JOINTS || prealign::TRUNK.contains(&(i / 3)),
            _ => true,
        }
    }
}

impl<'a> PoseRefiner<'a> {
    /// Start from the given fittings: each canonical point's depth point is its forward skinning.
    pub fn new(capture: &'a CapturePoints, options: PoseRefineOptions) -> Self {
        let rest_joints = capture.rest_joints();
        let norm = capture.normalisation;
        let frames = capture
            .frames
            .iter()
            .map(|f| {
                let correction = PoseCorrection::default();
                let bones = correction.bones(&rest_joints, &f.params);
                let canonical: Vec<Vec3> = f.points.iter().map(|q| norm.from_unit(*q)).collect();
                let (posed, posed_normals) = canonical
                    .par_iter()
                    .zip(&f.normals)
                    .map(|(&x, &n)| {
                        let a = blend_transform(&bones.transforms, &capture.field.weights_at(x));
                        (
                            a.transform_point3(x),
                            (Mat3::from_mat4(a).inverse().transpose() * n).normalize_or_zero(),
                        )
                    })
                    .unzip();
                let free_canonical: Vec<Vec3> =
                    f.outside().iter().map(|q| norm.from_unit(*q)).collect();
                let free_posed = free_canonical
                    .par_iter()
                    .map(|&x| {
                        blend_transform(&bones.transforms, &capture.field.weights_at(x))
                            .transform_point3(x)
                    })
                    .collect();
                let ambiguous = if f.ambiguous.len() == f.points.len() {
                    f.ambiguous.clone()
                } else {
                    vec![true; f.points.len()]
                };
                Frame {
                    given: f.params.clone(),
                    correction,
                    anchor: correction,
                    posed,
                    posed_normals,
                    ambiguous,
                    canonical,
                    free_posed,
                    free_canonical,
                    shells_from: f.free_space.len(),
                }
            })
            .collect();
        PoseRefiner {
            capture,
            rest_joints,
            frames,
            options,
            truth: None,
            lines: None,
            rounds_done: 0,
            measure_after: true,
        }
    }

    /// Diagnostic: trace the rounds against the trace's exact fittings (matched to the given
    /// ones by `pose_trace::match_truth`); writes the given fittings' errors.
    pub fn trace_against(&mut self, trace: &PoseTrace) {
        let given: Vec<BodyParams> = self.frames.iter().map(|f| f.given.clone()).collect();
        let indices: Vec<usize> = self.capture.frames.iter().map(|f| f.index).collect();
        self.truth = Some(crate::training::pose_trace::match_truth(
            &given,
            &indices,
            self.capture.capture_frames,
            &trace.truth,
        ));
        self.lines = Some(trace.lines.clone());
        self.trace_errors("given fittings");
    }

    /// Write a line to the trace, when there is one.
    pub fn trace(&self, line: impl FnOnce() -> String) {
        if let Some(lines) = &self.lines {
            lines.write(&line());
        }
    }

    /// Write the current fittings' errors, each joint's too, to the trace.
    pub fn trace_errors(&self, what: &str) {
        if let Some(e) = self.traced_errors() {
            self.trace(|| format!("{what}: {e}\n  per joint: {}", e.per_joint()));
        }
    }

    /// The errors against the truth when a trace is written.
    fn traced_errors(&self) -> Option<crate::training::pose_trace::PoseErrors> {
        self.lines.as_ref().and_then(|_| self.errors())
    }

    /// The corrected fitting of each frame.
    pub fn refined(&self) -> Vec<BodyParams> {
        self.frames.iter().map(|f| f.correction.apply(&f.given)).collect()
    }

    /// The refined fittings' errors against the truth, when it is known.
    pub fn errors(&self) -> Option<crate::training::pose_trace::PoseErrors> {
        self.truth.as_ref().map(|t| {
            crate::training::pose_trace::pose_errors(&self.refined(), t, &self.rest_joints)
        })
    }

    /// Diagnostic (`PoseTrace::snap`, after [`PoseRefiner::trace_against`]): set these joints' rotations
    /// (and the translation when `translation`) to the truth, to measure what their residual
    /// error costs the avatar. Nothing when the truth is unknown.
    pub fn snap_to_truth(&mut self, joints: &[usize], translation: bool) {
        let Some(truth) = self.truth.clone() else { return };
        for (k, t) in truth.iter().enumerate().take(self.frames.len()) {
            let f = &mut self.frames[k];
            for &j in joints.iter().filter(|&&j| j < NUM_JOINTS) {
                let given = glam::Quat::from_scaled_axis(f.given.pose[j]);
                f.correction.rotations[j] =
                    (given.inverse() * glam::Quat::from_scaled_axis(t.pose[j])).to_scaled_axis();
            }
            if translation {
                f.correction.translation = t.trans - f.given.trans;
            }
            f.anchor = f.correction;
            self.recanonicalise(k);
        }
    }

    pub fn corrections(&self) -> Vec<PoseCorrection> {
        self.frames.iter().map(|f| f.correction).collect()
    }

    /// One round on every frame with the SDF frozen; returns the mean over frames.
    pub fn round(&mut self, sdf: FrameSdf) -> RoundReport {
        let mut report = RoundReport { residual_before: 0.0, residual_after: 0.0 };
        let n = self.frames.len().max(1) as f32;
        let (iterations, cutoff) = (self.options.iterations, 10.0 * self.options.huber);
        for r in self.refine_frames(sdf, iterations, (-cutoff, cutoff), RoundPoints::All) {
            report.residual_before += r.residual_before / n;
            report.residual_after += r.residual_after / n;
        }
        if self.options.zero_mean && self.frames.len() > 1 {
            self.remove_common_correction();
        }
        self.recanonicalise_all_fully();
        self.rounds_done += 1;
        if let Some(e) = self.traced_errors() {
            self.trace(|| {
                format!(
                    "round {}: |sdf| {:.2} -> {:.2} mm; {e}",
                    self.rounds_done,
                    report.residual_before * 1e3,
                    report.residual_after * 1e3
                )
            });
        }
        report
    }

    /// Subtract the correction all frames share. A change common to every frame (all knees
    /// 3 degrees more bent) is also a change of the canonical shape: the SDF follows it and
    /// the data cannot tell the two apart, so without this the poses drift together toward
    /// the meta-learned body's shape. The given fittings are taken as right on average.
    fn remove_common_correction(&mut self) {
        let n = self.frames.len() as f32;
        let mut mean = vec![0f32; POSE_DOF];
        for f in &self.frames {
            mean.iter_mut()
                .zip(f.correction.to_vec())
                .zip(f.anchor.to_vec())
                .for_each(|((m, v), a)| *m += (v - a) / n);
        }
        let minus: Vec<f32> = mean.iter().map(|v| -v).collect();
        for f in self.frames.iter_mut() {
            f.correction.add(&minus);
        }
    }

    /// The training samples with every frame's current points, normals and pose input.
    pub fn update_samples(&self, samples: &mut [PoseSample], encoding: PoseEncoding) {
        let norm = self.capture.normalisation;
        for (k, (sample, frame)) in samples.iter_mut().zip(&self.frames).enumerate() {
            sample.points = frame.canonical.iter().map(|x| norm.to_unit(*x)).collect();
            sample.free_space = frame.free_canonical.iter().map(|x| norm.to_unit(*x)).collect();
            sample.normals = self.canonical_normals(k);
            sample.pose_input =
                encoding.input(&frame.correction.apply(&frame.given), &self.rest_joints, &norm);
        }
    }

    /// Frame `k`'s depth normals carried to its current canonical points.
    fn canonical_normals(&self, k: usize) -> Vec<Vec3> {
        let frame = &self.frames[k];
        let bones = frame.correction.bones(&self.rest_joints, &frame.given);
        frame
            .canonical
            .par_iter()
            .zip(&frame.posed_normals)
            .map(|(&x, &n)| {
                let a = Mat3::from_mat4(blend_transform(
                    &bones.transforms,
                    &self.capture.field.weights_at(x),
                ));
                (a.transpose() * n).normalize_or_zero()
            })
            .collect()
    }

    /// The shell samples drawn again from the frames' current canonical points. Drawn from
    /// the given fittings', points that a pose error put centimetres off the body look like
    /// loose clothing and get a shell behind them, which then carves into the body (tight
    /// outfit at 5 deg / 2 cm: Chamfer 0.329 -> 0.435 cm when the shells came).
    pub fn redraw_shells(&mut self, options: &ShellOptions) {
        let points: Vec<Vec<Vec3>> = self.frames.iter().map(|f| f.canonical.clone()).collect();
        let normals: Vec<Vec<Vec3>> =
            (0..self.frames.len()).map(|k| self.canonical_normals(k)).collect();
        let normals: Vec<&[Vec3]> = normals.iter().map(Vec::as_slice).collect();
        let shells = shell_samples_of(&self.capture.rest_sdf, &points, &normals, options);
        let field = &self.capture.field;
        for (frame, samples) in self.frames.iter_mut().zip(shells) {
            let bones = frame.correction.bones(&self.rest_joints, &frame.given);
            frame.free_canonical.truncate(frame.shells_from);
            frame.free_posed.truncate(frame.shells_from);
            frame.free_posed.extend(samples.iter().map(|&x| {
                blend_transform(&bones.transforms, &field.weights_at(x)).transform_point3(x)
            }));
            frame.free_canonical.extend(samples);
        }
    }
}

/// One round during a fit: the SDF of each frame is the hypernetwork's SIREN for the frame's
/// current pose input (frozen for the round); afterwards `samples` hold the refined points,
/// normals and pose inputs.
pub fn refine_round(
    refiner: &mut PoseRefiner,
    model: &crate::model::hyper::HyperNet,
    samples: &mut [PoseSample],
    encoding: PoseEncoding,
) -> RoundReport {
    use burn::module::Module;
    let device = crate::cpu_device();
    let inference = model.valid().to_device(&device);
    let sirens: Vec<SirenEval> = samples
        .iter()
        .map(|s| {
            let (w, b) = inference.siren_for(&s.pose_input, &device);
            SirenEval::from_tensors(&w, &b)
        })
        .collect();
    let norm = refiner.capture.normalisation;
    let metres = norm.metres_per_unit();
    let sdf = |k: usize, points: &[Vec3]| -> (Vec<f32>, Vec<Vec3>) {
        let unit: Vec<[f32; 3]> = points.iter().map(|p| norm.to_unit(*p).to_array()).collect();
        let (f, g) = sirens[k].sdf_and_gradient(&unit);
        (f.into_iter().map(|v| v * metres).collect(), g.into_iter().map(Vec3::from_array).collect())
    };
    let report = refiner.round(&sdf);
    refiner.update_samples(samples, encoding);
    report
}
