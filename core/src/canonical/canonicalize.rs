//! Canonicalizing a frame's depth points: inverse skinning of every point (and its normal),
//! choosing one root, and the 2 cm reprojection filter.

use super::field::SkinningField;
use super::root_finding::{
    Root, RootOptions, find_root_from, find_roots, forward_point, start_bones,
};
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
    /// Whether the search found more than one root for each kept point (several bones could
    /// have carried it there: near joints, between the thighs). A point with one root keeps it
    /// under a small change of the pose ([`canonicalize_points_from`]).
    pub ambiguous: Vec<bool>,
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
    nearest_with_gap(roots, |x, _| distance(x)).0
}

/// [`choose_nearest`]'s pick and how much farther the runner-up is (infinite for one root).
/// `distance(x, cap)` may answer infinity for a root at least `cap` from the surface: each
/// root after the first is asked with a cap beyond the nearest so far by more than
/// [`NEAREST_TIE`], so such a root can be neither the pick nor a runner-up within the tie, and
/// the pick and whether the gap is under the tie are those of the exact distances.
fn nearest_with_gap(roots: &[Root], distance: impl Fn(Vec3, f32) -> f32) -> (usize, f32) {
    if roots.len() < 2 {
        return (0, f32::INFINITY);
    }
    let mut nearest = f32::INFINITY;
    let d: Vec<f32> = roots
        .iter()
        .map(|r| {
            let v = distance(r.canonical, nearest + NEAREST_TIE + TIE_CAP_MARGIN);
            nearest = nearest.min(v);
            v
        })
        .collect();
    let best = (0..roots.len()).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
    let runner_up =
        (0..roots.len()).filter(|&i| i != best).map(|i| d[i]).fold(f32::INFINITY, f32::min);
    (best, runner_up - d[best])
}

/// A point whose runner-up root lies less than this much farther from the surface than the
/// root picked ([`RootPick::Nearest`]) is ambiguous (metres): a small change of the pose may
/// swap them.
pub const NEAREST_TIE: f32 = 0.05;

/// How far beyond the tie a root's distance is still measured exactly (metres): well above the
/// rounding of a distance, so that a root left unmeasured is surely beyond the tie.
const TIE_CAP_MARGIN: f32 = 0.01;

/// How a point's root is picked among several.
#[derive(Clone, Copy)]
pub enum RootPick<'a> {
    /// The root whose field weights best agree with the bone it started from
    /// ([`choose_by_agreement`]); a point with several roots is ambiguous.
    Agreement,
    /// The caller's choice; a point with several roots is ambiguous.
    Chooser(RootChooser<'a>),
    /// The root nearest a surface ([`choose_nearest`], `distance(x, cap)`: of a canonical point
    /// `x` to the surface, or infinity when it is not below `cap`); a point is ambiguous when
    /// its runner-up is within [`NEAREST_TIE`] of it.
    Nearest(&'a (dyn Fn(Vec3, f32) -> f32 + Sync)),
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
    let pick = match chooser {
        Some(c) => RootPick::Chooser(c),
        None => RootPick::Agreement,
    };
    canonicalize_points_from(
        field,
        bones,
        posed_body,
        body_weights,
        points,
        normals,
        &[],
        options,
        pick,
    )
}

/// [`canonicalize_points`] with the roots picked by `pick`, and warm starts for a pose that
/// differs little from one the points were canonicalized for before (pose refinement's
/// rounds): a point with `warm[i] = Some(x)` (its canonical point before, where the search
/// found it unambiguous: [`CanonicalFrame::ambiguous`]) is solved by Broyden's method from `x`
/// alone, and searched from every start bone only when that does not converge. Points without
/// a warm start (`warm` shorter than `points`, or `None`) are searched in full.
#[allow(clippy::too_many_arguments)]
pub fn canonicalize_points_from(
    field: &SkinningField,
    bones: &Bones,
    posed_body: &[Vec3],
    body_weights: &[[f32; NUM_JOINTS]],
    points: &[Vec3],
    normals: &[Vec3],
    warm: &[Option<Vec3>],
    options: &RootOptions,
    pick: RootPick,
) -> CanonicalFrame {
    // Built only when some point needs the full search.
    let index = std::sync::OnceLock::new();
    let index = || index.get_or_init(|| PointIndex::new(posed_body).ok());
    let results: Vec<Option<(Vec3, Vec3, bool, bool)>> = points
        .par_iter()
        .zip(normals.par_iter())
        .enumerate()
        .map(|(i, (&p, &n))| {
            let warm_root = warm
                .get(i)
                .copied()
                .flatten()
                .and_then(|x0| find_root_from(field, &bones.transforms, p, x0, options));
            let (x, ambiguous) = match warm_root {
                Some(r) => (r.canonical, false),
                None => {
                    let near = match index() {
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
                    let (best, ambiguous) = match pick {
                        RootPick::Agreement => (choose_by_agreement(&roots), roots.len() > 1),
                        RootPick::Chooser(c) => (c(&roots).min(roots.len() - 1), roots.len() > 1),
                        RootPick::Nearest(distance) => {
                            let (best, gap) = nearest_with_gap(&roots, distance);
                            (best, gap < NEAREST_TIE)
                        }
                    };
                    (roots[best].canonical, ambiguous)
                }
            };
            let blend = blend_transform(&bones.transforms, &field.weights_at(x));
            // Normals transform by the inverse transpose; going back, by the transpose.
            let nc = (Mat3::from_mat4(blend).transpose() * n).normalize_or_zero();
            let reprojected = blend.transform_point3(x);
            Some((x, nc, (reprojected - p).length() <= REPROJECTION_THRESHOLD, ambiguous))
        })
        .collect();
    let mut frame = CanonicalFrame {
        points: Vec::new(),
        normals: Vec::new(),
        source: Vec::new(),
        unsolved: 0,
        dropped: 0,
        ambiguous: Vec::new(),
        bones: bones.clone(),
    };
    for (i, r) in results.into_iter().enumerate() {
        match r {
            None => frame.unsolved += 1,
            Some((_, _, false, _)) => frame.dropped += 1,
            Some((x, n, true, ambiguous)) => {
                frame.points.push(x);
                frame.normals.push(n);
                frame.source.push(i);
                frame.ambiguous.push(ambiguous);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Roots at these distances from a surface (the x coordinate is the distance).
    fn roots_at(distances: &[f32]) -> Vec<Root> {
        distances
            .iter()
            .map(|&d| Root {
                canonical: Vec3::new(d, 0.0, 0.0),
                start_bone: 0,
                agreement: 0.0,
                residual: 0.0,
                steps: 0,
            })
            .collect()
    }

    #[test]
    fn capped_distances_pick_as_exact_ones_and_tell_the_same_ties() {
        let exact = |x: Vec3, _: f32| x.x;
        let capped = |x: Vec3, cap: f32| if x.x < cap { x.x } else { f32::INFINITY };
        let cases: [&[f32]; 8] = [
            &[0.3, 0.01],
            &[0.01, 0.3],
            &[0.2, 0.02, 0.06, 0.5],
            &[0.02, 0.02, 0.5],
            &[0.5, 0.4, 0.3, 0.2, 0.1],
            &[0.1, 0.149, 0.9],
            &[0.1, 0.151, 0.9],
            &[0.9, 0.1, 0.159, 0.161],
        ];
        for d in cases {
            let roots = roots_at(d);
            let (best, gap) = nearest_with_gap(&roots, exact);
            let (capped_best, capped_gap) = nearest_with_gap(&roots, capped);
            assert_eq!(best, capped_best, "{d:?}");
            assert_eq!(gap < NEAREST_TIE, capped_gap < NEAREST_TIE, "{d:?}: {gap} {capped_gap}");
        }
        // The tie itself: a runner-up within it is measured exactly.
        let (_, gap) = nearest_with_gap(&roots_at(&[0.5, 0.1, 0.13]), capped);
        assert!((gap - 0.03).abs() < 1e-6);
    }
}
