//! What the panels, the keys and the tests ask the studio to do, and the one place where it is
//! done ([`StudioApp::apply`]). Work that takes time starts a background task here; its result
//! is taken in `background.rs`.

use crate::studio::avatar::{StudioAvatar, canonical_of, load_avatar};
use crate::studio::avatar_job::FitJob;
use crate::studio::camera::Preset;
use crate::studio::capture_view::{LoadedCapture, load_capture};
use crate::studio::fit_config::FitConfig;
use crate::studio::path_dialog::PathDialog;
use crate::studio::posing::sdf_normals;
use crate::studio::project::{DEMO, MotionState, PROJECT_EXTENSION, Project, ViewMode};
use crate::studio::scan::{fitting_beside, is_scan, scan_capture};
use crate::studio::settings::{DialogAnswer, PathPurpose, Settings};
use crate::studio::state::{AvatarReady, JobView, StudioApp};
use crate::studio::tasks::Task;
use crate::studio::timeline::Timeline;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub enum Command {
    /// "demo" or a capture folder.
    OpenCapture(String),
    /// Whatever the path is: a capture folder (or its capture.json), a project, an avatar or a motion.
    OpenPath(PathBuf),
    OpenProject(PathBuf),
    SaveProject(PathBuf),
    /// Save the project where it was last saved or opened, else ask where (Ctrl+S).
    SaveProjectHere,
    OpenAvatar(PathBuf),
    SaveAvatar(PathBuf),
    /// A library clip name or a motion file.
    LoadMotion(String),
    ExportGlb(PathBuf),
    ExportObj(PathBuf),
    StartFit(FitConfig),
    /// Show a fine-tuning job started elsewhere (tests start a gated one).
    WatchFit(FitJob),
    CancelFit,
    /// Stop baking the clip: the frames baked so far play, the rest are posed live.
    StopBake,
    /// Ask the user for a path (native dialog, else the in-app one); the answer becomes the
    /// purpose's command.
    AskPath(PathPurpose),
    SetMode(ViewMode),
    SelectFrame(usize),
    FrameSubject,
    CameraPreset(Preset),
    Screenshot,
    TogglePlay,
    /// The timeline's frame, clip or joint offsets changed: pose again.
    PoseChanged,
    /// A view option changed: rebuild the scene.
    SceneChanged,
    DismissError,
}

impl Command {
    /// The command a path answers.
    pub fn answer(purpose: PathPurpose, path: PathBuf) -> Command {
        match purpose {
            PathPurpose::OpenCapture | PathPurpose::OpenScan => {
                Command::OpenCapture(path.display().to_string())
            }
            PathPurpose::OpenProject => Command::OpenProject(path),
            PathPurpose::SaveProject => Command::SaveProject(path),
            PathPurpose::OpenAvatar => Command::OpenAvatar(path),
            PathPurpose::SaveAvatar => Command::SaveAvatar(path),
            PathPurpose::OpenMotion => Command::LoadMotion(path.display().to_string()),
            PathPurpose::ExportGlb => Command::ExportGlb(path),
            PathPurpose::ExportObj => Command::ExportObj(path),
        }
    }
}

impl StudioApp {
    pub fn apply_all(&mut self, commands: Vec<Command>) {
        for c in commands {
            self.apply(c);
        }
    }

    pub fn apply(&mut self, command: Command) {
        match command {
            Command::OpenCapture(source) => self.open_capture(source),
            Command::OpenPath(p) => self.open_path(p),
            Command::OpenProject(p) => self.open_project(&p),
            Command::SaveProject(p) => self.save_project_to(&p),
            Command::SaveProjectHere => match self.project_path.clone() {
                Some(p) => self.save_project_to(&p),
                None => self.apply(Command::AskPath(PathPurpose::SaveProject)),
            },
            Command::OpenAvatar(p) => self.open_avatar(&p),
            Command::SaveAvatar(p) => self.save_avatar_to(&p),
            Command::LoadMotion(s) => self.load_motion(&s),
            Command::ExportGlb(p) => self.export_glb_to(p),
            Command::ExportObj(p) => self.export_obj_to(&p),
            Command::StartFit(cfg) => self.start_fit(cfg),
            Command::WatchFit(job) => self.watch_fit(job),
            Command::CancelFit => {
                if let Some(j) = &self.job {
                    j.cancel();
                    self.info("Cancelling: the partial avatar is kept");
                }
            }
            Command::StopBake => {
                self.bakes.stop();
                self.info("Stopped baking: the frames baked so far play, the rest are posed live");
            }
            Command::AskPath(purpose) => self.ask_path(purpose),
            Command::SetMode(mode) => self.set_mode(mode),
            Command::SelectFrame(i) => {
                self.view.selected_frame = i;
                self.set_mode(ViewMode::Capture);
                self.scene_dirty = true;
            }
            Command::FrameSubject => self.frame_subject(),
            Command::CameraPreset(p) => {
                p.apply(&mut self.view.camera);
                self.turntable = false;
                self.framed = true;
            }
            Command::Screenshot => self.screenshot_viewport(),
            Command::TogglePlay => {
                self.timeline.playing = !self.timeline.playing;
                if self.timeline.playing {
                    self.start_bake();
                }
            }
            Command::PoseChanged => self.pose_needed = true,
            Command::SceneChanged => self.scene_dirty = true,
            Command::DismissError => self.error = None,
        }
    }

    // ---- paths ---------------------------------------------------------------------------

    fn ask_path(&mut self, purpose: PathPurpose) {
        let default_name = match purpose {
            PathPurpose::SaveProject => format!("session.{PROJECT_EXTENSION}"),
            PathPurpose::SaveAvatar => "avatar.avatar".into(),
            PathPurpose::ExportGlb => format!("{}.glb", self.timeline.clip.name),
            PathPurpose::ExportObj => "pose.obj".into(),
            _ => String::new(),
        };
        let request = purpose.request(default_name);
        if !self.native_dialogs_failed {
            match self.dialogs.ask(&request) {
                DialogAnswer::Chosen(p) => return self.apply(Command::answer(purpose, p)),
                DialogAnswer::Cancelled => return,
                DialogAnswer::Unavailable => self.native_dialogs_failed = true,
            }
        }
        let folder = self
            .project_path
            .as_ref()
            .and_then(|p| p.parent().map(Path::to_path_buf))
            .filter(|p| p.is_dir());
        let folder =
            folder.or_else(|| std::env::current_dir().ok()).unwrap_or_else(|| PathBuf::from("/"));
        self.path_dialog = Some(PathDialog::new(request, folder));
    }

    /// Open whatever a path is.
    fn open_path(&mut self, p: PathBuf) {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("").to_string();
        if p.is_dir() || name == "capture.json" || (is_scan(&p) && p.is_file()) {
            self.open_capture(p.display().to_string());
        } else if name.ends_with(PROJECT_EXTENSION) {
            self.open_project(&p);
        } else if name.ends_with(".avatar") {
            self.open_avatar(&p);
        } else if name.ends_with(".json") || name.ends_with(".npz") {
            self.load_motion(&p.display().to_string());
        } else if !p.exists() {
            self.fail(format!("{}: no such file or folder", p.display()));
        } else {
            self.fail(format!(
                "{}: not a capture folder, scan (OBJ), project, avatar or motion",
                p.display()
            ));
        }
    }

    // ---- capture -------------------------------------------------------------------------

    /// Open a capture folder ("demo" = the embedded demo; an OBJ scan becomes a capture in the
    /// cache first) in the background.
    fn open_capture(&mut self, source: String) {
        let src = source.clone();
        let task = Task::spawn(
            "capture loader",
            self.wake(),
            move |_| -> crate::error::Result<LoadedCapture> {
                let path = PathBuf::from(&src);
                if src != DEMO && is_scan(&path) {
                    let mut c = load_capture(&scan_capture(&path)?)?;
                    c.name =
                        path.file_name().map_or(src.clone(), |n| n.to_string_lossy().into_owned());
                    return Ok(c);
                }
                let dir = if src == DEMO { crate::studio::demo::demo_capture_dir()? } else { path };
                load_capture(&dir)
            },
        );
        self.tasks.capture = Some((source, task));
    }

    // ---- avatar --------------------------------------------------------------------------

    pub(crate) fn set_avatar(&mut self, avatar: Arc<dyn StudioAvatar>, path: Option<PathBuf>) {
        self.avatar = Some(avatar.clone());
        self.avatar_saved = path.is_some();
        self.avatar_path = path.clone();
        self.avatar_canonical = None;
        self.avatar_normals = None;
        self.spawn_avatar_work(move || Ok((avatar, path)));
    }

    /// Open an avatar file in the background (loading builds its skinning field; then it is
    /// meshed): the UI keeps running.
    fn open_avatar(&mut self, path: &Path) {
        let resolution = self.settings.fit.final_resolution;
        let path = path.to_path_buf();
        self.info(format!("Opening the avatar {}…", path.display()));
        self.spawn_avatar_work(move || {
            load_avatar(&path, resolution)
                .map(|a| (a, Some(path.clone())))
                .map_err(|e| e.context(format!("Could not open the avatar {}", path.display())))
        });
    }

    fn spawn_avatar_work(
        &mut self,
        get: impl FnOnce() -> crate::error::Result<(Arc<dyn StudioAvatar>, Option<PathBuf>)>
        + Send
        + 'static,
    ) {
        let task = Task::spawn("avatar mesher", self.wake(), move |_| {
            let (avatar, path) = get()?;
            let betas = avatar.source().betas().to_vec();
            let mesh = canonical_of(avatar.as_ref(), &betas)
                .map_err(|e| e.context("Could not mesh the avatar"))?;
            // The SDF's gradient at the rest pose, once, turned by the skinning at each pose (exact
            // for a pose-independent surface; the slider's quick normals for the meta avatar).
            let rest = avatar_core::body::BodyParams { betas, ..Default::default() };
            let normals = match &mesh.smoother {
                // A smoothed surface keeps its own normals (the SDF's gradient has the noise).
                Some(_) => Some(Arc::new(mesh.mesh.vertex_normals())),
                None => Some(Arc::new(sdf_normals(
                    avatar.source(),
                    &rest,
                    &mesh.mesh.positions,
                    &mesh.mesh.vertex_normals(),
                )?)),
            };
            Ok(AvatarReady { avatar, path, mesh: Arc::new(mesh), normals })
        });
        self.tasks.avatar = Some(task);
    }

    /// What the session reads, for the output-path guard: the capture's files and a motion file.
    fn inputs(&self) -> avatar_core::io::Inputs {
        let mut inputs = avatar_core::io::Inputs::new();
        if let Some(c) = &self.capture {
            inputs = inputs.capture(&c.dir);
        }
        // A scan's capture is in the cache; the files the user has are the scan and its fitting.
        if let Some(scan) = self.capture_source.as_deref().map(Path::new).filter(|p| is_scan(p)) {
            inputs = inputs.file(scan);
            if let Ok(f) = fitting_beside(scan) {
                inputs = inputs.file(&f);
            }
        }
        let clip = Path::new(&self.timeline.clip_source);
        if clip.is_file() {
            inputs = inputs.file(clip);
        }
        inputs
    }

    fn save_avatar_to(&mut self, path: &Path) {
        let Some(a) = &self.avatar else {
            return self.fail("Fit or open an avatar before saving one".into());
        };
        if let Err(e) = self.inputs().check_file(path, &["avatar"]) {
            return self.fail(format!("Could not save the avatar: {e}"));
        }
        match a.save(path) {
            Ok(()) => {
                self.avatar_path = Some(path.to_path_buf());
                self.avatar_saved = true;
                self.info(format!("Saved the avatar to {}", path.display()));
            }
            Err(e) => self.fail(format!("Could not save the avatar: {e}")),
        }
    }

    // ---- fine-tuning ---------------------------------------------------------------------

    fn start_fit(&mut self, config: FitConfig) {
        let Some(capture) = &self.capture else {
            return self.fail("Open a capture before fine-tuning".into());
        };
        if self.job.is_none() {
            let ctx = self.ctx.clone();
            self.watch_fit(FitJob::start(capture.dir.clone(), config, move || {
                ctx.request_repaint()
            }));
        }
    }

    fn watch_fit(&mut self, job: FitJob) {
        if self.job.is_some() {
            return;
        }
        self.job_view = JobView { steps: job.config.steps, ..JobView::default() };
        self.settings.fit = job.config.clone();
        self.preview = None;
        self.job = Some(job);
        self.info("Fine-tuning started");
    }

    // ---- export --------------------------------------------------------------------------

    /// Export the animated glTF of the avatar playing the timeline's clip (background).
    fn export_glb_to(&mut self, path: PathBuf) {
        let Some(avatar) = self.avatar.clone() else {
            return self.fail("Fit or open an avatar before exporting".into());
        };
        if let Err(e) =
            self.inputs().maybe_file(self.avatar_path.as_ref()).check_file(&path, &["glb"])
        {
            return self.fail(format!("Export failed: {e}"));
        }
        let clip = self.timeline.clip.clone();
        let options =
            avatar_core::export::ExportOptions { color: self.view.material, ..Default::default() };
        self.tasks.export_progress = None;
        let task = Task::spawn("export", self.wake(), move |cx| -> crate::error::Result<String> {
            // Frames made of all the export will make, after every chunk (the side panel's bar).
            let progress = |p: avatar_core::export::Progress| cx.send(p);
            let control = avatar_core::export::Control { progress: Some(&progress), cancel: None };
            let e =
                avatar_core::export::export_glb_with(avatar.source(), &clip, &options, control)?;
            avatar_core::io::write_bytes_atomic(&path, &e.glb)?;
            Ok(format!(
                "Exported {} ({} frames, {} vertices, {:.2} MB)",
                path.display(),
                e.frames,
                e.rest.positions.len(),
                e.glb.len() as f64 / 1e6
            ))
        });
        self.tasks.export = Some(task);
        self.info("Exporting…");
    }

    /// Write the mesh on screen at the current pose as OBJ.
    fn export_obj_to(&mut self, path: &Path) {
        let Some(p) = &self.posed else {
            return self.fail("Nothing posed yet".into());
        };
        if let Err(e) =
            self.inputs().maybe_file(self.avatar_path.as_ref()).check_file(path, &["obj"])
        {
            return self.fail(format!("Could not write the OBJ: {e}"));
        }
        let mesh = avatar_core::mesh::TriMesh::new(p.positions.clone(), p.faces.to_vec());
        match avatar_core::mesh::io::write_obj(path, &mesh) {
            Ok(()) => {
                self.info(format!("Wrote {} ({} vertices)", path.display(), mesh.positions.len()))
            }
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
        Project::new(
            self.capture_source.clone(),
            self.avatar_path.as_ref().map(|p| p.display().to_string()),
            self.view.clone(),
            motion,
        )
    }

    /// Save the session; an unsaved avatar is saved beside the project first.
    pub fn save_project_to(&mut self, path: &Path) {
        if let Err(e) =
            self.inputs().maybe_file(self.avatar_path.as_ref()).check_file(path, &["json"])
        {
            return self.fail(format!("Could not save the project: {e}"));
        }
        if self.avatar.is_some() && !self.avatar_saved {
            let stem = path
                .file_name()
                .and_then(|n| n.to_str())
                .map(|n| n.trim_end_matches(".studio.json").trim_end_matches(".json").to_string())
                .unwrap_or_else(|| "avatar".into());
            let avatar_path = path.with_file_name(format!("{stem}.avatar"));
            self.save_avatar_to(&avatar_path);
            if !self.avatar_saved {
                return;
            }
        }
        match self.project().save(path) {
            Ok(()) => {
                Settings::push_recent(
                    &mut self.settings.recent_projects,
                    &path.display().to_string(),
                );
                self.project_path = Some(path.to_path_buf());
                self.info(format!("Saved the project {}", path.display()));
            }
            Err(e) => self.fail(format!("Could not save the project: {e}")),
        }
    }

    fn open_project(&mut self, path: &Path) {
        let p = match Project::load(path) {
            Ok(p) => p,
            Err(e) => return self.fail(format!("Could not open the project: {e}")),
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
            Err(e) => self.fail(format!("Could not open the project's motion: {e}")),
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
        self.project_path = Some(path.to_path_buf());
        self.pose_needed = true;
        self.scene_dirty = true;
    }

    fn load_motion(&mut self, source: &str) {
        match Timeline::open(source) {
            Ok(mut t) => {
                t.offsets = self.timeline.offsets;
                t.speed = self.timeline.speed;
                self.info(format!("Motion {} ({} frames)", t.clip.name, t.frames()));
                self.timeline = t;
                self.pose_needed = true;
            }
            Err(e) => self.fail(format!("Could not open the motion: {e}")),
        }
    }
}
