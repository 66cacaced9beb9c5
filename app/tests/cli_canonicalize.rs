//! `avatar-studio canonicalize` on the demo capture: a PLY of canonical points near the
//! canonical body, and a clear error for a folder that is not a capture.

use std::path::Path;
use std::process::Command;

#[test]
fn canonicalizes_the_demo_capture() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("points.ply");
    let run = Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
        .args(["canonicalize"])
        .arg(&demo)
        .arg("--out")
        .arg(&out)
        .args(["--frames", "2", "--field-cells", "64", "--no-cache"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("frame 0:") && stderr.contains("dropped by the 2 cm filter"),
        "{stderr}"
    );
    let text = std::fs::read(&out).unwrap();
    let header = String::from_utf8_lossy(&text[..text.len().min(400)]).to_string();
    assert!(header.contains("property float nx"), "{header}");
    let n: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(n > 4000, "{n} points");
    // Binary PLY: x y z nx ny nz per point. Canonical points lie on the T-posed body's clothes:
    // within 5 cm of the canonical body surface for nearly all, unit normals.
    let start = text.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let floats: Vec<f32> =
        text[start..].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(floats.len(), n * 6);
    let body = avatar_core::body::open_body_ref();
    let bvh = avatar_core::mesh::bvh::Bvh::build(&body.mesh(body.shaped_vertices(&[])));
    let mut near = 0;
    for p in floats.chunks_exact(6) {
        let (x, nrm) = (glam::Vec3::new(p[0], p[1], p[2]), glam::Vec3::new(p[3], p[4], p[5]));
        assert!((nrm.length() - 1.0).abs() < 1e-3);
        if bvh.closest_point(x).unwrap().distance < 0.05 {
            near += 1;
        }
    }
    // (The demo subject's shape differs from the mean body by a few centimetres.)
    assert!(near as f32 > 0.9 * n as f32, "{near} of {n} within 5 cm of the canonical body");
}

#[test]
fn a_folder_without_capture_json_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
        .arg("canonicalize")
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("x.ply"))
        .output()
        .unwrap();
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("capture.json"));
}
