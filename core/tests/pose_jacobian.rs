//! Pose corrections (PINA's joint pose refinement): the derivative of a skinned point with
//! respect to a frame's correction against finite differences of the forward kinematics.

use avatar_core::body::kinematics::forward_kinematics;
use avatar_core::body::skeleton::parent;
use avatar_core::body::{
    BodyParams, NUM_JOINTS, POSE_DOF, PoseCorrection, Weights, pose_error, skin_point,
    skinned_point_jacobian,
};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_setup(rng: &mut ChaCha8Rng) -> ([Vec3; NUM_JOINTS], BodyParams, Weights) {
    let mut joints = [Vec3::ZERO; NUM_JOINTS];
    for j in 1..NUM_JOINTS {
        let off = Vec3::new(
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.1..0.1),
        );
        joints[j] = joints[parent(j).unwrap()] + off;
    }
    let mut given = BodyParams { trans: Vec3::new(0.3, 1.0, -2.0), ..BodyParams::default() };
    for r in given.pose.iter_mut() {
        *r = Vec3::new(
            rng.random_range(-0.6..0.6),
            rng.random_range(-0.6..0.6),
            rng.random_range(-0.6..0.6),
        );
    }
    let mut w = [0f32; NUM_JOINTS];
    for x in w.iter_mut() {
        *x = rng.random_range(0.0..1.0f32).powi(4);
    }
    let s: f32 = w.iter().sum();
    w.iter_mut().for_each(|x| *x /= s);
    (joints, given, w)
}

fn check_against_finite_differences(correction: PoseCorrection, tolerance: f32) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..4 {
        let (joints, given, w) = random_setup(&mut rng);
        let x = Vec3::new(
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.2..0.2),
        );
        let bones = correction.bones(&joints, &given);
        let cols = skinned_point_jacobian(&bones, &w, x);
        let base = correction.to_vec();
        let h = 1e-3;
        let fd: Vec<Vec3> = (0..POSE_DOF)
            .map(|k| {
                let y = |sign: f32| {
                    let mut c = PoseCorrection::default();
                    let mut v = base.clone();
                    v[k] += sign * h;
                    c.add(&v);
                    skin_point(&c.bones(&joints, &given).transforms, &w, x)
                };
                (y(1.0) - y(-1.0)) / (2.0 * h)
            })
            .collect();
        for k in 0..POSE_DOF {
            // Relative to the largest column of the joint (f32 differences: 1e-3 absolute).
            let block = 3 * (k / 3)..3 * (k / 3) + 3;
            let scale = block.map(|b| fd[b].length().max(cols[b].length())).fold(0.0, f32::max);
            assert!(
                (fd[k] - cols[k]).length() <= tolerance * scale + 1e-3,
                "dof {k}: analytic {} vs finite differences {}",
                cols[k],
                fd[k]
            );
        }
    }
}

#[test]
fn jacobian_matches_finite_differences_at_zero_correction() {
    check_against_finite_differences(PoseCorrection::default(), 1e-2);
}

#[test]
fn jacobian_is_close_at_a_five_degree_correction() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut c = PoseCorrection::default();
    for r in c.rotations.iter_mut() {
        *r = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize()
            * 5f32.to_radians();
    }
    c.translation = Vec3::new(0.01, -0.02, 0.005);
    // The rotation-vector parameterisation's first-order error: |d| / 2 = 4 % at 5 degrees.
    check_against_finite_differences(c, 0.08);
}

#[test]
fn applied_correction_matches_its_rotations_and_errors_measure_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (joints, given, _) = random_setup(&mut rng);
    let mut c = PoseCorrection::default();
    c.rotations[5] = Vec3::new(0.0, 0.1, 0.0);
    c.translation = Vec3::new(0.02, 0.0, 0.0);
    let applied = c.apply(&given);
    let direct = forward_kinematics(&joints, &applied.rotations(), applied.trans);
    let via = c.bones(&joints, &given);
    for j in 0..NUM_JOINTS {
        assert!(direct.transforms[j].abs_diff_eq(via.transforms[j], 1e-5));
    }
    let (angle, trans) = pose_error(&given, &applied);
    assert!((angle * NUM_JOINTS as f32 - 0.1).abs() < 1e-4, "{angle}");
    assert!((trans - 0.02).abs() < 1e-6);
}
