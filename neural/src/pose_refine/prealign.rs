//! Pre-alignment of the frames' poses against a fixed target that knows the subject's shape
//! (the shaped body, `crate::body_sdf::BodySdf`), before the avatar's SDF has learned anything
//! from the misaligned points (docs/neural.md, "Pose refinement").

use super::{FrameSdf, PoseRefiner, RoundPoints, RoundReport};
use avatar_core::body::{blend_transform, PoseCorrection};
use glam::Vec3;

/// Rounds, and Gauss-Newton steps a round, of the upper body's pre-alignment: session 10's 4 of
/// 5. The whole body's longer schedule (`PoseRefineOptions::prealign_rounds`, session 11) moved
/// the quick dress's poses a little closer (4.45 -> 4.40 deg) and its Chamfer-L2 0.793 -> 0.890
/// cm at 5 deg / 2 cm.
const UPPER_BODY_SCHEDULE: (usize, usize) = (4, 5);

impl PoseRefiner<'_> {
    /// [`PoseRefiner::prealign`] on the points of the spine, the arms and the head's joints
    /// alone (the pelvis's and the legs' left out, besides the extremities): a dress's skirt
    /// hides the thighs and its points near the hips biased the translations when the whole
    /// body was pre-aligned (session 4), but its bodice and arms are tight. The legs keep the
    /// given fittings for the later rounds. Quick preset's dress at 5 deg / 2 cm: NC 0.723 ->
    /// 0.758, Chamfer-L2 0.851 -> 0.849 cm; exact fittings 0.693 -> 0.688 (docs/evaluation.md,
    /// session 10).
    pub fn prealign_upper_body(&mut self, sdf: FrameSdf) -> RoundReport {
        self.prealign_points(sdf, RoundPoints::UpperBody, UPPER_BODY_SCHEDULE)
    }

    /// The share of the frames' points (extremities left out) within `prealign_cutoff` of
    /// `sdf` at the current poses: high for tight clothing, low for a dress, whose skirt the
    /// body does not explain (pre-alignment then pulls the legs toward the skirt).
    pub fn near_share(&self, sdf: FrameSdf) -> f32 {
        let field = &self.capture.field;
        let (mut near, mut all) = (0usize, 0usize);
        for (k, frame) in self.frames.iter().enumerate() {
            let bones = frame.correction.bones(&self.rest_joints, &frame.given);
            let xc: Vec<Vec3> = self
                .subset(k, self.options.prealign_points_per_frame)
                .into_iter()
                .map(|i| (i, field.weights_at(frame.canonical[i])))
                .filter(|(_, w)| RoundPoints::Body.takes(w))
                .map(|(i, w)| blend_transform(&bones.transforms, &w).inverse().transform_point3(frame.posed[i]))
                .collect();
            let (f, _) = sdf(k, &xc);
            near += f.iter().filter(|v| v.abs() <= self.options.prealign_cutoff).count();
            all += f.len();
        }
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
    /// With `prealign_trunk_first`, the trunk's points first move only the pelvis, the spine
    /// and the translation (the upper body's schedule). All joints at once, the chain's
    /// cheapest way to fit the arms can be to bend the spine: a squat's upper spine went 10
    /// degrees sideways and its pelvis 1.4 cm up, a local minimum (residual 4.3 mm against 2.9
    /// at the true poses).
    pub fn prealign(&mut self, sdf: FrameSdf) -> RoundReport {
        if self.options.prealign_trunk_first {
            self.prealign_trunk(sdf);
        }
        self.prealign_points(sdf, RoundPoints::Body, (self.options.prealign_rounds, self.options.prealign_iterations))
    }

    /// Pre-alignment's first stage: the trunk's points (pelvis and spine) move only the trunk's
    /// joints and the translation; every other joint keeps its correction.
    pub fn prealign_trunk(&mut self, sdf: FrameSdf) -> RoundReport {
        self.prealign_points(sdf, RoundPoints::Trunk, UPPER_BODY_SCHEDULE)
    }

    /// `schedule`: rounds, and Gauss-Newton steps a round.
    fn prealign_points(&mut self, sdf: FrameSdf, points: RoundPoints, (rounds, iterations): (usize, usize)) -> RoundReport {
        let o = self.options;
        let mut report: Option<RoundReport> = None;
        let n = self.frames.len().max(1) as f32;
        // The corrections at the start of the best round so far, and that round's residual.
        let mut best: Option<(f32, Vec<PoseCorrection>)> = None;
        for round in 0..rounds {
            let start: Vec<PoseCorrection> = self.frames.iter().map(|f| f.correction).collect();
            let mut r = RoundReport { residual_before: 0.0, residual_after: 0.0 };
            for k in 0..self.frames.len() {
                let f = self.refine_frame(k, sdf, iterations, (-o.prealign_cutoff, o.prealign_cutoff), points);
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
                for k in 0..self.frames.len() {
                    self.recanonicalise(k);
                }
                if let Some(e) = self.errors() {
                    eprintln!("pose trace: pre-alignment {}: |sdf| {:.2} mm, no better than {:.2}: back to round {}'s start; {e}", round + 1, r.residual_before * 1e3, best_residual * 1e3, round);
                }
                break;
            }
            best = Some((r.residual_before, start));
            // The frames' shared translation along the body's axis is left to the given
            // fittings: against the naked body it is biased by the clothing, shoes and hair
            // (exact fittings moved 4 mm down, all frames alike). Across the body it is free.
            if self.frames.len() > 1 {
                // Each frame's body axis: the root's rotation of canonical up.
                let up: Vec<Vec3> = self.frames.iter().map(|f| glam::Quat::from_scaled_axis(f.correction.apply(&f.given).pose[0]) * Vec3::Y).collect();
                let mean = self.frames.iter().zip(&up).map(|(f, u)| f.correction.translation.dot(*u)).sum::<f32>() / n;
                self.frames.iter_mut().zip(&up).for_each(|(f, u)| f.correction.translation -= *u * mean);
            }
            for k in 0..self.frames.len() {
                self.recanonicalise(k);
            }
            if let Some(e) = self.errors() {
                eprintln!("pose trace: pre-alignment {}: |sdf| {:.2} -> {:.2} mm; {e}", round + 1, r.residual_before * 1e3, r.residual_after * 1e3);
            }
            report = Some(report.map_or(r, |first| RoundReport { residual_before: first.residual_before, residual_after: r.residual_after }));
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
