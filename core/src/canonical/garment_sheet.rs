//! Loose cloth remade as one whole sheet (FITE's explicit template, for a skirt, a dress, a
//! coat's tails or a cape). The loose pieces an SDF gives are marching-cubes surfaces of a
//! slab of cloth often no thicker than a cell: they come out torn, with holes through the front
//! of a dress and strips where a skirt was thin, and nothing keeps them one sheet from pose to
//! pose. Hanging cloth is a surface round the body's vertical axis, so here it is sampled as
//! one: rays run in toward the axis from every direction round the body and at every height,
//! and where a ray first meets the outside of a loose piece, that is the cloth. The cells the
//! rays hit make a grid whose holes (cells enclosed by cloth on every side, and short tears
//! that reach a border) are filled: the radius there spans the hole as a membrane would, then
//! moves onto the SDF's own surface where the SDF shows one along the ray (a slab thinner than
//! the extraction's cells dips toward zero without crossing it). The sheet is triangulated on
//! that grid: one piece with real borders (the hem, the waist, a cape's sides), no hole, no
//! edge of three faces, and evenly sized triangles whatever the extraction's cells were. What
//! lies under the sheet (the slab's inner wall, the SDF's blob between the legs) goes.
//!
//! Tried and not kept: growing the sheet cell by cell from what the extraction gave, wherever
//! the SDF crosses zero or dips under 4 mm along the next ray (to mend tears that reach the
//! hem). On one fitted dress and one simulated skirt at held-out poses it invented cloth where
//! the SDF's zero level is not a garment (spurious share 9.3 -> 10.2 % and 16 -> 31 %).
//!
//! What the sheet does not stand for (a loose piece no ray from outside reaches first: a
//! ponytail lying on the back, loose sleeves round a horizontal arm) is kept as it was.

mod grid;
#[cfg(test)]
mod tests;

use crate::mesh::TriMesh;
use crate::mesh::bvh::Bvh;
use crate::mesh::smooth::smooth_borders;
use crate::mesh::topology::{compact, drop_small_pieces};
use glam::Vec3;
use grid::Shape;
use rayon::prelude::*;
use std::f32::consts::TAU;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SheetGridOptions {
    /// Directions round the body (180: 1.05 cm apart at a skirt's 30 cm from the axis), and
    /// the height of a row (metres). Both are read when the grid is made
    /// ([`GarmentSheet::around`]).
    pub columns: usize,
    pub row_step: f32,
    /// A ray meets cloth where a face's normal points back along it by at least this cosine
    /// (a ray grazing a hem's rim or an edge on meets no cloth there).
    pub facing: f32,
    /// A hit farther (metres) from its neighbours' median radius is a stray layer (an inner
    /// wall's remnant seen through a tear) and its radius is taken from the neighbours.
    pub outlier: f32,
    /// How far (metres) either side of a filled hole's membrane the SDF is searched for the
    /// cloth, and the step of that search.
    pub search: f32,
    pub search_step: f32,
    /// Along a filled cell's ray, an SDF minimum under this (metres) without a crossing is
    /// cloth thinner than the extraction saw, and the sheet goes through it.
    pub thin: f32,
    /// Pieces of the sheet with less area (square metres) are dropped: flecks, not garments.
    pub min_piece_area: f32,
    /// Faces of the loose pieces this close (metres) to the sheet are what it stands for.
    pub cover: f32,
    /// Taubin iterations along the sheet's borders (`mesh::smooth::smooth_borders`), each
    /// vertex moving at most `border_reach` (metres): a hem on the grid is a staircase with a
    /// rim that zigzags.
    pub border_smoothing: usize,
    pub border_reach: f32,
    /// Tears that reach a border (which `grid::fill_enclosed` cannot tell from open space)
    /// close where they are short: a column's gap of at most `gap_rows` cells between cloth
    /// above and below (cloth hangs from its top), a row's gap of at most `gap_columns` cells
    /// between cloth either side (`grid::fill_short_gaps`). A cape's or an open coat's front
    /// is wider and stays open.
    pub gap_rows: usize,
    pub gap_columns: usize,
    /// The hem is evened by a running median of the columns' lowest cells over this many
    /// columns either side (`grid::even_hem`; 0: as the rays found it).
    pub hem_window: usize,
    /// Sweeps of the radius's smoothing over the sheet (`grid::smooth_values`; 0: none): the
    /// rays' hits carry the fitted SDF's specks and the depth's noise as lumps a few
    /// centimetres across, which cost the sheet's normals (on four subjects' loose outfits 30
    /// sweeps raised NC by 0.004-0.019 at an unchanged Chamfer-L2, docs/integrity.md).
    pub radius_smoothing: usize,
}

impl Default for SheetGridOptions {
    fn default() -> Self {
        SheetGridOptions {
            columns: 180,
            row_step: 0.01,
            facing: 0.2,
            outlier: 0.015,
            search: 0.015,
            search_step: 0.002,
            thin: 0.004,
            min_piece_area: 0.03,
            cover: 0.03,
            border_smoothing: 10,
            border_reach: 0.01,
            hem_window: 7,
            gap_rows: 20,
            gap_columns: 20,
            radius_smoothing: 30,
        }
    }
}

/// The grid of rays round one body (canonical space, +Y up).
#[derive(Debug, Clone)]
pub struct GarmentSheet {
    /// The vertical axis: x and z of the body's mean vertex.
    axis: (f32, f32),
    /// Height of the first row's centre.
    bottom: f32,
    /// Rays start this far (metres) from the axis, beyond any part of the body.
    reach: f32,
    shape: Shape,
    pub options: SheetGridOptions,
}

impl GarmentSheet {
    /// The grid round `body` (the rest body, canonical): rows from its feet to its crown.
    pub fn around(body: &TriMesh, options: SheetGridOptions) -> GarmentSheet {
        let n = body.positions.len().max(1) as f32;
        let mean = body.positions.iter().copied().sum::<Vec3>() / n;
        let (lo, hi) = body.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
        let farthest = body
            .positions
            .iter()
            .map(|p| ((p.x - mean.x).powi(2) + (p.z - mean.z).powi(2)).sqrt())
            .fold(0.0f32, f32::max);
        let rows = (((hi.y - lo.y) / options.row_step).ceil() as usize).max(2);
        GarmentSheet {
            axis: (mean.x, mean.z),
            bottom: lo.y + 0.5 * options.row_step,
            reach: farthest + 0.3,
            shape: Shape { rows, columns: options.columns.max(3) },
            options,
        }
    }

    /// The outward direction of a column, and the point on the axis at a row's height.
    fn column_direction(&self, column: usize) -> Vec3 {
        let theta = TAU * column as f32 / self.shape.columns as f32;
        Vec3::new(theta.cos(), 0.0, theta.sin())
    }

    fn axis_point(&self, row: usize) -> Vec3 {
        Vec3::new(self.axis.0, self.bottom + row as f32 * self.options.row_step, self.axis.1)
    }

    /// The point at `radius` from the axis in a cell's direction.
    fn point(&self, cell: usize, radius: f32) -> Vec3 {
        let (row, column) = (cell / self.shape.columns, cell % self.shape.columns);
        self.axis_point(row) + radius * self.column_direction(column)
    }

    /// `pieces` (the loose pieces of a canonical surface, outward faces) with what hangs round
    /// the body remade as a sheet on this grid. `sdf` is the surface's signed distance (metres;
    /// called on many probes at once), `is_loose` tells a point of loose cloth from one on or
    /// near the body (a ray's hit there is not the sheet's).
    pub fn remesh(
        &self,
        pieces: &TriMesh,
        sdf: impl Fn(&[Vec3]) -> Vec<f32>,
        is_loose: impl Fn(Vec3) -> bool + Sync,
    ) -> TriMesh {
        if pieces.faces.is_empty() {
            return pieces.clone();
        }
        let shape = self.shape;
        let hits = self.outermost_hits(pieces, &is_loose);
        let mut mask: Vec<bool> = hits.iter().map(Option::is_some).collect();
        // Stray layers lose their radius, not their cell.
        let known: Vec<Option<f32>> = (0..shape.len())
            .map(|i| {
                let r = hits[i]?;
                let median = grid::neighbour_median(shape, &hits, i).unwrap_or(r);
                ((r - median).abs() <= self.options.outlier).then_some(r)
            })
            .collect();
        mask = grid::fill_enclosed(shape, &grid::close(shape, &mask));
        // Hanging cloth is whole: short tears that reach a border close too (closing them
        // can enclose more holes).
        mask = grid::fill_enclosed(
            shape,
            &grid::fill_short_gaps(shape, &mask, self.options.gap_rows, self.options.gap_columns),
        );
        mask = self.drop_small_islands(&mask, &known);
        let mut radius = grid::fill_values(shape, &mask, &known, 60);
        // The filled cells, at their membrane's radius.
        let filled: Vec<(usize, f32)> = (0..shape.len())
            .filter(|&i| mask[i] && known[i].is_none())
            .filter_map(|i| Some((i, radius[i]?)))
            .collect();
        for (&(cell, _), r) in filled.iter().zip(self.search_rays(&filled, &sdf)) {
            if r.is_some() {
                radius[cell] = r;
            }
        }
        if self.options.hem_window > 0 {
            grid::even_hem(shape, &mut mask, &mut radius, self.options.hem_window);
        }
        grid::smooth_values(shape, &mask, &mut radius, self.options.radius_smoothing);
        // Cells joined only at a corner give triangles that share a single vertex, so a pinch
        // can cut a bit off the sheet (a piece of its own, joined by no edge); small bits go.
        let mut sheet =
            drop_small_pieces(&self.triangulate(&mask, &radius), self.options.min_piece_area);
        smooth_borders(&mut sheet, self.options.border_smoothing, self.options.border_reach);
        if sheet.faces.is_empty() {
            return pieces.clone();
        }
        // `radius` is set on the sheet's cells only.
        let rest = self.uncovered(pieces, &sheet, &radius);
        let base = sheet.positions.len() as u32;
        let mut merged = sheet;
        merged.positions.extend(rest.positions);
        merged.faces.extend(rest.faces.iter().map(|f| f.map(|v| v + base)));
        merged
    }

    /// Each cell's radius where its ray, coming in from outside, first meets the outside of
    /// a piece.
    fn outermost_hits(
        &self,
        pieces: &TriMesh,
        is_loose: &(impl Fn(Vec3) -> bool + Sync),
    ) -> Vec<Option<f32>> {
        let bvh = Bvh::build(pieces);
        let normals = pieces.face_normals();
        (0..self.shape.len())
            .into_par_iter()
            .map(|cell| {
                let inward = -self.column_direction(cell % self.shape.columns);
                let origin = self.point(cell, self.reach);
                bvh.ray_hits(origin, inward, 0.0, self.reach)
                    .into_iter()
                    .find(|h| normals[h.face as usize].dot(-inward) > self.options.facing)
                    .map(|h| self.reach - h.t)
                    .filter(|&r| is_loose(self.point(cell, r)))
            })
            .collect()
    }

    /// `mask` without pieces under `min_piece_area` (cells' areas at their radius, or at the
    /// median radius where unknown).
    fn drop_small_islands(&self, mask: &[bool], radius: &[Option<f32>]) -> Vec<bool> {
        let (label, sizes) = grid::pieces(self.shape, mask, true);
        let mut known: Vec<f32> = radius.iter().flatten().copied().collect();
        known.sort_by(f32::total_cmp);
        let typical = known.get(known.len() / 2).copied().unwrap_or(0.2);
        let cell_area = |r: f32| r * TAU / self.shape.columns as f32 * self.options.row_step;
        let mut area = vec![0f32; sizes.len()];
        for i in 0..self.shape.len() {
            if mask[i] {
                area[label[i] as usize] += cell_area(radius[i].unwrap_or(typical));
            }
        }
        (0..self.shape.len())
            .map(|i| mask[i] && area[label[i] as usize] >= self.options.min_piece_area)
            .collect()
    }

    /// Where the SDF shows cloth along each cell's ray within `search` of its start radius
    /// (`cells`: each with its start, a filled hole's membrane): its outermost crossing from outside
    /// in, else a minimum under `thin`; nothing where the start itself is farther than `thin`
    /// from the SDF's surface (a hole the SDF has too keeps its membrane).
    fn search_rays(
        &self,
        cells: &[(usize, f32)],
        sdf: &impl Fn(&[Vec3]) -> Vec<f32>,
    ) -> Vec<Option<f32>> {
        let o = &self.options;
        let half = (o.search / o.search_step).round() as i32;
        // Offsets from the start radius, outermost first.
        let offsets: Vec<f32> = (-half..=half).rev().map(|k| k as f32 * o.search_step).collect();
        let probes: Vec<Vec3> = cells
            .iter()
            .flat_map(|&(c, r)| offsets.iter().map(move |&t| self.point(c, (r + t).max(0.0))))
            .collect();
        if probes.is_empty() {
            return Vec::new();
        }
        let values = sdf(&probes);
        cells
            .iter()
            .zip(values.chunks(offsets.len()))
            .map(|(&(_, start), f)| {
                // No cloth at the start (a hole the SDF has too): nothing to move onto.
                if f[half as usize] > o.thin {
                    return None;
                }
                let crossing = (0..f.len() - 1)
                    .find(|&k| f[k] > 0.0 && f[k + 1] <= 0.0)
                    .map(|k| offsets[k] + (offsets[k + 1] - offsets[k]) * f[k] / (f[k] - f[k + 1]));
                let dip = (0..f.len())
                    .filter(|&k| f[k].is_finite())
                    .min_by(|&a, &b| f[a].total_cmp(&f[b]))
                    .filter(|&k| f[k] < o.thin)
                    .map(|k| offsets[k]);
                crossing.or(dip).map(|t| (start + t).max(0.0))
            })
            .collect()
    }

    /// The sheet's mesh: a vertex per cell with a radius, two triangles per whole quad (split
    /// along the shorter diagonal) and one where a quad has three corners, facing out.
    fn triangulate(&self, mask: &[bool], radius: &[Option<f32>]) -> TriMesh {
        let shape = self.shape;
        let mut index = vec![u32::MAX; shape.len()];
        let mut positions = Vec::new();
        for i in 0..shape.len() {
            if let (true, Some(r)) = (mask[i], radius[i]) {
                index[i] = positions.len() as u32;
                positions.push(self.point(i, r));
            }
        }
        let mut faces = Vec::new();
        for row in 0..shape.rows - 1 {
            for column in 0..shape.columns {
                // a: this cell, b: above it, c: beside it (round the axis), d: above c.
                let corner = |dr: usize, dc: usize| index[shape.index(row + dr, column + dc)];
                let (a, b, c, d) = (corner(0, 0), corner(1, 0), corner(0, 1), corner(1, 1));
                let present = |v: u32| v != u32::MAX;
                match (present(a), present(b), present(c), present(d)) {
                    (true, true, true, true) => {
                        let p = |v: u32| positions[v as usize];
                        if p(b).distance_squared(p(c)) <= p(a).distance_squared(p(d)) {
                            faces.extend([[a, b, c], [b, d, c]]);
                        } else {
                            faces.extend([[a, b, d], [a, d, c]]);
                        }
                    }
                    (true, true, true, false) => faces.push([a, b, c]),
                    (false, true, true, true) => faces.push([b, d, c]),
                    (true, false, true, true) => faces.push([a, d, c]),
                    (true, true, false, true) => faces.push([a, b, d]),
                    _ => {}
                }
            }
        }
        compact(&positions, &faces)
    }

    /// The cell whose ray passes nearest to `p`, and `p`'s distance from the axis.
    fn cell_of(&self, p: Vec3) -> Option<(usize, f32)> {
        let row = ((p.y - self.bottom) / self.options.row_step).round();
        if row < 0.0 || row >= self.shape.rows as f32 {
            return None;
        }
        let (dx, dz) = (p.x - self.axis.0, p.z - self.axis.1);
        let turn = dz.atan2(dx).rem_euclid(TAU) / TAU;
        let column = (turn * self.shape.columns as f32).round() as usize % self.shape.columns;
        Some((self.shape.index(row as usize, column), (dx * dx + dz * dz).sqrt()))
    }

    /// The faces of `pieces` the sheet does not stand for, in pieces of at least
    /// `min_piece_area`: not within `cover` of the sheet, and not under it (nearer the axis
    /// than the sheet at their cell: the cloth's inside or the blob between the legs, which
    /// the sheet hides).
    fn uncovered(&self, pieces: &TriMesh, sheet: &TriMesh, radius: &[Option<f32>]) -> TriMesh {
        let bvh = Bvh::build(sheet);
        let under = |p: Vec3| {
            self.cell_of(p).is_some_and(|(cell, r)| radius[cell].is_some_and(|sheet| r < sheet))
        };
        let kept: Vec<[u32; 3]> = (0..pieces.faces.len())
            .into_par_iter()
            .filter(|&f| {
                let [a, b, c] = pieces.triangle(f);
                let centre = (a + b + c) / 3.0;
                !under(centre) && !bvh.any_within(centre, self.options.cover)
            })
            .map(|f| pieces.faces[f])
            .collect();
        drop_small_pieces(&compact(&pieces.positions, &kept), self.options.min_piece_area)
    }
}
