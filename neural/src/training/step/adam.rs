//! Adam on flat parameter vectors, step for step the update of burn 0.22's `AdamConfig`
//! defaults (beta1 0.9, beta2 0.999, epsilon 1e-5, no weight decay), so fits on the training
//! path follow the same trajectory as the burn reference. Each parameter group (a range of
//! the flat vector) has its own learning rate and step count; a zero rate freezes the group.

use rayon::prelude::*;
use std::ops::Range;

const EPSILON: f32 = 1e-5;

pub use super::adam_step::{AdamStep, BETAS};
use super::adam_step::{BETA1, BETA2};

impl AdamStep {
    /// Parameters `p` and moments `m`, `v` updated from the gradient `g`, element by element
    /// (bit for bit the same on every kernel path and in any chunks).
    pub fn apply(&self, p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32]) {
        super::elementwise::adam_update(
            p,
            g,
            m,
            v,
            BETAS,
            self.first,
            self.lr,
            self.factor,
            self.eps,
        )
    }
}

/// What [`Adam::step_fused`] calls for each fused range: its index, then its parameters,
/// gradient buffer (free to use as scratch: the step does not read it), first and second
/// moments, and the group's step.
pub type FusedUpdate<'a> =
    dyn FnMut(usize, &mut [f32], &mut [f32], &mut [f32], &mut [f32], AdamStep) + 'a;

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
            if let Some((g, step)) = self.advance(range, *rate) {
                update(&mut params[range.clone()], &grad[range.clone()], &mut g.m, &mut g.v, step);
            }
        }
    }

    /// [`Adam::step`], but the parameters in `fused` (ranges, each inside one group, in
    /// increasing order) are updated by `update_fused` instead, which makes their gradient itself
    /// (`HyperGradient::step`: the heads' output weights, whose gradient is never stored);
    /// `grad` is not read there. A fused range in a frozen group (rate 0) or in none is left
    /// alone. The same parameters and moments as [`Adam::step`] given those gradients.
    pub fn step_fused(
        &mut self,
        params: &mut [f32],
        grad: &mut [f32],
        groups: &[(Range<usize>, f64)],
        fused: &[Range<usize>],
        update_fused: &mut FusedUpdate,
    ) {
        for (range, rate) in groups {
            let Some((g, step)) = self.advance(range, *rate) else { continue };
            let mut at = range.start;
            for (i, f) in fused.iter().enumerate() {
                if f.start < range.start || f.end > range.end {
                    assert!(
                        f.end <= range.start || f.start >= range.end,
                        "a fused range across groups"
                    );
                    continue;
                }
                assert!(f.start >= at, "fused ranges in increasing order");
                let (lo, hi) = (
                    at - range.start..f.start - range.start,
                    f.start - range.start..f.end - range.start,
                );
                update(
                    &mut params[at..f.start],
                    &grad[at..f.start],
                    &mut g.m[lo.clone()],
                    &mut g.v[lo],
                    step,
                );
                update_fused(
                    i,
                    &mut params[f.clone()],
                    &mut grad[f.clone()],
                    &mut g.m[hi.clone()],
                    &mut g.v[hi],
                    step,
                );
                at = f.end;
            }
            let rest = at - range.start..range.len();
            update(
                &mut params[at..range.end],
                &grad[at..range.end],
                &mut g.m[rest.clone()],
                &mut g.v[rest],
                step,
            );
        }
    }

    /// The state of `range`'s group (made at its first step) and its next step, or None when
    /// the group is frozen or empty.
    fn advance(&mut self, range: &Range<usize>, rate: f64) -> Option<(&mut Group, AdamStep)> {
        if rate == 0.0 || range.is_empty() {
            return None;
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
        let bc2 = (1.0 - BETA2.powi(g.time)).sqrt();
        let step = AdamStep {
            first: g.time == 1,
            lr: rate as f32,
            factor: bc2 / (1.0 - BETA1.powi(g.time)),
            eps: EPSILON * bc2,
        };
        Some((g, step))
    }
}

/// `step` over p, g, m, v (the same length) on all cores.
pub(super) fn update(p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32], step: AdamStep) {
    const CHUNK: usize = 1 << 14;
    p.par_chunks_mut(CHUNK)
        .zip(g.par_chunks(CHUNK))
        .zip(m.par_chunks_mut(CHUNK))
        .zip(v.par_chunks_mut(CHUNK))
        .for_each(|(((p, g), m), v)| step.apply(p, g, m, v));
}
