//! The studio's panels: menu bar, capture (left), avatar / fine-tuning / pose / look / export
//! (right), timeline (bottom), viewport (centre), the shortcuts window. Each is a small
//! function that reads the state, edits the plain values its widgets hold (fit settings,
//! view toggles, the timeline) and returns what else should happen as [`Command`]s, applied
//! by the app after the frame is drawn.

mod capture;
mod side;
mod timeline;
mod viewport;

use crate::studio::camera::Preset;
use crate::studio::commands::Command;
use crate::studio::project::{DEMO, ViewMode};
use crate::studio::settings::PathPurpose;
use crate::studio::state::{Status, StudioApp};
use crate::studio::style::{ACCENT, ERROR};
use crate::studio::viewport::Shading;
use eframe::egui;
use std::path::PathBuf;

pub use capture::capture_panel;

pub fn draw(app: &mut StudioApp, ui: &mut egui::Ui) -> Vec<Command> {
    if !app.flat {
        return draw_panels(app, ui);
    }
    // The panels are unfilled and the backdrop paints their colour (viewport/flat.rs); their
    // colour still counts as the background where egui asks (the scroll areas' fades).
    crate::studio::viewport::flat::backdrop(ui.painter(), ui.ctx().content_rect());
    let behind = egui::UiStackInfo::new(egui::UiKind::Frame)
        .with_frame(egui::Frame::new().fill(crate::studio::style::PANEL_FILL));
    ui.scope_builder(egui::UiBuilder::new().ui_stack_info(behind), |ui| draw_panels(app, ui)).inner
}

fn draw_panels(app: &mut StudioApp, ui: &mut egui::Ui) -> Vec<Command> {
    let mut out = Vec::new();
    keys(app, ui.ctx(), &mut out);
    let dropped: Vec<PathBuf> = ui.ctx().input(|i| {
        i.raw
            .dropped_files
            .iter()
            .map(|f| f.path().to_path_buf())
            .filter(|p| !p.as_os_str().is_empty())
            .collect()
    });
    out.extend(dropped.into_iter().map(Command::OpenPath));
    egui::Panel::top("menu").show(ui, |ui| menu_bar(app, ui, &mut out));
    egui::Panel::bottom("status").show(ui, |ui| status_bar(app, ui));
    egui::Panel::bottom("timeline").show(ui, |ui| timeline::timeline_panel(app, ui, &mut out));
    egui::Panel::left("capture").resizable(true).default_size(214.0).max_size(420.0).show(
        ui,
        |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| capture_panel(app, ui, &mut out));
        },
    );
    egui::Panel::right("avatar").resizable(true).default_size(280.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| side::side_panel(app, ui, &mut out));
    });
    egui::CentralPanel::no_frame().show(ui, |ui| viewport::viewport_panel(app, ui, &mut out));
    if app.show_shortcuts {
        shortcuts_window(app, ui.ctx());
    }
    out
}

/// The keyboard shortcuts: (keys, what they do).
pub const SHORTCUTS: [(&str, &str); 13] = [
    ("Space", "Play / pause"),
    (", and .", "Previous / next frame"),
    ("I and O", "The range starts / ends at the current frame"),
    ("F", "Frame the subject"),
    ("1 2 3 4", "Front, side, back, top view"),
    ("T", "Turntable on / off"),
    ("P", "Screenshot of the viewport"),
    ("Ctrl+S", "Save the project"),
    ("Ctrl+O", "Open a capture folder"),
    ("?", "This list"),
    ("Left drag", "Orbit"),
    ("Right drag, Shift+drag", "Pan"),
    ("Wheel", "Zoom to the cursor"),
];

fn keys(app: &mut StudioApp, ctx: &egui::Context, out: &mut Vec<Command>) {
    if ctx.egui_wants_keyboard_input() || app.path_dialog.is_some() {
        return;
    }
    // Consumed here, before any widget runs, so that a focused button does not also see them.
    ctx.input_mut(|i| {
        let none = egui::Modifiers::NONE;
        if i.consume_key(egui::Modifiers::COMMAND, egui::Key::S) {
            out.push(Command::SaveProjectHere);
        }
        if i.consume_key(egui::Modifiers::COMMAND, egui::Key::O) {
            out.push(Command::AskPath(PathPurpose::OpenCapture));
        }
        if i.consume_key(none, egui::Key::Space) {
            out.push(Command::TogglePlay);
        }
        for (key, delta) in [(egui::Key::Comma, -1), (egui::Key::Period, 1)] {
            if i.consume_key(none, key) {
                app.timeline.step(delta);
                out.push(Command::PoseChanged);
            }
        }
        for (key, set_in) in [(egui::Key::I, true), (egui::Key::O, false)] {
            if i.consume_key(none, key) {
                if set_in {
                    app.timeline.set_in()
                } else {
                    app.timeline.set_out()
                }
                out.push(Command::PoseChanged);
            }
        }
        if i.consume_key(none, egui::Key::F) {
            out.push(Command::FrameSubject);
        }
        if i.consume_key(none, egui::Key::P) {
            out.push(Command::Screenshot);
        }
        if i.consume_key(none, egui::Key::T) {
            app.turntable = !app.turntable;
        }
        for (key, preset) in [egui::Key::Num1, egui::Key::Num2, egui::Key::Num3, egui::Key::Num4]
            .into_iter()
            .zip(Preset::ALL)
        {
            if i.consume_key(none, key) {
                out.push(Command::CameraPreset(preset));
            }
        }
        if i.consume_key(none, egui::Key::Questionmark)
            || i.events.iter().any(|e| matches!(e, egui::Event::Text(t) if t == "?"))
        {
            app.show_shortcuts = !app.show_shortcuts;
        }
    });
}

fn shortcuts_window(app: &mut StudioApp, ctx: &egui::Context) {
    let mut open = true;
    egui::Window::new("Shortcuts")
        .open(&mut open)
        .collapsible(false)
        .resizable(false)
        .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
        .show(ctx, |ui| {
            egui::Grid::new("shortcuts").num_columns(2).spacing([16.0, 4.0]).show(ui, |ui| {
                for (k, what) in SHORTCUTS {
                    ui.label(egui::RichText::new(k).monospace().color(ACCENT));
                    ui.label(what);
                    ui.end_row();
                }
            });
        });
    app.show_shortcuts &= open;
}

fn menu_bar(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    egui::MenuBar::new().ui(ui, |ui| {
        ui.label(egui::RichText::new("Avatar Studio").strong().color(ACCENT));
        ui.separator();
        ui.menu_button("File", |ui| {
            if ui.button("Open capture folder…").clicked() {
                out.push(Command::AskPath(PathPurpose::OpenCapture));
            }
            if ui.button("Open scan (OBJ)…").on_hover_text("A 3D scan with its body fitting beside it (NAME.pose.json or pose.json), seen by virtual depth cameras").clicked() {
                out.push(Command::AskPath(PathPurpose::OpenScan));
            }
            if ui.button("Open demo capture").clicked() {
                out.push(Command::OpenCapture(DEMO.into()));
            }
            ui.menu_button("Recent captures", |ui| {
                if app.settings.recent_captures.is_empty() {
                    ui.weak("none yet");
                }
                for r in &app.settings.recent_captures {
                    if ui.button(r).clicked() {
                        out.push(Command::OpenCapture(r.clone()));
                    }
                }
            });
            ui.separator();
            if ui.button("Open project…").clicked() {
                out.push(Command::AskPath(PathPurpose::OpenProject));
            }
            ui.menu_button("Recent projects", |ui| {
                if app.settings.recent_projects.is_empty() {
                    ui.weak("none yet");
                }
                for r in &app.settings.recent_projects {
                    if ui.button(r).clicked() {
                        out.push(Command::OpenProject(PathBuf::from(r)));
                    }
                }
            });
            if ui.button("Save project (Ctrl+S)").clicked() {
                out.push(Command::SaveProjectHere);
            }
            if ui.button("Save project as…").clicked() {
                out.push(Command::AskPath(PathPurpose::SaveProject));
            }
            ui.separator();
            if ui.button("Open avatar…").clicked() {
                out.push(Command::AskPath(PathPurpose::OpenAvatar));
            }
            if ui.add_enabled(app.avatar.is_some(), egui::Button::new("Save avatar…")).clicked() {
                out.push(Command::AskPath(PathPurpose::SaveAvatar));
            }
            ui.separator();
            if ui.button("Screenshot (P)").clicked() {
                out.push(Command::Screenshot);
            }
        });
        ui.menu_button("View", |ui| {
            for (mode, label) in [(ViewMode::Capture, "Depth points"), (ViewMode::Canonical, "Canonical mesh"), (ViewMode::Posed, "Posed avatar")] {
                if ui.selectable_label(app.view.mode == mode, label).clicked() {
                    out.push(Command::SetMode(mode));
                }
            }
            if ui.checkbox(&mut app.view.skeleton, "Skeleton").changed() {
                out.push(Command::SceneChanged);
            }
            ui.separator();
            ui.radio_value(&mut app.view.shading, Shading::Lit, "Shaded");
            ui.radio_value(&mut app.view.shading, Shading::Normals, "Normals");
            if ui.button("Frame subject (F)").clicked() {
                out.push(Command::FrameSubject);
            }
            for p in Preset::ALL {
                if ui.button(format!("{} view", p.label())).clicked() {
                    out.push(Command::CameraPreset(p));
                }
            }
            ui.checkbox(&mut app.turntable, "Turntable (T)");
            let mut follow = app.view.follow_root;
            if ui.checkbox(&mut follow, "Follow the root").changed() {
                out.push(Command::FollowRoot(follow));
            }
        });
        ui.menu_button("Help", |ui| {
            if ui.button("Shortcuts (?)").clicked() {
                app.show_shortcuts = true;
            }
        });
    });
}

fn status_bar(app: &StudioApp, ui: &mut egui::Ui) {
    ui.horizontal(|ui| {
        match &app.status {
            Some(Status::Info(m)) => {
                ui.label(egui::RichText::new(m).small());
            }
            Some(Status::Error(m)) => {
                ui.label(egui::RichText::new(format!("Error: {m}")).small().color(ERROR));
            }
            None => {
                ui.label(egui::RichText::new("Ready").small());
            }
        }
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            if app.busy() {
                ui.spinner();
            }
            if let Some(s) = app.last_request_to_mesh.filter(|_| app.show_timings) {
                ui.label(egui::RichText::new(format!("pose {:.0} ms", s * 1000.0)).small().weak());
            }
        });
    });
}
