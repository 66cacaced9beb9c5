//! Screenshots: P saves the viewport; `StudioOptions::screenshot` saves the whole window once
//! the studio is idle and then closes it (for README images taken from a real window).

use crate::error::StudioError;
use crate::studio::state::{Status, StudioApp};
use eframe::egui;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

const PENDING: u8 = 1;
const SAVED: u8 = 2;
const FAILED: u8 = 3;

/// Encode and write (atomically) an egui image as PNG, cropped to `crop` (pixels) if given.
pub fn save_png(
    image: &egui::ColorImage,
    crop: Option<egui::Rect>,
    path: &Path,
) -> crate::error::Result<()> {
    let [w, h] = image.size;
    let (x0, y0, x1, y1) = match crop {
        Some(r) => (
            (r.min.x.max(0.0) as usize).min(w),
            (r.min.y.max(0.0) as usize).min(h),
            (r.max.x.max(0.0) as usize).min(w),
            (r.max.y.max(0.0) as usize).min(h),
        ),
        None => (0, 0, w, h),
    };
    if x1 <= x0 || y1 <= y0 {
        return Err(StudioError::invalid("empty screenshot"));
    }
    let mut buf = image::RgbaImage::new((x1 - x0) as u32, (y1 - y0) as u32);
    for y in y0..y1 {
        for x in x0..x1 {
            let c = image.pixels[y * w + x];
            buf.put_pixel(
                (x - x0) as u32,
                (y - y0) as u32,
                image::Rgba([c.r(), c.g(), c.b(), 255]),
            );
        }
    }
    let mut bytes = Vec::new();
    buf.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| StudioError::file(path, format!("cannot encode the PNG: {e}")))?;
    avatar_core::io::write_bytes_atomic(path, &bytes)?;
    Ok(())
}

/// Where P saves screenshots: `AVATAR_STUDIO_SCREENSHOT_DIR`, else the current folder.
pub fn default_screenshot_dir() -> PathBuf {
    std::env::var_os("AVATAR_STUDIO_SCREENSHOT_DIR")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn screenshot_path(dir: &Path) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let mut path = dir.join(format!("avatar-studio-{secs}.png"));
    let mut n = 1;
    while path.exists() {
        n += 1;
        path = dir.join(format!("avatar-studio-{secs}-{n}.png"));
    }
    path
}

impl StudioApp {
    /// Save the viewport as a PNG (P).
    pub fn screenshot_viewport(&mut self) {
        let path = screenshot_path(&self.screenshot_dir);
        let ppp = self.ctx.pixels_per_point();
        let crop = self.viewport_rect.map(|r| {
            egui::Rect::from_min_max(
                (r.min.to_vec2() * ppp).to_pos2(),
                (r.max.to_vec2() * ppp).to_pos2(),
            )
        });
        let p = path.clone();
        self.ctx.request_screenshot(move |img| {
            if let Err(e) = save_png(&img, crop, &p) {
                eprintln!("screenshot: {e}");
            }
        });
        self.status = Some(Status::Info(format!("Screenshot: {}", path.display())));
    }

    /// Timings and the automatic screenshot, after each frame.
    pub(crate) fn after_frame(&mut self) {
        if let Some(t0) = self.options.started {
            if !self.first_frame_reported {
                self.first_frame_reported = true;
                if self.options.timing {
                    eprintln!(
                        "timing: first frame {:.3} s after start",
                        t0.elapsed().as_secs_f64()
                    );
                }
            }
            if !self.ready_reported
                && self.capture.is_some()
                && self.posed.is_some()
                && !self.busy()
            {
                self.ready_reported = true;
                if self.options.timing {
                    eprintln!(
                        "timing: demo loaded and posed {:.3} s after start",
                        t0.elapsed().as_secs_f64()
                    );
                }
            }
        }
        let Some(path) = self.options.screenshot.clone() else { return };
        match &self.screenshot_state {
            None => {
                // Idle (or an error shown) and a few frames drawn: take it.
                if self.frames_drawn > 5 && (!self.busy() || self.error.is_some()) {
                    let state = Arc::new(AtomicU8::new(PENDING));
                    let s = state.clone();
                    let ctx = self.ctx.clone();
                    self.ctx.request_screenshot(move |img| {
                        let ok = save_png(&img, None, &path)
                            .map_err(|e| eprintln!("screenshot: {e}"))
                            .is_ok();
                        s.store(if ok { SAVED } else { FAILED }, Ordering::SeqCst);
                        ctx.request_repaint();
                    });
                    self.screenshot_state = Some(state);
                }
                self.ctx.request_repaint();
            }
            Some(state) => match state.load(Ordering::SeqCst) {
                PENDING => self.ctx.request_repaint(),
                _ => self.ctx.send_viewport_cmd(egui::ViewportCommand::Close),
            },
        }
    }
}
