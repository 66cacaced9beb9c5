//! The studio's own path dialog, shown when the native one is unavailable (no XDG portal, no
//! zenity) or fails: a folder field, the folder's listing (folders first, then the files the
//! request's filter admits) and, when saving, a file name that starts as the default name.

use crate::error::StudioError;
use crate::studio::settings::{PathKind, PathRequest};
use eframe::egui;
use std::path::{Path, PathBuf};

/// The dialog's answer, once the user has chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum PathDialogOutcome {
    Chosen(PathBuf),
    Cancelled,
}

pub struct PathDialog {
    pub request: PathRequest,
    /// The folder listed.
    pub folder: PathBuf,
    /// The folder field (typed paths are applied with Enter or "Go").
    pub folder_field: String,
    /// The file name (save) or the selected entry (open).
    pub name: String,
    entries: Vec<Entry>,
    listing_error: Option<String>,
    /// Why the last answer was refused (shown in the dialog).
    pub problem: Option<String>,
}

struct Entry {
    name: String,
    dir: bool,
}

impl PathDialog {
    pub fn new(request: PathRequest, folder: PathBuf) -> PathDialog {
        let name = if request.kind == PathKind::SaveFile {
            request.default_name.clone()
        } else {
            String::new()
        };
        let mut d = PathDialog {
            request,
            folder: PathBuf::new(),
            folder_field: String::new(),
            name,
            entries: Vec::new(),
            listing_error: None,
            problem: None,
        };
        d.go_to(folder);
        d
    }

    /// List another folder.
    pub fn go_to(&mut self, folder: PathBuf) {
        self.folder_field = folder.display().to_string();
        self.folder = folder;
        self.problem = None;
        match list(&self.folder, self.request.filter.1, self.request.kind == PathKind::Folder) {
            Ok(e) => {
                self.entries = e;
                self.listing_error = None;
            }
            Err(e) => {
                self.entries.clear();
                self.listing_error = Some(format!("Cannot list {}: {e}", self.folder.display()));
            }
        }
    }

    /// The path the dialog would answer now, or why it cannot answer.
    pub fn answer(&self) -> crate::error::Result<PathBuf> {
        let name = self.name.trim();
        match self.request.kind {
            PathKind::Folder => {
                Ok(if name.is_empty() { self.folder.clone() } else { self.folder.join(name) })
            }
            PathKind::OpenFile | PathKind::SaveFile if name.is_empty() => {
                Err(StudioError::invalid("Type a file name or pick one from the list"))
            }
            PathKind::OpenFile => {
                let p = self.folder.join(name);
                if p.is_file() { Ok(p) } else { Err(StudioError::file(&p, "no such file")) }
            }
            PathKind::SaveFile => {
                let p = self.folder.join(name);
                if !self.folder.is_dir() {
                    Err(StudioError::file(&self.folder, "no such folder"))
                } else if p.is_dir() {
                    Err(StudioError::invalid(format!("{} is a folder", p.display())))
                } else {
                    Ok(p)
                }
            }
        }
    }

    /// Draw the dialog (a modal window); returns the outcome once the user has chosen.
    pub fn show(&mut self, ctx: &egui::Context) -> Option<PathDialogOutcome> {
        let mut outcome = None;
        let modal = egui::Modal::new(egui::Id::unique("path dialog")).show(ctx, |ui| {
            ui.set_width(460.0);
            ui.heading(self.request.title);
            ui.horizontal(|ui| {
                let l = ui.label("Folder");
                let field = ui
                    .add(egui::TextEdit::singleline(&mut self.folder_field).desired_width(300.0))
                    .labelled_by(l.id);
                let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
                if ui.button("Go").clicked() || enter {
                    self.go_to(PathBuf::from(self.folder_field.trim()));
                }
                if ui
                    .add_enabled(self.folder.parent().is_some(), egui::Button::new("Up"))
                    .on_hover_text("The parent folder")
                    .clicked()
                    && let Some(p) = self.folder.parent()
                {
                    self.go_to(p.to_path_buf());
                }
            });
            if let Some(e) = &self.listing_error {
                ui.colored_label(crate::studio::style::ERROR, e);
            }
            let mut go = None;
            let mut pick = None;
            egui::ScrollArea::vertical().max_height(220.0).auto_shrink([false, false]).show(
                ui,
                |ui| {
                    if self.entries.is_empty() && self.listing_error.is_none() {
                        ui.weak(if self.request.kind == PathKind::Folder {
                            "No folders here"
                        } else {
                            "No matching files here"
                        });
                    }
                    for e in &self.entries {
                        let label =
                            if e.dir { format!("[folder] {}", e.name) } else { e.name.clone() };
                        let r = ui.selectable_label(!e.dir && self.name == e.name, label);
                        if r.clicked() {
                            if e.dir {
                                go = Some(self.folder.join(&e.name))
                            } else {
                                pick = Some((e.name.clone(), r.double_clicked()))
                            }
                        }
                        if r.double_clicked() && !e.dir {
                            pick = Some((e.name.clone(), true));
                        }
                    }
                },
            );
            if let Some(f) = go {
                self.go_to(f);
            }
            let mut accept = false;
            if let Some((name, double)) = pick {
                self.name = name;
                accept = double;
            }
            if self.request.kind != PathKind::Folder {
                ui.horizontal(|ui| {
                    let l = ui.label("File name");
                    let r = ui
                        .add(egui::TextEdit::singleline(&mut self.name).desired_width(300.0))
                        .labelled_by(l.id);
                    accept |= r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
                });
            }
            if let Ok(p) = self.answer()
                && self.request.kind == PathKind::SaveFile
                && p.exists()
            {
                ui.colored_label(
                    crate::studio::style::WARN,
                    format!("{} exists and will be replaced", p.display()),
                );
            }
            if let Some(p) = &self.problem {
                ui.colored_label(crate::studio::style::ERROR, p);
            }
            ui.separator();
            ui.horizontal(|ui| {
                let verb = match self.request.kind {
                    PathKind::Folder => "Open this folder",
                    PathKind::OpenFile => "Open",
                    PathKind::SaveFile => "Save",
                };
                accept |= ui.button(verb).clicked();
                if ui.button("Cancel").clicked() {
                    outcome = Some(PathDialogOutcome::Cancelled);
                }
            });
            if accept {
                match self.answer() {
                    Ok(p) => outcome = Some(PathDialogOutcome::Chosen(p)),
                    Err(e) => self.problem = Some(e.to_string()),
                }
            }
        });
        if modal.should_close() && outcome.is_none() {
            outcome = Some(PathDialogOutcome::Cancelled);
        }
        outcome
    }
}

/// Folders first, then files with one of `extensions` (all files when empty); hidden entries
/// are left out; each group sorted by name.
fn list(folder: &Path, extensions: &[&str], folders_only: bool) -> std::io::Result<Vec<Entry>> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(folder)? {
        let Ok(e) = e else { continue };
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue;
        }
        let dir = e.path().is_dir();
        let admitted = dir
            || (!folders_only
                && (extensions.is_empty()
                    || extensions
                        .iter()
                        .any(|x| name.to_ascii_lowercase().ends_with(&format!(".{x}")))));
        if admitted {
            out.push(Entry { name, dir });
        }
    }
    out.sort_by(|a, b| {
        b.dir.cmp(&a.dir).then_with(|| a.name.to_lowercase().cmp(&b.name.to_lowercase()))
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studio::settings::PathPurpose;

    #[test]
    fn listing_filters_and_answers() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("captures")).unwrap();
        std::fs::write(dir.path().join("b.avatar"), b"x").unwrap();
        std::fs::write(dir.path().join("a.glb"), b"x").unwrap();
        std::fs::write(dir.path().join(".hidden.avatar"), b"x").unwrap();
        let d = PathDialog::new(PathPurpose::OpenAvatar.request(""), dir.path().to_path_buf());
        let names: Vec<_> = d.entries.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["captures", "b.avatar"]);
        assert!(d.answer().is_err(), "nothing picked yet");
        let mut s =
            PathDialog::new(PathPurpose::ExportGlb.request("walk.glb"), dir.path().to_path_buf());
        assert_eq!(s.answer().unwrap(), dir.path().join("walk.glb"));
        s.name = "captures".into();
        assert!(s.answer().unwrap_err().to_string().contains("is a folder"));
        let mut missing =
            PathDialog::new(PathPurpose::SaveAvatar.request("a.avatar"), dir.path().join("nope"));
        assert!(missing.listing_error.is_some());
        assert!(missing.answer().unwrap_err().to_string().contains("no such folder"));
        missing.go_to(dir.path().to_path_buf());
        assert!(missing.answer().is_ok());
    }
}
