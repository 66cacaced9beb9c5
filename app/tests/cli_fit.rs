//! `avatar-studio fit` on the demo capture (a few steps), and its argument errors.

use std::path::Path;
use std::process::Command;

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

#[test]
fn fits_the_demo_and_writes_a_loadable_avatar() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo.avatar");
    let run = studio().arg("fit").arg(&demo).arg("--out").arg(&out).args(["--steps", "5", "--frames", "2"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.contains("static SDF avatar (4 x 128)") && stdout.contains("2 frames"), "{stdout}");
    let avatar = avatar_neural::StaticAvatar::load(&out).unwrap();
    assert_eq!(avatar.header.siren, avatar_neural::SirenConfig::compact());
}

#[test]
fn bad_arguments_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let o = studio().arg("fit").arg(&demo).arg("--out").arg(dir.path().join("a.avatar")).args(["--preset", "huge"]).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("huge"));
    let o = studio().arg("fit").arg(dir.path()).arg("--out").arg(dir.path().join("a.avatar")).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("capture.json"));
    let o = studio().arg("fit").arg(&demo).arg("--out").arg(dir.path().join("a.avatar")).args(["--device", "gpu"]).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("CPU backend only"));
}
