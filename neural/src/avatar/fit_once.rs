//! One-chunk fits of either kind with a progress callback: [`MetaAvatar::fit_capture`] and
//! each kind's `fit_points` (tests, examples, benches and the evaluation), over
//! [`super::fitting`]'s fits.

use crate::avatar::fitting::FitReport;
use crate::avatar::fitting::{FitEvent, fit_meta, fit_static};
use crate::avatar::meta_avatar::{Init, MetaAvatar};
use crate::avatar::static_avatar::StaticAvatar;
use crate::data::capture_points::CapturePoints;
use crate::error::Result;
use crate::model::siren::{Siren, SirenConfig};
use crate::training::fit::{FitOptions, Progress};
use crate::training::hyper_fit::HyperFitOptions;
use avatar_core::canonical::FieldCache;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// A progress callback as a fit's event callback (partial avatars dropped).
pub(crate) fn progress_only(
    progress: crate::training::fit::Progress<'_>,
) -> impl FnMut(FitEvent) + '_ {
    move |e| {
        if let FitEvent::Progress { step, loss, terms, .. } = e {
            progress(step, loss, terms)
        }
    }
}

/// One-chunk fits of either kind with a progress callback (tests, examples and benches).
impl MetaAvatar {
    /// Fine-tune on `frames` usable frames of a capture (chosen over all of it).
    pub fn fit_capture(
        dir: &Path,
        frames: usize,
        field_cache: &FieldCache,
        init: &Init,
        options: &HyperFitOptions,
        cancel: Option<&AtomicBool>,
        progress: Progress,
    ) -> Result<(MetaAvatar, FitReport)> {
        let capture = CapturePoints::open(dir, frames, field_cache)?;
        Ok(Self::fit_points(&capture, init, options, cancel, progress))
    }

    /// Fine-tune on a canonicalized capture: every frame is one pose sample (one chunk of
    /// [`crate::avatar::fitting::fit_avatar`]).
    pub fn fit_points(
        capture: &CapturePoints,
        init: &Init,
        options: &HyperFitOptions,
        cancel: Option<&AtomicBool>,
        progress: Progress,
    ) -> (MetaAvatar, FitReport) {
        fit_meta(capture, init, options, 0, cancel, None, &mut progress_only(progress))
    }
}

impl StaticAvatar {
    /// Fit to a canonicalized capture (all its frames pooled: the SDF ignores the pose), from
    /// SIREN's random initialisation (`init` None) or from given weights (the static
    /// meta-SDF), with these options (one chunk of `fit_static`; the avatars of `fit_avatar` take theirs
    /// from `HyperFitOptions::static_equivalent`).
    pub fn fit_points(
        capture: &CapturePoints,
        siren: SirenConfig,
        init: Option<Siren>,
        options: &FitOptions,
        cancel: Option<&AtomicBool>,
        progress: Progress,
    ) -> (StaticAvatar, FitReport) {
        fit_static(capture, siren, init, options, 0, cancel, &mut progress_only(progress))
    }
}
