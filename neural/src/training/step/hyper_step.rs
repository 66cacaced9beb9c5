//! The loss and full gradient of one fine-tuning / meta-learning step of the hypernetwork on
//! flat parameters: encoder -> heads -> one SIREN per pose (base weights plus the predicted
//! residual) -> IGR loss on the pose's points, plus MetaAvatar's residual regulariser; then
//! every adjoint back to the base SDF, the low-rank bases, the heads and (when it trains)
//! the encoder. `tests/train_gradients.rs` holds all of it to burn's autodiff.

use super::adam::Adam;
use super::blocks::BlockRunner;
use super::gemm::{Mat, gemm};
use super::heads::{
    EncoderPass, HeadPass, encoder_backward, encoder_forward, head_backward, head_forward,
};
use super::igr::IgrPoints;
use super::layout::{Block, HeadLayout, HyperLayout};
use super::weight_adam::weight_grad_adam;
use crate::model::hyper::HyperConfig;
use rayon::prelude::*;

/// The heads' output weights (all heads) from which `HyperGradient::step` fuses Adam into their
/// gradient's product: the paper preset's 84 M take it, the compact preset's do not. Small
/// heads stay in the caches, where the two passes cost less than the fused product's many row
/// streams (the compact step took 2-4 % more CPU fused).
const FUSED_ADAM_MIN_WEIGHTS: usize = 8 << 20;

/// One step's data: B poses, each with `surface + off` rows of points.
pub struct HyperBatch<'a> {
    /// Encoder inputs [B, input_len].
    pub inputs: &'a [f32],
    /// The points of each pose (surface rows first).
    pub points: Vec<&'a [[f32; 3]]>,
    pub loss: IgrPoints<'a>,
    /// MetaAvatar's residual regulariser weight (divided by the SDF's parameter count).
    pub residual_weight: f32,
}

/// Loss of a step: the total and the four logged IGR terms (on, normal, off, eikonal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepLoss {
    pub total: f32,
    pub terms: [f32; 4],
}

/// Buffers of the step, reused across steps.
pub struct HyperGradient {
    layout: HyperLayout,
    /// Heads with offsets relative to their own run of parameters.
    local_heads: Vec<HeadLayout>,
    head_runs: Vec<std::ops::Range<usize>>,
    runner: BlockRunner,
    pose_params: Vec<Vec<f32>>,
    residuals: Vec<Vec<f32>>,
    pose_grads: Vec<Vec<f32>>,
    head_passes: Vec<HeadPass>,
    d_outs: Vec<Vec<f32>>,
    encoder_pass: EncoderPass,
    cond: Vec<f32>,
    /// Whether `step` fuses Adam into the heads' output weights' gradient (wide heads only:
    /// [`FUSED_ADAM_MIN_WEIGHTS`]).
    fused_adam: bool,
}

fn rebase(b: &Block, base: usize) -> Block {
    Block { at: b.at - base, ..*b }
}

impl HyperGradient {
    pub fn new(config: &HyperConfig) -> HyperGradient {
        let layout = HyperLayout::new(config);
        let mut local_heads = Vec::new();
        let mut head_runs = Vec::new();
        for h in &layout.heads {
            let (start, end) = (h.w[0].at, h.beta[1].range().end);
            let r = |b: &Block| rebase(b, start);
            local_heads.push(HeadLayout {
                w: h.w.each_ref().map(r),
                b: h.b.each_ref().map(r),
                gamma: h.gamma.each_ref().map(r),
                beta: h.beta.each_ref().map(r),
            });
            head_runs.push(start..end);
        }
        let heads = layout.heads.len();
        let output_weights: usize = layout.heads.iter().map(|h| h.w[2].rows * h.w[2].cols).sum();
        HyperGradient {
            fused_adam: output_weights >= FUSED_ADAM_MIN_WEIGHTS,
            runner: BlockRunner::new(layout.sdf_shape.clone()),
            layout,
            local_heads,
            head_runs,
            pose_params: Vec::new(),
            residuals: Vec::new(),
            pose_grads: Vec::new(),
            head_passes: (0..heads).map(|_| HeadPass::default()).collect(),
            d_outs: vec![Vec::new(); heads],
            encoder_pass: EncoderPass::default(),
            cond: Vec::new(),
        }
    }

    pub fn layout(&self) -> &HyperLayout {
        &self.layout
    }

    /// `step` with Adam fused into the heads' output weights' gradient or not, whatever their
    /// size (the tests hold both ways to the same parameters on small networks).
    pub fn with_fused_adam(self, fused: bool) -> HyperGradient {
        HyperGradient { fused_adam: fused, ..self }
    }

    /// Loss of `batch` under `params` and its gradient into `grad` (overwritten, the layout's
    /// length). The encoder's gradient is only computed when `train_encoder` (else zero).
    pub fn compute(
        &mut self,
        params: &[f32],
        batch: &HyperBatch,
        train_encoder: bool,
        grad: &mut [f32],
    ) -> StepLoss {
        self.compute_but(params, batch, train_encoder, grad, true)
    }

    /// One training step: the loss of `batch` under `params`, then Adam's update of `params`
    /// with `groups`' rates (parameter ranges of the layout, as [`Adam::step`] takes them).
    /// The same parameters as [`Self::compute`] then [`Adam::step`], but wide heads' output
    /// weights (84 M of the paper preset's 85.6 M parameters) take Adam's update a tile at a
    /// time as their gradient is made, so that gradient is never stored, read back or
    /// cleared (the compact preset's small heads run the two passes:
    /// [`FUSED_ADAM_MIN_WEIGHTS`]). `grad` (the layout's length) holds every other
    /// parameter's gradient after it; the heads' output weights' part is left unspecified.
    pub fn step(
        &mut self,
        params: &mut [f32],
        batch: &HyperBatch,
        train_encoder: bool,
        grad: &mut [f32],
        adam: &mut Adam,
        groups: &[(std::ops::Range<usize>, f64)],
    ) -> StepLoss {
        if !self.fused_adam {
            let loss = self.compute(params, batch, train_encoder, grad);
            adam.step(params, grad, groups);
            return loss;
        }
        let loss = self.compute_but(params, batch, train_encoder, grad, false);
        let heads = &self.layout.heads;
        let fused: Vec<std::ops::Range<usize>> = heads.iter().map(|h| h.w[2].range()).collect();
        let poses = batch.points.len();
        let (passes, d_outs) = (&self.head_passes, &self.d_outs);
        adam.step_fused(params, grad, groups, &fused, &mut |i, p, g, m, v, step| {
            let w = &heads[i].w[2];
            let (x, d) = (passes[i].hidden(), &d_outs[i]);
            weight_grad_adam(x, d, (poses, w.rows, w.cols), p, m, v, g, step)
        });
        loss
    }

    /// [`Self::compute`], leaving the heads' output weights' gradient alone unless
    /// `output_weights`.
    fn compute_but(
        &mut self,
        params: &[f32],
        batch: &HyperBatch,
        train_encoder: bool,
        grad: &mut [f32],
        output_weights: bool,
    ) -> StepLoss {
        let lay = &self.layout;
        let shape = &lay.sdf_shape;
        let poses = batch.points.len();
        let input_len = lay.config.encoding.input_len();
        assert_eq!(batch.inputs.len(), poses * input_len, "one encoder input per pose");
        assert_eq!(params.len(), lay.len(), "parameters of another network");
        // Cleared but the heads' output weights, which `head_backward` writes whole (or
        // `step`'s Adam makes).
        let mut cleared = 0;
        for h in &lay.heads {
            let w = h.w[2].range();
            grad[cleared..w.start].fill(0.0);
            cleared = w.end;
        }
        grad[cleared..].fill(0.0);

        // Condition of every pose.
        let cond_len = lay.config.encoding.output_len();
        self.cond.resize(poses * cond_len, 0.0);
        match &lay.encoder {
            Some(e) => encoder_forward(
                e,
                params,
                batch.inputs,
                poses,
                &mut self.encoder_pass,
                &mut self.cond,
            ),
            None => self.cond.copy_from_slice(batch.inputs),
        }
        let cond = &self.cond;
        self.head_passes
            .par_iter_mut()
            .zip(&self.local_heads)
            .zip(&self.head_runs)
            .for_each(|((pass, h), run)| head_forward(h, &params[run.clone()], cond, poses, pass));

        // Each pose's SIREN: base + residual (U_l C or the full prediction).
        let base = &params[lay.sdf_range.clone()];
        for v in [&mut self.pose_params, &mut self.residuals, &mut self.pose_grads] {
            v.resize_with(poses, || vec![0f32; shape.len()]);
        }
        let (heads_out, layout) = (&self.head_passes, lay);
        let residual_sq: f64 = self.residuals[..poses]
            .par_iter_mut()
            .zip(&mut self.pose_params[..poses])
            .enumerate()
            .map(|(p, (res, pose))| {
                for l in 0..shape.layers() {
                    let (fan_in, fan_out) = shape.dims(l);
                    let out = &heads_out[l].out;
                    let width = out.len() / poses;
                    let row = &out[p * width..(p + 1) * width];
                    let coeffs = width - fan_out;
                    match layout.rank(l) {
                        Some(r) => {
                            let u = &params[layout.bases[l].range()];
                            gemm(
                                Mat::new(u, fan_in, r),
                                Mat::new(&row[..coeffs], r, fan_out),
                                0.0,
                                &mut res[shape.w_range(l)],
                            );
                        }
                        None => res[shape.w_range(l)].copy_from_slice(&row[..coeffs]),
                    }
                    res[shape.b_range(l)].copy_from_slice(&row[coeffs..]);
                }
                for ((w, b), r) in pose.iter_mut().zip(base).zip(res.iter()) {
                    *w = b + r;
                }
                res.iter().map(|v| (v * v) as f64).sum::<f64>()
            })
            .collect::<Vec<f64>>()
            .into_iter()
            .sum();
        let residual_sq = (residual_sq / poses as f64) as f32;

        // Every pose's SIREN over its points, on all cores.
        let pose_params: Vec<&[f32]> = self.pose_params.iter().map(|v| v.as_slice()).collect();
        let terms = self.runner.run(
            &pose_params,
            &batch.points,
            &batch.loss,
            &mut self.pose_grads[..poses],
        );

        // The base SDF collects every pose's gradient (the regulariser does not see it).
        const CHUNK: usize = 1 << 13;
        let pose_grads = &self.pose_grads[..poses];
        grad[lay.sdf_range.clone()].par_chunks_mut(CHUNK).enumerate().for_each(|(c, g)| {
            for pg in pose_grads {
                for (a, v) in g.iter_mut().zip(&pg[c * CHUNK..]) {
                    *a += v;
                }
            }
        });
        // Residual regulariser: coef sqrt(mean over poses of |residual|^2 + 1e-12).
        let coef = batch.residual_weight / shape.len() as f32;
        let root = (residual_sq + 1e-12).sqrt();
        let k_reg = coef / (poses as f32 * root);
        self.pose_grads[..poses].par_iter_mut().zip(&self.residuals).for_each(|(pg, res)| {
            for (g, r) in pg.iter_mut().zip(res) {
                *g += k_reg * r;
            }
        });

        // Adjoints of the heads' outputs (and the low-rank bases' gradient).
        for l in 0..shape.layers() {
            let (fan_in, fan_out) = shape.dims(l);
            let width = self.head_passes[l].out.len() / poses;
            let coeffs = width - fan_out;
            let d_out = &mut self.d_outs[l];
            d_out.resize(poses * width, 0.0);
            for p in 0..poses {
                let gw = &self.pose_grads[p][shape.w_range(l)];
                let d_row = &mut d_out[p * width..(p + 1) * width];
                match lay.rank(l) {
                    Some(r) => {
                        let u_block = lay.bases[l];
                        let c = &self.head_passes[l].out[p * width..p * width + coeffs];
                        // d C = U^T dW; d U += dW C^T.
                        gemm(
                            Mat::new(&params[u_block.range()], fan_in, r).t(),
                            Mat::new(gw, fan_in, fan_out),
                            0.0,
                            &mut d_row[..coeffs],
                        );
                        gemm(
                            Mat::new(gw, fan_in, fan_out),
                            Mat::new(c, r, fan_out).t(),
                            1.0,
                            &mut grad[u_block.range()],
                        );
                    }
                    None => d_row[..coeffs].copy_from_slice(gw),
                }
                d_row[coeffs..].copy_from_slice(&self.pose_grads[p][shape.b_range(l)]);
            }
        }

        // Heads (each writes its own run of the gradient), then the encoder.
        let mut d_conds = vec![
            vec![0f32; poses * cond_len];
            if train_encoder { self.local_heads.len() } else { 0 }
        ];
        {
            let (_, rest) = grad.split_at_mut(lay.heads_range.start);
            let (heads_grad, _) = rest.split_at_mut(lay.heads_range.len());
            let mut runs: Vec<&mut [f32]> = Vec::new();
            let mut remaining = heads_grad;
            for run in &self.head_runs {
                let (this, next) = remaining.split_at_mut(run.len());
                runs.push(this);
                remaining = next;
            }
            let mut d_cond_refs: Vec<Option<&mut [f32]>> =
                d_conds.iter_mut().map(|d| Some(d.as_mut_slice())).collect();
            d_cond_refs.resize_with(self.local_heads.len(), || None);
            runs.into_par_iter()
                .zip(d_cond_refs)
                .zip(&self.local_heads)
                .zip(&self.head_runs)
                .zip(&self.head_passes)
                .zip(&self.d_outs)
                .for_each(|(((((g, d_cond), h), run), pass), d_out)| {
                    let p = &params[run.clone()];
                    head_backward(h, p, cond, pass, d_out, g, d_cond, output_weights)
                });
        }
        if train_encoder && let Some(e) = &lay.encoder {
            let mut d_cond = vec![0f32; poses * cond_len];
            for d in &d_conds {
                for (a, v) in d_cond.iter_mut().zip(d) {
                    *a += v;
                }
            }
            encoder_backward(e, params, &self.encoder_pass, &d_cond, grad);
        }

        let total = terms.total() as f32 + coef * root;
        let t = terms.terms;
        StepLoss { total, terms: [t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32] }
    }
}
