//! `import depth` and the units/plausibility checks: folders of depth PNGs with AMASS-style or
//! JSON fittings (written here) become captures that open; bad inputs are named; translations
//! in millimetres are diagnosed in one line and a fit with fewer usable frames than asked is
//! refused, naming the frames.

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::capture::import::{DepthImport, Pinhole, import_depth};
use avatar_core::capture::plausibility::require_usable_frames;
use avatar_core::capture::*;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::synth::{PinholeCamera, orbit, render_depth};
use glam::{Mat4, Quat, Vec3};
use std::path::Path;

fn pose(i: usize) -> BodyParams {
    let mut p = BodyParams::default();
    p.pose[16].z = -0.9 + 0.2 * i as f32;
    p.pose[17].z = 0.9;
    p.pose[4].x = 0.3 * i as f32;
    p.trans = Vec3::new(0.05, -0.1 + 0.05 * i as f32, 0.1);
    p
}

/// Render the posed open body at `scale` PNG units per metre.
fn render(path: &Path, params: &BodyParams, c2w: Mat4, scale: f32) {
    let body = open_body_ref();
    let cam = PinholeCamera::metaavatar();
    let posed = body.pose(params);
    let r = render_depth(&cam, c2w, &posed.vertices, &body.faces);
    write_depth_png(path, &r.depth, cam.width, cam.height, scale).unwrap();
}

fn camera(i: usize) -> Mat4 {
    orbit(Vec3::new(0.0, -0.2, 0.0), 2.6, 0.4 * i as f32)
}

fn row_major(m: Mat4) -> Vec<f32> {
    m.transpose().to_cols_array().to_vec()
}

/// A TUM-scale depth folder (names out of lexical order), an AMASS-style npz and cameras.
fn amass_input(root: &Path, n: usize, trans_scale: f32) -> DepthImport {
    let depth = root.join("depth_in");
    std::fs::create_dir_all(&depth).unwrap();
    let names = ["frame_1.png", "frame_2.png", "frame_10.png", "frame_11.png"];
    let mut poses = Vec::new();
    let mut trans = Vec::new();
    for i in 0..n {
        let p = pose(i);
        render(&depth.join(names[i]), &p, camera(i), DEPTH_SCALE_TUM);
        poses.extend(p.flat_pose());
        trans.extend((p.trans * trans_scale).to_array());
    }
    let npz = root.join("fit.npz");
    avatar_core::io::npz::write_f32_npz(
        &npz,
        &[
            ("poses", vec![n, 72], poses),
            ("trans", vec![n, 3], trans),
            ("mocap_framerate", vec![], vec![60.0]),
        ],
    )
    .unwrap();
    let cams: Vec<Vec<f32>> = (0..n).map(|i| row_major(camera(i))).collect();
    let cameras = root.join("cameras.json");
    std::fs::write(&cameras, serde_json::to_string(&cams).unwrap()).unwrap();
    DepthImport {
        depth_dir: depth,
        fittings: npz,
        pinhole: Pinhole::parse("250,250,125,125").unwrap(),
        depth_scale: DEPTH_SCALE_TUM,
        z_up: false,
        cameras: Some(cameras),
        fps: None,
        body_model: None,
    }
}

fn assert_on_body(capture: &Capture, max_mm: f32) {
    let body = open_body_ref();
    for f in &capture.frames {
        let bvh = Bvh::build(&body.mesh(body.pose(&f.params).vertices));
        let worst =
            f.points.iter().map(|p| bvh.closest_point(*p).unwrap().distance).fold(0.0, f32::max);
        assert!(
            worst * 1000.0 < max_mm,
            "frame {}: a point {:.1} mm off the body",
            f.index,
            worst * 1000.0
        );
        assert!(f.points.len() > 1000, "frame {}: {} points", f.index, f.points.len());
    }
}

#[test]
fn depth_folder_with_amass_fittings_becomes_a_capture() {
    let root = tempfile::tempdir().unwrap();
    let job = amass_input(root.path(), 3, 1.0);
    let out = root.path().join("capture");
    let report = import_depth(&job, &out).unwrap();
    assert_eq!((report.frames, report.usable), (3, 3), "{:?}", report.warnings);
    assert!(report.diagnosis.is_none());
    let capture = Capture::open(&out).unwrap();
    assert_eq!(capture.manifest.depth_scale, DEPTH_SCALE_TUM);
    assert_eq!(capture.manifest.fps, Some(60.0));
    // Natural order: frame_1, frame_2, frame_10 carry the fittings 0, 1, 2.
    for (i, f) in capture.frames.iter().enumerate() {
        assert_eq!(f.params.pose[4].x, pose(i).pose[4].x);
        assert!(f.camera_to_world.abs_diff_eq(camera(i), 1e-6));
    }
    assert_on_body(&capture, 3.0);
    // The inputs are untouched and the output is refused a second time.
    let e = import_depth(&job, &out).unwrap_err().to_string();
    assert!(e.contains("not empty"), "{e}");
    let e = import_depth(&job, &job.depth_dir.clone()).unwrap_err().to_string();
    assert!(e.contains("overwrite the input"), "{e}");
}

#[test]
fn fittings_of_the_users_own_body_model_name_it_in_the_capture() {
    let root = tempfile::tempdir().unwrap();
    let mut job = amass_input(root.path(), 2, 1.0);
    // The open body written in SMPL's layout stands in for the user's model (same geometry).
    let model = root.path().join("my_model.npz");
    open_body_ref().save_npz(&model).unwrap();
    job.body_model = Some(model.clone());
    let out = root.path().join("capture");
    let report = import_depth(&job, &out).unwrap();
    assert_eq!(report.usable, 2, "{:?}", report.warnings);
    let capture = Capture::open(&out).unwrap();
    let absolute = std::fs::canonicalize(&model).unwrap();
    assert_eq!(
        capture.manifest.body_model,
        avatar_core::capture::manifest::BodyModelRef::Smpl(absolute.clone())
    );
    assert_eq!(capture.body_file.as_deref(), Some(absolute.as_path()));
    assert_on_body(&capture, 3.0);
    // A missing model file is named, and nothing is written.
    job.body_model = Some(root.path().join("gone.npz"));
    let out2 = root.path().join("capture2");
    let e = import_depth(&job, &out2).unwrap_err().to_string();
    assert!(e.contains("gone.npz"), "{e}");
    assert!(!out2.exists() || std::fs::read_dir(&out2).unwrap().next().is_none());
}

#[test]
fn json_pose_files_in_camera_coordinates_and_an_intrinsics_file() {
    let root = tempfile::tempdir().unwrap();
    let (depth, fits) = (root.path().join("d"), root.path().join("f"));
    std::fs::create_dir_all(&depth).unwrap();
    std::fs::create_dir_all(&fits).unwrap();
    for i in 0..2 {
        // The body upside down in OpenCV camera axes (y down), facing the camera, 2.5 m away.
        let mut p = pose(i);
        p.pose[0] = (Quat::from_rotation_x(std::f32::consts::PI)).to_scaled_axis();
        let j0 = open_body_ref().rest_joints(&[])[0];
        p.trans = Vec3::new(0.0, 0.0, 2.5) - j0;
        render(&depth.join(format!("{i}.png")), &p, Mat4::IDENTITY, DEPTH_SCALE_MM);
        std::fs::write(
            fits.join(format!("{i}.json")),
            serde_json::json!({"pose": p.flat_pose(), "trans": p.trans.to_array()}).to_string(),
        )
        .unwrap();
    }
    let intr = root.path().join("intrinsics.json");
    std::fs::write(
        &intr,
        r#"{"fx": 250, "fy": 250, "cx": 125, "cy": 125, "width": 250, "height": 250}"#,
    )
    .unwrap();
    let job = DepthImport {
        depth_dir: depth,
        fittings: fits,
        pinhole: Pinhole::parse(intr.to_str().unwrap()).unwrap(),
        depth_scale: DEPTH_SCALE_MM,
        z_up: false,
        cameras: None,
        fps: None,
        body_model: None,
    };
    let out = root.path().join("cap");
    let report = import_depth(&job, &out).unwrap();
    assert_eq!(report.usable, 2, "{:?}", report.warnings);
    let capture = Capture::open(&out).unwrap();
    assert_on_body(&capture, 3.0);
    // The capture's world is Y up: the head above the pelvis, the camera 2.5 m in front (+Z).
    for f in &capture.frames {
        let j = open_body_ref().pose(&f.params).posed_joints();
        assert!(j[15].y > j[0].y + 0.4, "head {} pelvis {}", j[15], j[0]);
        assert!((f.camera_center() - j[0]).z > 2.4, "camera {} pelvis {}", f.camera_center(), j[0]);
    }
}

#[test]
fn bad_inputs_are_named() {
    let root = tempfile::tempdir().unwrap();
    let mut job = amass_input(root.path(), 3, 1.0);
    // One image more than fittings.
    render(&job.depth_dir.join("frame_11.png"), &pose(0), camera(0), DEPTH_SCALE_TUM);
    let e = import_depth(&job, &root.path().join("a")).unwrap_err().to_string();
    assert!(e.contains("4 depth images") && e.contains("3 fitted frames"), "{e}");
    // An 8-bit image among them: that frame is a warning naming the input file.
    write_mask_png(job.depth_dir.join("frame_11.png"), &vec![true; 250 * 250], 250, 250).unwrap();
    std::fs::rename(job.depth_dir.join("frame_11.png"), job.depth_dir.join("frame_10.png"))
        .unwrap();
    let r = import_depth(&job, &root.path().join("b")).unwrap();
    assert_eq!(r.usable, 2);
    let w = r.warnings[0].to_string();
    assert!(w.contains("frame_10.png") && w.contains("16-bit"), "{w}");
    // Wrong depth units for every frame: the error names the input folder and the reason.
    job.depth_scale = 5.0;
    let e = import_depth(&job, &root.path().join("c")).unwrap_err().to_string();
    assert!(e.contains("depth_in") && e.contains("wrong units"), "{e}");
    assert!(!root.path().join("c").exists(), "nothing written for a failed import");
    // Intrinsics that are neither numbers nor a file.
    let e = Pinhole::parse("250,250,125").unwrap_err().to_string();
    assert!(e.contains("fx,fy,cx,cy"), "{e}");
}

#[test]
fn millimetre_translations_are_diagnosed_and_too_few_frames_refused() {
    let root = tempfile::tempdir().unwrap();
    // Every translation in millimetres: no frame is usable, and the error says why.
    let job = amass_input(root.path(), 4, 1000.0);
    let e = import_depth(&job, &root.path().join("all")).unwrap_err().to_string();
    assert!(e.contains("translations look like millimetres"), "{e}");

    // A capture.json whose translations (a body 1.45 m from the camera) are in millimetres:
    // over 1 km, every frame is refused, and the capture's error says why in one line. (An npz
    // or JSON fitting with such translations is refused when read, naming the file and frame.)
    let far = root.path().join("far");
    std::fs::create_dir_all(far.join("depth")).unwrap();
    let mut manifest = CaptureManifest::new(
        Intrinsics { fx: 250.0, fy: 250.0, cx: 125.0, cy: 125.0, width: 250, height: 250 },
        DEPTH_SCALE_MM,
    );
    for i in 0..2 {
        let name = format!("depth/{i}.png");
        render(&far.join(&name), &pose(i), camera(i), DEPTH_SCALE_MM);
        manifest.frames.push(FrameRecord {
            depth: name,
            mask: None,
            pose: Some(pose(i).flat_pose()),
            shape: vec![],
            translation: Some([0.0, 0.0, 1450.0]),
            camera_to_world: None,
        });
    }
    manifest.save(&far).unwrap();
    let e = Capture::open(&far).unwrap_err().to_string();
    assert!(
        e.contains("no usable frame") && e.contains("translations look like millimetres: 1450 m"),
        "{e}"
    );

    // The same capture where one frame is at the origin (0 mm = 0 m): that frame is usable.
    let dir = root.path().join("mm");
    let mut manifest = CaptureManifest::new(
        Intrinsics { fx: 250.0, fy: 250.0, cx: 125.0, cy: 125.0, width: 250, height: 250 },
        DEPTH_SCALE_MM,
    );
    std::fs::create_dir_all(dir.join("depth")).unwrap();
    for i in 0..4 {
        let mut p = pose(i);
        if i == 2 {
            p.trans = Vec3::ZERO;
        }
        let name = format!("depth/{i}.png");
        render(&dir.join(&name), &p, camera(i), DEPTH_SCALE_MM);
        let mut rec = FrameRecord {
            depth: name,
            mask: None,
            pose: Some(p.flat_pose()),
            shape: vec![],
            translation: Some((p.trans * 1000.0).to_array()),
            camera_to_world: None,
        };
        rec.set_camera_to_world(camera(i));
        manifest.frames.push(rec);
    }
    manifest.save(&dir).unwrap();
    let capture = Capture::open(&dir).unwrap();
    assert_eq!(capture.frames.len(), 1);
    let d = capture.diagnose().expect("3 of 4 frames miss the body");
    assert!(d.starts_with("translations look like millimetres:"), "{d}");
    let e = require_usable_frames(&capture, 8, &[2], &[]).unwrap_err().to_string();
    for want in [
        "capture.json",
        "only 1 usable frame (frame 2) of the 4 asked",
        "millimetres",
        "frame 0 (",
        "frame 3 (",
        "--frames 1",
    ] {
        assert!(e.contains(want), "missing {want:?} in {e}");
    }
    // Asking for no more than the usable frames is allowed.
    require_usable_frames(&capture, 1, &[2], &[]).unwrap();
}
