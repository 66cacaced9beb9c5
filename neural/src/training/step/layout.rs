//! Where every tensor of a hypernetwork sits in its flat parameter vector: the burn module's
//! visit order (`params::flatten`), so a flat vector converts to and from `HyperNet` without
//! reshuffling. Encoder, heads, low-rank bases, base SDF, in that order.

use super::siren_grad::SirenShape;
use crate::model::encoder::{BONE_FEATURES, BONE_INPUTS, PoseEncoding};
use crate::model::hyper::HyperConfig;
use avatar_core::body::skeleton::NUM_JOINTS;
use std::ops::Range;

/// A run of parameters: offset and [rows, cols] (cols 1 for vectors).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    pub at: usize,
    pub rows: usize,
    pub cols: usize,
}

impl Block {
    pub fn range(&self) -> Range<usize> {
        self.at..self.at + self.rows * self.cols
    }
}

struct Cursor(usize);

impl Cursor {
    fn take(&mut self, rows: usize, cols: usize) -> Block {
        let b = Block { at: self.0, rows, cols };
        self.0 += rows * cols;
        b
    }
}

/// The hierarchical bone encoder's tensors (empty for the quaternion encoding).
#[derive(Debug, Clone, PartialEq)]
pub struct EncoderLayout {
    pub prior_w: Block,
    pub prior_b: Block,
    pub w1: Vec<Block>,
    pub b1: Vec<Block>,
    pub w2: Vec<Block>,
    pub b2: Vec<Block>,
}

/// One head: Linear -> LayerNorm -> ReLU twice, then the output layer.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadLayout {
    pub w: [Block; 3],
    pub b: [Block; 3],
    pub gamma: [Block; 2],
    pub beta: [Block; 2],
}

#[derive(Debug, Clone, PartialEq)]
pub struct HyperLayout {
    pub config: HyperConfig,
    pub encoder: Option<EncoderLayout>,
    pub heads: Vec<HeadLayout>,
    /// U_l [in, rank] per layer (empty for full residuals).
    pub bases: Vec<Block>,
    /// The base SDF's parameters start here; `sdf_shape` gives offsets within it.
    pub sdf_at: usize,
    pub sdf_shape: SirenShape,
    /// Parameter groups (each has its own learning rate).
    pub encoder_range: Range<usize>,
    pub heads_range: Range<usize>,
    pub bases_range: Range<usize>,
    pub sdf_range: Range<usize>,
}

impl HyperLayout {
    pub fn new(config: &HyperConfig) -> HyperLayout {
        let mut c = Cursor(0);
        let encoder = (config.encoding == PoseEncoding::Hierarchical).then(|| {
            let n = BONE_INPUTS + BONE_FEATURES;
            let prior_w = c.take(NUM_JOINTS * 12, BONE_FEATURES);
            let prior_b = c.take(BONE_FEATURES, 1);
            let w1 = (0..NUM_JOINTS).map(|_| c.take(n, n)).collect();
            let b1 = (0..NUM_JOINTS).map(|_| c.take(n, 1)).collect();
            let w2 = (0..NUM_JOINTS).map(|_| c.take(n, BONE_FEATURES)).collect();
            let b2 = (0..NUM_JOINTS).map(|_| c.take(BONE_FEATURES, 1)).collect();
            EncoderLayout { prior_w, prior_b, w1, b1, w2, b2 }
        });
        let encoder_range = 0..c.0;
        let (cond, hidden) = (config.encoding.output_len(), config.head_hidden);
        let heads = config
            .layer_shapes()
            .into_iter()
            .map(|(fan_in, fan_out)| {
                let out = head_outputs(config, fan_in, fan_out);
                let w = [c.take(cond, hidden), c.take(hidden, hidden), c.take(hidden, out)];
                let b = [c.take(hidden, 1), c.take(hidden, 1), c.take(out, 1)];
                let gamma = [c.take(hidden, 1), c.take(hidden, 1)];
                let beta = [c.take(hidden, 1), c.take(hidden, 1)];
                HeadLayout { w, b, gamma, beta }
            })
            .collect();
        let heads_range = encoder_range.end..c.0;
        let bases = config
            .layer_shapes()
            .into_iter()
            .filter_map(|(fan_in, _)| rank(config, fan_in).map(|r| c.take(fan_in, r)))
            .collect();
        let bases_range = heads_range.end..c.0;
        let sdf_shape = SirenShape::of(&config.siren);
        let sdf_at = c.0;
        let sdf_range = sdf_at..sdf_at + sdf_shape.len();
        HyperLayout {
            config: *config,
            encoder,
            heads,
            bases,
            sdf_at,
            sdf_shape,
            encoder_range,
            heads_range,
            bases_range,
            sdf_range,
        }
    }

    pub fn len(&self) -> usize {
        self.sdf_range.end
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Rank of layer `l`'s residual (None: full).
    pub fn rank(&self, l: usize) -> Option<usize> {
        rank(&self.config, self.sdf_shape.dims(l).0)
    }
}

fn rank(config: &HyperConfig, fan_in: usize) -> Option<usize> {
    config.rank.map(|r| r.min(fan_in))
}

fn head_outputs(config: &HyperConfig, fan_in: usize, fan_out: usize) -> usize {
    match rank(config, fan_in) {
        Some(r) => r * fan_out + fan_out,
        None => fan_in * fan_out + fan_out,
    }
}
