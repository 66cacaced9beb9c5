//! `avatar-studio eval` end to end on a tiny configuration, and its argument errors.

use std::process::Command;

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

#[test]
fn writes_json_and_markdown() {
    let dir = tempfile::tempdir().unwrap();
    let (json, md) = (dir.path().join("r.json"), dir.path().join("t.md"));
    let out = studio()
        .args([
            "eval",
            "--preset",
            "paper",
            "--protocol",
            "interpolation",
            "--subjects",
            "1",
            "--outfits",
            "tshirt_shorts",
            "--chamfer-samples",
            "500",
            "--iou-resolution",
            "32",
            "--out",
        ])
        .arg(&json)
        .arg("--markdown")
        .arg(&md)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: avatar_core::eval::Report =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report.rows.len(), 2);
    assert_eq!(report.outfits, vec!["tshirt_shorts".to_string()]);
    let naked = &report.rows[0];
    // A tight t-shirt and shorts: the naked body is within a centimetre or so.
    assert!(naked.df_cm.mean > 0.3 && naked.df_cm.mean < 2.0, "{naked:?}");
    let table = std::fs::read_to_string(&md).unwrap();
    assert!(
        table.contains("**clean capture, interpolation**")
            && table.contains("| ground truth (sanity) | tshirt_shorts | 0 |"),
        "{table}"
    );
    assert!(table.contains("clothed spurious"), "{table}");
}

#[test]
fn bad_arguments_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = studio()
        .args(["eval", "--protocol", "sideways", "--out"])
        .arg(dir.path().join("r.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("sideways"));
    let out = studio()
        .args(["eval", "--subjects", "9", "--out"])
        .arg(dir.path().join("r.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--subjects"));
    let out = studio()
        // `--fit-error`, the alias of `--fitting-error`, reaches the same check.
        .args(["eval", "--subjects", "1", "--fit-error", "90,1", "--out"])
        .arg(dir.path().join("r.json"))
        .output()
        .unwrap();
    assert!(
        !out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--fitting-error"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (flag, value) in [
        ("--resolution", "100000"),
        ("--iou-resolution", "0"),
        ("--preset", "huge"),
        ("--captures", "dirty"),
        ("--noise", "kinect_v9"),
        ("--rows", "magic"),
        ("--outfits", "kilt"),
    ] {
        let out = studio()
            .args(["eval", "--subjects", "1", flag, value, "--out"])
            .arg(dir.path().join("r.json"))
            .output()
            .unwrap();
        assert!(!out.status.success(), "{flag} {value}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(value),
            "{flag}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let same = dir.path().join("r.json");
    let out = studio()
        .args(["eval", "--preset", "paper", "--out"])
        .arg(&same)
        .arg("--markdown")
        .arg(&same)
        .output()
        .unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("same file"));
    assert!(!dir.path().join("r.json").exists(), "no report from a refused run");
}
