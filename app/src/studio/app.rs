//! The studio as an eframe app: start-up, and per frame: take the background work's results,
//! advance the timeline, pose, rebuild the scene if something changed, draw the panels and
//! apply the commands they return. The state is in `state.rs`, what commands do in
//! `commands.rs`, the scene in `scene.rs`, the panels in `panels/`.

use crate::studio::commands::Command;
use crate::studio::path_dialog::PathDialogOutcome;
use crate::studio::posing::PoseWorker;
use crate::studio::project::{DEMO, ViewMode, ViewState};
use crate::studio::settings::{RfdDialogs, SETTINGS_KEY, Settings};
use crate::studio::state::{JobView, StudioApp, StudioOptions, Tasks};
use crate::studio::timeline::{Timeline, is_motion_file};
use crate::studio::viewport::{self, Scene};
use eframe::egui;
use std::sync::Arc;

/// The turntable's speed (radians per second): a turn in about 12 s.
const TURNTABLE_SPEED: f32 = 0.5;

impl StudioApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: StudioOptions) -> StudioApp {
        // On a software renderer the panels' fill and the thumbnails are painted by
        // viewport::flat, not by egui (the same pixels, a fraction of the CPU).
        // `AVATAR_STUDIO_FLAT=0` turns that off, for comparisons (docs/studio.md).
        let flat = cc.wgpu_render_state.as_ref().is_some_and(|rs| {
            let on = viewport::install(rs)
                && std::env::var("AVATAR_STUDIO_FLAT").map_or(true, |v| v != "0");
            if on {
                viewport::flat::install(rs, crate::studio::style::PANEL_FILL);
                viewport::ui_meshes::install(rs);
            }
            on
        });
        crate::studio::style::apply(&cc.egui_ctx, flat);
        let settings: Settings =
            cc.storage.and_then(|s| eframe::get_value(s, SETTINGS_KEY)).unwrap_or_default();
        let ctx = cc.egui_ctx.clone();
        let wake_ctx = ctx.clone();
        let poser = PoseWorker::start(move || wake_ctx.request_repaint());
        let timeline = Timeline::library("walk")
            .or_else(|| Timeline::library(avatar_core::motion::clip_names()[0]))
            .expect("the motion library has clips");
        let view = ViewState {
            shading: settings.shading,
            skeleton: settings.skeleton,
            material: settings.material,
            light: settings.light,
            ..ViewState::default()
        };
        let mut app = StudioApp {
            ctx,
            options: options.clone(),
            dialogs: Box::new(RfdDialogs),
            native_dialogs_failed: false,
            path_dialog: None,
            settings,
            tasks: Tasks::default(),
            capture: None,
            capture_source: None,
            frame_store: Default::default(),
            flat,
            body_rest: None,
            avatar: None,
            avatar_path: None,
            avatar_saved: true,
            avatar_canonical: None,
            avatar_normals: None,
            job: None,
            job_view: JobView::default(),
            preview: None,
            poser,
            posed: None,
            pose_needed: true,
            last_pose_seconds: None,
            pose_failed: None,
            pose_floor: 0,
            pose_requested_at: None,
            last_request_to_mesh: None,
            bakes: Default::default(),
            timeline,
            loaded_clips: Default::default(),
            view,
            scene: Arc::new(Scene::new()),
            scene_dirty: true,
            framed: false,
            viewport_rect: None,
            turntable: false,
            viewport_moving: false,
            ui_meshes_painted: false,
            playback_measure: None,
            motion_open_s: None,
            play_timing: None,
            show_shortcuts: false,
            status: None,
            error: None,
            frames_drawn: 0,
            first_frame_reported: false,
            ready_reported: false,
            screenshot_state: None,
            show_timings: true,
            pending_view: None,
            screenshot_dir: crate::studio::screenshot::default_screenshot_dir(),
            autosave_dir: crate::studio::demo::cache_dir().join("unsaved-avatars"),
            path_field: String::new(),
            project_path: None,
        };
        if let Some(p) = &options.project {
            app.apply(Command::OpenProject(p.clone()));
        } else if let Some(c) = options.capture.as_ref().filter(|c| is_motion_file(c)) {
            // A motion file: the demo capture with that motion.
            app.apply(Command::OpenCapture(DEMO.to_string()));
            app.apply(Command::LoadMotion(c.display().to_string()));
        } else if let Some(c) = &options.capture {
            app.apply(Command::OpenCapture(c.display().to_string()));
        } else if options.load_demo {
            app.apply(Command::OpenCapture(DEMO.to_string()));
        }
        app
    }

    /// Poll background work and rebuild what changed (called at the start of every frame).
    pub fn update_state(&mut self) {
        self.poll_tasks();
        let dt = self.ctx.input(|i| i.stable_dt).min(0.1);
        let from = self.timeline.current_frame();
        if self.timeline.tick(dt) {
            self.hold_for_bake(from);
            self.pose_needed = true;
        }
        if self.timeline.playing {
            self.start_bake(); // once per clip and posable; nothing when it exists or runs
            self.ctx.request_repaint();
        }
        if self.turntable {
            self.view.camera.turn(dt * TURNTABLE_SPEED);
            self.ctx.request_repaint();
        }
        if self.pose_needed {
            self.request_pose();
        }
        if self.scene_dirty {
            self.follow_root();
            self.scene = Arc::new(self.build_scene());
            self.scene_dirty = false;
            if !self.framed
                && (self.posed.is_some() || self.view.mode != ViewMode::Posed)
                && let Some((lo, hi)) = self.scene.bounds()
            {
                self.view.camera.frame(lo, hi);
                self.framed = true;
            }
        }
    }

    /// The in-app path dialog, when one is open; its answer becomes a command.
    fn path_dialog(&mut self, ctx: &egui::Context) -> Option<Command> {
        let outcome = self.path_dialog.as_mut()?.show(ctx)?;
        let purpose = self.path_dialog.take()?.request.purpose;
        match outcome {
            PathDialogOutcome::Chosen(p) => Some(Command::answer(purpose, p)),
            PathDialogOutcome::Cancelled => None,
        }
    }
}

impl eframe::App for StudioApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        self.update_state();
        let mut commands = crate::studio::panels::draw(self, ui);
        commands.extend(self.path_dialog(ui.ctx()));
        self.apply_all(commands);
        self.frames_drawn += 1;
        self.after_frame();
        self.report_first_playable();
        self.measure_playback();
        // While the view moves on a software renderer, the panels' text and widgets too are
        // painted by our shader (viewport/ui_meshes.rs); a still window is egui's.
        self.ui_meshes_painted = self.flat
            && self.viewport_moving
            && frame
                .wgpu_render_state()
                .is_some_and(|rs| viewport::ui_meshes::take_over(ui.ctx(), rs));
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        self.settings.shading = self.view.shading;
        self.settings.skeleton = self.view.skeleton;
        self.settings.material = self.view.material;
        self.settings.light = self.view.light;
        eframe::set_value(storage, SETTINGS_KEY, &self.settings);
    }

    fn on_exit(&mut self) {
        // A running job is cancelled; it writes nothing to disk, so nothing is left half done.
        if let Some(j) = &self.job {
            j.cancel();
        }
        self.bakes.cancel();
    }
}
