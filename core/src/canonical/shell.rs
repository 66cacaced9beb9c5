//! Thin walls for loose clothing. A skirt is a sheet, but a signed distance field can only
//! draw a closed surface: behind the skirt's observed outside the fit must end the garment's
//! inside somewhere, and since no camera sees that inside (between the skirt and the legs,
//! behind blazer tails) nothing says where. Left alone, a fit ends it wherever its prior
//! does: a skirt becomes a thick bell whose inner wall lies centimetres from the cloth.
//! PINA regresses unseen space toward the body's SDF (Eq. 11): outside the body is outside.
//! These samples apply that where it matters: a little behind each observed point of loose
//! clothing (along its inward normal), outside the body and clear of every other observed
//! point, the space is taken as empty. They become outside constraints like the free-space
//! samples on the camera rays, and the wall behind the cloth stays about `depth.0` thick.

use crate::mesh::point_index::PointIndex;
use crate::mesh::signed_distance::SignedDistance;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellOptions {
    /// Samples wanted per frame (fewer where the frame sees little loose clothing).
    pub per_frame: usize,
    /// How far behind the observed point (metres, along the inward normal): the wall's
    /// thickness, and the farthest a sample goes.
    pub depth: (f32, f32),
    /// Only points this far outside the body are loose clothing (metres): a tight garment's
    /// inside is the body, which the prior already knows.
    pub loose: f32,
    /// A sample must stay this far outside the body (metres).
    pub body_clearance: f32,
    /// And this far from every observed point (metres): another garment layer, a fold, the
    /// other side of a narrow gap, or the frames' remaining misalignment.
    pub clearance: f32,
    pub seed: u64,
}

impl Default for ShellOptions {
    fn default() -> Self {
        // 3.5-9 cm rather than 3-8 cm: with the inner wall taken off the avatar's mesh
        // (`canonical::sheets`) a thicker slab costs nothing and tears fewer holes into the
        // cloth (quick preset, dress / blazer NC 0.680 / 0.783 -> 0.692 / 0.793).
        ShellOptions {
            per_frame: 2000,
            depth: (0.035, 0.09),
            loose: 0.03,
            body_clearance: 0.015,
            clearance: 0.015,
            seed: 0x5e11_0b5e,
        }
    }
}

/// Samples behind a frame's canonical `points` (with outward unit `normals`), checked against
/// the rest body (`body`: its signed distance) and every frame's observed canonical points
/// (`observed`). Metres, canonical space. Seeded.
pub fn shell_samples(
    points: &[Vec3],
    normals: &[Vec3],
    body: &SignedDistance,
    observed: &PointIndex,
    options: &ShellOptions,
) -> Vec<Vec3> {
    if points.is_empty()
        || points.len() != normals.len()
        || options.per_frame == 0
        || !(options.depth.1 > options.depth.0)
    {
        return Vec::new();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    // A few candidates per wanted sample: most points are tight clothing or skin.
    let candidates: Vec<(usize, f32)> = (0..options.per_frame * 4)
        .map(|_| {
            (rng.random_range(0..points.len()), rng.random_range(options.depth.0..options.depth.1))
        })
        .collect();
    candidates
        .par_iter()
        .with_min_len(256)
        .filter_map(|&(i, depth)| {
            let (p, n) = (points[i], normals[i]);
            if n.length_squared() < 0.5 || body.at(p)? < options.loose {
                return None;
            }
            let q = p - n * depth;
            let clear_of_body = body.at(q)? >= options.body_clearance;
            let clear_of_points = observed.nearest(q).1 >= options.clearance;
            (clear_of_body && clear_of_points).then_some(q)
        })
        .collect::<Vec<_>>()
        .into_iter()
        .take(options.per_frame)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::TriMesh;

    /// A closed box with outward faces.
    fn cube(half: f32) -> TriMesh {
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * half;
        let positions = vec![
            c(-1., -1., -1.),
            c(1., -1., -1.),
            c(1., 1., -1.),
            c(-1., 1., -1.),
            c(-1., -1., 1.),
            c(1., -1., 1.),
            c(1., 1., 1.),
            c(-1., 1., 1.),
        ];
        let faces = vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [3, 7, 6],
            [3, 6, 2],
            [0, 4, 7],
            [0, 7, 3],
            [1, 2, 6],
            [1, 6, 5],
        ];
        TriMesh::new(positions, faces)
    }

    /// A square sheet of points at height `z`, `half` wide each way.
    fn sheet(z: f32, half: f32) -> Vec<Vec3> {
        (0..60)
            .flat_map(|i| {
                (0..60).map(move |j| {
                    Vec3::new(
                        half * (2.0 * i as f32 / 59.0 - 1.0),
                        half * (2.0 * j as f32 / 59.0 - 1.0),
                        z,
                    )
                })
            })
            .collect()
    }

    #[test]
    fn samples_lie_behind_loose_cloth_and_clear_of_the_body_and_the_cloth() {
        let body = SignedDistance::new(&cube(0.2));
        // A "skirt" sheet 12 cm in front of the +z face (normals +z), and a tight layer on the
        // -z face 1 cm off the body (normals -z).
        let skirt = sheet(0.32, 0.3);
        let tight = sheet(-0.21, 0.18);
        let observed: Vec<Vec3> = skirt.iter().chain(&tight).copied().collect();
        let index = PointIndex::new(&observed).unwrap();
        let options = ShellOptions { per_frame: 1000, ..ShellOptions::default() };
        let samples = shell_samples(&skirt, &vec![Vec3::Z; skirt.len()], &body, &index, &options);
        assert_eq!(samples.len(), 1000);
        for q in &samples {
            // Behind the skirt by the wall's depth, in front of the body.
            let behind = 0.32 - q.z;
            assert!(
                behind >= options.depth.0 - 1e-5 && behind <= options.depth.1 + 1e-5,
                "{q}: {behind} behind the sheet"
            );
            assert!(q.z > 0.2 + options.body_clearance, "{q} touches the body");
        }
        // Tight clothing gets none: its inside is the body.
        let tight_samples =
            shell_samples(&tight, &vec![Vec3::NEG_Z; tight.len()], &body, &index, &options);
        assert!(tight_samples.is_empty(), "{} samples behind a tight layer", tight_samples.len());
        // Seeded.
        assert_eq!(
            samples,
            shell_samples(&skirt, &vec![Vec3::Z; skirt.len()], &body, &index, &options)
        );
    }

    #[test]
    fn no_sample_lands_near_another_observed_layer() {
        let body = SignedDistance::new(&cube(0.2));
        // Two layers 3 cm apart in front of the body: behind the outer one lies the inner one.
        let outer = sheet(0.33, 0.3);
        let inner = sheet(0.30, 0.3);
        let observed: Vec<Vec3> = outer.iter().chain(&inner).copied().collect();
        let index = PointIndex::new(&observed).unwrap();
        let options = ShellOptions::default();
        let samples = shell_samples(&outer, &vec![Vec3::Z; outer.len()], &body, &index, &options);
        for q in &samples {
            assert!(index.nearest(*q).1 >= options.clearance - 1e-5, "{q} is on an observed layer");
        }
    }
}
