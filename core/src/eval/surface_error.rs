//! Where surfaces are wrong, not only by how much on average: on area-uniform samples of both
//! surfaces (the Chamfer samples), each measured to the other surface,
//! - spurious share: predicted samples farther than 2 cm from the true surface (surface the
//!   avatar adds: sheets, blobs, a skirt closed into a bell);
//! - missing share: true samples farther than 2 cm from the predicted surface (surface the
//!   avatar lacks);
//! - p99 (cm): the 99th percentile of the distances of both sample sets together.
//!
//! Each is reported for the whole surface and for the clothed region: the samples whose nearest
//! ground-truth vertex a garment covers (`Regions::cloth`), on either side.

use serde::{Deserialize, Serialize};

/// Metres to centimetres.
pub const CM: f32 = 100.0;

/// The distance (metres) of each sample of one surface to the other surface, and whether the
/// sample lies in the clothed region.
#[derive(Debug, Clone, Default)]
pub struct SampleDistances {
    pub distance: Vec<f32>,
    pub clothed: Vec<bool>,
}

impl SampleDistances {
    fn clothed_only(&self) -> Vec<f32> {
        self.distance.iter().zip(&self.clothed).filter(|(_, c)| **c).map(|(d, _)| *d).collect()
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SurfaceErrors {
    /// Share (0-1) of the predicted surface farther than the threshold from the truth.
    pub spurious: f32,
    /// Share (0-1) of the true surface farther than the threshold from the prediction.
    pub missing: f32,
    /// 99th percentile of all sample distances, both directions (cm).
    pub p99_cm: f32,
}

/// Shares beyond `far` (metres) and the 99th percentile; an empty side gives share 0.
pub fn surface_errors(pred_to_gt: &[f32], gt_to_pred: &[f32], far: f32) -> SurfaceErrors {
    let share = |v: &[f32]| {
        if v.is_empty() {
            0.0
        } else {
            v.iter().filter(|&&d| d > far).count() as f32 / v.len() as f32
        }
    };
    let mut all: Vec<f32> = pred_to_gt.iter().chain(gt_to_pred).copied().collect();
    SurfaceErrors {
        spurious: share(pred_to_gt),
        missing: share(gt_to_pred),
        p99_cm: percentile(&mut all, 0.99) * CM,
    }
}

/// The whole-surface and the clothed-region errors.
pub fn region_errors(
    pred: &SampleDistances,
    gt: &SampleDistances,
    far: f32,
) -> (SurfaceErrors, SurfaceErrors) {
    (
        surface_errors(&pred.distance, &gt.distance, far),
        surface_errors(&pred.clothed_only(), &gt.clothed_only(), far),
    )
}

/// The `q` quantile (0-1) by nearest rank; 0 for no values. Reorders `v`.
pub fn percentile(v: &mut [f32], q: f32) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let k = ((q * v.len() as f32).ceil() as usize).clamp(1, v.len()) - 1;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::super::metrics::{MetricOptions, Regions, evaluate_frame};
    use super::*;
    use crate::mesh::TriMesh;
    use crate::mesh::extract::{ExtractOptions, extract};
    use glam::Vec3;

    const R: f32 = 0.3;

    fn sphere(center: Vec3) -> TriMesh {
        let opts =
            ExtractOptions::new(center - Vec3::splat(R * 1.3), center + Vec3::splat(R * 1.3), 64);
        extract(|p: &[Vec3]| p.iter().map(|x| x.distance(center) - R).collect(), &opts)
            .unwrap()
            .mesh
    }

    fn area(m: &TriMesh) -> f32 {
        (0..m.faces.len())
            .map(|f| m.triangle(f))
            .map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length())
            .sum()
    }

    fn options() -> MetricOptions {
        MetricOptions { chamfer_samples: 40_000, iou_resolution: 16, ..MetricOptions::default() }
    }

    #[test]
    fn percentile_by_nearest_rank() {
        let mut v: Vec<f32> = (1..=200).rev().map(|i| i as f32).collect();
        assert_eq!(percentile(&mut v, 0.99), 198.0);
        assert_eq!(percentile(&mut v, 0.5), 100.0);
        assert_eq!(percentile(&mut [3.0], 0.99), 3.0);
        assert_eq!(percentile(&mut [], 0.99), 0.0);
        let e = surface_errors(&[0.0, 0.03, 0.01, 0.05], &[0.0; 4], 0.02);
        assert_eq!((e.spurious, e.missing), (0.5, 0.0));
    }

    #[test]
    fn a_flap_on_a_sphere_is_spurious_by_its_far_area() {
        // Truth: a sphere. Prediction: the same sphere with a flat flap sticking out radially
        // (plane y = 0, x from R to R + L, |z| < W/2). Flap points farther than 2 cm from the
        // sphere, sqrt(x^2 + z^2) - R > 2 cm, are spurious; nothing is missing.
        let (l, w) = (0.5f32, 0.3f32);
        let gt = sphere(Vec3::ZERO);
        let mut pred = gt.clone();
        let n = pred.positions.len() as u32;
        pred.positions.extend([
            Vec3::new(R, 0.0, -w / 2.0),
            Vec3::new(R + l, 0.0, -w / 2.0),
            Vec3::new(R + l, 0.0, w / 2.0),
            Vec3::new(R, 0.0, w / 2.0),
        ]);
        pred.faces.extend([[n, n + 1, n + 2], [n, n + 2, n + 3]]);
        // The far part of the flap by midpoint quadrature on a 1 mm grid.
        let steps = (l * 1000.0) as usize;
        let far_cells = (0..steps)
            .flat_map(|i| (0..(w * 1000.0) as usize).map(move |k| (i, k)))
            .filter(|&(i, k)| {
                let (x, z) = (R + (i as f32 + 0.5) / 1000.0, -w / 2.0 + (k as f32 + 0.5) / 1000.0);
                (x * x + z * z).sqrt() - R > 0.02
            })
            .count();
        let far_area = far_cells as f32 * 1e-6;
        let sphere_area = area(&gt);
        let expected = far_area / (sphere_area + l * w);
        // The clothed region: the +x half of the truth (the flap's side).
        let cloth: Vec<bool> = gt.positions.iter().map(|p| p.x > 0.0).collect();
        let right_area: f32 = (0..gt.faces.len())
            .filter(|&f| gt.faces[f].iter().all(|&v| cloth[v as usize]))
            .map(|f| {
                let [a, b, c] = gt.triangle(f);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        let expected_cloth = far_area / (right_area + l * w);
        let regions = Regions { scored: vec![true; gt.positions.len()], cloth };
        let m = evaluate_frame(&pred, &gt, &regions, &options(), 11).unwrap();
        // 40k samples: the standard error of a ~10 % share is 0.15 %.
        assert!(
            (m.surface.spurious - expected).abs() < 0.006,
            "spurious {} vs {expected}",
            m.surface.spurious
        );
        assert!(expected > 0.08, "{expected}");
        assert!(m.surface.missing < 1e-4, "{:?}", m.surface);
        assert!(
            (m.cloth.spurious - expected_cloth).abs() < 0.012,
            "clothed spurious {} vs {expected_cloth}",
            m.cloth.spurious
        );
        assert!(
            m.cloth.spurious > m.surface.spurious + 0.05,
            "the flap is a larger share of the clothed half"
        );
        // The far end of the flap is R + L from the centre: beyond the 99th percentile sits
        // flap area at distances up to L, so p99 is several centimetres.
        assert!(m.surface.p99_cm > 10.0 && m.surface.p99_cm < l * CM, "{:?}", m.surface);
    }

    #[test]
    fn a_shifted_sphere_misses_a_known_share_and_p99() {
        // Truth: sphere at 0; prediction: shifted by D along x. A true point at cos(angle to x) = u
        // is | sqrt(R^2 + D^2 - 2 R D u) - R | from the prediction; u is uniform on [-1, 1] over
        // the sphere's area, so the share beyond t is the measure of u outside [u1, u2].
        const D: f32 = 0.03;
        let share_beyond = |t: f32| {
            let u1 = ((R * R + D * D - (R + t) * (R + t)) / (2.0 * R * D)).clamp(-1.0, 1.0);
            let u2 = ((R * R + D * D - (R - t) * (R - t)) / (2.0 * R * D)).clamp(-1.0, 1.0);
            ((u1 + 1.0) + (1.0 - u2)) / 2.0
        };
        let expected_missing = share_beyond(0.02);
        let (mut lo, mut hi) = (0.0f32, 0.1f32);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if share_beyond(mid) > 0.01 { lo = mid } else { hi = mid }
        }
        let expected_p99 = lo * CM;
        let gt = sphere(Vec3::ZERO);
        let pred = sphere(Vec3::new(D, 0.0, 0.0));
        let regions = Regions::all(gt.positions.len());
        let m = evaluate_frame(&pred, &gt, &regions, &options(), 12).unwrap();
        assert!((expected_missing - 0.33).abs() < 0.03, "analytic share {expected_missing}");
        assert!(
            (m.surface.missing - expected_missing).abs() < 0.012,
            "missing {} vs {expected_missing}",
            m.surface.missing
        );
        // The same shape moved: the prediction's far share is the same by symmetry.
        assert!(
            (m.surface.spurious - expected_missing).abs() < 0.012,
            "spurious {}",
            m.surface.spurious
        );
        assert!(
            (m.surface.p99_cm - expected_p99).abs() < 0.05,
            "p99 {} vs {expected_p99}",
            m.surface.p99_cm
        );
        // The clothed region = the whole truth here.
        assert_eq!(m.cloth, m.surface);
        // Identical surfaces: nothing spurious, nothing missing.
        let same = evaluate_frame(&gt, &gt, &regions, &options(), 13).unwrap();
        assert_eq!((same.surface.spurious, same.surface.missing), (0.0, 0.0));
        assert!(same.surface.p99_cm < 1e-3);
    }
}
