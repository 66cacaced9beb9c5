//! One group's step of Adam as the kernels see it: the decay rates and the step's factors.
//! Data only, so the kernels can finish a product with Adam's update (`weight_adam.rs`)
//! without depending on the optimiser (`adam.rs`), which calls them.

pub const BETA1: f32 = 0.9;
pub const BETA2: f32 = 0.999;

/// Adam's decay rates of the first and second moments.
pub const BETAS: [f32; 2] = [BETA1, BETA2];

/// One group's step of Adam: what the update of a parameter needs besides its gradient and
/// moments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdamStep {
    /// The group's first step: the moments start from this gradient (as burn's do).
    pub first: bool,
    pub lr: f32,
    /// sqrt(1 - beta2^t) / (1 - beta1^t).
    pub factor: f32,
    /// epsilon sqrt(1 - beta2^t).
    pub eps: f32,
}
