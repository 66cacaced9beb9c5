//! Fitting an avatar to a canonicalized capture: the one entry point ([`fit_avatar`]) that
//! `avatar-studio fit`, the studio's fit job and the evaluation's rows call. A fit runs in
//! chunks of steps (the optimisers' state carried over; each chunk draws its batches from
//! seed + steps done); after each chunk but the last the caller sees the partial avatar
//! ([`FitEvent::Partial`], the studio's live preview), and a cancel stops it at the next step
//! with a usable, partial avatar (`PartialFit` in its header).
//!
//! Training runs where the options say (`HyperFitOptions::compute`, `FitOptions::compute`).

mod chunks;
mod meta_recipe;

use crate::avatar::fit_plan::{FitPhase, FitPlan};
use crate::avatar::meta_avatar::Init;
use crate::avatar::static_avatar::StaticAvatar;
use crate::avatar::{AnyAvatar, PartialFit};
use crate::config::Check;
use crate::data::capture_points::CapturePoints;
use crate::error::Result;
use crate::model::model_file::MetaModel;
use crate::model::siren::{Siren, SirenConfig};
use crate::training::fit::{FitOptions, SdfOptimiser, fit_sdf_resuming};
use crate::training::hyper_fit::HyperFitOptions;
use crate::training::pose_trace::PoseTrace;
use burn::module::Module;
use chunks::{Chunk, in_chunks, partials};
use glam::Vec3;
use std::sync::atomic::AtomicBool;

pub(crate) use meta_recipe::fit_meta;

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

impl Check for AvatarFit<'_> {
    /// The options ([`HyperFitOptions`]'s checks, the static SDF's through
    /// [`HyperFitOptions::static_equivalent`]) and the networks' sizes.
    fn check(&self) -> Result<()> {
        self.options.check()?;
        match &self.kind {
            FitKind::Meta(Init::Scratch { config, .. }) => config.check(),
            FitKind::Meta(Init::MetaLearned(_)) => Ok(()),
            FitKind::Static { siren, .. } => {
                siren.check()?;
                self.options.static_equivalent().check()
            }
        }
    }
}

/// Fit an avatar to a canonicalized capture. Options out of range are refused first
/// ([`Check`]: an error naming the option and its bound).
pub fn fit_avatar(
    capture: &CapturePoints,
    fit: &AvatarFit,
    on_event: &mut dyn FnMut(FitEvent),
) -> Result<(AnyAvatar, FitReport)> {
    fit.check()?;
    Ok(match &fit.kind {
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
    })
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
