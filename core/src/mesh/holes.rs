//! Holes in a surface: the loops of its open border, and closing the short ones. A garment's
//! real borders (a hem, a neckline) are long loops; the holes that an extraction tears
//! through a thin sheet are short ones.

use super::TriMesh;
use super::topology::edge_use;
use glam::Vec3;
use std::collections::HashMap;

/// The open border as closed loops of vertex indices, each in the direction its faces run
/// (a face (a, b, c) with its edge a -> b on the border continues the loop from b). Border
/// edges that do not close into a loop (at non-manifold vertices) are left out.
pub fn border_loops(mesh: &TriMesh) -> Vec<Vec<u32>> {
    let uses = edge_use(&mesh.faces);
    // Directed border edges, from each start vertex.
    let mut next: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut starts = Vec::new();
    for &[a, b, c] in &mesh.faces {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            if uses[&(u.min(v), u.max(v))] == 1 {
                next.entry(u).or_default().push(v);
                starts.push(u);
            }
        }
    }
    starts.sort_unstable();
    starts.dedup();
    let mut loops = Vec::new();
    for start in starts {
        while next.get(&start).is_some_and(|n| !n.is_empty()) {
            let mut path = vec![start];
            let mut at = start;
            let closed = loop {
                let Some(v) = next.get_mut(&at).and_then(|n| n.pop()) else { break false };
                if v == start {
                    break true;
                }
                path.push(v);
                at = v;
                if path.len() > mesh.positions.len() {
                    break false;
                }
            };
            if closed && path.len() >= 3 {
                loops.push(path);
            }
        }
    }
    loops
}

/// The length (metres) of a closed loop.
pub fn loop_length(mesh: &TriMesh, path: &[u32]) -> f32 {
    let p = |i: usize| mesh.positions[path[i % path.len()] as usize];
    (0..path.len()).map(|i| p(i).distance(p(i + 1))).sum()
}

/// Closes every border loop shorter than `max_length` (metres) that passes each of its vertices
/// once with a fan around its centroid, facing as the faces around it do. Returns the mesh and how many holes were closed.
pub fn close_short_holes(mesh: &TriMesh, max_length: f32) -> (TriMesh, usize) {
    let mut out = mesh.clone();
    let mut closed = 0;
    for path in border_loops(mesh) {
        // A loop through a vertex twice (two holes meeting at a pinch) would get a fan on both
        // sides of that vertex: edges of three faces. Such loops stay open.
        let mut seen = path.clone();
        seen.sort_unstable();
        seen.dedup();
        if loop_length(mesh, &path) >= max_length || seen.len() != path.len() {
            continue;
        }
        let centre =
            path.iter().map(|&v| mesh.positions[v as usize]).sum::<Vec3>() / path.len() as f32;
        let c = out.positions.len() as u32;
        out.positions.push(centre);
        for i in 0..path.len() {
            let (a, b) = (path[i], path[(i + 1) % path.len()]);
            // The border edge runs a -> b in its face; the patch runs it b -> a.
            out.faces.push([b, a, c]);
        }
        closed += 1;
    }
    (out, closed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::extract::{ExtractOptions, extract};
    use crate::mesh::integrity::integrity;

    fn sphere_with_hole(top: f32) -> TriMesh {
        let r = 0.3;
        let o = ExtractOptions::new(Vec3::splat(-1.3 * r), Vec3::splat(1.3 * r), 40);
        let s = extract(|p: &[Vec3]| p.iter().map(|x| x.length() - r).collect(), &o).unwrap().mesh;
        let faces =
            s.faces.iter().copied().filter(|f| f.iter().all(|&v| s.positions[v as usize].y <= top));
        TriMesh::new(s.positions.clone(), faces.collect())
    }

    #[test]
    fn a_short_hole_is_closed_facing_out_and_a_long_border_is_kept() {
        // A hole of about 2 pi sqrt(0.3^2 - 0.28^2) = 0.68 m around the top.
        let holed = sphere_with_hole(0.28);
        let loops = border_loops(&holed);
        assert_eq!(loops.len(), 1);
        let length = loop_length(&holed, &loops[0]);
        assert!(length > 0.6 && length < 1.0, "{length}");
        let (kept, n) = close_short_holes(&holed, 0.5);
        assert_eq!((n, kept), (0, holed.clone()));
        let (closed, n) = close_short_holes(&holed, 1.0);
        assert_eq!(n, 1);
        let i = integrity(&closed);
        assert_eq!((i.boundary_edges, i.non_manifold_edges, i.pieces), (0, 0, 1));
        // The patch faces out, as the sphere does: the closed mesh's volume is the sphere's.
        let v = closed.signed_volume();
        let ball = 4.0 / 3.0 * std::f32::consts::PI * 0.3f32.powi(3);
        assert!((v - ball).abs() < 0.03 * ball, "volume {v} vs {ball}");
    }

    #[test]
    fn a_sheet_keeps_its_hem_and_loses_its_holes() {
        // The lower half of a sphere is a bowl (its rim is a 1.9 m border); punch two holes.
        let bowl = sphere_with_hole(0.0);
        let mut faces = bowl.faces.clone();
        for c in [Vec3::new(0.0, -0.3, 0.0), Vec3::new(0.3, -0.05, 0.0)] {
            faces.retain(|f| {
                let p = f.iter().map(|&v| bowl.positions[v as usize]).sum::<Vec3>() / 3.0;
                p.distance(c) > 0.04
            });
        }
        let holed = TriMesh::new(bowl.positions.clone(), faces);
        assert_eq!(border_loops(&holed).len(), 3);
        let (closed, n) = close_short_holes(&holed, 0.5);
        assert_eq!(n, 2);
        let loops = border_loops(&closed);
        assert_eq!(loops.len(), 1);
        assert!(loop_length(&closed, &loops[0]) > 1.8);
    }

    #[test]
    fn two_holes_meeting_at_a_vertex_leave_no_non_manifold_edge() {
        // A 6 x 6 grid of quads with two cells cut out that touch at one corner (a pinch).
        let n = 7;
        let positions: Vec<Vec3> = (0..n * n)
            .map(|i| Vec3::new((i % n) as f32 * 0.02, (i / n) as f32 * 0.02, 0.0))
            .collect();
        let idx = |r: usize, c: usize| (r * n + c) as u32;
        let mut faces = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                if (r, c) == (2, 2) || (r, c) == (3, 3) {
                    continue;
                }
                faces.push([idx(r, c), idx(r, c + 1), idx(r + 1, c + 1)]);
                faces.push([idx(r, c), idx(r + 1, c + 1), idx(r + 1, c)]);
            }
        }
        let grid = TriMesh::new(positions, faces);
        let (closed, _) = close_short_holes(&grid, 0.3);
        let i = integrity(&closed);
        assert_eq!(i.non_manifold_edges, 0, "{i:?}");
        // The outer border (0.48 m) is no hole; the pinched pair (0.16 m, through one vertex
        // twice) stays open rather than get a fan on both sides of the pinch.
        assert!((i.boundary_length_m - 0.64).abs() < 1e-4, "{i:?}");
    }
}
