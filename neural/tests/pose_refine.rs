//! Joint pose refinement (PINA 3.2) on a small synthetic case: a body's rest surface is the
//! exact SDF, its depth points are skinned with true poses, the fittings are off by 5 degrees
//! per joint and 2 cm; refinement against the exact SDF must recover the true poses.

use avatar_core::body::{BodyModel, BodyParams, open_body_lowpoly, pose_error};
use avatar_core::canonical::ShellOptions;
use avatar_core::canonical::{
    FieldOptions, Normalisation, RootOptions, SkinningField, canonicalize_points, forward_point,
};
use avatar_core::eval::conditions::FittingError;
use avatar_core::mesh::bvh::Bvh;
use avatar_neural::data::body_sdf::BodySdf;
use avatar_neural::data::capture_points::{CapturePoints, FramePoints, shell_samples_of};
use avatar_neural::model::encoder::PoseEncoding;
use avatar_neural::training::pose_refine::{PoseRefineOptions, PoseRefiner};
use avatar_neural::training::pose_trace::pose_errors;
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn true_pose(rng: &mut ChaCha8Rng, k: usize) -> BodyParams {
    let mut p = BodyParams { trans: Vec3::new(0.1 * k as f32, 0.9, 2.0), ..BodyParams::default() };
    p.pose[0] = Vec3::new(0.0, 0.7 * k as f32, 0.0);
    for j in 1..24 {
        p.pose[j] = Vec3::new(
            rng.random_range(-0.25..0.25),
            rng.random_range(-0.25..0.25),
            rng.random_range(-0.25..0.25),
        );
    }
    // Arms down from the T-pose, elbows bent.
    p.pose[16].z -= 1.0;
    p.pose[17].z += 1.0;
    p.pose[18].y -= 0.6;
    p.pose[19].y += 0.6;
    p
}

/// The synthetic capture: canonical points from the perturbed fittings, as `fit` would get them.
fn capture(body: BodyModel, frames: usize) -> (CapturePoints, Vec<BodyParams>) {
    capture_with_error(body, frames, FittingError { joint_deg: 5.0, trans_m: 0.02 })
}

fn capture_with_error(
    body: BodyModel,
    frames: usize,
    error: FittingError,
) -> (CapturePoints, Vec<BodyParams>) {
    let rest = body.shaped_vertices(&[]);
    let field = SkinningField::build(
        &body,
        &rest,
        &FieldOptions { cells_along_height: 48, ..FieldOptions::default() },
    )
    .unwrap();
    let norm = Normalisation::from_body(&rest);
    let mesh = body.mesh(rest.clone());
    let normals = mesh.vertex_normals();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (mut out, mut truth) = (Vec::new(), Vec::new());
    for k in 0..frames {
        let t = true_pose(&mut rng, k);
        let bones = body.pose(&t).bones;
        let posed: Vec<Vec3> =
            rest.iter().map(|&x| forward_point(&field, &bones.transforms, x)).collect();
        let posed_n: Vec<Vec3> = rest
            .iter()
            .zip(&normals)
            .map(|(&x, &n)| {
                avatar_core::body::skin_normal(&bones.transforms, &field.weights_at(x), n)
            })
            .collect();
        let mut given = t.clone();
        error.apply(&mut given, &mut rng);
        let g = body.pose(&given);
        let c = canonicalize_points(
            &field,
            &g.bones,
            &g.vertices,
            &body.weights,
            &posed,
            &posed_n,
            &RootOptions::default(),
            None,
        );
        out.push(FramePoints {
            index: k,
            params: given,
            points: c.points.iter().map(|p| norm.to_unit(*p)).collect(),
            normals: c.normals,
            ambiguous: c.ambiguous,
            free_space: Vec::new(),
            shells: Vec::new(),
        });
        truth.push(t);
    }
    let rest_sdf = std::sync::Arc::new(avatar_core::mesh::signed_distance::SignedDistance::new(
        &body.mesh(rest.clone()),
    ));
    let rest_sign = avatar_neural::data::capture_points::rest_sign_grid(&body.mesh(rest.clone()));
    let capture = CapturePoints {
        body,
        body_file: None,
        betas: Vec::new(),
        rest,
        rest_sdf,
        rest_sign,
        field,
        field_cells: 48,
        normalisation: norm,
        capture_frames: frames,
        frames: out,
        dropped: 0,
        warnings: Vec::new(),
    };
    (capture, truth)
}

fn mean_error(a: &[BodyParams], b: &[BodyParams]) -> (f32, f32) {
    let e: Vec<(f32, f32)> = a.iter().zip(b).map(|(x, y)| pose_error(x, y)).collect();
    let n = e.len() as f32;
    (
        e.iter().map(|v| v.0).sum::<f32>().to_degrees() / n,
        e.iter().map(|v| v.1).sum::<f32>() * 100.0 / n,
    )
}

#[test]
fn refinement_against_the_true_surface_recovers_perturbed_poses() {
    let (capture, truth) = capture(open_body_lowpoly(), 3);
    let rest = capture.rest.clone();
    let mesh = capture.body.mesh(rest);
    let face_normals = mesh.face_normals();
    let bvh = Bvh::build(&mesh);
    let sdf = |_: usize, points: &[Vec3]| -> (Vec<f32>, Vec<Vec3>) {
        points
            .iter()
            .map(|&p| {
                let h = bvh.closest_point(p).unwrap();
                let n = face_normals[h.face as usize];
                let sign = if (p - h.point).dot(n) >= 0.0 { 1.0 } else { -1.0 };
                let g = if h.distance > 1e-6 { (p - h.point) / h.distance * sign } else { n };
                (sign * h.distance, g)
            })
            .unzip()
    };
    // The SDF is the truth here, not learned from the frames: a correction every frame shares
    // is observable (no zero-mean constraint) and the data can outweigh a weak prior.
    let options = PoseRefineOptions {
        zero_mean: false,
        rotation_prior: 1e-6,
        iterations: 4,
        points_per_frame: 2000,
        ..PoseRefineOptions::default()
    };
    let mut refiner = PoseRefiner::new(&capture, options);
    let given: Vec<BodyParams> = capture.frames.iter().map(|f| f.params.clone()).collect();
    let (deg0, cm0) = mean_error(&given, &truth);
    let mut reports = Vec::new();
    for _ in 0..4 {
        reports.push(refiner.round(&sdf));
    }
    let (deg1, cm1) = mean_error(&refiner.refined(), &truth);
    // The points are the rest body's vertices posed: canonicalised anew for the refined poses
    // they lie on the rest surface again, as for the true poses (each round finds their roots
    // afresh; iterating from the given fittings' roots left some on the roots those chose).
    let mut samples = capture.pose_samples(PoseEncoding::Hierarchical);
    let off_surface = |samples: &[avatar_neural::data::pose_sample::PoseSample]| {
        let mut d: Vec<f32> = samples
            .iter()
            .flat_map(|s| s.points.iter())
            .map(|&q| bvh.closest_point(capture.normalisation.from_unit(q)).unwrap().distance)
            .collect();
        d.sort_by(f32::total_cmp);
        (d[d.len() * 99 / 100], d.len())
    };
    let (given_p99, given_points) = off_surface(&samples);
    refiner.update_samples(&mut samples, PoseEncoding::Hierarchical);
    let (refined_p99, refined_points) = off_surface(&samples);
    eprintln!(
        "99th percentile off the rest surface {:.2} -> {:.2} mm; points {given_points} -> {refined_points}",
        given_p99 * 1e3,
        refined_p99 * 1e3
    );
    assert!(given_p99 > 0.01, "the given fittings put points off the rest surface: {given_p99} m");
    assert!(refined_p99 < 0.001, "refined: 99 % within {refined_p99} m of the rest surface");
    assert!(refined_points * 100 >= given_points * 97, "points {given_points} -> {refined_points}");
    eprintln!(
        "joint error {deg0:.2} -> {deg1:.2} deg, translation {cm0:.2} -> {cm1:.2} cm; rounds {reports:?}"
    );
    assert!(deg0 > 3.5 && cm0 > 1.0, "the perturbation has its stated size: {deg0} deg, {cm0} cm");
    assert!(deg1 < 0.35 * deg0, "joint error {deg0:.2} -> {deg1:.2} deg");
    assert!(cm1 < 0.15 * cm0, "translation error {cm0:.2} -> {cm1:.2} cm");
    assert!(reports.last().unwrap().residual_after < 0.5 * reports[0].residual_before);
}

#[test]
fn prealignment_against_the_body_recovers_perturbed_poses() {
    let (capture, truth) = capture(open_body_lowpoly(), 4);
    let body = BodySdf::new(&capture);
    // The body's own SDF: positive 2 mm out along the vertex normals, negative 2 mm in, never
    // further than that (curvature brings the surface closer; the low-poly body's thin, folded
    // parts, fingers and toes, may flip a few signs).
    let rest = &capture.rest;
    let normals = capture.body.mesh(rest.clone()).vertex_normals();
    let probe: Vec<Vec3> = (0..rest.len())
        .step_by(37)
        .flat_map(|i| [rest[i] + normals[i] * 0.002, rest[i] - normals[i] * 0.002])
        .collect();
    let (d, _) = body.eval(&probe);
    assert!(d.iter().all(|v| v.abs() < 0.0021), "{d:?}");
    let right = d.chunks(2).filter(|p| p[0] > 0.0 && p[1] < 0.0).count();
    assert!(right * 100 >= 90 * d.len() / 2, "{right} of {} signs right", d.len() / 2);
    // A uniform clothing offset is taken off: points 5 mm out read as on the surface.
    let (d, _) = body.beyond_clothing(
        &rest.iter().zip(&normals).map(|(x, n)| *x + *n * 0.005).collect::<Vec<_>>(),
        0.03,
    );
    let on = d.iter().filter(|v| v.abs() < 0.002).count();
    assert!(on * 10 >= 9 * d.len(), "{on} of {} at the clothing's offset", d.len());
    let mut refiner = PoseRefiner::new(&capture, PoseRefineOptions::default());
    // The gate: the naked body explains nearly all points even with 5 degree errors.
    let share = refiner.near_share(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    assert!(share > 0.8, "share of points near the body {share}");
    let given: Vec<BodyParams> = capture.frames.iter().map(|f| f.params.clone()).collect();
    let before = pose_errors(&given, &truth, &capture.rest_joints());
    let report = refiner.prealign(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    let after = pose_errors(&refiner.refined(), &truth, &capture.rest_joints());
    eprintln!("before: {before}\nafter: {after}\n{report:?}");
    assert!(
        before.joint_deg > 3.5 && before.posed_joints_cm > 3.0,
        "the perturbation has its stated size: {before}"
    );
    // The extremities (head, hands, feet) are left to the prior, the rest is recovered.
    assert!(after.posed_joints_cm < 0.25 * before.posed_joints_cm, "{before} -> {after}");
    assert!(after.swing_deg < 0.7 * before.swing_deg, "{before} -> {after}");
    assert!(report.residual_after < 0.5 * report.residual_before, "{report:?}");
    // The translation's shared part along the body's axis stays the given fittings' (clothing,
    // shoes and hair bias it against the naked body); across the body it is recovered.
    let refined = refiner.refined();
    let shared_up = refined
        .iter()
        .zip(&given)
        .map(|(r, g)| (Quat::from_scaled_axis(r.pose[0]) * Vec3::Y).dot(r.trans - g.trans))
        .sum::<f32>()
        / given.len() as f32;
    assert!(shared_up.abs() < 1e-4, "shared correction along the body's axis {shared_up}");
    assert!(after.trans_cm < 0.5 * before.trans_cm, "{before} -> {after}");
}

#[test]
fn prealignment_leaves_exact_fittings_where_they_are() {
    // Exact fittings: no round can fit the body better, so the poses come back unchanged
    // (before the acceptance test the rounds drifted them, the residual growing).
    let (capture, truth) =
        capture_with_error(open_body_lowpoly(), 4, FittingError { joint_deg: 0.0, trans_m: 0.0 });
    let body = BodySdf::new(&capture);
    let mut refiner = PoseRefiner::new(&capture, PoseRefineOptions::default());
    refiner.prealign(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    let after = pose_errors(&refiner.refined(), &truth, &capture.rest_joints());
    // Without the test the rounds here move the poses by 0.01 degrees / 0.01 cm; with it the
    // first round is undone.
    assert!(
        after.posed_joints_cm < 1e-3 && after.joint_deg < 1e-3,
        "exact fittings moved: {after}"
    );
}

#[test]
fn shells_redrawn_after_prealignment_drop_those_the_pose_errors_made() {
    // A naked body: no point is loose clothing, so every shell sample stands behind a point
    // that a fitting error put off the body, and carves into the body.
    let (mut capture, _) = capture(open_body_lowpoly(), 4);
    let options = ShellOptions { per_frame: 500, ..ShellOptions::default() };
    let norm = capture.normalisation;
    let points: Vec<Vec<Vec3>> = capture
        .frames
        .iter()
        .map(|f| f.points.iter().map(|p| norm.from_unit(*p)).collect())
        .collect();
    let normals: Vec<&[Vec3]> = capture.frames.iter().map(|f| f.normals.as_slice()).collect();
    let shells = shell_samples_of(&capture.rest_sdf, &points, &normals, &options);
    for (frame, s) in capture.frames.iter_mut().zip(shells) {
        frame.shells = s.iter().map(|p| norm.to_unit(*p)).collect();
    }
    let before: usize = capture.frames.iter().map(|f| f.shells.len()).sum();
    let body = BodySdf::new(&capture);
    let mut refiner = PoseRefiner::new(&capture, PoseRefineOptions::default());
    refiner.prealign(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    let mut samples = capture.pose_samples(PoseEncoding::Hierarchical);
    refiner.update_samples(&mut samples, PoseEncoding::Hierarchical);
    // Before the redraw the refiner carries the given fittings' shells along.
    assert_eq!(samples.iter().map(|s| s.free_space.len()).sum::<usize>(), before);
    refiner.redraw_shells(&options);
    refiner.update_samples(&mut samples, PoseEncoding::Hierarchical);
    let after: usize = samples.iter().map(|s| s.free_space.len()).sum();
    eprintln!(
        "shell samples behind a naked body: {before} from the given fittings, {after} after pre-alignment"
    );
    assert!(
        before >= 200,
        "the 5 degree / 2 cm errors put points off the body: {before} shell samples"
    );
    assert!(after * 4 <= before, "{before} -> {after}");
}

#[test]
fn upper_body_prealignment_corrects_the_arms_and_leaves_the_legs_to_the_fittings() {
    // Where a skirt hides the legs (a dress), only the spine's, the arms' and the head's
    // points are pre-aligned: the knees keep the given fittings exactly, the arms come closer
    // to the truth.
    let (capture, truth) = capture(open_body_lowpoly(), 4);
    let body = BodySdf::new(&capture);
    let mut refiner = PoseRefiner::new(&capture, PoseRefineOptions::default());
    let given: Vec<BodyParams> = capture.frames.iter().map(|f| f.params.clone()).collect();
    let before = pose_errors(&given, &truth, &capture.rest_joints());
    refiner.prealign_upper_body(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    let refined = refiner.refined();
    let after = pose_errors(&refined, &truth, &capture.rest_joints());
    eprintln!(
        "before: {before}\n  {}\nafter: {after}\n  {}",
        before.per_joint(),
        after.per_joint()
    );
    for (r, g) in refined.iter().zip(&given) {
        for knee in [4, 5] {
            assert!(
                (r.pose[knee] - g.pose[knee]).length() < 1e-6,
                "knee {knee} moved: {} -> {}",
                g.pose[knee],
                r.pose[knee]
            );
        }
    }
    // Shoulders and elbows (16-19): their mean error a fifth smaller or more (4.7 -> 3.3
    // degrees here), the posed joints (the legs' too, carried by the root) much closer.
    let arms = |e: &avatar_neural::training::pose_trace::PoseErrors| {
        (16..20).map(|j| e.per_joint_deg[j]).sum::<f32>() / 4.0
    };
    assert!(after.posed_joints_cm < 0.6 * before.posed_joints_cm, "{before} -> {after}");
    assert!(
        arms(&after) < 0.8 * arms(&before),
        "arms {:.2} -> {:.2} deg",
        arms(&before),
        arms(&after)
    );
    // Then the pre-alignment of the whole body again, as before.
    let mut whole = PoseRefiner::new(&capture, PoseRefineOptions::default());
    whole.prealign(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    assert!(
        whole.refined().iter().zip(&given).any(|(r, g)| (r.pose[4] - g.pose[4]).length() > 1e-3),
        "the whole body's pre-alignment moves the knees"
    );
}

#[test]
fn the_trunk_stage_moves_the_trunk_and_the_translation_alone() {
    // Pre-alignment's first stage: the trunk's points correct the pelvis, the spine and the
    // translation; every other joint keeps the given fitting exactly.
    let (capture, truth) = capture(open_body_lowpoly(), 4);
    let body = BodySdf::new(&capture);
    let mut refiner = PoseRefiner::new(&capture, PoseRefineOptions::default());
    let given: Vec<BodyParams> = capture.frames.iter().map(|f| f.params.clone()).collect();
    let before = pose_errors(&given, &truth, &capture.rest_joints());
    let report = refiner.prealign_trunk(&|_, p: &[Vec3]| body.beyond_clothing(p, 0.03));
    let refined = refiner.refined();
    let after = pose_errors(&refined, &truth, &capture.rest_joints());
    eprintln!(
        "before: {before}\n  {}\nafter: {after}\n  {}\n{report:?}",
        before.per_joint(),
        after.per_joint()
    );
    const TRUNK: [usize; 4] = [0, 3, 6, 9];
    for (r, g) in refined.iter().zip(&given) {
        for j in (0..24).filter(|j| !TRUNK.contains(j)) {
            assert!(
                (r.pose[j] - g.pose[j]).length() < 1e-6,
                "joint {j} moved: {} -> {}",
                g.pose[j],
                r.pose[j]
            );
        }
    }
    let trunk = |e: &avatar_neural::training::pose_trace::PoseErrors| {
        TRUNK.iter().map(|&j| e.per_joint_deg[j]).sum::<f32>() / 4.0
    };
    assert!(
        trunk(&after) < 0.7 * trunk(&before),
        "trunk {:.2} -> {:.2} deg",
        trunk(&before),
        trunk(&after)
    );
    assert!(after.trans_cm < 0.5 * before.trans_cm, "{before} -> {after}");
    assert!(report.residual_after < report.residual_before, "{report:?}");
}

#[test]
fn pre_alignment_from_two_starts_keeps_each_frames_better_fit() {
    // The whole body from the given fittings, and the trunk first: each frame keeps the start
    // that fits the body better, so the poses are no further from the truth than the whole
    // body's alone, and exact fittings stay exact (`prealignment_leaves_exact_fittings...`).
    let (capture, truth) = capture(open_body_lowpoly(), 4);
    let body = BodySdf::new(&capture);
    let sdf = |_: usize, p: &[Vec3]| body.beyond_clothing(p, 0.03);
    let mut alone = PoseRefiner::new(
        &capture,
        PoseRefineOptions { prealign_trunk_first: false, ..PoseRefineOptions::default() },
    );
    let alone_report = alone.prealign(&sdf);
    let mut both = PoseRefiner::new(&capture, PoseRefineOptions::default());
    assert!(both.options.prealign_trunk_first);
    let both_report = both.prealign(&sdf);
    let (a, b) = (
        pose_errors(&alone.refined(), &truth, &capture.rest_joints()),
        pose_errors(&both.refined(), &truth, &capture.rest_joints()),
    );
    eprintln!("whole body alone: {a}\n{alone_report:?}\ntwo starts: {b}\n{both_report:?}");
    assert!(b.posed_joints_cm <= 1.05 * a.posed_joints_cm, "{a} -> {b}");
    assert!(
        both_report.residual_after <= alone_report.residual_after * 1.02,
        "{alone_report:?} -> {both_report:?}"
    );
}

#[test]
fn fits_prealign_then_refine_twice_and_not_at_all_when_off() {
    let o = PoseRefineOptions::default();
    assert!(o.prealign_rounds > 0);
    let rounds = o.round_steps(256);
    assert_eq!(rounds.first(), Some(&o.first));
    assert!(
        rounds.iter().all(|&s| s < o.until) && rounds.windows(2).all(|w| w[1] - w[0] == o.every)
    );
    assert_eq!(rounds, [16, 48]);
    // Loose clothing that is still pre-aligned (a blazer's tails): the first round alone.
    assert_eq!(o.single_round().round_steps(256), [16]);
    // Loose clothing (no pre-alignment), every frame in every step: rounds after step 1 and
    // every 3 steps to 64.
    let loose = o.without_prealignment(8, 8).round_steps(256);
    assert_eq!((loose.first(), loose.last(), loose.len()), (Some(&1), Some(&61), 21));
    assert_eq!(o.without_prealignment(5, 8), o.without_prealignment(8, 8));
    // A quarter of the frames a step (the fit's 32) or fewer: after step 16, every 6 to 128.
    let late = o.without_prealignment(32, 8).round_steps(256);
    assert_eq!((late.first(), late.last(), late.len()), (Some(&16), Some(&124), 19));
    assert_eq!(o.without_prealignment(200, 8), o.without_prealignment(32, 8));
    // In between, in between.
    let middle = o.without_prealignment(16, 8);
    assert!(middle.first > 1 && middle.first < 16 && middle.until > 64 && middle.until < 128);
    // A short fit (the studio's quick fit, a 3-step test fit) is only pre-aligned.
    assert!(o.round_steps(3).is_empty());
    assert!(PoseRefineOptions::off().round_steps(256).is_empty());
}

#[test]
fn the_snap_diagnostic_sets_the_named_joints_and_the_translation_to_the_truth() {
    let (capture, truth) = capture(open_body_lowpoly(), 3);
    let mut refiner = PoseRefiner::new(&capture, PoseRefineOptions::default());
    let given: Vec<BodyParams> = capture.frames.iter().map(|f| f.params.clone()).collect();
    // Without a known truth nothing moves.
    refiner.snap_to_truth(&[1, 2], true);
    let moved = |r: &BodyParams, g: &BodyParams| {
        r.pose
            .iter()
            .zip(&g.pose)
            .map(|(a, b)| (*a - *b).length())
            .fold((r.trans - g.trans).length(), f32::max)
    };
    assert!(refiner.refined().iter().zip(&given).all(|(r, g)| moved(r, g) < 1e-6));
    refiner.truth = Some(truth.clone());
    refiner.snap_to_truth(&[1, 16], true);
    for ((r, t), g) in refiner.refined().iter().zip(&truth).zip(&given) {
        for j in [1, 16] {
            assert!(
                (r.pose[j] - t.pose[j]).length() < 1e-5,
                "joint {j}: {} against {}",
                r.pose[j],
                t.pose[j]
            );
        }
        assert!((r.trans - t.trans).length() < 1e-5);
        assert!((r.pose[2] - g.pose[2]).length() < 1e-6, "a joint not named keeps its fitting");
    }
}
