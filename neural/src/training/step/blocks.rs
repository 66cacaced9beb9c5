//! Spreads a step's points over the cores. Every group (pose) is cut into a few parts (one,
//! or more when there are fewer groups than threads); a part runs `siren_backward` over its
//! blocks of at most `BLOCK` points one after the other, accumulating into its own gradient,
//! on one of rayon's threads with that thread's scratch, so a thread's activations stay in
//! its cache from block to block. Parts, scratch and buffers are kept across steps (no
//! allocation in the loop once the largest step has run).

use super::siren_grad::{
    LossTerms, PointLoss, SirenScratch, SirenShape, siren_backward, transpose_weights,
};
use rayon::prelude::*;
use std::sync::Mutex;

/// Points per block: a block's activations (16 buffers of 128 x 128 floats for the compact
/// SIREN) stay in L2 from the forward pass to the reverse one. The paper's SIREN (24 buffers
/// of 128 x 256) measured no faster with 64.
pub const BLOCK: usize = 128;

struct Part {
    grad: Vec<f32>,
    group: usize,
    first: usize,
    rows: usize,
    terms: LossTerms,
}

pub struct BlockRunner {
    shape: SirenShape,
    parts: Vec<Part>,
    /// One scratch per thread of the pool (by rayon's thread index).
    scratch: Vec<Mutex<SirenScratch>>,
    /// Every group's weights transposed (`transpose_weights`), shared by its blocks.
    wt: Vec<Vec<Vec<f32>>>,
}

impl BlockRunner {
    pub fn new(shape: SirenShape) -> BlockRunner {
        BlockRunner { shape, parts: Vec::new(), scratch: Vec::new(), wt: Vec::new() }
    }

    pub fn shape(&self) -> &SirenShape {
        &self.shape
    }

    /// Loss terms of every group and the gradient of each group's SIREN into `grads[group]`
    /// (overwritten). `params[g]`: group g's SIREN; `points[g]`: its rows.
    pub fn run(
        &mut self,
        params: &[&[f32]],
        points: &[&[[f32; 3]]],
        loss: &dyn PointLoss,
        grads: &mut [Vec<f32>],
    ) -> LossTerms {
        let threads = rayon::current_num_threads().max(1);
        let per_group = threads.div_ceil(points.len().max(1));
        let mut k = 0;
        for (group, pts) in points.iter().enumerate() {
            // Parts of whole blocks, as even as the blocks allow.
            let blocks = pts.len().div_ceil(BLOCK);
            let parts = per_group.min(blocks);
            let mut first = 0;
            for p in 0..parts {
                let end = (blocks * (p + 1) / parts * BLOCK).min(pts.len());
                if k == self.parts.len() {
                    self.parts.push(Part {
                        grad: vec![0f32; self.shape.len()],
                        group,
                        first,
                        rows: 0,
                        terms: LossTerms::default(),
                    });
                }
                let part = &mut self.parts[k];
                (part.group, part.first, part.rows) = (group, first, end - first);
                first = end;
                k += 1;
            }
        }
        let shape = &self.shape;
        while self.scratch.len() < threads {
            self.scratch.push(Mutex::new(SirenScratch::new(shape, BLOCK)));
        }
        self.wt.resize_with(points.len(), Vec::new);
        self.wt.par_iter_mut().zip(params).for_each(|(wt, p)| transpose_weights(shape, p, wt));
        let (wt, scratch) = (&self.wt, &self.scratch);
        self.parts[..k].par_iter_mut().for_each(|part| {
            let slot = rayon::current_thread_index().unwrap_or(0) % scratch.len();
            // Only this thread takes its slot (a part runs no nested parallel work).
            let mut s = scratch[slot].lock().unwrap_or_else(|e| e.into_inner());
            part.terms = LossTerms::default();
            let mut first = part.first;
            while first < part.first + part.rows {
                let rows = BLOCK.min(part.first + part.rows - first);
                let pts = &points[part.group][first..first + rows];
                let t = siren_backward(
                    shape,
                    params[part.group],
                    &wt[part.group],
                    pts,
                    loss,
                    part.group,
                    first,
                    &mut s,
                    &mut part.grad,
                    first > part.first,
                );
                part.terms.add(&t);
                first += rows;
            }
        });
        let mut terms = LossTerms::default();
        for part in &self.parts[..k] {
            terms.add(&part.terms);
        }
        // Each group's parts (consecutive) summed into its gradient, the groups on all cores.
        let parts = &self.parts[..k];
        grads.par_iter_mut().enumerate().for_each(|(group, g)| {
            g.resize(shape.len(), 0.0);
            let mut mine = parts.iter().filter(|p| p.group == group && p.rows > 0);
            match mine.next() {
                Some(p) => g.copy_from_slice(&p.grad),
                None => g.fill(0.0),
            }
            for p in mine {
                for (a, v) in g.iter_mut().zip(&p.grad) {
                    *a += v;
                }
            }
        });
        terms
    }
}
