//! Pose refinement on a capture with exact fittings (PINA 3.2): a copy of the capture gets its
//! fittings perturbed (seeded; by default 5 degrees per joint and 2 cm RMS, the evaluation's
//! `FittingError`), the avatar is fitted on the copy with refinement, and the given and the refined
//! poses are compared with the exact ones (mean joint angle, translation).
//!
//!   cargo run --release --example pose_refine_check -- assets/demo [FRAMES] [STEPS] [DEG] [CM]

use avatar_core::body::pose_error;
use avatar_core::canonical::FieldCache;
use avatar_core::capture::CaptureManifest;
use avatar_core::eval::conditions::{CaptureConditions, FittingError};
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::{HyperFitOptions, Init, MetaAvatar, MetaModel};
use std::path::{Path, PathBuf};

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn copy_dir(from: &Path, to: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let target = to.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            copy_dir(&entry.path(), &target)?;
        } else {
            std::fs::copy(entry.path(), target)?;
        }
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let src = PathBuf::from(args.get(1).map_or("assets/demo", String::as_str));
    let arg = |i: usize, default: f32| args.get(i).map_or(Ok(default), |s| s.parse::<f32>());
    let (frames, steps) = (arg(2, 8.0)? as usize, arg(3, 256.0)? as usize);
    let error = FittingError { joint_deg: arg(4, 5.0)?, trans_m: arg(5, 2.0)? / 100.0 };
    let tmp = tempfile::tempdir()?;
    let dir = tmp.path().join("capture");
    copy_dir(&src, &dir)?;
    CaptureConditions { fitting_error: error, ..CaptureConditions::clean() }
        .perturb_fittings(&dir, 1)?;
    let (exact, perturbed) = (CaptureManifest::load(&src)?, CaptureManifest::load(&dir)?);
    let capture = CapturePoints::open(&dir, frames, &field_cache())?;
    // Each fitted frame's exact fitting: the manifest record its perturbed fitting came from.
    let mut truth = Vec::new();
    for f in &capture.frames {
        let i = (0..perturbed.frames.len())
            .find(|&i| {
                perturbed.frames[i]
                    .params()
                    .is_ok_and(|p| p.pose == f.params.pose && p.trans == f.params.trans)
            })
            .expect("every fitted frame is in the manifest");
        truth.push(exact.frames[i].params()?);
    }
    let model = MetaModel::shipped();
    let mut options = HyperFitOptions { steps, ..HyperFitOptions::default() };
    // Experiments: REFINE_ROTATION_PRIOR, REFINE_TRANSLATION_PRIOR, REFINE_EVERY, REFINE_ITERATIONS.
    let env = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<f32>().ok());
    let r = &mut options.refine_poses;
    r.rotation_prior = env("REFINE_ROTATION_PRIOR").unwrap_or(r.rotation_prior);
    r.translation_prior = env("REFINE_TRANSLATION_PRIOR").unwrap_or(r.translation_prior);
    r.every = env("REFINE_EVERY").map_or(r.every, |v| v as usize);
    r.iterations = env("REFINE_ITERATIONS").map_or(r.iterations, |v| v as usize);
    r.zero_mean = std::env::var("REFINE_FREE_MEAN").is_err();
    r.until = env("REFINE_UNTIL").map_or(r.until, |v| v as usize);
    r.huber = env("REFINE_HUBER").unwrap_or(r.huber);
    r.points_per_frame = env("REFINE_POINTS").map_or(r.points_per_frame, |v| v as usize);
    println!("refinement: {:?}", options.refine_poses);
    if std::env::var("ORACLE").is_ok() {
        // The SDF of an avatar fitted on the exact fittings, frozen: how far refinement gets
        // when the surface is right.
        let exact_points = CapturePoints::open(&src, frames, &field_cache())?;
        let off = HyperFitOptions {
            steps,
            refine_poses: avatar_neural::training::pose_refine::PoseRefineOptions::off(),
            ..HyperFitOptions::default()
        };
        let (oracle, _) = MetaAvatar::fit_points(
            &exact_points,
            &Init::MetaLearned(&model),
            &off,
            None,
            &mut |_, _, _| {},
        );
        let mut refiner =
            avatar_neural::training::pose_refine::PoseRefiner::new(&capture, options.refine_poses);
        let mut samples = capture.pose_samples(oracle.header.config.encoding);
        for _ in 0..6 {
            let r = avatar_neural::training::pose_refine::refine_round(
                &mut refiner,
                &oracle.model,
                &mut samples,
                oracle.header.config.encoding,
            );
            println!("oracle round {r:?}");
        }
        let refined = refiner.refined();
        let n = refined.len() as f32;
        let (b, a) = (0..refined.len()).fold((0.0, 0.0), |(b, a), i| {
            (
                b + pose_error(&capture.frames[i].params, &truth[i]).0,
                a + pose_error(&refined[i], &truth[i]).0,
            )
        });
        println!(
            "oracle SDF: joint-angle error {:.2} -> {:.2} deg",
            b.to_degrees() / n,
            a.to_degrees() / n
        );
        return Ok(());
    }
    let t = std::time::Instant::now();
    let (avatar, _) = MetaAvatar::fit_points(
        &capture,
        &Init::MetaLearned(&model),
        &options,
        None,
        &mut |_, _, _| {},
    );
    let seconds = t.elapsed().as_secs_f64();
    let poses = avatar.header.refined_poses.as_ref().expect("refinement is on by default");
    let mean = |pick: &dyn Fn(usize) -> (f32, f32)| {
        let n = poses.len() as f32;
        let (a, t) = (0..poses.len()).map(pick).fold((0.0, 0.0), |(a, t), (x, y)| (a + x, t + y));
        (a.to_degrees() / n, t * 100.0 / n)
    };
    let before = mean(&|i| pose_error(&poses[i].given, &truth[i]));
    let after = mean(&|i| pose_error(&poses[i].refined, &truth[i]));
    println!(
        "{}: {} frames, {steps} steps, fittings off by {} deg / {} cm RMS",
        src.display(),
        poses.len(),
        error.joint_deg,
        error.trans_m * 100.0
    );
    println!(
        "mean joint-angle error {:.2} -> {:.2} deg, translation error {:.2} -> {:.2} cm ({seconds:.0} s fit)",
        before.0, after.0, before.1, after.1
    );
    let mut per_joint = [(0f32, 0f32); 24];
    for (i, p) in poses.iter().enumerate() {
        for j in 0..24 {
            per_joint[j].0 += avatar_core::body::pose_jacobian::rotation_angle_between(
                p.given.pose[j],
                truth[i].pose[j],
            )
            .to_degrees()
                / poses.len() as f32;
            per_joint[j].1 += avatar_core::body::pose_jacobian::rotation_angle_between(
                p.refined.pose[j],
                truth[i].pose[j],
            )
            .to_degrees()
                / poses.len() as f32;
        }
    }
    // Posed joint positions (the body's skeleton at each fitting): what the depth sees.
    let joints = capture.rest_joints();
    let posed = |p: &avatar_core::body::BodyParams| {
        avatar_core::body::forward_kinematics(&joints, &p.rotations(), p.trans).posed_joints()
    };
    let (mut jb, mut ja) = (0f32, 0f32);
    for (i, p) in poses.iter().enumerate() {
        let t = posed(&truth[i]);
        let n = (poses.len() * 24) as f32;
        jb += posed(&p.given).iter().zip(&t).map(|(a, b)| (*a - *b).length()).sum::<f32>() * 100.0
            / n;
        ja += posed(&p.refined).iter().zip(&t).map(|(a, b)| (*a - *b).length()).sum::<f32>()
            * 100.0
            / n;
    }
    println!("mean posed joint position error {jb:.2} -> {ja:.2} cm");
    let names = avatar_core::body::JOINT_NAMES;
    println!(
        "  per joint (deg): {}",
        (0..24)
            .map(|j| format!("{} {:.1}->{:.1}", names[j], per_joint[j].0, per_joint[j].1))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for (i, p) in poses.iter().enumerate() {
        let (b, a) = (pose_error(&p.given, &truth[i]), pose_error(&p.refined, &truth[i]));
        println!(
            "  frame {i}: {:.2} -> {:.2} deg, {:.2} -> {:.2} cm",
            b.0.to_degrees(),
            a.0.to_degrees(),
            b.1 * 100.0,
            a.1 * 100.0
        );
    }
    Ok(())
}
