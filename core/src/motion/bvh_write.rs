//! Writing a clip as BVH motion capture (the SMPL skeleton under its own joint names, the open
//! body's rest offsets in centimetres, a T-pose rest, `Zrotation Xrotation Yrotation`
//! channels), and [`long_take`]: a long take made of the library's clips back to back at any
//! frame rate, to test what real mocap takes ask of `export` and `pose` (docs/export.md).
//! Read back by [`super::retarget`], a written clip comes back within float precision.

use super::clip::MotionClip;
use super::library::library;
use super::resample::interpolate;
use crate::body::{JOINT_NAMES, NUM_JOINTS, SMPL_PARENTS, open_body_ref};
use crate::error::Result;
use glam::{EulerRot, Quat, Vec3};
use std::fmt::Write as _;
use std::path::Path;

/// File units per metre.
const UNITS: f32 = 100.0;
/// End Site offset of the chain tips (metres, forward).
const TIP: f32 = 0.05;

/// The clip as BVH text.
pub fn to_bvh_string(clip: &MotionClip) -> String {
    let rest = open_body_ref().rest_joints(&[]);
    let mut text = String::from("HIERARCHY\n");
    write_joint(0, 0, &rest, &mut text);
    // The retargeter's standing height: the rest skeleton's hips above its lowest point.
    let lowest = (0..NUM_JOINTS).map(|j| rest[j].y - rest[0].y).fold(0.0f32, f32::min);
    let standing = -lowest;
    let order = depth_first();
    let _ = write!(
        text,
        "MOTION\nFrames: {}\nFrame Time: {}\n",
        clip.frames.len(),
        1.0 / clip.fps as f64
    );
    for f in &clip.frames {
        let root = (f.trans + Vec3::new(0.0, standing, 0.0)) * UNITS;
        let mut line = format!("{} {} {}", root.x, root.y, root.z);
        for &j in &order {
            let q = Quat::from_scaled_axis(f.pose[j]).normalize();
            let (z, x, y) = q.to_euler(EulerRot::ZXY);
            let _ = write!(line, " {} {} {}", z.to_degrees(), x.to_degrees(), y.to_degrees());
        }
        text.push_str(&line);
        text.push('\n');
    }
    text
}

/// Write the clip as a BVH file (atomically).
pub fn save_bvh(clip: &MotionClip, path: impl AsRef<Path>) -> Result<()> {
    crate::io::write_bytes_atomic(path, to_bvh_string(clip).as_bytes())
}

fn children(j: usize) -> Vec<usize> {
    (1..NUM_JOINTS).filter(|&c| SMPL_PARENTS[c] == j as i32).collect()
}

/// Joints in the order the hierarchy lists them.
fn depth_first() -> Vec<usize> {
    let mut out = Vec::with_capacity(NUM_JOINTS);
    let mut stack = vec![0];
    while let Some(j) = stack.pop() {
        out.push(j);
        stack.extend(children(j).into_iter().rev());
    }
    out
}

fn write_joint(j: usize, depth: usize, rest: &[Vec3; NUM_JOINTS], text: &mut String) {
    let pad = "  ".repeat(depth);
    let (kw, offset, channels) = match SMPL_PARENTS[j] {
        -1 => ("ROOT", Vec3::ZERO, "6 Xposition Yposition Zposition"),
        p => ("JOINT", (rest[j] - rest[p as usize]) * UNITS, "3"),
    };
    let _ = writeln!(
        text,
        "{pad}{kw} {}\n{pad}{{\n{pad}  OFFSET {} {} {}\n{pad}  CHANNELS {channels} Zrotation Xrotation Yrotation",
        JOINT_NAMES[j], offset.x, offset.y, offset.z
    );
    let kids = children(j);
    if kids.is_empty() {
        let _ = writeln!(
            text,
            "{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0 0 {}\n{pad}  }}",
            TIP * UNITS
        );
    }
    for c in kids {
        write_joint(c, depth + 1, rest, text);
    }
    let _ = writeln!(text, "{pad}}}");
}

/// A take of `frames` frames at `fps`: the library's clips back to back (every fifth clip of
/// the 13 in turn, so neighbours differ), each resampled to `fps` (slerp) and entered at a
/// varying phase, joined by 0.2 s blends. Deterministic.
pub fn long_take(name: &str, frames: usize, fps: f32) -> Result<MotionClip> {
    let lib = library();
    let blend = (0.2 * fps).round().max(1.0) as usize;
    let mut out: Vec<crate::body::BodyParams> = Vec::with_capacity(frames);
    let mut k = 0usize;
    while out.len() < frames {
        let clip = lib[(k * 5) % lib.len()].resample(fps)?;
        let start = (k * 7 % 10) * clip.len() / 20; // 0 to 45 % into the clip
        let segment = &clip.frames[start..];
        for (i, f) in segment.iter().enumerate() {
            if out.len() == frames {
                break;
            }
            let frame = match out.last() {
                Some(prev) if i < blend && k > 0 => {
                    interpolate(prev, f, (i + 1) as f32 / (blend + 1) as f32)
                }
                _ => f.clone(),
            };
            out.push(frame);
        }
        k += 1;
    }
    let clip = MotionClip::new(name, fps, out);
    clip.validate()?;
    Ok(clip)
}
