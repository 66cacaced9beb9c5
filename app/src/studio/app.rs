//! The studio's state and its per-frame logic (background work polled, scene rebuilt when
//! something changed). The panels that draw it live in `panels.rs`.

use crate::studio::avatar_job::{body_canonical, canonical_of, load_avatar, CanonicalMesh, FitConfig, FitJob, JobEvent, StudioAvatar};
use crate::studio::camera::OrbitCamera;
use crate::studio::posing::{Posable, PoseWorker, PosedMesh};
use crate::studio::project::{MotionState, Project, ViewMode, ViewState, DEMO};
use crate::studio::session::{load_capture, LoadedCapture};
use crate::studio::settings::{Dialogs, RfdDialogs, Settings, SETTINGS_KEY};
use crate::studio::timeline::Timeline;
use crate::studio::viewport::{self, Scene};
use avatar_core::body::{open_body_ref, BodyModel, SMPL_PARENTS};
use crossbeam_channel::Receiver;
use eframe::egui;
use glam::Vec3;
use std::path::{Path, PathBuf};
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
}

/// An avatar loaded (or fitted) and meshed off the UI thread.
pub struct AvatarReady {
    pub avatar: Arc<dyn StudioAvatar>,
    pub path: Option<PathBuf>,
    pub mesh: Arc<CanonicalMesh>,
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

    pub fn seconds_left(&self) -> Option<f64> {
        (self.step > 0 && self.steps > 0).then(|| self.elapsed_s * (self.steps - self.step.min(self.steps)) as f64 / self.step as f64)
    }
}

pub struct StudioApp {
    pub(crate) ctx: egui::Context,
    pub(crate) options: StudioOptions,
    pub(crate) dialogs: Box<dyn Dialogs>,
    pub settings: Settings,
    // Capture.
    pub capture: Option<Arc<LoadedCapture>>,
    /// "demo" or a folder path.
    pub capture_source: Option<String>,
    pub(crate) loading: Option<(String, Receiver<Result<LoadedCapture, String>>)>,
    pub(crate) thumbnails: Vec<Option<egui::TextureHandle>>,
    pub(crate) body_rest: Option<Arc<CanonicalMesh>>,
    // Avatar.
    pub avatar: Option<Arc<dyn StudioAvatar>>,
    pub avatar_path: Option<PathBuf>,
    pub avatar_saved: bool,
    pub(crate) avatar_canonical: Option<Arc<CanonicalMesh>>,
    pub(crate) meshing: Option<Receiver<Result<AvatarReady, String>>>,
    // Fine-tuning.
    pub job: Option<FitJob>,
    pub job_view: JobView,
    pub(crate) preview: Option<Arc<CanonicalMesh>>,
    // Posing.
    pub(crate) poser: PoseWorker,
    pub posed: Option<PosedMesh>,
    pub(crate) pose_needed: bool,
    pub last_pose_seconds: Option<f64>,
    pub(crate) pose_failed: Option<u64>,
    pub(crate) pose_requested_at: Option<Instant>,
    pub last_request_to_mesh: Option<f64>,
    // Timeline and view.
    pub timeline: Timeline,
    pub view: ViewState,
    pub(crate) scene: Arc<Scene>,
    pub(crate) scene_dirty: bool,
    pub(crate) framed: bool,
    pub(crate) viewport_rect: Option<egui::Rect>,
    // Export and messages.
    pub(crate) exporting: Option<Receiver<Result<String, String>>>,
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
    /// The capture panel's path field (for systems without a file dialog portal).
    pub(crate) path_field: String,
}

impl StudioApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: StudioOptions) -> StudioApp {
        if let Some(rs) = cc.wgpu_render_state.as_ref() {
            viewport::install(rs);
        }
        crate::studio::style::apply(&cc.egui_ctx);
        let settings: Settings = cc.storage.and_then(|s| eframe::get_value(s, SETTINGS_KEY)).unwrap_or_default();
        let ctx = cc.egui_ctx.clone();
        let wake_ctx = ctx.clone();
        let poser = PoseWorker::start(move || wake_ctx.request_repaint());
        let timeline = Timeline::library("walk").or_else(|| Timeline::library(avatar_core::motion::clip_names()[0])).expect("the motion library has clips");
        let view = ViewState { shading: settings.shading, skeleton: settings.skeleton, ..ViewState::default() };
        let mut app = StudioApp {
            ctx,
            options: options.clone(),
            dialogs: Box::new(RfdDialogs),
            settings,
            capture: None,
            capture_source: None,
            loading: None,
            thumbnails: Vec::new(),
            body_rest: None,
            avatar: None,
            avatar_path: None,
            avatar_saved: true,
            avatar_canonical: None,
            meshing: None,
            job: None,
            job_view: JobView::default(),
            preview: None,
            poser,
            posed: None,
            pose_needed: true,
            last_pose_seconds: None,
            pose_failed: None,
            pose_requested_at: None,
            last_request_to_mesh: None,
            timeline,
            view,
            scene: Arc::new(Scene::new()),
            scene_dirty: true,
            framed: false,
            viewport_rect: None,
            exporting: None,
            status: None,
            error: None,
            frames_drawn: 0,
            first_frame_reported: false,
            ready_reported: false,
            screenshot_state: None,
            path_field: String::new(),
            pending_view: None,
            show_timings: true,
            screenshot_dir: crate::studio::screenshot::default_screenshot_dir(),
        };
        if let Some(p) = &options.project {
            app.open_project(p);
        } else if let Some(c) = &options.capture {
            app.open_capture(c.display().to_string());
        } else if options.load_demo {
            app.open_capture(DEMO.to_string());
        }
        app
    }

    /// The viewport's rectangle in the last frame (points).
    pub fn viewport_rect(&self) -> Option<egui::Rect> {
        self.viewport_rect
    }

    /// Ask for the current pose again (tests change the timeline directly).
    pub fn pose_needed_for_tests(&mut self) {
        self.pose_needed = true;
    }

    /// Replace the file dialogs (tests answer them with fixed paths).
    pub fn set_dialogs(&mut self, dialogs: Box<dyn Dialogs>) {
        self.dialogs = dialogs;
    }

    /// True while anything runs in the background or a pose is on its way.
    pub fn busy(&self) -> bool {
        let answered = self.posed.as_ref().map(|p| p.id) == Some(self.poser.latest) || self.pose_failed == Some(self.poser.latest);
        let posing = self.poser.latest != 0 && !answered;
        self.loading.is_some() || self.job.is_some() || self.meshing.is_some() || self.exporting.is_some() || self.pose_needed || posing
    }

    pub fn body(&self) -> Arc<BodyModel> {
        // An avatar of a user's SMPL model poses with the body it carries, whatever capture is open.
        if let Some(a) = &self.avatar
            && a.source().body().is_frozen()
        {
            return Arc::new(a.source().body().clone());
        }
        self.capture.as_ref().map(|c| c.body.clone()).unwrap_or_else(|| Arc::new(open_body_ref().clone()))
    }

    /// The shape posed and shown: the avatar's own, else the capture's.
    pub fn betas(&self) -> Vec<f32> {
        if let Some(a) = &self.avatar {
            return a.source().betas().to_vec();
        }
        self.capture.as_ref().map(|c| c.betas.clone()).unwrap_or_default()
    }

    // ---- capture -------------------------------------------------------------------------

    /// Open a capture folder ("demo" = the embedded demo) in the background.
    pub fn open_capture(&mut self, source: String) {
        let (tx, rx) = crossbeam_channel::bounded(1);
        let ctx = self.ctx.clone();
        let src = source.clone();
        std::thread::Builder::new()
            .name("capture loader".into())
            .spawn(move || {
                let r = (|| -> anyhow::Result<LoadedCapture> {
                    let dir = if src == DEMO { crate::studio::demo::demo_capture_dir()? } else { PathBuf::from(&src) };
                    load_capture(&dir)
                })()
                .map_err(|e| format!("{e:#}"));
                let _ = tx.send(r);
                ctx.request_repaint();
            })
            .expect("spawning the capture loader");
        self.loading = Some((source, rx));
    }

    fn capture_loaded(&mut self, source: String, capture: LoadedCapture) {
        self.thumbnails = capture
            .frames
            .iter()
            .map(|f| f.thumbnail.clone().map(|img| self.ctx.load_texture(format!("thumb-{}-{}", capture.name, f.index), img, egui::TextureOptions::LINEAR)))
            .collect();
        self.body_rest = Some(Arc::new(body_canonical(&capture.body, &capture.betas)));
        match self.pending_view.take() {
            Some(v) => {
                self.view = v;
                self.view.selected_frame = self.view.selected_frame.min(capture.frames.len().saturating_sub(1));
                self.framed = true;
            }
            None => {
                self.view.selected_frame = capture.first_usable().unwrap_or(0);
                self.framed = false;
            }
        }
        let flagged = capture.flagged();
        let msg = format!(
            "Opened {}: {} frames, {} usable{}",
            if source == DEMO { "the demo capture".to_string() } else { capture.dir.display().to_string() },
            capture.frames.len(),
            capture.usable(),
            if flagged > 0 { format!(", {flagged} flagged") } else { String::new() }
        );
        self.status = Some(Status::Info(msg));
        if source != DEMO {
            Settings::push_recent(&mut self.settings.recent_captures, &source);
        }
        let title = if source == DEMO { "Avatar Studio - demo capture".to_string() } else { format!("Avatar Studio - {}", capture.name) };
        self.ctx.send_viewport_cmd(egui::ViewportCommand::Title(title));
        self.capture = Some(Arc::new(capture));
        self.capture_source = Some(source);
        if let Some(cfg) = self.options.auto_fit.take() {
            self.start_fit(cfg);
        }
        self.error = None;
        self.pose_needed = true;
        self.scene_dirty = true;
    }

    // ---- avatar --------------------------------------------------------------------------

    pub fn set_avatar(&mut self, avatar: Arc<dyn StudioAvatar>, path: Option<PathBuf>) {
        self.avatar = Some(avatar.clone());
        self.avatar_saved = path.is_some();
        self.avatar_path = path.clone();
        self.avatar_canonical = None;
        self.spawn_avatar_work(move || Ok((avatar, path)));
    }

    /// Open an avatar file in the background (loading builds its skinning field; then it is
    /// meshed): the UI keeps running.
    pub fn open_avatar(&mut self, path: &Path) {
        let resolution = self.settings.fit.final_resolution;
        let path = path.to_path_buf();
        self.status = Some(Status::Info(format!("Opening the avatar {}…", path.display())));
        self.spawn_avatar_work(move || load_avatar(&path, resolution).map(|a| (a, Some(path.clone()))).map_err(|e| format!("Could not open the avatar {}: {e:#}", path.display())));
    }

    fn spawn_avatar_work(&mut self, get: impl FnOnce() -> Result<(Arc<dyn StudioAvatar>, Option<PathBuf>), String> + Send + 'static) {
        let (tx, rx) = crossbeam_channel::bounded(1);
        let ctx = self.ctx.clone();
        std::thread::Builder::new()
            .name("avatar mesher".into())
            .spawn(move || {
                let r = get().and_then(|(avatar, path)| {
                    let betas = avatar.source().betas().to_vec();
                    let mesh = canonical_of(avatar.as_ref(), &betas).map_err(|e| format!("Could not mesh the avatar: {e:#}"))?;
                    Ok(AvatarReady { avatar, path, mesh: Arc::new(mesh) })
                });
                let _ = tx.send(r);
                ctx.request_repaint();
            })
            .expect("spawning the mesher");
        self.meshing = Some(rx);
    }

    pub fn save_avatar_to(&mut self, path: &Path) {
        let Some(a) = &self.avatar else { return };
        match a.save(path) {
            Ok(()) => {
                self.avatar_path = Some(path.to_path_buf());
                self.avatar_saved = true;
                self.status = Some(Status::Info(format!("Saved the avatar to {}", path.display())));
            }
            Err(e) => self.fail(format!("Could not save the avatar: {e:#}")),
        }
    }

    // ---- fine-tuning ---------------------------------------------------------------------

    pub fn start_fit(&mut self, config: FitConfig) {
        self.start_fit_gated(config, None);
    }

    /// Start a fit held after each chunk until `gate` receives (tests).
    pub fn start_fit_gated(&mut self, config: FitConfig, gate: impl Into<Option<Receiver<()>>>) {
        let gate = gate.into();
        let Some(capture) = &self.capture else {
            self.fail("Open a capture before fine-tuning".into());
            return;
        };
        if self.job.is_some() {
            return;
        }
        let ctx = self.ctx.clone();
        self.job_view = JobView { steps: config.steps, ..JobView::default() };
        self.settings.fit = config.clone();
        self.preview = None;
        self.job = Some(FitJob::start_gated(capture.dir.clone(), config, move || ctx.request_repaint(), gate));
        self.status = Some(Status::Info("Fine-tuning started".into()));
    }

    pub fn cancel_fit(&mut self) {
        if let Some(j) = &self.job {
            j.cancel();
            self.status = Some(Status::Info("Cancelling: the partial avatar is kept".into()));
        }
    }

    fn poll_job(&mut self) {
        let Some(job) = &self.job else { return };
        let mut finished = None;
        for e in job.events.try_iter() {
            match e {
                JobEvent::Started { points, frames } => {
                    self.job_view.points = points;
                    self.job_view.frames = frames;
                }
                JobEvent::Progress { step, steps, loss, terms, elapsed_s } => {
                    self.job_view.step = step;
                    self.job_view.steps = steps;
                    self.job_view.loss = loss;
                    self.job_view.terms = terms;
                    self.job_view.elapsed_s = elapsed_s;
                    if loss.is_finite() && loss > 0.0 {
                        self.job_view.losses.push([step as f64, (loss as f64).log10()]);
                    }
                }
                JobEvent::Preview { step, mesh } => {
                    self.job_view.preview_step = Some(step);
                    self.preview = Some(mesh);
                    self.pose_needed = true;
                    self.scene_dirty = true;
                }
                e @ (JobEvent::Finished { .. } | JobEvent::Failed(_)) => finished = Some(e),
            }
        }
        match finished {
            Some(JobEvent::Finished { avatar, cancelled, warnings, seconds }) => {
                let what = if cancelled { "Fine-tuning cancelled: the partial avatar is loaded" } else { "Fine-tuning finished" };
                let text = format!("{what} ({}, {seconds:.1} s){}", avatar.describe(), if warnings.is_empty() { String::new() } else { format!("; {} warnings", warnings.len()) });
                self.job_view.finished = Some(text.clone());
                self.status = Some(Status::Info(text));
                self.job = None;
                self.set_avatar(avatar, None);
            }
            Some(JobEvent::Failed(e)) => {
                self.job = None;
                self.preview = None;
                self.job_view.finished = Some(format!("Failed: {e}"));
                self.fail(format!("Fine-tuning failed: {e}"));
            }
            _ => {}
        }
    }

    // ---- posing --------------------------------------------------------------------------

    /// What the poser skins now: the job's partial result, the avatar, or the body.
    fn posable(&self) -> Option<Posable> {
        if let Some(p) = &self.preview {
            if self.job.is_some() || self.avatar_canonical.is_none() {
                return Some(Posable::Mesh(p.clone()));
            }
        }
        if let Some(c) = &self.avatar_canonical {
            return Some(match &self.avatar {
                Some(a) if a.pose_dependent() => Posable::PoseDependent { avatar: a.clone(), reference: c.clone() },
                _ => Posable::Mesh(c.clone()),
            });
        }
        self.body_rest.clone().map(Posable::Mesh)
    }

    pub fn request_pose(&mut self) {
        self.pose_needed = false;
        let Some(posable) = self.posable() else { return };
        let params = self.timeline.params(&self.betas());
        self.poser.request(params, posable, self.body());
        self.pose_requested_at = Some(Instant::now());
        self.pose_needed = false;
    }

    fn poll_pose(&mut self) {
        if let Some(r) = self.poser.poll() {
            match r {
                Ok(m) => {
                    self.last_pose_seconds = Some(m.seconds);
                    if m.id == self.poser.latest {
                        self.last_request_to_mesh = self.pose_requested_at.map(|t| t.elapsed().as_secs_f64());
                    }
                    self.posed = Some(m);
                    self.scene_dirty = true;
                }
                Err(e) => {
                    self.pose_failed = Some(e.id);
                    self.fail(format!("Posing failed: {e}"));
                }
            }
        }
    }

    // ---- export --------------------------------------------------------------------------

    /// Export the animated glTF of the avatar playing the timeline's clip (background).
    pub fn export_glb_to(&mut self, path: PathBuf) {
        let Some(avatar) = self.avatar.clone() else {
            self.fail("Fit or open an avatar before exporting".into());
            return;
        };
        let clip = self.timeline.clip.clone();
        let (tx, rx) = crossbeam_channel::bounded(1);
        let ctx = self.ctx.clone();
        std::thread::Builder::new()
            .name("export".into())
            .spawn(move || {
                let r = (|| -> anyhow::Result<String> {
                    let options = avatar_core::export::ExportOptions::default();
                    let e = avatar_core::export::export_glb(avatar.source(), &clip, &options)?;
                    avatar_core::io::write_bytes_atomic(&path, &e.glb)?;
                    Ok(format!("Exported {} ({} frames, {} vertices, {:.2} MB)", path.display(), e.frames, e.rest.positions.len(), e.glb.len() as f64 / 1e6))
                })()
                .map_err(|e| format!("Export failed: {e:#}"));
                let _ = tx.send(r);
                ctx.request_repaint();
            })
            .expect("spawning the exporter");
        self.exporting = Some(rx);
        self.status = Some(Status::Info("Exporting…".into()));
    }

    /// Write the mesh on screen at the current pose as OBJ.
    pub fn export_obj_to(&mut self, path: &Path) {
        let Some(p) = &self.posed else {
            self.fail("Nothing posed yet".into());
            return;
        };
        let mesh = avatar_core::mesh::TriMesh::new(p.positions.clone(), p.faces.clone());
        match avatar_core::mesh::io::write_obj(path, &mesh) {
            Ok(()) => self.status = Some(Status::Info(format!("Wrote {} ({} vertices)", path.display(), mesh.positions.len()))),
            Err(e) => self.fail(format!("Could not write the OBJ: {e}")),
        }
    }

    // ---- project -------------------------------------------------------------------------

    pub fn project(&self) -> Project {
        let motion = MotionState {
            clip: self.timeline.clip_source.clone(),
            frame: self.timeline.current_frame(),
            speed: self.timeline.speed,
            offsets: self.timeline.offsets.to_vec(),
        };
        Project::new(self.capture_source.clone(), self.avatar_path.as_ref().map(|p| p.display().to_string()), self.view.clone(), motion)
    }

    /// Save the session; an unsaved avatar is saved beside the project first.
    pub fn save_project_to(&mut self, path: &Path) {
        if self.avatar.is_some() && !self.avatar_saved {
            let stem = path.file_name().and_then(|n| n.to_str()).map(|n| n.trim_end_matches(".studio.json").trim_end_matches(".json").to_string()).unwrap_or_else(|| "avatar".into());
            let avatar_path = path.with_file_name(format!("{stem}.avatar"));
            self.save_avatar_to(&avatar_path);
            if !self.avatar_saved {
                return;
            }
        }
        match self.project().save(path) {
            Ok(()) => {
                Settings::push_recent(&mut self.settings.recent_projects, &path.display().to_string());
                self.status = Some(Status::Info(format!("Saved the project {}", path.display())));
            }
            Err(e) => self.fail(format!("Could not save the project: {e:#}")),
        }
    }

    pub fn open_project(&mut self, path: &Path) {
        let p = match Project::load(path) {
            Ok(p) => p,
            Err(e) => return self.fail(format!("Could not open the project: {e:#}")),
        };
        if let Some(c) = &p.capture {
            self.open_capture(c.clone());
        }
        match Timeline::open(&p.motion.clip) {
            Ok(mut t) => {
                t.set_frame(p.motion.frame);
                t.speed = p.motion.speed;
                for (j, o) in p.motion.offsets.iter().enumerate().take(t.offsets.len()) {
                    t.offsets[j] = *o;
                }
                self.timeline = t;
            }
            Err(e) => self.fail(format!("Could not open the project's motion: {e:#}")),
        }
        self.view = p.view.clone();
        self.framed = true;
        if p.capture.is_some() {
            self.pending_view = Some(p.view.clone());
        }
        if let Some(a) = &p.avatar {
            self.open_avatar(Path::new(a));
        }
        Settings::push_recent(&mut self.settings.recent_projects, &path.display().to_string());
        self.pose_needed = true;
        self.scene_dirty = true;
    }

    pub fn load_motion(&mut self, source: &str) {
        match Timeline::open(source) {
            Ok(mut t) => {
                t.offsets = self.timeline.offsets;
                t.speed = self.timeline.speed;
                self.status = Some(Status::Info(format!("Motion {} ({} frames)", t.clip.name, t.frames())));
                self.timeline = t;
                self.pose_needed = true;
            }
            Err(e) => self.fail(format!("Could not open the motion: {e:#}")),
        }
    }

    pub(crate) fn fail(&mut self, message: String) {
        self.status = Some(Status::Error(message.clone()));
        self.error = Some(message);
    }

    // ---- per frame -----------------------------------------------------------------------

    /// Poll background work and rebuild what changed (called at the start of every frame).
    pub fn update_state(&mut self) {
        if let Some((source, rx)) = &self.loading {
            if let Ok(r) = rx.try_recv() {
                let source = source.clone();
                self.loading = None;
                match r {
                    Ok(c) => self.capture_loaded(source, c),
                    Err(e) => {
                        let what = if source == DEMO { "the demo capture".to_string() } else { source.clone() };
                        self.fail(format!("Could not open {what}: {e}"));
                        self.scene_dirty = true;
                    }
                }
            }
        }
        if let Some(rx) = &self.meshing {
            if let Ok(r) = rx.try_recv() {
                self.meshing = None;
                match r {
                    Ok(ready) => {
                        let already = self.avatar.as_ref().is_some_and(|a| Arc::ptr_eq(a, &ready.avatar));
                        if !already {
                            self.status = Some(Status::Info(format!("Opened the avatar ({})", ready.avatar.describe())));
                            self.avatar_saved = ready.path.is_some();
                            self.avatar_path = ready.path.clone();
                            self.avatar = Some(ready.avatar);
                        }
                        self.avatar_canonical = Some(ready.mesh);
                        self.preview = None;
                        self.pose_needed = true;
                        self.scene_dirty = true;
                    }
                    Err(e) => self.fail(e),
                }
            }
        }
        if let Some(rx) = &self.exporting {
            if let Ok(r) = rx.try_recv() {
                self.exporting = None;
                match r {
                    Ok(m) => self.status = Some(Status::Info(m)),
                    Err(e) => self.fail(e),
                }
            }
        }
        self.poll_job();
        let dt = self.ctx.input(|i| i.stable_dt).min(0.1);
        if self.timeline.tick(dt) {
            self.pose_needed = true;
        }
        if self.timeline.playing {
            self.ctx.request_repaint();
        }
        if self.pose_needed {
            self.request_pose();
        }
        self.poll_pose();
        if self.scene_dirty {
            self.scene = Arc::new(self.build_scene());
            self.scene_dirty = false;
            if !self.framed && (self.posed.is_some() || self.view.mode != ViewMode::Posed) {
                if let Some((lo, hi)) = self.scene.bounds() {
                    self.view.camera.frame(lo, hi);
                    self.framed = true;
                }
            }
        }
    }

    /// The viewport's scene for the current view mode.
    pub fn build_scene(&self) -> Scene {
        let mut s = Scene::new();
        let skin = [0.72, 0.62, 0.55];
        let avatar_color = [0.55, 0.66, 0.80];
        let preview_color = [0.80, 0.62, 0.40];
        let skeleton_color = [1.0, 0.62, 0.18];
        let body = self.body();
        match self.view.mode {
            ViewMode::Capture => {
                if let Some(c) = &self.capture {
                    if let Some(f) = c.frames.get(self.view.selected_frame) {
                        s.add_lit_points(&f.points, &f.normals, [0.35, 0.85, 0.95], 1.0);
                        if let Some(params) = &f.params {
                            let posed = body.pose(params);
                            s.add_mesh(&posed.vertices, &body.faces, [0.42, 0.40, 0.40]);
                            if self.view.skeleton {
                                s.add_skeleton(&posed.posed_joints(), &SMPL_PARENTS, skeleton_color);
                            }
                        }
                    }
                }
            }
            ViewMode::Canonical => {
                let (mesh, color) = match (&self.preview, &self.avatar_canonical) {
                    (Some(p), _) if self.job.is_some() || self.avatar_canonical.is_none() => (Some(p.clone()), preview_color),
                    (_, Some(a)) => (Some(a.clone()), avatar_color),
                    _ => (self.body_rest.clone(), skin),
                };
                if let Some(m) = mesh {
                    s.add_mesh(&m.mesh.positions, &m.mesh.faces, color);
                }
                if self.view.skeleton {
                    let joints = body.rest_joints(&self.betas());
                    s.add_skeleton(&joints, &SMPL_PARENTS, skeleton_color);
                }
            }
            ViewMode::Posed => {
                if let Some(p) = &self.posed {
                    let color = if self.preview.is_some() && (self.job.is_some() || self.avatar_canonical.is_none()) {
                        preview_color
                    } else if self.avatar_canonical.is_some() {
                        avatar_color
                    } else {
                        skin
                    };
                    s.add_mesh(&p.positions, &p.faces, color);
                    if self.view.skeleton {
                        s.add_skeleton(&p.joints, &SMPL_PARENTS, skeleton_color);
                    }
                }
            }
        }
        let (lo, hi) = s.bounds().unwrap_or((Vec3::new(-0.5, -1.0, -0.5), Vec3::new(0.5, 1.0, 0.5)));
        let center = (lo + hi) * 0.5;
        s.add_grid(Vec3::new(center.x, 0.0, center.z), lo.y - 0.01, 1.5, 0.25);
        s
    }

    /// Frame the subject (F).
    pub fn frame_subject(&mut self) {
        if let Some((lo, hi)) = self.scene.bounds() {
            self.view.camera.frame(lo, hi);
        }
    }

    pub fn set_mode(&mut self, mode: ViewMode) {
        if self.view.mode != mode {
            self.view.mode = mode;
            self.scene_dirty = true;
        }
    }

    pub fn camera(&self) -> &OrbitCamera {
        &self.view.camera
    }
}

impl eframe::App for StudioApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.update_state();
        crate::studio::panels::draw(self, ui);
        self.frames_drawn += 1;
        self.after_frame();
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        self.settings.shading = self.view.shading;
        self.settings.skeleton = self.view.skeleton;
        eframe::set_value(storage, SETTINGS_KEY, &self.settings);
    }

    fn on_exit(&mut self) {
        // A running job is cancelled; it writes nothing to disk, so nothing is left half done.
        if let Some(j) = &self.job {
            j.cancel();
        }
    }
}
