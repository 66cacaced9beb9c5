//! Resampling a clip to a target frame rate: per joint, spherical linear interpolation of the
//! rotations (shortest arc) between the two nearest source frames; the root translation and
//! the shape coefficients interpolated linearly.
//!
//! Timing: source frame `i` is at `i / source_fps`; the clip spans `(n - 1) / source_fps`
//! seconds (first frame to last). The resampled clip has `floor(span * fps) + 1` frames, frame
//! `k` at `k / fps`: both start at t = 0, and the last resampled frame is at or before the last
//! source frame (never extrapolated). A clip already at the target rate is returned unchanged.

use super::clip::{MAX_CLIP_FRAMES, MotionClip};
use crate::body::{BodyParams, NUM_JOINTS};
use crate::error::{Error, Result};
use glam::{Quat, Vec3};

/// Frame rates a clip can be resampled to (`--fps` of `export` and `pose`).
pub const MIN_TARGET_FPS: f32 = 1.0;
pub const MAX_TARGET_FPS: f32 = 240.0;
/// The frame rate `export` and `pose` resample clips to unless told otherwise.
pub const DEFAULT_TARGET_FPS: f32 = 30.0;

/// Frames of a clip of `n` source frames at `source_fps` resampled to `fps`:
/// `floor((n - 1) / source_fps * fps) + 1` (a tiny tolerance keeps exact multiples exact).
pub fn resampled_len(n: usize, source_fps: f32, fps: f32) -> usize {
    if n == 0 {
        return 0;
    }
    let span = (n - 1) as f64 / source_fps as f64;
    (span * fps as f64 + 1e-6).floor() as usize + 1
}

/// Interpolate two rotations given as axis-angle: the shortest-arc slerp, as axis-angle of at
/// most pi.
pub fn slerp_axis_angle(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    let qa = Quat::from_scaled_axis(a).normalize();
    let mut qb = Quat::from_scaled_axis(b).normalize();
    if qa.dot(qb) < 0.0 {
        qb = -qb;
    }
    let mut q = qa.slerp(qb, t).normalize();
    if q.w < 0.0 {
        q = -q;
    }
    q.to_scaled_axis()
}

/// The pose between two frames at fraction `t` (0 = `a`, 1 = `b`).
pub fn interpolate(a: &BodyParams, b: &BodyParams, t: f32) -> BodyParams {
    if t <= 0.0 {
        return a.clone();
    }
    if t >= 1.0 {
        return b.clone();
    }
    let mut pose = [Vec3::ZERO; NUM_JOINTS];
    for (j, p) in pose.iter_mut().enumerate() {
        *p = slerp_axis_angle(a.pose[j], b.pose[j], t);
    }
    let betas = if a.betas.len() == b.betas.len() {
        a.betas.iter().zip(&b.betas).map(|(x, y)| x + (y - x) * t).collect()
    } else {
        a.betas.clone()
    };
    BodyParams { pose, betas, trans: a.trans.lerp(b.trans, t) }
}

impl MotionClip {
    /// The clip at `fps` frames a second (see the module's timing); `source_fps` keeps the
    /// rate the clip was recorded at. Errors name the clip and the limit.
    pub fn resample(&self, fps: f32) -> Result<MotionClip> {
        if !(fps.is_finite() && (MIN_TARGET_FPS..=MAX_TARGET_FPS).contains(&fps)) {
            return Err(Error::invalid(format!(
                "a target frame rate of {fps} fps is out of range ({MIN_TARGET_FPS} to {MAX_TARGET_FPS})"
            )));
        }
        self.validate()?;
        if fps == self.fps {
            return Ok(self.clone());
        }
        let n = resampled_len(self.len(), self.fps, fps);
        if n > MAX_CLIP_FRAMES {
            return Err(Error::invalid(format!(
                "motion '{}' at {fps} fps would have {n} frames, over the supported {MAX_CLIP_FRAMES}",
                self.name
            )));
        }
        let last = self.len() - 1;
        let frames = (0..n)
            .map(|k| {
                let s = k as f64 * self.fps as f64 / fps as f64;
                let i = (s.floor() as usize).min(last);
                let t = (s - i as f64) as f32;
                if i == last || t <= 1e-6 {
                    self.frames[i].clone()
                } else {
                    interpolate(&self.frames[i], &self.frames[i + 1], t)
                }
            })
            .collect();
        Ok(MotionClip { name: self.name.clone(), fps, source_fps: self.source_fps, frames })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_counts_follow_the_span() {
        assert_eq!(resampled_len(1, 120.0, 30.0), 1);
        assert_eq!(resampled_len(121, 120.0, 30.0), 31);
        assert_eq!(resampled_len(2752, 120.0, 30.0), 688);
        assert_eq!(resampled_len(3000, 120.0, 30.0), 750);
        assert_eq!(resampled_len(96, 30.0, 30.0), 96);
        assert_eq!(resampled_len(11, 10.0, 25.0), 26);
    }

    #[test]
    fn slerp_takes_the_short_way_round() {
        let a = Vec3::new(0.0, 3.0, 0.0);
        let b = Vec3::new(0.0, -3.0, 0.0); // 0.28 rad away across pi
        let m = slerp_axis_angle(a, b, 0.5);
        let angle = m.length();
        assert!((angle - std::f32::consts::PI).abs() < 1e-4, "{m}");
        assert!((slerp_axis_angle(a, b, 0.0) - a).length() < 1e-5);
    }
}
