//! The timeline: a motion clip, the current frame, play/pause, speed, plus per-joint offsets
//! for the major joints. Pure state and one small panel.

use avatar_core::body::{BodyParams, JOINT_NAMES, NUM_JOINTS};
use avatar_core::motion::{MotionClip, clip_by_name, clip_names};
use eframe::egui;
use glam::{EulerRot, Quat, Vec3};
use std::path::Path;

/// Motion files recorded faster are played (and baked) at this rate, as `export` and `pose`
/// write them by default.
pub const PLAYBACK_FPS: f32 = 30.0;

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
    }

    pub fn step(&mut self, delta: i32) {
        self.playing = false;
        let n = self.frames() as i32;
        self.frame = (self.current_frame() as i32 + delta).rem_euclid(n) as f32;
    }

    /// Advance by `dt` seconds when playing (wraps). Returns true when the frame changed.
    pub fn tick(&mut self, dt: f32) -> bool {
        if !self.playing || self.frames() < 2 {
            return false;
        }
        let before = self.current_frame();
        self.frame =
            (self.frame + dt * self.clip.fps * self.speed).rem_euclid(self.frames() as f32);
        self.current_frame() != before
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

/// What the timeline bar asks the app to do.
#[derive(Default)]
pub struct TimelineActions {
    pub changed: bool,
    pub open_file: bool,
    pub library: Option<String>,
}

/// The bottom bar: play/pause, step, the frame slider, speed, clip choice.
pub fn timeline_bar(ui: &mut egui::Ui, t: &mut Timeline) -> TimelineActions {
    let mut a = TimelineActions::default();
    ui.horizontal(|ui| {
        let label = if t.playing { "Pause" } else { "Play" };
        if ui.add_sized([78.0, 22.0], egui::Button::new(label)).on_hover_text("Space").clicked() {
            t.playing = !t.playing;
        }
        if ui.button("<").on_hover_text("Previous frame (,)").clicked() {
            t.step(-1);
            a.changed = true;
        }
        if ui.button(">").on_hover_text("Next frame (.)").clicked() {
            t.step(1);
            a.changed = true;
        }
        let n = t.frames();
        let mut f = t.current_frame();
        // Room for the time (and a resampled clip's source rate), speed and clip.
        let reserve = if t.clip.source_fps != t.clip.fps { 540.0 } else { 400.0 };
        ui.spacing_mut().slider_width = (ui.available_width() - reserve).max(120.0);
        let r = ui.add(
            egui::Slider::new(&mut f, 0..=n - 1)
                .text("frame")
                .clamping(egui::SliderClamping::Always),
        );
        if r.changed() {
            t.set_frame(f);
            t.playing = false;
            a.changed = true;
        }
        let source = if t.clip.source_fps != t.clip.fps {
            // A BVH's frame time gives 119.99999: rates to the hundredth.
            let rate = |f: f32| (f * 100.0).round() / 100.0;
            format!(" ({} fps source at {})", rate(t.clip.source_fps), rate(t.clip.fps))
        } else {
            String::new()
        };
        ui.label(
            egui::RichText::new(format!(
                "{:.2} s{source}",
                t.current_frame() as f32 / t.clip.fps.max(1e-3)
            ))
            .monospace()
            .weak(),
        );
        ui.separator();
        let speed_label = ui.label("speed");
        egui::ComboBox::from_id_salt("speed")
            .width(58.0)
            .selected_text(format!("{}x", t.speed))
            .show_ui(ui, |ui| {
                for s in [0.25, 0.5, 1.0, 2.0] {
                    ui.selectable_value(&mut t.speed, s, format!("{s}x"));
                }
            })
            .response
            .labelled_by(speed_label.id);
        let clip_label = ui.label("clip");
        egui::ComboBox::from_id_salt("clip")
            .width(110.0)
            .selected_text(t.clip.name.clone())
            .show_ui(ui, |ui| {
                for name in clip_names() {
                    if ui.selectable_label(t.clip.name == name, name).clicked() {
                        a.library = Some(name.to_string());
                    }
                }
                if ui.button("Open motion file…").clicked() {
                    a.open_file = true;
                }
            })
            .response
            .labelled_by(clip_label.id);
    });
    a
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
