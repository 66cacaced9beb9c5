//! The marching-cubes case table, generated at start-up from the cube's faces (no stored
//! table): on each face, a segment joins the edge where the CCW walk round the face enters the
//! inside corners to the edge where it leaves them, so inside corners that touch only
//! diagonally stay apart (the same choice on both sides of a face, hence no cracks). Chaining
//! the segments of the six faces gives closed loops, fanned into triangles. Every mesh edge in
//! the interior of the grid is therefore shared by exactly two faces.

use glam::Vec3;
use std::sync::OnceLock;

/// Cube corner `c` sits at (c & 1, c >> 1 & 1, c >> 2 & 1). Edge `4 * axis + k` joins a
/// corner with bit `axis` clear to the corner with it set.
pub(crate) const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7), // along x
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7), // along y
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7), // along z
];

fn edge_between(a: usize, b: usize) -> usize {
    let (lo, hi) = (a.min(b), a.max(b));
    EDGES.iter().position(|&e| e == (lo, hi)).expect("corners of a cube edge")
}

fn corner_position(c: usize) -> Vec3 {
    Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32)
}

/// The six faces, corners counter-clockwise seen from outside the cube.
fn cube_faces() -> [[usize; 4]; 6] {
    let mut faces = [[0; 4]; 6];
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in 0..2 {
            let corner = |du: usize, dv: usize| (side << axis) | (du << u) | (dv << v);
            let mut f = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
            let p = f.map(corner_position);
            let normal = (p[1] - p[0]).cross(p[2] - p[1]);
            let outward = if side == 1 { 1.0 } else { -1.0 };
            if normal[axis] * outward < 0.0 {
                f.reverse();
            }
            faces[2 * axis + side] = f;
        }
    }
    faces
}

type CaseTable = Vec<Vec<[u8; 3]>>;

/// Triangles (as cube edges) for each of the 256 inside/outside corner patterns.
pub(crate) fn case_table() -> &'static CaseTable {
    static TABLE: OnceLock<CaseTable> = OnceLock::new();
    TABLE.get_or_init(|| (0..256).map(case_triangles).collect())
}

/// Closed loops of cube edges crossed by the surface for one corner pattern, each loop
/// ordered so that its fan triangles face away from the inside corners.
fn case_loops(case: usize) -> Vec<Vec<usize>> {
    let inside = |c: usize| (case >> c) & 1 == 1;
    let mut next = [usize::MAX; 12];
    for face in cube_faces() {
        for i in 0..4 {
            let (prev, cur) = (face[(i + 3) % 4], face[i]);
            if inside(cur) && !inside(prev) {
                // Walk the run of inside corners to where the boundary leaves it.
                let mut j = i;
                while inside(face[(j + 1) % 4]) {
                    j = (j + 1) % 4;
                }
                let enter = edge_between(prev, cur);
                let leave = edge_between(face[j], face[(j + 1) % 4]);
                next[enter] = leave;
            }
        }
    }
    let mut seen = [false; 12];
    let mut loops = Vec::new();
    for start in 0..12 {
        if next[start] == usize::MAX || seen[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut e = start;
        while !seen[e] {
            seen[e] = true;
            lp.push(e);
            e = next[e];
        }
        loops.push(lp);
    }
    loops
}

fn case_triangles(case: usize) -> Vec<[u8; 3]> {
    let mut tris = Vec::new();
    for lp in case_loops(case) {
        for i in 1..lp.len().saturating_sub(1) {
            tris.push([lp[0] as u8, lp[i] as u8, lp[i + 1] as u8]);
        }
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edge_midpoint(e: usize) -> Vec3 {
        let (a, b) = EDGES[e];
        (corner_position(a) + corner_position(b)) * 0.5
    }

    #[test]
    fn case_table_loops_close_and_face_away_from_inside() {
        for case in 0..256usize {
            let inside = |c: usize| (case >> c) & 1 == 1;
            let crossed: Vec<usize> =
                (0..12).filter(|&e| inside(EDGES[e].0) != inside(EDGES[e].1)).collect();
            let loops = case_loops(case);
            let mut used: Vec<usize> = loops.iter().flatten().copied().collect();
            used.sort();
            assert_eq!(used, crossed, "case {case}: loops must use each crossed edge once");
            for lp in &loops {
                assert!(lp.len() >= 3, "case {case}: loop of {}", lp.len());
                // Newell normal of the loop (midpoints) against inside -> outside directions.
                let pts: Vec<Vec3> = lp.iter().map(|&e| edge_midpoint(e)).collect();
                let mut normal = Vec3::ZERO;
                for i in 0..pts.len() {
                    normal += pts[i].cross(pts[(i + 1) % pts.len()]);
                }
                let outward: Vec3 = lp
                    .iter()
                    .map(|&e| {
                        let (a, b) = EDGES[e];
                        let (i, o) = if inside(a) { (a, b) } else { (b, a) };
                        corner_position(o) - corner_position(i)
                    })
                    .sum();
                assert!(normal.dot(outward) > 0.0, "case {case}: loop {lp:?} faces inward");
            }
        }
        assert!(case_triangles(0).is_empty() && case_triangles(255).is_empty());
    }
}
