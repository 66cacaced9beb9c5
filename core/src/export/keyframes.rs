//! Frames between keyframes: the reference vertices are projected onto the pose's surface (the
//! costly part of a frame: the avatar's SDF and its gradient at every vertex, Newton steps) in
//! full only at keyframes, every `ExportOptions::keyframe_spacing` frames, and at the middle
//! frame between two; elsewhere each vertex's projection is interpolated linearly in time, and
//! only the vertices where that is not good enough are projected:
//!
//! 1. **Check.** The middle frame's projection is compared, vertex by vertex, with the
//!    keyframes' interpolated there. A vertex off by more than half the tolerance (or not a
//!    number) is projected at every frame of the segment, as it would be without keyframes;
//!    the others are interpolated from the keyframe to the middle frame and on to the next
//!    keyframe (the middle frame being a keyframe too).
//! 2. **Verify.** In one segment in `VERIFY_EVERY`, the frame halfway from its first keyframe to
//!    its middle frame is also made in full and compared with the interpolated one (after the
//!    avatar's smoothing); a segment off by more than `ExportOptions::interpolation_tolerance`
//!    is made in full at every frame. The largest error found is reported
//!    ([`KeyStats::max_verified_error`]).
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

/// One segment in this many is verified against a full projection of one of its frames.
pub const VERIFY_EVERY: usize = 4;

/// Segments kept at once, the least recently used dropped (each: two projections, its first
/// keyframe's and its middle frame's, the last shared with the next segment, and a list of
/// vertices: about 320 KB at 13,000 vertices): an export's two passes over a clip of up to
/// 128 segments (1,024 frames at the default spacing) project each keyframe once.
pub const CACHED_SEGMENTS: usize = 128;

/// The frames from one keyframe to the next.
struct Segment {
    start: usize,
    end: usize,
    first: Arc<Vec<Vec3>>,
    last: Arc<Vec<Vec3>>,
    /// The middle frame's projection (none in a segment of two frames).
    middle: Option<Vec<Vec3>>,
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

    /// A segment from its keyframes' projections: its middle frame and the check, and the
    /// verification of one in `VERIFY_EVERY`.
    fn make_segment(
        &self,
        s: usize,
        start: usize,
        end: usize,
        first: Arc<Vec<Vec3>>,
        last: Arc<Vec<Vec3>>,
    ) -> Result<Segment> {
        let mut segment =
            Segment { start, end, first, last, middle: None, projected: Vec::new(), full: false };
        if end - start < 2 {
            return Ok(segment);
        }
        let mut stats = KeyStats { full_projections: 1, ..KeyStats::default() };
        let mid = (start + end) / 2;
        let middle = self.raw(mid)?;
        let t = (mid - start) as f32 / (end - start) as f32;
        segment.projected = (segment.first.par_iter().zip(segment.last.par_iter()))
            .zip(&middle)
            .enumerate()
            .filter(|(_, ((a, b), m))| !(a.lerp(**b, t).distance(**m) <= 0.5 * self.tolerance))
            .map(|(i, _)| i as u32)
            .collect();
        segment.middle = Some(middle);
        let quarter = (start + mid) / 2;
        if s.is_multiple_of(VERIFY_EVERY) && quarter != start {
            let exact = self.maker.surface(&self.clip.frames[quarter])?;
            let made = self.surface(&segment, quarter)?;
            let error = exact.iter().zip(&made).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
            stats.full_projections += 1;
            stats.verified = 1;
            stats.max_verified_error = error;
            if !(error <= self.tolerance) {
                segment.full = true;
                stats.failed = 1;
            }
        }
        let between = end - start - 2;
        if segment.full {
            stats.full_projections += between;
        } else {
            stats.vertex_projections += segment.projected.len() * between;
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
        let mid = (segment.start + segment.end) / 2;
        let mut points = match &segment.middle {
            _ if f == segment.start => segment.first.to_vec(),
            _ if f == segment.end => segment.last.to_vec(),
            Some(middle) if f == mid => middle.clone(),
            Some(_) if segment.full => self.raw(f)?,
            Some(middle) => {
                let mut points = if f < mid {
                    interpolate(
                        &segment.first,
                        middle,
                        (f - segment.start) as f32 / (mid - segment.start) as f32,
                    )
                } else {
                    interpolate(
                        middle,
                        &segment.last,
                        (f - mid) as f32 / (segment.end - mid) as f32,
                    )
                };
                if !segment.projected.is_empty() {
                    let rest = &self.maker.rest.positions;
                    let some: Vec<Vec3> =
                        segment.projected.iter().map(|&v| rest[v as usize]).collect();
                    let p = self.maker.params(&self.clip.frames[f]);
                    let moved = self.maker.source.project(&p, &some, self.maker.steps())?;
                    for (&v, x) in segment.projected.iter().zip(moved) {
                        points[v as usize] = x;
                    }
                }
                points
            }
            None => unreachable!("a segment of two frames has none in between"),
        };
        self.maker.finish(&mut points);
        Ok(points)
    }
}

/// `a` and `b` (projections of the same vertices) interpolated linearly at `t`.
fn interpolate(a: &[Vec3], b: &[Vec3], t: f32) -> Vec<Vec3> {
    a.par_iter().zip(b.par_iter()).map(|(a, b)| a.lerp(*b, t)).collect()
}
