//! The evaluation's integrity columns: for one predicted mesh and its truth, the counts of
//! `mesh::integrity` for both (whole surface and clothed region), and the share of the
//! predicted surface that faces the wrong way (inside-out patches).

use super::prepared::Prepared;
use super::summary::Summary;
use crate::mesh::TriMesh;
use crate::mesh::integrity::{Integrity, integrity_in};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Integrity of a prediction and its truth, one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameIntegrity {
    pub pred: Integrity,
    pub truth: Integrity,
    /// The same counts restricted to the clothed region.
    pub pred_cloth: Integrity,
    pub truth_cloth: Integrity,
    /// Share (0-1) of the predicted area whose face normal opposes the normal of the nearest
    /// true face, whole surface and clothed region.
    pub inside_out: f32,
    pub cloth_inside_out: f32,
}

/// Scores one frame; `clothed(p)` says whether a point lies in the clothed region (by the
/// nearest true vertex, as the surface-error metrics classify their samples).
pub fn frame_integrity(
    pred: &Prepared,
    truth: &Prepared,
    clothed: impl Fn(Vec3) -> bool + Copy,
) -> FrameIntegrity {
    let (inside_out, cloth_inside_out) = inside_out_shares(pred.mesh, truth, clothed);
    FrameIntegrity {
        pred: integrity_in(pred.mesh, |_| true),
        truth: integrity_in(truth.mesh, |_| true),
        pred_cloth: integrity_in(pred.mesh, clothed),
        truth_cloth: integrity_in(truth.mesh, clothed),
        inside_out,
        cloth_inside_out,
    }
}

/// Area shares of `mesh` whose faces point against the nearest face of `truth`: over the
/// whole mesh and over the clothed region.
pub fn inside_out_shares(
    mesh: &TriMesh,
    truth: &Prepared,
    clothed: impl Fn(Vec3) -> bool,
) -> (f32, f32) {
    let truth_normals = truth.mesh.face_normals();
    let (mut area, mut flipped, mut cloth_area, mut cloth_flipped) = (0f64, 0f64, 0f64, 0f64);
    for f in 0..mesh.faces.len() {
        let [a, b, c] = mesh.triangle(f);
        let cross = (b - a).cross(c - a);
        let s = 0.5 * cross.length() as f64;
        if s == 0.0 {
            continue;
        }
        let centroid = (a + b + c) / 3.0;
        let Some(hit) = truth.bvh.closest_point(centroid) else { continue };
        let against = cross.dot(truth_normals[hit.face as usize]) < 0.0;
        area += s;
        flipped += if against { s } else { 0.0 };
        if clothed(centroid) {
            cloth_area += s;
            cloth_flipped += if against { s } else { 0.0 };
        }
    }
    ((flipped / area.max(1e-12)) as f32, (cloth_flipped / cloth_area.max(1e-12)) as f32)
}

/// A row's integrity columns: each count summarised over the row's frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IntegrityRow {
    pub pred_boundary_m: Summary,
    pub truth_boundary_m: Summary,
    pub pred_boundary_edges: Summary,
    pub truth_boundary_edges: Summary,
    pub pred_non_manifold: Summary,
    pub truth_non_manifold: Summary,
    pub pred_pieces: Summary,
    pub truth_pieces: Summary,
    pub pred_small_pieces: Summary,
    pub truth_small_pieces: Summary,
    /// Shares (0-1).
    pub pred_self_intersecting: Summary,
    pub truth_self_intersecting: Summary,
    pub inside_out: Summary,
    /// The clothed region.
    pub pred_cloth_boundary_m: Summary,
    pub truth_cloth_boundary_m: Summary,
    pub cloth_inside_out: Summary,
}

impl IntegrityRow {
    /// `None` for no frames.
    pub fn of(frames: &[FrameIntegrity]) -> Option<IntegrityRow> {
        let s =
            |f: fn(&FrameIntegrity) -> f32| Summary::of(&frames.iter().map(f).collect::<Vec<_>>());
        Some(IntegrityRow {
            pred_boundary_m: s(|i| i.pred.boundary_length_m)?,
            truth_boundary_m: s(|i| i.truth.boundary_length_m)?,
            pred_boundary_edges: s(|i| i.pred.boundary_edges as f32)?,
            truth_boundary_edges: s(|i| i.truth.boundary_edges as f32)?,
            pred_non_manifold: s(|i| i.pred.non_manifold_edges as f32)?,
            truth_non_manifold: s(|i| i.truth.non_manifold_edges as f32)?,
            pred_pieces: s(|i| i.pred.pieces as f32)?,
            truth_pieces: s(|i| i.truth.pieces as f32)?,
            pred_small_pieces: s(|i| i.pred.small_pieces as f32)?,
            truth_small_pieces: s(|i| i.truth.small_pieces as f32)?,
            pred_self_intersecting: s(|i| i.pred.self_intersecting)?,
            truth_self_intersecting: s(|i| i.truth.self_intersecting)?,
            inside_out: s(|i| i.inside_out)?,
            pred_cloth_boundary_m: s(|i| i.pred_cloth.boundary_length_m)?,
            truth_cloth_boundary_m: s(|i| i.truth_cloth.boundary_length_m)?,
            cloth_inside_out: s(|i| i.cloth_inside_out)?,
        })
    }

    /// The Markdown table's header (after the method and outfit columns).
    pub const HEADER: &str = "open border (m) pred / truth | open edges pred / truth | non-manifold edges pred / truth | pieces pred / truth (small) | self-intersecting faces pred / truth | inside-out | clothed open border (m) pred / truth | clothed inside-out";

    /// One Markdown row's cells (means over frames; shares in percent).
    pub fn cells(&self) -> String {
        format!(
            "{:.2} / {:.2} | {:.0} / {:.0} | {:.1} / {:.1} | {:.1} ({:.1}) / {:.1} ({:.1}) | {:.2}% / {:.2}% | {:.2}% | {:.2} / {:.2} | {:.2}%",
            self.pred_boundary_m.mean,
            self.truth_boundary_m.mean,
            self.pred_boundary_edges.mean,
            self.truth_boundary_edges.mean,
            self.pred_non_manifold.mean,
            self.truth_non_manifold.mean,
            self.pred_pieces.mean,
            self.pred_small_pieces.mean,
            self.truth_pieces.mean,
            self.truth_small_pieces.mean,
            100.0 * self.pred_self_intersecting.mean,
            100.0 * self.truth_self_intersecting.mean,
            100.0 * self.inside_out.mean,
            self.pred_cloth_boundary_m.mean,
            self.truth_cloth_boundary_m.mean,
            100.0 * self.cloth_inside_out.mean,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::extract::{ExtractOptions, extract};

    fn sphere(r: f32) -> TriMesh {
        let o = ExtractOptions::new(Vec3::splat(-1.3 * r), Vec3::splat(1.3 * r), 32);
        extract(|p: &[Vec3]| p.iter().map(|x| x.length() - r).collect(), &o).unwrap().mesh
    }

    #[test]
    fn a_flipped_patch_is_counted_by_its_area() {
        let truth = sphere(0.3);
        let mut pred = sphere(0.31);
        // Flip every face of the cap above y = 0.2: its area share is that of a spherical
        // cap, (r - h) / (2 r) with h = 0.2 (up to the faces straddling the cut).
        let mut cap_area = 0.0;
        let total = pred.surface_area();
        for f in 0..pred.faces.len() {
            let [a, b, c] = pred.triangle(f);
            if (a + b + c).y / 3.0 > 0.2 {
                cap_area += pred.triangle_area(f);
                pred.faces[f].swap(1, 2);
            }
        }
        let share = cap_area / total;
        let expected = (0.31 - 0.2) / (2.0 * 0.31);
        assert!((share - expected).abs() < 0.02, "cap share {share} vs {expected}");
        let t = Prepared::new(&truth, "truth").unwrap();
        let (whole, upper) = inside_out_shares(&pred, &t, |p| p.y > 0.0);
        assert!((whole - share).abs() < 1e-3, "inside-out {whole} vs {share}");
        // Half the sphere is the region; the whole cap lies in it.
        assert!((upper - 2.0 * share).abs() < 0.02, "upper half {upper}");
        // The truth against itself: nothing is inside out.
        assert_eq!(inside_out_shares(&truth, &t, |_| true).0, 0.0);
    }
}
