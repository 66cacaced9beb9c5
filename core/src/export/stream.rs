//! Frames made one bounded chunk at a time, so that memory does not grow with the clip:
//!
//! Frames are made through keyframes (`export::keyframes`: the projection interpolated between
//! keyframes, checked); then
//! 1. the deltas of a bounded sample of frames, spread evenly over the clip
//!    (`ExportOptions::sample_frames`; every frame when the clip is shorter: exact PCA), give
//!    the morph targets' basis ([`Basis::fit`]);
//! 2. every frame is then made again in order (the sampled ones are kept, not remade), projected
//!    onto the basis (its coefficients are all that is kept of it) and its reconstruction error
//!    measured; the worst frames' deltas are kept, at most `refine_frames`;
//! 3. if a frame outside the sample is rebuilt worse than the compression's share of the error
//!    bound (`ExportOptions::compression_bound`), the worst frames join
//!    the sample, the basis is fitted again and every frame projected again (one more pass).
//!
//! At most `sample_frames + refine_frames` deltas and one chunk of frames in the making are
//! held at once ([`Streamed::peak_frames_held`] counts them).

pub use super::frame::FrameMaker;
use super::keyframes::{KeyStats, Keyframes};
use super::morph::Basis;
use super::options::ExportOptions;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::motion::MotionClip;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

/// Frames made at once (in parallel) in a pass.
pub const CHUNK: usize = 8;

/// Where an export is: frames made so far of all the frames it will make.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    pub done: usize,
    pub total: usize,
}

/// How a caller follows and stops an export: progress after every chunk, a cancel flag
/// checked between chunks (the export then stops with an error saying [`CANCELLED`]).
#[derive(Default, Clone, Copy)]
pub struct Control<'a> {
    pub progress: Option<&'a (dyn Fn(Progress) + Sync)>,
    pub cancel: Option<&'a AtomicBool>,
}

impl Control<'_> {
    pub fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// The message of a cancelled export.
pub const CANCELLED: &str = "the export was cancelled";

/// `count` frame indices spread evenly over `n` frames (all of them when `n <= count`).
pub fn even_sample(n: usize, count: usize) -> Vec<usize> {
    if n <= count {
        return (0..n).collect();
    }
    if count <= 1 {
        return vec![0];
    }
    let mut out: Vec<usize> = (0..count)
        .map(|i| ((i as f64 * (n - 1) as f64 / (count - 1) as f64).round() as usize).min(n - 1))
        .collect();
    out.dedup();
    out
}

/// What the passes give: per frame its basis coefficients, the basis, the errors.
pub struct Streamed {
    pub basis: Basis,
    pub coefficients: Vec<Vec<f64>>,
    /// Largest vertex error of any frame rebuilt from the basis (metres).
    pub max_error: f32,
    /// Mean vertex error over all frames (metres).
    pub mean_error: f32,
    /// Largest error among the frames outside the basis's sample.
    pub max_error_unsampled: f32,
    /// Frames the basis was fitted on (the sample, plus the refinement's).
    pub basis_frames: usize,
    /// Frames added to the sample by the refinement pass (0: none was needed).
    pub refined_frames: usize,
    /// The most frame deltas (or posed meshes) held at any time.
    pub peak_frames_held: usize,
    /// The posed mesh of every frame, when asked for (`keep_posed`): grows with the clip.
    pub posed: Vec<Vec<Vec3>>,
    /// What the keyframes cost and how close the verified frames came (`export::keyframes`).
    pub keys: KeyStats,
}

struct Held {
    delta: Vec<Vec3>,
    posed: Option<Vec<Vec3>>,
}

/// Run the passes of the module's scheme over `clip`.
pub fn stream_frames(
    maker: &FrameMaker,
    clip: &MotionClip,
    options: &ExportOptions,
    control: Control,
    keep_posed: bool,
) -> Result<Streamed> {
    let n = clip.len();
    let sample = even_sample(n, options.sample_frames.max(2));
    let mut total = n;
    let progress = |done: usize, total: usize| {
        if let Some(p) = control.progress {
            p(Progress { done, total });
        }
    };
    let keys =
        Keyframes::new(maker, clip, options.keyframe_spacing, options.interpolation_tolerance);
    let mut held: HashMap<usize, Held> = HashMap::with_capacity(sample.len());
    let mut peak = 0usize;
    let mut done = 0usize;
    // Pass 1: the sample.
    for chunk in sample.chunks(CHUNK) {
        if control.cancelled() {
            return Err(Error::invalid(CANCELLED));
        }
        let made = keys.deltas(chunk)?;
        peak = peak.max(held.len() + made.len());
        for (&f, (delta, posed)) in chunk.iter().zip(made) {
            held.insert(f, Held { delta, posed: keep_posed.then_some(posed) });
        }
        done += chunk.len();
        progress(done, total);
    }
    let components = options.max_targets.max(1) - 1;
    let fit = |held: &HashMap<usize, Held>| {
        let mut keys: Vec<&usize> = held.keys().collect();
        keys.sort();
        let deltas: Vec<&[Vec3]> = keys.iter().map(|k| held[k].delta.as_slice()).collect();
        Basis::fit(&deltas, components, options.min_target_effect)
    };
    let mut basis = fit(&held);
    let mut posed_all = Vec::new();
    let mut refined = 0;
    let mut previous: Option<(Basis, Pass)> = None;
    loop {
        let collect = keep_posed && refined == 0;
        let pass =
            project_all(&keys, n, &basis, &held, options, control, (&mut done, total), collect)?;
        peak = peak.max(held.len() + pass.peak_extra);
        if collect {
            posed_all = pass.posed;
        }
        let over: Vec<(f32, usize, Vec<Vec3>)> =
            pass.worst.into_iter().filter(|w| w.0 > options.compression_bound()).collect();
        // The refined basis is kept only where it rebuilds the worst frame better.
        if let Some((old_basis, old)) =
            previous.take().filter(|(_, o)| o.max_error < pass.max_error)
        {
            return Ok(Streamed {
                basis_frames: held.len() - refined,
                basis: old_basis,
                coefficients: old.coefficients,
                max_error: old.max_error,
                mean_error: old.mean_error,
                max_error_unsampled: old.max_unsampled,
                refined_frames: 0,
                peak_frames_held: peak,
                posed: posed_all,
                keys: keys.stats(),
            });
        }
        if refined > 0 || over.is_empty() || options.refine_frames == 0 {
            return Ok(Streamed {
                basis_frames: held.len(),
                basis,
                coefficients: pass.coefficients,
                max_error: pass.max_error,
                mean_error: pass.mean_error,
                max_error_unsampled: pass.max_unsampled,
                refined_frames: refined,
                peak_frames_held: peak,
                posed: posed_all,
                keys: keys.stats(),
            });
        }
        // Pass 3: the worst frames join the sample; every frame is projected again.
        refined = over.len();
        for (_, f, delta) in over {
            held.insert(f, Held { delta, posed: None });
        }
        let kept = Pass { worst: Vec::new(), posed: Vec::new(), ..pass };
        previous = Some((std::mem::replace(&mut basis, fit(&held)), kept));
        total += n - held.len();
        progress(done, total);
    }
}

struct Pass {
    coefficients: Vec<Vec<f64>>,
    max_error: f32,
    mean_error: f32,
    max_unsampled: f32,
    /// The worst frames outside the held ones: (error, frame, delta), at most `refine_frames`.
    worst: Vec<(f32, usize, Vec<Vec3>)>,
    peak_extra: usize,
    posed: Vec<Vec<Vec3>>,
}

/// Every frame in order: its delta (held or made), its coefficients and error.
#[allow(clippy::too_many_arguments)]
fn project_all(
    keys: &Keyframes,
    n: usize,
    basis: &Basis,
    held: &HashMap<usize, Held>,
    options: &ExportOptions,
    control: Control,
    (done, total): (&mut usize, usize),
    collect_posed: bool,
) -> Result<Pass> {
    let mut pass = Pass {
        coefficients: Vec::with_capacity(n),
        max_error: 0.0,
        mean_error: 0.0,
        max_unsampled: 0.0,
        worst: Vec::new(),
        peak_extra: 0,
        posed: Vec::new(),
    };
    let mut error_sum = 0f64;
    let frames: Vec<usize> = (0..n).collect();
    for chunk in frames.chunks(CHUNK) {
        if control.cancelled() {
            return Err(Error::invalid(CANCELLED));
        }
        let fresh: Vec<usize> = chunk.iter().copied().filter(|f| !held.contains_key(f)).collect();
        let mut fresh_made = keys.deltas(&fresh)?.into_iter();
        let made: Vec<Option<(Vec<Vec3>, Vec<Vec3>)>> = chunk
            .iter()
            .map(|f| if held.contains_key(f) { None } else { fresh_made.next() })
            .collect();
        let fresh = made.iter().filter(|m| m.is_some()).count();
        pass.peak_extra = pass.peak_extra.max(fresh + pass.worst.len());
        let scored: Vec<(Vec<f64>, (f32, f32))> = chunk
            .par_iter()
            .zip(&made)
            .map(|(f, m)| {
                let delta = m.as_ref().map_or_else(|| held[f].delta.as_slice(), |m| &m.0);
                let c = basis.coefficients(delta);
                let e = basis.error(delta, &c);
                (c, e)
            })
            .collect();
        for ((&f, m), (c, (max, mean))) in chunk.iter().zip(made).zip(scored) {
            pass.coefficients.push(c);
            pass.max_error = pass.max_error.max(max);
            error_sum += mean as f64;
            if let Some((delta, posed)) = m {
                pass.max_unsampled = pass.max_unsampled.max(max);
                if options.refine_frames > 0 && max > options.compression_bound() {
                    keep_worst(&mut pass.worst, (max, f, delta), options.refine_frames);
                }
                if collect_posed {
                    pass.posed.push(posed);
                }
            } else if collect_posed {
                let h = &held[&f];
                pass.posed.push(h.posed.clone().unwrap_or_default());
            }
        }
        *done += fresh;
        if let Some(p) = control.progress.filter(|_| fresh > 0) {
            p(Progress { done: *done, total });
        }
    }
    pass.mean_error = (error_sum / n.max(1) as f64) as f32;
    Ok(pass)
}

/// Keep the `cap` largest errors.
fn keep_worst(worst: &mut Vec<(f32, usize, Vec<Vec3>)>, item: (f32, usize, Vec<Vec3>), cap: usize) {
    if worst.len() < cap {
        worst.push(item);
        return;
    }
    let (i, least) = worst
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.0.total_cmp(&b.1.0))
        .map(|(i, w)| (i, w.0))
        .expect("cap > 0");
    if item.0 > least {
        worst[i] = item;
    }
}

/// The posed mesh of every frame, one chunk at a time, handed to `sink` in order (OBJ/PLY
/// sequences, `pose`): nothing is kept. The projection onto each pose's surface is made at
/// keyframes and interpolated between them as the exporter's is (`options.keyframe_spacing`,
/// within `options.interpolation_tolerance`: `export::keyframes`); spacing 1 projects every
/// frame in full.
pub fn for_each_posed(
    maker: &FrameMaker,
    clip: &MotionClip,
    options: &ExportOptions,
    control: Control,
    mut sink: impl FnMut(usize, TriMesh) -> Result<()>,
) -> Result<()> {
    let keys =
        Keyframes::new(maker, clip, options.keyframe_spacing, options.interpolation_tolerance);
    let frames: Vec<usize> = (0..clip.len()).collect();
    for chunk in frames.chunks(CHUNK) {
        if control.cancelled() {
            return Err(Error::invalid(CANCELLED));
        }
        let surfaces = keys.surfaces(chunk)?;
        let made: Vec<Vec<Vec3>> = chunk
            .iter()
            .zip(surfaces)
            .map(|(&f, surface)| maker.skin(&clip.frames[f], &surface).0)
            .collect();
        for (&f, positions) in chunk.iter().zip(made) {
            sink(f, TriMesh::new(positions, maker.rest.faces.clone()))?;
        }
        if let Some(p) = control.progress {
            p(Progress { done: chunk[chunk.len() - 1] + 1, total: clip.len() });
        }
    }
    Ok(())
}
