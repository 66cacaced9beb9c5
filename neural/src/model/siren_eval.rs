//! Fast CPU evaluation of one SIREN (meshing, projection onto the surface, the pose slider):
//! plain f32 matrices multiplied by the training path's products (`train::gemm`: its AVX-512
//! kernel with the sine in the epilogue where the CPU has it, matrixmultiply otherwise) and a
//! branch-free sine the compiler vectorises, over blocks of points that stay in cache, the
//! blocks spread over rayon's threads. Training keeps burn; burn's CPU matrix multiply keeps to
//! one core and allocates a tensor per step, which made a posed mesh and the export's Newton
//! projection several times slower than the arithmetic needs. Tests check this path against
//! burn's forward and against finite differences.
//!
//! The spatial gradient is taken in reverse mode (one transposed multiply per layer), about
//! twice the cost of the values alone, against four times for forward-mode tangents.

pub use crate::model::sine::sin_cos;
use crate::model::siren::W0;
use crate::training::step::gemm::{Epilogue, Mat, dots, gemm, gemm_then};
use avatar_core::canonical::Normalisation;
use burn::tensor::Tensor;
use glam::Vec3;
use rayon::prelude::*;

/// Points per block: the activations of a 256-wide layer for 256 points are 256 KiB.
const BLOCK: usize = 256;

struct Layer {
    /// [fan_in, fan_out], row-major (the layout of the burn weights).
    w: Vec<f32>,
    /// W transposed, [fan_out, fan_in] row-major: the gradient's `delta W^T` then runs on the
    /// product's register tiles (as a product with a transposed operand it ran on dot
    /// products of rows, at half their rate).
    wt: Vec<f32>,
    b: Vec<f32>,
    fan_in: usize,
    fan_out: usize,
}

/// One SIREN's parameters, copied out of burn for evaluation.
pub struct SirenEval {
    layers: Vec<Layer>,
}

impl SirenEval {
    /// From explicit layer parameters: weights [in, out], biases [out].
    pub fn from_tensors(weights: &[Tensor<2>], biases: &[Tensor<1>]) -> SirenEval {
        let layers = weights
            .iter()
            .zip(biases)
            .map(|(w, b)| {
                let [fan_in, fan_out] = w.dims();
                let w = to_vec(w.clone().into_data());
                Layer {
                    wt: transposed(&w, fan_in, fan_out),
                    w,
                    b: to_vec(b.clone().into_data()),
                    fan_in,
                    fan_out,
                }
            })
            .collect::<Vec<_>>();
        assert!(
            layers.first().is_some_and(|l| l.fan_in == 3)
                && layers.last().is_some_and(|l| l.fan_out == 1),
            "a SIREN maps 3 inputs to 1 output"
        );
        SirenEval { layers }
    }

    /// From a SIREN module (a static SDF, the meta-SDF, a network being trained).
    pub fn of(siren: &crate::model::siren::Siren) -> SirenEval {
        let (w, b) = siren.params();
        SirenEval::from_tensors(&w, &b)
    }

    fn widest(&self) -> usize {
        self.layers.iter().map(|l| l.fan_out.max(l.fan_in)).max().unwrap_or(1)
    }

    /// SDF values (the network's units) at points given in its unit cube.
    pub fn sdf(&self, points: &[[f32; 3]]) -> Vec<f32> {
        let mut out = vec![0f32; points.len()];
        out.par_chunks_mut(BLOCK).zip(points.par_chunks(BLOCK)).for_each_init(
            || Scratch::new(self.widest(), self.layers.len(), false),
            |scratch, (out, points)| self.block(points, scratch, out, None),
        );
        out
    }

    /// SDF values and spatial gradients at points in the unit cube.
    pub fn sdf_and_gradient(&self, points: &[[f32; 3]]) -> (Vec<f32>, Vec<[f32; 3]>) {
        let mut values = vec![0f32; points.len()];
        let mut grads = vec![[0f32; 3]; points.len()];
        values
            .par_chunks_mut(BLOCK)
            .zip(grads.par_chunks_mut(BLOCK))
            .zip(points.par_chunks(BLOCK))
            .for_each_init(
                || Scratch::new(self.widest(), self.layers.len(), true),
                |scratch, ((values, grads), points)| {
                    self.block(points, scratch, values, Some(grads))
                },
            );
        (values, grads)
    }

    /// At most `steps` Newton steps x <- x - f(x) grad f / |grad f|^2 (unit cube): the points
    /// move along the gradient onto the zero level set. A point stops once |f| < `PROJECTED`
    /// (checked with the values alone, half the cost of a step), so most points need one step
    /// and one check; a point whose gradient vanishes stays where it is.
    pub fn project(&self, points: &[[f32; 3]], steps: usize) -> Vec<[f32; 3]> {
        let mut x = points.to_vec();
        x.par_chunks_mut(BLOCK).for_each_init(
            || ProjectScratch::new(self),
            |scratch, x| self.project_block(x, steps, scratch),
        );
        x
    }

    fn project_block(&self, x: &mut [[f32; 3]], steps: usize, s: &mut ProjectScratch) {
        s.active.clear();
        s.active.extend(0..x.len());
        for step in 0..steps {
            if step > 0 {
                // Keep only the points still off the surface.
                s.gathered.clear();
                s.gathered.extend(s.active.iter().map(|&i| x[i]));
                let n = s.gathered.len();
                self.block(&s.gathered, &mut s.eval, &mut s.f[..n], None);
                let f = &s.f;
                let mut j = 0;
                s.active.retain(|_| {
                    j += 1;
                    f[j - 1].abs() >= PROJECTED
                });
            }
            if s.active.is_empty() {
                return;
            }
            s.gathered.clear();
            s.gathered.extend(s.active.iter().map(|&i| x[i]));
            let n = s.gathered.len();
            self.block(&s.gathered, &mut s.eval, &mut s.f[..n], Some(&mut s.g[..n]));
            for (j, &i) in s.active.iter().enumerate() {
                let (f, g) = (s.f[j], s.g[j]);
                let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
                if g2 > 1e-8 && f.is_finite() {
                    let step = f / g2;
                    for a in 0..3 {
                        x[i][a] -= g[a] * step;
                    }
                }
            }
        }
    }

    /// One block of at most BLOCK points.
    fn block(
        &self,
        points: &[[f32; 3]],
        s: &mut Scratch,
        values: &mut [f32],
        grads: Option<&mut [[f32; 3]]>,
    ) {
        let n = points.len();
        let last = self.layers.len() - 1;
        for (i, p) in points.iter().enumerate() {
            s.input[i * 3..i * 3 + 3].copy_from_slice(p);
        }
        // Forward: activation l+1 = sin(W0 (h_l W_l + b_l)); derivative factors kept per layer.
        for (l, layer) in self.layers.iter().enumerate() {
            let (m, k, nout) = (n, layer.fan_in, layer.fan_out);
            let (done, rest) = s.acts.split_at_mut(l);
            let h: &[f32] = if l == 0 { &s.input[..m * 3] } else { &done[l - 1][..m * k] };
            if l == last {
                // The output layer (width 1): one dot product per point.
                values.fill(layer.b[0]);
                dots(h, &layer.w, k, 1.0, values);
                break;
            }
            let act = &mut rest[0][..m * nout];
            // act = sin(W0 (h W + b)) and its derivative W0 cos(...) in the product's epilogue
            // (kept per layer for the gradient, else dropped in `z`): the values are the same
            // bits with and without gradients.
            let deriv = match s.derivs.get_mut(l) {
                Some(d) => &mut d[..m * nout],
                None => &mut s.z[..m * nout],
            };
            gemm_then(
                Mat::new(h, m, k),
                Mat::new(&layer.w, k, nout),
                act,
                Epilogue::Sine { w0: W0, bias: &layer.b, deriv },
            );
        }
        let Some(grads) = grads else { return };
        // Backward: d f / d h_{L-1} is the last layer's weight column for every point.
        let top = &self.layers[last];
        let mut width = top.fan_in;
        for row in s.grad_a[..n * width].chunks_exact_mut(width) {
            row.copy_from_slice(&top.w[..width]);
        }
        for l in (0..last).rev() {
            let layer = &self.layers[l];
            // delta = grad_h ⊙ W0 cos(W0 z_l); grad of the layer input = delta W_l^T.
            for (g, d) in s.grad_a[..n * width].iter_mut().zip(&s.derivs[l][..n * width]) {
                *g *= d;
            }
            let k = layer.fan_in;
            let (src, dst) = (&s.grad_a[..n * width], &mut s.grad_b[..n * k]);
            // grad of the input = src W_l^T (the first layer's three columns: dot products of
            // src's rows with W_0's rows).
            if l == 0 {
                gemm(Mat::new(src, n, width), Mat::new(&layer.w, k, width).t(), 0.0, dst);
            } else {
                gemm(Mat::new(src, n, width), Mat::new(&layer.wt, width, k), 0.0, dst);
            }
            std::mem::swap(&mut s.grad_a, &mut s.grad_b);
            width = k;
        }
        for (i, g) in grads.iter_mut().enumerate() {
            g.copy_from_slice(&s.grad_a[i * 3..i * 3 + 3]);
        }
    }
}

/// A SIREN with the normalisation of its avatar: points and distances in metres.
pub struct MetricSdf {
    pub siren: SirenEval,
    pub normalisation: Normalisation,
}

impl MetricSdf {
    pub fn of(siren: &crate::model::siren::Siren, normalisation: Normalisation) -> MetricSdf {
        MetricSdf { siren: SirenEval::of(siren), normalisation }
    }

    fn unit(&self, points: &[Vec3]) -> Vec<[f32; 3]> {
        points.iter().map(|p| self.normalisation.to_unit(*p).to_array()).collect()
    }

    /// Signed distances (metres, negative inside) of canonical points.
    pub fn sdf(&self, points: &[Vec3]) -> Vec<f32> {
        let scale = self.normalisation.metres_per_unit();
        let mut f = self.siren.sdf(&self.unit(points));
        f.iter_mut().for_each(|v| *v *= scale);
        f
    }

    /// Canonical points moved onto the zero level set by `steps` Newton steps.
    pub fn project(&self, points: &[Vec3], steps: usize) -> Vec<Vec3> {
        self.siren
            .project(&self.unit(points), steps)
            .into_iter()
            .map(|q| self.normalisation.from_unit(Vec3::from_array(q)))
            .collect()
    }
}

/// `w` [rows, cols] row-major, transposed: [cols, rows] row-major.
fn transposed(w: &[f32], rows: usize, cols: usize) -> Vec<f32> {
    let mut t = vec![0f32; w.len()];
    for (r, row) in w.chunks_exact(cols).enumerate() {
        for (c, &v) in row.iter().enumerate() {
            t[c * rows + r] = v;
        }
    }
    t
}

fn to_vec(data: burn::tensor::TensorData) -> Vec<f32> {
    data.as_slice::<f32>().expect("f32 tensor data").to_vec()
}

/// |f| (unit cube) below which a projected point counts as on the surface: about 5 µm for a
/// body, well under the float noise of a distance measured in millimetres.
pub const PROJECTED: f32 = 1e-5;

struct ProjectScratch {
    eval: Scratch,
    active: Vec<usize>,
    gathered: Vec<[f32; 3]>,
    f: Vec<f32>,
    g: Vec<[f32; 3]>,
}

impl ProjectScratch {
    fn new(siren: &SirenEval) -> ProjectScratch {
        ProjectScratch {
            eval: Scratch::new(siren.widest(), siren.layers.len(), true),
            active: Vec::with_capacity(BLOCK),
            gathered: Vec::with_capacity(BLOCK),
            f: vec![0f32; BLOCK],
            g: vec![[0f32; 3]; BLOCK],
        }
    }
}

struct Scratch {
    input: Vec<f32>,
    z: Vec<f32>,
    /// Activations of the hidden layers.
    acts: Vec<Vec<f32>>,
    /// W0 cos(W0 z) of the hidden layers (only when gradients are wanted).
    derivs: Vec<Vec<f32>>,
    grad_a: Vec<f32>,
    grad_b: Vec<f32>,
}

impl Scratch {
    fn new(width: usize, layers: usize, gradients: bool) -> Scratch {
        let buf = || vec![0f32; BLOCK * width];
        let hidden = layers.saturating_sub(1);
        Scratch {
            input: vec![0f32; BLOCK * 3],
            z: buf(),
            acts: (0..hidden).map(|_| buf()).collect(),
            derivs: if gradients { (0..hidden).map(|_| buf()).collect() } else { Vec::new() },
            grad_a: if gradients { buf() } else { Vec::new() },
            grad_b: if gradients { buf() } else { Vec::new() },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::sin_cos;

    #[test]
    fn sine_and_cosine_match_the_library_across_the_range() {
        let mut worst = 0f32;
        for i in -200_000..=200_000 {
            let x = i as f32 * 1e-3 + 0.000_37;
            let (s, c) = sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 2e-6, "largest error {worst}");
        // exact multiples and signs
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!((sin_cos(std::f32::consts::PI).1 + 1.0).abs() < 1e-6);
        assert!((sin_cos(-std::f32::consts::FRAC_PI_2).0 + 1.0).abs() < 1e-6);
    }
}
