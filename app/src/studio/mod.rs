//! The studio: an eframe (egui + wgpu) desktop app over the avatar crates.
//!
//! The state (`state`) is changed in one place (`commands`, from the [`commands::Command`]s the
//! panels return; `session` opens and closes the capture, avatar, motion and project for it);
//! background work (`tasks`) is polled in one place (`background`); the
//! viewport's scene is built from the state (`scene`). Modules: `app` (start-up and the
//! frame), `panels` (the UI), `viewport` (the wgpu renderer: scene + camera in, pixels out),
//! `camera`, `avatar` (what the studio needs from an avatar), `fit_config` (the fit settings),
//! `avatar_job` (the fine-tuning job), `posing` (the pose
//! worker), `playback` (baked clips), `timeline`, `capture_view` (a capture as the studio shows
//! it), `scan` (an OBJ scan opened as a capture), `project` (the project file), `settings` (and the native dialogs), `path_dialog` (the
//! in-app one), `measure` (the playback rate in a real window), `screenshot`, `style`, `demo`.

pub mod app;
pub mod avatar;
pub mod avatar_job;
mod background;
pub mod bench;
pub mod camera;
pub mod capture_frames;
pub mod capture_view;
pub mod commands;
pub mod demo;
pub mod fit_config;
pub mod measure;
pub mod panels;
pub mod path_dialog;
pub mod playback;
pub mod posing;
pub mod project;
pub mod scan;
pub mod scene;
pub mod screenshot;
mod session;
pub mod settings;
pub mod state;
pub mod style;
pub mod tasks;
pub mod timeline;
pub mod viewport;

pub use commands::Command;
pub use state::{StudioApp, StudioOptions};

use eframe::egui;

/// The native window's options: wgpu (Vulkan, Metal, DX12 or GL; lavapipe on a machine with
/// no GPU), 1280 x 800, persistence on.
pub fn native_options() -> eframe::NativeOptions {
    eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("Avatar Studio")
            .with_inner_size([1280.0, 800.0])
            .with_min_inner_size([800.0, 500.0])
            .with_app_id("avatar-studio"),
        renderer: eframe::Renderer::Wgpu,
        persist_window: true,
        ..Default::default()
    }
}

/// Open the studio window (blocks until it closes).
pub fn run(options: StudioOptions) -> crate::error::Result<()> {
    eframe::run_native(
        "Avatar Studio",
        native_options(),
        Box::new(move |cc| Ok(Box::new(StudioApp::new(cc, options)))),
    )
    .map_err(|e| {
        crate::error::StudioError::invalid(format!("could not open the studio window: {e}"))
    })
}
