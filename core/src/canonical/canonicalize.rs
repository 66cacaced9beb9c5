//! Canonicalizing a frame's depth points: inverse skinning of every point (and its normal),
//! choosing one root, and the 2 cm reprojection filter.

use super::field::SkinningField;
use super::root_finding::{Root, RootOptions, find_roots, forward_point, start_bones};
use crate::body::{Bones, NUM_JOINTS, blend_transform};
use crate::mesh::TriMesh;
use crate::mesh::point_index::PointIndex;
use glam::{Mat3, Vec3};
use rayon::prelude::*;

/// Points whose canonical -> posed reprojection misses by more than this are dropped (metres).
pub const REPROJECTION_THRESHOLD: f32 = 0.02;

#[derive(Debug, Clone, PartialEq)]
pub struct CanonicalFrame {
    /// Canonical points (metres, body space) and unit normals.
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Index of each kept point in the input.
    pub source: Vec<usize>,
    /// Points with no converged root.
    pub unsolved: usize,
    /// Points dropped by the 2 cm reprojection filter.
    pub dropped: usize,
    pub bones: Bones,
}

impl CanonicalFrame {
    pub fn input_len(&self) -> usize {
        self.points.len() + self.unsolved + self.dropped
    }
}

/// How to pick among several valid roots. The default keeps the root whose field weights
/// best agree with the bone it started from; PINA passes the candidates' SDF values instead.
pub type RootChooser<'a> = &'a (dyn Fn(&[Root]) -> usize + Sync);

pub fn choose_by_agreement(roots: &[Root]) -> usize {
    (0..roots.len()).max_by(|&a, &b| roots[a].agreement.total_cmp(&roots[b].agreement)).unwrap_or(0)
}

/// The root nearest a surface (`distance` of a canonical point to it): the rest body's, before
/// an avatar exists (`Canonicalizer`, and pose refinement's rounds).
pub fn choose_nearest(roots: &[Root], distance: impl Fn(Vec3) -> f32) -> usize {
    let d: Vec<f32> = roots.iter().map(|r| distance(r.canonical)).collect();
    (0..roots.len()).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0)
}

/// Canonicalize posed points (with normals) of one frame. `posed_body` and `body_weights` are
/// the posed body's vertices and skinning weights (to pick the start bones of each point).
#[allow(clippy::too_many_arguments)]
pub fn canonicalize_points(
    field: &SkinningField,
    bones: &Bones,
    posed_body: &[Vec3],
    body_weights: &[[f32; NUM_JOINTS]],
    points: &[Vec3],
    normals: &[Vec3],
    options: &RootOptions,
    chooser: Option<RootChooser>,
) -> CanonicalFrame {
    let index = PointIndex::new(posed_body).ok();
    let results: Vec<Option<(Vec3, Vec3, bool)>> = points
        .par_iter()
        .zip(normals.par_iter())
        .map(|(&p, &n)| {
            let near = match &index {
                Some(ix) => body_weights[ix.nearest(p).0],
                None => {
                    let mut w = [0.0; NUM_JOINTS];
                    w[0] = 1.0;
                    w
                }
            };
            let starts = start_bones(&near, options.max_starts);
            let roots = find_roots(field, &bones.transforms, p, &starts, options);
            if roots.is_empty() {
                return None;
            }
            let pick = match chooser {
                Some(c) => c(&roots).min(roots.len() - 1),
                None => choose_by_agreement(&roots),
            };
            let x = roots[pick].canonical;
            let blend = blend_transform(&bones.transforms, &field.weights_at(x));
            // Normals transform by the inverse transpose; going back, by the transpose.
            let nc = (Mat3::from_mat4(blend).transpose() * n).normalize_or_zero();
            let reprojected = forward_point(field, &bones.transforms, x);
            Some((x, nc, (reprojected - p).length() <= REPROJECTION_THRESHOLD))
        })
        .collect();
    let mut frame = CanonicalFrame {
        points: Vec::new(),
        normals: Vec::new(),
        source: Vec::new(),
        unsolved: 0,
        dropped: 0,
        bones: bones.clone(),
    };
    for (i, r) in results.into_iter().enumerate() {
        match r {
            None => frame.unsolved += 1,
            Some((_, _, false)) => frame.dropped += 1,
            Some((x, n, true)) => {
                frame.points.push(x);
                frame.normals.push(n);
                frame.source.push(i);
            }
        }
    }
    frame
}

/// Forward skinning of a canonical mesh with the field (points and face topology).
pub fn forward_skin_mesh(field: &SkinningField, bones: &Bones, canonical: &TriMesh) -> TriMesh {
    let positions = canonical
        .positions
        .par_iter()
        .map(|&x| forward_point(field, &bones.transforms, x))
        .collect();
    TriMesh::new(positions, canonical.faces.clone())
}
