//! `avatar-studio import scan` and `fit` on its capture, `fit` refusing a capture with
//! translations in millimetres unless `--frames` allows it, and `export` playing a BVH file.

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::capture::{
    CaptureManifest, DEPTH_SCALE_MM, FrameRecord, Intrinsics, write_depth_png,
};
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::io::write_obj;
use avatar_core::synth::{
    ClothedTemplate, Outfit, PinholeCamera, PoseFeatures, canonical_surface, orbit, pose_surface,
    render_depth,
};
use glam::Vec3;
use std::path::Path;
use std::process::Command;

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

fn text(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

#[test]
fn a_scan_imports_into_a_capture_that_fit_takes() {
    let dir = tempfile::tempdir().unwrap();
    let body = open_body_ref();
    let mut pose = BodyParams::default();
    pose.pose[16].z = -0.7;
    pose.pose[17].z = 0.7;
    let t = ClothedTemplate::build(body, &[], Outfit::LongsleeveTrousers);
    let posed = body.pose(&pose);
    let canonical = canonical_surface(&t, &PoseFeatures::of(&posed.bones), 1);
    write_obj(
        dir.path().join("scan.obj"),
        &TriMesh::new(pose_surface(&t, &canonical, &posed.bones), t.faces.clone()),
    )
    .unwrap();
    std::fs::write(dir.path().join("pose.json"), serde_json::to_string(&pose).unwrap()).unwrap();
    let cap = dir.path().join("capture");
    let o = studio()
        .args(["import", "scan"])
        .arg(dir.path().join("scan.obj"))
        .arg("--fitting")
        .arg(dir.path().join("pose.json"))
        .arg("--out")
        .arg(&cap)
        .args(["--views", "4", "--resolution", "128"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("4 views"), "{}", text(&o));
    let o = studio()
        .arg("fit")
        .arg(&cap)
        .arg("--out")
        .arg(dir.path().join("scan.avatar"))
        .args(["--steps", "2", "--frames", "4"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("4 frames"), "{}", text(&o));
}

#[test]
fn fit_refuses_millimetre_translations_unless_frames_allows_it() {
    let dir = tempfile::tempdir().unwrap();
    let body = open_body_ref();
    let cam = PinholeCamera::metaavatar();
    let intr = Intrinsics {
        fx: cam.fx,
        fy: cam.fy,
        cx: cam.cx,
        cy: cam.cy,
        width: cam.width,
        height: cam.height,
    };
    let mut m = CaptureManifest::new(intr, DEPTH_SCALE_MM);
    for i in 0..4 {
        let mut p = BodyParams::default();
        p.pose[16].z = -0.8;
        p.pose[17].z = 0.8;
        // Frame 1 stands at the origin (0 mm = 0 m); the others are 5 to 15 cm off it.
        p.trans = if i == 1 { Vec3::ZERO } else { Vec3::new(0.05 * i as f32, -0.05, 0.1) };
        let c2w = orbit(Vec3::new(0.0, -0.2, 0.0), 2.6, 0.5 * i as f32);
        let r = render_depth(&cam, c2w, &body.pose(&p).vertices, &body.faces);
        let name = format!("depth/{i:06}.png");
        write_depth_png(dir.path().join(&name), &r.depth, cam.width, cam.height, DEPTH_SCALE_MM)
            .unwrap();
        let mut rec = FrameRecord {
            depth: name,
            mask: None,
            pose: Some(p.flat_pose()),
            shape: vec![],
            translation: Some((p.trans * 1000.0).to_array()),
            camera_to_world: None,
        };
        rec.set_camera_to_world(c2w);
        m.frames.push(rec);
    }
    m.save(dir.path()).unwrap();
    let out = dir.path().join("mm.avatar");
    let o = studio()
        .arg("fit")
        .arg(dir.path())
        .arg("--out")
        .arg(&out)
        .args(["--steps", "1"])
        .output()
        .unwrap();
    let msg = text(&o);
    assert!(!o.status.success(), "{msg}");
    for want in [
        "only 1 usable frame (frame 1) of the 4 asked",
        "translations look like millimetres",
        "frame 0 (",
        "--frames 1",
    ] {
        assert!(msg.contains(want), "missing {want:?} in {msg}");
    }
    assert!(!out.exists());
    let o = studio()
        .arg("fit")
        .arg(dir.path())
        .arg("--out")
        .arg(&out)
        .args(["--steps", "1", "--frames", "1"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("millimetres"), "the warning stays: {}", text(&o));
}

/// A small Mixamo-style skeleton in centimetres: the left knee bends 60 degrees over 4 frames at 60 fps.
const BVH: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT LeftUpLeg
  {
    OFFSET 9 -6 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftLeg
    {
      OFFSET 0 -40 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 -42 0
      }
    }
  }
  JOINT RightUpLeg
  {
    OFFSET -9 -6 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RightLeg
    {
      OFFSET 0 -40 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 -42 0
      }
    }
  }
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 0 55 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 20 0
      }
    }
  }
}
MOTION
Frames: 4
Frame Time: 0.0166667
0 88 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
0 88 1 0 0 0 0 0 0 0 20 0 0 0 0 0 0 0 0 0 0 0 0 0
0 88 2 0 0 0 0 0 0 0 40 0 0 0 0 0 0 0 0 0 0 0 0 0
0 88 3 0 0 0 0 0 0 0 60 0 0 0 0 0 0 0 0 0 0 0 0 0
";

#[test]
fn export_plays_a_bvh_file() {
    let dir = tempfile::tempdir().unwrap();
    let bvh = dir.path().join("kneebend.bvh");
    std::fs::write(&bvh, BVH).unwrap();
    let seq = dir.path().join("seq");
    let o = studio()
        .args(["export", "--format", "obj", "--fps", "60", "--motion"])
        .arg(&bvh)
        .arg("--out")
        .arg(&seq)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(Path::new(&seq).join("frame_000003.obj").exists(), "{}", text(&o));
    let clip = avatar_core::motion::MotionClip::load(&bvh).unwrap();
    assert!((clip.fps - 60.0).abs() < 0.01 && clip.len() == 4);
    // The left knee turned 60 degrees between the first and the last frame (the hip's rest
    // correction conjugates it, the angle stays).
    let (q0, q3) = (
        glam::Quat::from_scaled_axis(clip.frames[0].pose[4]),
        glam::Quat::from_scaled_axis(clip.frames[3].pose[4]),
    );
    let d = q0.conjugate() * q3;
    let angle = (2.0 * d.xyz().length().atan2(d.w.abs())).to_degrees();
    assert!((angle - 60.0).abs() < 0.01, "{q0} {q3}: {angle}");
    assert!((clip.frames[3].trans.z - clip.frames[0].trans.z - 0.03).abs() < 1e-5);
    // A file that is cut short is named with its line.
    std::fs::write(&bvh, BVH.rsplit_once("0 88 3").unwrap().0).unwrap();
    let o = studio()
        .args(["export", "--format", "obj", "--motion"])
        .arg(&bvh)
        .arg("--out")
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert!(
        !o.status.success() && text(&o).contains("kneebend.bvh") && text(&o).contains("line 54"),
        "{}",
        text(&o)
    );
}
