//! The right-hand panel: the avatar, fine-tuning (settings, progress, loss plot), the pose,
//! export, and the view (camera presets, turntable, material colour, light).

use crate::studio::camera::Preset;
use crate::studio::commands::Command;
use crate::studio::fit_config::{AvatarKind, FitConfig};
use crate::studio::settings::PathPurpose;
use crate::studio::state::StudioApp;
use crate::studio::style::{self, ACCENT, WARN};
use crate::studio::timeline::joint_controls;
use avatar_neural::IgrWeights;
use eframe::egui;

pub fn side_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    avatar_panel(app, ui, out);
    ui.separator();
    fit_panel(app, ui, out);
    ui.separator();
    pose_panel(app, ui, out);
    ui.separator();
    export_panel(app, ui, out);
    ui.separator();
    look_panel(app, ui, out);
}

/// The loss terms' weights of a fit (both kinds take `fit`'s): a term weighted 0 is switched
/// off and not shown.
fn loss_weights() -> IgrWeights {
    avatar_neural::HyperFitOptions::default().weights
}

/// "loss 0.0123 · surface 0.0040 · eikonal 0.012": the terms with a weight.
pub fn loss_readout(loss: f32, terms: [f32; 4], w: IgrWeights) -> String {
    let mut s = format!("loss {loss:.4}");
    for (name, value, weight, digits) in [
        ("surface", terms[0], w.surface, 4),
        ("normal", terms[1], w.normal, 3),
        ("eikonal", terms[3], w.eikonal, 3),
    ] {
        if weight != 0.0 {
            s += &format!(" · {name} {value:.digits$}");
        }
    }
    s
}

fn look_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    style::heading(ui, "View");
    ui.horizontal_wrapped(|ui| {
        for (p, key) in Preset::ALL.into_iter().zip(["1", "2", "3", "4"]) {
            if ui.button(p.label()).on_hover_text(format!("{} view ({key})", p.label())).clicked() {
                out.push(Command::CameraPreset(p));
            }
        }
        ui.toggle_value(&mut app.turntable, "Turntable")
            .on_hover_text("Turn around the subject (T)");
    });
    egui::Grid::new("look").num_columns(2).spacing([8.0, 3.0]).show(ui, |ui| {
        let l = ui.label("Material");
        // egui's Rgba is linear RGB, as the studio's colours are.
        let mut srgb =
            egui::Rgba::from_rgb(app.view.material[0], app.view.material[1], app.view.material[2]);
        if egui::color_picker::color_edit_button_rgba(
            ui,
            &mut srgb,
            egui::color_picker::Alpha::Opaque,
        )
        .labelled_by(l.id)
        .changed()
        {
            app.view.material = [srgb.r(), srgb.g(), srgb.b()];
            out.push(Command::SceneChanged);
        }
        ui.end_row();
        let (mut azimuth, mut elevation) = light_angles(app.view.light);
        let l = ui.label("Light");
        let a = ui
            .add(egui::Slider::new(&mut azimuth, -180.0..=180.0).suffix("°").text("around"))
            .labelled_by(l.id);
        ui.end_row();
        ui.label("");
        let e = ui.add(egui::Slider::new(&mut elevation, -89.0..=89.0).suffix("°").text("height"));
        ui.end_row();
        if a.changed() || e.changed() {
            app.view.light = light_direction(azimuth, elevation);
        }
    });
    if ui.small_button("Default look").clicked() {
        let d = crate::studio::project::ViewState::default();
        (app.view.material, app.view.light) = (d.material, d.light);
        out.push(Command::SceneChanged);
    }
}

/// (around, height) in degrees of a view-space light direction; 0 degrees around = from the
/// camera, positive = from its right.
pub fn light_angles(d: [f32; 3]) -> (f32, f32) {
    let v = glam::Vec3::from(d).normalize_or(glam::Vec3::Z);
    (v.x.atan2(v.z).to_degrees(), v.y.clamp(-1.0, 1.0).asin().to_degrees())
}

pub fn light_direction(around: f32, height: f32) -> [f32; 3] {
    let (a, h) = (around.to_radians(), height.to_radians());
    [h.cos() * a.sin(), h.sin(), h.cos() * a.cos()]
}

fn avatar_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    style::heading(ui, "Avatar");
    match &app.avatar {
        Some(a) => {
            ui.label(egui::RichText::new(a.describe()).strong());
            let where_ = match (&app.avatar_path, app.avatar_saved) {
                (Some(p), true) => p.display().to_string(),
                _ => "not saved".into(),
            };
            ui.label(egui::RichText::new(where_).small().weak());
            if ui
                .button("Save avatar…")
                .on_hover_text("The .avatar file the command line reads too")
                .clicked()
            {
                out.push(Command::AskPath(PathPurpose::SaveAvatar));
            }
            if app.meshing() {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label("Meshing the SDF…");
                });
            }
        }
        None => {
            ui.weak("No avatar yet: fine-tune one below, or open a .avatar file. The body of the capture's fitting is shown meanwhile.");
            if app.meshing() {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label("Opening the avatar…");
                });
            }
        }
    }
}

fn fit_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    style::heading(ui, "Fine-tune");
    let running = app.job.is_some();
    ui.add_enabled_ui(!running, |ui| {
        let cfg = &mut app.settings.fit;
        egui::Grid::new("fit config").num_columns(2).spacing([8.0, 3.0]).show(ui, |ui| {
            let l = ui.label("Avatar");
            egui::ComboBox::from_id_salt("kind")
                .selected_text(cfg.kind.label())
                .show_ui(ui, |ui| {
                    for kind in [AvatarKind::MetaAvatar, AvatarKind::StaticSdf] {
                        if ui.selectable_label(cfg.kind == kind, kind.label()).clicked() && cfg.kind != kind {
                            *cfg = cfg.keeping_prior(FitConfig::for_kind(kind));
                        }
                    }
                })
                .response
                .labelled_by(l.id);
            ui.end_row();
            if cfg.kind == AvatarKind::MetaAvatar {
                let l = ui.label("Prior");
                ui.add(egui::TextEdit::singleline(&mut cfg.model).hint_text("shipped").desired_width(150.0))
                    .on_hover_text("The meta-model the fine-tuning starts from: the path of a meta-model.bin that avatar-studio meta-train wrote (docs/own-data.md), or empty for the shipped one. The avatar records it.")
                    .labelled_by(l.id);
                ui.end_row();
            }
            let l = ui.label("Frames");
            ui.add(egui::DragValue::new(&mut cfg.frames).range(1..=64))
                .on_hover_text("The most usable frames the fit takes (refused under 8, or under this number when it is smaller). More frames average down the error the fittings share, which pose refinement cannot correct.")
                .labelled_by(l.id);
            ui.end_row();
            let l = ui.label("Steps");
            ui.add(egui::DragValue::new(&mut cfg.steps).range(1..=20000).speed(10.0)).labelled_by(l.id);
            ui.end_row();
            if cfg.kind == AvatarKind::StaticSdf {
                let l = ui.label("Network");
                egui::ComboBox::from_id_salt("net")
                    .selected_text(format!("{} × {}", cfg.layers, cfg.hidden))
                    .show_ui(ui, |ui| {
                        for (layers, h, name) in [(2, 32, "tiny"), (3, 64, "small"), (4, 128, "compact"), (5, 256, "paper")] {
                            if ui.selectable_label(cfg.layers == layers && cfg.hidden == h, format!("{name}: {layers} × {h}")).clicked() {
                                cfg.layers = layers;
                                cfg.hidden = h;
                            }
                        }
                    })
                    .response
                    .labelled_by(l.id);
                ui.end_row();
            }
            let l = ui.label("Points / pose");
            ui.add(egui::DragValue::new(&mut cfg.batch).range(100..=20000).speed(50.0)).labelled_by(l.id);
            ui.end_row();
        });
        ui.horizontal(|ui| {
            if ui.small_button("Quick (tiny)").clicked() {
                *cfg = cfg.keeping_prior(match cfg.kind {
                    AvatarKind::MetaAvatar => FitConfig::tiny(),
                    AvatarKind::StaticSdf => FitConfig::tiny_static(),
                });
            }
            if ui.small_button("Default").clicked() {
                *cfg = cfg.keeping_prior(FitConfig::for_kind(cfg.kind));
            }
        });
    });
    ui.horizontal(|ui| {
        if running {
            let cancelling = app.job.as_ref().is_some_and(|j| j.is_cancelling());
            if ui.add_enabled(!cancelling, egui::Button::new("Cancel")).clicked() {
                out.push(Command::CancelFit);
            }
        } else if ui
            .add_enabled(
                app.capture.is_some(),
                egui::Button::new(egui::RichText::new("Start fine-tuning").strong()),
            )
            .clicked()
        {
            out.push(Command::StartFit(app.settings.fit.clone()));
        }
    });
    let jv = &app.job_view;
    if running || !jv.losses.is_empty() {
        // A finished fit's bar says so, not its last phase and a time left.
        let text = if running {
            let left = jv
                .seconds_left()
                .map(|s| format!(" · {} left", human_seconds(s)))
                .unwrap_or_default();
            format!("{}step {} / {}{left}", phase_prefix(jv.phase), jv.step, jv.steps)
        } else {
            let end = if jv.step >= jv.steps { "finished" } else { "stopped" };
            format!("{end} · step {} / {}", jv.step, jv.steps)
        };
        ui.add(
            egui::ProgressBar::new(jv.fraction())
                .text(text)
                .fill(egui::Color32::from_rgb(48, 98, 170)),
        );
        ui.label(
            egui::RichText::new(loss_readout(jv.loss, jv.terms, loss_weights()))
                .small()
                .monospace(),
        );
        if jv.points > 0 {
            ui.label(
                egui::RichText::new(format!(
                    "{} canonical points from {} frames",
                    jv.points, jv.frames
                ))
                .small()
                .weak(),
            );
        }
        if let Some(s) = jv.preview_step
            && running
        {
            ui.label(
                egui::RichText::new(format!("Partial result shown (step {s})")).small().color(WARN),
            );
        }
        let line = egui_plot::Line::new("log10 loss", jv.losses.clone()).color(ACCENT).width(1.5);
        egui_plot::Plot::new("loss plot")
            .height(120.0)
            .allow_scroll(false)
            .allow_zoom(false)
            .allow_drag(false)
            .show_x(false)
            .y_axis_label("log10 loss")
            .include_x(0.0)
            .include_x(jv.steps.max(1) as f64)
            .show(ui, |p| p.line(line));
    }
    if let Some(f) = &app.job_view.finished {
        ui.label(egui::RichText::new(f).small());
    }
}

fn human_seconds(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.0} s")
    } else {
        format!("{}:{:02} min", (s / 60.0) as u64, (s % 60.0) as u64)
    }
}

fn pose_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    style::heading(ui, "Pose");
    ui.label(
        egui::RichText::new(format!(
            "Clip {} · {} frames at {:.0} fps",
            app.timeline.clip.name,
            app.timeline.frames(),
            app.timeline.clip.fps
        ))
        .small(),
    );
    let n = app.timeline.frames();
    let mut f = app.timeline.current_frame();
    if ui.add(egui::Slider::new(&mut f, 0..=n - 1).text("pose")).changed() {
        app.timeline.set_frame(f);
        app.timeline.playing = false;
        out.push(Command::PoseChanged);
    }
    egui::CollapsingHeader::new("Joints").default_open(false).show(ui, |ui| {
        if joint_controls(ui, &mut app.timeline) {
            out.push(Command::PoseChanged);
        }
    });
}

fn export_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    style::heading(ui, "Export");
    let has_avatar = app.avatar.is_some();
    ui.horizontal(|ui| {
        if ui
            .add_enabled(has_avatar && !app.exporting(), egui::Button::new("Export glTF…"))
            .on_hover_text("The avatar playing the clip: skin, morph targets and animation")
            .clicked()
        {
            out.push(Command::AskPath(PathPurpose::ExportGlb));
        }
        if ui
            .add_enabled(app.posed.is_some(), egui::Button::new("Export OBJ…"))
            .on_hover_text("The mesh on screen at the current pose")
            .clicked()
        {
            out.push(Command::AskPath(PathPurpose::ExportObj));
        }
    });
    let t = &app.timeline;
    let what = match t.range() {
        Some((a, b)) => {
            format!("glTF: {} frames {a}–{b} of {} (the timeline's range)", t.clip.name, t.frames())
        }
        None => format!("glTF: the whole clip {} ({} frames)", t.clip.name, t.frames()),
    };
    ui.label(egui::RichText::new(what).small().weak());
    if app.exporting() {
        match app.tasks.export_progress {
            Some(p) if p.total > 0 => {
                ui.add(
                    egui::ProgressBar::new(p.done as f32 / p.total as f32)
                        .text(format!("Exporting: frames {} / {}", p.done, p.total)),
                );
            }
            _ => {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label("Exporting…");
                });
            }
        }
    }
}

/// "refining poses · " before the step count while a phase other than training runs.
fn phase_prefix(phase: &str) -> String {
    if phase.is_empty() || phase == "training" { String::new() } else { format!("{phase} · ") }
}
