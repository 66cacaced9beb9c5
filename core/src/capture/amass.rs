//! AMASS-style `.npz` fittings: `poses` (N, 72 or more: SMPL-H / SMPL-X files hold 156 or
//! 165 values, of which the first 66 are the body joints 0-21), `betas`, `trans` and the frame
//! rate under either spelling (`mocap_framerate` or `mocap_frame_rate`).
//! AMASS is Z-up; [`z_up_to_y_up`] turns a sequence into the studio's Y-up world.

use super::manifest::{CaptureManifest, FrameRecord, Intrinsics};
use crate::body::{BodyModel, BodyParams, NUM_JOINTS};
use crate::error::{Error, Result};
use crate::io::npz::Npz;
use glam::{Quat, Vec3};
use std::path::Path;

#[derive(Debug, Clone, PartialEq)]
pub struct AmassSequence {
    pub fps: f32,
    pub frames: Vec<BodyParams>,
}

/// Widths of a `poses` row: 22 body joints alone, SMPL (24), SMPL-H (52), SMPL-X (55 joints).
pub const POSE_WIDTHS: [usize; 4] = [66, 72, 156, 165];

pub fn read_amass(path: impl AsRef<Path>) -> Result<AmassSequence> {
    let path = path.as_ref();
    let mut npz = Npz::open(path)?;
    let poses = npz.require("poses")?;
    if poses.shape.len() != 2 || !POSE_WIDTHS.contains(&poses.shape[1]) {
        return Err(Error::file(
            path,
            format!(
                "'poses' has shape {:?}, expected (frames, W) with W one of {POSE_WIDTHS:?} (SMPL body, SMPL, SMPL-H, SMPL-X)",
                poses.shape
            ),
        ));
    }
    let (n, width) = (poses.shape[0], poses.shape[1]);
    if n == 0 {
        return Err(Error::file(path, "'poses' has no frames"));
    }
    let betas: Vec<f32> = match npz.get("betas")? {
        Some(b) => b.data.iter().map(|&v| v as f32).collect(),
        None => Vec::new(),
    };
    let trans = match npz.get("trans")? {
        Some(t) if t.shape == vec![n, 3] => Some(t.data),
        Some(t) => {
            return Err(Error::file(
                path,
                format!("'trans' has shape {:?}, expected ({n}, 3)", t.shape),
            ));
        }
        None => None,
    };
    let fps = ["mocap_framerate", "mocap_frame_rate"]
        .iter()
        .find_map(|k| npz.get(k).ok().flatten())
        .and_then(|a| a.data.first().copied())
        .map(|v| v as f32)
        .unwrap_or(30.0);
    if !(crate::motion::MIN_FPS..=crate::motion::MAX_FPS).contains(&fps) {
        return Err(Error::file(
            path,
            format!(
                "frame rate {fps} is not plausible ({} to {} fps)",
                crate::motion::MIN_FPS,
                crate::motion::MAX_FPS
            ),
        ));
    }
    let mut frames = Vec::with_capacity(n);
    for i in 0..n {
        let row = &poses.data[i * width..(i + 1) * width];
        // SMPL has 24 joints; SMPL-H/X files have 22 body joints then hands: SMPL's hand joints
        // (22, 23) stay at rest.
        let mut flat = vec![0f32; 3 * NUM_JOINTS];
        let body = if width == 72 { 72 } else { 66 };
        for (k, v) in row[..body].iter().enumerate() {
            flat[k] = *v as f32;
        }
        let t = trans.as_ref().map_or(Vec3::ZERO, |t| {
            Vec3::new(t[3 * i] as f32, t[3 * i + 1] as f32, t[3 * i + 2] as f32)
        });
        let params = BodyParams::from_flat(&flat, betas.clone(), t)
            .map_err(|e| Error::file(path, format!("frame {i}: {e}")))?;
        frames.push(params);
    }
    Ok(AmassSequence { fps, frames })
}

/// Rotate a Z-up sequence into a Y-up world (x, y, z) -> (x, z, -y). The root rotation turns
/// about the root joint, so the translation is corrected with the body's rest root position.
pub fn z_up_to_y_up(seq: &mut AmassSequence, body: &BodyModel) {
    let r = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    for p in &mut seq.frames {
        let j0 = body.rest_joints(&p.betas)[0];
        let root = Quat::from_scaled_axis(p.pose[0]);
        p.pose[0] = (r * root).to_scaled_axis();
        p.trans = r * (p.trans + j0) - j0;
    }
}

/// A capture manifest pairing sorted depth PNGs (`depth_dir`, relative names) with the frames
/// of an AMASS fitting, one to one. Extra images or fittings are an error naming both counts.
pub fn manifest_from_depth_and_amass(
    depth_files: &[String],
    seq: &AmassSequence,
    intrinsics: Intrinsics,
    depth_scale: f32,
) -> Result<CaptureManifest> {
    if depth_files.len() != seq.frames.len() {
        return Err(Error::invalid(format!(
            "{} depth images but {} fitted frames: they must pair one to one",
            depth_files.len(),
            seq.frames.len()
        )));
    }
    let mut m = CaptureManifest::new(intrinsics, depth_scale);
    m.fps = Some(seq.fps);
    for (file, p) in depth_files.iter().zip(&seq.frames) {
        m.frames.push(FrameRecord {
            depth: file.clone(),
            mask: None,
            pose: Some(p.flat_pose()),
            shape: p.betas.clone(),
            translation: Some(p.trans.to_array()),
            camera_to_world: None,
        });
    }
    m.validate()?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::npz::write_f32_npz;

    #[test]
    fn both_frame_rate_spellings_and_smplh_width() {
        let dir = tempfile::tempdir().unwrap();
        for (key, width) in [("mocap_framerate", 72usize), ("mocap_frame_rate", 156)] {
            let p = dir.path().join(format!("{key}.npz"));
            let mut poses = vec![0f32; 3 * width];
            poses[3] = 0.5; // joint 1, x
            poses[width + 65] = 0.25; // frame 1, joint 21, z
            write_f32_npz(
                &p,
                &[
                    ("poses", vec![3, width], poses),
                    ("betas", vec![10], vec![0.1; 10]),
                    ("trans", vec![3, 3], vec![0.0, 0.0, 1.0, 0.0, 0.1, 1.0, 0.0, 0.2, 1.0]),
                    (key, vec![], vec![120.0]),
                ],
            )
            .unwrap();
            let s = read_amass(&p).unwrap();
            assert_eq!(s.fps, 120.0);
            assert_eq!(s.frames.len(), 3);
            assert_eq!(s.frames[0].pose[1].x, 0.5);
            assert_eq!(s.frames[1].pose[21].z, 0.25);
            assert_eq!(s.frames[2].trans, Vec3::new(0.0, 0.2, 1.0));
            assert_eq!(s.frames[0].betas.len(), 10);
        }
    }

    #[test]
    fn bad_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("nan.npz");
        let mut poses = vec![0f32; 72];
        poses[10] = f32::NAN;
        write_f32_npz(&p, &[("poses", vec![1, 72], poses)]).unwrap();
        let e = read_amass(&p).unwrap_err().to_string();
        assert!(e.contains("nan.npz") && e.contains("frame 0"), "{e}");
        let q = dir.path().join("nokey.npz");
        write_f32_npz(&q, &[("betas", vec![10], vec![0.0; 10])]).unwrap();
        let e = read_amass(&q).unwrap_err().to_string();
        assert!(e.contains("nokey.npz") && e.contains("poses"), "{e}");
    }

    #[test]
    fn z_up_conversion_keeps_the_root_joint_in_place() {
        let body = crate::body::open_body_lowpoly();
        let mut seq = AmassSequence {
            fps: 30.0,
            frames: vec![BodyParams { trans: Vec3::new(0.3, -0.2, 0.9), ..Default::default() }],
        };
        let before = body.pose(&seq.frames[0]).posed_joints();
        z_up_to_y_up(&mut seq, &body);
        let after = body.pose(&seq.frames[0]).posed_joints();
        let r = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        for j in 0..NUM_JOINTS {
            assert!((r * before[j] - after[j]).length() < 1e-4, "joint {j}");
        }
    }
}
