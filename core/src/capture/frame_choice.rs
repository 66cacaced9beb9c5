//! Which frames of a long capture a fit takes: spread over the whole take by farthest-point
//! sampling on what each frame shows, read from the manifest alone (the fittings and the
//! cameras; no depth image is read to choose). See docs/capture-format.md.
//!
//! A frame's features: the rotation matrices of its 23 body joints relative to their parents
//! (so that the distance between two poses is the chordal distance of their joints, with no
//! axis-angle wrap-around), the direction the camera sees the body from in the body's own frame
//! (front, side, back, above: `VIEW_WEIGHT`), and its time in the take (`TIME_WEIGHT`: of two
//! frames that show the same, the one farther away in time). The first pick is the take's first
//! frame; each next one is the frame farthest from every frame picked so far (ties to the
//! earlier frame), so the choice is deterministic and every prefix of it is spread too.

use super::manifest::CaptureManifest;
use super::open::{Capture, CaptureOptions};
use crate::body::NUM_JOINTS;
use crate::error::Result;
use glam::{Mat3, Quat, Vec3};

/// Weight of the camera's view of the body against the joints' rotations: the squared distance
/// between seeing the body from the front and from the back is 4 x this, from the front and
/// from a side 2 x this. With 4, turning the person round (16) counts as much as a leg swung
/// 90 degrees at the hip and the knee together (each 4 (1 - cos) = 4, times the two legs); a
/// walk's poses differ by about 2-6 from one another.
pub const VIEW_WEIGHT: f32 = 4.0;
/// Weight of the time in the take (0 at the first frame, 1 at the last): it only separates
/// frames that show about the same pose from the same side.
pub const TIME_WEIGHT: f32 = 1.0;

/// Features per frame: 23 joints x 9 rotation entries, 3 for the view, 1 for the time.
const DIMS: usize = (NUM_JOINTS - 1) * 9 + 4;

/// The frames of a capture in the order a fit takes them: an iterator over manifest indices
/// that yields every frame once. Frames whose fitting or camera cannot be read come last (in
/// manifest order): opening them names the problem.
pub struct FrameChoice {
    features: Vec<f32>,
    /// Manifest index of each feature row.
    rows: Vec<usize>,
    /// Squared distance of each row to the nearest picked row (`None`: picked).
    nearest: Vec<Option<f32>>,
    picked: usize,
    unreadable: std::vec::IntoIter<usize>,
}

impl FrameChoice {
    pub fn new(manifest: &CaptureManifest) -> FrameChoice {
        let n = manifest.frames.len();
        let mut features = Vec::with_capacity(n * DIMS);
        let mut rows = Vec::with_capacity(n);
        let mut unreadable = Vec::new();
        for (i, record) in manifest.frames.iter().enumerate() {
            let (Ok(params), Ok(camera)) = (record.params(), record.camera_to_world()) else {
                unreadable.push(i);
                continue;
            };
            rows.push(i);
            for axis_angle in &params.pose[1..] {
                let m = Mat3::from_quat(Quat::from_scaled_axis(*axis_angle));
                features.extend_from_slice(&m.to_cols_array());
            }
            let root = Quat::from_scaled_axis(params.pose[0]);
            let to_camera = camera.w_axis.truncate() - params.trans;
            let view = (root.inverse() * to_camera).normalize_or(Vec3::Z);
            features.extend((view * VIEW_WEIGHT.sqrt()).to_array());
            let t = if n > 1 { i as f32 / (n - 1) as f32 } else { 0.0 };
            features.push(t * TIME_WEIGHT.sqrt());
        }
        FrameChoice {
            nearest: vec![Some(f32::INFINITY); rows.len()],
            features,
            rows,
            picked: 0,
            unreadable: unreadable.into_iter(),
        }
    }

    /// The first `k` frames of the choice, in manifest order.
    pub fn first(manifest: &CaptureManifest, k: usize) -> Vec<usize> {
        let mut chosen: Vec<usize> = FrameChoice::new(manifest).take(k).collect();
        chosen.sort_unstable();
        chosen
    }

    fn row(&self, r: usize) -> &[f32] {
        &self.features[r * DIMS..(r + 1) * DIMS]
    }
}

impl Iterator for FrameChoice {
    type Item = usize;

    fn next(&mut self) -> Option<usize> {
        // The farthest row from the picked ones; the first frame first (all are infinitely far).
        let mut best: Option<(usize, f32)> = None;
        for (r, d) in self.nearest.iter().enumerate() {
            if let Some(d) = *d
                && best.is_none_or(|(_, b)| d > b)
            {
                best = Some((r, d));
            }
        }
        let Some((pick, _)) = best else {
            return self.unreadable.next();
        };
        self.nearest[pick] = None;
        self.picked += 1;
        let p: Vec<f32> = self.row(pick).to_vec();
        for r in 0..self.rows.len() {
            if let Some(d) = self.nearest[r] {
                let e: f32 = self.row(r).iter().zip(&p).map(|(a, b)| (a - b) * (a - b)).sum();
                self.nearest[r] = Some(d.min(e));
            }
        }
        Some(self.rows[pick])
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.rows.len() - self.picked + self.unreadable.len();
        (left, Some(left))
    }
}

impl Capture {
    /// Read frames in the order of `choice` until `usable` of the frames read can be used or
    /// the choice runs out; a frame that cannot be used is replaced by the next of the choice.
    pub fn read_chosen(
        &mut self,
        choice: &mut FrameChoice,
        usable: usize,
        options: &CaptureOptions,
    ) -> Result<()> {
        while self.frames.len() < usable {
            let batch: Vec<usize> = choice.by_ref().take(usable - self.frames.len()).collect();
            if batch.is_empty() {
                break;
            }
            self.read_frames(&batch, options)?;
        }
        Ok(())
    }
}
