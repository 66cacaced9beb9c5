//! Resampling clips to a target frame rate against known answers: a joint turning at a
//! constant angular velocity (through more than half a turn) resampled from 120 fps lands on
//! the analytic rotation at every target frame; the root moving at constant velocity lands on
//! the analytic position; slerp's endpoints; the frame count `floor(span * fps) + 1`; rates and
//! lengths out of range are refused naming the file and the limit.

use avatar_core::body::BodyParams;
use avatar_core::motion::resample::{interpolate, slerp_axis_angle};
use avatar_core::motion::{MAX_CLIP_FRAMES, MotionClip, open_clip_at, resampled_len};
use glam::{Quat, Vec3};

const OMEGA: f32 = 2.5; // rad/s
const AXIS: Vec3 = Vec3::new(0.0, 0.6, 0.8);
const VELOCITY: Vec3 = Vec3::new(0.4, 0.0, -0.3); // m/s

fn analytic(t: f32) -> (Quat, Vec3) {
    (Quat::from_axis_angle(AXIS, OMEGA * t), Vec3::new(0.0, 0.05, 0.0) + VELOCITY * t)
}

/// A 120 fps clip, `n` frames: the pelvis and the left shoulder turn at OMEGA about AXIS.
fn spinning(n: usize) -> MotionClip {
    let frames = (0..n)
        .map(|i| {
            let (q, trans) = analytic(i as f32 / 120.0);
            let mut p = BodyParams { trans, ..Default::default() };
            let aa = q.to_scaled_axis();
            p.pose[0] = aa;
            p.pose[16] = aa;
            p
        })
        .collect();
    MotionClip::new("spin", 120.0, frames)
}

fn angle(a: Quat, b: Quat) -> f32 {
    let d = a.conjugate() * b;
    2.0 * d.xyz().length().atan2(d.w.abs())
}

#[test]
fn constant_angular_velocity_lands_on_the_analytic_rotation() {
    let clip = spinning(241); // 2 s: 5 rad, past pi, so axis-angle wraps on the way
    for fps in [30.0, 50.0, 24.0, 29.97, 7.0] {
        let r = clip.resample(fps).unwrap();
        assert_eq!(r.len(), resampled_len(241, 120.0, fps));
        assert_eq!((r.fps, r.source_fps), (fps, 120.0));
        for (k, f) in r.frames.iter().enumerate() {
            let (q, trans) = analytic(k as f32 / fps);
            for j in [0, 16] {
                let got = Quat::from_scaled_axis(f.pose[j]);
                assert!(angle(got, q) < 2e-4, "{fps} fps frame {k} joint {j}: {}", angle(got, q));
            }
            assert!((f.trans - trans).length() < 1e-5, "{fps} fps frame {k}");
        }
    }
}

#[test]
fn frame_counts_and_endpoints() {
    // The span (n - 1) / source_fps, floor(span * fps) + 1 frames, the first at t = 0.
    assert_eq!(spinning(2752).resample(30.0).unwrap().len(), 688);
    assert_eq!(spinning(3000).resample(30.0).unwrap().len(), 750);
    assert_eq!(spinning(1).resample(30.0).unwrap().len(), 1);
    assert_eq!(spinning(121).resample(240.0).unwrap().len(), 241); // upsampling interpolates
    let same = spinning(10).resample(120.0).unwrap();
    assert_eq!(same, spinning(10));
    // Slerp's endpoints are the frames; its middle is the half rotation.
    let a = spinning(61).frames[0].clone();
    let b = spinning(61).frames[60].clone();
    assert_eq!(interpolate(&a, &b, 0.0), a);
    assert_eq!(interpolate(&a, &b, 1.0), b);
    let mid = interpolate(&a, &b, 0.5);
    let (q, _) = analytic(0.25);
    assert!(angle(Quat::from_scaled_axis(mid.pose[16]), q) < 1e-5);
    // The short way round between rotations either side of pi.
    let m = slerp_axis_angle(Vec3::new(3.0, 0.0, 0.0), Vec3::new(-3.0, 0.0, 0.0), 0.5);
    assert!((m.length() - std::f32::consts::PI).abs() < 1e-4, "{m}");
}

#[test]
fn rates_and_lengths_out_of_range_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for fps in [0.0, 0.5, 241.0, f32::NAN] {
        let e = spinning(10).resample(fps).unwrap_err().to_string();
        assert!(e.contains("1 to 240"), "{e}");
    }
    let path = dir.path().join("take.json");
    spinning(10).save_json(&path).unwrap();
    let e = open_clip_at(path.to_str().unwrap(), 500.0).unwrap_err().to_string();
    assert!(e.contains("take.json") && e.contains("240"), "{e}");
    // A BVH announcing more frames than supported is refused before anything is read.
    let bvh = dir.path().join("huge.bvh");
    let text = avatar_core::motion::bvh_write::to_bvh_string(&spinning(2))
        .replace("Frames: 2", &format!("Frames: {}", MAX_CLIP_FRAMES + 1));
    std::fs::write(&bvh, text).unwrap();
    let e = MotionClip::load(&bvh).unwrap_err().to_string();
    assert!(e.contains("huge.bvh") && e.contains("100000"), "{e}");
    // A frame rate out of range in the file itself.
    let fast = dir.path().join("fast.bvh");
    let text = avatar_core::motion::bvh_write::to_bvh_string(&spinning(2))
        .replace("Frame Time: 0.008333333333333333", "Frame Time: 0.0001");
    std::fs::write(&fast, text).unwrap();
    let e = MotionClip::load(&fast).unwrap_err().to_string();
    assert!(e.contains("fast.bvh") && e.contains("1000"), "{e}");
}

#[test]
fn a_written_bvh_reads_back_as_the_clip() {
    let dir = tempfile::tempdir().unwrap();
    let take = avatar_core::motion::bvh_write::long_take("take", 400, 120.0).unwrap();
    let path = dir.path().join("take.bvh");
    avatar_core::motion::bvh_write::save_bvh(&take, &path).unwrap();
    let back = MotionClip::load(&path).unwrap();
    assert_eq!(back.len(), 400);
    assert!((back.fps - 120.0).abs() < 1e-3);
    for (a, b) in take.frames.iter().zip(&back.frames) {
        for j in 0..24 {
            let e = angle(Quat::from_scaled_axis(a.pose[j]), Quat::from_scaled_axis(b.pose[j]));
            assert!(e < 1e-3, "joint {j}: {e}");
        }
        assert!((a.trans - b.trans).length() < 1e-4, "{} vs {}", a.trans, b.trans);
    }
}
