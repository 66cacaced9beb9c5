//! The simulated garments' rest shapes. The skirt is the template's waist panel (a flared
//! tube); the cape is the template's too (`synth::outfit`, `cape.rs`): a sheet hanging from
//! the shoulders behind the back down to the knees. Every garment vertex records (height fraction 0 at the top .. 1 at the hem,
//! angle or width coordinate) in `ClothedTemplate::panel`; the top row hangs from the body.

use super::super::outfit::ClothedTemplate;
use crate::mesh::TriMesh;
use glam::Vec3;

/// The garment alone (the template's vertices after the body's, and the faces among them),
/// at the given positions of those vertices.
pub fn garment_mesh(t: &ClothedTemplate, positions: Vec<Vec3>) -> TriMesh {
    let base = t.body_vertices as u32;
    let faces = t
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| v >= base))
        .map(|f| f.map(|v| v - base))
        .collect();
    TriMesh::new(positions, faces)
}

/// The garment vertices that hang from the body (its top row), as garment indices.
pub fn pinned_vertices(t: &ClothedTemplate) -> Vec<u32> {
    t.panel.iter().enumerate().filter(|(_, (h, _))| *h == 0.0).map(|(i, _)| i as u32).collect()
}
