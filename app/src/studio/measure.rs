//! `--measure-playback` (hidden): the studio's own playback rate in a real window, everything
//! drawn (egui's panels and the viewport). Once the studio is idle (the capture open and, with
//! `--quick-fit`, the avatar fitted and meshed) it presses Play; after the clip is baked it
//! counts the frames drawn and the clip frames shown for 5 s, prints them and closes.
//!
//! With `--timing`, a motion file's time to its first playable frame: the file read (and
//! resampled) when it is opened, then Play to the first baked frame drawn.

use crate::studio::commands::Command;
use crate::studio::state::{PlaybackMeasure, StudioApp};
use eframe::egui;
use std::time::Instant;

/// How long the frames are counted.
const SECONDS: f64 = 5.0;

impl StudioApp {
    /// With `--timing`: once Play was pressed on a motion file and a baked frame is drawn, print
    /// the file's opening time and Play to that frame (called after every frame).
    pub(crate) fn report_first_playable(&mut self) {
        let Some((play, open_s)) = self.play_timing else { return };
        if self.posed.as_ref().is_none_or(|p| p.id != 0) {
            return; // a baked frame is shown (id 0)
        }
        let play_s = play.elapsed().as_secs_f64();
        let c = &self.timeline.clip;
        eprintln!(
            "timing: motion {} ({} frames at {} fps, {} fps source): opened in {open_s:.3} s; Play to its first baked frame drawn {play_s:.3} s; first playable frame {:.3} s after the open began (Play at once)",
            self.timeline.clip_source,
            c.frames.len(),
            c.fps,
            (c.source_fps * 100.0).round() / 100.0,
            open_s + play_s
        );
        self.play_timing = None;
    }

    /// Called after every frame.
    pub(crate) fn measure_playback(&mut self) {
        if !self.options.measure_playback {
            return;
        }
        self.ctx.request_repaint();
        let frame = self.timeline.current_frame();
        match self.playback_measure {
            None => {
                if self.capture.is_some() && self.posed.is_some() && !self.busy() {
                    self.apply(Command::TogglePlay);
                    self.playback_measure = Some(PlaybackMeasure::Baking);
                }
            }
            Some(PlaybackMeasure::Baking) => {
                let baked = self.posed.as_ref().is_some_and(|p| p.id == 0); // a baked frame is shown
                if !self.bakes.baking() && baked && self.timeline.playing {
                    self.playback_measure = Some(PlaybackMeasure::Counting {
                        start: Instant::now(),
                        cpu: cpu_seconds(),
                        drawn: self.frames_drawn,
                        shown: 0,
                        last: frame,
                    });
                }
            }
            Some(PlaybackMeasure::Counting { start, cpu, drawn, shown, last }) => {
                let shown = shown + usize::from(frame != last);
                let s = start.elapsed().as_secs_f64();
                if s < SECONDS {
                    self.playback_measure =
                        Some(PlaybackMeasure::Counting { start, cpu, drawn, shown, last: frame });
                    return;
                }
                let frames = self.frames_drawn - drawn;
                let px = self
                    .viewport_rect
                    .map(|r| r.size() * self.ctx.pixels_per_point())
                    .unwrap_or_default();
                let vertices = self.posed.as_ref().map_or(0, |p| p.positions.len());
                eprintln!(
                    "timing: playback of the baked {} clip ({vertices} vertices): {frames} frames drawn in {s:.1} s ({:.1} fps), {shown} clip frames shown ({:.1} a second; the clip has {:.0} fps), viewport {:.0} x {:.0} px, {:.0} ms of CPU (all threads) a frame",
                    self.timeline.clip.name,
                    frames as f64 / s,
                    shown as f64 / s,
                    self.timeline.clip.fps,
                    px.x,
                    px.y,
                    (cpu_seconds() - cpu) * 1e3 / frames.max(1) as f64
                );
                self.playback_measure = Some(PlaybackMeasure::Done);
                self.ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
            Some(PlaybackMeasure::Done) => {}
        }
    }
}

/// CPU time of the whole process (all threads) in seconds, from /proc (0 where there is none;
/// also `fit --timings`).
pub fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // The fields after the command's closing parenthesis; utime and stime are the 12th and 13th.
    let fields: Vec<&str> =
        stat.rsplit_once(')').map_or("", |(_, r)| r).split_whitespace().collect();
    let ticks: f64 =
        fields.get(11..13).map_or(0.0, |f| f.iter().filter_map(|v| v.parse::<f64>().ok()).sum());
    ticks / 100.0 // USER_HZ
}
