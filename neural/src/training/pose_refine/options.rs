//! The options of pose refinement: when rounds run, how many points and steps they take, and
//! the priors that hold each frame near its given fitting.

use serde::{Deserialize, Serialize};

/// How poses are refined during a fit (docs/decisions.md has the measurements behind each
/// value).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseRefineOptions {
    pub enabled: bool,
    /// A refinement round after step 1 and then every `every` fitting steps, up to step
    /// `until`; the SDF then fits the aligned points. Early and often is better: the
    /// meta-learned SDF is a good target while it is still close to its prior, and the longer
    /// it learns from misaligned points the more it holds the misalignment (docs/decisions.md).
    pub every: usize,
    pub until: usize,
    /// Gauss-Newton steps a round.
    pub iterations: usize,
    /// Points of a frame that enter a round against the avatar's SDF (an even subsample).
    pub points_per_frame: usize,
    /// Points of a frame that enter pre-alignment. Older option files: 3,000, as rounds had.
    #[serde(default = "prealign_points")]
    pub prealign_points_per_frame: usize,
    /// Weight of the squared rotation correction (m^2 per rad^2, against the mean squared SDF).
    pub rotation_prior: f32,
    /// Weight of the squared translation correction.
    pub translation_prior: f32,
    /// Residuals beyond this (metres) weigh as |r| (Huber), beyond 10x not at all.
    pub huber: f32,
    /// Largest change of one joint's rotation (radians) and of the translation (metres) a step.
    pub max_step_rad: f32,
    pub max_step_m: f32,
    /// Keep the frames' mean correction at zero (see `remove_common_correction`).
    pub zero_mean: bool,
    /// Pre-alignment before the first fitting step (`PoseRefiner::prealign`): rounds against
    /// the subject's own body, Gauss-Newton steps a round, and the residual (metres, beyond the
    /// clothing's offset, either side) beyond which a point is left out (loose clothing).
    /// Older option files without these fields have no pre-alignment.
    #[serde(default)]
    pub prealign_rounds: usize,
    #[serde(default)]
    pub prealign_iterations: usize,
    #[serde(default)]
    pub prealign_cutoff: f32,
    /// The first fitting step after which a round against the avatar's SDF runs.
    #[serde(default = "first_round")]
    pub first: usize,
    /// Where the body does not explain the points (a dress), pre-align the upper body alone
    /// (`PoseRefiner::prealign_upper_body`). Older option files: off.
    #[serde(default)]
    pub prealign_upper_body: bool,
    /// Pre-alignment from a second start as well (`PoseRefiner::prealign`): the trunk's points
    /// alone first, only the pelvis, the spine and the translation moving, then the whole
    /// body; each frame keeps the start that fits the body better. Older option files: off.
    #[serde(default)]
    pub prealign_trunk_first: bool,
}

fn first_round() -> usize {
    1
}

fn prealign_points() -> usize {
    3000
}

impl Default for PoseRefineOptions {
    fn default() -> Self {
        PoseRefineOptions {
            enabled: true,
            // After pre-alignment, a round against the avatar's SDF once it has learned from
            // the aligned points (step 16) and one more once it is sharper (step 48): tight
            // outfit, 5 deg / 2 cm, Chamfer 0.261 -> 0.233 cm, exact fittings 0.181 -> 0.184
            // (docs/decisions.md). A round every 3 steps up to 64 (`without_prealignment`'s
            // schedule) let the translations drift: Chamfer 0.85 against 0.53 cm.
            every: 32,
            until: 49,
            iterations: 2,
            // 3,000 rather than 1,000: exact fittings move less with more points (tight
            // outfit: Chamfer 0.310 -> 0.287 cm), perturbed ones come closer (0.338 -> 0.329).
            // 8,000 in the rounds against the avatar's SDF, whose points are canonicalised
            // anew each round: quick dress at 5 deg / 2 cm 0.698 -> 0.678 cm rather than 3,000
            // (docs/decisions.md).
            points_per_frame: 8000,
            prealign_points_per_frame: 3000,
            rotation_prior: 1e-4,
            translation_prior: 1e-3,
            huber: 0.01,
            max_step_rad: 3f32.to_radians(),
            max_step_m: 0.01,
            zero_mean: true,
            // 8 rounds of 8 steps rather than 4 of 5: the frames' shared translation
            // across the body converges slowly against a body whose clothing offset each frame
            // takes from the side its camera sees (tight outfit, 5 deg / 2 cm: translation 0.28
            // -> 0.22 cm, Chamfer 0.233 -> 0.215 cm; exact fittings stop after round 2 as
            // before; docs/decisions.md).
            prealign_rounds: 8,
            prealign_iterations: 8,
            prealign_cutoff: 0.03,
            first: 16,
            prealign_upper_body: true,
            // The whole body at once let a squat's spine bend 10 degrees sideways and the
            // pelvis rise 1.4 cm to fit the arms (its residual 4.3 mm, 2.9 at the truth):
            // 2 subjects' tight outfit at 5 deg / 2 cm, Chamfer-L2 0.235 -> 0.216 cm; exact
            // fittings keep the whole body's start (docs/decisions.md).
            prealign_trunk_first: true,
        }
    }
}

impl PoseRefineOptions {
    pub fn off() -> Self {
        PoseRefineOptions { enabled: false, ..Self::default() }
    }

    /// The rounds for captures that pre-alignment leaves alone (loose clothing), whose steps
    /// each take `poses_per_step` of the capture's `frames`. Where every step takes every frame
    /// (8 frames), a round after step 1 and every 3 steps up to 64; where a step takes a
    /// quarter of them or fewer (the fit's default 32 frames), after step 16 and every 6 steps
    /// up to 128; in between, in proportion. The early rounds align each frame against an SDF
    /// that has barely seen it, and with 32 frames the poses did not come back from the first
    /// round's pull toward the prior (exact fittings moved 1.2 cm); four held-out dresses at
    /// 32 frames: Chamfer-L2 0.868 -> 0.762 cm, spurious 12.2 -> 10.4 %; at 8 frames the late
    /// schedule lost (0.791 -> 0.823; docs/decisions.md).
    pub fn without_prealignment(&self, frames: usize, poses_per_step: usize) -> Self {
        let batches = frames as f32 / poses_per_step.max(1) as f32;
        let t = ((batches - 1.0) / 3.0).clamp(0.0, 1.0);
        let between = |a: f32, b: f32| (a + t * (b - a)).round() as usize;
        PoseRefineOptions {
            first: between(1.0, 16.0),
            every: between(3.0, 6.0),
            until: between(64.0, 128.0),
            prealign_rounds: 0,
            ..*self
        }
    }

    /// The first round against the avatar's SDF alone (loose clothing that pre-alignment
    /// still took: a blazer's tails).
    pub fn single_round(&self) -> Self {
        PoseRefineOptions { until: self.first + 1, ..*self }
    }

    /// The training steps after which a round runs (none when off), for a fit of `steps` steps.
    pub fn round_steps(&self, steps: usize) -> Vec<usize> {
        if !self.enabled || self.every == 0 || steps < 2 {
            return Vec::new();
        }
        (self.first.max(1)..self.until.min(steps)).step_by(self.every).collect()
    }
}
