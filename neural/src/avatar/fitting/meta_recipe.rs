//! The pose-dependent avatar's fit as a sequence of named steps ([`fit_meta`]):
//!
//! 1. [`MetaFit::start`]: every frame one pose sample, the network forked from its start, the
//!    pose refiner and its rounds;
//! 2. [`MetaFit::prealign`]: the poses pre-aligned against the subject's own body, where the
//!    body explains most points;
//! 3. [`MetaFit::snap_to_truth`]: a diagnostic's joints set to the known true poses (off
//!    unless the caller's `PoseTrace` asks);
//! 4. [`MetaFit::train`]: the steps in chunks, with refinement rounds between them;
//! 5. [`MetaFit::extend_for_loose_cloth`]: more steps where the avatar has loose pieces;
//! 6. [`MetaFit::finish`]: the avatar of the steps that ran.

use super::chunks::{Chunk, cancelled, in_chunks, partials};
use super::{FitEvent, FitReport};
use crate::avatar::AnyAvatar;
use crate::avatar::fit_plan::{FitPhase, FitPlan};
use crate::avatar::meta_avatar::{Init, MetaAvatar, SCRATCH_ENCODER_RATE};
use crate::data::capture_points::CapturePoints;
use crate::data::pose_sample::PoseSample;
use crate::model::encoder::PoseEncoding;
use crate::model::hyper::HyperNet;
use crate::training::fit::SignPrior;
use crate::training::hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
use crate::training::pose_refine::{PoseRefiner, refine_round};
use crate::training::pose_trace::{PoseTrace, Snap};
use avatar_core::canonical::{BodyWrap, ShellOptions, SurfaceChoice};
use burn::module::Module;
use burn::tensor::Device;
use glam::Vec3;
use std::cell::OnceCell;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// Pre-alignment runs when at least this share of the points is near the body (midway between
/// the tight outfit's 86-100 % and the dress's 41-50 %, exact and perturbed fittings).
const PREALIGN_MIN_NEAR: f32 = 0.65;

/// The second round against the avatar's SDF runs only where the body explains nearly all
/// points (tight clothing 94-97 %): on the blazer (73 %) the sharper SDF's tails pulled the
/// legs (user table: Chamfer-L2 0.834 -> 0.904 cm, spurious 6.0 -> 7.0 %;
/// docs/decisions.md).
const SECOND_ROUND_MIN_NEAR: f32 = 0.85;

/// The hypernetwork's fine-tuning: every frame of the capture is one pose sample.
pub(crate) fn fit_meta(
    capture: &CapturePoints,
    init: &Init,
    options: &HyperFitOptions,
    chunk: usize,
    cancel: Option<&AtomicBool>,
    trace: Option<&PoseTrace>,
    on_event: &mut dyn FnMut(FitEvent),
) -> (MetaAvatar, FitReport) {
    let mut fit = MetaFit::start(capture, init, options, chunk, trace);
    on_event(FitEvent::Plan(fit.plan(fit.prealigns(), false)));
    fit.prealign(on_event);
    fit.snap_to_truth(trace);
    let prior = capture.sign_prior();
    let done = fit.train(&prior, cancel, on_event);
    let done = fit.extend_for_loose_cloth(done, &prior, cancel, on_event);
    fit.finish(done)
}

/// A pose-dependent avatar's fit in progress: the samples, the network and its optimisers, the
/// pose refiner, and the steps it will run.
struct MetaFit<'a> {
    capture: &'a CapturePoints,
    init: &'a Init<'a>,
    /// The caller's options, the from-scratch baseline's encoder rate set.
    options: HyperFitOptions,
    chunk: usize,
    encoding: PoseEncoding,
    samples: Vec<PoseSample>,
    device: Device,
    optimisers: HyperOptimisers,
    /// `None` only while a chunk trains it.
    model: Option<HyperNet>,
    refiner: Option<PoseRefiner<'a>>,
    /// The steps after which a refinement round runs.
    rounds: Vec<usize>,
    /// The diagnostic's joints set to the truth after every round.
    snap: Option<Snap>,
    /// The steps in all with loose cloth (`HyperFitOptions::loose_steps`).
    longer: usize,
    /// The steps in all: `options.steps`, `longer` once loose cloth is found.
    total: usize,
    /// The subject's body wrap, made once for every avatar of the fit (the loose check's,
    /// the partial ones, the last): it depends on the body and its shape alone.
    wrap: OnceCell<Arc<BodyWrap>>,
}

impl<'a> MetaFit<'a> {
    /// Step 1: the samples, the network, the refiner and its rounds.
    fn start(
        capture: &'a CapturePoints,
        init: &'a Init<'a>,
        options: &HyperFitOptions,
        chunk: usize,
        trace: Option<&PoseTrace>,
    ) -> Self {
        let encoding = init.config().encoding;
        let samples = capture.pose_samples(encoding);
        let device = options.compute.training_device();
        let model = Some(init.network().fork(&device));
        // A frozen encoder keeps meta-learned pose features; a random one must learn (the
        // from-scratch baseline trains it at the reference's 1e-4).
        let options = match init {
            Init::Scratch { .. } if options.lr_encoder == 0.0 => {
                HyperFitOptions { lr_encoder: SCRATCH_ENCODER_RATE, ..options.clone() }
            }
            _ => options.clone(),
        };
        // Pose refinement (PINA 3.2) runs between chunks, after the steps `rounds` names. Its
        // early rounds need the meta-learned SDF as their target: a random one (the
        // from-scratch baseline) would only move the poses away.
        let refine_options = options.refine_poses;
        let meta_learned = matches!(init, Init::MetaLearned(_));
        let rounds =
            if meta_learned { refine_options.round_steps(options.steps) } else { Vec::new() };
        let mut refiner = (meta_learned && refine_options.enabled)
            .then(|| PoseRefiner::new(capture, refine_options));
        // The fit reads no round's residual after its steps: not measured.
        if let Some(r) = refiner.as_mut() {
            r.measure_after = false;
        }
        if let (Some(r), Some(t)) = (refiner.as_mut(), trace) {
            r.trace_against(t);
        }
        // A loose outfit's longer fit is expected where pre-alignment finds the body explains
        // few points (the dress's 41-50 %), and is checked after the steps.
        let longer = if meta_learned { options.loose_steps() } else { options.steps };
        let total = options.steps;
        MetaFit {
            capture,
            init,
            options,
            chunk,
            encoding,
            samples,
            device,
            optimisers: HyperOptimisers::default(),
            model,
            refiner,
            rounds,
            snap: None,
            longer,
            total,
            wrap: OnceCell::new(),
        }
    }

    /// What the fit will do: pre-alignment or not, the refinement rounds, and the loose cloth's
    /// longer fit when `loose`.
    fn plan(&self, prealignment: bool, loose: bool) -> FitPlan {
        let steps = self.options.steps;
        FitPlan {
            prealignment: prealignment as usize,
            steps: if loose { self.longer } else { steps },
            refinements: self.rounds.len(),
            loose_checks: (self.longer > steps) as usize,
            partials: partials(0, steps, self.chunk)
                + if loose { partials(steps, self.longer, self.chunk) } else { 0 },
        }
    }

    fn prealigns(&self) -> bool {
        self.refiner.as_ref().is_some_and(|r| r.options.prealign_rounds > 0)
    }

    /// Step 2: pre-alignment against the subject's own body, before the SDF learns the
    /// misalignment. Only where the body explains most points (tight clothing): on a dress it
    /// pulled the legs toward the skirt (exact fittings: Chamfer 2.17 -> 2.55 cm,
    /// docs/decisions.md); there the upper body alone, and rounds of the loose schedule
    /// (`PoseRefineOptions::without_prealignment`).
    fn prealign(&mut self, on_event: &mut dyn FnMut(FitEvent)) {
        let Some(r) = self.refiner.as_mut().filter(|r| r.options.prealign_rounds > 0) else {
            return;
        };
        on_event(FitEvent::Phase(FitPhase::PreAlignment));
        let body = crate::data::body_sdf::BodySdf::new(self.capture);
        let band = r.options.prealign_cutoff;
        let sdf = |k: usize, p: &[Vec3]| body.beyond_clothing_of(k, p, band);
        let share = r.near_share(&sdf);
        let aligned = if share >= PREALIGN_MIN_NEAR {
            r.prealign(&sdf);
            if share < SECOND_ROUND_MIN_NEAR {
                r.options = r.options.single_round();
            }
            Some("on")
        } else {
            let upper = r
                .options
                .prealign_upper_body
                .then(|| r.prealign_upper_body(&sdf))
                .map(|_| "upper body only");
            r.options =
                r.options.without_prealignment(self.samples.len(), self.options.poses_per_step);
            upper
        };
        self.rounds = r.options.round_steps(self.options.steps);
        if aligned.is_some() {
            r.redraw_shells(&ShellOptions::default());
            r.update_samples(&mut self.samples, self.encoding);
        }
        on_event(FitEvent::Plan(self.plan(true, share < PREALIGN_MIN_NEAR)));
        if let Some(r) = self.refiner.as_ref() {
            r.trace(|| {
                format!(
                    "{:.0} % of the points near the body: pre-alignment {}",
                    share * 100.0,
                    aligned.unwrap_or("off")
                )
            });
        }
    }

    /// Step 3 (a diagnostic): the joints the caller's trace names set to the truth; without
    /// the truth (`PoseTrace`) the fit is left as it is.
    fn snap_to_truth(&mut self, trace: Option<&PoseTrace>) {
        self.snap = trace
            .and_then(|t| t.snap.clone())
            .filter(|_| self.refiner.as_ref().is_some_and(|r| r.truth.is_some()));
        if let (Some(r), Some(snap)) = (self.refiner.as_mut(), self.snap.as_ref()) {
            r.snap_to_truth(&snap.joints, snap.translation);
            r.redraw_shells(&ShellOptions::default());
            r.update_samples(&mut self.samples, self.encoding);
        }
    }

    /// Step 4: `options.steps` steps in chunks, a refinement round after each step `rounds`
    /// names; returns the steps done (fewer when cancelled).
    fn train(
        &mut self,
        prior: SignPrior,
        cancel: Option<&AtomicBool>,
        on_event: &mut dyn FnMut(FitEvent),
    ) -> usize {
        let (steps, chunk, rounds) = (self.options.steps, self.chunk, self.rounds.clone());
        in_chunks(0, steps, chunk, &rounds, cancel, prior, on_event, &mut |c| {
            self.chunk_step(c, cancel)
        })
    }

    /// Step 5: loose cloth is still being reconstructed where the body-hugging kinds have
    /// converged: an avatar with loose pieces by then goes on
    /// (`HyperFitOptions::loose_step_factor`). Not from scratch: a barely trained random SDF's
    /// blobs are no cloth, and the baseline keeps the budget it is compared at.
    fn extend_for_loose_cloth(
        &mut self,
        done: usize,
        prior: SignPrior,
        cancel: Option<&AtomicBool>,
        on_event: &mut dyn FnMut(FitEvent),
    ) -> usize {
        if done != self.options.steps || self.longer <= done || cancelled(cancel) {
            return done;
        }
        on_event(FitEvent::Phase(FitPhase::LooseCheck));
        let has_loose = matches!(
            self.chunk_step(Chunk::Partial(done), cancel),
            Some(AnyAvatar::Meta(a)) if a.surface_kind() == SurfaceChoice::WrappedWithLoose
        );
        on_event(FitEvent::Plan(self.plan(self.prealigns(), has_loose)));
        if !has_loose {
            return done;
        }
        self.total = self.longer;
        let (longer, chunk) = (self.longer, self.chunk);
        in_chunks(done, longer, chunk, &[], cancel, prior, on_event, &mut |c| {
            self.chunk_step(c, cancel)
        })
    }

    /// Step 6: the avatar after `done` steps (the refined poses traced when asked).
    fn finish(self, done: usize) -> (MetaAvatar, FitReport) {
        if let Some(r) = self.refiner.as_ref() {
            r.trace_errors("refined");
        }
        let model = self.model.as_ref().expect("the fit returns its network");
        (
            MetaAvatar::from_fitted(
                self.capture,
                self.init,
                done,
                self.total,
                model,
                self.refiner.as_ref(),
                self.body_wrap(),
            ),
            FitReport::of(self.capture),
        )
    }

    /// What the chunk loop asks: train a chunk, refine the poses at a break, or the partial
    /// avatar.
    fn chunk_step(&mut self, c: Chunk, cancel: Option<&AtomicBool>) -> Option<AnyAvatar> {
        match c {
            Chunk::Run { steps, done, prior, progress } => {
                let chunk_options = HyperFitOptions {
                    steps,
                    seed: self.options.seed.wrapping_add(done as u64),
                    ..self.options.clone()
                };
                self.model = self.model.take().map(|m| {
                    fit_hyper(
                        m,
                        &self.samples,
                        &chunk_options,
                        &mut self.optimisers,
                        &self.device,
                        Some(prior),
                        cancel,
                        progress,
                    )
                });
                None
            }
            Chunk::Break => {
                self.refine_poses();
                None
            }
            Chunk::Partial(done) => self.model.as_ref().map(|m| {
                AnyAvatar::Meta(MetaAvatar::from_fitted(
                    self.capture,
                    self.init,
                    done,
                    self.total,
                    m,
                    self.refiner.as_ref(),
                    self.body_wrap(),
                ))
            }),
        }
    }

    /// The subject's body wrap, made at the first avatar.
    fn body_wrap(&self) -> Arc<BodyWrap> {
        self.wrap.get_or_init(|| MetaAvatar::body_wrap_of(self.capture)).clone()
    }

    /// A refinement round against the avatar's SDF (then the diagnostic's snap).
    fn refine_poses(&mut self) {
        if let (Some(r), Some(m)) = (self.refiner.as_mut(), self.model.as_ref()) {
            refine_round(r, m, &mut self.samples, self.encoding);
            if let Some(snap) = self.snap.as_ref() {
                r.snap_to_truth(&snap.joints, snap.translation);
                r.update_samples(&mut self.samples, self.encoding);
            }
        }
    }
}
