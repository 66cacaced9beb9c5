//! Taubin smoothing (lambda|mu): removes the high-frequency roughness of an extracted surface
//! (marching-cubes terraces, the ripples of a network fitted to noisy points) without the
//! shrinkage of plain Laplacian smoothing. Each iteration is a shrinking step (lambda > 0)
//! followed by an inflating step (mu < -lambda), both toward the mean of the vertex's neighbours.

use super::TriMesh;
use glam::Vec3;

/// Taubin's usual pair: pass band near k = 1/lambda + 1/mu = 0.1.
pub const LAMBDA: f32 = 0.5;
pub const MU: f32 = -0.53;

/// Smooth the mesh's positions in place; faces are unchanged.
pub fn taubin(mesh: &mut TriMesh, iterations: usize) {
    if iterations == 0 || mesh.faces.is_empty() {
        return;
    }
    let neighbours = vertex_neighbours(mesh);
    let mut next = mesh.positions.clone();
    for _ in 0..iterations {
        for factor in [LAMBDA, MU] {
            for (v, out) in next.iter_mut().enumerate() {
                let (start, end) = (neighbours.offsets[v], neighbours.offsets[v + 1]);
                let p = mesh.positions[v];
                if start == end {
                    *out = p;
                    continue;
                }
                let mean = neighbours.indices[start..end]
                    .iter()
                    .map(|&k| mesh.positions[k as usize])
                    .sum::<Vec3>()
                    / (end - start) as f32;
                *out = p + factor * (mean - p);
            }
            std::mem::swap(&mut mesh.positions, &mut next);
        }
    }
}

/// The edge neighbours of every vertex (compressed rows, each neighbour once): vertex v's are
/// `indices[offsets[v]..offsets[v + 1]]`.
pub struct Neighbours {
    pub offsets: Vec<usize>,
    pub indices: Vec<u32>,
}

pub fn vertex_neighbours(mesh: &TriMesh) -> Neighbours {
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(mesh.faces.len() * 6);
    for &[a, b, c] in &mesh.faces {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            edges.push((u, v));
            edges.push((v, u));
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let mut offsets = vec![0usize; mesh.positions.len() + 1];
    for &(u, _) in &edges {
        offsets[u as usize + 1] += 1;
    }
    for i in 0..mesh.positions.len() {
        offsets[i + 1] += offsets[i];
    }
    Neighbours { offsets, indices: edges.into_iter().map(|(_, v)| v).collect() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit icosphere-like sphere: a UV sphere is enough for the properties below.
    fn sphere(rings: usize, segments: usize, radius: impl Fn(usize, usize) -> f32) -> TriMesh {
        let mut positions = vec![Vec3::Y * radius(0, 0)];
        for r in 1..rings {
            let theta = std::f32::consts::PI * r as f32 / rings as f32;
            for s in 0..segments {
                let phi = std::f32::consts::TAU * s as f32 / segments as f32;
                positions.push(
                    Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
                        * radius(r, s),
                );
            }
        }
        positions.push(-Vec3::Y * radius(rings, 0));
        let idx = |r: usize, s: usize| (1 + (r - 1) * segments + s % segments) as u32;
        let last = positions.len() as u32 - 1;
        let mut faces = Vec::new();
        for s in 0..segments {
            faces.push([0, idx(1, s + 1), idx(1, s)]);
            faces.push([last, idx(rings - 1, s), idx(rings - 1, s + 1)]);
        }
        for r in 1..rings - 1 {
            for s in 0..segments {
                faces.push([idx(r, s), idx(r, s + 1), idx(r + 1, s)]);
                faces.push([idx(r, s + 1), idx(r + 1, s + 1), idx(r + 1, s)]);
            }
        }
        TriMesh::new(positions, faces)
    }

    fn radius_spread(mesh: &TriMesh) -> (f32, f32) {
        let r: Vec<f32> = mesh.positions.iter().map(|p| p.length()).collect();
        let mean = r.iter().sum::<f32>() / r.len() as f32;
        let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / r.len() as f32;
        (mean, var.sqrt())
    }

    #[test]
    fn roughness_goes_and_the_size_stays() {
        // A unit sphere with +-2 % alternating bumps (the highest frequency the mesh carries).
        let mut rough = sphere(40, 80, |r, s| if (r + s) % 2 == 0 { 1.02 } else { 0.98 });
        let (mean_before, spread_before) = radius_spread(&rough);
        assert!(spread_before > 0.015);
        taubin(&mut rough, 10);
        let (mean_after, spread_after) = radius_spread(&rough);
        assert!(spread_after < 0.2 * spread_before, "spread {spread_before} -> {spread_after}");
        // Plain Laplacian smoothing would shrink the sphere by several percent; Taubin keeps it.
        assert!(
            (mean_after - mean_before).abs() < 0.01,
            "mean radius {mean_before} -> {mean_after}"
        );
    }

    #[test]
    fn a_smooth_surface_barely_moves_and_isolated_vertices_stay() {
        let mut smooth = sphere(40, 80, |_, _| 1.0);
        smooth.positions.push(Vec3::splat(5.0)); // a vertex no face uses
        let before = smooth.positions.clone();
        taubin(&mut smooth, 10);
        // Off the surface, that is: vertices may slide along it (the UV sphere's poles do).
        let off = before
            .iter()
            .zip(&smooth.positions)
            .take(before.len() - 1)
            .map(|(_, b)| (b.length() - 1.0).abs())
            .fold(0.0, f32::max);
        assert!(off < 0.005, "moved off the sphere by {off}");
        assert_eq!(*smooth.positions.last().unwrap(), Vec3::splat(5.0));
    }
}
