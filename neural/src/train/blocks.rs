//! Spreads a step's points over the cores: every group (pose) is cut into blocks of at most
//! `BLOCK` points, each block runs `siren_backward` into its own gradient buffer on rayon's
//! threads, and the blocks of a group are summed. Blocks, their scratch and their buffers are
//! kept across steps (no allocation in the loop once the largest step has run).

use super::siren_grad::{siren_backward, transpose_weights, LossTerms, PointLoss, SirenScratch, SirenShape};
use rayon::prelude::*;

/// Points per block: a 128-wide block's activations stay in L2.
pub const BLOCK: usize = 256;

struct Block {
    scratch: SirenScratch,
    grad: Vec<f32>,
    group: usize,
    first: usize,
    rows: usize,
    terms: LossTerms,
}

pub struct BlockRunner {
    shape: SirenShape,
    blocks: Vec<Block>,
    /// Every group's weights transposed (`transpose_weights`), shared by its blocks.
    wt: Vec<Vec<Vec<f32>>>,
}

impl BlockRunner {
    pub fn new(shape: SirenShape) -> BlockRunner {
        BlockRunner { shape, blocks: Vec::new(), wt: Vec::new() }
    }

    pub fn shape(&self) -> &SirenShape {
        &self.shape
    }

    /// Loss terms of every group and the gradient of each group's SIREN into `grads[group]`
    /// (overwritten). `params[g]`: group g's SIREN; `points[g]`: its rows.
    pub fn run(&mut self, params: &[&[f32]], points: &[&[[f32; 3]]], loss: &dyn PointLoss, grads: &mut [Vec<f32>]) -> LossTerms {
        let mut k = 0;
        for (group, pts) in points.iter().enumerate() {
            let mut first = 0;
            while first < pts.len() {
                let rows = BLOCK.min(pts.len() - first);
                if k == self.blocks.len() {
                    self.blocks.push(Block { scratch: SirenScratch::new(&self.shape, BLOCK), grad: vec![0f32; self.shape.len()], group, first, rows, terms: LossTerms::default() });
                }
                let b = &mut self.blocks[k];
                (b.group, b.first, b.rows) = (group, first, rows);
                first += rows;
                k += 1;
            }
        }
        let shape = &self.shape;
        self.wt.resize_with(points.len(), Vec::new);
        self.wt.par_iter_mut().zip(params).for_each(|(wt, p)| transpose_weights(shape, p, wt));
        let wt = &self.wt;
        self.blocks[..k].par_iter_mut().for_each(|b| {
            b.grad.fill(0.0);
            let pts = &points[b.group][b.first..b.first + b.rows];
            b.terms = siren_backward(shape, params[b.group], &wt[b.group], pts, loss, b.group, b.first, &mut b.scratch, &mut b.grad);
        });
        let mut terms = LossTerms::default();
        for g in grads.iter_mut() {
            g.resize(shape.len(), 0.0);
            g.fill(0.0);
        }
        for b in &self.blocks[..k] {
            terms.add(&b.terms);
            for (a, v) in grads[b.group].iter_mut().zip(&b.grad) {
                *a += v;
            }
        }
        terms
    }
}
