//! Pose-dependent deformation as glTF morph targets: PCA of the per-frame vertex deltas
//! (Gram-matrix eigendecomposition, Jacobi), at most `max_targets` targets including a constant
//! compensation target, each target's weights remapped to [0, 1].

use glam::Vec3;

#[derive(Debug, Clone, PartialEq)]
pub struct MorphTargets {
    /// Delta applied with weight 1 in every frame: the mean plus each component's minimum.
    pub constant: Vec<Vec3>,
    /// Component targets (deltas).
    pub targets: Vec<Vec<Vec3>>,
    /// Per frame, per component target: in [0, 1].
    pub weights: Vec<Vec<f32>>,
}

impl MorphTargets {
    /// All targets as glTF sees them: the constant one first.
    pub fn all_targets(&self) -> Vec<&Vec<Vec3>> {
        std::iter::once(&self.constant).chain(self.targets.iter()).collect()
    }

    /// Per frame, the weights of `all_targets`.
    pub fn all_weights(&self, frame: usize) -> Vec<f32> {
        std::iter::once(1.0).chain(self.weights[frame].iter().copied()).collect()
    }

    /// The reconstructed delta of a frame.
    pub fn delta(&self, frame: usize) -> Vec<Vec3> {
        let mut d = self.constant.clone();
        for (t, &w) in self.targets.iter().zip(&self.weights[frame]) {
            for (x, y) in d.iter_mut().zip(t) {
                *x += *y * w;
            }
        }
        d
    }
}

/// Symmetric eigendecomposition by cyclic Jacobi rotations: (eigenvalues, eigenvectors as
/// columns), sorted by decreasing eigenvalue.
fn symmetric_eigen(mut a: Vec<Vec<f64>>) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = a.len();
    let mut v = vec![vec![0.0; n]; n];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..60 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let diag: f64 = (0..n).map(|i| a[i][i] * a[i][i]).sum();
        if off <= 1e-22 * diag.max(1e-300) {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in v.iter_mut() {
                    let (vkp, vkq) = (row[p], row[q]);
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| a[y][y].total_cmp(&a[x][x]));
    let values = order.iter().map(|&i| a[i][i]).collect();
    let vectors = order.iter().map(|&i| (0..n).map(|k| v[k][i]).collect()).collect();
    (values, vectors)
}

/// The PCA basis of a set of per-frame deltas: their mean and at most `max_components` unit
/// components (flattened x, y, z per vertex), in decreasing variance. Fitted on a bounded
/// sample of frames; any frame's delta is then projected onto it ([`Basis::coefficients`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Basis {
    pub mean: Vec<Vec3>,
    pub components: Vec<Vec<f64>>,
}

impl Basis {
    /// PCA of `deltas` (frames x vertices; Gram matrix, Jacobi). Components whose largest vertex
    /// displacement over these frames is below `min_effect` (metres) are dropped: they would
    /// cost a full target for nothing visible.
    pub fn fit(deltas: &[&[Vec3]], max_components: usize, min_effect: f32) -> Basis {
        use rayon::prelude::*;
        let frames = deltas.len();
        let verts = deltas.first().map_or(0, |d| d.len());
        let mut mean = vec![Vec3::ZERO; verts];
        for d in deltas {
            for (m, x) in mean.iter_mut().zip(d.iter()) {
                *m += *x / frames as f32;
            }
        }
        let centred: Vec<Vec<f32>> = deltas
            .iter()
            .map(|d| d.iter().zip(&mean).flat_map(|(x, m)| (*x - *m).to_array()).collect())
            .collect();
        let gram: Vec<Vec<f64>> = (0..frames)
            .into_par_iter()
            .map(|i| {
                (0..frames)
                    .map(|j| {
                        centred[i].iter().zip(&centred[j]).map(|(a, b)| *a as f64 * *b as f64).sum()
                    })
                    .collect()
            })
            .collect();
        let (values, vectors) = symmetric_eigen(gram);
        let top = values.first().copied().unwrap_or(0.0).max(0.0);
        let mut components = Vec::new();
        for (lambda, v) in values.iter().zip(&vectors).take(max_components) {
            if *lambda <= 1e-12 * top || *lambda <= 0.0 {
                break;
            }
            let s = lambda.sqrt();
            // Unit component u = D^T v / s, coefficients c_f = s v_f.
            let mut u = vec![0f64; verts * 3];
            for (f, row) in centred.iter().enumerate() {
                for (k, x) in row.iter().enumerate() {
                    u[k] += v[f] * *x as f64 / s;
                }
            }
            let lo = v.iter().map(|x| x * s).fold(f64::INFINITY, f64::min);
            let hi = v.iter().map(|x| x * s).fold(f64::NEG_INFINITY, f64::max);
            let span = hi - lo;
            if span < 1e-9 {
                continue;
            }
            let effect = u
                .chunks_exact(3)
                .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() * span)
                .fold(0.0, f64::max);
            if effect < min_effect as f64 {
                // Components come in decreasing variance: the rest are smaller still.
                break;
            }
            components.push(u);
        }
        Basis { mean, components }
    }

    /// A frame's coefficients: its delta minus the mean, projected on each component.
    pub fn coefficients(&self, delta: &[Vec3]) -> Vec<f64> {
        self.components
            .iter()
            .map(|u| {
                delta
                    .iter()
                    .zip(&self.mean)
                    .zip(u.chunks_exact(3))
                    .map(|((d, m), c)| {
                        let x = *d - *m;
                        x.x as f64 * c[0] + x.y as f64 * c[1] + x.z as f64 * c[2]
                    })
                    .sum()
            })
            .collect()
    }

    /// Largest and mean vertex error of a frame's delta rebuilt from its coefficients.
    pub fn error(&self, delta: &[Vec3], coefficients: &[f64]) -> (f32, f32) {
        let mut max = 0f64;
        let mut sum = 0f64;
        for (k, (d, m)) in delta.iter().zip(&self.mean).enumerate() {
            let mut r = [m.x as f64, m.y as f64, m.z as f64];
            for (u, c) in self.components.iter().zip(coefficients) {
                for (a, r) in r.iter_mut().enumerate() {
                    *r += u[3 * k + a] * c;
                }
            }
            let e = ((r[0] - d.x as f64).powi(2)
                + (r[1] - d.y as f64).powi(2)
                + (r[2] - d.z as f64).powi(2))
            .sqrt();
            max = max.max(e);
            sum += e;
        }
        (max as f32, (sum / delta.len().max(1) as f64) as f32)
    }

    /// The morph targets of this basis for frames with these coefficients: each component's
    /// weights remapped to [0, 1] over the frames, the mean and the shifts in the constant
    /// target.
    pub fn targets(&self, coefficients: &[Vec<f64>]) -> MorphTargets {
        let mut constant = self.mean.clone();
        let mut targets = Vec::new();
        let mut columns: Vec<Vec<f32>> = Vec::new();
        for (k, u) in self.components.iter().enumerate() {
            let lo = coefficients.iter().map(|c| c[k]).fold(f64::INFINITY, f64::min);
            let hi = coefficients.iter().map(|c| c[k]).fold(f64::NEG_INFINITY, f64::max);
            let span = hi - lo;
            if span.is_nan() || span < 1e-9 {
                // Constant over the frames: into the constant target.
                for (v, c) in constant.iter_mut().zip(u.chunks_exact(3)) {
                    *v += Vec3::new((c[0] * lo) as f32, (c[1] * lo) as f32, (c[2] * lo) as f32);
                }
                continue;
            }
            for (v, c) in constant.iter_mut().zip(u.chunks_exact(3)) {
                *v += Vec3::new((c[0] * lo) as f32, (c[1] * lo) as f32, (c[2] * lo) as f32);
            }
            targets.push(
                u.chunks_exact(3)
                    .map(|c| {
                        Vec3::new((c[0] * span) as f32, (c[1] * span) as f32, (c[2] * span) as f32)
                    })
                    .collect(),
            );
            columns.push(
                coefficients.iter().map(|c| ((c[k] - lo) / span).clamp(0.0, 1.0) as f32).collect(),
            );
        }
        let weights =
            (0..coefficients.len()).map(|f| columns.iter().map(|col| col[f]).collect()).collect();
        MorphTargets { constant, targets, weights }
    }
}

/// Compress per-frame deltas (frames x vertices) into at most `max_targets` targets, the
/// constant one included: the basis of every frame ([`Basis::fit`]), every frame projected.
pub fn compress(deltas: &[Vec<Vec3>], max_targets: usize, min_effect: f32) -> MorphTargets {
    let refs: Vec<&[Vec3]> = deltas.iter().map(|d| d.as_slice()).collect();
    let basis = Basis::fit(&refs, max_targets.saturating_sub(1), min_effect);
    let coefficients: Vec<Vec<f64>> = deltas.iter().map(|d| basis.coefficients(d)).collect();
    basis.targets(&coefficients)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_low_rank_deltas_and_weights_in_unit_range() {
        // Deltas spanned by two patterns: two components reproduce them exactly.
        let a: Vec<Vec3> = (0..50).map(|i| Vec3::new(i as f32 * 0.001, 0.0, 0.01)).collect();
        let b: Vec<Vec3> =
            (0..50).map(|i| Vec3::new(0.0, (i as f32 * 0.3).sin() * 0.02, 0.0)).collect();
        let deltas: Vec<Vec<Vec3>> = (0..30)
            .map(|f| {
                let (s, t) = ((f as f32 * 0.4).sin(), (f as f32 * 0.17).cos() * 2.0);
                a.iter().zip(&b).map(|(x, y)| *x * s + *y * t + Vec3::splat(0.005)).collect()
            })
            .collect();
        let m = compress(&deltas, 64, 0.0);
        assert_eq!(m.targets.len(), 2);
        for (f, d) in deltas.iter().enumerate() {
            assert!(m.weights[f].iter().all(|w| (0.0..=1.0).contains(w)));
            for (x, y) in m.delta(f).iter().zip(d) {
                assert!((*x - *y).length() < 1e-5);
            }
        }
        // Truncation to one target keeps the largest component only.
        assert_eq!(compress(&deltas, 2, 0.0).targets.len(), 1);
        // Components below a visible effect are dropped.
        assert_eq!(compress(&deltas, 64, 1.0).targets.len(), 0);
    }
}
