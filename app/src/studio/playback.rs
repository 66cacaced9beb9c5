//! Playback at the clip's rate: a pose takes longer than a frame on two cores, so the clip's
//! poses (the timeline's range of them) are baked once in the background (with progress) and
//! played from memory, each frame as soon as it is baked (a long take plays its start while the
//! rest bakes). Bakes are cached per posable (avatar, body or partial result) and per clip with
//! its joint offsets, and serve any of their frames whatever range asked for them; at most
//! [`MAX_BAKED_FRAMES`] frames are held in all (a longer clip's later frames are posed live),
//! and a bake stopped by hand keeps the frames it made.

use crate::error::StudioError;
use crate::studio::posing::{Posable, PoseRequest, PosedMesh, pose};
use crate::studio::tasks::{Task, Wake};
use crate::studio::timeline::Timeline;
use avatar_core::body::{BodyModel, BodyParams};
use std::sync::Arc;

/// How many bakes are kept (the oldest is dropped first).
const CACHED: usize = 3;
/// The most frames baked for one clip and held by all bakes together: 1,200 frames (40 s at
/// 30 fps) of a 13,380-vertex avatar are about 480 MB. Frames past it are posed live.
pub const MAX_BAKED_FRAMES: usize = 1200;

/// The poses of the frames a bake of `timeline`'s play range holds (at most
/// [`MAX_BAKED_FRAMES`]), for the body shaped by `betas`.
pub fn range_params(timeline: &Timeline, betas: &[f32]) -> Vec<BodyParams> {
    let (a, b) = timeline.play_range();
    (a..=b).take(MAX_BAKED_FRAMES).map(|f| timeline.params_at(f, betas)).collect()
}

/// What a bake depends on: the canonical mesh posed (by identity), the clip and the joint
/// offsets (bit patterns, so that the key is exact), and the frames it bakes (the timeline's
/// range).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BakeKey {
    canonical: usize,
    clip: String,
    clip_frames: usize,
    offsets: Vec<u32>,
    /// The first frame baked and how many (at most [`MAX_BAKED_FRAMES`] are).
    first: usize,
    count: usize,
}

impl BakeKey {
    /// Frames `range.0` to `range.1` (inclusive) of a clip of `clip_frames` frames.
    pub fn new(
        posable: &Posable,
        clip_source: &str,
        clip_frames: usize,
        offsets: &[[f32; 3]],
        range: (usize, usize),
    ) -> BakeKey {
        BakeKey {
            canonical: Arc::as_ptr(posable.canonical()) as usize,
            clip: clip_source.to_string(),
            clip_frames,
            offsets: offsets.iter().flatten().map(|v| v.to_bits()).collect(),
            first: range.0,
            count: (range.1 + 1).saturating_sub(range.0).min(MAX_BAKED_FRAMES),
        }
    }

    /// The bake of `timeline`'s play range for `posable`.
    pub fn of_timeline(posable: &Posable, timeline: &Timeline) -> BakeKey {
        BakeKey::new(
            posable,
            &timeline.clip_source,
            timeline.frames(),
            &timeline.offsets,
            timeline.play_range(),
        )
    }

    /// The same mesh, clip and offsets (any frames).
    fn same_motion(&self, other: &BakeKey) -> bool {
        self.canonical == other.canonical
            && self.clip == other.clip
            && self.clip_frames == other.clip_frames
            && self.offsets == other.offsets
    }
}

/// Frames of a clip, posed: `frames[i]` is clip frame `first + i`.
pub struct Baked {
    pub key: BakeKey,
    pub first: usize,
    pub frames: Vec<Arc<PosedMesh>>,
    pub seconds: f64,
}

/// The running bake: its key, the frame it began with (an index into the key's frames), its
/// task (events: the index of a frame made and its mesh) and the frames made so far.
struct Running {
    key: BakeKey,
    from: usize,
    task: Task<Baked, (usize, Arc<PosedMesh>)>,
    made: Vec<Option<Arc<PosedMesh>>>,
    count: usize,
}

/// The bakes, the one running and its progress.
#[derive(Default)]
pub struct Bakes {
    done: Vec<Arc<Baked>>,
    running: Option<Running>,
    /// (frames baked, frames) of the running bake.
    pub progress: Option<(usize, usize)>,
    /// Bakes that failed (not retried).
    failed: Vec<BakeKey>,
    /// The bake stopped by hand (its frames are kept when it ends).
    stopped: Option<BakeKey>,
}

impl Bakes {
    pub fn get(&self, key: &BakeKey) -> Option<&Arc<Baked>> {
        self.done.iter().find(|b| &b.key == key)
    }

    pub fn baking(&self) -> bool {
        self.running.is_some()
    }

    /// The running bake, if it is of the motion of `key`.
    fn running_for(&self, key: &BakeKey) -> Option<&Running> {
        self.running.as_ref().filter(|r| r.key.same_motion(key))
    }

    /// Clip frame `frame` of the motion of `key`, from any bake of it (done, or already made
    /// by the running one) whose frames include it.
    pub fn frame(&self, key: &BakeKey, frame: usize) -> Option<Arc<PosedMesh>> {
        let mut done = self.done.iter().rev().filter(|b| b.key.same_motion(key));
        let found =
            done.find_map(|b| frame.checked_sub(b.first).and_then(|i| b.frames.get(i)).cloned());
        if found.is_some() {
            return found;
        }
        let r = self.running_for(key)?;
        frame.checked_sub(r.key.first).and_then(|i| r.made.get(i)).cloned().flatten()
    }

    /// The running bake of the motion of `key`: the clip frames it bakes (first, count) and the
    /// one it makes next (None once all are made).
    pub fn running_span(&self, key: &BakeKey) -> Option<((usize, usize), Option<usize>)> {
        let r = self.running_for(key)?;
        let n = r.made.len();
        let next = (0..n).map(|i| (r.from + i) % n).find(|&i| r.made[i].is_none());
        Some(((r.key.first, n), next.map(|i| r.key.first + i)))
    }

    /// The frames of the motion of `key` that are baked (first, count), for the timeline.
    pub fn baked_spans(&self, key: &BakeKey) -> Vec<(usize, usize)> {
        let mut spans: Vec<(usize, usize)> = self
            .done
            .iter()
            .filter(|b| b.key.same_motion(key))
            .map(|b| (b.first, b.frames.len()))
            .collect();
        if let Some(r) = self.running_for(key) {
            spans.extend(runs(&r.made).into_iter().map(|(i, n)| (r.key.first + i, n)));
        }
        spans.retain(|s| s.1 > 0);
        spans
    }

    /// Frames held by the finished bakes and the running one.
    pub fn held_frames(&self) -> usize {
        let running = self.running.as_ref().map_or(0, |r| r.count);
        self.done.iter().map(|b| b.frames.len()).sum::<usize>() + running
    }

    /// Start baking `params` (one per frame of the key's frames), beginning with clip frame
    /// `from` (the playhead; the key's first frame when it is outside) and going round, unless
    /// a bake of those frames exists or runs; a bake of another key still running is cancelled.
    pub fn start(
        &mut self,
        key: BakeKey,
        from: usize,
        posable: Posable,
        body: Arc<BodyModel>,
        params: Vec<BodyParams>,
        wake: Wake,
    ) {
        // A finished bake of the same motion holding all these frames serves them.
        let covered = self.done.iter().any(|b| {
            b.key.same_motion(&key)
                && b.first <= key.first
                && key.first + key.count <= b.first + b.frames.len()
        });
        if covered
            || self.get(&key).is_some()
            || self.failed.contains(&key)
            || self.running.as_ref().is_some_and(|r| r.key == key)
        {
            return;
        }
        self.cancel();
        self.running = None;
        let mut params = params;
        params.truncate(MAX_BAKED_FRAMES);
        // Room for the new bake: the oldest bakes go first.
        while !self.done.is_empty() && self.held_frames() + params.len() > MAX_BAKED_FRAMES {
            self.done.remove(0);
        }
        let n = params.len();
        let from = from.checked_sub(key.first).filter(|&i| i < n).unwrap_or(0);
        let k = key.clone();
        let task = Task::spawn("playback bake", wake, move |cx| {
            let t = std::time::Instant::now();
            let mut frames: Vec<Option<Arc<PosedMesh>>> = vec![None; n];
            let mut faces = None;
            for i in (from..n).chain(0..from) {
                if cx.cancelled() {
                    return Err(StudioError::invalid("cancelled"));
                }
                let request = PoseRequest {
                    id: 0,
                    params: params[i].clone(),
                    posable: posable.clone(),
                    body: body.clone(),
                };
                let mut m = pose(&request)?;
                // One copy of the triangles for the whole clip.
                m.faces = faces.get_or_insert_with(|| m.faces.clone()).clone();
                let m = Arc::new(m);
                frames[i] = Some(m.clone());
                cx.send((i, m));
            }
            let frames = frames.into_iter().flatten().collect();
            let first = k.first;
            Ok(Baked { key: k, first, frames, seconds: t.elapsed().as_secs_f64() })
        });
        self.progress = Some((0, n));
        self.running = Some(Running { key, from, task, made: vec![None; n], count: 0 });
    }

    /// Progress and the finished bake, if it just finished (errors are returned for the status
    /// bar; a cancelled bake is dropped quietly, a stopped one keeps its frames).
    pub fn poll(&mut self) -> Option<crate::error::Result<Arc<Baked>>> {
        let r = self.running.as_mut()?;
        let events = r.task.drain_events();
        // A cancelled bake's frames are dropped as they arrive; a stopped one keeps them.
        if !r.task.is_cancelling() || self.stopped.as_ref() == Some(&r.key) {
            for (i, m) in events {
                r.count += usize::from(r.made[i].is_none());
                r.made[i] = Some(m);
            }
        }
        if let Some((_, n)) = self.progress {
            self.progress = Some((r.count, n));
        }
        let result = r.task.poll()?;
        let cancelled = r.task.is_cancelling();
        let r = self.running.take().expect("polled above");
        self.progress = None;
        let stopped = self.stopped.take().is_some_and(|k| k == r.key);
        match result {
            Ok(b) => Some(Ok(self.keep(b))),
            Err(_) if stopped => {
                // The frames made, as the runs they form (the first named in the status).
                let mut kept = None;
                for (i, n) in runs(&r.made) {
                    let frames = r.made[i..i + n].iter().flatten().cloned().collect();
                    let b = Baked {
                        key: r.key.clone(),
                        first: r.key.first + i,
                        frames,
                        seconds: f64::NAN,
                    };
                    kept.get_or_insert(self.keep(b));
                }
                let none =
                    || Arc::new(Baked { key: r.key, first: 0, frames: vec![], seconds: f64::NAN });
                Some(Ok(kept.unwrap_or_else(none)))
            }
            Err(_) if cancelled => None,
            Err(e) => {
                self.failed.push(r.key);
                Some(Err(StudioError::from(e).context("baking the clip for playback")))
            }
        }
    }

    fn keep(&mut self, b: Baked) -> Arc<Baked> {
        let b = Arc::new(b);
        self.done.push(b.clone());
        while self.done.len() > CACHED
            || (self.done.len() > 1 && self.held_frames() > MAX_BAKED_FRAMES)
        {
            self.done.remove(0);
        }
        b
    }

    /// Cancel the running bake (another clip or avatar is shown): its frames are dropped.
    pub fn cancel(&mut self) {
        self.stopped = None; // a bake stopped by hand and not yet ended keeps nothing either
        if let Some(r) = &mut self.running {
            r.task.cancel();
            r.made.iter_mut().for_each(|m| *m = None);
            r.count = 0;
        }
        self.progress = None;
    }

    /// Cancel the running bake and drop every bake (the avatar they posed is closed).
    pub fn clear(&mut self) {
        self.cancel();
        self.done.clear();
        self.failed.clear();
    }

    /// Stop the running bake by hand: the frames baked so far are kept and played, the rest
    /// posed live, and the bake is not started again for this clip.
    pub fn stop(&mut self) {
        if let Some(r) = &self.running {
            self.stopped = Some(r.key.clone());
            r.task.cancel();
        }
    }
}

/// The runs of made frames: (first index, length).
fn runs(made: &[Option<Arc<PosedMesh>>]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for (i, m) in made.iter().enumerate() {
        match out.last_mut() {
            Some((s, n)) if m.is_some() && *s + *n == i => *n += 1,
            _ if m.is_some() => out.push((i, 1)),
            _ => {}
        }
    }
    out
}
