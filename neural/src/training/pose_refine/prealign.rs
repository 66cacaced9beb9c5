//! Pre-alignment of the frames' poses against a fixed target that knows the subject's shape
//! (the shaped body, `crate::data::body_sdf::BodySdf`), before the avatar's SDF has learned anything
//! from the misaligned points (docs/neural.md, "Pose refinement"; the measurements behind the
//! defaults: docs/decisions.md).

use super::{FrameSdf, PoseRefiner, RoundPoints, RoundReport};
use avatar_core::body::{PoseCorrection, blend_transform};
use glam::Vec3;
use rayon::prelude::*;

/// Rounds, and Gauss-Newton steps a round, of the upper body's pre-alignment: 4 of 5. The whole
/// body's longer schedule (`PoseRefineOptions::prealign_rounds`) moved the quick dress's poses a
/// little closer (4.45 -> 4.40 deg) but its Chamfer-L2 0.793 -> 0.890 cm at 5 deg / 2 cm.
const UPPER_BODY_SCHEDULE: (usize, usize) = (4, 5);

/// What pre-alignment changes of a frame: its correction, its canonical points and its
/// free-space samples' canonical points.
type FrameState = (PoseCorrection, Vec<Vec3>, Vec<Vec3>);

impl PoseRefiner<'_> {
    /// [`PoseRefiner::prealign`] on the points of the spine, the arms and the head's joints
    /// alone (the pelvis's and the legs' left out, besides the extremities): a dress's skirt
    /// hides the thighs and its points near the hips biased the translations when the whole
    /// body was pre-aligned, but its bodice and arms are tight. The legs keep the
    /// given fittings for the later rounds. Quick preset's dress at 5 deg / 2 cm: NC 0.723 ->
    /// 0.758, Chamfer-L2 0.851 -> 0.849 cm; exact fittings 0.693 -> 0.688 (docs/decisions.md).
    pub fn prealign_upper_body(&mut self, sdf: FrameSdf) -> RoundReport {
        self.prealign_points(sdf, RoundPoints::UpperBody, UPPER_BODY_SCHEDULE)
    }

    /// The share of the frames' points (extremities left out) within `prealign_cutoff` of
    /// `sdf` at the current poses: high for tight clothing, low for a dress, whose skirt the
    /// body does not explain (pre-alignment then pulls the legs toward the skirt).
    pub fn near_share(&self, sdf: FrameSdf) -> f32 {
        let (near, all) = (0..self.frames.len())
            .into_par_iter()
            .map(|k| {
                let f = self.body_point_sdf(k, sdf);
                (f.iter().filter(|v| v.abs() <= self.options.prealign_cutoff).count(), f.len())
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        near as f32 / all.max(1) as f32
    }

    /// Pre-alignment (before the avatar's SDF has learned from the misaligned points): rounds
    /// of Gauss-Newton steps of every frame against `sdf`, a fixed target that knows the
    /// subject's shape (the shaped body, `BodySdf`, less the clothing's offset). A point whose
    /// residual is beyond `prealign_cutoff` either side (loose clothing: a skirt, hair) or on
    /// the head, hands or feet is left out. Against a fixed shape the error the frames share is
    /// observable, so no zero-mean constraint here but along the body's axis; the later rounds
    /// keep their mean correction relative to this one.
    ///
    /// With `prealign_trunk_first`, a second start: the trunk's points first move only the
    /// pelvis, the spine and the translation (the upper body's schedule), then the whole body
    /// as from the given fittings; each frame keeps the start whose poses fit the body better
    /// (`body_residuals`). All joints at once, the chain's cheapest way to fit the arms can be
    /// to bend the spine: a squat's upper spine went 10 degrees sideways and its pelvis 1.4 cm
    /// up, a local minimum (residual 4.3 mm against 2.9 at the true poses). The trunk alone is
    /// no better start where the limbs are right: it moved exact fittings' posed joints 0.65
    /// cm, and the whole body brought them back only to 0.4 (t-shirt's NC on the user table
    /// 0.942 -> 0.941 with the trunk first everywhere).
    pub fn prealign(&mut self, sdf: FrameSdf) -> RoundReport {
        let schedule = (self.options.prealign_rounds, self.options.prealign_iterations);
        if !self.options.prealign_trunk_first {
            return self.prealign_points(sdf, RoundPoints::Body, schedule);
        }
        let given = self.state();
        let whole_report = self.prealign_points(sdf, RoundPoints::Body, schedule);
        let (whole, whole_residuals) = (self.state(), self.body_residuals(sdf));
        self.restore(&given, |_| true);
        self.prealign_trunk(sdf);
        let report = self.prealign_points(sdf, RoundPoints::Body, schedule);
        let trunk_residuals = self.body_residuals(sdf);
        let whole_better: Vec<bool> =
            whole_residuals.iter().zip(&trunk_residuals).map(|(w, t)| w <= t).collect();
        self.restore(&whole, |k| whole_better[k]);
        if whole_better.iter().any(|&w| !w) && whole_better.iter().any(|&w| w) {
            // Frames from both starts: their shared translation along the body's axis back to
            // the given fittings' (each start held it there alone).
            self.hold_shared_axial_translation();
            self.recanonicalise_all();
        }
        for f in self.frames.iter_mut() {
            f.anchor = f.correction;
        }
        if let Some(e) = self.traced_errors() {
            self.trace(|| {
                format!(
                    "pre-alignment from the trunk first kept for {} of {} frames; {e}",
                    whole_better.iter().filter(|&&w| !w).count(),
                    whole_better.len()
                )
            });
        }
        // Both starts begin at the given fittings.
        let after = if whole_better.iter().all(|&w| w) {
            whole_report.residual_after
        } else {
            report.residual_after
        };
        RoundReport { residual_before: whole_report.residual_before, residual_after: after }
    }

    /// Each frame's correction and canonical points (pre-alignment moves nothing else).
    fn state(&self) -> Vec<FrameState> {
        self.frames
            .iter()
            .map(|f| (f.correction, f.canonical.clone(), f.free_canonical.clone()))
            .collect()
    }

    /// Back to `state` for the frames `which` names.
    fn restore(&mut self, state: &[FrameState], which: impl Fn(usize) -> bool) {
        for (k, (f, (c, canonical, free))) in self.frames.iter_mut().zip(state).enumerate() {
            if which(k) {
                f.correction = *c;
                f.canonical.clone_from(canonical);
                f.free_canonical.clone_from(free);
            }
        }
    }

    /// Each frame's mean |residual| against `sdf` over its pre-alignment points (the whole
    /// body's; each residual capped at `prealign_cutoff`, so a pose cannot look better by
    /// pushing points out of reach).
    fn body_residuals(&self, sdf: FrameSdf) -> Vec<f32> {
        let cutoff = self.options.prealign_cutoff;
        (0..self.frames.len())
            .into_par_iter()
            .map(|k| {
                let f = self.body_point_sdf(k, sdf);
                f.iter().map(|v| v.abs().min(cutoff)).sum::<f32>() / f.len().max(1) as f32
            })
            .collect()
    }

    /// `sdf` at frame `k`'s pre-alignment points (its even subsample, extremities left out),
    /// canonicalised for its current pose with the weights at their canonical points.
    fn body_point_sdf(&self, k: usize, sdf: FrameSdf) -> Vec<f32> {
        let field = &self.capture.field;
        let frame = &self.frames[k];
        let bones = frame.correction.bones(&self.rest_joints, &frame.given);
        let xc: Vec<Vec3> = self
            .subset(k, self.options.prealign_points_per_frame)
            .into_iter()
            .map(|i| (i, field.weights_at(frame.canonical[i])))
            .filter(|(_, w)| RoundPoints::Body.takes(w))
            .map(|(i, w)| {
                blend_transform(&bones.transforms, &w).inverse().transform_point3(frame.posed[i])
            })
            .collect();
        sdf(k, &xc).0
    }

    /// The frames' shared translation along the body's axis is left to the given fittings:
    /// against the naked body it is biased by the clothing, shoes and hair (exact fittings
    /// moved 4 mm down, all frames alike). Across the body it is free.
    fn hold_shared_axial_translation(&mut self) {
        if self.frames.len() < 2 {
            return;
        }
        let n = self.frames.len() as f32;
        // Each frame's body axis: the root's rotation of canonical up.
        let up: Vec<Vec3> = self
            .frames
            .iter()
            .map(|f| glam::Quat::from_scaled_axis(f.correction.apply(&f.given).pose[0]) * Vec3::Y)
            .collect();
        let mean =
            self.frames.iter().zip(&up).map(|(f, u)| f.correction.translation.dot(*u)).sum::<f32>()
                / n;
        self.frames.iter_mut().zip(&up).for_each(|(f, u)| f.correction.translation -= *u * mean);
    }

    /// Pre-alignment's first stage: the trunk's points (pelvis and spine) move only the trunk's
    /// joints and the translation; every other joint keeps its correction.
    pub fn prealign_trunk(&mut self, sdf: FrameSdf) -> RoundReport {
        self.prealign_points(sdf, RoundPoints::Trunk, UPPER_BODY_SCHEDULE)
    }

    /// `schedule`: rounds, and Gauss-Newton steps a round.
    fn prealign_points(
        &mut self,
        sdf: FrameSdf,
        points: RoundPoints,
        (rounds, iterations): (usize, usize),
    ) -> RoundReport {
        let o = self.options;
        let mut report: Option<RoundReport> = None;
        let n = self.frames.len().max(1) as f32;
        // The corrections at the start of the best round so far, and that round's residual.
        let mut best: Option<(f32, Vec<PoseCorrection>)> = None;
        for round in 0..rounds {
            let start: Vec<PoseCorrection> = self.frames.iter().map(|f| f.correction).collect();
            let mut r = RoundReport { residual_before: 0.0, residual_after: 0.0 };
            let keep = (-o.prealign_cutoff, o.prealign_cutoff);
            for f in self.refine_frames(sdf, iterations, keep, points) {
                r.residual_before += f.residual_before / n;
                r.residual_after += f.residual_after / n;
            }
            // A round whose start fits the body no better than the previous round's did: that
            // round only moved the poses (exact fittings drift by half a centimetre over four
            // rounds, the residual growing). Back to the best start, and stop.
            if let Some((best_residual, best_start)) = &best
                && r.residual_before >= *best_residual
            {
                for (f, c) in self.frames.iter_mut().zip(best_start) {
                    f.correction = *c;
                }
                self.recanonicalise_all();
                if let Some(e) = self.traced_errors() {
                    self.trace(|| format!(
                        "pre-alignment {}: |sdf| {:.2} mm, no better than {:.2}: back to round {}'s start; {e}",
                        round + 1,
                        r.residual_before * 1e3,
                        best_residual * 1e3,
                        round
                    ));
                }
                break;
            }
            best = Some((r.residual_before, start));
            self.hold_shared_axial_translation();
            self.recanonicalise_all();
            if let Some(e) = self.traced_errors() {
                self.trace(|| {
                    format!(
                        "pre-alignment {}: |sdf| {:.2} -> {:.2} mm; {e}",
                        round + 1,
                        r.residual_before * 1e3,
                        r.residual_after * 1e3
                    )
                });
            }
            report = Some(report.map_or(r, |first| RoundReport {
                residual_before: first.residual_before,
                residual_after: r.residual_after,
            }));
        }
        for f in self.frames.iter_mut() {
            f.anchor = f.correction;
        }
        report.unwrap_or(RoundReport { residual_before: 0.0, residual_after: 0.0 })
    }
}

/// Joints whose surface a person's clothing and hair change most against the naked body
/// (shoes, hair, hands in gloves or sleeves): head, ankles, feet, wrists and hands.
const EXTREMITIES: [usize; 9] = [7, 8, 10, 11, 15, 20, 21, 22, 23];

/// Whether a point belongs mostly to an extremity (pre-alignment against the naked body leaves
/// it out: a shoe's sole would pull the body down).
pub(super) fn on_extremity(w: &avatar_core::body::skinning::Weights) -> bool {
    EXTREMITIES.iter().map(|&j| w[j]).sum::<f32>() > 0.5
}

/// The pelvis and the legs (`JOINT_NAMES`): where a skirt hangs.
const LOWER_BODY: [usize; 9] = [0, 1, 2, 4, 5, 7, 8, 10, 11];

/// Whether a point belongs mostly to the pelvis or the legs.
pub(super) fn on_lower_body(w: &avatar_core::body::skinning::Weights) -> bool {
    LOWER_BODY.iter().map(|&j| w[j]).sum::<f32>() > 0.5
}

/// The trunk's joints: pelvis and the three spine joints.
pub(super) const TRUNK: [usize; 4] = [0, 3, 6, 9];

/// Whether a point belongs mostly to the trunk.
pub(super) fn on_trunk(w: &avatar_core::body::skinning::Weights) -> bool {
    TRUNK.iter().map(|&j| w[j]).sum::<f32>() > 0.5
}
