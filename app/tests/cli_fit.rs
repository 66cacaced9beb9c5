//! `avatar-studio fit` on the demo capture (a few steps), and its argument errors.

use avatar_core::canonical::FieldCache;
use std::path::Path;
use std::process::Command;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn studio() -> Command {
    Command::new(env!("CARGO_BIN_EXE_avatar-studio"))
}

#[test]
fn fits_the_demo_from_the_shipped_meta_model_and_writes_a_loadable_avatar() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo.avatar");
    let run = studio()
        .arg("fit")
        .arg(&demo)
        .arg("--out")
        .arg(&out)
        .args(["--steps", "3", "--frames", "2", "--timings"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(
        stdout.contains("pose-dependent avatar (meta-learned") && stdout.contains("2 frames"),
        "{stdout}"
    );
    // --timings: the phases that ran, training's three steps among them.
    for row in ["| canonicalization |", "| pre-aligning poses |", "| saving |", "| total |"] {
        assert!(stdout.contains(row), "{row} in {stdout}");
    }
    assert!(stdout.contains("| training |") && stdout.contains("3 steps"), "{stdout}");
    assert!(
        ["kernels: AVX-512", "kernels: AVX2", "kernels: portable"]
            .iter()
            .any(|k| stdout.contains(k)),
        "{stdout}"
    );
    let avatar = avatar_neural::MetaAvatar::load(&out, &field_cache()).unwrap();
    assert_eq!(avatar.header.config, avatar_neural::HyperConfig::compact());
    assert_eq!(
        (avatar.header.init.as_str(), avatar.header.frames, avatar.header.steps),
        ("meta-learned", 2, 3)
    );
    // Pose refinement is on by default: both frames' refined fittings are saved with the avatar.
    let poses = avatar.header.refined_poses.as_ref().expect("refined poses saved");
    assert_eq!(poses.len(), 2);
    assert!(
        poses.iter().all(|p| p.refined.validate().is_ok()
            && avatar_core::body::pose_error(&p.given, &p.refined).0 < 0.2),
        "{poses:?}"
    );
    assert!(stdout.contains("poses refined by"), "{stdout}");
    let out_off = dir.path().join("off.avatar");
    let run = studio()
        .arg("fit")
        .arg(&demo)
        .arg("--out")
        .arg(&out_off)
        .args(["--steps", "3", "--frames", "2", "--refine-poses", "off"])
        .args(["--kernels", "portable", "--timings"])
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    // --kernels: the plain loops, whatever the CPU has.
    assert!(String::from_utf8_lossy(&run.stdout).contains("kernels: portable"));
    assert!(
        avatar_neural::MetaAvatar::load(&out_off, &field_cache())
            .unwrap()
            .header
            .refined_poses
            .is_none()
    );
    // The studio opens it as a pose-dependent avatar.
    let studio_avatar = avatar_studio::studio::avatar::load_avatar(&out, 32).unwrap();
    assert!(
        studio_avatar.pose_dependent() && studio_avatar.describe().contains("meta-learned"),
        "{}",
        studio_avatar.describe()
    );

    // The static SDF from the static meta-SDF, and `pose` over the meta avatar.
    let out_static = dir.path().join("static.avatar");
    let run = studio()
        .arg("fit")
        .arg(&demo)
        .arg("--out")
        .arg(&out_static)
        .args(["--steps", "3", "--frames", "2", "--static"])
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let avatar = avatar_neural::StaticAvatar::load(&out_static, &field_cache()).unwrap();
    assert_eq!(avatar.header.siren, avatar_neural::SirenConfig::compact());
    let posed = dir.path().join("posed");
    let run = studio()
        .arg("pose")
        .arg(&out)
        .args(["--motion", "squat", "--frames", "2", "--resolution", "32"])
        .arg("--out")
        .arg(&posed)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for f in ["frame_0000.obj", "frame_0001.obj"] {
        let mesh = avatar_core::mesh::io::read_obj(posed.join(f)).unwrap();
        assert!(mesh.faces.len() > 100, "{f}: {} faces", mesh.faces.len());
    }
}

#[test]
fn bad_arguments_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let o = studio()
        .arg("fit")
        .arg(&demo)
        .arg("--out")
        .arg(dir.path().join("a.avatar"))
        .args(["--preset", "huge"])
        .output()
        .unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("huge"));
    let o = studio()
        .arg("fit")
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("a.avatar"))
        .output()
        .unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("capture.json"));
    if !cfg!(feature = "gpu") {
        let o = studio()
            .arg("fit")
            .arg(&demo)
            .arg("--out")
            .arg(dir.path().join("a.avatar"))
            .args(["--device", "gpu"])
            .output()
            .unwrap();
        assert!(
            !o.status.success() && String::from_utf8_lossy(&o.stderr).contains("no GPU support"),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let o = studio()
        .arg("fit")
        .arg(&demo)
        .arg("--out")
        .arg(dir.path().join("a.avatar"))
        .args(["--device", "tpu"])
        .output()
        .unwrap();
    assert!(
        !o.status.success()
            && String::from_utf8_lossy(&o.stderr).contains("expected cpu, gpu or cpu-burn")
    );
}

/// A capture fitted with the user's SMPL model (the stand-in the test writes, never a licensed
/// file): the studio opens it with that body; `fit --body-model` fits it; the avatar then poses
/// and exports with the model file gone.
#[test]
fn a_capture_fitted_with_an_smpl_model_fits_and_its_avatar_works_without_the_model_file() {
    use avatar_core::synth::{Outfit, SynthJob, generate_smpl_capture};
    let dir = tempfile::tempdir().unwrap();
    let cap = dir.path().join("capture");
    let mut job =
        SynthJob::new(3, Outfit::TshirtShorts, avatar_core::motion::clip_by_name("walk").unwrap());
    job.frames = Some(2);
    generate_smpl_capture(&cap, "my_smpl.npz", &job).unwrap();
    let loaded = avatar_studio::studio::capture_view::load_capture(&cap).unwrap();
    let usable = loaded.first_reads.iter().filter(|r| r.verdict.is_ok()).count();
    assert_eq!((loaded.body.num_betas, usable, loaded.betas.len()), (10, 2, 10));

    // The model moves away: capture.json's reference is missing, --body-model names the file.
    let model = dir.path().join("elsewhere.npz");
    std::fs::rename(cap.join("my_smpl.npz"), &model).unwrap();
    let out = dir.path().join("me.avatar");
    let fit = |extra: &[&std::ffi::OsStr]| {
        studio()
            .arg("fit")
            .arg(&cap)
            .arg("--out")
            .arg(&out)
            .args(["--steps", "3", "--frames", "2", "--static"])
            .args(extra)
            .output()
            .unwrap()
    };
    let o = fit(&[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("my_smpl.npz") && err.contains("capture.json"),
        "{err}"
    );
    let o = fit(&["--body-model".as_ref(), model.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_file(&model).unwrap();

    let avatar = avatar_neural::StaticAvatar::load(&out, &field_cache()).unwrap();
    assert_eq!(avatar.header.body_model, "smpl");
    let posed = dir.path().join("posed");
    let o = studio()
        .arg("pose")
        .arg(&out)
        .args(["--motion", "squat", "--frames", "2", "--resolution", "32"])
        .arg("--out")
        .arg(&posed)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        posed.join("frame_000001.obj").exists(),
        "{:?}",
        std::fs::read_dir(&posed).unwrap().map(|e| e.unwrap().file_name()).collect::<Vec<_>>()
    );
    let glb = dir.path().join("me.glb");
    let o = studio()
        .arg("export")
        .arg(&out)
        .args(["--motion", "walk", "--frames", "3", "--targets", "4"])
        .arg("--out")
        .arg(&glb)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::metadata(&glb).unwrap().len() > 10_000);
}
