//! The tree of a mesh whose corners moved: the same splits, the boxes recomputed.

use super::{Bvh, TriMesh, scale_of, triangle_box};
use glam::Vec3;

impl Bvh {
    /// This tree's splits over `mesh`, the same faces with their corners moved (a posed body,
    /// from a tree of the body at rest): the boxes are recomputed from the leaves up, which
    /// costs a fraction of a build. The answers are a fresh build's (they never depend on the
    /// tree's shape); queries slow down where the move carried a node's triangles apart. A
    /// mesh of other faces, or with corners that are not finite, gets a fresh build.
    pub fn refit(&self, mesh: &TriMesh) -> Bvh {
        let same_faces = mesh.faces.len() == self.face_ids.len();
        if !same_faces || mesh.positions.iter().any(|p| !p.is_finite()) {
            return Bvh::build(mesh);
        }
        let tris: Vec<[Vec3; 3]> =
            self.face_ids.iter().map(|&f| mesh.triangle(f as usize)).collect();
        let mut nodes = self.nodes.clone();
        // Preorder: both children of a node come after it, so a reverse pass sees them first.
        for i in (0..nodes.len()).rev() {
            let node = nodes[i];
            let (min, max) = if node.count > 0 {
                let start = node.first as usize;
                tris[start..start + node.count as usize].iter().map(triangle_box).fold(
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                    |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
                )
            } else {
                let (l, r) = (&nodes[i + 1], &nodes[node.first as usize]);
                (l.min.min(r.min), l.max.max(r.max))
            };
            (nodes[i].min, nodes[i].max) = (min, max);
        }
        let scale = scale_of(&tris);
        Bvh {
            nodes,
            tris,
            face_ids: self.face_ids.clone(),
            tree_index: self.tree_index.clone(),
            scale,
        }
    }
}
