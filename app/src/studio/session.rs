//! What the session holds and how it is opened and closed: the capture, the avatar (opened,
//! meshed, saved, closed when another capture opens), the motion (a library clip, a motion file,
//! one kept in the clip list) and the project. Called from `commands.rs`'s `apply`.

use crate::studio::avatar::{StudioAvatar, canonical_of, load_avatar};
use crate::studio::capture_view::{LoadedCapture, load_capture};
use crate::studio::posing::sdf_normals;
use crate::studio::project::{DEMO, MotionState, Project};
use crate::studio::scan::{fitting_beside, is_scan, scan_capture};
use crate::studio::settings::Settings;
use crate::studio::state::{AvatarReady, CaptureOpening, JobView, StudioApp};
use crate::studio::tasks::Task;
use crate::studio::timeline::Timeline;
use std::path::{Path, PathBuf};
use std::sync::Arc;

impl StudioApp {
    // ---- capture -------------------------------------------------------------------------

    /// Open a capture folder ("demo" = the embedded demo; an OBJ scan becomes a capture in the
    /// cache first) in the background. Once it is open, the avatar of another capture is closed
    /// (`close_avatar`) unless a project opens them together.
    pub(crate) fn open_capture(&mut self, source: String, with_project: bool) {
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
        let started = std::time::Instant::now();
        self.tasks.capture = Some(CaptureOpening { source, with_project, task, started });
    }

    /// Close the avatar and all that was made of it or for it: a running fit (cancelled), its
    /// loss plot and frame count, the partial result, the mesh being made, the bakes and the
    /// posed mesh (poses still on their way are not shown). An avatar never saved is saved
    /// first into `autosave_dir`; if that fails the avatar stays open and the error says so.
    /// Returns what to tell the user, if anything.
    pub(crate) fn close_avatar(&mut self) -> Result<Option<String>, String> {
        let mut notes = Vec::new();
        if let Some(a) = self.avatar.clone().filter(|_| !self.avatar_saved) {
            let name: String = self
                .capture
                .as_ref()
                .map_or("avatar", |c| c.name.as_str())
                .chars()
                .map(|c| if c.is_alphanumeric() || c == '-' { c } else { '_' })
                .collect();
            let secs = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            let path = self.autosave_dir.join(format!("{name}-{secs}.avatar"));
            let saved = std::fs::create_dir_all(&self.autosave_dir)
                .map_err(|e| format!("{}: {e}", self.autosave_dir.display()))
                .and_then(|()| a.save(&path).map_err(|e| e.to_string()));
            match saved {
                Ok(()) => notes.push(format!("its unsaved avatar is kept in {}", path.display())),
                Err(e) => {
                    return Err(format!(
                        "The unsaved avatar could not be kept ({e}): it stays open; save it with File > Save avatar"
                    ));
                }
            }
        }
        if let Some(job) = self.job.take() {
            job.cancel(); // and dropped: its thread stops, nothing was written
            notes.push("its fine-tuning was cancelled".into());
        }
        let had = self.avatar.is_some() || !notes.is_empty();
        self.avatar = None;
        self.avatar_path = None;
        self.avatar_saved = true;
        self.avatar_canonical = None;
        self.avatar_normals = None;
        self.tasks.avatar = None;
        self.preview = None;
        self.job_view = JobView::default();
        self.bakes.clear();
        self.posed = None;
        self.pose_floor = self.poser.latest + 1;
        self.pose_needed = true;
        self.scene_dirty = true;
        Ok(had.then(|| {
            let mut m = "the previous avatar is closed".to_string();
            for n in notes {
                m += &format!("; {n}");
            }
            m
        }))
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
    pub(crate) fn open_avatar(&mut self, path: &Path) {
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
    pub(crate) fn inputs(&self) -> avatar_core::io::Inputs {
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

    pub(crate) fn save_avatar_to(&mut self, path: &Path) {
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

    // ---- project -------------------------------------------------------------------------

    pub fn project(&self) -> Project {
        let motion = MotionState {
            clip: self.timeline.clip_source.clone(),
            frame: self.timeline.current_frame(),
            speed: self.timeline.speed,
            offsets: self.timeline.offsets.to_vec(),
            range: self.timeline.range().map(|(a, b)| [a, b]),
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

    pub(crate) fn open_project(&mut self, path: &Path) {
        let p = match Project::load(path) {
            Ok(p) => p,
            Err(e) => return self.fail(format!("Could not open the project: {e}")),
        };
        // The project's capture and avatar replace the session's.
        let closed = match self.close_avatar() {
            Ok(m) => m,
            Err(e) => return self.fail(format!("Could not open the project: {e}")),
        };
        if let Some(c) = &p.capture {
            self.open_capture(c.clone(), true);
        }
        match Timeline::open(&p.motion.clip) {
            Ok(mut t) => {
                t.speed = p.motion.speed;
                for (j, o) in p.motion.offsets.iter().enumerate().take(t.offsets.len()) {
                    t.offsets[j] = *o;
                }
                if let Some([a, b]) = p.motion.range {
                    t.set_range(a, b);
                }
                t.set_frame(p.motion.frame);
                self.loaded_clips.keep(&t);
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
        if let Some(m) = closed {
            self.info(format!("Opening the project {}: {m}", path.display()));
        }
        self.pose_needed = true;
        self.scene_dirty = true;
    }

    /// A library clip or a motion file (read, and kept in the clip list).
    pub(crate) fn load_motion(&mut self, source: &str) {
        let t0 = std::time::Instant::now();
        match Timeline::open(source) {
            Ok(t) => {
                self.motion_open_s = Some(t0.elapsed().as_secs_f64()); // --timing
                self.show_motion(t)
            }
            Err(e) => self.fail(format!("Could not open the motion: {e}")),
        }
    }

    /// A motion file kept in the clip list, without reading it again.
    pub(crate) fn show_loaded_clip(&mut self, source: &str) {
        match self.loaded_clips.timeline(source) {
            Some(t) => self.show_motion(t),
            None => self.load_motion(source),
        }
    }

    /// Another clip on the timeline (the joint offsets and speed stay): the running bake stops
    /// and its frames are dropped; a motion file joins the clip list.
    fn show_motion(&mut self, mut t: Timeline) {
        t.offsets = self.timeline.offsets;
        t.speed = self.timeline.speed;
        self.bakes.cancel();
        self.loaded_clips.keep(&t);
        let source = if t.clip.source_fps != t.clip.fps {
            format!(", {} fps source", (t.clip.source_fps * 100.0).round() / 100.0)
        } else {
            String::new()
        };
        self.info(format!(
            "Motion {} ({} frames at {} fps{source})",
            t.clip.name,
            t.frames(),
            t.clip.fps
        ));
        self.timeline = t;
        self.pose_needed = true;
    }
}
