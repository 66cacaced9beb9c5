//! The timeline: a motion clip, the current frame, play/pause, speed, per-joint offsets for
//! the major joints, the frames the slider spans (zoom) and the range that plays, bakes and
//! exports; the motion files opened in the session. Pure state and the joint controls (the bar
//! is `panels/timeline.rs`).

use avatar_core::body::{BodyParams, JOINT_NAMES, NUM_JOINTS};
use avatar_core::motion::{MotionClip, clip_by_name};
use eframe::egui;
use glam::{EulerRot, Quat, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Motion files recorded faster are played (and baked) at this rate, as `export` and `pose`
/// write them by default.
pub const PLAYBACK_FPS: f32 = 30.0;

/// The fewest frames the slider spans when zoomed in (fewer only in a shorter clip).
pub const MIN_ZOOM_FRAMES: usize = 10;

/// Motion files kept in the clip list (the oldest leaves first).
pub const MAX_LOADED_CLIPS: usize = 8;

/// Joints with their own controls (SMPL indices).
pub const MAJOR_JOINTS: [usize; 12] = [0, 3, 6, 12, 16, 17, 18, 19, 1, 2, 4, 5];

pub struct Timeline {
    pub clip: MotionClip,
    /// Library name or file path the clip came from.
    pub clip_source: String,
    /// Fractional frame position.
    pub frame: f32,
    pub playing: bool,
    pub speed: f32,
    /// Per-joint offsets, Euler XYZ in degrees.
    pub offsets: [[f32; 3]; NUM_JOINTS],
    /// The frames the slider spans (first, last), zoomed in; None: the whole clip.
    zoom: Option<(usize, usize)>,
    /// The frames that play, bake and export (first, last); None: the whole clip.
    range: Option<(usize, usize)>,
}

impl Timeline {
    pub fn new(clip: MotionClip, source: impl Into<String>) -> Timeline {
        Timeline {
            clip,
            clip_source: source.into(),
            frame: 0.0,
            playing: false,
            speed: 1.0,
            offsets: [[0.0; 3]; NUM_JOINTS],
            zoom: None,
            range: None,
        }
    }

    pub fn library(name: &str) -> Option<Timeline> {
        clip_by_name(name).map(|c| Timeline::new(c, name))
    }

    pub fn frames(&self) -> usize {
        self.clip.frames.len().max(1)
    }

    pub fn current_frame(&self) -> usize {
        (self.frame.floor() as usize).min(self.frames() - 1)
    }

    pub fn set_frame(&mut self, f: usize) {
        self.frame = f.min(self.frames() - 1) as f32;
        self.keep_in_view();
    }

    pub fn step(&mut self, delta: i32) {
        self.playing = false;
        let n = self.frames() as i32;
        self.frame = (self.current_frame() as i32 + delta).rem_euclid(n) as f32;
        self.keep_in_view();
    }

    /// Advance by `dt` seconds when playing, looping over the range (or the whole clip); a frame
    /// outside the range goes to its first. Returns true when the frame changed.
    pub fn tick(&mut self, dt: f32) -> bool {
        let (a, b) = self.play_range();
        let len = (b - a + 1) as f32;
        if !self.playing || len < 2.0 {
            return false;
        }
        let before = self.current_frame();
        let mut at = self.frame - a as f32;
        if !(0.0..len).contains(&at) {
            at = 0.0;
        }
        self.frame = a as f32 + (at + dt * self.clip.fps * self.speed).rem_euclid(len);
        self.keep_in_view();
        self.current_frame() != before
    }

    pub fn last(&self) -> usize {
        self.frames() - 1
    }

    /// The frames that play, bake and export (first, last; inclusive).
    pub fn play_range(&self) -> (usize, usize) {
        self.range.unwrap_or((0, self.last()))
    }

    /// The range chosen, if any (not the whole clip).
    pub fn range(&self) -> Option<(usize, usize)> {
        self.range
    }

    /// Play, bake and export frames `a` to `b` (either order, clamped to the clip); the whole
    /// clip is no range.
    pub fn set_range(&mut self, a: usize, b: usize) {
        let (a, b) = (a.min(b).min(self.last()), a.max(b).min(self.last()));
        self.range = ((a, b) != (0, self.last())).then_some((a, b));
    }

    /// The range starts at the current frame (its end stays unless it is before).
    pub fn set_in(&mut self) {
        let f = self.current_frame();
        let (_, b) = self.play_range();
        self.set_range(f, if b >= f { b } else { self.last() });
    }

    /// The range ends at the current frame (its start stays unless it is after).
    pub fn set_out(&mut self) {
        let f = self.current_frame();
        let (a, _) = self.play_range();
        self.set_range(if a <= f { a } else { 0 }, f);
    }

    pub fn clear_range(&mut self) {
        self.range = None;
    }

    /// The frames the slider spans (first, last; inclusive).
    pub fn zoom_range(&self) -> (usize, usize) {
        self.zoom.unwrap_or((0, self.last()))
    }

    /// The slider spans frames `a` to `b` (either order), at least [`MIN_ZOOM_FRAMES`] (grown
    /// around their middle); the current frame is brought into view.
    pub fn set_zoom(&mut self, a: usize, b: usize) {
        let last = self.last();
        let (a, b) = (a.min(b).min(last), a.max(b).min(last));
        let want = b - a + 1;
        let span = want.max(MIN_ZOOM_FRAMES.min(last + 1));
        let a = a.saturating_sub((span - want) / 2).min(last + 1 - span);
        let b = a + span - 1;
        self.zoom = ((a, b) != (0, last)).then_some((a, b));
        if !(a..=b).contains(&self.current_frame()) {
            self.set_frame(a);
        }
    }

    /// Zoom by `factor` (below 1 in, above 1 out) around the current frame.
    pub fn zoom_by(&mut self, factor: f32) {
        let (a, b) = self.zoom_range();
        let span = (((b - a + 1) as f32 * factor).round() as usize).max(1);
        let start = self.current_frame().saturating_sub(span / 2);
        self.set_zoom(start, start + span - 1);
    }

    /// The slider spans the range (or the whole clip when there is none).
    pub fn zoom_to_range(&mut self) {
        let (a, b) = self.play_range();
        self.set_zoom(a, b);
    }

    pub fn zoom_all(&mut self) {
        self.zoom = None;
    }

    /// A current frame outside the slider's span moves the span (a page, keeping its width).
    pub fn keep_in_view(&mut self) {
        let (a, b) = self.zoom_range();
        let f = self.current_frame();
        if !(a..=b).contains(&f) {
            let span = b - a + 1;
            let start = if f < a { f.saturating_sub(span - 1) } else { f };
            let start = start.min(self.last() + 1 - span);
            self.zoom = Some((start, start + span - 1));
        }
    }

    /// The clip cut to the range (the whole clip without one): what an export writes.
    pub fn range_clip(&self) -> MotionClip {
        let (a, b) = self.play_range();
        let mut clip = self.clip.clone();
        if (a, b) != (0, self.last()) {
            clip.frames = self.clip.frames[a..=b].to_vec();
        }
        clip
    }

    /// The pose at the current frame with the joint offsets applied, in the given shape.
    pub fn params(&self, betas: &[f32]) -> BodyParams {
        self.params_at(self.current_frame(), betas)
    }

    /// The pose at frame `f` with the joint offsets applied, in the given shape.
    pub fn params_at(&self, f: usize, betas: &[f32]) -> BodyParams {
        let mut p = self.clip.frames.get(f).cloned().unwrap_or_default();
        for (j, o) in self.offsets.iter().enumerate() {
            if o.iter().any(|v| *v != 0.0) {
                let q = Quat::from_euler(
                    EulerRot::XYZ,
                    o[0].to_radians(),
                    o[1].to_radians(),
                    o[2].to_radians(),
                );
                p.pose[j] = (Quat::from_scaled_axis(p.pose[j]) * q).to_scaled_axis();
            }
        }
        p.betas = betas.to_vec();
        p
    }

    /// A motion file; one recorded faster than [`PLAYBACK_FPS`] (a 120 fps take) is resampled
    /// to it, its source rate kept (`clip.source_fps`, shown on the timeline).
    pub fn load_file(path: &Path) -> crate::error::Result<Timeline> {
        let mut clip = MotionClip::load(path)?;
        if clip.frames.is_empty() {
            return Err(crate::error::StudioError::file(path, "the motion has no frames"));
        }
        if clip.fps > PLAYBACK_FPS {
            clip = clip.resample(PLAYBACK_FPS).map_err(|e| {
                crate::error::StudioError::file(path, format!("cannot resample the motion: {e}"))
            })?;
        }
        Ok(Timeline::new(clip, path.display().to_string()))
    }

    /// A library name or a file.
    pub fn open(source: &str) -> crate::error::Result<Timeline> {
        match Timeline::library(source) {
            Some(t) => Ok(t),
            None => Timeline::load_file(Path::new(source)),
        }
    }
}

/// A motion file (JSON that is not a capture's or a project's, AMASS npz, BVH) by its name.
pub fn is_motion_file(p: &std::path::Path) -> bool {
    let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("").to_lowercase();
    p.is_file()
        && !name.ends_with(".studio.json")
        && name != "capture.json"
        && [".json", ".npz", ".bvh"].iter().any(|e| name.ends_with(e))
}

/// The motion files opened in this session, newest first, kept in the clip list: choosing one
/// shows it again without reading its file.
#[derive(Default)]
pub struct LoadedClips {
    clips: Vec<(String, Arc<MotionClip>)>,
}

impl LoadedClips {
    /// Keep the clip a timeline opened from a file (a library clip is not kept: it is listed).
    pub fn keep(&mut self, t: &Timeline) {
        if clip_by_name(&t.clip_source).is_some() {
            return;
        }
        self.clips.retain(|(s, _)| *s != t.clip_source);
        self.clips.insert(0, (t.clip_source.clone(), Arc::new(t.clip.clone())));
        self.clips.truncate(MAX_LOADED_CLIPS);
    }

    /// (source, clip), newest first.
    pub fn iter(&self) -> impl Iterator<Item = &(String, Arc<MotionClip>)> {
        self.clips.iter()
    }

    pub fn len(&self) -> usize {
        self.clips.len()
    }

    pub fn is_empty(&self) -> bool {
        self.clips.is_empty()
    }

    /// A timeline of the kept clip `source`.
    pub fn timeline(&self, source: &str) -> Option<Timeline> {
        let (_, clip) = self.clips.iter().find(|(s, _)| s == source)?;
        Some(Timeline::new((**clip).clone(), source))
    }
}

/// Per-joint controls (degrees, as offsets on the clip's pose).
pub fn joint_controls(ui: &mut egui::Ui, t: &mut Timeline) -> bool {
    let mut changed = false;
    egui::Grid::new("joints").num_columns(4).spacing([6.0, 2.0]).show(ui, |ui| {
        for &j in &MAJOR_JOINTS {
            let l = ui.label(pretty_joint(JOINT_NAMES[j]));
            for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                let r = ui
                    .add(
                        egui::DragValue::new(&mut t.offsets[j][k])
                            .range(-120.0..=120.0)
                            .speed(0.5)
                            .suffix("°")
                            .prefix(*axis),
                    )
                    .labelled_by(l.id);
                changed |= r.changed();
            }
            ui.end_row();
        }
    });
    if ui.button("Reset joints").clicked() {
        t.offsets = [[0.0; 3]; NUM_JOINTS];
        changed = true;
    }
    changed
}

pub fn pretty_joint(name: &str) -> String {
    let s = name.replace('_', " ");
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => s,
    }
}

/// A zero pose (for the skeleton of a clip-less view).
pub fn rest_pose(betas: &[f32]) -> BodyParams {
    BodyParams { pose: [Vec3::ZERO; NUM_JOINTS], betas: betas.to_vec(), trans: Vec3::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;
    use avatar_core::body::BodyParams;

    fn clip(frames: usize) -> Timeline {
        Timeline::new(MotionClip::new("c", 30.0, vec![BodyParams::default(); frames]), "c.json")
    }

    #[test]
    fn the_range_plays_in_a_loop_and_is_what_exports() {
        let mut t = clip(100);
        assert_eq!(t.play_range(), (0, 99));
        t.set_frame(20);
        t.set_in();
        t.set_frame(29);
        t.set_out();
        assert_eq!(t.range(), Some((20, 29)));
        assert_eq!(t.range_clip().frames.len(), 10);
        // Playing from outside the range starts at its first frame and loops within it.
        t.set_frame(70);
        t.playing = true;
        t.tick(0.0);
        assert_eq!(t.current_frame(), 20);
        for _ in 0..25 {
            t.tick(1.0 / 30.0 + 1e-4);
            assert!((20..=29).contains(&t.current_frame()), "{}", t.current_frame());
        }
        // Either order, clamped; the whole clip is no range.
        t.set_range(150, 90);
        assert_eq!(t.range(), Some((90, 99)));
        t.set_range(0, 99);
        assert_eq!(t.range(), None);
        // An in point after the out point opens the range to the clip's end.
        t.set_range(10, 20);
        t.set_frame(50);
        t.set_in();
        assert_eq!(t.range(), Some((50, 99)));
    }

    #[test]
    fn zoom_keeps_the_current_frame_in_view() {
        let mut t = clip(688);
        t.set_frame(300);
        t.zoom_by(0.25);
        let (a, b) = t.zoom_range();
        assert_eq!(b - a + 1, 172);
        assert!((a..=b).contains(&300));
        // A frame outside the view pages it; its width stays.
        t.set_frame(600);
        let (a2, b2) = t.zoom_range();
        assert_eq!((a2, b2 - a2), (516, b - a), "clamped to the clip's end");
        // The fewest frames in view, and a range to zoom to.
        t.set_zoom(5, 6);
        assert_eq!(t.zoom_range().1 - t.zoom_range().0 + 1, MIN_ZOOM_FRAMES);
        t.set_range(100, 199);
        t.zoom_to_range();
        assert_eq!(t.zoom_range(), (100, 199));
        assert_eq!(t.current_frame(), 100, "brought into view");
        t.zoom_all();
        assert_eq!(t.zoom_range(), (0, 687));
        // A clip shorter than the fewest frames.
        let mut short = clip(3);
        short.set_zoom(1, 1);
        assert_eq!(short.zoom_range(), (0, 2));
    }

    #[test]
    fn loaded_clips_keep_files_not_library_clips() {
        let mut kept = LoadedClips::default();
        kept.keep(&Timeline::library("walk").unwrap());
        assert!(kept.is_empty());
        for i in 0..MAX_LOADED_CLIPS + 2 {
            kept.keep(&Timeline::new(MotionClip::new("c", 30.0, vec![]), format!("{i}.bvh")));
        }
        assert_eq!(kept.len(), MAX_LOADED_CLIPS);
        assert_eq!(kept.iter().next().unwrap().0, format!("{}.bvh", MAX_LOADED_CLIPS + 1));
        assert!(kept.timeline("0.bvh").is_none(), "the oldest left");
        let again = kept.timeline("5.bvh").unwrap();
        assert_eq!(again.clip_source, "5.bvh");
    }
}
