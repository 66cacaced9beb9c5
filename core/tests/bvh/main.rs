//! BVH motion capture: files written here (the open body's skeleton under Mixamo, CMU,
//! Blender or made-up names, in centimetres or metres) are parsed and retargeted to the SMPL
//! skeleton; a known joint rotation lands on the right SMPL joint, the frame rate and the
//! root translation are kept, and bad files are refused naming the file and the line.

use avatar_core::body::{NUM_JOINTS, SMPL_PARENTS, open_body_ref};
use avatar_core::motion::MotionClip;
use avatar_core::motion::bvh::BvhFile;
use avatar_core::motion::retarget::JointMap;
use glam::{Mat3, Quat, Vec3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod names;
use names::{BLENDER, CMU, MIXAMO};

/// How to write the test skeleton.
struct Skeleton<'a> {
    names: [&'a str; NUM_JOINTS],
    /// File units per metre (100 = centimetres).
    units: f32,
    /// Rest offsets of the left arm's children turned down by this many degrees (an A-pose).
    a_pose_deg: f32,
    /// An extra joint without SMPL counterpart between the neck and the head (CMU's Neck1).
    neck1: bool,
    /// Rotation channel order of every joint (the root's too).
    order: &'a str,
}

impl Default for Skeleton<'_> {
    fn default() -> Self {
        Skeleton {
            names: MIXAMO,
            units: 100.0,
            a_pose_deg: 0.0,
            neck1: false,
            order: "Zrotation Xrotation Yrotation",
        }
    }
}

/// Per frame: the root position (metres) and each SMPL joint's Euler angles (degrees, in the
/// skeleton's channel order).
struct Frame {
    root: Vec3,
    euler: [[f32; 3]; NUM_JOINTS],
}

fn rest_offsets(s: &Skeleton) -> [Vec3; NUM_JOINTS] {
    let j = open_body_ref().rest_joints(&[]);
    let down = Mat3::from_rotation_z(-s.a_pose_deg.to_radians());
    let mut off = [Vec3::ZERO; NUM_JOINTS];
    for k in 1..NUM_JOINTS {
        let p = SMPL_PARENTS[k] as usize;
        off[k] = j[k] - j[p];
        // The left arm below the shoulder (elbow, wrist, hand) hangs down.
        if matches!(k, 18 | 20 | 22) {
            off[k] = down * off[k];
        }
    }
    off
}

fn write_bvh(s: &Skeleton, frames: &[Frame], frame_time: f32) -> String {
    let off = rest_offsets(s);
    let mut text = String::from("HIERARCHY\n");
    let mut order = Vec::new();
    fn joint(
        k: usize,
        depth: usize,
        s: &Skeleton,
        off: &[Vec3; NUM_JOINTS],
        text: &mut String,
        order: &mut Vec<usize>,
    ) {
        let pad = "  ".repeat(depth);
        let kw = if k == 0 { "ROOT" } else { "JOINT" };
        let mut o = off[k] * s.units;
        if k == 15 && s.neck1 {
            o *= 0.5;
            let _ = writeln!(
                text,
                "{pad}JOINT Neck1\n{pad}{{\n{pad}  OFFSET {} {} {}\n{pad}  CHANNELS 3 {}",
                o.x, o.y, o.z, s.order
            );
            order.push(usize::MAX);
        }
        let channels = if k == 0 {
            format!("6 Xposition Yposition Zposition {}", s.order)
        } else {
            format!("3 {}", s.order)
        };
        let _ = writeln!(
            text,
            "{pad}{kw} {}\n{pad}{{\n{pad}  OFFSET {} {} {}\n{pad}  CHANNELS {channels}",
            s.names[k], o.x, o.y, o.z
        );
        order.push(k);
        let children: Vec<usize> =
            (1..NUM_JOINTS).filter(|&c| SMPL_PARENTS[c] as usize == k).collect();
        if children.is_empty() {
            let _ = writeln!(
                text,
                "{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0 0 {}\n{pad}  }}",
                0.05 * s.units
            );
        }
        for c in children {
            joint(c, depth + 1, s, off, text, order);
        }
        let _ = writeln!(text, "{pad}}}");
        if k == 15 && s.neck1 {
            let _ = writeln!(text, "{pad}}}");
        }
    }
    joint(0, 0, s, &off, &mut text, &mut order);
    let _ = write!(text, "MOTION\nFrames: {}\nFrame Time: {frame_time}\n", frames.len());
    for f in frames {
        let mut row = vec![f.root.x * s.units, f.root.y * s.units, f.root.z * s.units];
        for &k in &order {
            row.extend(if k == usize::MAX { [0.0; 3] } else { f.euler[k] });
        }
        let line: Vec<String> = row.iter().map(|v| format!("{v}")).collect();
        text.push_str(&line.join(" "));
        text.push('\n');
    }
    text
}

/// The rotation the skeleton's channel order gives for Euler angles in degrees.
fn channel_rotation(order: &str, e: [f32; 3]) -> Quat {
    order.split_whitespace().zip(e).fold(Quat::IDENTITY, |q, (c, deg)| {
        let r = deg.to_radians();
        q * match &c[..1] {
            "X" => Quat::from_rotation_x(r),
            "Y" => Quat::from_rotation_y(r),
            _ => Quat::from_rotation_z(r),
        }
    })
}

fn standing_height(s: &Skeleton) -> f32 {
    let text = write_bvh(s, &[still(Vec3::ZERO)], 0.1);
    let b = BvhFile::parse(&text).unwrap();
    let lo = b
        .rest_positions()
        .into_iter()
        .chain(b.rest_end_sites())
        .map(|p| p.y)
        .fold(f32::INFINITY, f32::min);
    -lo / s.units
}

fn still(root: Vec3) -> Frame {
    Frame { root, euler: [[0.0; 3]; NUM_JOINTS] }
}

fn save(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Degrees between two rotations (atan2 form: exact near zero, unlike acos of the dot).
fn angle_between(a: Quat, b: Quat) -> f32 {
    let d = a.conjugate() * b;
    (2.0 * d.xyz().length().atan2(d.w.abs())).to_degrees()
}

#[test]
fn a_joint_rotation_lands_on_the_mapped_smpl_joint() {
    let dir = tempfile::tempdir().unwrap();
    let s = Skeleton::default();
    let mut f = still(Vec3::new(0.0, standing_height(&s), 0.0));
    f.euler[18] = [20.0, -35.0, 50.0]; // LeftForeArm: Z X Y
    let path = save(dir.path(), "elbow.bvh", &write_bvh(&s, &[f], 1.0 / 30.0));
    let clip = MotionClip::load(&path).unwrap();
    assert_eq!(clip.len(), 1);
    let expect = channel_rotation(s.order, [20.0, -35.0, 50.0]);
    let got = Quat::from_scaled_axis(clip.frames[0].pose[18]);
    assert!(angle_between(got, expect) < 0.01, "left_elbow: {got} vs {expect}");
    for j in (0..NUM_JOINTS).filter(|&j| j != 18) {
        assert!(
            clip.frames[0].pose[j].length() < 1e-4,
            "joint {j} moved: {}",
            clip.frames[0].pose[j]
        );
    }
    // Standing at the rest hips height: no translation.
    assert!(clip.frames[0].trans.length() < 1e-4, "{}", clip.frames[0].trans);
}

#[test]
fn posed_joints_match_the_bvh_skeleton_for_any_channel_order() {
    let body = open_body_ref();
    for order in [
        "Zrotation Xrotation Yrotation",
        "Xrotation Yrotation Zrotation",
        "Yrotation Zrotation Xrotation",
    ] {
        let s = Skeleton { order, ..Skeleton::default() };
        let mut f = still(Vec3::new(0.1, 0.8, -0.2));
        for (j, e) in f.euler.iter_mut().enumerate() {
            let k = j as f32;
            *e = [(k * 7.0) % 40.0 - 20.0, (k * 13.0) % 50.0 - 25.0, (k * 5.0) % 30.0 - 15.0];
        }
        let text = write_bvh(&s, &[f], 0.05);
        let bvh = BvhFile::parse(&text).unwrap();
        let map = JointMap::by_names(&bvh).unwrap();
        assert_eq!(map.source, "mixamo");
        let clip = avatar_core::motion::retarget::retarget(&bvh, &map, body, "t").unwrap();
        let smpl = body.pose(&clip.frames[0]).posed_joints();
        let (_, pos) = bvh.pose(0).global(&bvh.joints);
        for j in 1..NUM_JOINTS {
            let b = map.bvh_of[j].unwrap();
            let want = (pos[b] - pos[0]) / s.units;
            let have = smpl[j] - smpl[0];
            assert!((want - have).length() < 1e-4, "{order}: joint {j}: {have} vs {want}");
        }
    }
}

#[test]
fn frame_rate_units_and_root_translation_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let h = standing_height(&Skeleton::default());
    let frames = |n: usize| -> Vec<Frame> {
        (0..n)
            .map(|i| {
                let t = i as f32 / 10.0;
                let mut f = still(Vec3::new(0.3 * t, h + 0.05 * (6.0 * t).sin(), -0.8 * t));
                f.euler[0] = [30.0 * t, 0.0, 0.0]; // Zrotation first
                f.euler[1] = [0.0, -40.0 * t, 0.0];
                f
            })
            .collect()
    };
    let cm = MotionClip::load(save(
        dir.path(),
        "walk_cm.bvh",
        &write_bvh(&Skeleton::default(), &frames(12), 1.0 / 120.0),
    ))
    .unwrap();
    let m = MotionClip::load(save(
        dir.path(),
        "walk_m.bvh",
        &write_bvh(&Skeleton { units: 1.0, ..Skeleton::default() }, &frames(12), 1.0 / 120.0),
    ))
    .unwrap();
    assert!((cm.fps - 120.0).abs() < 1e-3, "{}", cm.fps);
    assert_eq!(cm.len(), 12);
    for (i, (a, b)) in cm.frames.iter().zip(&m.frames).enumerate() {
        let t = i as f32 / 10.0;
        let want = Vec3::new(0.3 * t, 0.05 * (6.0 * t).sin(), -0.8 * t);
        assert!((a.trans - want).length() < 1e-4, "frame {i}: {} vs {want}", a.trans);
        assert!((a.trans - b.trans).length() < 1e-5);
        for j in 0..NUM_JOINTS {
            assert!(
                (a.pose[j] - b.pose[j]).length() < 1e-5,
                "cm and m differ at frame {i} joint {j}"
            );
        }
    }
    // The root's 30 degrees a unit of t about Z (the channel order's first) is the global orientation.
    let q = Quat::from_scaled_axis(cm.frames[10].pose[0]);
    assert!(angle_between(q, Quat::from_rotation_z(30f32.to_radians())) < 0.01);
}

#[test]
fn cmu_and_blender_names_and_an_a_pose_rest() {
    let dir = tempfile::tempdir().unwrap();
    let body = open_body_ref();
    // CMU names with the extra Neck1 joint; the left shoulder (CMU LeftArm) raised 30 degrees.
    let s = Skeleton { names: CMU, neck1: true, ..Skeleton::default() };
    let mut f = still(Vec3::new(0.0, standing_height(&s), 0.0));
    f.euler[16] = [30.0, 0.0, 0.0];
    let text = write_bvh(&s, &[f], 1.0 / 30.0);
    assert_eq!(JointMap::by_names(&BvhFile::parse(&text).unwrap()).unwrap().source, "cmu");
    let clip = MotionClip::load(save(dir.path(), "cmu.bvh", &text)).unwrap();
    let got = Quat::from_scaled_axis(clip.frames[0].pose[16]);
    assert!(angle_between(got, Quat::from_rotation_z(30f32.to_radians())) < 0.01, "{got}");

    // Blender metarig names in metres, with the left arm resting in an A-pose (45 degrees down):
    // every channel zero still shows the A-pose on the SMPL body (the rest correction).
    let s = Skeleton {
        names: BLENDER,
        units: 1.0,
        a_pose_deg: 45.0,
        order: "Xrotation Yrotation Zrotation",
        ..Skeleton::default()
    };
    let text = write_bvh(&s, &[still(Vec3::new(0.0, standing_height(&s), 0.0))], 1.0 / 24.0);
    let bvh = BvhFile::parse(&text).unwrap();
    assert_eq!(JointMap::by_names(&bvh).unwrap().source, "blender");
    let clip = MotionClip::load(save(dir.path(), "apose.bvh", &text)).unwrap();
    assert!((clip.fps - 24.0).abs() < 1e-3);
    let smpl = body.pose(&clip.frames[0]).posed_joints();
    let rest = bvh.rest_positions();
    let idx = |n: &str| bvh.joint_index(n).unwrap();
    for (a, b, na, nb) in [(16, 18, "upper_arm.L", "forearm.L"), (18, 20, "forearm.L", "hand.L")] {
        let want = (rest[idx(nb)] - rest[idx(na)]).normalize();
        let have = (smpl[b] - smpl[a]).normalize();
        assert!(want.dot(have) > 0.9999, "bone {a}->{b}: {have} vs {want}");
        assert!(have.y < -0.6, "the arm hangs down: {have}");
    }
    // The other arm stays in the T-pose.
    assert!(clip.frames[0].pose[17].length() < 1e-4 && clip.frames[0].pose[19].length() < 1e-4);
}

#[test]
fn a_mapping_file_names_an_unknown_skeleton() {
    let dir = tempfile::tempdir().unwrap();
    let names: Vec<String> = (0..NUM_JOINTS).map(|j| format!("bone{j:02}")).collect();
    let names: [&str; NUM_JOINTS] = std::array::from_fn(|j| names[j].as_str());
    let s = Skeleton { names, ..Skeleton::default() };
    let mut f = still(Vec3::new(0.0, standing_height(&s), 0.0));
    f.euler[5] = [0.0, 25.0, 0.0];
    let path = save(dir.path(), "robot.bvh", &write_bvh(&s, &[f], 1.0 / 30.0));
    let e = MotionClip::load(&path).unwrap_err().to_string();
    assert!(e.contains("robot.bvh") && e.contains("mapping file"), "{e}");
    let joints: serde_json::Map<String, serde_json::Value> = (0..NUM_JOINTS)
        .map(|j| (names[j].to_string(), avatar_core::body::JOINT_NAMES[j].into()))
        .collect();
    save(
        dir.path(),
        "robot.map.json",
        &serde_json::json!({ "joints": joints, "scale": 0.01 }).to_string(),
    );
    let clip = MotionClip::load(&path).unwrap();
    let got = Quat::from_scaled_axis(clip.frames[0].pose[5]);
    assert!(
        angle_between(got, Quat::from_rotation_x(25f32.to_radians())) < 0.01,
        "right_knee {got}"
    );
    // A bad mapping file is named with the problem.
    save(
        dir.path(),
        "robot.map.json",
        r#"{"joints": {"bone00": "pelvis", "bone01": "left_thigh"}}"#,
    );
    let e = MotionClip::load(&path).unwrap_err().to_string();
    assert!(e.contains("robot.map.json") && e.contains("left_thigh"), "{e}");
}

#[test]
fn bad_files_are_refused_naming_the_file_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let s = Skeleton::default();
    let good = write_bvh(&s, &[still(Vec3::Y), still(Vec3::Y), still(Vec3::Y)], 1.0 / 30.0);
    let lines: Vec<&str> = good.lines().collect();
    let motion = lines.iter().position(|l| *l == "MOTION").unwrap() + 1; // 1-based line of MOTION

    // A truncated MOTION block (Frames: 3, two frame lines).
    let truncated = lines[..lines.len() - 1].join("\n") + "\n";
    let e = MotionClip::load(save(dir.path(), "cut.bvh", &truncated)).unwrap_err().to_string();
    assert!(
        e.contains("cut.bvh")
            && e.contains("truncated")
            && e.contains(&format!("line {}", motion + 4)),
        "{e}"
    );

    // NaN in the second frame.
    let mut v: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    let second = motion + 3; // MOTION, Frames, Frame Time, frame 0, frame 1 (0-based index motion+3)
    v[second] = v[second].replacen(" 0", " NaN", 1);
    let e = MotionClip::load(save(dir.path(), "nan.bvh", &(v.join("\n") + "\n")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nan.bvh")
            && e.contains(&format!("line {}", second + 1))
            && e.contains("not a finite number"),
        "{e}"
    );

    // A joint without its CHANNELS line.
    let channels = lines.iter().position(|l| l.trim_start().starts_with("CHANNELS 3")).unwrap();
    let mut v: Vec<&str> = lines.clone();
    v.remove(channels);
    let e = MotionClip::load(save(dir.path(), "nochan.bvh", &(v.join("\n") + "\n")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nochan.bvh")
            && e.contains(&format!("line {}", channels + 1))
            && e.contains("CHANNELS"),
        "{e}"
    );

    // A frame line with a missing value.
    let mut v: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    let first = motion + 2;
    v[first] = v[first].rsplit_once(' ').unwrap().0.to_string();
    let e = MotionClip::load(save(dir.path(), "short.bvh", &(v.join("\n") + "\n")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("short.bvh")
            && e.contains(&format!("line {}", first + 1))
            && e.contains("values"),
        "{e}"
    );

    // Not a BVH file at all.
    let e = MotionClip::load(save(dir.path(), "empty.bvh", "")).unwrap_err().to_string();
    assert!(e.contains("empty.bvh") && e.contains("HIERARCHY"), "{e}");
}

#[test]
fn a_retargeted_clip_is_a_valid_clip() {
    let s = Skeleton::default();
    let mut f = still(Vec3::new(0.0, 1.0, 0.0));
    f.euler[0] = [170.0, -170.0, 175.0]; // large root rotations stay within pi per joint
    let bvh = BvhFile::parse(&write_bvh(&s, &[f], 0.04)).unwrap();
    let clip = avatar_core::motion::retarget::retarget(
        &bvh,
        &JointMap::by_names(&bvh).unwrap(),
        open_body_ref(),
        "x",
    )
    .unwrap();
    clip.validate().unwrap();
    assert!(clip.frames[0].pose.iter().all(|a| a.length() <= std::f32::consts::PI + 1e-4));
}
