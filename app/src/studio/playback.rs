//! Playback at the clip's rate: a pose takes longer than a frame on two cores, so the clip's
//! poses are baked once in the background (with progress) and played from memory. Bakes are
//! cached per posable (avatar, body or partial result) and per clip with its joint offsets.

use crate::error::StudioError;
use crate::studio::posing::{Posable, PoseRequest, PosedMesh, pose};
use crate::studio::tasks::{Task, Wake};
use avatar_core::body::{BodyModel, BodyParams};
use std::sync::Arc;

/// How many bakes are kept (the oldest is dropped first).
const CACHED: usize = 3;

/// What a bake depends on: the canonical mesh posed (by identity), the clip and the joint
/// offsets (bit patterns, so that the key is exact).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BakeKey {
    canonical: usize,
    clip: String,
    frames: usize,
    offsets: Vec<u32>,
}

impl BakeKey {
    pub fn new(
        posable: &Posable,
        clip_source: &str,
        frames: usize,
        offsets: &[[f32; 3]],
    ) -> BakeKey {
        BakeKey {
            canonical: Arc::as_ptr(posable.canonical()) as usize,
            clip: clip_source.to_string(),
            frames,
            offsets: offsets.iter().flatten().map(|v| v.to_bits()).collect(),
        }
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
    running: Option<(BakeKey, Task<Baked, usize>)>,
    /// (frames baked, frames) of the running bake.
    pub progress: Option<(usize, usize)>,
    /// Bakes that failed (not retried).
    failed: Vec<BakeKey>,
}

impl Bakes {
    pub fn get(&self, key: &BakeKey) -> Option<&Arc<Baked>> {
        self.done.iter().find(|b| &b.key == key)
    }

    pub fn baking(&self) -> bool {
        self.running.is_some()
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
        if self.get(&key).is_some()
            || self.failed.contains(&key)
            || self.running.as_ref().is_some_and(|(k, _)| *k == key)
        {
            return;
        }
        let n = params.len();
        let k = key.clone();
        let task = Task::spawn("playback bake", wake, move |cx| {
            let t = std::time::Instant::now();
            let mut frames: Vec<Arc<PosedMesh>> = Vec::with_capacity(n);
            for (f, params) in params.into_iter().enumerate() {
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
                frames.push(Arc::new(m));
                cx.send(f + 1);
            }
            Ok(Baked { key: k, frames, seconds: t.elapsed().as_secs_f64() })
        });
        self.progress = Some((0, n));
        self.running = Some((key, task));
    }

    /// Progress and the finished bake, if it just finished (errors are returned for the status
    /// bar; a cancelled bake is dropped quietly).
    pub fn poll(&mut self) -> Option<crate::error::Result<Arc<Baked>>> {
        let (key, task) = self.running.as_ref()?;
        if let (Some(done), Some((_, n))) = (task.drain_events().last().copied(), self.progress) {
            self.progress = Some((done, n));
        }
        let r = task.poll()?;
        let cancelled = task.is_cancelling();
        let key = key.clone();
        self.running = None;
        self.progress = None;
        match r {
            Ok(b) => {
                let b = Arc::new(b);
                self.done.push(b.clone());
                if self.done.len() > CACHED {
                    self.done.remove(0);
                }
                Some(Ok(b))
            }
            Err(_) if cancelled => None,
            Err(e) => {
                self.failed.push(key);
                Some(Err(StudioError::from(e).context("baking the clip for playback")))
            }
        }
    }

    pub fn cancel(&mut self) {
        if let Some((_, t)) = &self.running {
            t.cancel();
        }
    }
}
