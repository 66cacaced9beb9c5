//! Settings kept between runs (eframe storage) and the file dialogs (rfd, replaceable in
//! tests).

use crate::studio::avatar_job::FitConfig;
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
}

impl Default for Settings {
    fn default() -> Self {
        Settings { recent_captures: Vec::new(), recent_projects: Vec::new(), fit: FitConfig::default(), shading: Shading::Lit, point_size: 3.0, skeleton: false }
    }
}

impl Settings {
    pub fn push_recent(list: &mut Vec<String>, item: &str) {
        list.retain(|s| s != item);
        list.insert(0, item.to_string());
        list.truncate(MAX_RECENT);
    }
}

/// File dialogs. The studio uses rfd; tests answer with fixed paths.
pub trait Dialogs {
    fn pick_folder(&mut self, title: &str) -> Option<PathBuf>;
    fn pick_file(&mut self, title: &str, filter: (&str, &[&str])) -> Option<PathBuf>;
    fn save_file(&mut self, title: &str, default_name: &str, filter: (&str, &[&str])) -> Option<PathBuf>;
}

pub struct RfdDialogs;

impl Dialogs for RfdDialogs {
    fn pick_folder(&mut self, title: &str) -> Option<PathBuf> {
        rfd::FileDialog::new().set_title(title).pick_folder()
    }
    fn pick_file(&mut self, title: &str, filter: (&str, &[&str])) -> Option<PathBuf> {
        rfd::FileDialog::new().set_title(title).add_filter(filter.0, filter.1).pick_file()
    }
    fn save_file(&mut self, title: &str, default_name: &str, filter: (&str, &[&str])) -> Option<PathBuf> {
        rfd::FileDialog::new().set_title(title).set_file_name(default_name).add_filter(filter.0, filter.1).save_file()
    }
}

/// Answers every dialog with the next queued path (None when the queue is empty): for tests.
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
    fn pick_folder(&mut self, _title: &str) -> Option<PathBuf> {
        self.answers.pop_front()
    }
    fn pick_file(&mut self, _title: &str, _filter: (&str, &[&str])) -> Option<PathBuf> {
        self.answers.pop_front()
    }
    fn save_file(&mut self, _title: &str, _default_name: &str, _filter: (&str, &[&str])) -> Option<PathBuf> {
        self.answers.pop_front()
    }
}
