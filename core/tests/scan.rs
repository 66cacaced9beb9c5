//! `import scan`: OBJ files written here (normals, quads, several objects) load with tobj; a
//! synthetic clothed person written as an OBJ becomes a capture whose depth points lie on the
//! scan and cover it; scans in the wrong units or that the fitting does not describe are refused.
//! (The avatar fitted from such a capture against the scan: app/tests/scan_avatar.rs.)

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::capture::Capture;
use avatar_core::capture::scan::{ScanViews, import_scan, load_scan};
use avatar_core::eval::sampling::PointIndex;
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::synth::{ClothedTemplate, Outfit, PoseFeatures, canonical_surface, pose_surface};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;

/// The scan's pose: arms lowered, one knee bent, turned a little.
pub fn scan_pose() -> BodyParams {
    let mut p = BodyParams::default();
    p.pose[0].y = 0.4;
    p.pose[16].z = -0.8;
    p.pose[17].z = 0.8;
    p.pose[4].x = 0.4;
    p.trans = Vec3::new(0.1, 0.0, -0.2);
    p
}

/// The synthetic clothed person (polo with a loose hem) posed as `scan_pose`.
pub fn clothed_scan() -> TriMesh {
    let body = open_body_ref();
    let t = ClothedTemplate::build(body, &[], Outfit::PoloLoose);
    let posed = body.pose(&scan_pose());
    let canonical = canonical_surface(&t, &PoseFeatures::of(&posed.bones), 7);
    TriMesh::new(pose_surface(&t, &canonical, &posed.bones), t.faces.clone())
}

/// OBJ text with vertex normals, the faces split over two objects (`o body`, `o clothes`).
fn obj_with_normals_and_objects(mesh: &TriMesh, scale: f32) -> String {
    let mut s = String::from("# a test scan\nmtllib missing.mtl\n");
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p.x * scale, p.y * scale, p.z * scale);
    }
    for n in mesh.vertex_normals() {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    let half = mesh.faces.len() / 2;
    for (k, f) in mesh.faces.iter().enumerate() {
        if k == 0 || k == half {
            s.push_str(if k == 0 { "o body\n" } else { "o clothes\nusemtl cloth\n" });
        }
        let [a, b, c] = f.map(|i| i + 1);
        let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
    }
    s
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn quads_objects_and_missing_normals_load() {
    let dir = tempfile::tempdir().unwrap();
    // A unit cube of 6 quads without normals, and a triangle in a second object with negative indices.
    let cube = "o cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n\
                o tri\nv 5 0 0\nv 6 0 0\nv 5 1 0\nf -3 -2 -1\n";
    let m = load_scan(write(dir.path(), "cube.obj", cube)).unwrap();
    assert_eq!((m.positions.len(), m.faces.len()), (11, 13));
    assert!((m.surface_area() - 6.5).abs() < 1e-5, "{}", m.surface_area());
    let e =
        load_scan(write(dir.path(), "points.obj", "v 0 0 0\nv 1 0 0\n")).unwrap_err().to_string();
    assert!(e.contains("points.obj") && e.contains("no faces"), "{e}");
    let e = load_scan(write(dir.path(), "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.obj"), "{e}");
    let e = load_scan(dir.path().join("missing.obj")).unwrap_err().to_string();
    assert!(e.contains("missing.obj"), "{e}");
}

#[test]
fn a_scan_becomes_a_capture_whose_depth_lies_on_the_scan() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = clothed_scan();
    let scan = write(dir.path(), "scan.obj", &obj_with_normals_and_objects(&mesh, 1.0));
    let fitting = write(dir.path(), "pose.json", &serde_json::to_string(&scan_pose()).unwrap());
    let out = dir.path().join("capture");
    let report = import_scan(
        &scan,
        &fitting,
        &out,
        open_body_ref(),
        &ScanViews { views: 6, resolution: 160 },
    )
    .unwrap();
    assert_eq!((report.frames, report.faces), (6, mesh.faces.len()));
    let capture = Capture::open(&out).unwrap();
    assert_eq!(capture.frames.len(), 6, "{:?}", capture.warnings);
    // Every depth point lies on the scan (0.1 mm depth steps, float error).
    let bvh = Bvh::build(&mesh);
    let mut all = Vec::new();
    for f in &capture.frames {
        assert_eq!(f.params, scan_pose());
        let worst =
            f.points.iter().map(|p| bvh.closest_point(*p).unwrap().distance).fold(0.0, f32::max);
        assert!(worst < 2e-4, "frame {}: a point {:.3} mm off the scan", f.index, worst * 1000.0);
        all.extend(f.points.iter().copied());
    }
    // The ring of views covers most of the scan (not the top of the head, under the arms, soles).
    let index = PointIndex::new(&all).unwrap();
    let covered = mesh.positions.iter().filter(|p| index.nearest(**p).1 < 0.01).count();
    let fraction = covered as f32 / mesh.positions.len() as f32;
    assert!(fraction > 0.8, "only {:.0} % of the scan seen", fraction * 100.0);
}

#[test]
fn scans_in_millimetres_or_elsewhere_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = clothed_scan();
    let fitting = write(dir.path(), "pose.json", &serde_json::to_string(&scan_pose()).unwrap());
    let mm = write(dir.path(), "mm.obj", &obj_with_normals_and_objects(&mesh, 1000.0));
    let e =
        import_scan(&mm, &fitting, &dir.path().join("a"), open_body_ref(), &ScanViews::default())
            .unwrap_err()
            .to_string();
    assert!(e.contains("mm.obj") && e.contains("millimetres"), "{e}");
    let mut other = scan_pose();
    other.trans.x += 1.5;
    let elsewhere = write(dir.path(), "elsewhere.json", &serde_json::to_string(&other).unwrap());
    let ok = write(dir.path(), "scan.obj", &obj_with_normals_and_objects(&mesh, 1.0));
    let e =
        import_scan(&ok, &elsewhere, &dir.path().join("b"), open_body_ref(), &ScanViews::default())
            .unwrap_err()
            .to_string();
    assert!(e.contains("scan.obj") && e.contains("fitting"), "{e}");
    // The output may not be the scan itself.
    let e = import_scan(&ok, &fitting, &ok, open_body_ref(), &ScanViews::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("overwrite"), "{e}");
}
