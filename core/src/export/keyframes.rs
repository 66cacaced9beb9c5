//! Frames between keyframes: the reference vertices are projected onto the pose's surface (the
//! costly part of a frame: the avatar's SDF and its gradient at every vertex, Newton steps) only
//! at keyframes, every `ExportOptions::keyframe_spacing` frames; in between, each vertex's
//! projection is interpolated linearly in time, and only the vertices where that is not good
//! enough are projected:
//!
//! 1. **Check.** At the segment's middle frame the SDF is evaluated at the interpolated points
//!    (values only: a tenth of a projection's cost). A vertex whose interpolated point lies
//!    further than half the tolerance from the pose's zero level (or is not a number) is
//!    projected at every frame of the segment, as a frame without keyframes would be.
//! 2. **Verify.** Every `VERIFY_EVERY`-th segment's middle frame is also made in full (every
//!    vertex projected) and compared with its interpolated surface; a segment off by more than
//!    `ExportOptions::interpolation_tolerance` is made in full at every frame. The largest
//!    error found is reported ([`KeyStats::max_verified_error`]).
//!
//! Everything after the projection (the avatar's smoothing, the skinning) is done at every
//! frame. Which vertices are projected depends only on the segment's own frames, so a frame
//! comes out the same whichever pass asks for it, in whatever order. Segments are cached, at
//! most [`CACHED_SEGMENTS`], so memory stays flat in the clip's length.

use super::frame::FrameMaker;
use crate::error::Result;
use crate::motion::MotionClip;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

/// One segment in this many is verified against a full projection of its middle frame.
pub const VERIFY_EVERY: usize = 4;

/// Segments kept at once, the least recently used dropped (each: a keyframe's projection, the
/// next one shared with the next segment, and a list of vertices; about 160 KB at 13,000
/// vertices): an export's two passes over a clip of up to 1,024 frames project each keyframe
/// once.
pub const CACHED_SEGMENTS: usize = 128;

/// The frames from one keyframe to the next.
struct Segment {
    start: usize,
    end: usize,
    first: Arc<Vec<Vec3>>,
    last: Arc<Vec<Vec3>>,
    /// Vertices projected at every frame in between (the check's).
    projected: Vec<u32>,
    /// The verification failed: every frame is made in full.
    full: bool,
}

/// What the keyframes cost and how close they came.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KeyStats {
    /// Frames whose every vertex was projected (keyframes, verifications, failed segments).
    pub full_projections: usize,
    /// Vertex projections made at frames between keyframes.
    pub vertex_projections: usize,
    /// Segments verified against a full projection, and the largest vertex error (canonical
    /// surface, metres) found there.
    pub verified: usize,
    pub max_verified_error: f32,
    /// Segments made in full because the verification failed.
    pub failed: usize,
}

/// Frames of one clip made through keyframes (see the module).
pub struct Keyframes<'a> {
    maker: &'a FrameMaker<'a>,
    clip: &'a MotionClip,
    spacing: usize,
    tolerance: f32,
    /// Segment index -> (last use, segment).
    segments: Mutex<BTreeMap<usize, (u64, Arc<Segment>)>>,
    uses: std::sync::atomic::AtomicU64,
    stats: Mutex<KeyStats>,
}

impl<'a> Keyframes<'a> {
    /// `spacing` 1: every frame projected in full (no interpolation).
    pub fn new(
        maker: &'a FrameMaker<'a>,
        clip: &'a MotionClip,
        spacing: usize,
        tolerance: f32,
    ) -> Self {
        Keyframes {
            maker,
            clip,
            spacing: spacing.max(1),
            tolerance,
            segments: Mutex::new(BTreeMap::new()),
            uses: Default::default(),
            stats: Mutex::new(KeyStats::default()),
        }
    }

    pub fn stats(&self) -> KeyStats {
        *self.stats.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The delta and posed mesh (`FrameMaker::delta`) of each of `frames`.
    pub fn deltas(&self, frames: &[usize]) -> Result<Vec<(Vec<Vec3>, Vec<Vec3>)>> {
        self.each(frames, |f, points| self.maker.delta_of(&self.clip.frames[f], &points))
    }

    /// The canonical surface (smoothed, not skinned: `FrameMaker::surface`) of each of
    /// `frames`.
    pub fn surfaces(&self, frames: &[usize]) -> Result<Vec<Vec<Vec3>>> {
        self.each(frames, |_, points| points)
    }

    fn each<T: Send>(
        &self,
        frames: &[usize],
        then: impl Fn(usize, Vec<Vec3>) -> T + Sync,
    ) -> Result<Vec<T>> {
        let segments = self.segments_for(frames)?;
        frames
            .par_iter()
            .map(|&f| {
                let segment = segments.iter().find(|s| s.start <= f && f <= s.end).expect("made");
                Ok(then(f, self.surface(segment, f)?))
            })
            .collect()
    }

    /// The segments holding `frames`, made where not cached: first the keyframes they need
    /// (each once, those of cached neighbours taken from them), then their checks, in parallel.
    fn segments_for(&self, frames: &[usize]) -> Result<Vec<Arc<Segment>>> {
        let mut wanted: Vec<usize> = frames.iter().map(|&f| self.segment_of(f)).collect();
        wanted.sort_unstable();
        wanted.dedup();
        let mut keys: BTreeMap<usize, Option<Arc<Vec<Vec3>>>> = BTreeMap::new();
        let missing: Vec<usize> = {
            let cache = self.segments.lock().unwrap_or_else(|e| e.into_inner());
            for (_, segment) in cache.values() {
                keys.insert(segment.start, Some(segment.first.clone()));
                keys.insert(segment.end, Some(segment.last.clone()));
            }
            wanted.iter().copied().filter(|s| !cache.contains_key(s)).collect()
        };
        let ends = |s: usize| {
            (s * self.spacing, (s * self.spacing + self.spacing).min(self.clip.len() - 1))
        };
        let to_project: Vec<usize> = missing
            .iter()
            .flat_map(|&s| [ends(s).0, ends(s).1])
            .filter(|k| keys.get(k).is_none_or(|k| k.is_none()))
            .collect::<std::collections::BTreeSet<usize>>()
            .into_iter()
            .collect();
        let projected: Vec<Vec<Vec3>> =
            to_project.par_iter().map(|&k| self.raw(k)).collect::<Result<_>>()?;
        self.count(KeyStats { full_projections: to_project.len(), ..KeyStats::default() });
        for (k, p) in to_project.into_iter().zip(projected) {
            keys.insert(k, Some(Arc::new(p)));
        }
        let key = |k: usize| keys[&k].clone().expect("projected");
        let made: Vec<(usize, Segment)> = missing
            .par_iter()
            .map(|&s| {
                let (start, end) = ends(s);
                self.make_segment(s, start, end, key(start), key(end)).map(|m| (s, m))
            })
            .collect::<Result<_>>()?;
        let now = self.uses.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut cache = self.segments.lock().unwrap_or_else(|e| e.into_inner());
        for (s, m) in made {
            cache.insert(s, (now, Arc::new(m)));
        }
        let got = wanted
            .iter()
            .map(|s| {
                let entry = cache.get_mut(s).expect("made");
                entry.0 = now;
                entry.1.clone()
            })
            .collect();
        while cache.len() > CACHED_SEGMENTS.max(wanted.len()) {
            let oldest = cache.iter().min_by_key(|(_, (used, _))| *used).map(|(s, _)| *s);
            cache.remove(&oldest.expect("not empty"));
        }
        Ok(got)
    }

    fn count(&self, add: KeyStats) {
        let mut total = self.stats.lock().unwrap_or_else(|e| e.into_inner());
        total.full_projections += add.full_projections;
        total.vertex_projections += add.vertex_projections;
        total.verified += add.verified;
        total.max_verified_error = total.max_verified_error.max(add.max_verified_error);
        total.failed += add.failed;
    }

    /// The segment holding frame `f` (the last frame belongs to the last segment).
    fn segment_of(&self, f: usize) -> usize {
        let last = self.clip.len().saturating_sub(1);
        f.min(last.saturating_sub(1)) / self.spacing
    }

    /// A segment from its keyframes' projections: the check, and the verification of one in
    /// `VERIFY_EVERY`.
    fn make_segment(
        &self,
        s: usize,
        start: usize,
        end: usize,
        first: Arc<Vec<Vec3>>,
        last: Arc<Vec<Vec3>>,
    ) -> Result<Segment> {
        let mut segment = Segment { start, end, first, last, projected: Vec::new(), full: false };
        if end - start < 2 {
            return Ok(segment);
        }
        let mut stats = KeyStats::default();
        let mid = (start + end) / 2;
        let p = self.maker.params(&self.clip.frames[mid]);
        let values = self.maker.source.sdf(&p, &interpolate(&segment, mid))?;
        segment.projected = values
            .iter()
            .enumerate()
            .filter(|(_, v)| !(v.abs() <= 0.5 * self.tolerance))
            .map(|(i, _)| i as u32)
            .collect();
        if s % VERIFY_EVERY == 0 {
            let exact = self.maker.surface(&self.clip.frames[mid])?;
            let made = self.surface(&segment, mid)?;
            let error = exact.iter().zip(&made).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
            stats.full_projections += 1;
            stats.verified = 1;
            stats.max_verified_error = error;
            if !(error <= self.tolerance) {
                segment.full = true;
                stats.failed = 1;
            }
        }
        if segment.full {
            stats.full_projections += end - start - 1;
        } else {
            stats.vertex_projections += segment.projected.len() * (end - start - 1);
        }
        self.count(stats);
        Ok(segment)
    }

    /// The reference vertices projected onto frame `f`'s surface, not yet smoothed.
    fn raw(&self, f: usize) -> Result<Vec<Vec3>> {
        let p = self.maker.params(&self.clip.frames[f]);
        self.maker.source.project(&p, &self.maker.rest.positions, self.maker.steps())
    }

    /// Frame `f`'s canonical surface (smoothed), `f` in the segment.
    fn surface(&self, segment: &Segment, f: usize) -> Result<Vec<Vec3>> {
        let mut points = if f == segment.start {
            segment.first.to_vec()
        } else if f == segment.end {
            segment.last.to_vec()
        } else if segment.full {
            self.raw(f)?
        } else {
            let mut points = interpolate(segment, f);
            if !segment.projected.is_empty() {
                let rest = &self.maker.rest.positions;
                let some: Vec<Vec3> = segment.projected.iter().map(|&v| rest[v as usize]).collect();
                let p = self.maker.params(&self.clip.frames[f]);
                let moved = self.maker.source.project(&p, &some, self.maker.steps())?;
                for (&v, x) in segment.projected.iter().zip(moved) {
                    points[v as usize] = x;
                }
            }
            points
        };
        self.maker.finish(&mut points);
        Ok(points)
    }
}

/// The segment's keyframe projections interpolated linearly at frame `f` (a point that is not
/// a number at either end stays so: the check then projects it).
fn interpolate(segment: &Segment, f: usize) -> Vec<Vec3> {
    let t = (f - segment.start) as f32 / (segment.end - segment.start) as f32;
    segment.first.par_iter().zip(segment.last.par_iter()).map(|(a, b)| a.lerp(*b, t)).collect()
}
