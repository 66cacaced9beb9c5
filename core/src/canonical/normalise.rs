//! The canonical space normalisation to [-1, 1]^3 (MetaAvatar's appendix, after the reference
//! implementation): centre = mean of the minimally clothed canonical body; one scale for all
//! axes (aspect kept) from the min and max over all axes of the centred body; 5% padding; then
//! `2 ((p - centre - min + pad) / range / 1.1 - 0.5)`, so the body spans about +-0.909.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Plausible range of a normalisation (metres): from a small child to well beyond any adult.
pub const NORMALISATION_RANGE: std::ops::RangeInclusive<f32> = 0.2..=5.0;

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Normalisation {
    pub centre: Vec3,
    pub coord_min: f32,
    pub range: f32,
}

impl Normalisation {
    pub fn from_body(canonical_body: &[Vec3]) -> Normalisation {
        let centre =
            canonical_body.iter().copied().sum::<Vec3>() / canonical_body.len().max(1) as f32;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for p in canonical_body {
            let c = *p - centre;
            lo = lo.min(c.min_element());
            hi = hi.max(c.max_element());
        }
        Normalisation { centre, coord_min: lo, range: (hi - lo).max(1e-6) }
    }

    /// Refuse a normalisation no body gives: non-finite values, a range (the body's largest
    /// extent, metres) outside [`NORMALISATION_RANGE`], a centre beyond 1 km.
    pub fn validate(&self) -> crate::Result<()> {
        let bad = |m: String| Err(crate::Error::invalid(format!("normalisation: {m}")));
        if !NORMALISATION_RANGE.contains(&self.range) {
            return bad(format!(
                "range {} m is not a body's size ({} to {} m)",
                self.range,
                NORMALISATION_RANGE.start(),
                NORMALISATION_RANGE.end()
            ));
        }
        if !(self.centre.is_finite() && self.centre.length() <= 1000.0) {
            return bad(format!("centre {} is not finite or beyond 1 km", self.centre));
        }
        if !(self.coord_min.is_finite() && self.coord_min.abs() <= self.range) {
            return bad(format!(
                "coord_min {} does not fit its range {}",
                self.coord_min, self.range
            ));
        }
        Ok(())
    }

    fn pad(&self) -> f32 {
        0.05 * self.range
    }

    /// Metres (canonical body space) -> normalised [-1, 1]^3.
    pub fn to_unit(&self, p: Vec3) -> Vec3 {
        ((p - self.centre - Vec3::splat(self.coord_min) + Vec3::splat(self.pad()))
            / self.range
            / 1.1
            - Vec3::splat(0.5))
            * 2.0
    }

    /// Normalised -> metres.
    pub fn from_unit(&self, q: Vec3) -> Vec3 {
        (q * 0.5 + Vec3::splat(0.5)) * 1.1 * self.range - Vec3::splat(self.pad())
            + Vec3::splat(self.coord_min)
            + self.centre
    }

    /// Metres per normalised unit (distances and SDF values scale by this).
    pub fn metres_per_unit(&self) -> f32 {
        0.55 * self.range
    }
}
