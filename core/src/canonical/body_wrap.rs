//! A clothed surface on the body's own mesh: each vertex of the rest body moved along its
//! normal onto the avatar's surface (an SDF's zero level), where clothing lies close enough
//! for that to reach it (shirts, sleeves, trousers: the cloth is the body plus an offset).
//!
//! Why not the marching-cubes mesh: its vertex normals carry the grid (irregular triangles; on
//! a 5 cm limb at 1 cm cells an exact sphere's area-weighted vertex normals are 0.02 off even
//! with every vertex on the sphere), its vertices sit where the grid puts them, and it cannot
//! resolve hands, a face or the gap between the arm and the torso at the depth's resolution.
//! The body's mesh keeps all of that, its topology is the one the body's skinning and any
//! artist's tools were made for, and the depth only has to give the offset, which varies
//! slowly. Where the surface cannot be reached along the normal within the band (a hand
//! swallowed by a blob of the SDF, the web of an armpit), the vertex stays on the body.
//!
//! Loose clothing (a skirt, a blazer's tails) is not an offset of the body: the extracted mesh
//! is then farther from the wrapped body than `WrapOptions::far` over more than `max_uncovered`
//! of its area ([`BodyWrap::covers`]), and the avatar is the wrapped body with the extracted
//! mesh's loose pieces beside it ([`BodyWrap::with_loose_pieces`]); a piece lying mostly round
//! parts of the body too thin to wrap (the SDF's blob round a hand) is not clothing and is left
//! out. The wrapped body is posed with the body's own skinning weights
//! ([`BodyWrap::own_weights`]).

use super::fold_guard::FoldGuard;
use super::garment_sheet::{GarmentSheet, SheetGridOptions};
use crate::body::{BodyModel, Weights, interpolate_weights};
use crate::mesh::TriMesh;
use crate::mesh::barycentric;
use crate::mesh::bvh::Bvh;
use crate::mesh::holes::close_short_holes;
use crate::mesh::smooth::smooth_borders;
use crate::mesh::topology::{
    compact, drop_non_manifold_faces, drop_small_pieces, edge_use, face_components,
};
use glam::Vec3;
use rayon::prelude::*;

mod options;
pub use options::{SpanCrossings, SurfaceChoice, WrapOptions};

/// The SMPL joints of the neck and the head.
const NECK: usize = 12;
const HEAD: usize = 15;

/// The rest body of one subject, ready to wrap surfaces.
pub struct BodyWrap {
    rest: TriMesh,
    /// The rest body's surface area (square metres).
    rest_area: f32,
    normals: Vec<Vec3>,
    /// The body's thickness at each vertex (metres, along the inward normal; infinite where
    /// the ray leaves no other side within 20 cm).
    thickness: Vec<f32>,
    /// The radius of the largest ball that touches the body at each vertex from outside, and
    /// from inside (metres, at most `MAX_REACH`): how far the vertex can move along its normal
    /// before the moved surface folds over itself.
    reach_out: Vec<f32>,
    reach_in: Vec<f32>,
    guard: FoldGuard,
    /// The head's vertices (dominant joint the neck or the head; none for a mesh without
    /// weights).
    head: Vec<bool>,
    /// The grid loose cloth is remade on.
    pub sheet: GarmentSheet,
    pub options: WrapOptions,
}

/// A wrapped surface: the body's mesh with each vertex on the surface, or left on the body
/// (`found` false) where the surface was not reached within the band.
pub struct Wrapped {
    pub mesh: TriMesh,
    pub found: Vec<bool>,
}

impl BodyWrap {
    pub fn new(body: &BodyModel, betas: &[f32]) -> BodyWrap {
        let mut wrap = Self::of_mesh(body.mesh(body.shaped_vertices(betas)));
        wrap.head = body
            .weights
            .iter()
            .map(|w| matches!(crate::body::skinning::dominant_joint(w), NECK | HEAD))
            .collect();
        wrap
    }

    /// Any closed mesh with outward faces as the body (tests use spheres).
    pub fn of_mesh(rest: TriMesh) -> BodyWrap {
        let normals = rest.vertex_normals();
        let bvh = Bvh::build(&rest);
        let thickness = rest
            .positions
            .par_iter()
            .zip(&normals)
            .map(|(&x, &n)| thickness_at(&bvh, x, n))
            .collect();
        let reach = |side: f32| -> Vec<f32> {
            rest.positions
                .par_iter()
                .zip(&normals)
                .map(|(&x, &n)| touching_ball_radius(&bvh, x, side * n))
                .collect()
        };
        let (reach_out, reach_in) = (reach(1.0), reach(-1.0));
        BodyWrap {
            reach_out,
            reach_in,
            rest_area: rest.surface_area(),
            guard: FoldGuard::new(&rest),
            head: vec![false; rest.positions.len()],
            sheet: GarmentSheet::around(&rest, SheetGridOptions::default()),
            rest,
            normals,
            thickness,
            options: WrapOptions::default(),
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.rest.positions.len()
    }

    /// Each body vertex moved along its normal to the surface `sdf` (metres, negative inside)
    /// crosses outward nearest to the body; `sdf` is called once, on every probe together.
    pub fn wrap(&self, sdf: impl Fn(&[Vec3]) -> Vec<f32>) -> Wrapped {
        self.wrap_within(sdf, self.options.outside)
    }

    /// [`BodyWrap::wrap`] looking no farther than `outside` (metres) out.
    pub fn wrap_within(&self, sdf: impl Fn(&[Vec3]) -> Vec<f32>, outside: f32) -> Wrapped {
        let o = &self.options;
        let count = ((o.inside + outside) / o.step).round() as usize + 1;
        let steps: Vec<f32> = (0..count).map(|i| -o.inside + o.step * i as f32).collect();
        let probes: Vec<Vec3> = self
            .rest
            .positions
            .iter()
            .zip(&self.normals)
            .flat_map(|(&x, &n)| steps.iter().map(move |&t| x + t * n))
            .collect();
        let values = sdf(&probes);
        let mut offsets: Vec<Option<f32>> = values
            .par_chunks(count)
            .zip(&self.thickness)
            .map(
                |(f, &thick)| {
                    if thick < o.thin { None } else { outward_crossing_nearest_zero(&steps, f) }
                },
            )
            .collect();
        for ((t, &out), &inward) in offsets.iter_mut().zip(&self.reach_out).zip(&self.reach_in) {
            if let Some(t) = t {
                *t = t.clamp(-o.crease_share * inward, o.crease_share * out);
            }
        }
        self.guard.unfold(&self.rest, &self.normals, &mut offsets);
        let positions = self
            .rest
            .positions
            .iter()
            .zip(&self.normals)
            .zip(&offsets)
            .map(|((&x, &n), t)| x + t.unwrap_or(0.0) * n)
            .collect();
        Wrapped {
            mesh: TriMesh::new(positions, self.rest.faces.clone()),
            found: offsets.iter().map(Option::is_some).collect(),
        }
    }

    /// Spans the crossing faces of a wrapped surface (`mesh` has the body's faces; its vertices
    /// moved by [`BodyWrap::wrap`] and smoothed after it) where [`WrapOptions::span_crossings`]
    /// says, but for the bare body's own crossings (`FoldGuard::span_crossings`). Returns how
    /// many faces crossed before in pairs with a face that may move; a mesh of other faces is
    /// left as it is.
    pub fn span_crossings(&self, mesh: &mut TriMesh) -> usize {
        if mesh.faces != self.rest.faces {
            return 0;
        }
        let everywhere;
        let movable: &[bool] = match self.options.span_crossings {
            SpanCrossings::Nowhere => return 0,
            SpanCrossings::Head => &self.head,
            SpanCrossings::Everywhere => {
                everywhere = vec![true; self.head.len()];
                &everywhere
            }
        };
        self.guard.span_crossings(&self.rest, &mut mesh.positions, movable)
    }

    /// The share of `extracted`'s area farther than `options.far` from `wrapped`.
    pub fn uncovered_share(&self, wrapped: &TriMesh, extracted: &TriMesh) -> f32 {
        let far = faces_far_from(&Bvh::build(wrapped), extracted, self.options.far);
        let area = |f: usize| extracted.triangle_area(f) as f64;
        let total: f64 = (0..extracted.faces.len()).map(area).sum();
        let uncovered: f64 = (0..extracted.faces.len()).filter(|&f| far[f]).map(area).sum();
        if total > 0.0 { (uncovered / total) as f32 } else { 0.0 }
    }

    /// Whether the wrapped body stands for `extracted` (tight clothing only).
    pub fn covers(&self, wrapped: &TriMesh, extracted: &TriMesh) -> bool {
        self.uncovered_share(wrapped, extracted) <= self.options.max_uncovered
    }

    /// `wrapped` (wrapped within `options.tight_outside`) with the pieces of `extracted`
    /// farther than `options.far` from it: the wrapped body's vertices first, in the body's
    /// order, then the pieces'. Each piece's border vertices within `options.seam` of the
    /// wrapped body are put on it; pieces under `options.min_piece_share` of the body's area are
    /// dropped. What hangs round the body is remade as one sheet (`options.remesh_loose`;
    /// `sdf`: the surface's signed distance, as for [`BodyWrap::wrap`]).
    pub fn with_loose_pieces(
        &self,
        wrapped: &TriMesh,
        extracted: &TriMesh,
        sdf: impl Fn(&[Vec3]) -> Vec<f32>,
    ) -> TriMesh {
        let o = &self.options;
        let bvh = Bvh::build(wrapped);
        let far = faces_far_from(&bvh, extracted, o.far);
        let loose: Vec<[u32; 3]> =
            extracted.faces.iter().zip(&far).filter(|(_, f)| **f).map(|(f, _)| *f).collect();
        let chosen = drop_small_pieces(
            &compact(&extracted.positions, &loose),
            o.min_shred_share * self.rest_area,
        );
        let chosen = close_short_holes(&chosen, o.max_hole).0;
        let mut pieces = self.clothing_pieces(&chosen, &bvh);
        if o.remesh_loose {
            pieces = self.sheet.remesh(&pieces, sdf, |p| !bvh.any_within(p, o.far));
        }
        // Border edges (one face) of the pieces: their vertices go onto the body nearby.
        let mut border: Vec<u32> = edge_use(&pieces.faces)
            .iter()
            .filter(|(_, n)| **n == 1)
            .flat_map(|(e, _)| [e.0, e.1])
            .collect();
        border.sort_unstable();
        border.dedup();
        let mut seam = Vec::new();
        for v in border {
            if let Some(hit) = bvh.closest_point_within(pieces.positions[v as usize], o.seam) {
                pieces.positions[v as usize] = hit.point;
                seam.push(v);
            }
        }
        // Put onto the body, a border zigzags as far as its vertices were from it: smoothed
        // along itself, then the seam's vertices back onto the body (exactly: `own_weights`).
        let sheet = &self.sheet.options;
        smooth_borders(&mut pieces, sheet.border_smoothing, sheet.border_reach);
        for v in seam {
            if let Some(hit) = bvh.closest_point(pieces.positions[v as usize]) {
                pieces.positions[v as usize] = hit.point;
            }
        }
        let base = wrapped.positions.len() as u32;
        let mut merged = wrapped.clone();
        merged.positions.extend(pieces.positions);
        merged.faces.extend(pieces.faces.iter().map(|f| f.map(|v| v + base)));
        // A seam vertex put onto the body can land on a body vertex: the two make one, and an
        // edge there may gain a third face.
        drop_non_manifold_faces(&merged, wrapped.faces.len()).0
    }

    /// The connected pieces (faces sharing a vertex) of `mesh` that can be clothing: not
    /// fragments (less than `min_piece_share` of the body's area), and not lying mostly round a
    /// part of the body too thin to wrap (the SDF's blob round a hand, which the body's own hand
    /// stands for, as it does in the wrapped body). `wrapped`: the wrapped body's faces (the rest body's).
    fn clothing_pieces(&self, mesh: &TriMesh, wrapped: &Bvh) -> TriMesh {
        let (labels, count) = face_components(mesh);
        let (mut piece_area, mut thin_area) = (vec![0f32; count], vec![0f32; count]);
        let thin_vertex = |v: u32| self.thickness[v as usize] < self.options.thin;
        for (f, &l) in labels.iter().enumerate() {
            let [a, b, c] = mesh.triangle(f);
            let area = mesh.triangle_area(f);
            piece_area[l as usize] += area;
            let near_thin = wrapped.closest_point((a + b + c) / 3.0).is_some_and(|hit| {
                self.rest.faces[hit.face as usize].iter().filter(|&&v| thin_vertex(v)).count() >= 2
            });
            if near_thin {
                thin_area[l as usize] += area;
            }
        }
        let min_area = self.options.min_piece_share * self.rest_area;
        let clothing = |l: usize| piece_area[l] >= min_area && thin_area[l] <= 0.5 * piece_area[l];
        let kept: Vec<[u32; 3]> = mesh
            .faces
            .iter()
            .zip(&labels)
            .filter(|(_, l)| clothing(**l as usize))
            .map(|(f, _)| *f)
            .collect();
        compact(&mesh.positions, &kept)
    }

    /// Where each vertex of a wrapped surface ([`BodyWrap::wrap`], or
    /// [`BodyWrap::with_loose_pieces`]: its body faces first) stands, for skinning: the body's
    /// own weights (`body_weights`, one per body vertex) on the body's vertices, and on a loose
    /// piece's vertices that were put onto the body (its seam) the body's weights at that point,
    /// so the seam moves with the body and stays closed at every pose; `others` elsewhere (the
    /// field's). A mesh that is not a wrapped surface keeps `others`.
    ///
    /// Why not the field's weights: they are the body's diffused into a grid and read back by
    /// trilinear interpolation, smeared over a cell; the body's vertices have exact ones.
    pub fn own_weights(
        &self,
        body_weights: &[Weights],
        mesh: &TriMesh,
        mut others: Vec<Weights>,
    ) -> Vec<Weights> {
        let (n, body_faces) = (self.vertex_count(), self.rest.faces.len());
        let wrapped = body_weights.len() == n
            && mesh.positions.len() >= n
            && mesh.faces.len() >= body_faces
            && mesh.faces[..body_faces] == self.rest.faces[..];
        if !wrapped || others.len() != mesh.positions.len() {
            return others;
        }
        others[..n].copy_from_slice(body_weights);
        if mesh.positions.len() > n {
            let body_part = TriMesh::new(mesh.positions[..n].to_vec(), self.rest.faces.clone());
            let bvh = Bvh::build(&body_part);
            let seams: Vec<(usize, Weights)> = (n..mesh.positions.len())
                .into_par_iter()
                .filter_map(|v| {
                    let hit = bvh.closest_point_within(mesh.positions[v], SEAM_TOLERANCE)?;
                    let [a, b, c] = body_part.triangle(hit.face as usize);
                    let face = self.rest.faces[hit.face as usize].map(|i| i as usize);
                    Some((
                        v,
                        interpolate_weights(body_weights, face, barycentric(hit.point, a, b, c)),
                    ))
                })
                .collect();
            for (v, w) in seams {
                others[v] = w;
            }
        }
        others
    }
}

/// How close (metres) a loose piece's vertex must be to the wrapped body to count as put on it
/// (the seam vertices are exactly on it, up to rounding).
const SEAM_TOLERANCE: f32 = 1e-5;

/// Which faces of `mesh` have their centre farther than `far` from the surface in `bvh`.
fn faces_far_from(bvh: &Bvh, mesh: &TriMesh, far: f32) -> Vec<bool> {
    // Neighbouring faces of a mesh mostly come in turn: the triangle found for one is tried
    // first for the next.
    (0..mesh.faces.len())
        .into_par_iter()
        .map_init(
            || u32::MAX,
            |last, f| {
                let [a, b, c] = mesh.triangle(f);
                !bvh.any_within_from((a + b + c) / 3.0, far, last)
            },
        )
        .collect()
}

/// The body's thickness at `x` along the inward normal: the nearest other side of three rays a
/// few degrees apart (one ray through a vertex or an edge of the far side can slip between its
/// triangles).
fn thickness_at(bvh: &Bvh, x: Vec3, n: Vec3) -> f32 {
    let (t1, t2) = n.any_orthonormal_pair();
    [-n, (-n + 0.08 * t1).normalize(), (-n - 0.05 * t1 + 0.07 * t2).normalize()]
        .iter()
        .filter_map(|&d| bvh.ray_cast(x - 1e-4 * n, d, 1e-3, 0.2).map(|h| h.t))
        .fold(f32::INFINITY, f32::min)
}

/// Balls wider than this (metres) are not looked for: offsets never reach that far.
const MAX_REACH: f32 = 0.1;

/// The radius of the largest ball (up to `MAX_REACH`) touching the surface in `bvh` at `x`
/// whose centre lies along `dir` (a unit normal, either side): no point of the surface lies
/// inside it. Balls along one normal nest (a smaller one lies inside a larger one), so the
/// radius is found by bisection.
fn touching_ball_radius(bvh: &Bvh, x: Vec3, dir: Vec3) -> f32 {
    // Facets round a vertex lie up to about a percent inside a ball that touches the smooth
    // surface there; a tenth of a millimetre covers rounding.
    let empty = |r: f32| {
        let clearance = 0.98 * r - 1e-4;
        clearance <= 0.0 || !bvh.any_within(x + r * dir, clearance)
    };
    if empty(MAX_REACH) {
        return MAX_REACH;
    }
    let (mut lo, mut hi) = (0.0f32, MAX_REACH);
    for _ in 0..14 {
        let mid = 0.5 * (lo + hi);
        if empty(mid) { lo = mid } else { hi = mid }
    }
    lo
}

/// Where the SDF sampled at `steps` along a ray goes from inside to outside, the crossing
/// nearest to the ray's origin (t = 0); linear between samples.
fn outward_crossing_nearest_zero(steps: &[f32], f: &[f32]) -> Option<f32> {
    let mut best: Option<f32> = None;
    for i in 0..steps.len() - 1 {
        let (a, b) = (f[i], f[i + 1]);
        if a <= 0.0 && b > 0.0 && a.is_finite() {
            let t = steps[i] + (steps[i + 1] - steps[i]) * a / (a - b);
            if best.is_none_or(|s: f32| t.abs() < s.abs()) {
                best = Some(t);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests;
