//! What the panels, the keys and the tests ask the studio to do, and the one place where it is
//! done ([`StudioApp::apply`]). Work that takes time starts a background task here; its result
//! is taken in `background.rs`; opening and closing what the session holds is `session.rs`.

use crate::studio::avatar_job::FitJob;
use crate::studio::camera::Preset;
use crate::studio::fit_config::FitConfig;
use crate::studio::path_dialog::PathDialog;
use crate::studio::project::{PROJECT_EXTENSION, ViewMode};
use crate::studio::scan::is_scan;
use crate::studio::settings::{DialogAnswer, PathPurpose};
use crate::studio::state::{JobView, StudioApp};
use crate::studio::tasks::Task;
use std::path::{Path, PathBuf};

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
    /// A library clip name or a motion file (read from disk).
    LoadMotion(String),
    /// A motion file opened earlier in the session, from the clip list (not read again).
    ShowLoadedClip(String),
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
    /// The camera follows the posed body's root (on) or stays where it is (off).
    FollowRoot(bool),
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
            Command::OpenCapture(source) => self.open_capture(source, false),
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
            Command::ShowLoadedClip(s) => self.show_loaded_clip(&s),
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
            Command::FollowRoot(on) => {
                self.view.follow_root = on;
                self.follow_root();
                self.scene_dirty = true;
            }
            Command::Screenshot => self.screenshot_viewport(),
            Command::TogglePlay => {
                self.timeline.playing = !self.timeline.playing;
                if self.timeline.playing {
                    self.start_bake();
                    if self.options.timing
                        && let Some(open_s) = self.motion_open_s.take()
                    {
                        self.play_timing = Some((std::time::Instant::now(), open_s));
                    }
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
            self.open_capture(p.display().to_string(), false);
        } else if name.ends_with(PROJECT_EXTENSION) {
            self.open_project(&p);
        } else if name.ends_with(".avatar") {
            self.open_avatar(&p);
        } else if crate::studio::timeline::is_motion_file(&p) {
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
        // The timeline's range (the whole clip without one).
        let clip = self.timeline.range_clip();
        let range = match self.timeline.range() {
            Some((a, b)) => format!(", frames {a}-{b} of the clip"),
            None => String::new(),
        };
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
                "Exported {} ({} frames{range}, {} vertices, {:.2} MB)",
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
}
