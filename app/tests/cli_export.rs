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

/// Inputs beyond what is supported are refused before any work, naming the file and the
/// limit: a take over the supported length, a frame rate out of range, a capture too large to
/// hold in memory.
#[test]
fn limits_are_said_up_front_naming_the_file() {
    use avatar_core::motion::bvh_write::{long_take, to_bvh_string};
    let dir = tempfile::tempdir().unwrap();
    let fails = |args: &[&std::ffi::OsStr]| {
        let o = studio().args(args).output().unwrap();
        assert!(!o.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    let glb = dir.path().join("x.glb");
    let take = to_bvh_string(&long_take("take", 4, 120.0).unwrap());
    assert!(take.contains("Frames: 4"), "{take}");
    let huge = dir.path().join("huge.bvh");
    std::fs::write(&huge, take.replace("Frames: 4", "Frames: 100001")).unwrap();
    let e = fails(&[
        "export".as_ref(),
        "--motion".as_ref(),
        huge.as_os_str(),
        "--out".as_ref(),
        glb.as_os_str(),
    ]);
    assert!(e.contains("huge.bvh") && e.contains("100000"), "{e}");
    let ok = dir.path().join("take.bvh");
    std::fs::write(&ok, &take).unwrap();
    let e = fails(&[
        "export".as_ref(),
        "--motion".as_ref(),
        ok.as_os_str(),
        "--fps".as_ref(),
        "500".as_ref(),
        "--out".as_ref(),
        glb.as_os_str(),
    ]);
    assert!(e.contains("take.bvh") && e.contains("500") && e.contains("240"), "{e}");
    assert!(!glb.exists(), "nothing written");

    // 10 frames of 4096 x 4096 could hold 4.4 GiB of points: refused before a depth image is
    // read (there is none here).
    let capture = dir.path().join("big");
    std::fs::create_dir_all(&capture).unwrap();
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo/capture.json");
    let mut m: serde_json::Value = serde_json::from_slice(&std::fs::read(demo).unwrap()).unwrap();
    m["intrinsics"] = serde_json::json!({
        "fx": 3000.0, "fy": 3000.0, "cx": 2048.0, "cy": 2048.0, "width": 4096, "height": 4096
    });
    let first = m["frames"][0].clone();
    m["frames"] = (0..10).map(|_| first.clone()).collect();
    std::fs::write(capture.join("capture.json"), serde_json::to_vec(&m).unwrap()).unwrap();
    let ply = dir.path().join("c.ply");
    let e =
        fails(&["canonicalize".as_ref(), capture.as_os_str(), "--out".as_ref(), ply.as_os_str()]);
    assert!(
        e.contains("capture.json") && e.contains("too large to open whole") && e.contains("4 GiB"),
        "{e}"
    );
}
