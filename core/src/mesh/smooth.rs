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

/// Taubin smoothing of the open border alone: each vertex on a border loop moves toward the
/// mean of its two neighbours along the loop, the rest of the mesh stays. A sheet sampled on
/// a grid has a staircase for a hem (a row up, a column on) and a rim that zigzags in and out
/// where rays graze it; smoothed along the loop it becomes the curve it stands for. Each vertex
/// moves at most `max_move` (metres) from where it was, so the faces along the border cannot
/// fold over their inner vertices. Vertices on two loops (a pinch) stay.
pub fn smooth_borders(mesh: &mut TriMesh, iterations: usize, max_move: f32) {
    let loops = super::holes::border_loops(mesh);
    let mut visits = vec![0u8; mesh.positions.len()];
    for v in loops.iter().flatten() {
        visits[*v as usize] = visits[*v as usize].saturating_add(1);
    }
    let start = mesh.positions.clone();
    for path in loops.iter().filter(|l| l.len() >= 4) {
        let n = path.len();
        let mut p: Vec<Vec3> = path.iter().map(|&v| mesh.positions[v as usize]).collect();
        let mut next = p.clone();
        for _ in 0..iterations {
            for factor in [LAMBDA, MU] {
                for i in 0..n {
                    let mean = 0.5 * (p[(i + n - 1) % n] + p[(i + 1) % n]);
                    next[i] = p[i] + factor * (mean - p[i]);
                }
                std::mem::swap(&mut p, &mut next);
            }
        }
        for (&v, q) in path.iter().zip(p) {
            if visits[v as usize] == 1 {
                let from = start[v as usize];
                let step = q - from;
                let length = step.length();
                mesh.positions[v as usize] =
                    if length > max_move { from + step * (max_move / length) } else { q };
            }
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

    /// A flat sheet 40 x 10 cm on a 1 cm grid whose lower border is a staircase: a row up and
    /// down every 2 columns.
    fn stepped_sheet() -> TriMesh {
        let (columns, rows) = (41usize, 11usize);
        let lowest = |c: usize| (c / 2) % 2;
        let index = |r: usize, c: usize| (r * columns + c) as u32;
        let positions: Vec<Vec3> = (0..rows)
            .flat_map(|r| (0..columns).map(move |c| Vec3::new(c as f32, r as f32, 0.0) * 0.01))
            .collect();
        let mut faces = Vec::new();
        for r in 0..rows - 1 {
            for c in 0..columns - 1 {
                let present = |rr: usize, cc: usize| rr >= lowest(cc);
                let (a, b, cc, d) = ((r, c), (r + 1, c), (r, c + 1), (r + 1, c + 1));
                let p = |(rr, c2): (usize, usize)| present(rr, c2).then(|| index(rr, c2));
                match (p(a), p(b), p(cc), p(d)) {
                    (Some(a), Some(b), Some(c), Some(d)) => faces.extend([[a, c, b], [b, c, d]]),
                    (None, Some(b), Some(c), Some(d)) => faces.push([b, c, d]),
                    (Some(a), Some(b), None, Some(d)) => faces.push([a, d, b]),
                    _ => {}
                }
            }
        }
        super::super::topology::compact(&positions, &faces)
    }

    #[test]
    fn a_stepped_border_straightens_and_the_inside_stays() {
        use crate::mesh::holes::{border_loops, loop_length};
        let mut sheet = stepped_sheet();
        let before = sheet.positions.clone();
        let length = |m: &TriMesh| border_loops(m).iter().map(|l| loop_length(m, l)).sum::<f32>();
        let stepped = length(&sheet);
        smooth_borders(&mut sheet, 10, 0.01);
        let smoothed = length(&sheet);
        // The rectangle's outline is 1.0 m (40 + 10 + 40 + 10 cm); the steps, cut diagonally by
        // the triangulation, add 8 cm; smoothed, the corners round a little.
        assert!(stepped > 1.07, "stepped border {stepped} m");
        assert!(smoothed < 1.0 && smoothed > 0.95, "{stepped} -> {smoothed} m");
        let border: std::collections::HashSet<u32> =
            border_loops(&sheet).into_iter().flatten().collect();
        for (v, (a, b)) in before.iter().zip(&sheet.positions).enumerate() {
            assert!(a.distance(*b) <= 0.01 + 1e-6, "vertex {v} moved {}", a.distance(*b));
            if !border.contains(&(v as u32)) {
                assert_eq!(a, b, "inner vertex {v} moved");
            }
        }
        // No face folds over: every normal still faces +z.
        assert!(sheet.face_normals().iter().all(|n| n.z > 0.5));
    }
}
