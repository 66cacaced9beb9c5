//! Settings kept between runs (eframe storage) and the native file dialogs (rfd, replaceable
//! in tests; the in-app dialog in `path_dialog.rs` stands in where they are missing).

use crate::studio::fit_config::FitConfig;
use crate::studio::viewport::Shading;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

pub const SETTINGS_KEY: &str = "avatar-studio-settings";
const MAX_RECENT: usize = 8;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    pub recent_captures: Vec<String>,
    pub recent_projects: Vec<String>,
    pub fit: FitConfig,
    pub shading: Shading,
    pub point_size: f32,
    pub skeleton: bool,
    /// The avatar's material colour and the key light (linear RGB; view-space direction).
    pub material: [f32; 3],
    pub light: [f32; 3],
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            recent_captures: Vec::new(),
            recent_projects: Vec::new(),
            fit: FitConfig::default(),
            shading: Shading::Lit,
            point_size: 3.0,
            skeleton: false,
            material: avatar_core::export::DEFAULT_COLOR,
            light: crate::studio::project::default_light(),
        }
    }
}

impl Settings {
    pub fn push_recent(list: &mut Vec<String>, item: &str) {
        list.retain(|s| s != item);
        list.insert(0, item.to_string());
        list.truncate(MAX_RECENT);
    }
}

/// What a path is asked for: the dialog's title, kind, default name and filter, and the
/// command its answer becomes (`commands::Command::answer`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathPurpose {
    OpenCapture,
    /// An OBJ scan, opened as a capture (`studio::scan`).
    OpenScan,
    OpenProject,
    SaveProject,
    OpenAvatar,
    SaveAvatar,
    OpenMotion,
    ExportGlb,
    ExportObj,
}

/// What kind of path a dialog returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathKind {
    Folder,
    OpenFile,
    SaveFile,
}

/// One path request, as the native and the in-app dialogs show it.
#[derive(Debug, Clone, PartialEq)]
pub struct PathRequest {
    pub purpose: PathPurpose,
    pub title: &'static str,
    pub kind: PathKind,
    /// The file name proposed when saving.
    pub default_name: String,
    /// (label, extensions)
    pub filter: (&'static str, &'static [&'static str]),
}

/// A dialog's answer.
#[derive(Debug, Clone, PartialEq)]
pub enum DialogAnswer {
    Chosen(PathBuf),
    Cancelled,
    /// No native dialog on this system (no XDG portal, no zenity) or it failed: the studio
    /// shows its own.
    Unavailable,
}

/// File dialogs. The studio uses rfd; tests answer with fixed paths or disable them.
pub trait Dialogs {
    fn ask(&mut self, request: &PathRequest) -> DialogAnswer;
}

/// The native dialogs (rfd). `AVATAR_STUDIO_NATIVE_DIALOGS=0` turns them off.
pub struct RfdDialogs;

impl Dialogs for RfdDialogs {
    fn ask(&mut self, r: &PathRequest) -> DialogAnswer {
        if std::env::var_os("AVATAR_STUDIO_NATIVE_DIALOGS").is_some_and(|v| v == "0") {
            return DialogAnswer::Unavailable;
        }
        let t = std::time::Instant::now();
        let d = rfd::FileDialog::new().set_title(r.title);
        let chosen = match r.kind {
            PathKind::Folder => d.pick_folder(),
            PathKind::OpenFile => d.add_filter(r.filter.0, r.filter.1).pick_file(),
            PathKind::SaveFile => {
                d.set_file_name(&r.default_name).add_filter(r.filter.0, r.filter.1).save_file()
            }
        };
        match chosen {
            Some(p) => DialogAnswer::Chosen(p),
            // Without a portal rfd returns at once with nothing (and logs); no person cancels
            // a dialog that fast.
            None if t.elapsed() < std::time::Duration::from_millis(400) => {
                DialogAnswer::Unavailable
            }
            None => DialogAnswer::Cancelled,
        }
    }
}

/// No native dialogs (tests of the in-app dialog, systems where they misbehave).
pub struct NoDialogs;

impl Dialogs for NoDialogs {
    fn ask(&mut self, _request: &PathRequest) -> DialogAnswer {
        DialogAnswer::Unavailable
    }
}

/// Answers every dialog with the next queued path (Cancelled when the queue is empty): for tests.
#[derive(Default)]
pub struct ScriptedDialogs {
    pub answers: std::collections::VecDeque<PathBuf>,
}

impl ScriptedDialogs {
    pub fn new(answers: impl IntoIterator<Item = PathBuf>) -> ScriptedDialogs {
        ScriptedDialogs { answers: answers.into_iter().collect() }
    }
}

impl Dialogs for ScriptedDialogs {
    fn ask(&mut self, _request: &PathRequest) -> DialogAnswer {
        self.answers.pop_front().map_or(DialogAnswer::Cancelled, DialogAnswer::Chosen)
    }
}

impl PathPurpose {
    /// The request shown for this purpose; `default_name` is proposed when saving.
    pub fn request(self, default_name: impl Into<String>) -> PathRequest {
        use PathKind::*;
        let (title, kind, filter): (
            &'static str,
            PathKind,
            (&'static str, &'static [&'static str]),
        ) = match self {
            PathPurpose::OpenCapture => ("Open a capture folder", Folder, ("Capture folder", &[])),
            PathPurpose::OpenScan => ("Open a 3D scan", OpenFile, ("OBJ scan", &["obj"])),
            PathPurpose::OpenProject => ("Open a project", OpenFile, ("Studio project", &["json"])),
            PathPurpose::SaveProject => {
                ("Save the project", SaveFile, ("Studio project", &["json"]))
            }
            PathPurpose::OpenAvatar => ("Open an avatar", OpenFile, ("Avatar", &["avatar"])),
            PathPurpose::SaveAvatar => ("Save the avatar", SaveFile, ("Avatar", &["avatar"])),
            PathPurpose::OpenMotion => {
                ("Open a motion", OpenFile, ("Motion", &["json", "npz", "bvh"]))
            }
            PathPurpose::ExportGlb => ("Export animated glTF", SaveFile, ("glTF binary", &["glb"])),
            PathPurpose::ExportObj => ("Export the posed mesh", SaveFile, ("OBJ", &["obj"])),
        };
        PathRequest { purpose: self, title, kind, default_name: default_name.into(), filter }
    }
}
