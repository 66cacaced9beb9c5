//! The IGR loss of MetaAvatar (weights from the reference implementation): on-surface |f|,
//! a cosine normal term (a plain dot product would be unbounded below), off-surface
//! exp(-alpha |f|), and the eikonal term on all points.

use burn::tensor::Tensor;

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct IgrWeights {
    pub surface: f32,
    pub normal: f32,
    pub off_surface: f32,
    pub alpha: f32,
    pub eikonal: f32,
}

impl Default for IgrWeights {
    fn default() -> Self {
        IgrWeights { surface: 3e3, normal: 1e2, off_surface: 1e2, alpha: 100.0, eikonal: 5e1 }
    }
}

impl IgrWeights {
    /// Fine-tuning on depth points: no normal term. Normals estimated from depth are noisy, and
    /// the reference fine-tunes without them; at 8 frames this raised NC by about 0.007 for both
    /// the MetaAvatar and the static meta-SDF (docs/decisions.md). Meta-training keeps the term
    /// (its points are exact surface samples).
    pub fn depth() -> Self {
        IgrWeights { normal: 0.0, ..IgrWeights::default() }
    }
}

/// Terms of one evaluation (for logging), and their weighted sum as a tensor to differentiate.
pub struct IgrLoss {
    pub total: Tensor<1>,
    pub terms: [f32; 4],
}

/// `f`, `grad`: network outputs for [surface points; off-surface points] stacked, the first
/// `surface` rows on the surface with target `normals` [surface, 3].
/// `prior`: for each off-surface point, +1 where it must be outside, -1 inside, 0 unknown
/// (PINA's off-surface prior from the body's SDF, for regions no camera saw); weighted by
/// `prior_weight`, penalising the wrong sign linearly.
#[allow(clippy::too_many_arguments)]
pub fn igr_loss(
    f: Tensor<2>,
    grad: Tensor<2>,
    normals: Tensor<2>,
    surface: usize,
    w: &IgrWeights,
    prior: Option<(Tensor<2>, f32)>,
    with_terms: bool,
) -> IgrLoss {
    let n = f.dims()[0];
    let f_s = f.clone().slice([0..surface, 0..1]);
    let f_o = f.slice([surface..n, 0..1]);
    let g_s = grad.clone().slice([0..surface, 0..3]);
    let on = f_s.abs().mean() * w.surface;
    // Without a weight the term is not built at all (fine-tuning on depth: a cheaper step).
    let normal = if w.normal == 0.0 {
        Tensor::zeros([1], &normals.device())
    } else {
        let dot = (g_s.clone() * normals.clone()).sum_dim(1);
        let g_norm = (g_s.clone() * g_s).sum_dim(1).sqrt();
        let n_norm = (normals.clone() * normals).sum_dim(1).sqrt();
        let cos = dot / (g_norm * n_norm + 1e-8);
        (cos.neg() + 1.0).mean() * w.normal
    };
    let off = (f_o.clone().abs() * (-w.alpha)).exp().mean() * w.off_surface;
    let prior_term =
        prior.map(|(signs, weight)| (f_o * signs.neg()).clamp_min(0.0).mean() * weight);
    let all_norm = (grad.clone() * grad).sum_dim(1).sqrt();
    let eik = (all_norm - 1.0).abs().mean() * w.eikonal;
    let terms = if with_terms {
        [scalar(&on), scalar(&normal), scalar(&off), scalar(&eik)]
    } else {
        [f32::NAN; 4]
    };
    let total = on + normal + off + eik;
    let total = match prior_term {
        Some(p) => total + p,
        None => total,
    };
    IgrLoss { total, terms }
}

pub fn scalar(t: &Tensor<1>) -> f32 {
    t.to_data().as_slice::<f32>().map(|s| s[0]).unwrap_or(f32::NAN)
}
