//! Units of a capture's fittings: when most frames have no depth near the fitted body, say why
//! in one line (translations in millimetres or centimetres, an inverted or superfluous
//! camera_to_world, Z-up fittings). See docs/capture-format.md.

use super::depth_png::read_depth_png;
use super::frame_error::{FrameError, NO_DEPTH_NEAR_BODY};
use super::manifest::{CaptureManifest, FrameRecord};
use super::points::backproject;
use crate::body::{BodyModel, BodyParams, NUM_JOINTS, SMPL_PARENTS};
use glam::{Mat4, Quat, Vec3};
use std::path::Path;

/// A depth point this close to the fitted skeleton (joints and bones) counts as on the body.
const NEAR_SKELETON: f32 = 0.25;
/// Frames examined for a diagnosis (the first ones that failed for lack of depth near the body).
const FRAMES_EXAMINED: usize = 4;

/// What might be wrong with a frame's fitting or camera, each a way to correct it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Hypothesis {
    AsGiven,
    Millimetres,
    Centimetres,
    InvertedCamera,
    CameraCoordinates,
    ZUp,
}

const HYPOTHESES: [Hypothesis; 6] = [
    Hypothesis::AsGiven,
    Hypothesis::Millimetres,
    Hypothesis::Centimetres,
    Hypothesis::InvertedCamera,
    Hypothesis::CameraCoordinates,
    Hypothesis::ZUp,
];

/// The one-line diagnosis when at least half of the `considered` frames failed with
/// [`NO_DEPTH_NEAR_BODY`]: each correction is tried on a few of them and the one that puts the
/// most depth points on the fitted skeleton is named.
pub fn diagnose(
    dir: &Path,
    manifest: &CaptureManifest,
    body: &BodyModel,
    warnings: &[FrameError],
    considered: usize,
) -> Option<String> {
    // Translations beyond 1 km are refused before any depth is read: millimetres, most likely.
    let huge: Vec<f32> = warnings
        .iter()
        .filter(|w| w.reason.contains("over 1 km"))
        .filter_map(|w| manifest.frames[w.index].translation.map(|t| Vec3::from_array(t).length()))
        .collect();
    if !huge.is_empty() && 2 * huge.len() >= considered {
        let t = median(huge);
        return Some(if t / 1000.0 < 20.0 {
            format!(
                "translations look like millimetres: {t:.0} m; a person is metres from the camera (write metres in \"translation\")"
            )
        } else {
            format!("translations of {t:.0} m are not plausible: wrong units?")
        });
    }
    let far: Vec<&FrameError> =
        warnings.iter().filter(|w| w.reason.starts_with(NO_DEPTH_NEAR_BODY)).collect();
    if far.is_empty() || 2 * far.len() < considered {
        return None;
    }
    let mut score = [0f32; HYPOTHESES.len()];
    let mut examined = Vec::new();
    for w in far.iter().take(FRAMES_EXAMINED) {
        let record = &manifest.frames[w.index];
        let (Ok(params), Ok(c2w)) = (record.params(), record.camera_to_world()) else { continue };
        let Ok(depth) = read_depth_png(dir.join(&record.depth), manifest.depth_scale) else {
            continue;
        };
        let (points, _) = backproject(&depth, &manifest.intrinsics, Mat4::IDENTITY, None);
        let step = (points.len() / 4000).max(1);
        let camera_points: Vec<Vec3> = points.into_iter().step_by(step).collect();
        if camera_points.is_empty() {
            continue;
        }
        for (k, h) in HYPOTHESES.iter().enumerate() {
            if let Some((p, c)) = apply(*h, &params, c2w, record, body) {
                let world: Vec<Vec3> =
                    camera_points.iter().map(|q| c.transform_point3(*q)).collect();
                score[k] += near_fraction(&world, &skeleton_samples(body, &p));
            }
        }
        examined.push((params, c2w, camera_points));
    }
    if examined.is_empty() {
        return None;
    }
    let n = examined.len() as f32;
    let (best, best_score) =
        (0..HYPOTHESES.len()).map(|k| (k, score[k] / n)).max_by(|a, b| a.1.total_cmp(&b.1))?;
    let given = score[0] / n;
    let trans = median(examined.iter().map(|(p, _, _)| p.trans.length()).collect());
    if best != 0 && best_score >= 0.1 && best_score >= 2.0 * given {
        return Some(match HYPOTHESES[best] {
            Hypothesis::Millimetres => format!(
                "translations look like millimetres: {trans:.0} m; divided by 1000 they put the body on the depth (write metres in \"translation\")"
            ),
            Hypothesis::Centimetres => format!(
                "translations look like centimetres: {trans:.0} m; divided by 100 they put the body on the depth (write metres in \"translation\")"
            ),
            Hypothesis::InvertedCamera => {
                "camera_to_world looks inverted (a world-to-camera matrix): its inverse puts the body on the depth".into()
            }
            Hypothesis::CameraCoordinates => {
                "the fittings look like they are in camera coordinates: without camera_to_world the body is on the depth".into()
            }
            Hypothesis::ZUp => "the fittings look Z-up (AMASS): turned to Y-up the body is on the depth (import with --z-up)".into(),
            Hypothesis::AsGiven => unreachable!("best != 0"),
        });
    }
    // No correction helps: say where the body and the depth are.
    let (params, c2w, pts) = &examined[0];
    let pelvis = body.pose(params).posed_joints()[0];
    let depth_centre = c2w.transform_point3(Vec3::new(
        median(pts.iter().map(|p| p.x).collect()),
        median(pts.iter().map(|p| p.y).collect()),
        median(pts.iter().map(|p| p.z).collect()),
    ));
    let units = if trans > 20.0 {
        format!("; translations of {trans:.0} m are not plausible, wrong units?")
    } else {
        String::new()
    };
    Some(format!(
        "the fitted body is {:.2} m from the depth (pelvis at {:.2?}, depth centre at {:.2?}): are the translations and camera_to_world right?{units}",
        (pelvis - depth_centre).length(),
        pelvis.to_array(),
        depth_centre.to_array()
    ))
}

/// The frame's fitting and camera-to-world under a hypothesis (`None`: not applicable).
fn apply(
    h: Hypothesis,
    params: &BodyParams,
    c2w: Mat4,
    record: &FrameRecord,
    body: &BodyModel,
) -> Option<(BodyParams, Mat4)> {
    let mut p = params.clone();
    match h {
        Hypothesis::AsGiven => Some((p, c2w)),
        Hypothesis::Millimetres | Hypothesis::Centimetres => {
            let s = if h == Hypothesis::Millimetres { 1e-3 } else { 1e-2 };
            (p.trans.length() > 2.0).then(|| {
                p.trans *= s;
                (p, c2w)
            })
        }
        Hypothesis::InvertedCamera => record.camera_to_world.is_some().then(|| (p, c2w.inverse())),
        Hypothesis::CameraCoordinates => {
            record.camera_to_world.is_some().then_some((p, Mat4::IDENTITY))
        }
        Hypothesis::ZUp => {
            let r = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
            let j0 = body.rest_joints(&p.betas)[0];
            p.pose[0] = (r * Quat::from_scaled_axis(p.pose[0])).to_scaled_axis();
            p.trans = r * (p.trans + j0) - j0;
            Some((p, c2w))
        }
    }
}

/// Points along the posed skeleton: joints and three points on each bone.
fn skeleton_samples(body: &BodyModel, params: &BodyParams) -> Vec<Vec3> {
    let rest = body.rest_joints(&params.betas);
    let joints =
        crate::body::forward_kinematics(&rest, &params.rotations(), params.trans).posed_joints();
    let mut out = joints.to_vec();
    for j in 1..NUM_JOINTS {
        let p = joints[SMPL_PARENTS[j] as usize];
        out.extend([0.25f32, 0.5, 0.75].map(|t| p.lerp(joints[j], t)));
    }
    out
}

fn near_fraction(points: &[Vec3], skeleton: &[Vec3]) -> f32 {
    let r2 = NEAR_SKELETON * NEAR_SKELETON;
    let near =
        points.iter().filter(|p| skeleton.iter().any(|s| s.distance_squared(**p) <= r2)).count();
    near as f32 / points.len().max(1) as f32
}

fn median(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return f32::NAN;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f32::total_cmp).1
}
