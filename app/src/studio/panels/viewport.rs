//! The viewport panel: the 3D view (camera input, the scene painted by the wgpu renderer), its
//! toolbar (view modes, skeleton, shading, framing) and the
//! information in its corner.

use crate::studio::commands::Command;
use crate::studio::project::ViewMode;
use crate::studio::state::StudioApp;
use crate::studio::viewport::{self, Shading};
use eframe::egui;

pub fn viewport_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    let rect = ui.available_rect_before_wrap();
    let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
    if app.view.camera.handle_input(ui, &response) {
        app.turntable &= !response.dragged(); // grabbing the view stops the turntable
        app.framed = true;
    }
    if response.double_clicked() {
        out.push(Command::FrameSubject);
    }
    app.viewport_rect = Some(rect);
    let cam = app.view.camera.matrices(rect.width() / rect.height().max(1.0));
    // Playback, the turntable and an orbit redraw every frame: the renderer may then trade MSAA
    // for the frame rate (on a software renderer).
    app.viewport_moving = app.timeline.playing || app.turntable || response.dragged();
    viewport::paint(
        ui,
        rect,
        app.scene.clone(),
        cam,
        app.view.shading,
        app.settings.point_size,
        app.view.light,
        app.viewport_moving,
    );
    // Toolbar over the viewport.
    let mut bar = ui.new_child(
        egui::UiBuilder::new()
            .max_rect(rect.shrink(8.0))
            .layout(egui::Layout::left_to_right(egui::Align::TOP)),
    );
    egui::Frame::new()
        .fill(egui::Color32::from_rgba_unmultiplied(24, 26, 30, 225))
        .corner_radius(5.0)
        .inner_margin(4.0)
        .show(&mut bar, |ui| {
            ui.set_max_width(rect.width() - 24.0);
            ui.horizontal_wrapped(|ui| {
                for (mode, label, tip) in [
                    (
                        ViewMode::Capture,
                        "Depth points",
                        "The selected frame's back-projected points and fitted body",
                    ),
                    (ViewMode::Canonical, "Canonical", "The avatar's canonical SDF mesh"),
                    (ViewMode::Posed, "Posed", "The avatar at the timeline's pose"),
                ] {
                    if ui
                        .selectable_label(app.view.mode == mode, label)
                        .on_hover_text(tip)
                        .clicked()
                    {
                        out.push(Command::SetMode(mode));
                    }
                }
                ui.separator();
                if ui.selectable_label(app.view.skeleton, "Skeleton").clicked() {
                    app.view.skeleton = !app.view.skeleton;
                    out.push(Command::SceneChanged);
                }
                ui.separator();
                ui.selectable_value(&mut app.view.shading, Shading::Lit, "Shaded");
                ui.selectable_value(&mut app.view.shading, Shading::Normals, "Normals");
                ui.separator();
                if ui.button("Frame").on_hover_text("Frame the subject (F)").clicked() {
                    out.push(Command::FrameSubject);
                }
                let follow = app.view.follow_root;
                if ui
                    .selectable_label(follow, "Follow")
                    .on_hover_text("The camera follows the body's root over the floor (posed view)")
                    .clicked()
                {
                    out.push(Command::FollowRoot(!follow));
                }
            });
        });
    // Info over the viewport's lower left corner.
    let info = scene_info(app);
    ui.painter().text(
        rect.left_bottom() + egui::vec2(10.0, -8.0),
        egui::Align2::LEFT_BOTTOM,
        info,
        egui::FontId::monospace(11.0),
        egui::Color32::from_white_alpha(150),
    );
    if app.scene.is_empty() || (app.scene.indices.is_empty() && app.scene.points.is_empty()) {
        let flagged = (app.view.mode == ViewMode::Capture)
            .then(|| {
                let i = app.view.selected_frame;
                app.frame_store.problem(i).map(|p| format!("Frame {i} is not used: {p}"))
            })
            .flatten();
        let msg = if app.loading().is_some() {
            "Loading…".to_string()
        } else if let Some(f) = flagged {
            f
        } else if app.error.is_some() {
            "Nothing to show: see the error on the left".to_string()
        } else {
            "Nothing to show yet".to_string()
        };
        let galley = ui.painter().layout(
            msg,
            egui::FontId::proportional(15.0),
            egui::Color32::from_white_alpha(140),
            rect.width() - 60.0,
        );
        ui.painter().galley(rect.center() - galley.size() / 2.0, galley, egui::Color32::WHITE);
    }
}

fn scene_info(app: &StudioApp) -> String {
    let s = &app.scene;
    let what = match app.view.mode {
        ViewMode::Capture => {
            let frame = app.capture.as_ref().and_then(|c| c.frames.get(app.view.selected_frame));
            let refined = frame
                .and_then(|f| f.params.as_ref())
                .and_then(|given| Some((given, app.refined_fitting(given)?)));
            let note = match refined {
                Some((given, r)) => {
                    let (angle, trans) = avatar_core::body::pose_error(given, r);
                    format!(
                        " · body at the refined pose ({:.1}° per joint, {:.1} cm from the fitting)",
                        angle.to_degrees(),
                        trans * 100.0
                    )
                }
                None => String::new(),
            };
            format!("frame {} · {} points{note}", app.view.selected_frame, s.points.len())
        }
        ViewMode::Canonical => "canonical".to_string(),
        ViewMode::Posed => {
            format!("{} · frame {}", app.timeline.clip.name, app.timeline.current_frame())
        }
    };
    format!("{what} · {} vertices · {} triangles", s.vertices.len(), s.indices.len() / 3)
}
