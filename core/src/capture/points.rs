//! From depth pixels to oriented points on the person: back-projection, PCA normals, and
//! cropping by distance to the posed body (background and floor removed).

use super::depth_png::DepthImage;
use super::manifest::Intrinsics;
use crate::error::{Error, Result};
use crate::mesh::bvh::Bvh;
use glam::{Mat3, Mat4, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::num::NonZero;

/// World-space points of every pixel with depth (and inside the mask, if given), with the
/// pixel index each came from.
pub fn backproject(
    depth: &DepthImage,
    intrinsics: &Intrinsics,
    camera_to_world: Mat4,
    mask: Option<&[bool]>,
) -> (Vec<Vec3>, Vec<u32>) {
    let mut points = Vec::new();
    let mut pixels = Vec::new();
    for v in 0..depth.height {
        for u in 0..depth.width {
            let i = (v * depth.width + u) as usize;
            let z = depth.metres[i];
            if z <= 0.0 || mask.is_some_and(|m| !m[i]) {
                continue;
            }
            points.push(
                camera_to_world.transform_point3(intrinsics.unproject(u as f32, v as f32, z)),
            );
            pixels.push(i as u32);
        }
    }
    (points, pixels)
}

/// Unit normals by PCA of the `k` nearest neighbours (smallest-eigenvalue direction), turned
/// to face `camera_center`. Points with fewer than 3 neighbours get the direction to the camera.
pub fn estimate_normals(points: &[Vec3], camera_center: Vec3, k: usize) -> Vec<Vec3> {
    if points.is_empty() {
        return Vec::new();
    }
    let coords: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f32, 3> =
        ImmutableKdTree::new_from_slice(&coords).expect("finite points");
    let k = NonZero::new(k.clamp(3, 64)).unwrap();
    points
        .par_iter()
        .map(|&p| {
            let to_cam = (camera_center - p).normalize_or(Vec3::Z);
            let hits = tree.query(&p.to_array()).nearest_n::<SquaredEuclidean<f32>>(k).execute();
            if hits.len() < 3 {
                return to_cam;
            }
            let mean =
                hits.iter().map(|h| points[h.item as usize]).sum::<Vec3>() / hits.len() as f32;
            let mut cov = Mat3::ZERO;
            for h in &hits {
                let d = points[h.item as usize] - mean;
                cov += Mat3::from_cols(d * d.x, d * d.y, d * d.z);
            }
            let n = smallest_eigenvector(cov).unwrap_or(to_cam);
            if n.dot(to_cam) < 0.0 { -n } else { n }
        })
        .collect()
}

/// Eigenvector of the smallest eigenvalue of a symmetric 3x3 matrix, by inverse-free power
/// iteration on (trace I - A), which maps the smallest eigenvalue to the largest.
fn smallest_eigenvector(a: Mat3) -> Option<Vec3> {
    let shift = a.x_axis.x + a.y_axis.y + a.z_axis.z;
    if !(shift > 0.0) {
        return None;
    }
    let b = Mat3::from_diagonal(Vec3::splat(shift)) - a;
    // Start from the column of b with the largest norm; 32 iterations are plenty for 3x3.
    let mut v = [b.x_axis, b.y_axis, b.z_axis]
        .into_iter()
        .max_by(|p, q| p.length_squared().total_cmp(&q.length_squared()))?;
    for _ in 0..32 {
        v = (b * v).normalize_or_zero();
        if v == Vec3::ZERO {
            return None;
        }
    }
    Some(v)
}

/// How a frame's points are cut down to the person.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CropOptions {
    /// Keep points within this distance of the posed body surface (metres). Loose clothing
    /// (a dress hem, blazer tails) reaches 30 cm from the body.
    pub max_distance: f32,
    /// Remove a floor plane found below the feet (RANSAC).
    pub remove_floor: bool,
    /// Points this close to the floor plane are floor (metres) ...
    pub floor_tolerance: f32,
    /// ... unless they are this close to the body (the soles of the feet).
    pub keep_near_body: f32,
}

impl Default for CropOptions {
    fn default() -> Self {
        CropOptions {
            max_distance: 0.30,
            remove_floor: true,
            floor_tolerance: 0.015,
            keep_near_body: 0.01,
        }
    }
}

/// What cropping removed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CropReport {
    pub far_from_body: usize,
    pub floor: usize,
}

/// Indices of the points kept, with the counts of what was removed.
pub fn crop_to_body(
    points: &[Vec3],
    body: &Bvh,
    up: Vec3,
    options: &CropOptions,
) -> Result<(Vec<usize>, CropReport)> {
    let (lo, _) =
        body.bounds().ok_or_else(|| Error::invalid("cannot crop to an empty body mesh"))?;
    // Whether a point is near the body, found by the first triangle within reach (neighbouring
    // pixels are near the same triangles: each query first tries the last one); its distance
    // is measured only where the floor's test needs it.
    let near_body: Vec<bool> = points
        .par_iter()
        .map_init(|| u32::MAX, |last, &p| body.any_within_from(p, options.max_distance, last))
        .collect();
    let body_dist = |p: Vec3| {
        body.closest_point_within(p, options.max_distance).map_or(f32::INFINITY, |h| h.distance)
    };
    let mut report = CropReport::default();
    let near: Vec<usize> = (0..points.len()).filter(|&i| near_body[i]).collect();
    report.far_from_body = points.len() - near.len();
    let floor = if options.remove_floor {
        let lowest =
            lo.dot(up).min(near.iter().map(|&i| points[i].dot(up)).fold(f32::INFINITY, f32::min));
        let candidates: Vec<Vec3> =
            near.iter().map(|&i| points[i]).filter(|p| p.dot(up) < lowest + 0.12).collect();
        // Without enough floor in view for RANSAC, the floor is the plane under the body's soles.
        fit_floor_plane(&candidates, up, options.floor_tolerance).or(Some((up, lo.dot(up))))
    } else {
        None
    };
    let kept: Vec<usize> = near
        .into_iter()
        .filter(|&i| match floor {
            Some((n, d)) => {
                let on_floor =
                    (points[i].dot(n) - d).abs() <= options.floor_tolerance || points[i].dot(n) < d;
                let is_floor = on_floor && body_dist(points[i]) > options.keep_near_body;
                if is_floor {
                    report.floor += 1;
                }
                !is_floor
            }
            None => true,
        })
        .collect();
    Ok((kept, report))
}

/// A plane n.x = d nearly perpendicular to `up` supported by at least 50 points (and a
/// tenth of the candidates), by seeded RANSAC; `None` when there is no floor.
fn fit_floor_plane(candidates: &[Vec3], up: Vec3, tolerance: f32) -> Option<(Vec3, f32)> {
    if candidates.len() < 50 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed_f100);
    let mut best: Option<(Vec3, f32, usize)> = None;
    for _ in 0..200 {
        let [a, b, c] = [0; 3].map(|_| candidates[rng.random_range(0..candidates.len())]);
        let mut n = (b - a).cross(c - a);
        if n.length_squared() < 1e-12 {
            continue;
        }
        n = n.normalize();
        if n.dot(up) < 0.0 {
            n = -n;
        }
        if n.dot(up) < 0.95 {
            continue; // Not horizontal (within about 18 degrees).
        }
        let d = n.dot(a);
        let support = candidates.iter().filter(|p| (p.dot(n) - d).abs() <= tolerance).count();
        if best.is_none_or(|(_, _, s)| support > s) {
            best = Some((n, d, support));
        }
    }
    best.filter(|&(_, _, s)| s >= 50 && s * 10 >= candidates.len()).map(|(n, d, _)| (n, d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pca_normals_of_a_plane_face_the_camera() {
        let pts: Vec<Vec3> = (0..400)
            .map(|i| Vec3::new((i % 20) as f32 * 0.01, (i / 20) as f32 * 0.01, 2.0))
            .collect();
        let normals = estimate_normals(&pts, Vec3::ZERO, 12);
        for n in normals {
            assert!((n - Vec3::NEG_Z).length() < 1e-3, "{n}");
        }
    }

    #[test]
    fn backprojection_inverts_projection() {
        let intr = Intrinsics { fx: 500.0, fy: 480.0, cx: 2.0, cy: 1.5, width: 4, height: 3 };
        let depth = DepthImage {
            width: 4,
            height: 3,
            metres: vec![1.0, 0.0, 2.0, 3.0, 1.5, 1.5, 0.0, 2.5, 1.0, 1.0, 1.0, 4.0],
        };
        let (pts, px) = backproject(&depth, &intr, Mat4::IDENTITY, None);
        assert_eq!(pts.len(), 10);
        for (p, &i) in pts.iter().zip(&px) {
            let (u, v) = (i % 4, i / 4);
            assert!((intr.fx * p.x / p.z + intr.cx - u as f32).abs() < 1e-4);
            assert!((intr.fy * p.y / p.z + intr.cy - v as f32).abs() < 1e-4);
            assert_eq!(p.z, depth.at(u, v));
        }
    }
}
