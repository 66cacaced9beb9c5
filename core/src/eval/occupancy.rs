//! Inside/outside of a triangle mesh at the points of a sample grid, for volumetric IoU.
//!
//! Robust rule: every grid point lies on three axis-parallel lines. Along each line the
//! mesh's crossings are found by 2-D rasterisation (a top-left rule so a line through a
//! shared edge or vertex counts once), each crossing signed by the face orientation. A point
//! gets six votes: the signed crossing count (winding number) from -inf and from +inf along
//! each axis; a vote says "inside" when that winding is non-zero. Inside = at least 4 of 6.
//! For a closed mesh all six agree (flipped orientation included, overlapping parts are
//! united); a hole in the surface corrupts only the votes of lines passing through it, so a
//! point is misclassified only when most of its lines pass through holes.

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use glam::{DVec3, Vec3};
use rand::Rng;

/// A regular grid of sample points `origin + step * (i, j, k)`.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleGrid {
    pub origin: Vec3,
    pub step: f32,
    pub dims: [usize; 3],
}

impl SampleGrid {
    /// Cubic cells of `longest side / resolution` covering `[min, max]`, shifted by a random
    /// sub-cell offset (stratified sampling: every point of the box is equally likely to be
    /// sampled).
    pub fn covering<R: Rng>(
        min: Vec3,
        max: Vec3,
        resolution: usize,
        rng: &mut R,
    ) -> Result<SampleGrid> {
        let extent = max - min;
        if !min.is_finite() || !max.is_finite() || !(extent.max_element() > 0.0) {
            return Err(Error::invalid(format!(
                "sample box is empty or not finite: {min} .. {max}"
            )));
        }
        let step = extent.max_element() / resolution.max(1) as f32;
        let offset = Vec3::new(rng.random(), rng.random(), rng.random()) * step;
        let origin = min + offset;
        let dims = [0, 1, 2].map(|a| (((max[a] - origin[a]) / step).floor().max(0.0) as usize) + 1);
        Ok(SampleGrid { origin, step, dims })
    }

    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn index(&self, i: [usize; 3]) -> usize {
        i[0] + self.dims[0] * (i[1] + self.dims[1] * i[2])
    }

    pub fn point(&self, i: [usize; 3]) -> Vec3 {
        self.origin + Vec3::new(i[0] as f32, i[1] as f32, i[2] as f32) * self.step
    }
}

/// Whether each grid point (in `SampleGrid::index` order) is inside the mesh.
pub fn inside_mask(mesh: &TriMesh, grid: &SampleGrid) -> Vec<bool> {
    let mut votes = vec![0u8; grid.len()];
    let origin = grid.origin.as_dvec3();
    let step = grid.step as f64;
    // Vertex positions in grid units.
    let pts: Vec<DVec3> = mesh.positions.iter().map(|p| (p.as_dvec3() - origin) / step).collect();
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let (nu, nv) = (grid.dims[u], grid.dims[v]);
        // (line, depth along the axis in grid units, +1 where the face normal points +axis).
        let mut crossings: Vec<(u32, f64, i8)> = Vec::new();
        for face in &mesh.faces {
            let [p0, p1, p2] = face.map(|i| pts[i as usize]);
            let (mut a, mut b, c) = ((p0[u], p0[v]), (p1[u], p1[v]), (p2[u], p2[v]));
            let (mut da, mut db, dc) = (p0[axis], p1[axis], p2[axis]);
            // Twice the signed projected area; its sign is the sign of the normal's
            // `axis` component because (axis, u, v) is a cyclic permutation of (x, y, z).
            let area = orient(a, b, c);
            if !(area.abs() > 0.0) {
                continue; // edge-on (or NaN): no crossing
            }
            let dir: i8 = if area > 0.0 { 1 } else { -1 };
            if area < 0.0 {
                std::mem::swap(&mut a, &mut b);
                std::mem::swap(&mut da, &mut db);
            }
            let area = area.abs();
            let lo_u = a.0.min(b.0).min(c.0).ceil().max(0.0);
            let hi_u = a.0.max(b.0).max(c.0).floor().min(nu as f64 - 1.0);
            let lo_v = a.1.min(b.1).min(c.1).ceil().max(0.0);
            let hi_v = a.1.max(b.1).max(c.1).floor().min(nv as f64 - 1.0);
            if lo_u > hi_u || lo_v > hi_v {
                continue;
            }
            for iv in lo_v as usize..=hi_v as usize {
                for iu in lo_u as usize..=hi_u as usize {
                    let q = (iu as f64, iv as f64);
                    let (w0, w1, w2) = (orient(b, c, q), orient(c, a, q), orient(a, b, q));
                    if covers(w0, b, c) && covers(w1, c, a) && covers(w2, a, b) {
                        let depth = (w0 * da + w1 * db + w2 * dc) / area;
                        crossings.push(((iu + nu * iv) as u32, depth, dir));
                    }
                }
            }
        }
        crossings.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
        let n_axis = grid.dims[axis];
        let mut start = 0;
        while start < crossings.len() {
            let line = crossings[start].0 as usize;
            let end =
                start + crossings[start..].iter().take_while(|c| c.0 as usize == line).count();
            let run = &crossings[start..end];
            let total: i32 = run.iter().map(|c| c.2 as i32).sum();
            let (iu, iv) = (line % nu, line / nu);
            let mut before = 0i32; // signed crossings with depth < k
            let mut at_or_before = 0i32; // signed crossings with depth <= k
            let (mut p, mut q) = (0, 0);
            for k in 0..n_axis {
                let kf = k as f64;
                while p < run.len() && run[p].1 < kf {
                    before += run[p].2 as i32;
                    p += 1;
                }
                while q < run.len() && run[q].1 <= kf {
                    at_or_before += run[q].2 as i32;
                    q += 1;
                }
                // From -inf a crossing whose normal points -axis enters: winding -before.
                let forward = -before;
                let backward = total - at_or_before;
                let mut idx = [0usize; 3];
                idx[axis] = k;
                idx[u] = iu;
                idx[v] = iv;
                votes[grid.index(idx)] += (forward != 0) as u8 + (backward != 0) as u8;
            }
            start = end;
        }
    }
    votes.into_iter().map(|n| n >= 4).collect()
}

/// Twice the signed area of (a, b, q): positive when q is left of a -> b.
fn orient(a: (f64, f64), b: (f64, f64), q: (f64, f64)) -> f64 {
    (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0)
}

/// Top-left rule for a counter-clockwise triangle: points exactly on an edge belong to one
/// of the two triangles sharing it (the edge directions are opposite there).
fn covers(w: f64, a: (f64, f64), b: (f64, f64)) -> bool {
    if w != 0.0 {
        return w > 0.0;
    }
    let d = (b.0 - a.0, b.1 - a.1);
    d.1 > 0.0 || (d.1 == 0.0 && d.0 < 0.0)
}

/// Volumetric IoU of two meshes at the points of a seeded grid over their joint bounds.
pub fn volumetric_iou<R: Rng>(
    a: &TriMesh,
    b: &TriMesh,
    resolution: usize,
    rng: &mut R,
) -> Result<f32> {
    let (amin, amax) = a.bounds().ok_or_else(|| Error::invalid("IoU of an empty mesh"))?;
    let (bmin, bmax) = b.bounds().ok_or_else(|| Error::invalid("IoU of an empty mesh"))?;
    let grid = SampleGrid::covering(amin.min(bmin), amax.max(bmax), resolution, rng)?;
    let (ia, ib) = (inside_mask(a, &grid), inside_mask(b, &grid));
    let inter = ia.iter().zip(&ib).filter(|(x, y)| **x && **y).count();
    let union = ia.iter().zip(&ib).filter(|(x, y)| **x || **y).count();
    if union == 0 {
        return Err(Error::invalid("IoU undefined: neither mesh encloses any sample point"));
    }
    Ok(inter as f32 / union as f32)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    pub(crate) fn cube(min: Vec3, size: Vec3) -> TriMesh {
        let p = (0..8)
            .map(|i| {
                min + size * Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)
            })
            .collect();
        let f = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        TriMesh::new(p, f)
    }

    fn fraction_inside(mesh: &TriMesh, grid: &SampleGrid) -> f32 {
        let m = inside_mask(mesh, grid);
        m.iter().filter(|x| **x).count() as f32 / m.len() as f32
    }

    #[test]
    fn inside_mask_matches_a_box_exactly() {
        let mesh = cube(Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.0, 0.5, 0.7));
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let grid = SampleGrid::covering(Vec3::ZERO, Vec3::splat(1.5), 40, &mut rng).unwrap();
        let mask = inside_mask(&mesh, &grid);
        for z in 0..grid.dims[2] {
            for y in 0..grid.dims[1] {
                for x in 0..grid.dims[0] {
                    let p = grid.point([x, y, z]);
                    let truth = p.cmpgt(Vec3::new(0.1, 0.2, 0.3)).all()
                        && p.cmplt(Vec3::new(1.1, 0.7, 1.0)).all();
                    assert_eq!(mask[grid.index([x, y, z])], truth, "at {p}");
                }
            }
        }
        // Reversed faces (inward normals) enclose the same volume.
        let mut flipped = mesh.clone();
        flipped.faces.iter_mut().for_each(|f| f.swap(1, 2));
        assert_eq!(inside_mask(&flipped, &grid), mask);
    }

    #[test]
    fn iou_of_offset_cubes_is_analytic() {
        let a = cube(Vec3::ZERO, Vec3::ONE);
        let b = cube(Vec3::new(0.3, 0.2, 0.1), Vec3::ONE);
        let inter = 0.7 * 0.8 * 0.9;
        let truth = inter / (2.0 - inter);
        for seed in 0..3 {
            let iou = volumetric_iou(&a, &b, 64, &mut ChaCha8Rng::seed_from_u64(seed)).unwrap();
            assert!((iou - truth).abs() < 0.01, "seed {seed}: IoU {iou} vs {truth}");
        }
        let same = volumetric_iou(&a, &a, 32, &mut ChaCha8Rng::seed_from_u64(0)).unwrap();
        assert_eq!(same, 1.0);
        let apart = volumetric_iou(
            &a,
            &cube(Vec3::splat(3.0), Vec3::ONE),
            32,
            &mut ChaCha8Rng::seed_from_u64(0),
        )
        .unwrap();
        assert_eq!(apart, 0.0);
    }

    #[test]
    fn holes_and_overlaps_are_handled_by_the_vote() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let grid = SampleGrid::covering(Vec3::splat(-0.5), Vec3::splat(2.5), 48, &mut rng).unwrap();
        let full = cube(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0));
        let truth = fraction_inside(&full, &grid);
        // Remove one triangle: lines through the hole lose a crossing, the vote keeps the volume.
        let mut holed = full.clone();
        holed.faces.remove(4);
        assert!((fraction_inside(&holed, &grid) - truth).abs() < 0.02 * truth);
        // Two overlapping closed boxes: the union, not the parity.
        let mut pair = cube(Vec3::ZERO, Vec3::ONE);
        let other = cube(Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.5, 1.0, 1.0));
        let n = pair.positions.len() as u32;
        pair.positions.extend(other.positions);
        pair.faces.extend(other.faces.iter().map(|f| f.map(|i| i + n)));
        let union = fraction_inside(&pair, &grid);
        assert!((union - truth).abs() < 0.01 * truth, "union {union} vs {truth}");
    }
}
