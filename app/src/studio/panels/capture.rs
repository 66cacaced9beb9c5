//! The capture panel: open a capture (dialog, demo, typed path), the error box, the frames as
//! depth thumbnails with the flagged ones and their reasons.

use crate::studio::commands::Command;
use crate::studio::project::DEMO;
use crate::studio::settings::PathPurpose;
use crate::studio::state::StudioApp;
use crate::studio::style::{self, ACCENT, ERROR, WARN};
use eframe::egui;
use std::path::PathBuf;

pub fn capture_panel(app: &mut StudioApp, ui: &mut egui::Ui, out: &mut Vec<Command>) {
    style::heading(ui, "Capture");
    ui.horizontal(|ui| {
        if ui.button("Open…").on_hover_text("Open a capture folder (or drop it on the window)").clicked() {
            out.push(Command::AskPath(PathPurpose::OpenCapture));
        }
        if ui.button("Scan…").on_hover_text("Open a 3D scan (OBJ) with its body fitting beside it (NAME.pose.json or pose.json)").clicked() {
            out.push(Command::AskPath(PathPurpose::OpenScan));
        }
        if ui.button("Demo").on_hover_text("The embedded demo capture").clicked() {
            out.push(Command::OpenCapture(DEMO.into()));
        }
    });
    ui.horizontal(|ui| {
        let field = ui.add(
            egui::TextEdit::singleline(&mut app.path_field)
                .hint_text("or type a path")
                .desired_width(ui.available_width() - 40.0),
        );
        let go = ui
            .add_enabled(!app.path_field.trim().is_empty(), egui::Button::new("Go"))
            .on_hover_text("Open the capture folder, project, avatar or motion at this path");
        if go.clicked()
            || (field.lost_focus()
                && ui.input(|i| i.key_pressed(egui::Key::Enter))
                && !app.path_field.trim().is_empty())
        {
            out.push(Command::OpenPath(PathBuf::from(app.path_field.trim())));
        }
    });
    if let Some(src) = app.loading() {
        ui.horizontal(|ui| {
            ui.spinner();
            ui.label(format!("Opening {}…", if src == DEMO { "the demo" } else { src }));
        });
    }
    if let Some(e) = app.error.clone() {
        egui::Frame::new()
            .fill(egui::Color32::from_rgb(60, 28, 28))
            .corner_radius(4.0)
            .inner_margin(6.0)
            .show(ui, |ui| {
                ui.label(egui::RichText::new("Error").strong().color(ERROR));
                ui.label(egui::RichText::new(e).small());
                if ui.small_button("Dismiss").clicked() {
                    out.push(Command::DismissError);
                }
            });
    }
    let Some(c) = app.capture.clone() else {
        ui.weak(
            "No capture open. Open a folder with capture.json, drop one here, or use the demo.",
        );
        return;
    };
    ui.label(
        egui::RichText::new(if app.capture_source.as_deref() == Some(DEMO) {
            "Demo capture".to_string()
        } else {
            c.name.clone()
        })
        .strong(),
    );
    let (checked, usable) = (app.frame_store.checked(), app.frame_store.usable());
    let flagged_count = checked - usable;
    let usable = if checked == c.frames.len() {
        format!("{usable} usable")
    } else {
        format!("{usable} of {checked} checked usable")
    };
    ui.label(
        egui::RichText::new(format!(
            "{} frames · {usable} · {} × {} px · {:.0} fps",
            c.frames.len(),
            c.manifest.intrinsics.width,
            c.manifest.intrinsics.height,
            c.fps
        ))
        .small()
        .weak(),
    );
    if flagged_count > 0 {
        ui.label(
            egui::RichText::new(format!("{flagged_count} frames flagged")).small().color(WARN),
        );
    }
    ui.add_space(4.0);
    let size = 60.0;
    let cols = ((ui.available_width() + 4.0) / (size + 4.0)).floor().max(1.0) as usize;
    // The thumbnails' boxes, and on a software renderer their images (viewport::flat: one
    // callback for all), go into these slots below the borders and numbers.
    let grid_painter = ui.painter().clone();
    let (boxes_slot, images_slot) =
        (grid_painter.add(egui::Shape::Noop), grid_painter.add(egui::Shape::Noop));
    let (mut boxes, mut flat_images) = (Vec::new(), Vec::new());
    egui::Grid::new("thumbs").spacing([4.0, 4.0]).show(ui, |ui| {
        for (i, f) in c.frames.iter().enumerate() {
            let selected = app.view.selected_frame == i;
            let (rect, resp) = ui.allocate_exact_size(egui::vec2(size, size), egui::Sense::click());
            if (i + 1) % cols == 0 {
                ui.end_row();
            }
            if !ui.is_rect_visible(rect) {
                continue; // off screen: nothing read, nothing drawn
            }
            let painter = ui.painter_at(rect);
            let mut covered = false; // by an opaque square image: only the box's rim shows
            let problem = app.frame_store.problem(i).map(str::to_string);
            if let Some((tex, pixels)) = app.frame_store.thumbnail(i) {
                let img_size = tex.size_vec2();
                let scale = (size - 4.0) / img_size.x.max(img_size.y);
                let r = egui::Rect::from_center_size(rect.center(), img_size * scale);
                covered = app.flat && r.expand(0.01).contains_rect(rect.shrink(2.0));
                if app.flat {
                    flat_images.push(crate::studio::viewport::flat::FlatImage {
                        rect: r,
                        id: tex.id(),
                        pixels,
                    });
                } else {
                    painter.image(
                        tex.id(),
                        r,
                        egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                        egui::Color32::WHITE,
                    );
                }
            }
            // On a software renderer every pixel egui fills is dear (viewport/flat.rs): where
            // the image covers the box's inside, only its 2-point rim is drawn.
            let box_color = egui::Color32::from_rgb(14, 15, 18);
            boxes.push(if covered {
                egui::Shape::rect_stroke(
                    rect,
                    3.0,
                    egui::Stroke::new(2.0, box_color),
                    egui::StrokeKind::Inside,
                )
            } else {
                egui::Shape::rect_filled(rect, 3.0, box_color)
            });
            let border = if problem.is_some() {
                egui::Stroke::new(2.0, ERROR)
            } else if selected {
                egui::Stroke::new(2.0, ACCENT)
            } else {
                egui::Stroke::new(1.0, egui::Color32::from_rgb(50, 53, 60))
            };
            painter.rect_stroke(rect, 3.0, border, egui::StrokeKind::Inside);
            painter.text(
                rect.left_bottom() + egui::vec2(4.0, -3.0),
                egui::Align2::LEFT_BOTTOM,
                format!("{}", f.index),
                egui::FontId::monospace(10.0),
                egui::Color32::from_white_alpha(200),
            );
            if problem.is_some() {
                painter.text(
                    rect.right_top() + egui::vec2(-4.0, 3.0),
                    egui::Align2::RIGHT_TOP,
                    "!",
                    egui::FontId::proportional(13.0),
                    ERROR,
                );
            }
            let resp = match (&problem, app.frame_store.verdict(i)) {
                (Some(p), _) => resp.on_hover_text(format!("Frame {} is not used: {p}", f.index)),
                (None, Some(Ok(n))) => resp.on_hover_text(format!("Frame {}: {n} points", f.index)),
                (None, _) => resp.on_hover_text(format!("Frame {}: being read", f.index)),
            };
            if resp.clicked() {
                out.push(Command::SelectFrame(i));
            }
        }
    });
    grid_painter.set(boxes_slot, egui::Shape::Vec(boxes));
    if !flat_images.is_empty() {
        grid_painter.set(
            images_slot,
            crate::studio::viewport::flat::images(grid_painter.clip_rect(), flat_images),
        );
    }
    let flagged: Vec<_> = app
        .frame_store
        .flagged()
        .filter_map(|(i, p)| c.frames.get(i).map(|f| (i, f.file.clone(), p.to_string())))
        .collect();
    if !flagged.is_empty() {
        ui.add_space(6.0);
        style::heading(ui, "Flagged frames");
        // A long capture's list is cut (the thumbnails show every flagged frame).
        const LISTED: usize = 50;
        let more = flagged.len().saturating_sub(LISTED);
        for (i, file, p) in flagged.into_iter().take(LISTED) {
            ui.label(
                egui::RichText::new(format!(
                    "frame {i} ({}): {p}",
                    file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
                ))
                .small()
                .color(WARN),
            );
        }
        if more > 0 {
            ui.label(egui::RichText::new(format!("and {more} more")).small().color(WARN));
        }
    }
}
