//! A capture's frames as the studio holds them: read on demand, with a bound on what is held.
//! The frame shown in the viewport has its points read (the last [`MAX_POINT_FRAMES`] selected
//! stay), the thumbnails on screen are read (at most [`MAX_THUMBNAILS`] stay) and each frame
//! read is checked (its verdict, a number or a reason, is all that is kept of a frame no longer
//! shown). The reading runs on one thread of its own, dropped with the store (another capture,
//! or none), which stops it after the batch under way.

use avatar_core::body::BodyParams;
use avatar_core::capture::{CaptureSource, read_depth_png};
use crossbeam_channel::{Receiver, Sender};
use eframe::egui;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::{HashMap, HashSet, VecDeque};
use std::path::PathBuf;
use std::sync::Arc;

/// Frames whose points are held at most (the one shown and those shown just before).
pub const MAX_POINT_FRAMES: usize = 8;
/// Thumbnails held at most (a screenful is about 40); the least recently shown go first.
pub const MAX_THUMBNAILS: usize = 256;
/// Thumbnails' longer side, pixels.
pub const THUMBNAIL_SIZE: usize = 72;
/// Requests read together (in parallel).
const BATCH: usize = 16;

/// One frame of the manifest: what the manifest says of it.
pub struct FrameView {
    pub index: usize,
    pub file: PathBuf,
    /// The body fitting (None when the manifest's record cannot be read).
    pub params: Option<BodyParams>,
}

/// A usable frame's person: world-space points and their unit normals (facing the camera).
pub struct FramePoints {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
}

impl FramePoints {
    pub fn bytes(&self) -> usize {
        (self.points.len() + self.normals.len()) * std::mem::size_of::<Vec3>()
    }
}

/// What reading a frame gave.
pub struct FrameRead {
    pub index: usize,
    /// The number of points of the person, or why the frame is not used.
    pub verdict: Result<usize, String>,
    /// Its points, when they were asked for.
    pub points: Option<Arc<FramePoints>>,
    /// Its depth as a thumbnail, when it was asked for (`Some(None)`: the image cannot be read).
    pub thumbnail: Option<Option<egui::ColorImage>>,
}

/// Read `indices` (in parallel): each one checked, with its points when `points` and its
/// thumbnail when `thumbnails`.
pub fn read_frames(
    source: &CaptureSource,
    indices: &[usize],
    points: bool,
    thumbnails: bool,
) -> avatar_core::Result<Vec<FrameRead>> {
    let loaded = source.load(indices)?;
    let scale = source.manifest.depth_scale;
    Ok(loaded
        .into_par_iter()
        .zip(indices.par_iter())
        .map(|(r, &index)| {
            let thumbnail = thumbnails.then(|| {
                let file = source.dir.join(&source.manifest.frames[index].depth);
                read_depth_png(&file, scale)
                    .ok()
                    .map(|d| depth_thumbnail(&d.metres, d.width as usize, d.height as usize))
            });
            match r {
                Ok(f) => FrameRead {
                    index,
                    verdict: Ok(f.points.len()),
                    points: points
                        .then(|| Arc::new(FramePoints { points: f.points, normals: f.normals })),
                    thumbnail,
                },
                Err(e) => FrameRead { index, verdict: Err(e.reason), points: None, thumbnail },
            }
        })
        .collect())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Want {
    Points(usize),
    Thumbnail(usize),
}

/// A batch read by the reading thread.
type Reads = avatar_core::Result<Vec<FrameRead>>;

/// A thumbnail held: egui's texture and its pixels (for `viewport::flat`).
pub type Thumbnail = (egui::TextureHandle, Arc<egui::ColorImage>);

/// The frames of the open capture (empty when none is open).
#[derive(Default)]
pub struct FrameStore {
    name: String,
    verdicts: Vec<Option<Result<usize, String>>>,
    /// Most recently shown last.
    points: VecDeque<(usize, Arc<FramePoints>)>,
    thumbnails: HashMap<usize, (Thumbnail, u64)>,
    tick: u64,
    pending: HashSet<Want>,
    /// Frames whose depth image could not be read for a thumbnail (not asked again).
    no_image: HashSet<usize>,
    reader: Option<(Sender<Want>, Receiver<Reads>)>,
    /// A read that failed as a whole (the capture's files went away): said once.
    pub failed: Option<String>,
}

impl FrameStore {
    /// The store of a capture of `frames` frames just opened, with the frames read when it was
    /// (`first`), and its reading thread; `wake` is called after each batch read.
    pub fn new(
        ctx: &egui::Context,
        name: &str,
        frames: usize,
        source: Arc<CaptureSource>,
        first: Vec<FrameRead>,
        wake: crate::studio::tasks::Wake,
    ) -> FrameStore {
        let (want_tx, want_rx) = crossbeam_channel::unbounded::<Want>();
        let (read_tx, read_rx) = crossbeam_channel::unbounded();
        let spawned = std::thread::Builder::new().name("capture frames".into()).spawn(move || {
            // Ends when the store (the sender) is dropped.
            while let Ok(first) = want_rx.recv() {
                let mut batch = vec![first];
                batch.extend(want_rx.try_iter().take(BATCH - 1));
                let mut pts: Vec<usize> = Vec::new();
                let mut thumbs: Vec<usize> = Vec::new();
                for w in batch {
                    match w {
                        Want::Points(i) => pts.push(i),
                        Want::Thumbnail(i) => thumbs.push(i),
                    }
                }
                for (list, points) in [(pts, true), (thumbs, false)] {
                    if list.is_empty() {
                        continue;
                    }
                    if read_tx.send(read_frames(&source, &list, points, !points)).is_err() {
                        return;
                    }
                    wake();
                }
            }
        });
        let mut store = FrameStore {
            name: name.to_string(),
            verdicts: vec![None; frames],
            reader: spawned.ok().map(|_| (want_tx, read_rx)),
            ..FrameStore::default()
        };
        store.take(ctx, first);
        store
    }

    /// Take what the reading thread has read; true when anything arrived.
    pub fn poll(&mut self, ctx: &egui::Context) -> bool {
        let Some((_, rx)) = &self.reader else { return false };
        let arrived: Vec<_> = rx.try_iter().collect();
        let any = !arrived.is_empty();
        for r in arrived {
            match r {
                Ok(reads) => self.take(ctx, reads),
                Err(e) => {
                    self.pending.clear();
                    self.failed = Some(e.to_string());
                }
            }
        }
        any
    }

    fn take(&mut self, ctx: &egui::Context, reads: Vec<FrameRead>) {
        for r in reads {
            let i = r.index;
            if let Some(p) = r.points {
                self.pending.remove(&Want::Points(i));
                self.points.retain(|(j, _)| *j != i);
                self.points.push_back((i, p));
                while self.points.len() > MAX_POINT_FRAMES {
                    self.points.pop_front();
                }
            }
            match r.thumbnail {
                Some(Some(img)) => {
                    let tex = ctx.load_texture(
                        format!("thumb-{}-{i}", self.name),
                        img.clone(),
                        egui::TextureOptions::LINEAR,
                    );
                    self.tick += 1;
                    self.thumbnails.insert(i, ((tex, Arc::new(img)), self.tick));
                    self.evict_thumbnails();
                }
                Some(None) => {
                    self.no_image.insert(i);
                }
                None => {}
            }
            self.pending.remove(&Want::Thumbnail(i));
            if r.verdict.is_err() {
                self.pending.remove(&Want::Points(i)); // nothing to show: not asked again
            }
            if let Some(v) = self.verdicts.get_mut(i) {
                *v = Some(r.verdict);
            }
        }
    }

    fn evict_thumbnails(&mut self) {
        while self.thumbnails.len() > MAX_THUMBNAILS {
            let oldest = self.thumbnails.iter().min_by_key(|(_, (_, t))| *t).map(|(i, _)| *i);
            match oldest {
                Some(i) => self.thumbnails.remove(&i),
                None => break,
            };
        }
    }

    fn want(&mut self, w: Want) {
        if self.failed.is_some() || !self.pending.insert(w) {
            return;
        }
        if let Some((tx, _)) = &self.reader
            && tx.send(w).is_err()
        {
            self.pending.remove(&w);
        }
    }

    /// The points of frame `i` if they are held; asked for otherwise (a usable frame).
    pub fn points(&mut self, i: usize) -> Option<Arc<FramePoints>> {
        if let Some(pos) = self.points.iter().position(|(j, _)| *j == i) {
            let held = self.points.remove(pos).expect("found above");
            let p = held.1.clone();
            self.points.push_back(held);
            return Some(p);
        }
        if !matches!(self.verdict(i), Some(Err(_))) {
            self.want(Want::Points(i));
        }
        None
    }

    /// The points of frame `i` if they are held (no request).
    pub fn held_points(&self, i: usize) -> Option<&Arc<FramePoints>> {
        self.points.iter().find(|(j, _)| *j == i).map(|(_, p)| p)
    }

    /// The thumbnail of frame `i` if it is held; asked for otherwise (once: a frame whose
    /// image cannot be read has none).
    pub fn thumbnail(&mut self, i: usize) -> Option<Thumbnail> {
        self.tick += 1;
        let tick = self.tick;
        if let Some((t, seen)) = self.thumbnails.get_mut(&i) {
            *seen = tick;
            return Some(t.clone());
        }
        if !self.no_image.contains(&i) {
            self.want(Want::Thumbnail(i));
        }
        None
    }

    /// Frame `i`'s verdict once it was read: its number of points or why it is not used.
    pub fn verdict(&self, i: usize) -> Option<&Result<usize, String>> {
        self.verdicts.get(i).and_then(|v| v.as_ref())
    }

    pub fn problem(&self, i: usize) -> Option<&str> {
        match self.verdict(i) {
            Some(Err(p)) => Some(p),
            _ => None,
        }
    }

    /// Frames read so far, and of those the usable ones.
    pub fn checked(&self) -> usize {
        self.verdicts.iter().filter(|v| v.is_some()).count()
    }

    pub fn usable(&self) -> usize {
        self.verdicts.iter().filter(|v| matches!(v, Some(Ok(_)))).count()
    }

    /// The frames found unusable so far, in order.
    pub fn flagged(&self) -> impl Iterator<Item = (usize, &str)> {
        self.verdicts.iter().enumerate().filter_map(|(i, v)| match v {
            Some(Err(p)) => Some((i, p.as_str())),
            _ => None,
        })
    }

    /// Reads asked for and not yet done.
    pub fn busy(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Frames whose points are held, thumbnails held, and the bytes they take (points,
    /// normals and thumbnail pixels).
    pub fn held(&self) -> (usize, usize, usize) {
        let points: usize = self.points.iter().map(|(_, p)| p.bytes()).sum();
        let pixels: usize =
            self.thumbnails.values().map(|((_, img), _)| img.pixels.len() * 4).sum();
        (self.points.len(), self.thumbnails.len(), points + pixels)
    }
}

/// A depth image as a thumbnail: near = warm and bright, far = cool and dark, no depth = black.
pub fn depth_thumbnail(metres: &[f32], width: usize, height: usize) -> egui::ColorImage {
    let valid: Vec<f32> = metres.iter().copied().filter(|z| *z > 0.0 && z.is_finite()).collect();
    let (lo, hi) =
        valid.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &z| (lo.min(z), hi.max(z)));
    let side = width.max(height).max(1);
    let scale = THUMBNAIL_SIZE as f32 / side as f32;
    let (w, h) = (
        ((width as f32 * scale).round() as usize).max(1),
        ((height as f32 * scale).round() as usize).max(1),
    );
    let mut pixels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            // Nearest valid sample of the block the thumbnail pixel covers.
            let (u0, v0) = ((x as f32 / scale) as usize, (y as f32 / scale) as usize);
            let (u1, v1) = (
                (((x + 1) as f32 / scale) as usize).min(width),
                (((y + 1) as f32 / scale) as usize).min(height),
            );
            let mut z = 0.0f32;
            'outer: for v in v0..v1.max(v0 + 1).min(height) {
                for u in u0..u1.max(u0 + 1).min(width) {
                    let d = metres[v * width + u];
                    if d > 0.0 && d.is_finite() {
                        z = d;
                        break 'outer;
                    }
                }
            }
            pixels.push(if z > 0.0 {
                let t = if hi > lo { ((z - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
                ramp(1.0 - t)
            } else {
                egui::Color32::from_rgb(12, 13, 16)
            });
        }
    }
    egui::ColorImage::new([w, h], pixels)
}

/// A perceptual-ish ramp from deep blue (0) through teal to warm white (1).
fn ramp(t: f32) -> egui::Color32 {
    let stops = [
        [20.0, 30.0, 70.0],
        [30.0, 110.0, 150.0],
        [90.0, 190.0, 170.0],
        [240.0, 220.0, 150.0],
        [255.0, 250.0, 235.0],
    ];
    let x = t.clamp(0.0, 1.0) * (stops.len() - 1) as f32;
    let i = (x.floor() as usize).min(stops.len() - 2);
    let f = x - i as f32;
    let c: Vec<u8> =
        (0..3).map(|k| (stops[i][k] + (stops[i + 1][k] - stops[i][k]) * f) as u8).collect();
    egui::Color32::from_rgb(c[0], c[1], c[2])
}
