//! The studio's panels: menu bar, capture (left), avatar / fine-tuning / pose / export
//! (right), timeline (bottom), viewport (centre). Each is a small function over the app.

use crate::studio::app::{Status, StudioApp};
use crate::studio::avatar_job::{AvatarKind, FitConfig};
use crate::studio::project::{ViewMode, DEMO, PROJECT_EXTENSION};
use crate::studio::style::{self, ACCENT, ERROR, WARN};
use crate::studio::timeline::{joint_controls, timeline_bar};
use crate::studio::viewport::{self, Shading};
use eframe::egui;
use std::path::PathBuf;

pub fn draw(app: &mut StudioApp, ui: &mut egui::Ui) {
    handle_keys(app, ui.ctx());
    handle_drops(app, ui.ctx());
    egui::Panel::top("menu").show(ui, |ui| menu_bar(app, ui));
    egui::Panel::bottom("status").show(ui, |ui| status_bar(app, ui));
    egui::Panel::bottom("timeline").show(ui, |ui| {
        ui.add_space(3.0);
        let a = timeline_bar(ui, &mut app.timeline);
        if a.changed {
            app.pose_needed = true;
        }
        if let Some(name) = a.library {
            app.load_motion(&name);
        }
        if a.open_file {
            if let Some(p) = app.dialogs.pick_file("Open a motion", ("Motion", &["json", "npz", "bvh"])) {
                app.load_motion(&p.display().to_string());
            }
        }
        ui.add_space(1.0);
    });
    egui::Panel::left("capture").resizable(true).default_size(214.0).max_size(420.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| capture_panel(app, ui));
    });
    egui::Panel::right("avatar").resizable(true).default_size(280.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| {
            avatar_panel(app, ui);
            ui.separator();
            fit_panel(app, ui);
            ui.separator();
            pose_panel(app, ui);
            ui.separator();
            export_panel(app, ui);
        });
    });
    egui::CentralPanel::no_frame().show(ui, |ui| viewport_panel(app, ui));
}

fn handle_keys(app: &mut StudioApp, ctx: &egui::Context) {
    if ctx.egui_wants_keyboard_input() {
        return;
    }
    // Consumed here, before any widget runs, so that a focused button does not also see them.
    let (space, prev, next, frame, shot) = ctx.input_mut(|i| {
        let none = egui::Modifiers::NONE;
        (i.consume_key(none, egui::Key::Space), i.consume_key(none, egui::Key::Comma), i.consume_key(none, egui::Key::Period), i.consume_key(none, egui::Key::F), i.consume_key(none, egui::Key::P))
    });
    if space {
        app.timeline.playing = !app.timeline.playing;
    }
    if prev || next {
        app.timeline.step(if prev { -1 } else { 1 });
        app.pose_needed = true;
    }
    if frame {
        app.frame_subject();
    }
    if shot {
        app.screenshot_viewport();
    }
}

fn handle_drops(app: &mut StudioApp, ctx: &egui::Context) {
    let dropped: Vec<PathBuf> = ctx.input(|i| i.raw.dropped_files.iter().map(|f| f.path().to_path_buf()).filter(|p| !p.as_os_str().is_empty()).collect());
    for p in dropped {
        open_path(app, p);
    }
}

/// Open whatever a path is: a capture folder (or its capture.json), a project, an avatar or a
/// motion file.
pub fn open_path(app: &mut StudioApp, p: PathBuf) {
    {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("").to_string();
        if p.is_dir() || name == "capture.json" {
            app.open_capture(p.display().to_string());
        } else if name.ends_with(PROJECT_EXTENSION) {
            app.open_project(&p);
        } else if name.ends_with(".avatar") {
            app.open_avatar(&p);
        } else if name.ends_with(".json") || name.ends_with(".npz") {
            app.load_motion(&p.display().to_string());
        } else if !p.exists() {
            app.fail(format!("{}: no such file or folder", p.display()));
        } else {
            app.fail(format!("{}: not a capture folder, project, avatar or motion", p.display()));
        }
    }
}

fn menu_bar(app: &mut StudioApp, ui: &mut egui::Ui) {
    egui::MenuBar::new().ui(ui, |ui| {
        ui.label(egui::RichText::new("Avatar Studio").strong().color(ACCENT));
        ui.separator();
        ui.menu_button("File", |ui| {
            if ui.button("Open capture folder…").clicked() {
                if let Some(p) = app.dialogs.pick_folder("Open a capture folder") {
                    app.open_capture(p.display().to_string());
                }
            }
            if ui.button("Open demo capture").clicked() {
                app.open_capture(DEMO.into());
            }
            ui.menu_button("Recent captures", |ui| {
                if app.settings.recent_captures.is_empty() {
                    ui.weak("none yet");
                }
                for r in app.settings.recent_captures.clone() {
                    if ui.button(&r).clicked() {
                        app.open_capture(r);
                    }
                }
            });
            ui.separator();
            if ui.button("Open project…").clicked() {
                if let Some(p) = app.dialogs.pick_file("Open a project", ("Studio project", &["json"])) {
                    app.open_project(&p);
                }
            }
            ui.menu_button("Recent projects", |ui| {
                if app.settings.recent_projects.is_empty() {
                    ui.weak("none yet");
                }
                for r in app.settings.recent_projects.clone() {
                    if ui.button(&r).clicked() {
                        app.open_project(std::path::Path::new(&r));
                    }
                }
            });
            if ui.button("Save project…").clicked() {
                if let Some(p) = app.dialogs.save_file("Save the project", "session.studio.json", ("Studio project", &["json"])) {
                    app.save_project_to(&p);
                }
            }
            ui.separator();
            if ui.button("Open avatar…").clicked() {
                if let Some(p) = app.dialogs.pick_file("Open an avatar", ("Avatar", &["avatar"])) {
                    app.open_avatar(&p);
                }
            }
            if ui.add_enabled(app.avatar.is_some(), egui::Button::new("Save avatar…")).clicked() {
                if let Some(p) = app.dialogs.save_file("Save the avatar", "avatar.avatar", ("Avatar", &["avatar"])) {
                    app.save_avatar_to(&p);
                }
            }
            ui.separator();
            if ui.button("Screenshot (P)").clicked() {
                app.screenshot_viewport();
            }
        });
        ui.menu_button("View", |ui| {
            for (mode, label) in [(ViewMode::Capture, "Depth points"), (ViewMode::Canonical, "Canonical mesh"), (ViewMode::Posed, "Posed avatar")] {
                if ui.selectable_label(app.view.mode == mode, label).clicked() {
                    app.set_mode(mode);
                }
            }
            if ui.checkbox(&mut app.view.skeleton, "Skeleton").changed() {
                app.scene_dirty = true;
            }
            ui.separator();
            ui.radio_value(&mut app.view.shading, Shading::Lit, "Shaded");
            ui.radio_value(&mut app.view.shading, Shading::Normals, "Normals");
            if ui.button("Frame subject (F)").clicked() {
                app.frame_subject();
            }
        });
    });
}

fn status_bar(app: &mut StudioApp, ui: &mut egui::Ui) {
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

fn capture_panel(app: &mut StudioApp, ui: &mut egui::Ui) {
    style::heading(ui, "Capture");
    ui.horizontal(|ui| {
        if ui.button("Open…").on_hover_text("Open a capture folder (or drop it on the window)").clicked() {
            if let Some(p) = app.dialogs.pick_folder("Open a capture folder") {
                app.open_capture(p.display().to_string());
            }
        }
        if ui.button("Demo").on_hover_text("The embedded demo capture").clicked() {
            app.open_capture(DEMO.into());
        }
    });
    ui.horizontal(|ui| {
        let field = ui.add(egui::TextEdit::singleline(&mut app.path_field).hint_text("or type a folder path").desired_width(ui.available_width() - 40.0));
        let go = ui.add_enabled(!app.path_field.trim().is_empty(), egui::Button::new("Go")).on_hover_text("Open the capture folder, project, avatar or motion at this path");
        if go.clicked() || (field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) && !app.path_field.trim().is_empty()) {
            let p = PathBuf::from(app.path_field.trim());
            open_path(app, p);
        }
    });
    if let Some((src, _)) = &app.loading {
        ui.horizontal(|ui| {
            ui.spinner();
            ui.label(format!("Opening {}…", if src == DEMO { "the demo" } else { src }));
        });
    }
    if let Some(e) = app.error.clone() {
        egui::Frame::new().fill(egui::Color32::from_rgb(60, 28, 28)).corner_radius(4.0).inner_margin(6.0).show(ui, |ui| {
            ui.label(egui::RichText::new("Error").strong().color(ERROR));
            ui.label(egui::RichText::new(e).small());
            if ui.small_button("Dismiss").clicked() {
                app.error = None;
            }
        });
    }
    let Some(c) = app.capture.clone() else {
        ui.weak("No capture open. Open a folder with capture.json, drop one here, or use the demo.");
        return;
    };
    ui.label(egui::RichText::new(if app.capture_source.as_deref() == Some(DEMO) { "Demo capture".to_string() } else { c.name.clone() }).strong());
    ui.label(egui::RichText::new(format!("{} frames · {} usable · {} × {} px · {:.0} fps", c.frames.len(), c.usable(), c.manifest.intrinsics.width, c.manifest.intrinsics.height, c.fps)).small().weak());
    if c.flagged() > 0 {
        ui.label(egui::RichText::new(format!("{} frames flagged", c.flagged())).small().color(WARN));
    }
    ui.add_space(4.0);
    let size = 60.0;
    let cols = ((ui.available_width() + 4.0) / (size + 4.0)).floor().max(1.0) as usize;
    egui::Grid::new("thumbs").spacing([4.0, 4.0]).show(ui, |ui| {
        for (i, f) in c.frames.iter().enumerate() {
            let selected = app.view.selected_frame == i;
            let (rect, resp) = ui.allocate_exact_size(egui::vec2(size, size), egui::Sense::click());
            let painter = ui.painter_at(rect);
            painter.rect_filled(rect, 3.0, egui::Color32::from_rgb(14, 15, 18));
            if let Some(Some(tex)) = app.thumbnails.get(i) {
                let img_size = tex.size_vec2();
                let scale = (size - 4.0) / img_size.x.max(img_size.y);
                let r = egui::Rect::from_center_size(rect.center(), img_size * scale);
                painter.image(tex.id(), r, egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)), egui::Color32::WHITE);
            }
            let border = if f.problem.is_some() {
                egui::Stroke::new(2.0, ERROR)
            } else if selected {
                egui::Stroke::new(2.0, ACCENT)
            } else {
                egui::Stroke::new(1.0, egui::Color32::from_rgb(50, 53, 60))
            };
            painter.rect_stroke(rect, 3.0, border, egui::StrokeKind::Inside);
            painter.text(rect.left_bottom() + egui::vec2(4.0, -3.0), egui::Align2::LEFT_BOTTOM, format!("{}", f.index), egui::FontId::monospace(10.0), egui::Color32::from_white_alpha(200));
            if f.problem.is_some() {
                painter.text(rect.right_top() + egui::vec2(-4.0, 3.0), egui::Align2::RIGHT_TOP, "!", egui::FontId::proportional(13.0), ERROR);
            }
            let resp = match &f.problem {
                Some(p) => resp.on_hover_text(format!("Frame {} is not used: {p}", f.index)),
                None => resp.on_hover_text(format!("Frame {}: {} points", f.index, f.points.len())),
            };
            if resp.clicked() {
                app.view.selected_frame = i;
                app.set_mode(ViewMode::Capture);
                app.scene_dirty = true;
            }
            if (i + 1) % cols == 0 {
                ui.end_row();
            }
        }
    });
    let flagged: Vec<_> = c.frames.iter().filter_map(|f| f.problem.as_ref().map(|p| (f.index, f.file.clone(), p.clone()))).collect();
    if !flagged.is_empty() {
        ui.add_space(6.0);
        style::heading(ui, "Flagged frames");
        for (i, file, p) in flagged {
            ui.label(egui::RichText::new(format!("frame {i} ({}): {p}", file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())).small().color(WARN));
        }
    }
}

fn avatar_panel(app: &mut StudioApp, ui: &mut egui::Ui) {
    style::heading(ui, "Avatar");
    match &app.avatar {
        Some(a) => {
            ui.label(egui::RichText::new(a.describe()).strong());
            let where_ = match (&app.avatar_path, app.avatar_saved) {
                (Some(p), true) => p.display().to_string(),
                _ => "not saved".into(),
            };
            ui.label(egui::RichText::new(where_).small().weak());
            if ui.button("Save avatar…").on_hover_text("The .avatar file the command line reads too").clicked() {
                if let Some(p) = app.dialogs.save_file("Save the avatar", "avatar.avatar", ("Avatar", &["avatar"])) {
                    app.save_avatar_to(&p);
                }
            }
            if app.meshing.is_some() {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label("Meshing the SDF…");
                });
            }
        }
        None => {
            ui.weak("No avatar yet: fine-tune one below, or open a .avatar file. The body of the capture's fitting is shown meanwhile.");
            if app.meshing.is_some() {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label("Opening the avatar…");
                });
            }
        }
    }
}

fn fit_panel(app: &mut StudioApp, ui: &mut egui::Ui) {
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
                            *cfg = FitConfig::for_kind(kind);
                        }
                    }
                })
                .response
                .labelled_by(l.id);
            ui.end_row();
            let l = ui.label("Frames");
            ui.add(egui::DragValue::new(&mut cfg.frames).range(1..=64)).labelled_by(l.id);
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
            let l = ui.label(if cfg.kind == AvatarKind::MetaAvatar { "Points / pose" } else { "Points / step" });
            ui.add(egui::DragValue::new(&mut cfg.batch).range(100..=20000).speed(50.0)).labelled_by(l.id);
            ui.end_row();
        });
        ui.horizontal(|ui| {
            if ui.small_button("Quick (tiny)").clicked() {
                *cfg = match cfg.kind {
                    AvatarKind::MetaAvatar => FitConfig::tiny(),
                    AvatarKind::StaticSdf => FitConfig::tiny_static(),
                };
            }
            if ui.small_button("Default").clicked() {
                *cfg = FitConfig::for_kind(cfg.kind);
            }
        });
    });
    ui.horizontal(|ui| {
        if running {
            let cancelling = app.job.as_ref().is_some_and(|j| j.is_cancelling());
            if ui.add_enabled(!cancelling, egui::Button::new("Cancel")).clicked() {
                app.cancel_fit();
            }
        } else if ui.add_enabled(app.capture.is_some(), egui::Button::new(egui::RichText::new("Start fine-tuning").strong())).clicked() {
            app.start_fit(app.settings.fit.clone());
        }
    });
    let jv = &app.job_view;
    if running || !jv.losses.is_empty() {
        let left = jv.seconds_left().map(|s| format!(" · {} left", human_seconds(s))).unwrap_or_default();
        ui.add(egui::ProgressBar::new(jv.fraction()).text(format!("step {} / {}{left}", jv.step, jv.steps)).fill(egui::Color32::from_rgb(48, 98, 170)));
        ui.label(egui::RichText::new(format!("loss {:.4} · surface {:.4} · normal {:.3} · eikonal {:.3}", jv.loss, jv.terms[0], jv.terms[1], jv.terms[3])).small().monospace());
        if jv.points > 0 {
            ui.label(egui::RichText::new(format!("{} canonical points from {} frames", jv.points, jv.frames)).small().weak());
        }
        if let Some(s) = jv.preview_step {
            if running {
                ui.label(egui::RichText::new(format!("Partial result shown (step {s})")).small().color(WARN));
            }
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
    if s < 60.0 { format!("{s:.0} s") } else { format!("{}:{:02} min", (s / 60.0) as u64, (s % 60.0) as u64) }
}

fn pose_panel(app: &mut StudioApp, ui: &mut egui::Ui) {
    style::heading(ui, "Pose");
    ui.label(egui::RichText::new(format!("Clip {} · {} frames at {:.0} fps", app.timeline.clip.name, app.timeline.frames(), app.timeline.clip.fps)).small());
    let n = app.timeline.frames();
    let mut f = app.timeline.current_frame();
    if ui.add(egui::Slider::new(&mut f, 0..=n - 1).text("pose")).changed() {
        app.timeline.set_frame(f);
        app.timeline.playing = false;
        app.pose_needed = true;
    }
    egui::CollapsingHeader::new("Joints").default_open(false).show(ui, |ui| {
        if joint_controls(ui, &mut app.timeline) {
            app.pose_needed = true;
        }
    });
}

fn export_panel(app: &mut StudioApp, ui: &mut egui::Ui) {
    style::heading(ui, "Export");
    let has_avatar = app.avatar.is_some();
    ui.horizontal(|ui| {
        if ui.add_enabled(has_avatar && app.exporting.is_none(), egui::Button::new("Export glTF…")).on_hover_text("The avatar playing the clip: skin, morph targets and animation").clicked() {
            if let Some(p) = app.dialogs.save_file("Export animated glTF", &format!("{}.glb", app.timeline.clip.name), ("glTF binary", &["glb"])) {
                app.export_glb_to(p);
            }
        }
        if ui.add_enabled(app.posed.is_some(), egui::Button::new("Export OBJ…")).on_hover_text("The mesh on screen at the current pose").clicked() {
            if let Some(p) = app.dialogs.save_file("Export the posed mesh", "pose.obj", ("OBJ", &["obj"])) {
                app.export_obj_to(&p);
            }
        }
    });
    if app.exporting.is_some() {
        ui.horizontal(|ui| {
            ui.spinner();
            ui.label("Exporting…");
        });
    }
}

fn viewport_panel(app: &mut StudioApp, ui: &mut egui::Ui) {
    let rect = ui.available_rect_before_wrap();
    let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
    if app.view.camera.handle_input(ui, &response) {
        app.framed = true;
    }
    if response.double_clicked() {
        app.frame_subject();
    }
    app.viewport_rect = Some(rect);
    let cam = app.view.camera.matrices(rect.width() / rect.height().max(1.0));
    viewport::paint(ui, rect, app.scene.clone(), cam, app.view.shading, app.settings.point_size);
    // Toolbar over the viewport.
    let mut bar = ui.new_child(egui::UiBuilder::new().max_rect(rect.shrink(8.0)).layout(egui::Layout::left_to_right(egui::Align::TOP)));
    egui::Frame::new().fill(egui::Color32::from_rgba_unmultiplied(24, 26, 30, 225)).corner_radius(5.0).inner_margin(4.0).show(&mut bar, |ui| {
        ui.set_max_width(rect.width() - 24.0);
        ui.horizontal_wrapped(|ui| {
            for (mode, label, tip) in [
                (ViewMode::Capture, "Depth points", "The selected frame's back-projected points and fitted body"),
                (ViewMode::Canonical, "Canonical", "The avatar's canonical SDF mesh"),
                (ViewMode::Posed, "Posed", "The avatar at the timeline's pose"),
            ] {
                if ui.selectable_label(app.view.mode == mode, label).on_hover_text(tip).clicked() {
                    app.set_mode(mode);
                }
            }
            ui.separator();
            if ui.selectable_label(app.view.skeleton, "Skeleton").clicked() {
                app.view.skeleton = !app.view.skeleton;
                app.scene_dirty = true;
            }
            ui.separator();
            ui.selectable_value(&mut app.view.shading, Shading::Lit, "Shaded");
            ui.selectable_value(&mut app.view.shading, Shading::Normals, "Normals");
            ui.separator();
            if ui.button("Frame").on_hover_text("Frame the subject (F)").clicked() {
                app.frame_subject();
            }
        });
    });
    // Info over the viewport's lower left corner.
    let info = scene_info(app);
    ui.painter().text(rect.left_bottom() + egui::vec2(10.0, -8.0), egui::Align2::LEFT_BOTTOM, info, egui::FontId::monospace(11.0), egui::Color32::from_white_alpha(150));
    if app.scene.is_empty() || (app.scene.indices.is_empty() && app.scene.points.is_empty()) {
        let flagged = (app.view.mode == ViewMode::Capture)
            .then(|| app.capture.as_ref().and_then(|c| c.frames.get(app.view.selected_frame)).and_then(|f| f.problem.as_ref().map(|p| format!("Frame {} is not used: {p}", f.index))))
            .flatten();
        let msg = if app.loading.is_some() {
            "Loading…".to_string()
        } else if let Some(f) = flagged {
            f
        } else if app.error.is_some() {
            "Nothing to show: see the error on the left".to_string()
        } else {
            "Nothing to show yet".to_string()
        };
        let galley = ui.painter().layout(msg, egui::FontId::proportional(15.0), egui::Color32::from_white_alpha(140), rect.width() - 60.0);
        ui.painter().galley(rect.center() - galley.size() / 2.0, galley, egui::Color32::WHITE);
    }
}

fn scene_info(app: &StudioApp) -> String {
    let s = &app.scene;
    let what = match app.view.mode {
        ViewMode::Capture => format!("frame {} · {} points", app.view.selected_frame, s.points.len()),
        ViewMode::Canonical => "canonical".to_string(),
        ViewMode::Posed => format!("{} · frame {}", app.timeline.clip.name, app.timeline.current_frame()),
    };
    format!("{what} · {} vertices · {} triangles", s.vertices.len(), s.indices.len() / 3)
}
