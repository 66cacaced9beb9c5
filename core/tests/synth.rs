//! Synthetic captures: round trip through the capture loader, determinism, measurable
//! pose-dependent clothing, ground-truth files.

use avatar_core::body::{BodyParams, open_body_ref, skinning::unskin_point};
use avatar_core::capture::Capture;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::motion::{PoseBuilder, Side, clip_by_name};
use avatar_core::synth::*;
use std::path::Path;

fn job(outfit: Outfit, frames: usize) -> SynthJob {
    let mut j = SynthJob::new(7, outfit, clip_by_name("walk").unwrap());
    j.frames = Some(frames);
    j
}

#[test]
fn depth_points_lie_on_the_ground_truth_surface() {
    // The simulated skirt too: its garment turned with the person, frame by frame.
    for outfit in [Outfit::LongsleeveTrousers, Outfit::Dress, Outfit::SimSkirt] {
        let dir = tempfile::tempdir().unwrap();
        generate_capture(dir.path(), open_body_ref(), &job(outfit, 3)).unwrap();
        let cap = Capture::open(dir.path()).unwrap();
        assert!(cap.warnings.is_empty(), "{:?}", cap.warnings);
        let gt = GroundTruth::load(dir.path()).unwrap();
        assert_eq!(gt.frames.len(), 3);
        for f in &cap.frames {
            let bvh = Bvh::build(&gt.posed_mesh(f.index));
            let mut d: Vec<f32> =
                f.points.iter().map(|&p| bvh.closest_point(p).unwrap().distance).collect();
            d.sort_by(f32::total_cmp);
            let median = d[d.len() / 2];
            let p95 = d[d.len() * 95 / 100];
            assert!(median < 0.002, "{}: frame {} median {median} m", outfit.name(), f.index);
            assert!(p95 < 0.01, "{}: frame {} p95 {p95} m", outfit.name(), f.index);
            // The crop keeps the person: nearly every rendered pixel survives.
            let rendered = image::open(&f.depth_file)
                .unwrap()
                .to_luma16()
                .pixels()
                .filter(|p| p.0[0] > 0)
                .count();
            assert!(
                f.points.len() as f32 > 0.97 * rendered as f32,
                "{} of {rendered} points kept",
                f.points.len()
            );
        }
    }
}

#[test]
fn the_person_turns_45_degrees_a_frame() {
    let body = open_body_ref();
    let params = job(Outfit::TshirtShorts, 4).frame_params(body);
    for (i, p) in params.iter().enumerate() {
        let fwd = glam::Quat::from_scaled_axis(p.pose[0]) * glam::Vec3::Z;
        let base = glam::Quat::from_scaled_axis(
            job(Outfit::TshirtShorts, 4).clip.frames
                [i * job(Outfit::TshirtShorts, 4).clip.len() / 4]
                .pose[0],
        ) * glam::Vec3::Z;
        let turn = (base.z.atan2(base.x) - fwd.z.atan2(fwd.x)).to_degrees().rem_euclid(360.0);
        assert!(
            (turn - (45.0 * i as f32).rem_euclid(360.0)).abs() < 0.5
                || (turn - 360.0).abs() < 0.5 && i % 8 == 0,
            "frame {i}: {turn}"
        );
    }
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for e in walk(dir) {
        out.push((e.strip_prefix(dir).unwrap().display().to_string(), std::fs::read(&e).unwrap()));
    }
    out.sort();
    out
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() { v.extend(walk(&p)) } else { v.push(p) }
    }
    v
}

#[test]
fn generation_is_deterministic_byte_for_byte() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let mut j = job(Outfit::PoloLoose, 2);
    j.noise = DepthNoise::preset("kinect_v1");
    j.noise_seed = 11;
    generate_capture(a.path(), open_body_ref(), &j).unwrap();
    generate_capture(b.path(), open_body_ref(), &j).unwrap();
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert_eq!(fa.len(), 2 + 1 + 3);
    assert!(fa == fb, "two runs with the same seed differ");
    // Another noise seed changes the depth but not the ground truth.
    j.noise_seed = 12;
    let c = tempfile::tempdir().unwrap();
    generate_capture(c.path(), open_body_ref(), &j).unwrap();
    let fc = files(c.path());
    assert_ne!(
        fa.iter().find(|f| f.0.ends_with("000000.png")),
        fc.iter().find(|f| f.0.ends_with("000000.png"))
    );
    assert_eq!(
        fa.iter().find(|f| f.0.ends_with("frames.npz")),
        fc.iter().find(|f| f.0.ends_with("frames.npz"))
    );
}

/// Largest and mean displacement (metres) of the clothed vertices between the canonical
/// surfaces of two poses: what plain skinning of a rest shape cannot explain.
fn pose_dependence(outfit: Outfit, a: &BodyParams, b: &BodyParams) -> (f32, f32) {
    let body = open_body_ref();
    let t = ClothedTemplate::build(body, &[], outfit);
    let ca = canonical_surface(&t, &PoseFeatures::of(&body.pose(a).bones), 0);
    let cb = canonical_surface(&t, &PoseFeatures::of(&body.pose(b).bones), 0);
    let d: Vec<f32> = ca
        .iter()
        .zip(&cb)
        .zip(&t.cloth)
        .filter(|(_, c)| **c > 0.5)
        .map(|((p, q), _)| (*p - *q).length())
        .collect();
    (d.iter().copied().fold(0.0, f32::max), d.iter().sum::<f32>() / d.len() as f32)
}

pub fn two_poses() -> (BodyParams, BodyParams) {
    let a = PoseBuilder::relaxed().build();
    let mut b = PoseBuilder::tpose();
    b.shoulder(Side::Left, 70.0, 0.0, 0.0)
        .shoulder(Side::Right, 70.0, 0.0, 0.0)
        .elbow(Side::Left, 100.0)
        .elbow(Side::Right, 100.0);
    b.hip(Side::Left, 45.0, 0.0, 0.0)
        .hip(Side::Right, -10.0, 0.0, 0.0)
        .knee(Side::Left, 90.0)
        .knee(Side::Right, 20.0);
    (a, b.build())
}

#[test]
fn clothing_depends_visibly_on_the_pose() {
    let (a, b) = two_poses();
    for outfit in ALL_OUTFITS {
        let (max, mean) = pose_dependence(outfit, &a, &b);
        // Folds reach 1.5-3 cm (the t-shirt has short sleeves and shorts: fewer folds); the
        // loose panels move much more.
        let floor = if outfit == Outfit::TshirtShorts { 0.015 } else { 0.02 };
        assert!(max > floor, "{}: max {max} m", outfit.name());
        if outfit.spec().panel.is_some() {
            assert!(max > 0.03, "{}: panel moved only {max} m", outfit.name());
        }
        assert!(mean > 0.0005, "{}: mean {mean} m", outfit.name());
        // The same pose twice gives the same surface (deterministic).
        assert_eq!(pose_dependence(outfit, &a, &a).0, 0.0);
    }
}

#[test]
fn ground_truth_canonical_is_the_unposed_posed_mesh() {
    let dir = tempfile::tempdir().unwrap();
    generate_capture(dir.path(), open_body_ref(), &job(Outfit::BlazerTails, 2)).unwrap();
    let gt = GroundTruth::load(dir.path()).unwrap();
    let cap = avatar_core::capture::CaptureManifest::load(dir.path()).unwrap();
    let body = open_body_ref();
    for (i, f) in gt.frames.iter().enumerate() {
        let params = cap.frames[i].params().unwrap();
        let bones = body.pose(&params).bones;
        for v in (0..f.posed.len()).step_by(97) {
            let back = unskin_point(&bones.transforms, &gt.weights[v], f.posed[v]);
            assert!((back - f.canonical[v]).length() < 1e-4, "frame {i} vertex {v}");
        }
        assert!(f.visible.iter().filter(|&&x| x).count() > 1000);
        // A posed vertex maps to its own canonical position.
        let bvh = Bvh::build(&gt.posed_mesh(i));
        let c = gt.canonical_of_posed_point(i, &bvh, f.posed[123]).unwrap();
        assert!((c - f.canonical[123]).length() < 1e-4);
    }
    let mask = gt.metric_mask();
    let kept = mask.iter().filter(|&&m| m).count();
    assert!(kept > mask.len() / 4 && kept < mask.len(), "{kept} of {}", mask.len());
    // A truncated ground-truth file is named.
    let p = dir.path().join("gt/frames.npz");
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 3]).unwrap();
    let err = GroundTruth::load(dir.path()).unwrap_err().to_string();
    assert!(err.contains("frames.npz"), "{err}");
}

#[test]
fn unknown_outfit_lists_the_valid_ones() {
    let err = Outfit::from_name("kimono").unwrap_err().to_string();
    assert!(
        err.contains("kimono") && err.contains("blazer_tails") && err.contains("dress"),
        "{err}"
    );
}
