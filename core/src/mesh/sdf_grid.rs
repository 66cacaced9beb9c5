//! A closed mesh's signed distance sampled once on a regular grid and read back by trilinear
//! interpolation: for the many queries that only ask which side of a band a point lies on
//! (the fit's off-surface sign prior asks it of every step's off-surface points), where a
//! closest-point query per point cost a tenth of the fit.
//!
//! Two grids: a fine one over the mesh's bounds, exact at its nodes within `band` of the
//! surface, and a coarse one out to `reach`; beyond, everything reads `reach`. A node's
//! distance is signed by the mesh's vertex normals blended at the closest point (which holds at
//! edges and corners, where the nearest face's normal can point the wrong way). Between nodes
//! the value is off by at most the distance's change across a cell (the distance is
//! 1-Lipschitz): a cell's diagonal, and far less where the surface is smooth.

use super::TriMesh;
use super::signed_distance::SignedDistance;
use glam::Vec3;
use rayon::prelude::*;

pub struct SdfGrid {
    /// Exact at the nodes within `band` of the surface, over the mesh's bounds and a little.
    fine: Level,
    /// Exact at the nodes within `reach`, over the bounds grown by `reach`.
    coarse: Level,
    reach: f32,
}

/// One regular grid of values.
struct Level {
    origin: Vec3,
    cell: f32,
    dims: [usize; 3],
    values: Vec<f32>,
}

/// How finely and how far [`SdfGrid::new`] samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SdfGridOptions {
    /// The fine grid's spacing and the distance it holds exactly (metres); it spans the mesh's
    /// bounds grown by `band` and two cells.
    pub fine_cell: f32,
    pub band: f32,
    /// The coarse grid's spacing and the distance it holds exactly; it spans the bounds grown
    /// by `reach` and two cells, and everything beyond reads `reach`. `reach` must exceed the
    /// depth of the mesh's deepest inside point (a node farther than `reach` from the surface
    /// reads as outside).
    pub coarse_cell: f32,
    pub reach: f32,
}

impl SdfGrid {
    /// The signed distance of `mesh` on the two grids (`None` for an empty mesh or spacings and
    /// distances that are not positive and finite). A fine node farther than `band` from the
    /// surface takes the coarse grid's value there (two closest-point queries in three are
    /// spared; those nodes are far inside or outside).
    pub fn new(mesh: &TriMesh, options: &SdfGridOptions) -> Option<SdfGrid> {
        let o = options;
        let valid = |v: f32| v > 0.0 && v.is_finite();
        if mesh.is_empty() || ![o.fine_cell, o.band, o.coarse_cell, o.reach].into_iter().all(valid)
        {
            return None;
        }
        let (lo, hi) =
            mesh.positions.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            );
        let sdf = SignedDistance::new(mesh);
        let coarse = Level::sample(lo, hi, o.coarse_cell, o.reach, |p| {
            sdf.within(p, o.reach).unwrap_or(o.reach)
        });
        let fine = Level::sample(lo, hi, o.fine_cell, o.band, |p| {
            sdf.within(p, o.band).unwrap_or_else(|| coarse.at(p).unwrap_or(o.reach))
        });
        Some(SdfGrid { fine, coarse, reach: o.reach })
    }

    /// The interpolated signed distance at `p` (metres, positive outside): `reach` where the
    /// surface is farther than `reach` from every node around `p`.
    pub fn at(&self, p: Vec3) -> f32 {
        self.fine.at(p).or_else(|| self.coarse.at(p)).unwrap_or(self.reach)
    }

    /// The distance beyond which the grid reads `reach`.
    pub fn reach(&self) -> f32 {
        self.reach
    }

    /// Nodes of both grids.
    pub fn num_nodes(&self) -> usize {
        self.fine.values.len() + self.coarse.values.len()
    }
}

impl Level {
    /// `value` at every node of a grid of `cell` over the bounds `lo`..`hi` grown by `margin`
    /// and two cells.
    fn sample(
        lo: Vec3,
        hi: Vec3,
        cell: f32,
        margin: f32,
        value: impl Fn(Vec3) -> f32 + Sync,
    ) -> Level {
        let grow = Vec3::splat(margin + 2.0 * cell);
        let origin = lo - grow;
        let size = hi + grow - origin;
        let dims = [size.x, size.y, size.z].map(|s| (s / cell).ceil() as usize + 1);
        let values = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| {
                let (x, y, z) = (i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1]));
                value(origin + Vec3::new(x as f32, y as f32, z as f32) * cell)
            })
            .collect();
        Level { origin, cell, dims, values }
    }

    /// Trilinear at `p`; `None` outside the grid.
    fn at(&self, p: Vec3) -> Option<f32> {
        let g = (p - self.origin) / self.cell;
        if !g.cmpge(Vec3::ZERO).all() || !g.is_finite() {
            return None;
        }
        let i0 = [g.x, g.y, g.z].map(|v| v.floor() as usize);
        if (0..3).any(|a| i0[a] + 1 >= self.dims[a]) {
            return None;
        }
        let t = g - Vec3::new(i0[0] as f32, i0[1] as f32, i0[2] as f32);
        let [nx, ny] = [self.dims[0], self.dims[0] * self.dims[1]];
        let k = i0[0] + nx * i0[1] + ny * i0[2];
        let v = |o: usize| self.values[k + o];
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = lerp(v(0), v(1), t.x);
        let x10 = lerp(v(nx), v(nx + 1), t.x);
        let x01 = lerp(v(ny), v(ny + 1), t.x);
        let x11 = lerp(v(nx + ny), v(nx + ny + 1), t.x);
        Some(lerp(lerp(x00, x10, t.y), lerp(x01, x11, t.y), t.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed octahedron-subdivided sphere of radius `r` (outward faces).
    fn sphere(r: f32) -> TriMesh {
        let mut positions = vec![Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        for _ in 0..4 {
            let mut next = Vec::new();
            let mut mid = std::collections::HashMap::new();
            let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    positions
                        .push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                    positions.len() as u32 - 1
                })
            };
            for [a, b, c] in faces {
                let (ab, bc, ca) = (
                    midpoint(a, b, &mut positions),
                    midpoint(b, c, &mut positions),
                    midpoint(c, a, &mut positions),
                );
                next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            faces = next;
        }
        TriMesh::new(positions.into_iter().map(|p| p * r).collect(), faces)
    }

    #[test]
    fn a_sphere_reads_its_distance_within_reach_and_reach_beyond() {
        let mesh = sphere(0.15);
        let options = SdfGridOptions { fine_cell: 0.02, band: 0.2, coarse_cell: 0.02, reach: 0.2 };
        let grid = SdfGrid::new(&mesh, &options).unwrap();
        let exact = SignedDistance::new(&mesh);
        let mut worst: f32 = 0.0;
        // Points from the centre to beyond reach, along directions off the grid's axes.
        for k in 0..400 {
            let dir = Vec3::new((k as f32 * 0.37).sin(), (k as f32 * 0.71).cos(), 0.4).normalize();
            let r = 0.6 * k as f32 / 400.0;
            let p = dir * r;
            let d = exact.at(p).unwrap();
            let g = grid.at(p);
            // Away from the centre, where the distance has its kink.
            if d > -0.1 && d < 0.15 {
                worst = worst.max((g - d).abs());
            }
            if d > 0.2 + 2.0 * 0.02 * 3f32.sqrt() {
                assert_eq!(g, 0.2, "beyond reach at {p}");
            }
            assert!(g.signum() == d.signum() || d.abs() < 0.02, "sign at {p}: {g} against {d}");
        }
        // Smooth surface: trilinear error well under a cell.
        assert!(worst < 0.004, "worst error {worst}");
        assert_eq!(grid.at(Vec3::splat(5.0)), 0.2);
        assert_eq!(grid.at(Vec3::splat(f32::NAN)), 0.2);
        assert!(SdfGrid::new(&TriMesh::default(), &options).is_none());
        assert!(SdfGrid::new(&mesh, &SdfGridOptions { fine_cell: 0.0, ..options }).is_none());
    }

    #[test]
    fn the_rest_body_sides_of_two_bands_match_the_exact_distance() {
        let body = crate::body::open_body_ref();
        let mesh = body.mesh(body.shaped_vertices(&[]));
        let options = SdfGridOptions { fine_cell: 0.02, band: 0.1, coarse_cell: 0.05, reach: 0.45 };
        let grid = SdfGrid::new(&mesh, &options).unwrap();
        let exact = SignedDistance::new(&mesh);
        let (lo, hi) =
            mesh.positions.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            );
        let side = |d: f32| (d > 0.35) as i32 - (d < -0.03) as i32;
        let (mut near, mut wrong, mut total) = (0, 0, 0);
        // A low-discrepancy sweep of the body's box grown by half a metre.
        for k in 0..100_000 {
            let f = |a: f32| (k as f32 * a).fract();
            let t = Vec3::new(f(0.618_034), f(0.754_878), f(0.569_840));
            let p = lo - Vec3::splat(0.5) + t * (hi - lo + Vec3::splat(1.0));
            let d = exact.within(p, 1.0).unwrap_or(1.0);
            total += 1;
            near += (d < -0.03) as usize;
            if side(grid.at(p)) != side(d) {
                wrong += 1;
                // Only next to a band's edge, within half a cell: inside a thin limb the distance
                // has its kink on the limb's axis, a few millimetres below the inner edge; the
                // outer edge is read from the 5 cm grid.
                assert!(
                    (d - 0.35).abs() < 0.01 || (d + 0.03).abs() < 0.01,
                    "{p}: grid {} against {d}",
                    grid.at(p)
                );
            }
        }
        assert!(near > 150, "{near} deep points of {total}");
        assert!(wrong * 100 < total, "{wrong} of {total} on the other side");
    }
}
