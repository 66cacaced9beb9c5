//! The project file (`.studio.json`): the capture, the avatar, the view and the motion of a
//! session. Written atomically; paths are stored relative to the project file when they lie
//! beside it, so a project folder can be moved.

use crate::error::{Result, StudioError};
use crate::studio::camera::OrbitCamera;
use crate::studio::viewport::Shading;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub const PROJECT_FORMAT: &str = "avatar-studio-project";
pub const PROJECT_VERSION: u32 = 1;
pub const PROJECT_EXTENSION: &str = "studio.json";

/// What the viewport shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ViewMode {
    /// The depth points of the selected frame and its fitted body.
    Capture,
    /// The avatar's canonical (unposed) SDF mesh.
    Canonical,
    /// The avatar at the timeline's pose.
    Posed,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewState {
    pub mode: ViewMode,
    pub skeleton: bool,
    pub shading: Shading,
    pub camera: OrbitCamera,
    pub selected_frame: usize,
    /// The avatar's material colour (linear RGB): the viewport's and the exported glTF's.
    #[serde(default = "default_material")]
    pub material: [f32; 3],
    /// The key light's direction in view space (towards the light).
    #[serde(default = "default_light")]
    pub light: [f32; 3],
    /// The camera follows the posed body's root across the floor (root motion stays in view).
    #[serde(default)]
    pub follow_root: bool,
}

fn default_material() -> [f32; 3] {
    avatar_core::export::DEFAULT_COLOR
}

/// From the camera's upper left.
pub fn default_light() -> [f32; 3] {
    [-0.45, 0.6, 0.65]
}

impl Default for ViewState {
    fn default() -> Self {
        ViewState {
            mode: ViewMode::Posed,
            skeleton: false,
            shading: Shading::Lit,
            camera: OrbitCamera::default(),
            selected_frame: 0,
            material: default_material(),
            light: default_light(),
            follow_root: false,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotionState {
    /// A library clip name or a motion file.
    pub clip: String,
    pub frame: usize,
    pub speed: f32,
    #[serde(default)]
    pub offsets: Vec<[f32; 3]>,
    /// The timeline's range (first, last frame) that plays, bakes and exports; none: the clip.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<[usize; 2]>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Project {
    pub format: String,
    pub version: u32,
    /// The capture folder; "demo" = the embedded demo capture.
    pub capture: Option<String>,
    /// The avatar file (NAME.avatar), if one was fitted or opened.
    pub avatar: Option<String>,
    pub view: ViewState,
    pub motion: MotionState,
}

pub const DEMO: &str = "demo";

impl Project {
    pub fn new(
        capture: Option<String>,
        avatar: Option<String>,
        view: ViewState,
        motion: MotionState,
    ) -> Project {
        Project {
            format: PROJECT_FORMAT.into(),
            version: PROJECT_VERSION,
            capture,
            avatar,
            view,
            motion,
        }
    }

    pub fn save(&self, path: &Path) -> Result<()> {
        let mut p = self.clone();
        let base = path.parent().unwrap_or(Path::new("."));
        p.capture = p.capture.map(|c| relative_to(&c, base));
        p.avatar = p.avatar.map(|a| relative_to(&a, base));
        let text =
            serde_json::to_string_pretty(&p).map_err(|e| StudioError::file(path, e.to_string()))?;
        avatar_core::io::write_bytes_atomic(path, text.as_bytes())?;
        Ok(())
    }

    pub fn load(path: &Path) -> Result<Project> {
        let text =
            std::fs::read_to_string(path).map_err(|e| StudioError::file(path, e.to_string()))?;
        let mut p: Project = serde_json::from_str(&text)
            .map_err(|e| StudioError::file(path, format!("not a studio project: {e}")))?;
        if p.format != PROJECT_FORMAT {
            return Err(StudioError::file(
                path,
                format!("not a studio project (format {:?})", p.format),
            ));
        }
        if p.version > PROJECT_VERSION {
            return Err(StudioError::file(
                path,
                format!(
                    "project version {} is newer than this build reads ({PROJECT_VERSION})",
                    p.version
                ),
            ));
        }
        let base = path.parent().unwrap_or(Path::new("."));
        p.capture = p.capture.map(|c| absolute_from(&c, base));
        p.avatar = p.avatar.map(|a| absolute_from(&a, base));
        Ok(p)
    }
}

fn relative_to(p: &str, base: &Path) -> String {
    if p == DEMO {
        return p.to_string();
    }
    let path = PathBuf::from(p);
    let base = base.canonicalize().unwrap_or_else(|_| base.to_path_buf());
    let abs = path.canonicalize().unwrap_or(path.clone());
    match abs.strip_prefix(&base) {
        Ok(rel) => rel.to_string_lossy().into_owned(),
        Err(_) => abs.to_string_lossy().into_owned(),
    }
}

fn absolute_from(p: &str, base: &Path) -> String {
    if p == DEMO {
        return p.to_string();
    }
    let path = PathBuf::from(p);
    if path.is_absolute() { p.to_string() } else { base.join(path).to_string_lossy().into_owned() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_round_trips_with_relative_paths() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("me.avatar"), b"x").unwrap();
        let avatar = dir.path().join("me.avatar").to_string_lossy().into_owned();
        let p = Project::new(
            Some(DEMO.into()),
            Some(avatar.clone()),
            ViewState::default(),
            MotionState {
                clip: "walk".into(),
                frame: 7,
                speed: 0.5,
                offsets: vec![],
                range: Some([3, 40]),
            },
        );
        let path = dir.path().join("session.studio.json");
        p.save(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\"me.avatar\""), "{text}");
        let back = Project::load(&path).unwrap();
        assert_eq!(back.motion, p.motion);
        assert_eq!(back.view, p.view);
        assert_eq!(
            PathBuf::from(back.avatar.unwrap()).canonicalize().unwrap(),
            PathBuf::from(avatar).canonicalize().unwrap()
        );
    }

    #[test]
    fn a_bad_project_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.studio.json");
        std::fs::write(&path, "{ not json").unwrap();
        let e = Project::load(&path).unwrap_err().to_string();
        assert!(e.contains("bad.studio.json"), "{e}");
    }
}
