//! What a fit will do, phase by phase, and the time left it implies. `fit_avatar` announces
//! its [`FitPlan`] (and revises it when it decides: after pre-alignment, after the loose
//! check) and each [`FitPhase`] as it starts; [`TimeLeft`] turns those events and the clock
//! of the caller into an estimate (the CLI's `fit`, the studio's fit job). No clock is read
//! here: callers pass the seconds elapsed.

/// A part of a fit, announced as it starts (it ends where the next one starts, or the fit
/// returns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FitPhase {
    /// The poses aligned to the subject's own body, before the first step.
    PreAlignment,
    /// A run of training steps (sampling, loss and gradient, Adam), up to the next break.
    Training,
    /// A pose refinement round against the avatar's SDF, between steps.
    Refinement,
    /// The avatar meshed once to see whether it has loose pieces (they earn more steps).
    LooseCheck,
    /// The partial avatar made for the caller after a chunk (the caller's own work on it,
    /// the studio's preview mesh, counts here too).
    Partial,
}

impl FitPhase {
    pub const ALL: [FitPhase; 5] = [
        FitPhase::PreAlignment,
        FitPhase::Training,
        FitPhase::Refinement,
        FitPhase::LooseCheck,
        FitPhase::Partial,
    ];

    /// A short label for progress lines.
    pub fn label(self) -> &'static str {
        match self {
            FitPhase::PreAlignment => "pre-aligning poses",
            FitPhase::Training => "training",
            FitPhase::Refinement => "refining poses",
            FitPhase::LooseCheck => "checking for loose cloth",
            FitPhase::Partial => "partial avatar",
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// The cost of one of this phase in training steps, until the fit has measured both.
    /// Measured on the demo's default fit (wall time, `fit --timings`, docs/performance.md;
    /// AMD Zen 5, AVX-512 kernels): a pre-alignment about 65 steps, a refinement round of its
    /// 32 frames about 13 (10 on the AVX2 kernels), the loose check about 20; a partial avatar
    /// (the studio's preview mesh) taken as 10.
    fn steps_equivalent(self) -> f64 {
        match self {
            FitPhase::PreAlignment => 65.0,
            FitPhase::Training => 1.0,
            FitPhase::Refinement => 13.0,
            FitPhase::LooseCheck => 20.0,
            FitPhase::Partial => 10.0,
        }
    }
}

/// How much of each phase a whole fit holds (steps for training, occurrences otherwise),
/// counted from its start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FitPlan {
    pub prealignment: usize,
    pub steps: usize,
    pub refinements: usize,
    pub loose_checks: usize,
    pub partials: usize,
}

impl FitPlan {
    fn count(&self, phase: FitPhase) -> usize {
        match phase {
            FitPhase::PreAlignment => self.prealignment,
            FitPhase::Training => self.steps,
            FitPhase::Refinement => self.refinements,
            FitPhase::LooseCheck => self.loose_checks,
            FitPhase::Partial => self.partials,
        }
    }
}

/// The time a fit has left, from its events: each phase's own measured cost once one has
/// run, the fit's overall pace in training steps for the phases not yet seen.
#[derive(Debug, Clone, Default)]
pub struct TimeLeft {
    plan: FitPlan,
    /// Per phase: seconds spent and units done (steps for training; phases ended otherwise).
    spent: [f64; 5],
    done: [f64; 5],
    current: Option<(FitPhase, f64)>,
    /// Steps done at the last progress event (training's units).
    steps: usize,
}

impl TimeLeft {
    pub fn plan(&mut self, plan: FitPlan) {
        self.plan = plan;
    }

    /// A phase starts `at` seconds into the fit (the one before ends).
    pub fn phase(&mut self, phase: FitPhase, at: f64) {
        self.close(at);
        self.current = Some((phase, at));
    }

    /// `steps` training steps are done, `at` seconds into the fit.
    pub fn steps(&mut self, steps: usize, at: f64) {
        self.steps = steps;
        if let Some((FitPhase::Training, start)) = self.current {
            let t = FitPhase::Training.index();
            self.spent[t] += at - start;
            self.done[t] = steps as f64;
            self.current = Some((FitPhase::Training, at));
        }
    }

    /// The fit returned `at` seconds in.
    pub fn finish(&mut self, at: f64) {
        self.close(at);
    }

    fn close(&mut self, at: f64) {
        if let Some((phase, start)) = self.current.take() {
            self.spent[phase.index()] += at - start;
            if phase != FitPhase::Training {
                self.done[phase.index()] += 1.0;
            }
        }
    }

    /// Seconds spent in each phase so far (the current one up to its last event).
    pub fn spent(&self) -> impl Iterator<Item = (FitPhase, f64, usize)> + '_ {
        FitPhase::ALL.into_iter().map(|p| (p, self.spent[p.index()], self.done[p.index()] as usize))
    }

    /// The seconds left `at` seconds into the fit; `None` until a phase has ended or a
    /// step has run (nothing measured yet).
    pub fn left(&self, at: f64) -> Option<f64> {
        let units: f64 =
            FitPhase::ALL.iter().map(|p| self.done[p.index()] * p.steps_equivalent()).sum();
        let seconds: f64 = self.spent.iter().sum();
        if units <= 0.0 || seconds <= 0.0 {
            return None;
        }
        let pace = seconds / units;
        let mut left = 0.0;
        for p in FitPhase::ALL {
            let i = p.index();
            // The first steps pay for warming up (allocations, caches): training's own rate
            // counts from the fourth step on.
            let measured =
                if p == FitPhase::Training { self.done[i] >= 4.0 } else { self.done[i] > 0.0 };
            let each =
                if measured { self.spent[i] / self.done[i] } else { pace * p.steps_equivalent() };
            let remaining = (self.plan.count(p) as f64 - self.done[i]).max(0.0);
            left += remaining * each;
        }
        // The phase under way has run for a while already (its share is counted above).
        if let Some((p, start)) = self.current
            && p != FitPhase::Training
        {
            left -= (at - start).min(left);
        }
        Some(left.max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit that runs as planned, each phase at its assumed cost in steps of 0.1 s: the
    /// estimate after the first phase is the true time left, and it falls to zero at the end.
    #[test]
    fn a_steady_fit_is_estimated_from_its_first_phase() {
        let step = 0.1;
        let pre = FitPhase::PreAlignment.steps_equivalent() * step;
        let round = FitPhase::Refinement.steps_equivalent() * step;
        let plan = FitPlan { prealignment: 1, steps: 100, refinements: 2, ..FitPlan::default() };
        let mut t = TimeLeft::default();
        t.plan(plan);
        assert_eq!(t.left(0.0), None, "nothing measured yet");
        t.phase(FitPhase::PreAlignment, 0.0);
        t.phase(FitPhase::Training, pre);
        let left = t.left(pre).expect("a phase ended");
        assert!((left - (100.0 * step + 2.0 * round)).abs() < 1e-9, "{left}");
        // Training runs slower than assumed (0.2 s a step): measured steps take over.
        t.steps(50, pre + 10.0);
        t.phase(FitPhase::Refinement, pre + 10.0);
        t.phase(FitPhase::Training, pre + 10.0 + round);
        let left = t.left(pre + 10.0 + round).unwrap();
        assert!((left - (50.0 * 0.2 + round)).abs() < 1e-9, "{left}");
        let end = pre + 20.0 + round;
        t.steps(100, end);
        t.phase(FitPhase::Refinement, end);
        t.finish(end + round);
        assert_eq!(t.left(end + round), Some(0.0));
        let training = t.spent().find(|s| s.0 == FitPhase::Training).unwrap();
        assert!((training.1 - 20.0).abs() < 1e-9 && training.2 == 100);
    }

    /// A first step three times as slow as the rest (warming up) leaves the estimate where
    /// the pre-alignment's pace put it; from the fourth step on the steps' own rate counts.
    #[test]
    fn the_first_steps_warm_up_does_not_inflate_the_estimate() {
        let step = 0.1;
        let pre = FitPhase::PreAlignment.steps_equivalent() * step;
        let mut t = TimeLeft::default();
        t.plan(FitPlan { prealignment: 1, steps: 100, ..FitPlan::default() });
        t.phase(FitPhase::PreAlignment, 0.0);
        t.phase(FitPhase::Training, pre);
        t.steps(1, pre + 3.0 * step);
        let left = t.left(pre + 3.0 * step).unwrap();
        let truth = 99.0 * step;
        assert!((left - truth).abs() / truth < 0.05, "{left} against {truth}");
        t.steps(10, pre + 12.0 * step);
        let left = t.left(pre + 12.0 * step).unwrap();
        // 12 steps' time over 10 steps: the measured rate, slightly high, and no more.
        assert!((left - 90.0 * 0.12).abs() < 1e-9, "{left}");
    }

    /// A revised plan (loose cloth: twice the steps) moves the estimate at once.
    #[test]
    fn a_longer_plan_adds_its_steps() {
        let mut t = TimeLeft::default();
        t.plan(FitPlan { steps: 10, ..FitPlan::default() });
        t.phase(FitPhase::Training, 0.0);
        t.steps(10, 2.0);
        assert_eq!(t.left(2.0), Some(0.0));
        t.plan(FitPlan { steps: 20, loose_checks: 1, ..FitPlan::default() });
        t.phase(FitPhase::LooseCheck, 2.0);
        let left = t.left(2.0).unwrap();
        // 10 steps at 0.2 s and a loose check at the steps' pace.
        let check = FitPhase::LooseCheck.steps_equivalent() * 0.2;
        assert!((left - (2.0 + check)).abs() < 1e-9, "{left}");
    }
}
