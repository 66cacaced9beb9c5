//! Adam on flat parameter vectors, step for step the update of burn 0.22's `AdamConfig`
//! defaults (beta1 0.9, beta2 0.999, epsilon 1e-5, no weight decay), so fits on the training
//! path follow the same trajectory as the burn reference. Each parameter group (a range of
//! the flat vector) has its own learning rate and step count; a zero rate freezes the group.

use rayon::prelude::*;
use std::ops::Range;

const BETA1: f32 = 0.9;
const BETA2: f32 = 0.999;
const EPSILON: f32 = 1e-5;

struct Group {
    range: Range<usize>,
    m: Vec<f32>,
    v: Vec<f32>,
    time: i32,
}

#[derive(Default)]
pub struct Adam {
    groups: Vec<Group>,
}

impl Adam {
    /// One step of every group: `rates[i]` is the rate of `ranges[i]`.
    pub fn step(&mut self, params: &mut [f32], grad: &[f32], groups: &[(Range<usize>, f64)]) {
        for (range, rate) in groups {
            if *rate == 0.0 || range.is_empty() {
                continue;
            }
            let k = match self.groups.iter().position(|g| g.range == *range) {
                Some(k) => k,
                None => {
                    self.groups.push(Group {
                        range: range.clone(),
                        m: vec![0f32; range.len()],
                        v: vec![0f32; range.len()],
                        time: 0,
                    });
                    self.groups.len() - 1
                }
            };
            let g = &mut self.groups[k];
            g.time += 1;
            let first = g.time == 1;
            let bc2 = (1.0 - BETA2.powi(g.time)).sqrt();
            let factor = bc2 / (1.0 - BETA1.powi(g.time));
            let eps = EPSILON * bc2;
            let lr = *rate as f32;
            const CHUNK: usize = 1 << 14;
            params[range.clone()]
                .par_chunks_mut(CHUNK)
                .zip(grad[range.clone()].par_chunks(CHUNK))
                .zip(g.m.par_chunks_mut(CHUNK))
                .zip(g.v.par_chunks_mut(CHUNK))
                .for_each(|(((p, gr), m), v)| {
                    super::elementwise::adam_update(
                        p,
                        gr,
                        m,
                        v,
                        [BETA1, BETA2],
                        first,
                        lr,
                        factor,
                        eps,
                    )
                });
        }
    }
}
