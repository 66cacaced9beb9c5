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
use avatar_core::body::{BodyModel, BodyParams};
use std::sync::Arc;

/// How many bakes are kept (the oldest is dropped first).
const CACHED: usize = 3;
/// The most frames baked for one clip and held by all bakes together: 1,200 frames (40 s at
/// 30 fps) of a 13,380-vertex avatar are about 480 MB. Frames past it are posed live.
pub const MAX_BAKED_FRAMES: usize = 1200;

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

    /// The same mesh, clip and offsets (any frames).
    fn same_motion(&self, other: &BakeKey) -> bool {
        self.canonical == other.canonical
            && self.clip == other.clip
            && self.clip_frames == other.clip_frames
            && self.offsets == other.offsets
    }

    /// The first frame baked.
    pub fn first(&self) -> usize {
        self.first
    }
}

/// Every frame of a clip, posed.
pub struct Baked {
    pub key: BakeKey,
    pub frames: Vec<Arc<PosedMesh>>,
    pub seconds: f64,
}

/// The bakes, the one running and its progress.
#[derive(Default)]
pub struct Bakes {
    done: Vec<Arc<Baked>>,
    running: Option<(BakeKey, Task<Baked, Arc<PosedMesh>>)>,
    /// The running bake's frames so far (played while it runs).
    partial: Vec<Arc<PosedMesh>>,
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

    /// Clip frame `frame` of the motion of `key`, from any bake of it (done, or already made
    /// by the running one) whose frames include it.
    pub fn frame(&self, key: &BakeKey, frame: usize) -> Option<Arc<PosedMesh>> {
        let at = |k: &BakeKey, frames: &[Arc<PosedMesh>]| {
            frame.checked_sub(k.first).and_then(|i| frames.get(i)).cloned()
        };
        let done = self.done.iter().rev().filter(|b| b.key.same_motion(key));
        if let Some(m) = done.filter_map(|b| at(&b.key, &b.frames)).next() {
            return Some(m);
        }
        match &self.running {
            Some((k, _)) if k.same_motion(key) => at(k, &self.partial),
            _ => None,
        }
    }

    /// The frames of the motion of `key` that are baked (first, count), for the timeline.
    pub fn baked_spans(&self, key: &BakeKey) -> Vec<(usize, usize)> {
        let mut spans: Vec<(usize, usize)> = self
            .done
            .iter()
            .filter(|b| b.key.same_motion(key))
            .map(|b| (b.key.first, b.frames.len()))
            .collect();
        if let Some((k, _)) = self.running.as_ref().filter(|(k, _)| k.same_motion(key)) {
            spans.push((k.first, self.partial.len()));
        }
        spans.retain(|s| s.1 > 0);
        spans
    }

    /// Frames held by the finished bakes and the running one.
    pub fn held_frames(&self) -> usize {
        self.done.iter().map(|b| b.frames.len()).sum::<usize>() + self.partial.len()
    }

    /// Start baking `params` (one per frame) unless that bake exists or runs; a bake of another
    /// key still running is cancelled.
    pub fn start(
        &mut self,
        key: BakeKey,
        posable: Posable,
        body: Arc<BodyModel>,
        params: Vec<BodyParams>,
        wake: Wake,
    ) {
        // A finished bake of the same motion holding all these frames serves them.
        let covered = self.done.iter().any(|b| {
            b.key.same_motion(&key)
                && b.key.first <= key.first
                && key.first + key.count <= b.key.first + b.frames.len()
        });
        if covered
            || self.get(&key).is_some()
            || self.failed.contains(&key)
            || self.running.as_ref().is_some_and(|(k, _)| *k == key)
        {
            return;
        }
        self.cancel();
        self.running = None;
        self.partial.clear();
        let mut params = params;
        params.truncate(MAX_BAKED_FRAMES);
        // Room for the new bake: the oldest bakes go first.
        while !self.done.is_empty() && self.held_frames() + params.len() > MAX_BAKED_FRAMES {
            self.done.remove(0);
        }
        let n = params.len();
        let k = key.clone();
        let task = Task::spawn("playback bake", wake, move |cx| {
            let t = std::time::Instant::now();
            let mut frames: Vec<Arc<PosedMesh>> = Vec::with_capacity(n);
            for params in params {
                if cx.cancelled() {
                    return Err(StudioError::invalid("cancelled"));
                }
                let mut m = pose(&PoseRequest {
                    id: 0,
                    params,
                    posable: posable.clone(),
                    body: body.clone(),
                })?;
                if let Some(first) = frames.first() {
                    m.faces = first.faces.clone(); // one copy of the triangles for the whole clip
                }
                let m = Arc::new(m);
                frames.push(m.clone());
                cx.send(m);
            }
            Ok(Baked { key: k, frames, seconds: t.elapsed().as_secs_f64() })
        });
        self.progress = Some((0, n));
        self.running = Some((key, task));
    }

    /// Progress and the finished bake, if it just finished (errors are returned for the status
    /// bar; a cancelled bake is dropped quietly, a stopped one keeps its frames).
    pub fn poll(&mut self) -> Option<crate::error::Result<Arc<Baked>>> {
        let (key, task) = self.running.as_ref()?;
        let events = task.drain_events();
        // A cancelled bake's frames are dropped as they arrive; a stopped one keeps them.
        if !task.is_cancelling() || self.stopped.as_ref() == Some(key) {
            self.partial.extend(events);
        }
        if let Some((_, n)) = self.progress {
            self.progress = Some((self.partial.len(), n));
        }
        let r = task.poll()?;
        let cancelled = task.is_cancelling();
        let key = key.clone();
        self.running = None;
        self.progress = None;
        let partial = std::mem::take(&mut self.partial);
        let stopped = self.stopped.take().is_some_and(|k| k == key);
        match r {
            Ok(b) => Some(Ok(self.keep(b))),
            Err(_) if stopped => {
                Some(Ok(self.keep(Baked { key, frames: partial, seconds: f64::NAN })))
            }
            Err(_) if cancelled => None,
            Err(e) => {
                self.failed.push(key);
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
        if let Some((_, t)) = &self.running {
            t.cancel();
        }
        self.partial.clear();
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
        if let Some((k, t)) = &self.running {
            self.stopped = Some(k.clone());
            t.cancel();
        }
    }
}
