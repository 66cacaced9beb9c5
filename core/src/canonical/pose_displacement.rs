//! How far a pose may move an avatar's surface. The posed surface is the reference surface
//! (made whole once: FITE's explicit template, `avatar::PoseTemplate`) with each vertex moved
//! toward the pose's zero level (`AvatarSource::project`), then skinned. The pose-conditioned
//! SDF of an avatar fitted to a few frames is reliable near the poses it saw and loose away
//! from them: at an unseen pose a coat's tails may be missing from it, and Newton steps then
//! carry the tails' vertices centimetres away onto the legs, the sheet folding over itself. So
//! each vertex moves along its reference normal only (sliding along the surface would push it
//! into a neighbouring part: at the armpit, the inner thigh), by a bounded amount, then
//! averaged with its neighbours' moves (a skirt's neighbours move together): the pose adds
//! wrinkles and a lean, the skinning carries the rest.

use crate::mesh::smooth::Neighbours;
use glam::Vec3;
use rayon::prelude::*;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplacementLimit {
    /// The longest move (metres) of a vertex away from its rest position.
    pub max: f32,
    /// Averaging sweeps of the moves over the mesh's edges (each: half its own, half its
    /// neighbours' mean).
    pub sweeps: usize,
}

impl Default for DisplacementLimit {
    fn default() -> Self {
        // One fitted dress (16 frames of a walk), 24 held-out frames of four clips
        // (docs/decisions.md): unbounded projection Chamfer-L2 0.993 cm / NC 0.857; skinning
        // the reference surface alone 0.928 / 0.856; 3 cm 0.930 (10 sweeps 0.909); 1 cm
        // 0.908 (10 sweeps 0.899 / NC 0.866); along the normal only the same distances with
        // fewer self-intersecting faces (tight outfit 7.8 -> 6.1 %, blazer 8.9 -> 8.0 %).
        DisplacementLimit { max: 0.01, sweeps: 10 }
    }
}

/// `moved` (the positions `reference` each moved by a pose) with every move replaced by its
/// part along the vertex's reference normal (`normals`), bounded by `limit.max`, then smoothed
/// over `neighbours` (the reference mesh's), in place.
pub fn bound_moves(
    reference: &[Vec3],
    normals: &[Vec3],
    moved: &mut [Vec3],
    neighbours: &Neighbours,
    limit: &DisplacementLimit,
) {
    if reference.len() != moved.len() || normals.len() != moved.len() {
        return;
    }
    let mut moves: Vec<Vec3> = moved
        .par_iter()
        .zip(reference)
        .zip(normals)
        .map(|((&x, &r), &n)| {
            let d = x - r;
            if !d.is_finite() { Vec3::ZERO } else { n * d.dot(n).clamp(-limit.max, limit.max) }
        })
        .collect();
    let mut next = moves.clone();
    for _ in 0..limit.sweeps {
        next.par_iter_mut().enumerate().for_each(|(v, out)| {
            let around = &neighbours.indices[neighbours.offsets[v]..neighbours.offsets[v + 1]];
            *out = if around.is_empty() {
                moves[v]
            } else {
                let mean =
                    around.iter().map(|&u| moves[u as usize]).sum::<Vec3>() / around.len() as f32;
                0.5 * (moves[v] + mean)
            };
        });
        std::mem::swap(&mut moves, &mut next);
    }
    moved.par_iter_mut().zip(reference).zip(&moves).for_each(|((x, &r), &d)| *x = r + d);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::TriMesh;
    use crate::mesh::smooth::vertex_neighbours;

    /// A flat grid of `n` x `n` vertices 1 cm apart.
    fn grid(n: usize) -> TriMesh {
        let positions =
            (0..n * n).map(|i| Vec3::new((i % n) as f32 * 0.01, (i / n) as f32 * 0.01, 0.0));
        let mut faces = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let v = (y * n + x) as u32;
                let n = n as u32;
                faces.push([v, v + 1, v + n + 1]);
                faces.push([v, v + n + 1, v + n]);
            }
        }
        TriMesh::new(positions.collect(), faces)
    }

    #[test]
    fn small_even_moves_pass_and_a_jump_is_bounded_and_spread() {
        let mesh = grid(21);
        let neighbours = vertex_neighbours(&mesh);
        let normals = vec![Vec3::Z; mesh.positions.len()];
        let limit = DisplacementLimit { max: 0.01, sweeps: 10 };
        // A lift of 4 mm everywhere passes unchanged; a slide along the sheet goes.
        let mut moved: Vec<Vec3> =
            mesh.positions.iter().map(|&p| p + Vec3::new(0.003, 0.0, 0.004)).collect();
        bound_moves(&mesh.positions, &normals, &mut moved, &neighbours, &limit);
        for (m, r) in moved.iter().zip(&mesh.positions) {
            assert!((*m - *r - Vec3::Z * 0.004).length() < 1e-6);
        }
        // One vertex in the middle jumps 20 cm (onto another sheet): it moves at most 1 cm, and
        // less than that once averaged; far vertices barely move.
        let centre = 10 * 21 + 10;
        let mut moved = mesh.positions.clone();
        moved[centre] += Vec3::Z * 0.2;
        bound_moves(&mesh.positions, &normals, &mut moved, &neighbours, &limit);
        let d = |v: usize| (moved[v] - mesh.positions[v]).length();
        assert!(d(centre) < 0.005, "the jump kept {} m", d(centre));
        assert!(d(centre) > d(centre + 3), "the move did not spread out");
        assert!(d(0) < 1e-6, "a corner moved {} m", d(0));
        let total: Vec3 = moved.iter().zip(&mesh.positions).map(|(m, r)| *m - *r).sum::<Vec3>();
        assert!((total.z - 0.01).abs() < 1e-3, "the bounded move's sum {}", total.z);
    }

    #[test]
    fn a_move_that_is_not_a_number_is_dropped() {
        let mesh = grid(3);
        let neighbours = vertex_neighbours(&mesh);
        let mut moved = mesh.positions.clone();
        moved[4] = Vec3::NAN;
        let normals = vec![Vec3::Z; 9];
        bound_moves(
            &mesh.positions,
            &normals,
            &mut moved,
            &neighbours,
            &DisplacementLimit::default(),
        );
        assert!(moved.iter().all(|p| p.is_finite()));
    }
}
