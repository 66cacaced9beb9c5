//! The fast evaluation path (`siren_eval`) against burn's forward and finite differences.

use avatar_neural::cpu_device;
use avatar_neural::model::siren::{SirenConfig, sdf_and_gradient, sdf_only};
use avatar_neural::model::siren_eval::SirenEval;
use burn::tensor::{Tensor, TensorData};

fn points(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| {
            [
                (i as f32 * 0.37).sin() * 0.9,
                (i as f32 * 0.11).cos() * 0.8,
                (i as f32 * 0.23).sin() * 0.7,
            ]
        })
        .collect()
}

fn tensor(x: &[[f32; 3]]) -> Tensor<2> {
    Tensor::from_data(
        TensorData::new(x.iter().flatten().copied().collect::<Vec<f32>>(), [x.len(), 3]),
        &cpu_device(),
    )
}

fn values(t: Tensor<2>) -> Vec<f32> {
    t.into_data().as_slice::<f32>().unwrap().to_vec()
}

#[test]
fn values_and_gradients_match_burn_for_several_shapes() {
    // 600 points: two full blocks and a partial one.
    let x = points(600);
    for config in [
        SirenConfig { hidden: 16, layers: 2 },
        SirenConfig::compact(),
        SirenConfig { hidden: 64, layers: 5 },
    ] {
        let siren = config.init(11, &cpu_device());
        let (w, b) = siren.params();
        let fast = SirenEval::from_tensors(&w, &b);
        let expected = values(sdf_only(&w, &b, tensor(&x)));
        let f = fast.sdf(&x);
        let (f2, g) = fast.sdf_and_gradient(&x);
        let (_, eg) = sdf_and_gradient(&w, &b, tensor(&x));
        let eg = values(eg);
        let scale = expected.iter().fold(0f32, |m, v| m.max(v.abs())).max(1e-3);
        for i in 0..x.len() {
            assert!(
                (f[i] - expected[i]).abs() < 1e-4 * scale + 1e-6,
                "{config:?} point {i}: {} vs burn {}",
                f[i],
                expected[i]
            );
            assert_eq!(f[i], f2[i], "values agree with and without gradients");
            for a in 0..3 {
                let e = eg[i * 3 + a];
                assert!(
                    (g[i][a] - e).abs() < 2e-3 * (1.0 + e.abs()),
                    "{config:?} point {i} axis {a}: {} vs burn {e}",
                    g[i][a]
                );
            }
        }
    }
}

#[test]
fn gradients_match_finite_differences() {
    let siren = SirenConfig::compact().init(5, &cpu_device());
    let (w, b) = siren.params();
    let fast = SirenEval::from_tensors(&w, &b);
    let x = points(40);
    let (_, g) = fast.sdf_and_gradient(&x);
    let h = 1e-3f32;
    for (i, p) in x.iter().enumerate() {
        for a in 0..3 {
            let (mut plus, mut minus) = (*p, *p);
            plus[a] += h;
            minus[a] -= h;
            let f = fast.sdf(&[plus, minus]);
            let fd = (f[0] - f[1]) / (2.0 * h);
            assert!(
                (fd - g[i][a]).abs() < 0.02 * (1.0 + fd.abs()),
                "point {i} axis {a}: analytic {} vs finite differences {fd}",
                g[i][a]
            );
        }
    }
}

#[test]
fn projection_lands_on_the_zero_level_set_of_the_shipped_meta_sdf() {
    // The shipped meta-SDF is body-shaped. Vertices of its surface pushed 1-2 cm (unit cube:
    // 0.01-0.02) along their normals, in and out, must land back on it in three Newton steps.
    use avatar_core::mesh::extract::{ExtractOptions, extract};
    use glam::Vec3;
    let fast = SirenEval::of(&avatar_neural::MetaModel::shipped().static_siren());
    let options = ExtractOptions::new(Vec3::splat(-1.0), Vec3::splat(1.0), 48);
    let mesh = extract(
        |p: &[Vec3]| fast.sdf(&p.iter().map(|q| q.to_array()).collect::<Vec<_>>()),
        &options,
    )
    .unwrap()
    .mesh;
    assert!(
        mesh.positions.len() > 500,
        "the meta-SDF has a surface ({} vertices)",
        mesh.positions.len()
    );
    let normals = mesh.vertex_normals();
    let pushed: Vec<[f32; 3]> = mesh
        .positions
        .iter()
        .zip(&normals)
        .enumerate()
        .map(|(i, (p, n))| (*p + *n * (0.02 * ((i % 5) as f32 / 2.0 - 1.0))).to_array())
        .collect();
    let before: Vec<f32> = fast.sdf(&pushed).iter().map(|f| f.abs()).collect();
    let after: Vec<f32> = fast.sdf(&fast.project(&pushed, 3)).iter().map(|f| f.abs()).collect();
    let quantile = |v: &[f32], q: f64| {
        let mut v = v.to_vec();
        v.sort_by(f32::total_cmp);
        v[((v.len() - 1) as f64 * q) as usize]
    };
    let (median, p95) = (quantile(&after, 0.5), quantile(&after, 0.95));
    assert!(quantile(&before, 0.5) > 5e-3, "the pushed points start off the surface");
    assert!(
        median < 1e-5 && p95 < 1e-3,
        "|f| after projection: median {median}, 95th percentile {p95} (before: median {})",
        quantile(&before, 0.5)
    );
}
