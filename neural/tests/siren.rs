//! The SIREN SDF: forward-mode gradients match finite differences, and a short IGR fit on a
//! sphere learns a signed distance (loss falls, surface values near zero, signs right).

use avatar_neural::*;
use burn::tensor::{Tensor, TensorData};
use glam::Vec3;

fn points(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let t = i as f32 * 0.618_034;
            Vec3::new((t * 7.1).sin() * 0.6, (t * 3.3).cos() * 0.6, (t * 5.7).sin() * 0.6)
        })
        .collect()
}

fn tensor(v: &[Vec3], device: &burn::tensor::Device) -> Tensor<2> {
    Tensor::from_data(
        TensorData::new(v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>(), [v.len(), 3]),
        device,
    )
}

#[test]
fn tangent_gradients_match_finite_differences() {
    let device = cpu_device();
    let model = SirenConfig { hidden: 32, layers: 3 }.init(7, &device);
    let x = points(20);
    let (f, g) = model.sdf_and_gradient(tensor(&x, &device));
    let f: Vec<f32> = f.to_data().as_slice::<f32>().unwrap().to_vec();
    let g: Vec<f32> = g.to_data().as_slice::<f32>().unwrap().to_vec();
    let plain = sdf_values(&model, &x);
    let h = 1e-3;
    for (i, p) in x.iter().enumerate() {
        assert!((f[i] - plain[i]).abs() < 1e-5, "tangent pass changes f");
        for a in 0..3 {
            let mut e = Vec3::ZERO;
            e[a] = h;
            let fd =
                (sdf_values(&model, &[*p + e])[0] - sdf_values(&model, &[*p - e])[0]) / (2.0 * h);
            let an = g[i * 3 + a];
            assert!(
                (fd - an).abs() < 2e-2 * (1.0 + an.abs()),
                "point {i} axis {a}: analytic {an} vs finite difference {fd}"
            );
        }
    }
}

#[test]
fn short_fit_learns_a_sphere() {
    let device = cpu_training_device();
    let r = 0.5;
    let dirs: Vec<Vec3> = points(3000).into_iter().map(|p| p.normalize()).collect();
    let surface: Vec<Vec3> = dirs.iter().map(|d| *d * r).collect();
    let model = SirenConfig { hidden: 64, layers: 3 }.init(3, &device);
    let mut losses = Vec::new();
    let options = FitOptions {
        steps: 300,
        learning_rate: 1e-4,
        batch: 1000,
        off_surface: 1000,
        seed: 1,
        ..FitOptions::default()
    };
    let model =
        fit_sdf(model, &surface, &dirs, &[], &options, &device, None, None, &mut |_, loss, _| {
            losses.push(loss)
        });
    assert!(losses.len() >= 10);
    let (first, last) = (losses[0], *losses.last().unwrap());
    assert!(last < 0.3 * first, "loss {first} -> {last}");
    let model = burn::module::Module::valid(&model);
    let probe: Vec<Vec3> = points(200).into_iter().map(|p| p.normalize() * r).collect();
    let on = sdf_values(&model, &probe);
    let mean_abs = on.iter().map(|v| v.abs()).sum::<f32>() / on.len() as f32;
    assert!(mean_abs < 0.03, "mean |f| on the sphere {mean_abs}");
    // Signed: negative just inside, positive just outside, and about the true distance (the
    // far interior needs longer training than a test allows).
    let dirs: Vec<Vec3> = points(50).into_iter().map(|p| p.normalize()).collect();
    let inside = sdf_values(&model, &dirs.iter().map(|d| *d * (r - 0.05)).collect::<Vec<_>>());
    let outside = sdf_values(&model, &dirs.iter().map(|d| *d * (r + 0.05)).collect::<Vec<_>>());
    let right =
        inside.iter().filter(|&&v| v < 0.0).count() + outside.iter().filter(|&&v| v > 0.0).count();
    assert!(
        right >= 95,
        "{right} of 100 probes have the right sign: inside {inside:?} outside {outside:?}"
    );
    let err = inside
        .iter()
        .map(|v| (v + 0.05).abs())
        .chain(outside.iter().map(|v| (v - 0.05).abs()))
        .sum::<f32>()
        / 100.0;
    assert!(err < 0.03, "mean distance error {err}");
}
