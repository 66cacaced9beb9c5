//! Faces of a mesh that pass through other faces of it (share no vertex with them, and an edge
//! of one goes through the other). Candidate pairs come from a uniform grid of cells about twice
//! the mean edge long; each pair is tested once, in the first cell both faces reach.
//! [`CrossingTracker`] keeps the crossing pairs up to date while a few vertices move at a time
//! (`FoldGuard::span_crossings`), testing again only the faces that moved.

use super::bvh::ray_triangle;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// A face far larger than the cells (a sliver across the body) would fill thousands of cells;
/// such faces are rare and capped at this many cells a side, which still holds their corners.
const MAX_CELLS_A_SIDE: i32 = 8;

/// Per face: whether it crosses another face with which it shares no vertex.
pub fn self_intersecting_faces(positions: &[Vec3], faces: &[[u32; 3]]) -> Vec<bool> {
    flags(faces.len(), &crossing_pairs(positions, faces, None))
}

/// The pairs of faces `(f, g)`, `f < g`, that cross; with `only`, just the pairs that hold at
/// least one face it marks.
pub fn crossing_pairs(
    positions: &[Vec3],
    faces: &[[u32; 3]],
    only: Option<&[bool]>,
) -> Vec<(u32, u32)> {
    if faces.len() < 2 {
        return Vec::new();
    }
    let tri = |f: u32| faces[f as usize].map(|v| positions[v as usize]);
    let mean_edge = faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| positions[v as usize]);
            (a.distance(b) + b.distance(c) + c.distance(a)) as f64 / 3.0
        })
        .sum::<f64>()
        / faces.len() as f64;
    let cell = (2.0 * mean_edge as f32).max(1e-6);
    let key = |p: Vec3| (p / cell).floor().as_ivec3();
    let ranges: Vec<(IVec3, IVec3)> = (0..faces.len() as u32)
        .map(|f| {
            let [a, b, c] = tri(f);
            let lo = key(a.min(b).min(c));
            (lo, key(a.max(b).max(c)).min(lo + IVec3::splat(MAX_CELLS_A_SIDE - 1)))
        })
        .collect();
    // (cell, face) for every cell a face's box reaches, sorted by cell.
    let mut entries: Vec<(IVec3, u32)> = Vec::new();
    for (f, &(lo, hi)) in ranges.iter().enumerate() {
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    entries.push((IVec3::new(x, y, z), f as u32));
                }
            }
        }
    }
    entries.par_sort_unstable_by_key(|&(c, f)| (c.x, c.y, c.z, f));
    let mut groups: Vec<&[(IVec3, u32)]> = Vec::new();
    let mut start = 0;
    for i in 1..=entries.len() {
        if i == entries.len() || entries[i].0 != entries[start].0 {
            if i - start > 1 {
                groups.push(&entries[start..i]);
            }
            start = i;
        }
    }
    let wanted = |f: u32, g: u32| only.is_none_or(|o| o[f as usize] || o[g as usize]);
    let mut pairs: Vec<(u32, u32)> = groups
        .par_iter()
        .flat_map_iter(|group| {
            let cell_here = group[0].0;
            let mut found = Vec::new();
            for (i, &(_, f)) in group.iter().enumerate() {
                for &(_, g) in &group[i + 1..] {
                    // Tested in the first cell both reach only.
                    if ranges[f as usize].0.max(ranges[g as usize].0) != cell_here
                        || !wanted(f, g)
                        || faces[f as usize].iter().any(|v| faces[g as usize].contains(v))
                    {
                        continue;
                    }
                    if triangles_cross(tri(f), tri(g)) {
                        found.push((f.min(g), f.max(g)));
                    }
                }
            }
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// Whether two triangles cross: an edge of either passes through the other (coplanar
/// touching, a set of measure zero on real meshes, is not counted).
pub fn triangles_cross(t: [Vec3; 3], u: [Vec3; 3]) -> bool {
    let (lo_t, hi_t) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
    let (lo_u, hi_u) = (u[0].min(u[1]).min(u[2]), u[0].max(u[1]).max(u[2]));
    if lo_t.cmpgt(hi_u).any() || lo_u.cmpgt(hi_t).any() {
        return false;
    }
    let edge_through = |a: Vec3, b: Vec3, tri: [Vec3; 3]| {
        ray_triangle(a, b - a, tri[0], tri[1], tri[2])
            .is_some_and(|(s, _, _, _)| (0.0..=1.0).contains(&s))
    };
    (0..3).any(|i| edge_through(t[i], t[(i + 1) % 3], u) || edge_through(u[i], u[(i + 1) % 3], t))
}

/// Per face: whether it is in one of `pairs`.
pub fn flags(face_count: usize, pairs: &[(u32, u32)]) -> Vec<bool> {
    let mut crossing = vec![false; face_count];
    for &(f, g) in pairs {
        crossing[f as usize] = true;
        crossing[g as usize] = true;
    }
    crossing
}

/// The crossing pairs of a mesh whose vertices move a few at a time: each update tests again
/// only the faces with a vertex that moved since the last one.
pub struct CrossingTracker<'a> {
    faces: &'a [[u32; 3]],
    last: Vec<Vec3>,
    pairs: Vec<(u32, u32)>,
}

impl<'a> CrossingTracker<'a> {
    pub fn new(positions: &[Vec3], faces: &'a [[u32; 3]]) -> CrossingTracker<'a> {
        Self::among(positions, faces, None)
    }

    /// With `only`, just the pairs that hold at least one face it marks (the faces that may
    /// move: the pairs of two others never change).
    pub fn among(
        positions: &[Vec3],
        faces: &'a [[u32; 3]],
        only: Option<&[bool]>,
    ) -> CrossingTracker<'a> {
        CrossingTracker {
            faces,
            last: positions.to_vec(),
            pairs: crossing_pairs(positions, faces, only),
        }
    }

    /// The crossing pairs at `positions` (the same vertices, some moved).
    pub fn update(&mut self, positions: &[Vec3]) -> &[(u32, u32)] {
        let moved: Vec<bool> = positions.iter().zip(&self.last).map(|(p, q)| p != q).collect();
        if moved.iter().any(|&m| m) {
            let touched: Vec<bool> =
                self.faces.iter().map(|f| f.iter().any(|&v| moved[v as usize])).collect();
            self.pairs.retain(|&(f, g)| !touched[f as usize] && !touched[g as usize]);
            self.pairs.extend(crossing_pairs(positions, self.faces, Some(&touched)));
            self.pairs.sort_unstable();
            self.last.copy_from_slice(positions);
        }
        &self.pairs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_triangles_are_found_and_touching_ones_are_not() {
        let t = [Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0)];
        let through =
            [Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.2, 1.0, 0.1)];
        assert!(triangles_cross(t, through));
        let above = through.map(|p| p + Vec3::Y * 1.5);
        assert!(!triangles_cross(t, above));
        let beside = through.map(|p| p + Vec3::X * 3.0);
        assert!(!triangles_cross(t, beside));
    }

    /// A strip of small triangles and a long sliver through it: every pair found once, by
    /// the whole test and by the tracker after the sliver moves away and back.
    #[test]
    fn the_tracker_follows_moving_faces_and_agrees_with_a_whole_test() {
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        for i in 0..40 {
            let x = i as f32 * 0.1;
            let k = positions.len() as u32;
            positions.extend([
                Vec3::new(x, 0.0, -0.05),
                Vec3::new(x + 0.1, 0.0, -0.05),
                Vec3::new(x + 0.05, 0.0, 0.05),
            ]);
            faces.push([k, k + 1, k + 2]);
        }
        // The sliver: 4 m long, through the strip's plane along x at z = 0.
        let k = positions.len() as u32;
        positions.extend([
            Vec3::new(-0.1, -0.01, 0.0),
            Vec3::new(4.1, -0.01, 0.0),
            Vec3::new(2.0, 0.02, 0.001),
        ]);
        faces.push([k, k + 1, k + 2]);
        let whole = crossing_pairs(&positions, &faces, None);
        assert!(whole.len() >= 10, "the sliver crosses the strip: {whole:?}");
        assert!(whole.iter().all(|&(_, g)| g == 40), "only the sliver crosses: {whole:?}");
        let mut tracker = CrossingTracker::new(&positions, &faces);
        let mut lifted = positions.clone();
        for p in &mut lifted[120..] {
            p.y += 1.0;
        }
        assert!(tracker.update(&lifted).is_empty());
        assert_eq!(tracker.update(&positions), whole.as_slice());
        let count = self_intersecting_faces(&positions, &faces).iter().filter(|&&c| c).count();
        assert_eq!(count, whole.len() + 1);
    }
}
