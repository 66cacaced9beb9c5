//! The metrics: MetaAvatar's Dp, Df and NC on the clothed ground-truth vertices, PINA's
//! volumetric IoU and Chamfer-L2 on the whole surfaces.
//!
//! - Dp (cm): for each scored ground-truth vertex, the distance to the nearest predicted
//!   vertex; the mean over the scored vertices.
//! - Df (cm): the same, to the nearest point of the predicted surface (point-to-triangle).
//! - NC: 1 - mean |n_pred - n_gt| over the scored vertices, with n_pred the unit vertex
//!   normal of the nearest predicted vertex and n_gt the ground-truth unit vertex normal
//!   (area-weighted). In [-1, 1]: 1 for identical surfaces, -1 for reversed normals.
//! - IoU: volumetric, on a seeded stratified grid over the joint bounds (see `occupancy`).
//! - Chamfer-L2 (cm): points sampled uniformly on both surfaces (seeded), each measured to
//!   the other *surface* (point-to-triangle): (mean pred -> gt + mean gt -> pred) / 2.
//!   Measuring to the surface rather than to the other sample set removes the sampling
//!   floor (about half the sample spacing, 0.5 cm at 10k samples on a body).
//!
//! - Spurious and missing shares and the 99th-percentile distance, whole surface and clothed
//!   region, on the Chamfer samples: see `surface_error`.
//! - Integrity of both surfaces (open border, non-manifold edges, pieces, self-intersections)
//!   and the predicted area that faces the wrong way: see `integrity`.
//!
//! Scored vertices: ground-truth vertices whose dominant body joint is one of
//! `skeleton::CLOTHED_JOINTS` (no hands, wrists, feet, ankles, neck or head), and visible
//! where the ground truth marks hidden vertices.

use super::integrity::{FrameIntegrity, frame_integrity};
use super::occupancy::volumetric_iou;
use super::surface_error::{SurfaceErrors, region_errors};
use crate::body::skeleton::CLOTHED_JOINTS;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::synth::ClothedTemplate;
use glam::Vec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

pub use super::prepared::{Prepared, check_mesh};
pub use super::summary::Summary;
use super::summary::mean;
pub use super::surface_error::CM;

/// Sampling settings of the metrics that sample (IoU, Chamfer).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricOptions {
    /// Points sampled on each surface for the Chamfer distance.
    pub chamfer_samples: usize,
    /// Grid points along the longest side of the joint bounds for IoU.
    pub iou_resolution: usize,
    /// Distance beyond which a sample counts as spurious or missing (metres).
    #[serde(default = "default_far")]
    pub far_m: f32,
}

fn default_far() -> f32 {
    0.02
}

impl Default for MetricOptions {
    fn default() -> Self {
        MetricOptions { chamfer_samples: 10_000, iou_resolution: 128, far_m: default_far() }
    }
}

/// Scores of one predicted mesh against one ground-truth frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameMetrics {
    pub dp_cm: f32,
    pub df_cm: f32,
    pub nc: f32,
    pub iou: f32,
    pub chamfer_cm: f32,
    /// Spurious, missing and p99 over the whole surfaces ...
    pub surface: SurfaceErrors,
    /// ... and over the clothed region.
    pub cloth: SurfaceErrors,
    /// Ground-truth vertices scored by Dp, Df and NC.
    pub scored_vertices: usize,
    /// Whether the surfaces are whole: open borders, non-manifold edges, pieces,
    /// self-intersections, inside-out patches (prediction and truth).
    #[serde(default)]
    pub integrity: FrameIntegrity,
}

/// Which ground-truth vertices the metrics look at: `scored` by Dp, Df and NC, `cloth` the
/// clothed region of the surface-sample metrics.
#[derive(Debug, Clone, PartialEq)]
pub struct Regions {
    pub scored: Vec<bool>,
    pub cloth: Vec<bool>,
}

impl Regions {
    /// Every vertex in both.
    pub fn all(n: usize) -> Regions {
        Regions { scored: vec![true; n], cloth: vec![true; n] }
    }

    /// The generator's ground truth: `scored` by dominant joint (`clothed_mask`); `cloth` the
    /// vertices a garment covers: `ClothedTemplate::cloth` >= 0.5 (a garment offset of at least
    /// 2 mm at rest: shirt, sleeves, trousers) and every panel vertex (skirt, tails).
    pub fn of_template(t: &ClothedTemplate) -> Result<Regions> {
        Ok(Regions {
            scored: clothed_mask(&t.vertex_joint, None)?,
            cloth: t.cloth.iter().map(|&c| c >= 0.5).collect(),
        })
    }
}

/// The metric mask: clothed-region vertices (by dominant joint), visible ones only when a
/// visibility flag is given.
pub fn clothed_mask(vertex_joint: &[u8], visible: Option<&[bool]>) -> Result<Vec<bool>> {
    if let Some(v) = visible
        && v.len() != vertex_joint.len()
    {
        return Err(Error::invalid(format!(
            "visibility has {} entries for {} vertices",
            v.len(),
            vertex_joint.len()
        )));
    }
    Ok(vertex_joint
        .iter()
        .enumerate()
        .map(|(i, &j)| CLOTHED_JOINTS.contains(&(j as usize)) && visible.is_none_or(|v| v[i]))
        .collect())
}

/// Per-vertex Dp, Df (metres) and normal differences |n_pred - n_gt| for the given points.
pub struct VertexScores {
    pub point: Vec<f32>,
    pub face: Vec<f32>,
    pub normal_error: Vec<f32>,
}

/// Dp, Df and the NC terms for ground-truth points with unit normals.
pub fn vertex_scores(gt_points: &[Vec3], gt_normals: &[Vec3], pred: &Prepared) -> VertexScores {
    let mut s = VertexScores {
        point: Vec::with_capacity(gt_points.len()),
        face: Vec::with_capacity(gt_points.len()),
        normal_error: Vec::with_capacity(gt_points.len()),
    };
    for (&p, &n) in gt_points.iter().zip(gt_normals) {
        let (nearest, d) = pred.vertices.nearest(p);
        s.point.push(d);
        s.face.push(pred.surface_distance_below(p, d));
        s.normal_error.push((pred.normals[nearest] - n).length());
    }
    s
}

/// All metrics of a predicted mesh against a ground-truth mesh; `regions` selects the
/// ground-truth vertices scored by Dp, Df and NC and the clothed region. `seed` drives IoU and
/// the surface sampling.
pub fn evaluate_frame(
    pred: &TriMesh,
    gt: &TriMesh,
    regions: &Regions,
    options: &MetricOptions,
    seed: u64,
) -> Result<FrameMetrics> {
    let gt_prepared = Prepared::new(gt, "ground-truth")?;
    let mask = &regions.scored;
    for (what, m) in [("metric mask", mask), ("clothed region", &regions.cloth)] {
        if m.len() != gt.positions.len() {
            return Err(Error::invalid(format!(
                "{what} has {} entries for {} ground-truth vertices",
                m.len(),
                gt.positions.len()
            )));
        }
    }
    let prepared = Prepared::new(pred, "predicted")?;
    let (points, normals): (Vec<Vec3>, Vec<Vec3>) = gt
        .positions
        .iter()
        .zip(&gt_prepared.normals)
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|((p, n), _)| (*p, *n))
        .unzip();
    if points.is_empty() {
        return Err(Error::invalid("no ground-truth vertex lies in the clothed-region mask"));
    }
    let s = vertex_scores(&points, &normals, &prepared);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let iou = volumetric_iou(pred, gt, options.iou_resolution, &mut rng)?;
    // The same samples as `chamfer_l2` (same order), classified by the nearest true vertex.
    let clothed = |p: Vec3| regions.cloth[gt_prepared.vertices.nearest(p).0];
    let to_gt =
        prepared.sample_distances(&gt_prepared, options.chamfer_samples, &mut rng, clothed)?;
    let to_pred =
        gt_prepared.sample_distances(&prepared, options.chamfer_samples, &mut rng, clothed)?;
    let chamfer = 0.5 * (mean(&to_gt.distance) + mean(&to_pred.distance));
    let (surface, cloth) = region_errors(&to_gt, &to_pred, options.far_m);
    let integrity = frame_integrity(&prepared, &gt_prepared, clothed);
    Ok(FrameMetrics {
        dp_cm: mean(&s.point) * CM,
        df_cm: mean(&s.face) * CM,
        nc: 1.0 - mean(&s.normal_error),
        iou,
        chamfer_cm: chamfer * CM,
        surface,
        cloth,
        scored_vertices: points.len(),
        integrity,
    })
}

/// Symmetric Chamfer-L2 distance (metres): `samples` points on each surface, each measured
/// to the other surface.
pub fn chamfer_l2(a: &Prepared, b: &Prepared, samples: usize, rng: &mut ChaCha8Rng) -> Result<f32> {
    let ab = a.sample_distances(b, samples, rng, |_| false)?;
    let ba = b.sample_distances(a, samples, rng, |_| false)?;
    Ok(0.5 * (mean(&ab.distance) + mean(&ba.distance)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::extract::{ExtractOptions, extract};

    fn sphere_mesh(center: Vec3, r: f32, res: usize) -> TriMesh {
        let opts =
            ExtractOptions::new(center - Vec3::splat(r * 1.3), center + Vec3::splat(r * 1.3), res);
        extract(|p: &[Vec3]| p.iter().map(|x| x.distance(center) - r).collect(), &opts)
            .unwrap()
            .mesh
    }

    #[test]
    fn identical_meshes_score_perfectly() {
        let m = sphere_mesh(Vec3::ZERO, 0.3, 40);
        let r =
            evaluate_frame(&m, &m, &Regions::all(m.positions.len()), &MetricOptions::default(), 1)
                .unwrap();
        assert_eq!(r.dp_cm, 0.0);
        assert_eq!(r.df_cm, 0.0);
        assert!((r.nc - 1.0).abs() < 1e-6, "{r:?}");
        assert_eq!(r.iou, 1.0);
        assert!(r.chamfer_cm < 1e-4, "{r:?}");
    }

    #[test]
    fn shifted_and_scaled_spheres_give_the_analytic_distance() {
        let gt = sphere_mesh(Vec3::ZERO, 0.30, 64);
        // Concentric sphere 2 cm larger: every distance is 2 cm, up to tessellation.
        let big = sphere_mesh(Vec3::ZERO, 0.32, 64);
        let r = evaluate_frame(
            &big,
            &gt,
            &Regions::all(gt.positions.len()),
            &MetricOptions::default(),
            2,
        )
        .unwrap();
        assert!((r.df_cm - 2.0).abs() < 0.05, "Df {}", r.df_cm);
        // Nearest vertex is at least the surface distance and within a cell of it.
        let cell_cm = 0.32 * 2.6 / 64.0 * CM;
        assert!(
            r.dp_cm >= r.df_cm && r.dp_cm < r.df_cm + 0.5 * cell_cm,
            "Dp {} Df {}",
            r.dp_cm,
            r.df_cm
        );
        assert!((r.chamfer_cm - 2.0).abs() < 0.05, "Chamfer {}", r.chamfer_cm);
        let iou_truth = (0.30f32 / 0.32).powi(3);
        assert!((r.iou - iou_truth).abs() < 0.01, "IoU {} vs {iou_truth}", r.iou);
        assert!(r.nc > 0.95, "NC {}", r.nc);
        // Shifted by 3 cm along x: the exact distance of each GT vertex to the moved sphere
        // is | |p - c| - r | (about 1.5 cm on average: the mean |cos| over a sphere is 1/2).
        let c = Vec3::new(0.03, 0.0, 0.0);
        let moved = sphere_mesh(c, 0.30, 64);
        let r = evaluate_frame(
            &moved,
            &gt,
            &Regions::all(gt.positions.len()),
            &MetricOptions::default(),
            3,
        )
        .unwrap();
        let exact =
            mean(&gt.positions.iter().map(|p| (p.distance(c) - 0.30).abs()).collect::<Vec<_>>())
                * CM;
        assert!((exact - 1.5).abs() < 0.1, "analytic mean {exact}");
        assert!((r.df_cm - exact).abs() < 0.05, "Df {} vs {exact}", r.df_cm);
    }

    #[test]
    fn reversed_faces_give_normal_consistency_near_minus_one() {
        let gt = sphere_mesh(Vec3::ZERO, 0.3, 40);
        let mut flipped = gt.clone();
        flipped.faces.iter_mut().for_each(|f| f.swap(1, 2));
        let r = evaluate_frame(
            &flipped,
            &gt,
            &Regions::all(gt.positions.len()),
            &MetricOptions::default(),
            4,
        )
        .unwrap();
        assert!((r.nc + 1.0).abs() < 1e-5, "NC {}", r.nc);
        assert_eq!(r.dp_cm, 0.0);
        assert_eq!(r.iou, 1.0); // volume does not depend on orientation
    }

    #[test]
    fn mask_restricts_the_scored_vertices() {
        // GT: sphere; prediction: the same sphere with its +x half pushed out 5 cm. Scoring
        // only the -x half sees no error.
        let gt = sphere_mesh(Vec3::ZERO, 0.3, 40);
        let mut pred = gt.clone();
        pred.positions.iter_mut().filter(|p| p.x > 0.05).for_each(|p| *p *= 1.0 + 0.05 / 0.3);
        let left: Vec<bool> = gt.positions.iter().map(|p| p.x < -0.05).collect();
        let r = evaluate_frame(
            &pred,
            &gt,
            &Regions { scored: left.clone(), cloth: left.clone() },
            &MetricOptions::default(),
            5,
        )
        .unwrap();
        assert_eq!(r.dp_cm, 0.0);
        assert_eq!(r.scored_vertices, left.iter().filter(|m| **m).count());
        let r_all = evaluate_frame(
            &pred,
            &gt,
            &Regions::all(gt.positions.len()),
            &MetricOptions::default(),
            5,
        )
        .unwrap();
        assert!(r_all.dp_cm > 1.0);
        let none = Regions {
            scored: vec![false; gt.positions.len()],
            cloth: vec![true; gt.positions.len()],
        };
        assert!(evaluate_frame(&pred, &gt, &none, &MetricOptions::default(), 5).is_err());
    }

    #[test]
    fn clothed_mask_keeps_clothed_joints_and_visible_vertices() {
        let joints = [0u8, 15, 16, 20, 4, 12];
        assert_eq!(
            clothed_mask(&joints, None).unwrap(),
            vec![true, false, true, false, true, false]
        );
        let vis = [true, true, false, true, true, true];
        assert_eq!(
            clothed_mask(&joints, Some(&vis)).unwrap(),
            vec![true, false, false, false, true, false]
        );
        assert!(clothed_mask(&joints, Some(&vis[..3])).is_err());
    }

    #[test]
    fn bad_meshes_are_errors_not_panics() {
        let gt = sphere_mesh(Vec3::ZERO, 0.3, 24);
        let opts = MetricOptions::default();
        assert!(
            evaluate_frame(&TriMesh::default(), &gt, &Regions::all(gt.positions.len()), &opts, 0)
                .unwrap_err()
                .to_string()
                .contains("empty")
        );
        let mut nan = gt.clone();
        nan.positions[3] = Vec3::NAN;
        assert!(
            evaluate_frame(&nan, &gt, &Regions::all(gt.positions.len()), &opts, 0)
                .unwrap_err()
                .to_string()
                .contains("not finite")
        );
        let mut bad = gt.clone();
        bad.faces[0][1] = 1_000_000;
        assert!(evaluate_frame(&bad, &gt, &Regions::all(gt.positions.len()), &opts, 0).is_err());
        assert!(evaluate_frame(&gt, &gt, &Regions::all(1), &opts, 0).is_err());
        let short_cloth = Regions { cloth: vec![true], ..Regions::all(gt.positions.len()) };
        assert!(
            evaluate_frame(&gt, &gt, &short_cloth, &opts, 0)
                .unwrap_err()
                .to_string()
                .contains("clothed region")
        );
    }

    #[test]
    fn summary_statistics() {
        let s = Summary::of(&[3.0, 1.0, 2.0, 10.0]).unwrap();
        assert_eq!((s.mean, s.median, s.min, s.max, s.count), (4.0, 2.5, 1.0, 10.0, 4));
        assert!(Summary::of(&[]).is_none());
    }
}
