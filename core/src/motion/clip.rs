//! `MotionClip`: a named pose sequence at a frame rate, and its JSON file format.
//!
//! ```json
//! {"format": "avatar-studio-motion", "version": 1, "name": "walk", "fps": 30,
//!  "source_fps": 120 (optional: the rate it was recorded at, when resampled),
//!  "frames": [{"pose": [72 floats, axis-angle radians], "trans": [x, y, z], "betas": [..] (optional)}, ...]}
//! ```

use crate::body::BodyParams;
use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

pub const MOTION_FORMAT: &str = "avatar-studio-motion";
pub const MOTION_VERSION: u32 = 1;
/// Plausible frame rates of a clip file (frames per second).
pub const MIN_FPS: f32 = 1.0;
pub const MAX_FPS: f32 = 1000.0;
/// The longest clip read or made (frames): 100,000 frames are 14 minutes at 120 fps, 55 at
/// 30 fps. A longer file is refused up front, naming the file and this limit.
pub const MAX_CLIP_FRAMES: usize = 100_000;

#[derive(Debug, Clone, PartialEq)]
pub struct MotionClip {
    pub name: String,
    /// Frames per second (> 0).
    pub fps: f32,
    /// The frame rate the motion was recorded at: `fps` unless the clip was resampled
    /// ([`MotionClip::resample`]).
    pub source_fps: f32,
    pub frames: Vec<BodyParams>,
}

#[derive(Serialize, Deserialize)]
struct ClipFile {
    format: String,
    version: u32,
    name: String,
    fps: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    source_fps: Option<f32>,
    frames: Vec<FrameFile>,
}

#[derive(Serialize, Deserialize)]
struct FrameFile {
    pose: Vec<f32>,
    #[serde(default)]
    trans: Option<Vec<f32>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    betas: Option<Vec<f32>>,
}

impl MotionClip {
    pub fn new(name: impl Into<String>, fps: f32, frames: Vec<BodyParams>) -> Self {
        MotionClip { name: name.into(), fps, source_fps: fps, frames }
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Duration in seconds (frame count / fps).
    pub fn duration(&self) -> f32 {
        self.frames.len() as f32 / self.fps
    }

    /// Reject empty clips, a bad frame rate and invalid frames (names the frame).
    pub fn validate(&self) -> Result<()> {
        if !(MIN_FPS..=MAX_FPS).contains(&self.fps) {
            return Err(Error::invalid(format!(
                "motion '{}': fps {} is not a plausible frame rate ({MIN_FPS} to {MAX_FPS})",
                self.name, self.fps
            )));
        }
        if self.frames.is_empty() {
            return Err(Error::invalid(format!("motion '{}' has no frames", self.name)));
        }
        check_length(&self.name, self.frames.len())?;
        if !(MIN_FPS..=MAX_FPS).contains(&self.source_fps) {
            return Err(Error::invalid(format!(
                "motion '{}': source fps {} is not a plausible frame rate ({MIN_FPS} to {MAX_FPS})",
                self.name, self.source_fps
            )));
        }
        for (i, f) in self.frames.iter().enumerate() {
            f.validate()
                .map_err(|e| Error::invalid(format!("motion '{}' frame {i}: {e}", self.name)))?;
        }
        Ok(())
    }

    /// The clip as JSON text: one frame per line, floats written losslessly.
    pub fn to_json_string(&self) -> String {
        let mut s = String::new();
        let name = serde_json::to_string(&self.name).unwrap_or_else(|_| "\"clip\"".into());
        let _ = write!(
            s,
            "{{\"format\": \"{MOTION_FORMAT}\", \"version\": {MOTION_VERSION}, \"name\": {name}, \"fps\": {}, ",
            num(self.fps)
        );
        if self.source_fps != self.fps {
            let _ = write!(s, "\"source_fps\": {}, ", num(self.source_fps));
        }
        s.push_str("\"frames\": [\n");
        for (i, f) in self.frames.iter().enumerate() {
            let pose: Vec<String> = f.flat_pose().into_iter().map(num).collect();
            let trans: Vec<String> = f.trans.to_array().into_iter().map(num).collect();
            let _ =
                write!(s, "  {{\"pose\": [{}], \"trans\": [{}]", pose.join(","), trans.join(","));
            if !f.betas.is_empty() {
                let betas: Vec<String> = f.betas.iter().copied().map(num).collect();
                let _ = write!(s, ", \"betas\": [{}]", betas.join(","));
            }
            s.push_str(if i + 1 < self.frames.len() { "},\n" } else { "}\n" });
        }
        s.push_str("]}\n");
        s
    }

    /// Write the clip as JSON (atomically).
    pub fn save_json(&self, path: impl AsRef<Path>) -> Result<()> {
        crate::io::write_bytes_atomic(path, self.to_json_string().as_bytes())
    }

    /// Parse the JSON clip format; errors name the problem and the frame.
    pub fn from_json_str(text: &str) -> Result<Self> {
        let file: ClipFile = serde_json::from_str(text)
            .map_err(|e| Error::invalid(format!("not a valid motion clip JSON ({e})")))?;
        if file.format != MOTION_FORMAT {
            return Err(Error::invalid(format!(
                "format is '{}', expected '{MOTION_FORMAT}'",
                file.format
            )));
        }
        if file.version != MOTION_VERSION {
            return Err(Error::invalid(format!(
                "version {} is not supported (expected {MOTION_VERSION})",
                file.version
            )));
        }
        check_length(&file.name, file.frames.len())?;
        let mut frames = Vec::with_capacity(file.frames.len());
        for (i, f) in file.frames.into_iter().enumerate() {
            let trans = match f.trans.as_deref() {
                None => Vec3::ZERO,
                Some([x, y, z]) => Vec3::new(*x, *y, *z),
                Some(t) => {
                    return Err(Error::invalid(format!(
                        "frame {i}: trans has {} values, expected 3",
                        t.len()
                    )));
                }
            };
            let params = BodyParams::from_flat(&f.pose, f.betas.unwrap_or_default(), trans)
                .map_err(|e| Error::invalid(format!("frame {i}: {e}")))?;
            frames.push(params);
        }
        let source_fps = file.source_fps.unwrap_or(file.fps);
        let clip = MotionClip { name: file.name, fps: file.fps, source_fps, frames };
        clip.validate()?;
        Ok(clip)
    }

    /// Every `step`-th frame (frame rate divided accordingly).
    pub fn subsample(&self, step: usize) -> MotionClip {
        let step = step.max(1);
        MotionClip {
            name: self.name.clone(),
            fps: self.fps / step as f32,
            source_fps: self.source_fps,
            frames: self.frames.iter().step_by(step).cloned().collect(),
        }
    }
}

/// Refuse a clip longer than [`MAX_CLIP_FRAMES`] (before anything is made of it).
pub fn check_length(name: &str, frames: usize) -> Result<()> {
    if frames > MAX_CLIP_FRAMES {
        return Err(Error::invalid(format!(
            "motion '{name}' has {frames} frames, over the supported {MAX_CLIP_FRAMES} (about 14 min at 120 fps)"
        )));
    }
    Ok(())
}

/// Shortest lossless text of an f32 (integers without a trailing ".0").
fn num(x: f32) -> String {
    if x == x.trunc() && x.abs() < 1e7 { format!("{}", x as i64) } else { format!("{x}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clip() -> MotionClip {
        let mut a = BodyParams::default();
        a.pose[18] = Vec3::new(0.0, -1.234_567_8, 0.1);
        a.trans = Vec3::new(0.0, -0.05, 0.3);
        let mut b = a.clone();
        b.pose[0] = Vec3::new(0.0, 0.7, 0.0);
        b.betas = vec![0.5, -0.25];
        MotionClip::new("test \"clip\"", 30.0, vec![a, b])
    }

    #[test]
    fn json_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.json");
        let c = clip();
        c.save_json(&path).unwrap();
        let back = MotionClip::load(&path).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn bad_files_name_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.json");
        let mut text = clip().to_json_string();
        text = text.replacen("-1.2345678", "90", 1);
        std::fs::write(&path, &text).unwrap();
        let e = MotionClip::load(&path).unwrap_err().to_string();
        assert!(e.contains("bad.json") && e.contains("frame 0") && e.contains("radians"), "{e}");

        std::fs::write(&path, "{\"format\": \"avatar-studio-motion\"").unwrap();
        let e = MotionClip::load(&path).unwrap_err().to_string();
        assert!(e.contains("bad.json") && e.contains("not a valid motion clip"), "{e}");

        let empty = clip().to_json_string().replace("\"fps\": 30", "\"fps\": 0");
        std::fs::write(&path, empty).unwrap();
        let e = MotionClip::load(&path).unwrap_err().to_string();
        assert!(e.contains("fps"), "{e}");

        let e = MotionClip::load(dir.path().join("missing.json")).unwrap_err().to_string();
        assert!(e.contains("missing.json"), "{e}");
        let e = MotionClip::load(dir.path().join("clip.fbx")).unwrap_err().to_string();
        assert!(e.contains("clip.fbx") && e.contains(".json") && e.contains(".bvh"), "{e}");
    }
}
