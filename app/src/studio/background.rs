//! The one place where the studio takes the results of its background work (capture loading,
//! avatar meshing, export, fine-tuning, posing and playback bakes), once per frame.

use crate::studio::avatar::body_canonical;
use crate::studio::avatar_job::JobEvent;
use crate::studio::capture_view::LoadedCapture;
use crate::studio::project::DEMO;
use crate::studio::settings::Settings;
use crate::studio::state::StudioApp;
use crate::studio::tasks::take_done;
use eframe::egui;
use std::sync::Arc;
use std::time::Instant;

impl StudioApp {
    pub(crate) fn poll_tasks(&mut self) {
        if let Some(r) = self.tasks.capture.as_ref().and_then(|c| c.task.poll()) {
            let opening = self.tasks.capture.take().expect("polled above");
            let source = opening.source;
            match r {
                Ok(c) => {
                    if self.options.timing {
                        eprintln!(
                            "timing: capture {} ({} frames, {} read) opened in {:.3} s",
                            c.dir.display(),
                            c.frames.len(),
                            c.first_reads.len(),
                            opening.started.elapsed().as_secs_f64()
                        );
                    }
                    self.capture_loaded(source, c, opening.with_project)
                }
                Err(e) => {
                    let what = if source == DEMO {
                        "the demo capture".to_string()
                    } else {
                        source.clone()
                    };
                    self.fail(format!("Could not open {what}: {e}"));
                    self.scene_dirty = true;
                }
            }
        }
        match take_done(&mut self.tasks.avatar) {
            Some(Ok(ready)) => {
                let already = self.avatar.as_ref().is_some_and(|a| Arc::ptr_eq(a, &ready.avatar));
                if !already {
                    self.info(format!("Opened the avatar ({})", ready.avatar.describe()));
                    self.avatar_saved = ready.path.is_some();
                    self.avatar_path = ready.path.clone();
                    self.avatar = Some(ready.avatar);
                }
                self.avatar_canonical = Some(ready.mesh);
                self.avatar_normals = ready.normals;
                self.preview = None;
                self.pose_needed = true;
                self.scene_dirty = true;
            }
            Some(Err(e)) => self.fail(e.to_string()),
            None => {}
        }
        if let Some(task) = &self.tasks.export
            && let Some(p) = task.events.try_iter().last()
        {
            self.tasks.export_progress = Some(p);
        }
        match take_done(&mut self.tasks.export) {
            Some(Ok(m)) => self.info(m),
            Some(Err(e)) => self.fail(format!("Export failed: {e}")),
            None => {}
        }
        self.poll_job();
        match self.bakes.poll() {
            Some(Ok(b)) => {
                if b.seconds.is_nan() {
                    self.info(format!(
                        "Kept {} baked frames for playback; the others are posed live",
                        b.frames.len()
                    ));
                } else {
                    self.info(format!(
                        "Baked {} frames for playback in {:.1} s",
                        b.frames.len(),
                        b.seconds
                    ));
                }
                self.show_baked();
            }
            Some(Err(e)) => self.fail(format!("{e}")),
            None => {}
        }
        self.poll_pose();
        self.poll_frames();
    }

    /// Take the frames read on demand; in the depth view, ask for the shown frame's points.
    fn poll_frames(&mut self) {
        if self.frame_store.poll(&self.ctx) {
            self.scene_dirty = true;
        }
        if let Some(e) = self.frame_store.failed.take() {
            self.fail(format!("Could not read the capture's frames: {e}"));
        }
        if self.view.mode == crate::studio::project::ViewMode::Capture && self.capture.is_some() {
            // Held, or asked for: the scene shows it once it is read.
            let _ = self.frame_store.points(self.view.selected_frame);
        }
    }

    fn capture_loaded(&mut self, source: String, mut capture: LoadedCapture, with_project: bool) {
        // Another capture is another person: the avatar of the one before is closed (a
        // project's capture comes with its own avatar; reopening the same capture keeps it).
        let closed = if with_project || self.capture_source.as_deref() == Some(source.as_str()) {
            Ok(None)
        } else {
            self.close_avatar()
        };
        // The previous capture's frames (and their reading thread) go first.
        self.frame_store = Default::default();
        self.frame_store = crate::studio::capture_frames::FrameStore::new(
            &self.ctx,
            &capture.name,
            capture.frames.len(),
            capture.source.clone(),
            std::mem::take(&mut capture.first_reads),
            self.wake(),
        );
        self.body_rest = Some(Arc::new(body_canonical(&capture.body, &capture.betas)));
        match self.pending_view.take() {
            Some(v) => {
                self.view = v;
                self.view.selected_frame =
                    self.view.selected_frame.min(capture.frames.len().saturating_sub(1));
                self.framed = true;
            }
            None => {
                self.view.selected_frame = capture.first_usable;
                self.framed = false;
            }
        }
        let (checked, usable) = (self.frame_store.checked(), self.frame_store.usable());
        let flagged = checked - usable;
        let counts = if checked == capture.frames.len() {
            format!("{usable} usable")
        } else {
            format!(
                "{usable} of the {checked} checked usable, the others checked as they are shown"
            )
        };
        let msg = format!(
            "Opened {}: {} frames, {counts}{}",
            if source == DEMO {
                "the demo capture".to_string()
            } else if crate::studio::scan::is_scan(std::path::Path::new(&source)) {
                format!("the scan {source}")
            } else {
                capture.dir.display().to_string()
            },
            capture.frames.len(),
            if flagged > 0 { format!(", {flagged} flagged") } else { String::new() }
        );
        match closed {
            Ok(Some(note)) => self.info(format!("{msg}; {note}")),
            Ok(None) => self.info(msg),
            Err(e) => self.fail(e),
        }
        if source != DEMO {
            Settings::push_recent(&mut self.settings.recent_captures, &source);
        }
        let title = if source == DEMO {
            "Avatar Studio - demo capture".to_string()
        } else {
            format!("Avatar Studio - {}", capture.name)
        };
        self.ctx.send_viewport_cmd(egui::ViewportCommand::Title(title));
        self.capture = Some(Arc::new(capture));
        self.capture_source = Some(source);
        if let Some(cfg) = self.options.auto_fit.take() {
            self.apply(crate::studio::commands::Command::StartFit(cfg));
        }
        if !matches!(self.status, Some(crate::studio::state::Status::Error(_))) {
            self.error = None;
        }
        self.pose_needed = true;
        self.scene_dirty = true;
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
                JobEvent::Phase { label, left_s } => {
                    self.job_view.phase = label;
                    self.job_view.left_s = left_s;
                }
                JobEvent::Progress { step, steps, loss, terms, elapsed_s, left_s } => {
                    self.job_view.left_s = left_s;
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
                let what = if cancelled {
                    "Fine-tuning cancelled: the partial avatar is loaded"
                } else {
                    "Fine-tuning finished"
                };
                let text = format!(
                    "{what} ({}, {seconds:.1} s){}",
                    avatar.describe(),
                    if warnings.is_empty() {
                        String::new()
                    } else {
                        format!("; {} warnings", warnings.len())
                    }
                );
                self.job_view.finished = Some(text.clone());
                self.info(text);
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

    // ---- posing and playback -------------------------------------------------------------

    /// The bake of the current clip for what is shown now, if it is done.
    fn current_bake(
        &self,
    ) -> Option<(crate::studio::playback::BakeKey, crate::studio::posing::Posable)> {
        let posable = self.posable()?;
        Some((crate::studio::playback::BakeKey::of_timeline(&posable, &self.timeline), posable))
    }

    /// The frames of the current clip baked for what is shown now (first, count).
    pub fn baked_spans(&self) -> Vec<(usize, usize)> {
        self.current_bake().map(|(key, _)| self.bakes.baked_spans(&key)).unwrap_or_default()
    }

    /// Bake the clip's poses for playback (its range; in the background, once per posable,
    /// clip and range). Nothing is baked while a fit runs: its partial result changes.
    pub(crate) fn start_bake(&mut self) {
        if self.job.is_some() {
            return;
        }
        let Some((key, posable)) = self.current_bake() else { return };
        let params = crate::studio::playback::range_params(&self.timeline, &self.betas());
        let (body, wake) = (self.body(), self.wake());
        let from = self.timeline.current_frame();
        self.bakes.start(key, from, posable.exact(), body, params, wake);
    }

    /// While the clip's bake runs, playback does not run ahead of it: from a baked frame (or
    /// the one the bake makes next) the playhead goes no further than the last frame baked on
    /// its way, so every frame played is baked and no live pose takes the cores from the bake.
    /// `from` is the frame before the timeline advanced. The bake begins at the playhead
    /// (`start_bake`), so playing from anywhere in the range plays at the bake's pace.
    pub(crate) fn hold_for_bake(&mut self, from: usize) {
        let Some((key, _)) = self.current_bake() else { return };
        let Some(((first, count), Some(next))) = self.bakes.running_span(&key) else { return };
        let f = self.timeline.current_frame();
        let baked = |g: usize| self.bakes.frame(&key, g).is_some();
        if !(first..first + count).contains(&f) || baked(f) || !(baked(from) || from == next) {
            return;
        }
        // The frame before the bake's next, if it lies between `from` and `f` in play order.
        let (a, b) = self.timeline.play_range();
        let ahead = |x: usize, y: usize| (y + (b - a + 1) - x) % (b - a + 1);
        let last = if next == a { b } else { next - 1 };
        let hold = if from != next && baked(last) && ahead(from, last) < ahead(from, f) {
            last
        } else {
            from
        };
        self.timeline.frame = hold as f32;
    }

    /// Show the baked mesh of the current frame, if it is baked (by a finished bake or the
    /// running one). Returns true if shown.
    fn show_baked(&mut self) -> bool {
        let Some((key, _)) = self.current_bake() else { return false };
        let Some(frame) = self.bakes.frame(&key, self.timeline.current_frame()) else {
            return false;
        };
        if !self.posed.as_ref().is_some_and(|p| Arc::ptr_eq(p, &frame)) {
            self.posed = Some(frame);
            self.scene_dirty = true;
        }
        true
    }

    /// Pose the current frame: from the bake when there is one, else ask the pose worker.
    pub(crate) fn request_pose(&mut self) {
        self.pose_needed = false;
        if self.show_baked() {
            self.last_request_to_mesh = Some(0.0);
            return;
        }
        let Some(posable) = self.posable() else { return };
        let params = self.timeline.params(&self.betas());
        self.poser.request(params, posable, self.body());
        self.pose_requested_at = Some(Instant::now());
    }

    fn poll_pose(&mut self) {
        if let Some(r) = self.poser.poll() {
            match r {
                // A pose of an avatar closed since is dropped.
                Ok(m) if m.id < self.pose_floor => {}
                Ok(m) => {
                    self.last_pose_seconds = Some(m.seconds);
                    if m.id == self.poser.latest {
                        self.last_request_to_mesh =
                            self.pose_requested_at.map(|t| t.elapsed().as_secs_f64());
                    }
                    // A baked frame shown meanwhile is newer than a live pose that arrives late.
                    if !self.show_baked() {
                        self.posed = Some(Arc::new(m));
                        self.scene_dirty = true;
                    }
                }
                Err(e) => {
                    self.pose_failed = Some(e.id);
                    self.fail(format!("Posing failed: {e}"));
                }
            }
        }
    }
}
