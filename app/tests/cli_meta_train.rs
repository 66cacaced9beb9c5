//! `avatar-studio meta-train`'s data-parallel flags: refused before anything is read or
//! written when they cannot work (the runs themselves: neural/tests/meta_train_collective.rs).

use std::process::Command;

fn meta_train(dir: &std::path::Path, extra: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
        .args(["meta-train", "--subjects", "1", "--poses", "1", "--data"])
        .arg(dir.join("data"))
        .arg("--out")
        .arg(dir.join("out"))
        .args(extra)
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn collective_flags_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, err) = meta_train(dir.path(), &["--collective", "nccl"]);
    assert!(!ok && err.contains("none or mpi"), "{err}");
    let (ok, err) = meta_train(dir.path(), &["--hyper-meta-batch", "0"]);
    assert!(!ok && err.contains("--hyper-meta-batch must be at least 1"), "{err}");
    #[cfg(not(feature = "mpi"))]
    {
        let (ok, err) = meta_train(dir.path(), &["--collective", "mpi"]);
        assert!(!ok && err.contains("--features mpi"), "{err}");
    }
    assert!(!dir.path().join("data").exists() && !dir.path().join("out").exists());
}
