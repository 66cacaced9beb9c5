//! The procedural clip library: joint-angle curves (degrees, anatomical meanings, see
//! [`super::pose_builder`]) sampled at 30 fps. Every curve is a C1 function of time
//! ([`super::curves`]), clips are deterministic and stay within [`super::limits`].
//!
//! Clips start from (and mostly return to) the relaxed standing pose (arms hanging 15 degrees
//! from the body). The root stays in place (no travel) except for the vertical offset that keeps
//! the lower foot on the ground ([`PoseBuilder::ground`]); `turn` rotates the root.

use super::clip::MotionClip;
use super::curves::{bump, envelope, osc, plateau, ramp};
use super::pose_builder::{PoseBuilder, Side};
use Side::{Left, Right};

pub const LIBRARY_FPS: f32 = 30.0;

/// Clips held out of meta-training, for evaluation on unseen motion.
pub const HELDOUT_CLIPS: [&str; 3] = ["kick", "lunge", "twist"];

struct Spec {
    name: &'static str,
    duration: f32,
    pose: fn(f32) -> PoseBuilder,
}

const SPECS: [Spec; 13] = [
    Spec { name: "walk", duration: 3.2, pose: walk },
    Spec { name: "raise_arms", duration: 3.0, pose: raise_arms },
    Spec { name: "squat", duration: 3.0, pose: squat },
    Spec { name: "turn", duration: 3.0, pose: turn },
    Spec { name: "bend", duration: 3.0, pose: bend },
    Spec { name: "kick", duration: 2.5, pose: kick },
    Spec { name: "arm_swing", duration: 3.0, pose: arm_swing },
    Spec { name: "lunge", duration: 3.0, pose: lunge },
    Spec { name: "jumping_jacks", duration: 2.4, pose: jumping_jacks },
    Spec { name: "twist", duration: 3.0, pose: twist },
    Spec { name: "march", duration: 3.0, pose: march },
    Spec { name: "curls", duration: 2.4, pose: curls },
    Spec { name: "side_stretch", duration: 3.0, pose: side_stretch },
];

fn sample(spec: &Spec) -> MotionClip {
    let n = (spec.duration * LIBRARY_FPS).round() as usize;
    let frames = (0..n).map(|i| (spec.pose)(i as f32 / LIBRARY_FPS).build()).collect();
    MotionClip::new(spec.name, LIBRARY_FPS, frames)
}

/// Every procedural clip, in a fixed order.
pub fn library() -> Vec<MotionClip> {
    SPECS.iter().map(sample).collect()
}

/// Names of the library clips, in library order.
pub fn clip_names() -> Vec<&'static str> {
    SPECS.iter().map(|s| s.name).collect()
}

/// One library clip by name.
pub fn clip_by_name(name: &str) -> Option<MotionClip> {
    SPECS.iter().find(|s| s.name == name).map(sample)
}

/// (training clips, held-out clips): the held-out ones are [`HELDOUT_CLIPS`].
pub fn library_split() -> (Vec<MotionClip>, Vec<MotionClip>) {
    library().into_iter().partition(|c| !HELDOUT_CLIPS.contains(&c.name.as_str()))
}

/// Relaxed arms with a common elbow bend.
fn relaxed() -> PoseBuilder {
    PoseBuilder::relaxed()
}

/// Gait: 3 cycles of 1.067 s. Hip -10..26 flexion, knee 5..60 (peak in mid swing), arms swing
/// opposite to the legs, pelvis and trunk counter-rotate.
fn walk(t: f32) -> PoseBuilder {
    let period = 3.2 / 3.0;
    let env = envelope(t, 3.2, 0.35);
    let mut p = relaxed();
    for (side, phase) in [(Left, 0.0f32), (Right, std::f32::consts::PI)] {
        let ph = 2.0 * std::f32::consts::PI * t / period + phase;
        let hip = 8.0 + 18.0 * ph.sin();
        let k = 0.5 + 0.5 * ph.cos();
        let knee = 5.0 + 55.0 * k * k;
        let ankle = 8.0 * (ph - 0.6).sin();
        p.hip(side, hip * env, 0.0, 0.0).knee(side, knee * env).ankle(side, ankle * env);
        // Arm of this side swings with the opposite leg.
        let swing = -20.0 * ph.sin() * env;
        p.shoulder(side, -75.0, swing, 0.0).elbow(side, 15.0 + 10.0 * (0.5 - 0.5 * ph.sin()) * env);
    }
    let s = osc(t, period, 0.0) * env;
    p.spine(3.0, 0.0, 6.0 * s).root(0.0, -5.0 * s, 0.0);
    // The ankle-foot rocker keeps the pelvis higher than stiff legs would: 60% of the drop.
    p.ground();
    p.trans.y *= 0.6;
    p
}

/// Both arms from hanging to overhead (through the sides) and back, with a collar shrug.
fn raise_arms(t: f32) -> PoseBuilder {
    let a = bump(t, 0.1, 2.9);
    let mut p = relaxed();
    let elev = -75.0 + 160.0 * a;
    for s in [Left, Right] {
        p.shoulder(s, elev, 0.0, 0.0).elbow(s, 12.0 - 7.0 * a).collar(s, 20.0 * a);
    }
    p.spine(-5.0 * a, 0.0, 0.0).neck(-10.0 * a, 0.0);
    p
}

/// Deep squat with arms reaching forward: hips 95, knees 110, ankles 25 dorsiflexion.
fn squat(t: f32) -> PoseBuilder {
    let a = bump(t, 0.1, 2.9);
    let mut p = relaxed();
    for s in [Left, Right] {
        p.hip(s, 95.0 * a, 8.0 * a, 10.0 * a).knee(s, 110.0 * a).ankle(s, 25.0 * a);
        p.shoulder(s, -75.0 - 12.0 * a, 85.0 * a, 0.0).elbow(s, 12.0 - 6.0 * a);
    }
    p.spine(20.0 * a, 0.0, 0.0).neck(-15.0 * a, 0.0).root(0.0, 0.0, 0.0);
    p.ground();
    p
}

/// Root turns 100 degrees to the left and back, the head leading, a small weight shift.
fn turn(t: f32) -> PoseBuilder {
    let a = bump(t, 0.0, 3.0);
    let lead = bump(t, 0.0, 2.6);
    let mut p = relaxed();
    p.root(0.0, 100.0 * a, 0.0).neck(0.0, 25.0 * (lead - a).max(-1.0) + 10.0 * lead).spine(
        0.0,
        0.0,
        10.0 * (lead - a),
    );
    for s in [Left, Right] {
        p.shoulder(s, -75.0 + 10.0 * a, 0.0, 0.0);
    }
    p.hip(Left, 0.0, 4.0 * a, 0.0).hip(Right, 0.0, 4.0 * a, 0.0);
    p.ground();
    p
}

/// Forward bend at the spine (75 degrees over three joints) and hips (30), arms hanging.
fn bend(t: f32) -> PoseBuilder {
    let a = plateau(t, 0.1, 1.3, 1.7, 2.9);
    let mut p = relaxed();
    p.spine(75.0 * a, 0.0, 0.0).neck(10.0 * a, 0.0);
    for s in [Left, Right] {
        p.hip(s, 30.0 * a, 0.0, 0.0).knee(s, 8.0 * a);
        // Keep the arms hanging roughly vertically as the trunk pitches forward.
        p.shoulder(s, -75.0 - 10.0 * a, 95.0 * a, 0.0).elbow(s, 12.0 + 8.0 * a);
    }
    p.ground();
    p
}

/// Right-leg front kick: wind-up (knee 85), hip flexes to 80 as the knee extends, return.
fn kick(t: f32) -> PoseBuilder {
    let mut p = relaxed();
    let hip = 30.0 * bump(t, 0.1, 1.1) * (1.0 - ramp(t, 0.6, 1.1)) + 80.0 * bump(t, 0.5, 2.3);
    let knee = 85.0 * bump(t, 0.1, 1.3) + 30.0 * bump(t, 1.5, 2.4);
    p.hip(Right, hip, 0.0, 0.0).knee(Right, knee).ankle(Right, -25.0 * bump(t, 0.7, 2.0));
    let bal = bump(t, 0.1, 2.4);
    p.knee(Left, 12.0 * bal).hip(Left, 6.0 * bal, 0.0, 0.0);
    p.shoulder(Left, -75.0 + 40.0 * bal, 30.0 * bal, 0.0).shoulder(
        Right,
        -75.0 + 30.0 * bal,
        -25.0 * bal,
        0.0,
    );
    p.elbow(Left, 12.0 + 40.0 * bal).elbow(Right, 12.0 + 30.0 * bal);
    p.spine(-8.0 * bump(t, 0.5, 2.3), 0.0, 0.0);
    p.ground();
    p
}

/// Large alternating arm swings (60 degrees forward and back) with knees bouncing.
fn arm_swing(t: f32) -> PoseBuilder {
    let env = envelope(t, 3.0, 0.4);
    let s = osc(t, 1.5, 0.0) * env;
    let mut p = relaxed();
    p.shoulder(Left, -75.0, 60.0 * s, 0.0).shoulder(Right, -75.0, -60.0 * s, 0.0);
    p.elbow(Left, 15.0 + 25.0 * s.max(0.0)).elbow(Right, 15.0 + 25.0 * (-s).max(0.0));
    let knees = 10.0 * (0.5 - 0.5 * osc(t, 0.75, 0.0)) * env;
    for side in [Left, Right] {
        p.hip(side, knees * 0.6, 0.0, 0.0).knee(side, knees).ankle(side, knees * 0.4);
    }
    p.spine(0.0, 0.0, 8.0 * s);
    p.ground();
    p
}

/// Forward lunge on the left leg and back, hands to the hips (elbows out).
fn lunge(t: f32) -> PoseBuilder {
    let a = plateau(t, 0.1, 1.2, 1.8, 2.9);
    let mut p = relaxed();
    p.hip(Left, 75.0 * a, 5.0 * a, 0.0).knee(Left, 90.0 * a).ankle(Left, 15.0 * a);
    p.hip(Right, -15.0 * a, 5.0 * a, 0.0).knee(Right, 70.0 * a).ankle(Right, -20.0 * a);
    for s in [Left, Right] {
        p.shoulder(s, -75.0 + 25.0 * a, -10.0 * a, 0.0).elbow(s, 12.0 + 70.0 * a);
    }
    p.spine(-5.0 * a, 0.0, 0.0);
    p.ground();
    p
}

/// Two jumping jacks: arms from hanging to overhead through the sides, legs apart 20 degrees.
fn jumping_jacks(t: f32) -> PoseBuilder {
    let a = bump(t, 0.0, 1.2) + bump(t, 1.2, 2.4);
    let mut p = relaxed();
    for s in [Left, Right] {
        p.shoulder(s, -75.0 + 160.0 * a, 0.0, 0.0).elbow(s, 12.0 - 5.0 * a).collar(s, 15.0 * a);
        p.hip(s, 5.0 * a, 20.0 * a, 10.0 * a).knee(s, 12.0 * a).ankle(s, 5.0 * a);
    }
    p.ground();
    p
}

/// Trunk twist left and right (36 degrees over the spine, pelvis counter-turning 8) with the
/// arms held out and elbows bent.
fn twist(t: f32) -> PoseBuilder {
    let env = envelope(t, 3.0, 0.5);
    let s = osc(t, 1.5, 0.0) * env;
    let mut p = relaxed();
    p.spine(0.0, 0.0, 36.0 * s).root(0.0, -8.0 * s, 0.0).neck(0.0, 10.0 * s);
    let up = ramp(t, 0.0, 0.5) * (1.0 - ramp(t, 2.5, 3.0));
    for side in [Left, Right] {
        p.shoulder(side, -75.0 + 55.0 * up, 0.0, 40.0 * up).elbow(side, 12.0 + 70.0 * up);
    }
    p.ground();
    p
}

/// Marching with high knees: hips flex to 75 and knees to 90, one leg per half second.
fn march(t: f32) -> PoseBuilder {
    let mut p = relaxed();
    let mut l = 0.0;
    let mut r = 0.0;
    for k in 0..3 {
        let t0 = k as f32;
        l += bump(t, t0, t0 + 0.5);
        r += bump(t, t0 + 0.5, t0 + 1.0);
    }
    p.hip(Left, 75.0 * l, 0.0, 0.0).knee(Left, 90.0 * l).ankle(Left, -15.0 * l);
    p.hip(Right, 75.0 * r, 0.0, 0.0).knee(Right, 90.0 * r).ankle(Right, -15.0 * r);
    p.shoulder(Left, -75.0, 35.0 * r - 20.0 * l, 0.0).shoulder(
        Right,
        -75.0,
        35.0 * l - 20.0 * r,
        0.0,
    );
    p.elbow(Left, 12.0 + 70.0 * r).elbow(Right, 12.0 + 70.0 * l);
    p.ground();
    p
}

/// Biceps curls: both elbows to 135 degrees twice, arms hanging.
fn curls(t: f32) -> PoseBuilder {
    let a = bump(t, 0.0, 1.2) + bump(t, 1.2, 2.4);
    let mut p = relaxed();
    for s in [Left, Right] {
        p.shoulder(s, -78.0, 10.0 * a, 0.0).elbow(s, 12.0 + 123.0 * a).wrist(s, 0.0, 10.0 * a);
    }
    p.knee(Left, 4.0 * a).knee(Right, 4.0 * a);
    p.ground();
    p
}

/// Side stretch: left arm overhead, trunk bends to the right, then the mirror image.
fn side_stretch(t: f32) -> PoseBuilder {
    let l = bump(t, 0.0, 1.5);
    let r = bump(t, 1.5, 3.0);
    let mut p = relaxed();
    p.spine(0.0, 30.0 * (l - r), 0.0).neck(0.0, 0.0);
    p.shoulder(Left, -75.0 + 165.0 * l, 0.0, 0.0)
        .collar(Left, 20.0 * l)
        .elbow(Left, 12.0 + 10.0 * l);
    p.shoulder(Right, -75.0 + 165.0 * r, 0.0, 0.0)
        .collar(Right, 20.0 * r)
        .elbow(Right, 12.0 + 10.0 * r);
    p.hip(Left, 0.0, 6.0 * (l + r), 0.0).hip(Right, 0.0, 6.0 * (l + r), 0.0);
    p.ground();
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::NUM_JOINTS;
    use crate::motion::limits::check_clip_limits;

    #[test]
    fn library_has_the_required_clips_with_30fps_and_2_to_4_seconds() {
        let lib = library();
        for name in [
            "walk",
            "raise_arms",
            "squat",
            "turn",
            "bend",
            "kick",
            "arm_swing",
            "lunge",
            "jumping_jacks",
            "twist",
        ] {
            assert!(lib.iter().any(|c| c.name == name), "missing {name}");
        }
        for c in &lib {
            assert_eq!(c.fps, 30.0);
            assert!((2.0..=4.0).contains(&c.duration()), "{} lasts {}", c.name, c.duration());
            c.validate().unwrap();
        }
        let (train, heldout) = library_split();
        assert_eq!(heldout.len(), HELDOUT_CLIPS.len());
        assert_eq!(train.len() + heldout.len(), lib.len());
        assert!(train.iter().all(|c| !HELDOUT_CLIPS.contains(&c.name.as_str())));
        assert_eq!(clip_by_name("squat").unwrap(), lib[2]);
        assert!(clip_by_name("moonwalk").is_none());
    }

    #[test]
    fn clips_are_deterministic() {
        assert_eq!(library(), library());
    }

    #[test]
    fn every_clip_respects_the_joint_limits() {
        for c in library() {
            check_clip_limits(&c, 0.5).unwrap();
        }
    }

    #[test]
    fn limit_check_catches_a_hyperextended_knee() {
        let mut c = clip_by_name("walk").unwrap();
        c.frames[5].pose[4] = glam::Vec3::new(-0.5, 0.0, 0.0);
        let e = check_clip_limits(&c, 0.5).unwrap_err().to_string();
        assert!(e.contains("left_knee") && e.contains("frame 5"), "{e}");
    }

    /// C1: joint rotations change smoothly. The angular velocity between frames (quaternion
    /// log of the relative rotation) stays bounded and its change from one frame to the next
    /// (the angular acceleration) is small, so there are no velocity jumps.
    #[test]
    fn clips_are_smooth() {
        use glam::Quat;
        for c in library() {
            let dt = 1.0 / c.fps;
            let omega = |i: usize, j: usize| {
                let a = Quat::from_scaled_axis(c.frames[i].pose[j]);
                let b = Quat::from_scaled_axis(c.frames[i + 1].pose[j]);
                (a.inverse() * b).to_scaled_axis() * (180.0 / std::f32::consts::PI) / dt
            };
            for i in 1..c.frames.len() - 1 {
                for j in 0..NUM_JOINTS {
                    let (w0, w1) = (omega(i - 1, j), omega(i, j));
                    assert!(w1.length() < 720.0, "{} frame {i} joint {j}: {w1} deg/s", c.name);
                    let acc = (w1 - w0) / dt;
                    assert!(
                        acc.length() < 8000.0,
                        "{} frame {i} joint {j}: accel {acc} deg/s^2",
                        c.name
                    );
                }
                let dv = (c.frames[i + 1].trans - 2.0 * c.frames[i].trans + c.frames[i - 1].trans)
                    / (dt * dt);
                assert!(dv.length() < 8.0, "{} frame {i}: trans accel {dv}", c.name);
            }
        }
    }

    /// The clips move: each has a joint that travels at least 30 degrees.
    #[test]
    fn clips_move_substantially() {
        for c in library() {
            let q = |f: usize, j: usize| glam::Quat::from_scaled_axis(c.frames[f].pose[j]);
            let range = (0..c.frames.len())
                .flat_map(|f| (0..NUM_JOINTS).map(move |j| (f, j)))
                .map(|(f, j)| q(0, j).angle_between(q(f, j)).to_degrees())
                .fold(0.0f32, f32::max);
            assert!(range > 30.0, "{} only moves {range} degrees", c.name);
        }
    }
}
