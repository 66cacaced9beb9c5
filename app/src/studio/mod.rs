//! The studio: an eframe (egui + wgpu) desktop app over the avatar crates.
//!
//! Modules: `app` (state and per-frame logic), `panels` (the UI), `viewport` (the wgpu
//! renderer: scene + camera in, pixels out), `camera`, `avatar_job` (the avatar trait and the
//! background fine-tuning job), `posing` (the pose worker), `timeline`, `session` (captures),
//! `project` (the project file), `settings`, `screenshot`, `style`, `demo`.

pub mod app;
pub mod avatar_job;
pub mod bench;
pub mod camera;
pub mod demo;
pub mod panels;
pub mod posing;
pub mod project;
pub mod screenshot;
pub mod session;
pub mod settings;
pub mod style;
pub mod timeline;
pub mod viewport;

pub use app::{StudioApp, StudioOptions};

use eframe::egui;

/// The native window's options: wgpu (Vulkan, Metal, DX12 or GL; lavapipe on a machine with
/// no GPU), 1280 x 800, persistence on.
pub fn native_options() -> eframe::NativeOptions {
    eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_title("Avatar Studio").with_inner_size([1280.0, 800.0]).with_min_inner_size([800.0, 500.0]).with_app_id("avatar-studio"),
        renderer: eframe::Renderer::Wgpu,
        persist_window: true,
        ..Default::default()
    }
}

/// Open the studio window (blocks until it closes).
pub fn run(options: StudioOptions) -> anyhow::Result<()> {
    eframe::run_native("Avatar Studio", native_options(), Box::new(move |cc| Ok(Box::new(StudioApp::new(cc, options)))))
        .map_err(|e| anyhow::anyhow!("could not open the studio window: {e}"))
}
