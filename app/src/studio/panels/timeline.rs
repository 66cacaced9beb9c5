//! The timeline at the bottom: play/pause, frame step, the frame slider over the frames in view
//! (zoomed), the time, speed and the clip (the library and the motion files opened in the
//! session); under it the whole clip as a strip (the frames baked, the range, the frames in
//! view, the current frame; click or drag to scrub), zoom, and the range that plays, bakes and
//! exports; then a running bake's progress.

use crate::studio::commands::Command;
use crate::studio::settings::PathPurpose;
use crate::studio::state::StudioApp;
use crate::studio::style::ACCENT;
use crate::studio::timeline::Timeline;
use avatar_core::motion::clip_names;
use eframe::egui;

pub fn timeline_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    ui.add_space(3.0);
    let was_playing = app.timeline.playing;
    let before = (app.timeline.current_frame(), app.timeline.play_range());
    controls(app, ui, out);
    let baked = app.baked_spans();
    range_row(ui, &mut app.timeline, &baked);
    if app.timeline.playing != was_playing {
        app.timeline.playing = was_playing;
        out.push(Command::TogglePlay);
    }
    if (app.timeline.current_frame(), app.timeline.play_range()) != before {
        out.push(Command::PoseChanged);
    }
    if let Some((done, n)) = app.bakes.progress {
        ui.horizontal(|ui| {
            let stop = ui.button("Stop").on_hover_text(
                "Stop baking: the frames baked so far play, the rest are posed live",
            );
            if stop.clicked() {
                out.push(Command::StopBake);
            }
            ui.add(
                egui::ProgressBar::new(done as f32 / n.max(1) as f32)
                    .text(format!(
                        "Baking the clip for playback: {done} / {n} frames (baked frames play)"
                    ))
                    .desired_height(14.0),
            );
        });
    }
    ui.add_space(1.0);
}

/// Play, step, the slider over the frames in view, time, speed, clip (the right-hand ones laid
/// out from the right: the slider takes the width left, the clip list is never cut off).
fn controls(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    let t = &mut app.timeline;
    let kept = &app.loaded_clips;
    ui.horizontal(|ui| {
        let label = if t.playing { "Pause" } else { "Play" };
        if ui.add_sized([78.0, 22.0], egui::Button::new(label)).on_hover_text("Space").clicked() {
            t.playing = !t.playing;
        }
        if ui.button("<").on_hover_text("Previous frame (,)").clicked() {
            t.step(-1);
        }
        if ui.button(">").on_hover_text("Next frame (.)").clicked() {
            t.step(1);
        }
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            let combo = egui::ComboBox::from_id_salt("clip")
                .width(110.0)
                .selected_text(t.clip.name.clone())
                .show_ui(ui, |ui| {
                    for name in clip_names() {
                        if ui.selectable_label(t.clip_source == name, name).clicked() {
                            out.push(Command::LoadMotion(name.to_string()));
                        }
                    }
                    if !kept.is_empty() {
                        ui.separator();
                    }
                    // The motion files opened in the session.
                    for (source, clip) in kept.iter() {
                        let text = format!("{} · {} frames", clip.name, clip.frames.len());
                        let entry = ui.selectable_label(t.clip_source == *source, text);
                        if entry.on_hover_text(source).clicked() {
                            out.push(Command::ShowLoadedClip(source.clone()));
                        }
                    }
                    if ui.button("Open motion file…").clicked() {
                        out.push(Command::AskPath(PathPurpose::OpenMotion));
                    }
                });
            let clip_label = ui.label("clip");
            combo.response.labelled_by(clip_label.id);
            let speed = egui::ComboBox::from_id_salt("speed")
                .width(58.0)
                .selected_text(format!("{}x", t.speed))
                .show_ui(ui, |ui| {
                    for s in [0.25, 0.5, 1.0, 2.0] {
                        ui.selectable_value(&mut t.speed, s, format!("{s}x"));
                    }
                });
            let speed_label = ui.label("speed");
            speed.response.labelled_by(speed_label.id);
            ui.separator();
            let source = if t.clip.source_fps != t.clip.fps {
                // A BVH's frame time gives 119.99999: rates to the hundredth.
                let rate = |f: f32| (f * 100.0).round() / 100.0;
                format!(" ({} fps source at {})", rate(t.clip.source_fps), rate(t.clip.fps))
            } else {
                String::new()
            };
            ui.label(
                egui::RichText::new(format!("{}{source}", seconds(t, t.current_frame())))
                    .monospace()
                    .weak(),
            );
            // The slider over the frames in view, with its value and "frame".
            let (lo, hi) = t.zoom_range();
            let mut f = t.current_frame();
            ui.spacing_mut().slider_width = (ui.available_width() - 100.0).max(60.0);
            let r = ui.add(
                egui::Slider::new(&mut f, lo..=hi)
                    .text("frame")
                    .clamping(egui::SliderClamping::Always),
            );
            if r.changed() {
                t.set_frame(f);
                t.playing = false;
            }
        });
    });
}

/// "12.34 s": the time of frame `f`.
fn seconds(t: &Timeline, f: usize) -> String {
    format!("{:.2} s", f as f32 / t.clip.fps.max(1e-3))
}

/// The whole clip as a strip, zoom, and the range (laid out from the right; the strip takes the
/// width left).
fn range_row(ui: &mut egui::Ui, t: &mut Timeline, baked: &[(usize, usize)]) {
    ui.horizontal(|ui| {
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            let clear = ui
                .add_enabled(t.range().is_some(), egui::Button::new("clear").small())
                .on_hover_text("The whole clip");
            if clear.clicked() {
                t.clear_range();
            }
            if ui.small_button("out").on_hover_text("The range ends here (O)").clicked() {
                t.set_out();
            }
            if ui.small_button("in").on_hover_text("The range starts here (I)").clicked() {
                t.set_in();
            }
            let (mut a, mut b) = t.play_range();
            let last = t.last();
            let rb = ui.add(egui::DragValue::new(&mut b).range(0..=last));
            ui.label("–");
            let ra = ui.add(egui::DragValue::new(&mut a).range(0..=last));
            let range = ui.label("range").on_hover_text(
                "The frames that play (looped), bake and export; I and O set its ends at the current frame",
            );
            let (ra, rb) = (ra.labelled_by(range.id), rb.labelled_by(range.id));
            if ra.changed() || rb.changed() {
                t.set_range(a, b);
            }
            ui.separator();
            if ui.small_button("to range").on_hover_text("The slider spans the range").clicked() {
                t.zoom_to_range();
            }
            let all = ui.small_button("all").on_hover_text("The slider spans the whole clip");
            if all.clicked() {
                t.zoom_all();
            }
            for (text, tip, factor) in [("+", "Zoom in", 0.5), ("−", "Zoom out", 2.0)] {
                if ui.small_button(text).on_hover_text(tip).clicked() {
                    t.zoom_by(factor);
                }
            }
            ui.label("zoom");
            let width = ui.available_width();
            ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                strip(ui, t, baked, width);
            });
        });
    });
}

/// The whole clip, `width` points wide: the baked frames (lower half), the range (accent), the
/// frames in the slider's view (a frame), the current frame (a line), a tick every few seconds.
/// A click or drag moves the current frame there.
fn strip(ui: &mut egui::Ui, t: &mut Timeline, baked: &[(usize, usize)], width: f32) {
    let (rect, response) =
        ui.allocate_exact_size(egui::vec2(width, 16.0), egui::Sense::click_and_drag());
    let n = t.frames() as f32;
    response.widget_info(|| egui::WidgetInfo::slider(true, t.current_frame() as f64, "whole clip"));
    let x = |f: f32| rect.left() + rect.width() * (f / n).clamp(0.0, 1.0);
    let span = |a: usize, b_excl: usize| {
        egui::Rect::from_x_y_ranges(x(a as f32)..=x(b_excl as f32), rect.y_range())
    };
    let p = ui.painter_at(rect.expand(1.0));
    p.rect_filled(rect, 3.0, egui::Color32::from_gray(34));
    for &(first, count) in baked {
        let r = span(first, first + count);
        let lower = egui::Rect::from_x_y_ranges(r.x_range(), rect.center().y..=rect.bottom());
        p.rect_filled(lower, 0.0, egui::Color32::from_rgb(70, 84, 104));
    }
    if let Some((a, b)) = t.range() {
        p.rect_filled(span(a, b + 1), 0.0, ACCENT.gamma_multiply(0.35));
    }
    // A tick every 1, 2, 5, 10, 30 or 60 s: at most about 25 on the strip.
    let fps = t.clip.fps.max(1e-3);
    let every = [1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 300.0]
        .into_iter()
        .find(|s| n / fps / s <= 25.0)
        .unwrap_or(600.0);
    let mut s = every;
    while s * fps < n {
        let xs = x(s * fps);
        p.line_segment(
            [egui::pos2(xs, rect.top()), egui::pos2(xs, rect.top() + 5.0)],
            egui::Stroke::new(1.0, egui::Color32::from_gray(110)),
        );
        s += every;
    }
    let (lo, hi) = t.zoom_range();
    if t.zoom_range() != (0, t.last()) {
        p.rect_stroke(
            span(lo, hi + 1),
            2.0,
            egui::Stroke::new(1.5, egui::Color32::from_gray(220)),
            egui::StrokeKind::Inside,
        );
    }
    let xf = x(t.current_frame() as f32 + 0.5);
    p.line_segment(
        [egui::pos2(xf, rect.top()), egui::pos2(xf, rect.bottom())],
        egui::Stroke::new(2.0, ACCENT),
    );
    if let Some(pos) = response.interact_pointer_pos() {
        let f = ((pos.x - rect.left()) / rect.width() * n).floor().max(0.0) as usize;
        t.set_frame(f);
        t.playing = false;
    }
    response.on_hover_text(format!(
        "The whole clip: {} frames, {}; click or drag to go to a frame",
        t.frames(),
        seconds(t, t.frames())
    ));
}
