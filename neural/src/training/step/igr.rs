//! The IGR loss of `loss::igr_loss` per point, with its adjoints, for the training path.
//! A step's points come in groups (one per pose): each group's first `surface` rows lie on
//! the surface (with a target normal), the next `off` rows off it (with an optional sign
//! from the prior). Every term is a mean over a fixed count, so blocks of points are scored
//! independently and their shares add up.

use super::siren_grad::{LossTerms, PointLoss};
use crate::training::loss::IgrWeights;

pub struct IgrPoints<'a> {
    pub weights: IgrWeights,
    pub prior_weight: f32,
    pub groups: usize,
    pub surface: usize,
    pub off: usize,
    /// Target normals of the surface rows, group-major [groups * surface].
    pub normals: &'a [[f32; 3]],
    /// +1 outside, -1 inside, 0 unknown for the off-surface rows [groups * off].
    pub signs: Option<&'a [f32]>,
}

/// sign(x) with sign(0) = 0, as burn differentiates |x|.
fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

impl PointLoss for IgrPoints<'_> {
    fn adjoint(
        &self,
        group: usize,
        first: usize,
        f: &[f32],
        g: &[f32],
        d_f: &mut [f32],
        d_g: &mut [f32],
    ) -> LossTerms {
        let w = &self.weights;
        let s_count = (self.groups * self.surface).max(1) as f32;
        let o_count = (self.groups * self.off).max(1) as f32;
        let all = (self.groups * (self.surface + self.off)) as f32;
        let (k_on, k_normal, k_off, k_eik, k_prior) = (
            w.surface / s_count,
            w.normal / s_count,
            w.off_surface / o_count,
            w.eikonal / all,
            self.prior_weight / o_count,
        );
        let mut t = [0f64; 5];
        for (i, (&fv, gv)) in f.iter().zip(g.chunks_exact(3)).enumerate() {
            let row = first + i;
            let norm = (gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]).sqrt();
            // Eikonal |(|g| - 1)| on every point.
            t[3] += (k_eik * (norm - 1.0).abs()) as f64;
            let de = k_eik * sign(norm - 1.0) / norm;
            let mut dg = [de * gv[0], de * gv[1], de * gv[2]];
            let df;
            if row < self.surface {
                t[0] += (k_on * fv.abs()) as f64;
                df = k_on * sign(fv);
                if w.normal != 0.0 {
                    let n = self.normals[group * self.surface + row];
                    let n_norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    let dot = gv[0] * n[0] + gv[1] * n[1] + gv[2] * n[2];
                    let den = norm * n_norm + 1e-8;
                    let cos = dot / den;
                    t[1] += (k_normal * (1.0 - cos)) as f64;
                    // d cos / d g = n / den - dot n_norm g / (|g| den^2)
                    let a = -k_normal / den;
                    let b = k_normal * dot * n_norm / (norm * den * den);
                    for k in 0..3 {
                        dg[k] += a * n[k] + b * gv[k];
                    }
                }
            } else {
                let e = (-w.alpha * fv.abs()).exp();
                t[2] += (k_off * e) as f64;
                let mut d = -k_off * w.alpha * e * sign(fv);
                if let Some(signs) = self.signs {
                    let s = signs[group * self.off + row - self.surface];
                    let wrong = -s * fv;
                    if wrong > 0.0 {
                        t[4] += (k_prior * wrong) as f64;
                        d -= k_prior * s;
                    }
                }
                df = d;
            }
            d_f[i] = df;
            d_g[i * 3..i * 3 + 3].copy_from_slice(&dg);
        }
        LossTerms { terms: t }
    }
}
