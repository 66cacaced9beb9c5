//! Whether a surface is whole: open borders, non-manifold edges, separate pieces and faces that
//! cut through other faces. Distances (Chamfer, Df) cannot see a hole or a torn sheet; these
//! counts can, and the evaluation reports them for the prediction and the truth side by side.
//!
//! Vertices at bit-identical positions are merged first, so a mesh written with split vertices
//! (per-face normals, seams) is judged by its geometry, not by its indexing.

use super::TriMesh;
use super::topology::edge_use;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// A piece smaller than this share of the whole area counts as a small piece (a shard).
pub const SMALL_PIECE_SHARE: f32 = 0.01;

/// The integrity counts of one mesh (or of one region of it).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Integrity {
    /// Edges used by exactly one face: the open border (a garment's hem, or a hole).
    pub boundary_edges: usize,
    /// Their total length (metres).
    pub boundary_length_m: f32,
    /// Edges used by three or more faces.
    pub non_manifold_edges: usize,
    /// Connected pieces (faces sharing an edge are connected).
    pub pieces: usize,
    /// Pieces under `SMALL_PIECE_SHARE` of the total area.
    pub small_pieces: usize,
    /// Share (0-1) of the faces that cross another face they share no vertex with.
    pub self_intersecting: f32,
}

/// Faces re-indexed onto merged vertices, degenerate faces (two equal corners) dropped.
struct Welded {
    positions: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
}

fn weld(mesh: &TriMesh) -> Welded {
    let mut index_of: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let mut positions = Vec::with_capacity(mesh.positions.len());
    let remap: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let key = super::topology::position_key(*p);
            *index_of.entry(key).or_insert_with(|| {
                positions.push(*p);
                positions.len() as u32 - 1
            })
        })
        .collect();
    let mut faces = Vec::with_capacity(mesh.faces.len());
    for face in &mesh.faces {
        let [a, b, c] = face.map(|v| remap[v as usize]);
        if a != b && b != c && a != c {
            faces.push([a, b, c]);
        }
    }
    Welded { positions, faces }
}

/// The open border: every edge used by exactly one face, as its two end points.
pub fn boundary_segments(mesh: &TriMesh) -> Vec<(Vec3, Vec3)> {
    let w = weld(mesh);
    let mut out: Vec<(Vec3, Vec3)> = edge_use(&w.faces)
        .into_iter()
        .filter(|&(_, n)| n == 1)
        .map(|((a, b), _)| (w.positions[a as usize], w.positions[b as usize]))
        .collect();
    // Hash order is not deterministic; the drawing should be.
    out.sort_by(|x, y| {
        x.0.to_array().partial_cmp(&y.0.to_array()).unwrap_or(std::cmp::Ordering::Equal)
    });
    out
}

/// Integrity of the whole mesh.
pub fn integrity(mesh: &TriMesh) -> Integrity {
    integrity_in(mesh, |_| true)
}

/// Integrity of the part of the mesh where `region(point)` holds: edges by their midpoint,
/// faces by their centroid. Pieces are counted over the whole mesh either way (a region cuts
/// pieces apart).
pub fn integrity_in(mesh: &TriMesh, region: impl Fn(Vec3) -> bool) -> Integrity {
    let w = weld(mesh);
    if w.faces.is_empty() {
        return Integrity::default();
    }
    let mut out = Integrity::default();
    for (&(a, b), &n) in &edge_use(&w.faces) {
        let (pa, pb) = (w.positions[a as usize], w.positions[b as usize]);
        if !region(0.5 * (pa + pb)) {
            continue;
        }
        if n == 1 {
            out.boundary_edges += 1;
            out.boundary_length_m += pa.distance(pb);
        } else if n > 2 {
            out.non_manifold_edges += 1;
        }
    }
    let (pieces, small) = pieces(&w);
    out.pieces = pieces;
    out.small_pieces = small;
    let crossing = self_intersecting_faces(&w.positions, &w.faces);
    let centroid = |f: &[u32; 3]| f.iter().map(|&v| w.positions[v as usize]).sum::<Vec3>() / 3.0;
    let in_region: Vec<bool> = w.faces.iter().map(|f| region(centroid(f))).collect();
    let counted = in_region.iter().filter(|&&r| r).count();
    let crossed = crossing.iter().zip(&in_region).filter(|&(&c, &r)| c && r).count();
    out.self_intersecting = crossed as f32 / counted.max(1) as f32;
    out
}

/// Pieces connected through shared edges, and how many of them are under
/// `SMALL_PIECE_SHARE` of the area.
fn pieces(w: &Welded) -> (usize, usize) {
    let (labels, count) = super::topology::edge_components(&w.faces);
    let mut area = vec![0f32; count];
    for (f, &[a, b, c]) in w.faces.iter().enumerate() {
        let [pa, pb, pc] = [a, b, c].map(|v| w.positions[v as usize]);
        area[labels[f] as usize] += 0.5 * (pb - pa).cross(pc - pa).length();
    }
    let total: f32 = area.iter().sum();
    (count, area.iter().filter(|&&s| s < SMALL_PIECE_SHARE * total).count())
}

pub use super::crossings::{self_intersecting_faces, triangles_cross};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::extract::{ExtractOptions, extract};

    fn sphere(center: Vec3, r: f32, res: usize) -> TriMesh {
        let o =
            ExtractOptions::new(center - Vec3::splat(r * 1.3), center + Vec3::splat(r * 1.3), res);
        extract(|p: &[Vec3]| p.iter().map(|x| x.distance(center) - r).collect(), &o).unwrap().mesh
    }

    /// Both meshes in one (`b`'s vertices after `a`'s).
    fn joined(mut a: TriMesh, b: &TriMesh) -> TriMesh {
        let n = a.positions.len() as u32;
        a.positions.extend(&b.positions);
        a.faces.extend(b.faces.iter().map(|f| f.map(|v| v + n)));
        a
    }

    #[test]
    fn a_closed_sphere_is_whole() {
        let s = sphere(Vec3::ZERO, 0.3, 32);
        let i = integrity(&s);
        assert_eq!(i.boundary_edges, 0, "{i:?}");
        assert_eq!(i.boundary_length_m, 0.0);
        assert_eq!(i.non_manifold_edges, 0);
        assert_eq!(i.pieces, 1);
        assert_eq!(i.small_pieces, 0);
        assert_eq!(i.self_intersecting, 0.0);
    }

    #[test]
    fn a_cut_cap_leaves_a_circular_border_of_known_length() {
        let r = 0.3;
        let s = sphere(Vec3::ZERO, r, 48);
        // Drop every face with a corner above y = 0.2: the hole's rim is a circle of radius
        // sqrt(r^2 - y^2) at about that height, traced by the kept faces' top edges.
        let faces: Vec<[u32; 3]> = s
            .faces
            .iter()
            .copied()
            .filter(|f| f.iter().all(|&v| s.positions[v as usize].y <= 0.2))
            .collect();
        let cut = TriMesh::new(s.positions.clone(), faces);
        let i = integrity(&cut);
        let rim_y = cut
            .faces
            .iter()
            .flat_map(|f| f.iter().map(|&v| cut.positions[v as usize].y))
            .fold(f32::MIN, f32::max);
        let circle = std::f32::consts::TAU * (r * r - rim_y * rim_y).sqrt();
        // A marching-cubes rim zigzags along the cells: longer than the circle, by less than
        // the sqrt(2) of a staircase.
        assert!(
            i.boundary_length_m > 0.98 * circle && i.boundary_length_m < 1.45 * circle,
            "border {} m, circle {circle} m",
            i.boundary_length_m
        );
        assert!(i.boundary_edges > 20);
        assert_eq!(i.non_manifold_edges, 0);
        assert_eq!(i.pieces, 1);
        // Only the region around the rim sees the border.
        let above = integrity_in(&cut, |p| p.y > 0.0);
        let below = integrity_in(&cut, |p| p.y < 0.0);
        assert_eq!(above.boundary_edges, i.boundary_edges);
        assert_eq!(below.boundary_edges, 0);
    }

    #[test]
    fn two_spheres_are_two_pieces_and_a_shard_is_small() {
        let m = joined(sphere(Vec3::ZERO, 0.3, 32), &sphere(Vec3::new(1.0, 0.0, 0.0), 0.02, 12));
        let i = integrity(&m);
        assert_eq!(i.pieces, 2);
        assert_eq!(i.small_pieces, 1, "a 2 cm sphere is under 1 % of a 30 cm one's area");
        assert_eq!(i.boundary_edges, 0);
        // Split vertices (each face its own corners) are merged back: still two closed pieces.
        let split = TriMesh::new(
            m.faces.iter().flat_map(|f| f.map(|v| m.positions[v as usize])).collect(),
            (0..m.faces.len() as u32).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect(),
        );
        assert_eq!(integrity(&split), i);
    }

    #[test]
    fn overlapping_spheres_cross_each_other_along_one_circle() {
        let m = joined(sphere(Vec3::ZERO, 0.3, 32), &sphere(Vec3::new(0.3, 0.0, 0.0), 0.3, 32));
        let i = integrity(&m);
        assert_eq!(i.pieces, 2);
        let crossing = self_intersecting_faces(&m.positions, &m.faces);
        // Every crossing face lies near the circle where the spheres meet: |p| = |p - c| = r,
        // at x = 0.15.
        for (f, face) in m.faces.iter().enumerate().filter(|(f, _)| crossing[*f]) {
            let c = face.iter().map(|&v| m.positions[v as usize]).sum::<Vec3>() / 3.0;
            assert!((c.x - 0.15).abs() < 0.04, "face {f} at {c} crosses");
        }
        assert!(i.self_intersecting > 0.01 && i.self_intersecting < 0.2, "{i:?}");
    }

    #[test]
    fn a_fin_on_an_edge_is_non_manifold() {
        // Two triangles sharing the edge (0, 1), and a third one on the same edge.
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z];
        let faces = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let i = integrity(&TriMesh::new(positions, faces));
        assert_eq!(i.non_manifold_edges, 1);
        assert_eq!(i.boundary_edges, 6);
        assert_eq!(i.pieces, 1);
    }
}
