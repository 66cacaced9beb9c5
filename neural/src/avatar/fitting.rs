//! Fitting an avatar to a canonicalized capture: the one entry point ([`fit_avatar`]) that
//! `avatar-studio fit`, the studio's fit job and the evaluation's rows call. A fit runs in
//! chunks of steps (the optimisers' state carried over; each chunk draws its batches from
//! seed + steps done); after each chunk but the last the caller sees the partial avatar
//! ([`FitEvent::Partial`], the studio's live preview), and a cancel stops it at the next step
//! with a usable, partial avatar (`PartialFit` in its header).
//!
//! Training runs where the options say (`HyperFitOptions::compute`, `FitOptions::compute`).

use crate::avatar::fit_plan::{FitPhase, FitPlan};
use crate::avatar::meta_avatar::{Init, MetaAvatar, SCRATCH_ENCODER_RATE};
use crate::avatar::static_avatar::StaticAvatar;
use crate::avatar::{AnyAvatar, PartialFit};
use crate::capture_points::CapturePoints;
use crate::fit::{FitOptions, Progress, SdfOptimiser, SignPrior, fit_sdf_resuming};
use crate::hyper_fit::{HyperFitOptions, HyperOptimisers, fit_hyper};
use crate::model_file::MetaModel;
use crate::pose_refine::{PoseRefiner, refine_round};
use crate::pose_trace::PoseTrace;
use crate::siren::{Siren, SirenConfig};
use avatar_core::canonical::{ShellOptions, SurfaceChoice};
use burn::module::Module;
use glam::Vec3;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Which avatar a fit makes, and where its networks start.
pub enum FitKind<'a> {
    /// The pose-dependent hypernetwork avatar (MetaAvatar or the from-scratch baseline).
    Meta(Init<'a>),
    /// A static (pose-independent) SIREN SDF over all frames pooled: from `init`'s static SDF
    /// (the meta-model's, recorded in the avatar as its prior) or, with `None`, from SIREN's
    /// random initialisation.
    Static { siren: SirenConfig, init: Option<&'a MetaModel> },
}

/// A fit's configuration.
pub struct AvatarFit<'a> {
    pub kind: FitKind<'a>,
    /// Steps, seed, points a step, rates and loss. The static SDF uses
    /// [`HyperFitOptions::static_equivalent`] of them: the same budget pooled over the poses
    /// (the one static-SDF recipe).
    pub options: HyperFitOptions,
    /// Steps per chunk, with a [`FitEvent::Partial`] after each chunk but the last (0: one
    /// chunk, no partial avatars).
    pub chunk: usize,
    /// Set to stop at the next step; the avatar of the steps that ran is returned.
    pub cancel: Option<&'a AtomicBool>,
    /// Diagnostic: the true poses to trace pose refinement against (`None`: no trace).
    pub trace: Option<&'a PoseTrace>,
}

/// What fitting reports.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    pub frames: usize,
    pub points: usize,
    pub dropped: usize,
    pub warnings: Vec<String>,
}

impl FitReport {
    fn of(capture: &CapturePoints) -> FitReport {
        FitReport {
            frames: capture.frames.len(),
            points: capture.num_points(),
            dropped: capture.dropped,
            warnings: capture.warnings.clone(),
        }
    }
}

/// What a fit tells its caller while it runs.
// Sent about 50 times a fit; a partial avatar moves once per chunk, unboxed as `fit_avatar` returns it.
#[allow(clippy::large_enum_variant)]
pub enum FitEvent {
    /// A logged step (about 50 a fit, and the last): its index from 0, the loss and its four
    /// IGR terms (surface, normal, off-surface, eikonal).
    Progress { step: usize, steps: usize, loss: f32, terms: [f32; 4] },
    /// The avatar after `done` steps, at the end of a chunk (the caller may block here: the
    /// fit waits).
    Partial { done: usize, avatar: AnyAvatar },
    /// What the whole fit will do (first, then revised as the fit decides).
    Plan(FitPlan),
    /// A phase starts (the one before ends).
    Phase(FitPhase),
}

/// Fit an avatar to a canonicalized capture.
pub fn fit_avatar(
    capture: &CapturePoints,
    fit: &AvatarFit,
    on_event: &mut dyn FnMut(FitEvent),
) -> (AnyAvatar, FitReport) {
    match &fit.kind {
        FitKind::Meta(init) => {
            let (avatar, report) =
                fit_meta(capture, init, &fit.options, fit.chunk, fit.cancel, fit.trace, on_event);
            (AnyAvatar::Meta(avatar), report)
        }
        FitKind::Static { siren, init } => {
            let (mut avatar, report) = fit_static(
                capture,
                *siren,
                init.map(MetaModel::static_siren),
                &fit.options.static_equivalent(),
                fit.chunk,
                fit.cancel,
                on_event,
            );
            avatar.header.prior = init.and_then(|m| m.prior());
            (AnyAvatar::Static(avatar), report)
        }
    }
}

fn cancelled(cancel: Option<&AtomicBool>) -> bool {
    cancel.is_some_and(|c| c.load(Ordering::Relaxed))
}

/// Steps per chunk: all of them for 0.
fn chunk_len(chunk: usize, steps: usize) -> usize {
    if chunk == 0 { steps.max(1) } else { chunk.clamp(1, steps.max(1)) }
}

/// What the chunk loop asks of a kind's fit: run `steps` more steps (after `done`) with the
/// counting prior and the progress callback, act at a break (pose refinement), or make the partial avatar after `done` steps.
enum Chunk<'a> {
    Run { steps: usize, done: usize, prior: SignPrior<'a>, progress: Progress<'a> },
    Break,
    Partial(usize),
}

/// The chunk loop both kinds share, from step `from` to `steps`; returns the steps done.
/// Chunks also end at the steps `breaks` names (without a partial avatar). The fit calls the sign prior once a step: its
/// calls are the steps that ran when a cancel stops it early (neural/tests/partial_fit.rs
/// checks the count).
#[allow(clippy::too_many_arguments)]
fn in_chunks(
    from: usize,
    steps: usize,
    chunk: usize,
    breaks: &[usize],
    cancel: Option<&AtomicBool>,
    prior: SignPrior,
    on_event: &mut dyn FnMut(FitEvent),
    fit: &mut dyn FnMut(Chunk) -> Option<AnyAvatar>,
) -> usize {
    let every = chunk_len(chunk, steps);
    let steps_run = AtomicUsize::new(from);
    let counted = |p: &[Vec3]| {
        steps_run.fetch_add(1, Ordering::Relaxed);
        prior(p)
    };
    let mut done = from;
    while done < steps && !cancelled(cancel) {
        let next_look = (done / every + 1) * every;
        let next_break = breaks.iter().copied().find(|&s| s > done).unwrap_or(usize::MAX);
        let base = done;
        on_event(FitEvent::Phase(FitPhase::Training));
        let n = next_look.min(next_break).min(steps) - base;
        let mut progress = |step: usize, loss: f32, terms: [f32; 4]| {
            on_event(FitEvent::Progress { step: base + step, steps, loss, terms })
        };
        fit(Chunk::Run { steps: n, done: base, prior: &counted, progress: &mut progress });
        done = steps_run.load(Ordering::Relaxed).min(base + n);
        if done < base + n {
            break;
        }
        if breaks.contains(&done) {
            on_event(FitEvent::Phase(FitPhase::Refinement));
            fit(Chunk::Break);
        }
        if chunk > 0 && done < steps && done.is_multiple_of(every) {
            on_event(FitEvent::Phase(FitPhase::Partial));
            if let Some(avatar) = fit(Chunk::Partial(done)) {
                on_event(FitEvent::Partial { done, avatar });
            }
        }
    }
    done
}

/// The partial avatars [`in_chunks`] makes from step `from` to `to`.
fn partials(from: usize, to: usize, chunk: usize) -> usize {
    if chunk == 0 || to <= from {
        return 0;
    }
    let every = chunk_len(chunk, to);
    (to - 1) / every - from / every
}

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
    let encoding = init.config().encoding;
    let mut samples = capture.pose_samples(encoding);
    let device = options.compute.training_device();
    let mut optimisers = HyperOptimisers::default();
    let mut model = Some(init.network().fork(&device));
    // A frozen encoder keeps meta-learned pose features; a random one must learn (the
    // from-scratch baseline trains it at the reference's 1e-4).
    let options = &match init {
        Init::Scratch { .. } if options.lr_encoder == 0.0 => {
            HyperFitOptions { lr_encoder: SCRATCH_ENCODER_RATE, ..options.clone() }
        }
        _ => options.clone(),
    };
    // Pose refinement (PINA 3.2) runs between chunks, after the steps `rounds` names. Its
    // early rounds need the meta-learned SDF as their target: a random one (the from-scratch
    // baseline) would only move the poses away.
    let refine_options = options.refine_poses;
    let mut rounds = match init {
        Init::MetaLearned(_) => refine_options.round_steps(options.steps),
        Init::Scratch { .. } => Vec::new(),
    };
    let refine = matches!(init, Init::MetaLearned(_)) && refine_options.enabled;
    let mut refiner = refine.then(|| PoseRefiner::new(capture, refine_options));
    // The fit reads no round's residual after its steps: not measured.
    if let Some(r) = refiner.as_mut() {
        r.measure_after = false;
    }
    if let (Some(r), Some(t)) = (refiner.as_mut(), trace) {
        r.trace_against(t);
    }
    // The plan: a loose outfit's longer fit is expected where pre-alignment finds the body
    // explains few points (the dress's 41-50 %), and is checked after the steps.
    let longer =
        if matches!(init, Init::MetaLearned(_)) { options.loose_steps() } else { options.steps };
    let plan = |prealignment: bool, rounds: usize, loose: bool| {
        let steps = if loose { longer } else { options.steps };
        FitPlan {
            prealignment: prealignment as usize,
            steps,
            refinements: rounds,
            loose_checks: (longer > options.steps) as usize,
            partials: partials(0, options.steps, chunk)
                + if loose { partials(options.steps, longer, chunk) } else { 0 },
        }
    };
    let prealigns = refiner.as_ref().is_some_and(|r| r.options.prealign_rounds > 0);
    on_event(FitEvent::Plan(plan(prealigns, rounds.len(), false)));
    // Pre-alignment against the subject's own body, before the SDF learns the misalignment.
    if let Some(r) = refiner.as_mut().filter(|r| r.options.prealign_rounds > 0) {
        on_event(FitEvent::Phase(FitPhase::PreAlignment));
        let body = crate::body_sdf::BodySdf::new(capture);
        let band = r.options.prealign_cutoff;
        let sdf = |_: usize, p: &[Vec3]| body.beyond_clothing(p, band);
        // Only where the body explains most points (tight clothing): on a dress it pulled the
        // legs toward the skirt (exact fittings: Chamfer 2.17 -> 2.55 cm, docs/decisions.md).
        let share = r.near_share(&sdf);
        let aligned = if share >= PREALIGN_MIN_NEAR {
            r.prealign(&sdf);
            if share < SECOND_ROUND_MIN_NEAR {
                r.options = r.options.single_round();
            }
            Some("on")
        } else {
            // Elsewhere rounds after step 1 and every 3 steps to 64, after the upper body alone.
            let upper = r
                .options
                .prealign_upper_body
                .then(|| r.prealign_upper_body(&sdf))
                .map(|_| "upper body only");
            r.options = r.options.without_prealignment();
            upper
        };
        rounds = r.options.round_steps(options.steps);
        if aligned.is_some() {
            r.redraw_shells(&ShellOptions::default());
            r.update_samples(&mut samples, encoding);
        }
        on_event(FitEvent::Plan(plan(true, rounds.len(), share < PREALIGN_MIN_NEAR)));
        r.trace(|| {
            format!(
                "{:.0} % of the points near the body: pre-alignment {}",
                share * 100.0,
                aligned.unwrap_or("off")
            )
        });
    }
    // The diagnostic needs the truth (`PoseTrace`); without it the fit is left as it is.
    let snap = trace
        .and_then(|t| t.snap.clone())
        .filter(|_| refiner.as_ref().is_some_and(|r| r.truth.is_some()));
    if let (Some(r), Some(snap)) = (refiner.as_mut(), snap.as_ref()) {
        r.snap_to_truth(&snap.joints, snap.translation);
        r.redraw_shells(&ShellOptions::default());
        r.update_samples(&mut samples, encoding);
    }
    // The steps in all: `options.steps`, more for loose cloth (below).
    let total = std::cell::Cell::new(options.steps);
    let prior = capture.sign_prior();
    let mut run = |c: Chunk| match c {
        Chunk::Run { steps, done, prior, progress } => {
            let chunk_options = HyperFitOptions {
                steps,
                seed: options.seed.wrapping_add(done as u64),
                ..options.clone()
            };
            model = model.take().map(|m| {
                fit_hyper(
                    m,
                    &samples,
                    &chunk_options,
                    &mut optimisers,
                    &device,
                    Some(prior),
                    cancel,
                    progress,
                )
            });
            None
        }
        Chunk::Break => {
            if let (Some(r), Some(m)) = (refiner.as_mut(), model.as_ref()) {
                refine_round(r, m, &mut samples, encoding);
                if let Some(snap) = snap.as_ref() {
                    r.snap_to_truth(&snap.joints, snap.translation);
                    r.update_samples(&mut samples, encoding);
                }
            }
            None
        }
        Chunk::Partial(done) => model.as_ref().map(|m| {
            AnyAvatar::Meta(MetaAvatar::from_fitted(
                capture,
                init,
                done,
                total.get(),
                m,
                refiner.as_ref(),
            ))
        }),
    };
    let mut done = in_chunks(0, options.steps, chunk, &rounds, cancel, &prior, on_event, &mut run);
    // Loose cloth is still being reconstructed where the body-hugging kinds have converged:
    // an avatar with loose pieces by then goes on (`HyperFitOptions::loose_step_factor`). Not
    // from scratch: a barely trained random SDF's blobs are no cloth, and the baseline keeps
    // the budget it is compared at.
    if done == options.steps && longer > done && !cancelled(cancel) {
        on_event(FitEvent::Phase(FitPhase::LooseCheck));
        let has_loose = matches!(run(Chunk::Partial(done)), Some(AnyAvatar::Meta(a)) if a.surface_kind() == SurfaceChoice::WrappedWithLoose);
        on_event(FitEvent::Plan(plan(prealigns, rounds.len(), has_loose)));
        if has_loose {
            total.set(longer);
            done = in_chunks(done, longer, chunk, &[], cancel, &prior, on_event, &mut run);
        }
    }
    if let Some(r) = refiner.as_ref() {
        r.trace_errors("refined");
    }
    (
        MetaAvatar::from_fitted(
            capture,
            init,
            done,
            total.get(),
            &model.expect("the fit returns its network"),
            refiner.as_ref(),
        ),
        FitReport::of(capture),
    )
}

/// The static SDF's fit: all frames pooled (the SDF ignores the pose), the capture's sign prior.
pub(crate) fn fit_static(
    capture: &CapturePoints,
    siren: SirenConfig,
    init: Option<Siren>,
    options: &FitOptions,
    chunk: usize,
    cancel: Option<&AtomicBool>,
    on_event: &mut dyn FnMut(FitEvent),
) -> (StaticAvatar, FitReport) {
    let points: Vec<Vec3> = capture.frames.iter().flat_map(|f| f.points.iter().copied()).collect();
    let normals: Vec<Vec3> =
        capture.frames.iter().flat_map(|f| f.normals.iter().copied()).collect();
    let outside: Vec<Vec3> = capture.frames.iter().flat_map(|f| f.outside()).collect();
    let device = options.compute.training_device();
    let mut model = Some(init.unwrap_or_else(|| siren.init(options.seed, &device)).fork(&device));
    let mut optimiser = SdfOptimiser::default();
    on_event(FitEvent::Plan(FitPlan {
        steps: options.steps,
        partials: partials(0, options.steps, chunk),
        ..FitPlan::default()
    }));
    let done = in_chunks(
        0,
        options.steps,
        chunk,
        &[],
        cancel,
        &capture.sign_prior(),
        on_event,
        &mut |c| match c {
            Chunk::Run { steps, done, prior, progress } => {
                let chunk_options = FitOptions {
                    steps,
                    seed: options.seed.wrapping_add(done as u64),
                    ..options.clone()
                };
                model = model.take().map(|m| {
                    fit_sdf_resuming(
                        m,
                        &points,
                        &normals,
                        &outside,
                        &chunk_options,
                        &mut optimiser,
                        &device,
                        Some(prior),
                        cancel,
                        progress,
                    )
                });
                None
            }
            Chunk::Break => None,
            Chunk::Partial(done) => model
                .as_ref()
                .map(|m| AnyAvatar::Static(static_avatar(capture, siren, m, done, options.steps))),
        },
    );
    (
        static_avatar(
            capture,
            siren,
            &model.expect("the fit returns its network"),
            done,
            options.steps,
        ),
        FitReport::of(capture),
    )
}

fn static_avatar(
    capture: &CapturePoints,
    siren: SirenConfig,
    model: &Siren,
    done: usize,
    requested: usize,
) -> StaticAvatar {
    let mut avatar = StaticAvatar::from_fitted(capture, siren, model);
    avatar.header.partial = PartialFit::of(done, requested);
    avatar
}

#[cfg(test)]
mod tests;
