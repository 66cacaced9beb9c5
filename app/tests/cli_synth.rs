//! `avatar-studio synth` end to end, and the committed demo assets: the demo capture and the
//! motion clips regenerate byte for byte from their documented commands.

use std::path::{Path, PathBuf};
use std::process::Command;

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// The command in docs/synthetic-data.md that makes assets/demo.
pub const DEMO_ARGS: [&str; 10] = [
    "--seed",
    "2024",
    "--outfits",
    "longsleeve_trousers",
    "--clips",
    "walk",
    "--frames-per-clip",
    "32",
    "--no-ground-truth",
    "--turn=45",
];

pub const MOTION_FILES: [&str; 5] = ["walk", "raise_arms", "squat", "kick", "jumping_jacks"];

fn listing(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().display().to_string(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn demo_capture_regenerates_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let out = studio().arg("synth").arg("--out").arg(tmp.path()).args(DEMO_ARGS).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let demo = repo().join("assets/demo");
    if std::env::var_os("UPDATE_ASSETS").is_some() {
        let _ = std::fs::remove_dir_all(&demo);
        let status =
            studio().arg("synth").arg("--out").arg(&demo).args(DEMO_ARGS).status().unwrap();
        assert!(status.success());
    }
    let (a, b) = (listing(tmp.path()), listing(&demo));
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for (x, y) in a.iter().zip(&b) {
        assert!(
            x.1 == y.1,
            "assets/demo/{} differs from a fresh run of the documented command",
            x.0
        );
    }
    // And the demo opens as a capture with every frame usable.
    let cap = avatar_core::capture::Capture::open(&demo).unwrap();
    assert_eq!(cap.frames.len(), 32);
    assert!(cap.warnings.is_empty());
}

#[test]
fn motion_assets_match_the_library() {
    for name in MOTION_FILES {
        let path = repo().join(format!("assets/motions/{name}.json"));
        let clip = avatar_core::motion::clip_by_name(name).unwrap();
        if std::env::var_os("UPDATE_ASSETS").is_some() {
            clip.save_json(&path).unwrap();
        }
        let loaded = avatar_core::motion::MotionClip::load(&path).unwrap();
        assert_eq!(loaded.frames.len(), clip.frames.len(), "{name}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), clip.to_json_string(), "{name}");
    }
}

#[test]
fn several_combinations_go_to_named_folders_and_bad_names_are_listed() {
    let tmp = tempfile::tempdir().unwrap();
    let out = studio()
        .arg("synth")
        .arg("--out")
        .arg(tmp.path())
        .args([
            "--subjects",
            "2",
            "--outfits",
            "dress,tshirt_shorts",
            "--clips",
            "squat",
            "--frames-per-clip",
            "2",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for s in
        ["s00_dress_squat", "s01_dress_squat", "s00_tshirt_shorts_squat", "s01_tshirt_shorts_squat"]
    {
        assert!(tmp.path().join(s).join("capture.json").exists(), "{s}");
        assert!(tmp.path().join(s).join("gt/frames.npz").exists(), "{s}");
    }
    let out = studio()
        .arg("synth")
        .arg("--out")
        .arg(tmp.path().join("x"))
        .args(["--outfits", "kimono"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("kimono") && err.contains("polo_loose"), "{err}");
    let out = studio()
        .arg("synth")
        .arg("--out")
        .arg(tmp.path().join("y"))
        .args(["--clips", "moonwalk"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("moonwalk") && err.contains("squat"), "{err}");
}
