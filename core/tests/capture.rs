//! Capture folders end to end: write a rendered capture of the posed open body, open it, and
//! check the points lie on the body; every kind of bad input gives a warning or an error that
//! names the frame and the file.

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::capture::*;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::synth::{PinholeCamera, orbit, render_depth};
use glam::{Mat4, Vec3};
use std::path::Path;

fn intrinsics(cam: &PinholeCamera) -> Intrinsics {
    Intrinsics {
        fx: cam.fx,
        fy: cam.fy,
        cx: cam.cx,
        cy: cam.cy,
        width: cam.width,
        height: cam.height,
    }
}

fn pose(i: usize) -> BodyParams {
    let mut p = BodyParams::default();
    p.pose[16].z = -0.9 + 0.2 * i as f32; // left shoulder down
    p.pose[17].z = 0.9;
    p.pose[4].x = 0.3 * i as f32; // left knee
    p
}

/// Render `n` frames of the posed body (plus optional floor and wall) into a capture folder.
fn write_capture(dir: &Path, n: usize, with_scene: bool) -> (CaptureManifest, Vec<Mat4>) {
    let body = open_body_ref();
    let cam = PinholeCamera::metaavatar();
    std::fs::create_dir_all(dir.join("depth")).unwrap();
    let mut m = CaptureManifest::new(intrinsics(&cam), DEPTH_SCALE_MM);
    let mut c2ws = Vec::new();
    for i in 0..n {
        let params = pose(i);
        let posed = body.pose(&params);
        let mut positions = posed.vertices.clone();
        let mut faces = body.faces.clone();
        if with_scene {
            let feet = positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
            let base = positions.len() as u32;
            // A floor under the feet (kept beyond the near plane) and a wall 1.5 m behind the body.
            positions.extend([
                Vec3::new(-1.5, feet, -1.2),
                Vec3::new(1.5, feet, -1.2),
                Vec3::new(1.5, feet, 1.0),
                Vec3::new(-1.5, feet, 1.0),
                Vec3::new(-2.0, -1.0, -1.5),
                Vec3::new(2.0, -1.0, -1.5),
                Vec3::new(2.0, 2.0, -1.5),
                Vec3::new(-2.0, 2.0, -1.5),
            ]);
            faces.extend([
                [base, base + 2, base + 1],
                [base, base + 3, base + 2],
                [base + 4, base + 5, base + 6],
                [base + 4, base + 6, base + 7],
            ]);
        }
        let c2w = orbit(Vec3::new(0.0, -0.2, 0.0), 2.6, 0.3 * i as f32)
            * Mat4::from_translation(Vec3::new(0.0, 0.0, 0.0));
        let render = render_depth(&cam, c2w, &positions, &faces);
        let name = format!("depth/{i:06}.png");
        write_depth_png(dir.join(&name), &render.depth, cam.width, cam.height, DEPTH_SCALE_MM)
            .unwrap();
        let mut rec = FrameRecord {
            depth: name,
            mask: None,
            pose: Some(params.flat_pose()),
            shape: vec![],
            translation: Some([0.0; 3]),
            camera_to_world: None,
        };
        rec.set_camera_to_world(c2w);
        m.frames.push(rec);
        c2ws.push(c2w);
    }
    m.save(dir).unwrap();
    (m, c2ws)
}

#[test]
fn back_projected_points_lie_on_the_posed_body() {
    let dir = tempfile::tempdir().unwrap();
    write_capture(dir.path(), 2, false);
    let cap = Capture::open(dir.path()).unwrap();
    assert!(cap.warnings.is_empty(), "{:?}", cap.warnings);
    assert_eq!(cap.frames.len(), 2);
    for f in &cap.frames {
        let body = open_body_ref();
        let posed = body.pose(&f.params);
        let mesh = body.mesh(posed.vertices);
        let bvh = Bvh::build(&mesh);
        let mut d: Vec<f32> =
            f.points.iter().map(|&p| bvh.closest_point(p).unwrap().distance).collect();
        d.sort_by(f32::total_cmp);
        let median = d[d.len() / 2];
        assert!(f.points.len() > 3000, "{} points", f.points.len());
        assert!(median < 0.002, "median distance {median} m");
        // Normals face the camera and mostly agree with the mesh's normals.
        let face_normals = mesh.face_normals();
        let cc = f.camera_center();
        let mut agree = 0;
        for (p, n) in f.points.iter().zip(&f.normals) {
            assert!(n.dot(cc - *p) >= 0.0);
            let hit = bvh.closest_point(*p).unwrap();
            if n.dot(face_normals[hit.face as usize]) > 0.8 {
                agree += 1;
            }
        }
        assert!(
            agree as f32 > 0.85 * f.points.len() as f32,
            "{agree} of {} normals agree",
            f.points.len()
        );
    }
}

#[test]
fn floor_and_wall_are_cropped_away() {
    let clean = tempfile::tempdir().unwrap();
    write_capture(clean.path(), 1, false);
    let scene = tempfile::tempdir().unwrap();
    write_capture(scene.path(), 1, true);
    let a = Capture::open(clean.path()).unwrap();
    let b = Capture::open(scene.path()).unwrap();
    let (fa, fb) = (&a.frames[0], &b.frames[0]);
    assert!(fb.crop.floor > 100, "{:?}", fb.crop);
    assert!(fb.crop.far_from_body > 5000, "{:?}", fb.crop);
    // What is left is the body: about as many points as without the scene, all on the body.
    let diff = (fa.points.len() as i64 - fb.points.len() as i64).abs();
    assert!(diff < fa.points.len() as i64 / 50, "{} vs {}", fa.points.len(), fb.points.len());
    let body = open_body_ref();
    let bvh = Bvh::build(&body.mesh(body.pose(&fb.params).vertices));
    let off = fb.points.iter().filter(|&&p| bvh.closest_point(p).unwrap().distance > 0.02).count();
    assert!(off < fb.points.len() / 100, "{off} points off the body");
}

fn warning_for(cap: &Capture, frame: usize) -> String {
    cap.warnings
        .iter()
        .find(|w| w.index == frame)
        .map(|w| w.to_string())
        .unwrap_or_else(|| panic!("no warning for frame {frame}: {:?}", cap.warnings))
}

#[test]
fn every_bad_frame_is_named_and_good_frames_survive() {
    let dir = tempfile::tempdir().unwrap();
    let (mut m, _) = write_capture(dir.path(), 8, false);
    let d = dir.path();
    // 1: missing image. 2: corrupt image. 3: wrong size. 4: wrong units (metres stored as mm).
    // 5: NaN in the fitting. 6: no fitting. 7: fitting far from the points (empty crop).
    std::fs::remove_file(d.join(&m.frames[1].depth)).unwrap();
    std::fs::write(d.join(&m.frames[2].depth), b"not a png at all").unwrap();
    write_depth_png(d.join(&m.frames[3].depth), &vec![2.0; 100 * 80], 100, 80, DEPTH_SCALE_MM)
        .unwrap();
    let img = read_depth_png(d.join(&m.frames[4].depth), DEPTH_SCALE_MM).unwrap();
    write_depth_png(
        d.join(&m.frames[4].depth),
        &img.metres,
        img.width,
        img.height,
        DEPTH_SCALE_MM * 10.0,
    )
    .unwrap();
    m.frames[6].pose = None;
    m.frames[7].translation = Some([3.0, 0.0, 0.0]);
    m.save(d).unwrap();
    // NaN can only be written as null in JSON.
    let text = std::fs::read_to_string(d.join(MANIFEST_FILE)).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["frames"][5]["pose"][7] = serde_json::Value::Null;
    std::fs::write(d.join(MANIFEST_FILE), serde_json::to_string(&json).unwrap()).unwrap();

    let cap = Capture::open(d).unwrap();
    assert_eq!(cap.frames.iter().map(|f| f.index).collect::<Vec<_>>(), vec![0]);
    assert_eq!(cap.warnings.len(), 7);
    let w = warning_for(&cap, 1);
    assert!(
        w.contains("000001.png") && (w.contains("No such file") || w.contains("not found")),
        "{w}"
    );
    let w = warning_for(&cap, 2);
    assert!(w.contains("000002.png") && w.contains("PNG"), "{w}");
    let w = warning_for(&cap, 3);
    assert!(w.contains("100x80") && w.contains("250x250"), "{w}");
    let w = warning_for(&cap, 4);
    assert!(w.contains("wrong units") && w.contains("depth_scale"), "{w}");
    let w = warning_for(&cap, 5);
    assert!(w.contains("frame 5") && w.contains("body fitting"), "{w}");
    let w = warning_for(&cap, 6);
    assert!(w.contains("no body fitting"), "{w}");
    let w = warning_for(&cap, 7);
    assert!(w.contains("within 30 cm"), "{w}");
}

#[test]
fn mostly_zero_depth_and_all_bad_captures() {
    let dir = tempfile::tempdir().unwrap();
    let (m, _) = write_capture(dir.path(), 1, false);
    let mut zero = vec![0.0; 250 * 250];
    zero[0] = 2.0;
    write_depth_png(dir.path().join(&m.frames[0].depth), &zero, 250, 250, DEPTH_SCALE_MM).unwrap();
    let err = Capture::open(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("capture.json")
            && err.contains("no usable frame")
            && err.contains("zero almost everywhere"),
        "{err}"
    );
}

#[test]
fn bad_manifests_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let err = Capture::open(dir.path()).unwrap_err().to_string();
    assert!(err.contains("capture.json"), "{err}");
    std::fs::write(
        dir.path().join(MANIFEST_FILE),
        "{\"format\": \"avatar-studio-capture\", \"version\": 1",
    )
    .unwrap();
    let err = Capture::open(dir.path()).unwrap_err().to_string();
    assert!(err.contains("capture.json") && err.contains("not a valid capture manifest"), "{err}");
    let json = r#"{"format":"avatar-studio-capture","version":1,"intrinsics":{"fx":250,"fy":250,"cx":125,"cy":125,"width":250,"height":250},"depth_scale":1000,"frames":[]}"#;
    std::fs::write(dir.path().join(MANIFEST_FILE), json).unwrap();
    let err = Capture::open(dir.path()).unwrap_err().to_string();
    assert!(err.contains("capture.json") && err.contains("no frames"), "{err}");
}

#[test]
fn tum_depth_scale_reads_the_same_points() {
    let dir = tempfile::tempdir().unwrap();
    let (mut m, _) = write_capture(dir.path(), 1, false);
    let a = Capture::open(dir.path()).unwrap();
    let img = read_depth_png(dir.path().join(&m.frames[0].depth), DEPTH_SCALE_MM).unwrap();
    write_depth_png(dir.path().join(&m.frames[0].depth), &img.metres, 250, 250, DEPTH_SCALE_TUM)
        .unwrap();
    m.depth_scale = DEPTH_SCALE_TUM;
    m.save(dir.path()).unwrap();
    let b = Capture::open(dir.path()).unwrap();
    assert_eq!(a.frames[0].points.len(), b.frames[0].points.len());
    for (p, q) in a.frames[0].points.iter().zip(&b.frames[0].points) {
        assert!((*p - *q).length() < 3e-4);
    }
}
