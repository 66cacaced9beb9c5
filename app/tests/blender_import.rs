//! Blender imports an exported GLB headless and plays it: `tests/blender/check_glb.py`
//! run by Debian's `blender` on a short walk of the synthetic avatar. The counts Blender finds
//! (bones, shape keys, keyframes) must equal what the file holds, read here with the `gltf`
//! crate, Blender's skinned, morphed mesh of each frame must match the studio's posed mesh
//! (`--format obj`) of that frame, and the material Blender makes (a Principled BSDF) must have
//! the base colour chosen for the export (`--color`, the studio's material colour).
//!
//! Without `blender` on PATH (or `BLENDER` naming the binary) the test prints a notice and passes,
//! except under CI (the `CI` variable set), where it fails: `scripts/test.sh` installs Blender.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

fn find_blender() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("BLENDER") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).map(|d| d.join("blender")).find(|p| p.is_file())
}

/// What the GLB holds: joints of its skin, morph targets that move POSITION (the ones Blender
/// turns into shape keys), samples of its animation.
fn glb_counts(path: &Path) -> (usize, usize, usize) {
    let doc = gltf::Gltf::from_slice(&std::fs::read(path).unwrap()).unwrap().document;
    let skins: Vec<_> = doc.skins().collect();
    assert_eq!(skins.len(), 1);
    let joints = skins[0].joints().count();
    let mesh = doc.meshes().next().unwrap();
    let prim = mesh.primitives().next().unwrap();
    let targets = prim.morph_targets().filter(|t| t.positions().is_some()).count();
    let anims: Vec<_> = doc.animations().collect();
    assert_eq!(anims.len(), 1);
    let samples: Vec<usize> = anims[0].samplers().map(|s| s.input().count()).collect();
    assert!(samples.windows(2).all(|w| w[0] == w[1]), "samplers of different lengths: {samples:?}");
    (joints, targets, samples[0])
}

fn run_check(
    blender: &Path,
    glb: &Path,
    expect: (usize, usize, usize),
    extra: &[&std::ffi::OsStr],
) -> Output {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/blender/check_glb.py");
    Command::new(blender)
        .args(["-b", "--factory-startup", "--python-exit-code", "2", "--python"])
        .arg(script)
        .arg("--")
        .arg(glb)
        .args(["--expect-joints", &expect.0.to_string()])
        .args(["--expect-shape-keys", &expect.1.to_string()])
        .args(["--expect-frames", &expect.2.to_string()])
        .args(extra)
        .output()
        .unwrap_or_else(|e| panic!("running {}: {e}", blender.display()))
}

fn summary(out: &Output) -> serde_json::Value {
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout.lines().find_map(|l| l.strip_prefix("BLENDER_CHECK ")).unwrap_or_else(|| {
        panic!(
            "no BLENDER_CHECK line; stdout:\n{stdout}\nstderr:\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    serde_json::from_str(line).unwrap()
}

#[test]
fn blender_imports_and_plays_the_exported_glb() {
    let Some(blender) = find_blender() else {
        if std::env::var_os("CI").is_some() {
            panic!(
                "blender is not on PATH, and CI must run the Blender import check: install it (scripts/test.sh does: apt-get install --no-install-recommends blender python3-numpy)"
            );
        }
        eprintln!(
            "notice: blender not on PATH (or BLENDER unset); skipping the Blender import check (apt-get install --no-install-recommends blender python3-numpy)"
        );
        return;
    };

    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("walk.glb");
    // A material colour of the artist's choice (the studio's View panel sets the same option).
    let color = [0.2f32, 0.5, 0.3];
    let out = studio()
        .args([
            "export",
            "--motion",
            "walk",
            "--frames",
            "12",
            "--targets",
            "16",
            "--color",
            "0.2,0.5,0.3",
            "--out",
        ])
        .arg(&glb)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let seq = dir.path().join("seq");
    let out = studio()
        .args(["export", "--motion", "walk", "--frames", "12", "--format", "obj", "--out"])
        .arg(&seq)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let (joints, targets, frames) = glb_counts(&glb);
    let doc = gltf::Gltf::from_slice(&std::fs::read(&glb).unwrap()).unwrap().document;
    let factor = doc
        .meshes()
        .next()
        .unwrap()
        .primitives()
        .next()
        .unwrap()
        .material()
        .pbr_metallic_roughness()
        .base_color_factor();
    assert_eq!(factor, [color[0], color[1], color[2], 1.0], "the chosen colour is in the file");
    assert_eq!((joints, frames), (24, 12));
    assert!(targets >= 2, "{targets} morph targets");

    let out = run_check(
        &blender,
        &glb,
        (joints, targets, frames),
        &["--compare-obj".as_ref(), seq.as_os_str()],
    );
    let s = summary(&out);
    assert!(
        out.status.success(),
        "Blender check failed ({}): {}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{s}");
    assert_eq!(s["ok"], true);
    assert_eq!(s["joints"], joints);
    assert_eq!(s["shape_keys"], targets);
    assert_eq!(s["frames"], frames);
    assert_eq!(s["played_frames"], frames);
    assert_eq!(s["root_bones"], serde_json::json!(["pelvis"]));
    assert_eq!(s["fps"], 30.0);
    // Every PCA target moves; the constant compensation target does not.
    assert_eq!(s["animated_shape_keys"], targets - 1);
    assert_eq!(s["import_warnings"], serde_json::json!([]), "Blender's glTF importer complained");
    assert_eq!(s["material"], "avatar", "the exported material reaches Blender");
    let base: Vec<f64> =
        s["base_color"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(base.len(), 3);
    assert!(
        base.iter().zip(color).all(|(b, e)| (b - e as f64).abs() < 1e-3),
        "Blender's base colour {base:?}, the chosen {color:?}"
    );
    // Blender's evaluated mesh is the studio's posed mesh (12 frames, 16 targets: exact PCA).
    assert_eq!(s["obj_frames_compared"], frames);
    assert!(s["obj_max_error_mm"].as_f64().unwrap() < 0.5, "{s}");
    assert!(s["max_vertex_motion_m"].as_f64().unwrap() > 0.01, "{s}");

    // The check fails, and says why, when a count is off.
    let out = run_check(&blender, &glb, (joints + 1, targets, frames), &[]);
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stdout));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("BLENDER_CHECK_FAILED: joints: Blender has 24 bones, expected 25"),
        "{stdout}"
    );
    assert_eq!(summary(&out)["ok"], false);
}
