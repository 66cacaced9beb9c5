//! Free-space evidence: a depth pixel says that the ray from the camera to the measured point
//! is empty (the classic truncated-SDF fusion idea). Samples on those rays, a little in front
//! of the measured depth, become "outside" constraints of the fit: they carve away the sheets
//! and blobs a SIREN grows between the legs or under a skirt where no depth point pins it.
//! Pixels without depth give no evidence (a sensor hole looks the same as the background).

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Where on the rays the samples go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeSpaceOptions {
    /// Samples per frame.
    pub per_frame: usize,
    /// The nearest sample's distance in front of the measured point (metres): beyond the depth
    /// noise (Kinect v2: about 4 mm at 2.4 m) and the thickness of a fold.
    pub min_gap: f32,
    /// The farthest (metres): the sign prior already says "outside" beyond 35 cm of the body.
    pub max_gap: f32,
    pub seed: u64,
}

impl Default for FreeSpaceOptions {
    fn default() -> Self {
        FreeSpaceOptions { per_frame: 4000, min_gap: 0.02, max_gap: 0.30, seed: 0x0f4e_e5ace }
    }
}

/// Samples on the camera rays of `points` (a frame's measured points, world space), each
/// between `min_gap` and `max_gap` in front of its point, denser near the surface (where the
/// spurious surfaces are). Seeded: the same frame gives the same samples.
pub fn free_space_samples(
    points: &[Vec3],
    camera_center: Vec3,
    options: &FreeSpaceOptions,
) -> Vec<Vec3> {
    if points.is_empty()
        || options.per_frame == 0
        || !(options.max_gap > options.min_gap)
        || options.min_gap < 0.0
    {
        return Vec::new();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let span = options.max_gap - options.min_gap;
    let mut out = Vec::with_capacity(options.per_frame);
    for _ in 0..options.per_frame {
        let p = points[rng.random_range(0..points.len())];
        let to_camera = camera_center - p;
        let range = to_camera.length();
        // A sample may not pass the camera (points closer than the gap give none).
        let u: f32 = rng.random();
        let gap = options.min_gap + span * u * u;
        if gap >= range {
            continue;
        }
        out.push(p + to_camera / range * gap);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::depth_png::DepthImage;
    use crate::capture::manifest::Intrinsics;
    use crate::capture::points::backproject;
    use glam::Mat4;

    /// A depth image of a sphere in front of a wall, seen by a camera at the origin looking
    /// down +z (the camera frame is the world frame).
    fn sphere_scene() -> (DepthImage, Intrinsics) {
        let intr = Intrinsics { fx: 60.0, fy: 60.0, cx: 32.0, cy: 32.0, width: 64, height: 64 };
        let (c, r) = (Vec3::new(0.0, 0.0, 2.0), 0.5);
        let mut metres = vec![0.0; 64 * 64];
        for v in 0..64 {
            for u in 0..64 {
                let d =
                    Vec3::new((u as f32 - intr.cx) / intr.fx, (v as f32 - intr.cy) / intr.fy, 1.0);
                // Ray o + t d with |o + t d - c| = r; depth is t (z of d is 1).
                let (a, b, cc) = (d.dot(d), -2.0 * d.dot(c), c.dot(c) - r * r);
                let disc = b * b - 4.0 * a * cc;
                // The wall at 3 m behind the sphere where the ray misses it; a hole every 7th pixel.
                let z = if disc >= 0.0 { (-b - disc.sqrt()) / (2.0 * a) } else { 3.0 };
                metres[v * 64 + u] = if (u + v) % 7 == 0 { 0.0 } else { z };
            }
        }
        (DepthImage { width: 64, height: 64, metres }, intr)
    }

    #[test]
    fn no_sample_lies_behind_an_observed_depth() {
        let (depth, intr) = sphere_scene();
        let (points, _) = backproject(&depth, &intr, Mat4::IDENTITY, None);
        let options = FreeSpaceOptions { per_frame: 5000, ..FreeSpaceOptions::default() };
        let samples = free_space_samples(&points, Vec3::ZERO, &options);
        assert!(samples.len() > 4900, "{}", samples.len());
        for q in &samples {
            // Project into the image: the pixel the sample falls on has depth, and the sample is
            // in front of it by at least the gap (less a pixel's worth of slant on the sphere).
            let (u, v) = (intr.fx * q.x / q.z + intr.cx, intr.fy * q.y / q.z + intr.cy);
            let (ui, vi) = (u.round() as usize, v.round() as usize);
            let observed = depth.at(ui as u32, vi as u32);
            assert!(observed > 0.0, "sample {q} falls on a pixel without depth");
            assert!(
                q.z < observed - 0.01,
                "sample {q} at depth {} is not in front of {observed}",
                q.z
            );
            // And outside the sphere: nothing behind an observed depth, nothing inside the object.
            assert!((*q - Vec3::new(0.0, 0.0, 2.0)).length() > 0.5, "sample {q} inside the sphere");
        }
        // Gaps within the range, denser near the surface.
        let gaps: Vec<f32> = samples
            .iter()
            .map(|q| points.iter().map(|p| (*p - *q).length()).fold(f32::INFINITY, f32::min))
            .collect();
        let near = gaps.iter().filter(|&&g| g < 0.1).count();
        assert!(near * 2 > gaps.len(), "{near} of {} within 10 cm", gaps.len());
        assert!(gaps.iter().all(|&g| g <= options.max_gap + 1e-4));
    }

    #[test]
    fn samples_are_seeded_and_empty_input_gives_none() {
        let pts = vec![Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.1, 0.0, 2.1)];
        let o = FreeSpaceOptions { per_frame: 10, ..FreeSpaceOptions::default() };
        assert_eq!(
            free_space_samples(&pts, Vec3::ZERO, &o),
            free_space_samples(&pts, Vec3::ZERO, &o)
        );
        assert!(free_space_samples(&[], Vec3::ZERO, &o).is_empty());
        // A point nearer the camera than the gap gives no sample past the camera.
        let close = free_space_samples(&[Vec3::new(0.0, 0.0, 0.01)], Vec3::ZERO, &o);
        assert!(close.is_empty());
    }
}
