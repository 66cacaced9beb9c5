//! `avatar-studio export` end to end: a GLB the Khronos validator accepts, an OBJ sequence,
//! clear errors for bad arguments.

use std::path::Path;
use std::process::Command;

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

#[test]
fn exports_a_valid_glb_and_an_obj_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("anim.glb");
    let out = studio()
        .args(["export", "--motion", "kick", "--frames", "15", "--targets", "16", "--out"])
        .arg(&glb)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("15 frames") && stdout.contains("morph targets"), "{stdout}");
    let bytes = std::fs::read(&glb).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
    let validator = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/gltf-validator");
    assert!(
        validator.join("node_modules/gltf-validator").exists(),
        "run `npm ci --prefix tests/gltf-validator` (scripts/test.sh does)"
    );
    let v = Command::new("node").arg(validator.join("validate.mjs")).arg(&glb).output().unwrap();
    let report: serde_json::Value = serde_json::from_slice(&v.stdout).unwrap();
    assert_eq!(report["issues"]["numErrors"], 0, "{}", report["issues"]["messages"]);
    assert_eq!(report["issues"]["numWarnings"], 0, "{}", report["issues"]["messages"]);

    let seq = dir.path().join("seq");
    let out = studio()
        .args(["export", "--motion", "walk", "--frames", "3", "--format", "obj", "--out"])
        .arg(&seq)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mesh = avatar_core::mesh::io::read_obj(seq.join("frame_000002.obj")).unwrap();
    assert!(mesh.positions.len() > 10_000);
}

#[test]
fn bad_arguments_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let o = studio()
            .arg("export")
            .args(args)
            .arg("--out")
            .arg(dir.path().join("x.glb"))
            .output()
            .unwrap();
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    let e = run(&["--motion", "moonwalk"]);
    assert!(e.contains("moonwalk") && e.contains("squat"), "{e}");
    let e = run(&["me.avatar", "--motion", "walk"]);
    assert!(e.contains("me.avatar"), "{e}");
    let e = run(&["--motion", "walk", "--format", "fbx"]);
    assert!(e.contains("fbx"), "{e}");
    let e = run(&["--motion", "walk", "--color", "0.2,1.5,0.3"]);
    assert!(e.contains("--color") && e.contains("between 0 and 1"), "{e}");
    let e = run(&["--motion", "walk", "--color", "0.2,0.5"]);
    assert!(e.contains("three numbers"), "{e}");
    assert!(!dir.path().join("x.glb").exists(), "nothing written");
}
