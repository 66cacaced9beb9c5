//! Body model: the SMPL npz loader on a synthetic model written by the test (never a licensed
//! file), pose correctives, LBS round trips, and clear errors for bad model files.

use avatar_core::body::{BodyModel, BodyParams, NUM_JOINTS, SMPL_PARENTS, skinning};
use glam::Vec3;
use npyz::WriterBuilder;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::io::Write;
use std::path::Path;

/// A small SMPL-like model: a cloud of vertices around a stick skeleton with smooth weights.
struct Synthetic {
    v_template: Vec<f64>,  // V*3
    shapedirs: Vec<f64>,   // V*3*K
    posedirs: Vec<f64>,    // V*3*207
    j_regressor: Vec<f64>, // 24*V
    weights: Vec<f64>,     // V*24
    faces: Vec<u32>,       // F*3
    nv: usize,
    k: usize,
}

fn rest_joints() -> [Vec3; NUM_JOINTS] {
    let mut j = [Vec3::ZERO; NUM_JOINTS];
    let offsets: [Vec3; NUM_JOINTS] = [
        Vec3::new(0.0, 0.9, 0.0),
        Vec3::new(0.09, -0.08, 0.0),
        Vec3::new(-0.09, -0.08, 0.0),
        Vec3::new(0.0, 0.1, 0.0),
        Vec3::new(0.0, -0.38, 0.0),
        Vec3::new(0.0, -0.38, 0.0),
        Vec3::new(0.0, 0.13, 0.0),
        Vec3::new(0.0, -0.4, 0.0),
        Vec3::new(0.0, -0.4, 0.0),
        Vec3::new(0.0, 0.05, 0.0),
        Vec3::new(0.0, -0.05, 0.12),
        Vec3::new(0.0, -0.05, 0.12),
        Vec3::new(0.0, 0.2, 0.0),
        Vec3::new(0.07, 0.11, 0.0),
        Vec3::new(-0.07, 0.11, 0.0),
        Vec3::new(0.0, 0.1, 0.0),
        Vec3::new(0.1, 0.02, 0.0),
        Vec3::new(-0.1, 0.02, 0.0),
        Vec3::new(0.26, 0.0, 0.0),
        Vec3::new(-0.26, 0.0, 0.0),
        Vec3::new(0.25, 0.0, 0.0),
        Vec3::new(-0.25, 0.0, 0.0),
        Vec3::new(0.08, 0.0, 0.0),
        Vec3::new(-0.08, 0.0, 0.0),
    ];
    for i in 0..NUM_JOINTS {
        j[i] = offsets[i] + if i == 0 { Vec3::ZERO } else { j[SMPL_PARENTS[i] as usize] };
    }
    j
}

fn synthetic(seed: u64) -> Synthetic {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let joints = rest_joints();
    let per_joint = 8;
    let nv = NUM_JOINTS * per_joint;
    let k = 4;
    let mut v_template = Vec::new();
    let mut weights = vec![0.0; nv * NUM_JOINTS];
    for j in 0..NUM_JOINTS {
        for i in 0..per_joint {
            let v = j * per_joint + i;
            let p = joints[j]
                + Vec3::new(
                    rng.random_range(-0.04..0.04),
                    rng.random_range(-0.04..0.04),
                    rng.random_range(-0.04..0.04),
                );
            v_template.extend(p.to_array().map(f64::from));
            // Blend the own joint with its parent: smooth-ish multi-joint weights.
            let own = rng.random_range(0.5..1.0);
            weights[v * NUM_JOINTS + j] += own;
            let other = if j == 0 { 3 } else { SMPL_PARENTS[j] as usize };
            weights[v * NUM_JOINTS + other] += 1.0 - own;
        }
    }
    let shapedirs = (0..nv * 3 * k).map(|_| rng.random_range(-0.02..0.02)).collect();
    let posedirs = (0..nv * 3 * 207).map(|_| rng.random_range(-0.005..0.005)).collect();
    // Joint regressor: the mean of each joint's own vertices.
    let mut j_regressor = vec![0.0; NUM_JOINTS * nv];
    for j in 0..NUM_JOINTS {
        for i in 0..per_joint {
            j_regressor[j * nv + j * per_joint + i] = 1.0 / per_joint as f64;
        }
    }
    let faces = (0..nv as u32 - 2).flat_map(|i| [i, i + 1, i + 2]).collect();
    Synthetic { v_template, shapedirs, posedirs, j_regressor, weights, faces, nv, k }
}

enum Data<'a> {
    F64(&'a [f64]),
    I64(Vec<i64>),
    U32(&'a [u32]),
}

fn write_npz(path: &Path, arrays: &[(&str, Vec<u64>, Data)]) {
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut npz = npyz::npz::NpzWriter::new(&mut buf);
        for (name, shape, data) in arrays {
            match data {
                Data::F64(d) => {
                    let mut w = npz
                        .array::<f64>(name, Default::default())
                        .unwrap()
                        .default_dtype()
                        .shape(shape)
                        .begin_nd()
                        .unwrap();
                    w.extend(d.iter().copied()).unwrap();
                    w.finish().unwrap();
                }
                Data::I64(d) => {
                    let mut w = npz
                        .array::<i64>(name, Default::default())
                        .unwrap()
                        .default_dtype()
                        .shape(shape)
                        .begin_nd()
                        .unwrap();
                    w.extend(d.iter().copied()).unwrap();
                    w.finish().unwrap();
                }
                Data::U32(d) => {
                    let mut w = npz
                        .array::<u32>(name, Default::default())
                        .unwrap()
                        .default_dtype()
                        .shape(shape)
                        .begin_nd()
                        .unwrap();
                    w.extend(d.iter().copied()).unwrap();
                    w.finish().unwrap();
                }
            }
        }
    }
    std::fs::File::create(path).unwrap().write_all(&buf.into_inner()).unwrap();
}

fn kintree() -> Vec<i64> {
    let mut k: Vec<i64> =
        SMPL_PARENTS.iter().map(|&p| if p < 0 { 4294967295 } else { p as i64 }).collect();
    k.extend(0..NUM_JOINTS as i64);
    k
}

/// An array's shape and values.
type Array = (Vec<u64>, Vec<f64>);

/// Write the synthetic model, optionally replacing or dropping one key.
fn write_model(path: &Path, s: &Synthetic, tamper: Option<(&str, Option<Array>)>) {
    let (nv, k) = (s.nv as u64, s.k as u64);
    let mut arrays: Vec<(&str, Vec<u64>, Data)> = vec![
        ("v_template", vec![nv, 3], Data::F64(&s.v_template)),
        ("shapedirs", vec![nv, 3, k], Data::F64(&s.shapedirs)),
        ("posedirs", vec![nv, 3, 207], Data::F64(&s.posedirs)),
        ("J_regressor", vec![24, nv], Data::F64(&s.j_regressor)),
        ("weights", vec![nv, 24], Data::F64(&s.weights)),
        ("kintree_table", vec![2, 24], Data::I64(kintree())),
        ("f", vec![s.faces.len() as u64 / 3, 3], Data::U32(&s.faces)),
    ];
    let replacement;
    if let Some((key, new)) = tamper {
        let at = arrays.iter().position(|a| a.0 == key).unwrap();
        match new {
            None => {
                arrays.remove(at);
            }
            Some((shape, data)) => {
                replacement = data;
                arrays[at] = (key, shape, Data::F64(&replacement));
            }
        }
    }
    write_npz(path, &arrays);
}

fn random_params(rng: &mut ChaCha8Rng, k: usize, scale: f32) -> BodyParams {
    let mut p = BodyParams::default();
    for aa in p.pose.iter_mut() {
        *aa = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * scale;
    }
    p.betas = (0..k).map(|_| rng.random_range(-2.0..2.0)).collect();
    p.trans = Vec3::new(0.3, -0.2, 1.5);
    p
}

#[test]
fn synthetic_smpl_npz_loads_and_poses_with_correctives() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("SMPL_TEST.npz");
    let s = synthetic(7);
    write_model(&path, &s, None);
    let model = BodyModel::load_npz(&path).unwrap();
    assert_eq!(model.num_vertices(), s.nv);
    assert_eq!(model.num_betas, s.k);
    assert!(model.posedirs.is_some());
    for w in &model.weights {
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
    // The regressor gives back the stick skeleton for zero shape.
    let joints = model.rest_joints(&[]);
    for (a, b) in joints.iter().zip(rest_joints()) {
        assert!((*a - b).length() < 0.03, "joint off by {}", (*a - b).length());
    }

    // Pose correctives: rest vertex = shaped + posedirs . (R - I) features, checked by hand.
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let params = random_params(&mut rng, s.k, 0.4);
    let posed = model.pose(&params);
    let rotations = params.rotations();
    let feat = BodyModel::pose_features(&rotations);
    let v = 37;
    let mut expected = [0f64; 3];
    for c in 0..3 {
        expected[c] = s.v_template[v * 3 + c]
            + (0..s.k)
                .map(|b| s.shapedirs[(v * 3 + c) * s.k + b] * params.betas[b] as f64)
                .sum::<f64>()
            + (0..207).map(|p| s.posedirs[(v * 3 + c) * 207 + p] * feat[p] as f64).sum::<f64>();
    }
    let got = posed.rest_vertices[v];
    for c in 0..3 {
        assert!(
            (got[c] as f64 - expected[c]).abs() < 1e-5,
            "component {c}: {} vs {}",
            got[c],
            expected[c]
        );
    }
    // The corrective is not negligible, so the check above can fail.
    let shaped = model.shaped_vertices(&params.betas);
    assert!((posed.rest_vertices[v] - shaped[v]).length() > 1e-3);
}

#[test]
fn lbs_pose_then_inverse_pose_round_trip_within_1e5() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.npz");
    let s = synthetic(3);
    write_model(&path, &s, None);
    let model = BodyModel::load_npz(&path).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..5 {
        let params = random_params(&mut rng, s.k, 0.8);
        let posed = model.pose(&params);
        let mut worst = 0f32;
        for ((rest, p), w) in posed.rest_vertices.iter().zip(&posed.vertices).zip(&model.weights) {
            let back = skinning::unskin_point(&posed.bones.transforms, w, *p);
            worst = worst.max((back - *rest).length());
        }
        assert!(worst < 1e-5, "round trip error {worst} m");
        // And the pose really moved the body.
        let moved = posed
            .vertices
            .iter()
            .zip(&posed.rest_vertices)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f32::max);
        assert!(moved > 0.1);
    }
}

#[test]
fn bad_model_files_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let s = synthetic(5);
    let good = dir.path().join("good.npz");
    write_model(&good, &s, None);

    // Truncated file.
    let bytes = std::fs::read(&good).unwrap();
    let truncated = dir.path().join("truncated.npz");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let e = BodyModel::load_npz(&truncated).unwrap_err().to_string();
    assert!(e.contains("truncated.npz"), "{e}");

    let cases: Vec<(&str, Option<Array>, &str)> = vec![
        ("weights", None, "missing array 'weights'"),
        ("J_regressor", None, "missing array 'J_regressor'"),
        ("shapedirs", Some((vec![5, 3, 2], vec![0.0; 30])), "'shapedirs'"),
        ("v_template", Some((vec![s.nv as u64, 2], vec![0.0; s.nv * 2])), "'v_template'"),
        ("kintree_table", Some((vec![2, 52], vec![0.0; 104])), "only SMPL's 24-joint"),
        (
            "weights",
            Some((vec![s.nv as u64, 24], {
                let mut w = s.weights.clone();
                w[24 * 10 + 3] = f64::NAN;
                w
            })),
            "'weights': contains NaN",
        ),
        (
            "weights",
            Some((vec![s.nv as u64, 24], s.weights.iter().map(|w| w * 2.0).collect())),
            "sum to 2",
        ),
        ("f", Some((vec![1, 3], vec![0.0, 1.0, 1e6])), "'f': face 0"),
    ];
    for (i, (key, new, expect)) in cases.into_iter().enumerate() {
        let path = dir.path().join(format!("bad{i}.npz"));
        write_model(&path, &s, Some((key, new)));
        let e = BodyModel::load_npz(&path).unwrap_err().to_string();
        assert!(e.contains(&format!("bad{i}.npz")) && e.contains(expect), "case {key}: {e}");
    }

    // A file that is not an npz at all, and a missing file.
    let junk = dir.path().join("junk.npz");
    std::fs::write(&junk, b"definitely not a zip").unwrap();
    assert!(BodyModel::load_npz(&junk).unwrap_err().to_string().contains("junk.npz"));
    assert!(
        BodyModel::load_npz(dir.path().join("nope.npz"))
            .unwrap_err()
            .to_string()
            .contains("nope.npz")
    );
}
