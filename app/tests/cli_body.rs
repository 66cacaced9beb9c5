//! `avatar-studio body` end to end: pose file in, mesh out, clear errors on bad input.

use std::process::Command;

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

#[test]
fn body_command_poses_and_writes_obj() {
    let dir = tempfile::tempdir().unwrap();
    let pose = dir.path().join("pose.json");
    // Left shoulder lowered 1.2 rad about z: the left hand drops well below shoulder height.
    let mut p = vec![[0.0f32; 3]; 24];
    p[16] = [0.0, 0.0, -1.2];
    std::fs::write(&pose, serde_json::json!({"pose": p, "trans": [0.0, 1.0, 0.0]}).to_string())
        .unwrap();
    let out = dir.path().join("body.obj");
    let status =
        studio().args(["body", "--pose"]).arg(&pose).arg("--out").arg(&out).status().unwrap();
    assert!(status.success());
    let mesh = avatar_core::mesh::io::read_obj(&out).unwrap();
    let model = avatar_core::body::open_body_ref();
    assert_eq!(mesh.positions.len(), model.num_vertices());
    assert_eq!(mesh.faces, model.faces);
    // Translation applied: the feet moved up by 1 m.
    let (lo, _) = mesh.bounds().unwrap();
    let (rest_lo, _) = avatar_core::mesh::bounds(&model.v_template).unwrap();
    assert!((lo.y - (rest_lo.y + 1.0)).abs() < 0.02, "{} vs {}", lo.y, rest_lo.y + 1.0);
    // The left arm (x > 0.5 m in the T-pose) is no longer there: max x shrinks.
    let max_x = mesh.positions.iter().map(|v| v.x).fold(f32::MIN, f32::max);
    assert!(max_x < 0.7, "left arm still horizontal: max x {max_x}");
}

#[test]
fn body_command_reports_bad_pose_file_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let pose = dir.path().join("broken_pose.json");
    std::fs::write(&pose, "{\"pose\": [0, 0").unwrap();
    let out = dir.path().join("x.obj");
    let result =
        studio().args(["body", "--pose"]).arg(&pose).arg("--out").arg(&out).output().unwrap();
    assert!(!result.status.success());
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("broken_pose.json") && stderr.contains("not a valid pose JSON"),
        "{stderr}"
    );
    assert!(!out.exists(), "no output on error");
}
