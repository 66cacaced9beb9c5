//! The studio's state: what is open (capture, avatar, fit), what runs in the background, the
//! timeline and the view. Panels read it and return [`Command`](crate::studio::commands::Command)s;
//! `commands.rs` changes it, `app.rs` polls the background work once per frame, `scene.rs`
//! turns it into the viewport's scene.

use crate::studio::avatar::{CanonicalMesh, StudioAvatar};
use crate::studio::avatar_job::FitJob;
use crate::studio::capture_view::LoadedCapture;
use crate::studio::fit_config::FitConfig;
use crate::studio::path_dialog::PathDialog;
use crate::studio::playback::Bakes;
use crate::studio::posing::{PoseWorker, PosedMesh};
use crate::studio::project::ViewState;
use crate::studio::settings::{Dialogs, Settings};
use crate::studio::tasks::Task;
use crate::studio::timeline::{LoadedClips, Timeline};
use crate::studio::viewport::Scene;
use avatar_core::body::{BodyModel, open_body_ref};
use eframe::egui;
use glam::Vec3;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// How the studio starts.
#[derive(Debug, Clone, Default)]
pub struct StudioOptions {
    /// Open the embedded demo capture at start.
    pub load_demo: bool,
    /// Open this capture folder (instead of the demo).
    pub capture: Option<PathBuf>,
    /// Open this project.
    pub project: Option<PathBuf>,
    /// Write a screenshot of the whole window here once the studio is idle, then exit.
    pub screenshot: Option<PathBuf>,
    /// When the process started (for the start-to-first-frame measurement).
    pub started: Option<Instant>,
    /// Print timings to stderr.
    pub timing: bool,
    /// Start this fine-tuning as soon as the capture is open (README screenshots).
    pub auto_fit: Option<FitConfig>,
    /// Measure playback in the window once idle, print it and close (`studio::measure`).
    pub measure_playback: bool,
}

/// An avatar loaded (or fitted) and meshed off the UI thread.
pub struct AvatarReady {
    pub avatar: Arc<dyn StudioAvatar>,
    pub path: Option<PathBuf>,
    pub mesh: Arc<CanonicalMesh>,
    /// Smooth normals of the mesh from the SDF's gradient at the rest pose.
    pub normals: Option<Arc<Vec<Vec3>>>,
}

/// A message in the status bar.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    Info(String),
    Error(String),
}

/// The fine-tuning panel's record of a job.
#[derive(Default)]
pub struct JobView {
    pub step: usize,
    pub steps: usize,
    pub loss: f32,
    pub terms: [f32; 4],
    pub elapsed_s: f64,
    /// The phase under way ("" before the first) and the fit's estimate of the time left.
    pub phase: &'static str,
    pub left_s: Option<f64>,
    /// (step, log10 loss)
    pub losses: Vec<[f64; 2]>,
    pub points: usize,
    pub frames: usize,
    pub preview_step: Option<usize>,
    pub finished: Option<String>,
}

impl JobView {
    pub fn fraction(&self) -> f32 {
        if self.steps == 0 { 0.0 } else { self.step as f32 / self.steps as f32 }
    }

    /// The fit's own estimate (its plan and each phase's measured cost), once it has one.
    pub fn seconds_left(&self) -> Option<f64> {
        self.left_s
    }
}

/// A capture being opened.
pub struct CaptureOpening {
    /// "demo" or a folder path.
    pub source: String,
    /// Opened by a project, with its avatar: the avatar is not closed when it opens.
    pub with_project: bool,
    pub task: Task<LoadedCapture>,
    /// When the opening began (`--timing`).
    pub started: Instant,
}

/// The background tasks the studio waits for, by name (fit, pose and bake have their own
/// wrappers: `FitJob`, `PoseWorker`, `Bakes`).
#[derive(Default)]
pub struct Tasks {
    /// Opening a capture ("demo" or a folder).
    pub capture: Option<CaptureOpening>,
    /// Opening or meshing an avatar.
    pub avatar: Option<Task<AvatarReady>>,
    /// Writing the animated glTF, and its last progress (frames made of all).
    pub export: Option<Task<String, avatar_core::export::Progress>>,
    pub export_progress: Option<avatar_core::export::Progress>,
}

pub struct StudioApp {
    pub(crate) ctx: egui::Context,
    pub(crate) options: StudioOptions,
    pub(crate) dialogs: Box<dyn Dialogs>,
    /// The native dialog failed once: ask with the in-app one from now on.
    pub(crate) native_dialogs_failed: bool,
    pub path_dialog: Option<PathDialog>,
    pub settings: Settings,
    pub(crate) tasks: Tasks,
    // Capture.
    pub capture: Option<Arc<LoadedCapture>>,
    /// "demo" or a folder path.
    pub capture_source: Option<String>,
    /// The capture's frames as read on demand: thumbnails, points, checks (bounded).
    pub frame_store: crate::studio::capture_frames::FrameStore,
    /// The panels' fill and the thumbnails are painted by `viewport::flat` (a software
    /// renderer), not by egui.
    pub(crate) flat: bool,
    pub(crate) body_rest: Option<Arc<CanonicalMesh>>,
    // Avatar.
    pub avatar: Option<Arc<dyn StudioAvatar>>,
    pub avatar_path: Option<PathBuf>,
    pub avatar_saved: bool,
    pub(crate) avatar_canonical: Option<Arc<CanonicalMesh>>,
    pub(crate) avatar_normals: Option<Arc<Vec<Vec3>>>,
    // Fine-tuning.
    pub job: Option<FitJob>,
    pub job_view: JobView,
    pub(crate) preview: Option<Arc<CanonicalMesh>>,
    // Posing and playback.
    pub(crate) poser: PoseWorker,
    pub posed: Option<Arc<PosedMesh>>,
    pub(crate) pose_needed: bool,
    pub last_pose_seconds: Option<f64>,
    pub(crate) pose_failed: Option<u64>,
    /// Poses requested before this id were for an avatar since closed: not shown.
    pub(crate) pose_floor: u64,
    pub(crate) pose_requested_at: Option<Instant>,
    pub last_request_to_mesh: Option<f64>,
    pub bakes: Bakes,
    // Timeline and view.
    pub timeline: Timeline,
    /// Motion files opened in the session (the clip list keeps them).
    pub loaded_clips: LoadedClips,
    pub view: ViewState,
    pub(crate) scene: Arc<Scene>,
    pub(crate) scene_dirty: bool,
    pub(crate) framed: bool,
    pub(crate) viewport_rect: Option<egui::Rect>,
    /// The camera turns around the subject.
    pub turntable: bool,
    /// The viewport redraws every frame (playing, turntable, orbiting): drawn without MSAA on a
    /// software renderer.
    pub viewport_moving: bool,
    /// The last frame's panels were painted by `viewport::ui_meshes` (the view moved, on a
    /// software renderer).
    pub ui_meshes_painted: bool,
    pub(crate) playback_measure: Option<PlaybackMeasure>,
    /// `--timing`: the last motion file's opening time (s), and when Play was pressed on it
    /// with that time (`measure::report_first_playable`).
    pub(crate) motion_open_s: Option<f64>,
    pub(crate) play_timing: Option<(Instant, f64)>,
    /// The shortcuts window (?) is open.
    pub show_shortcuts: bool,
    // Messages and the rest.
    pub status: Option<Status>,
    pub error: Option<String>,
    pub(crate) frames_drawn: u64,
    pub(crate) first_frame_reported: bool,
    pub(crate) ready_reported: bool,
    pub(crate) screenshot_state: Option<Arc<std::sync::atomic::AtomicU8>>,
    /// Show the pose round-trip time in the status bar (tests turn it off: it varies).
    pub show_timings: bool,
    /// The view of a project being opened, applied once its capture is loaded.
    pub(crate) pending_view: Option<ViewState>,
    /// Where P saves screenshots.
    pub screenshot_dir: PathBuf,
    /// Where an avatar never saved is kept when it is closed (another capture opens).
    pub autosave_dir: PathBuf,
    /// The capture panel's path field (for systems without a file dialog portal).
    pub path_field: String,
    /// The project file last saved or opened (Ctrl+S saves there).
    pub project_path: Option<PathBuf>,
}

impl StudioApp {
    /// The viewport's rectangle in the last frame (points).
    pub fn viewport_rect(&self) -> Option<egui::Rect> {
        self.viewport_rect
    }

    /// Parts of the UI are painted by the studio's own shaders (`viewport::flat`, and while the
    /// view moves `viewport::ui_meshes`): on a software renderer.
    pub fn flat_painting(&self) -> bool {
        self.flat
    }

    /// Replace the file dialogs (tests answer them with fixed paths, or disable them).
    pub fn set_dialogs(&mut self, dialogs: Box<dyn Dialogs>) {
        self.dialogs = dialogs;
    }

    /// True while anything runs in the background or a pose is on its way.
    pub fn busy(&self) -> bool {
        let t = &self.tasks;
        t.capture.is_some()
            || t.avatar.is_some()
            || t.export.is_some()
            || self.job.is_some()
            || self.bakes.baking()
            || self.pose_needed
            || self.poser.busy()
            || self.frame_store.busy()
    }

    pub fn body(&self) -> Arc<BodyModel> {
        // An avatar of a user's SMPL model poses with the body it carries, whatever capture is open.
        if let Some(a) = &self.avatar
            && a.source().body().is_frozen()
        {
            return Arc::new(a.source().body().clone());
        }
        self.capture
            .as_ref()
            .map(|c| c.body.clone())
            .unwrap_or_else(|| Arc::new(open_body_ref().clone()))
    }

    /// The shape posed and shown: the avatar's own, else the capture's.
    pub fn betas(&self) -> Vec<f32> {
        if let Some(a) = &self.avatar {
            return a.source().betas().to_vec();
        }
        self.capture.as_ref().map(|c| c.betas.clone()).unwrap_or_default()
    }

    /// "Opening the demo…" while a capture loads.
    pub fn loading(&self) -> Option<&str> {
        self.tasks.capture.as_ref().map(|c| c.source.as_str())
    }

    pub fn meshing(&self) -> bool {
        self.tasks.avatar.is_some()
    }

    pub fn exporting(&self) -> bool {
        self.tasks.export.is_some()
    }

    pub fn camera(&self) -> &crate::studio::camera::OrbitCamera {
        &self.view.camera
    }

    pub(crate) fn wake(&self) -> crate::studio::tasks::Wake {
        let ctx = self.ctx.clone();
        Arc::new(move || ctx.request_repaint())
    }

    pub(crate) fn fail(&mut self, message: String) {
        self.status = Some(Status::Error(message.clone()));
        self.error = Some(message);
    }

    pub(crate) fn info(&mut self, message: impl Into<String>) {
        self.status = Some(Status::Info(message.into()));
    }
}

/// Where `--measure-playback` is (`studio::measure`).
#[derive(Debug, Clone, Copy)]
pub enum PlaybackMeasure {
    /// Play pressed; the clip is baking.
    Baking,
    /// Counting since `start`: frames drawn then, clip frames shown since, the last one shown.
    Counting { start: std::time::Instant, cpu: f64, drawn: u64, shown: usize, last: usize },
    /// Printed; the window is closing.
    Done,
}
