//! The chunk loop both kinds of fit share: steps in chunks, a partial avatar after each chunk
//! but the last, breaks for pose refinement, and the cancel checked between them.

use super::FitEvent;
use crate::avatar::AnyAvatar;
use crate::avatar::fit_plan::FitPhase;
use crate::training::fit::{Progress, SignPrior};
use glam::Vec3;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

pub(super) fn cancelled(cancel: Option<&AtomicBool>) -> bool {
    cancel.is_some_and(|c| c.load(Ordering::Relaxed))
}

/// Steps per chunk: all of them for 0.
pub(super) fn chunk_len(chunk: usize, steps: usize) -> usize {
    if chunk == 0 { steps.max(1) } else { chunk.clamp(1, steps.max(1)) }
}

/// What the chunk loop asks of a kind's fit: run `steps` more steps (after `done`) with the
/// counting prior and the progress callback, act at a break (pose refinement), or make the partial avatar after `done` steps.
pub(super) enum Chunk<'a> {
    Run { steps: usize, done: usize, prior: SignPrior<'a>, progress: Progress<'a> },
    Break,
    Partial(usize),
}

/// The chunk loop both kinds share, from step `from` to `steps`; returns the steps done.
/// Chunks also end at the steps `breaks` names (without a partial avatar). The fit calls the sign prior once a step: its
/// calls are the steps that ran when a cancel stops it early (neural/tests/partial_fit.rs
/// checks the count).
#[allow(clippy::too_many_arguments)]
pub(super) fn in_chunks(
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
pub(super) fn partials(from: usize, to: usize, chunk: usize) -> usize {
    if chunk == 0 || to <= from {
        return 0;
    }
    let every = chunk_len(chunk, to);
    (to - 1) / every - from / every
}
