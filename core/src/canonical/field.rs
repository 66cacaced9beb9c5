//! The diffused skinning field (FITE, Eq. 4-6): the body's skinning weights extended into the
//! 3D space around the canonical body. On the surface it equals the body's weights; along the
//! surface normal it does not change (each cell takes the weights of its nearest surface
//! point); away from the surface it is smoothed by diffusion so that the field has no seams
//! where the nearest surface point jumps (between the legs, under the arms). Each joint's
//! field is clamped to [0, 1] and renormalised. Stored on a regular grid and queried
//! trilinearly.

use crate::body::{BodyModel, NUM_JOINTS, Weights, interpolate_weights};
use crate::error::{Error, Result};
use crate::mesh::bvh::Bvh;
use crate::mesh::{TriMesh, barycentric};
use glam::Vec3;
use rayon::prelude::*;

/// How the field is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldOptions {
    /// Cells along the body's height (the other axes use the same cell size).
    pub cells_along_height: usize,
    /// Space around the body covered by the grid (metres): loose clothing lives there.
    pub margin: f32,
    /// Cells closer than this many cell sizes to the surface keep their nearest-point weights.
    pub fixed_band: f32,
    /// Diffusion (Jacobi) iterations for the cells further out.
    pub smoothing_iterations: usize,
}

/// Cells along the height a skinning field may have: 128 is the default; 256 is already about
/// half a gigabyte (24 weights a node), beyond that the grid does not fit in memory.
pub const FIELD_CELLS: std::ops::RangeInclusive<usize> = 16..=256;

impl FieldOptions {
    /// Refuse grids that cannot be built (checked before anything is allocated).
    pub fn validate(&self) -> Result<()> {
        if !FIELD_CELLS.contains(&self.cells_along_height) {
            return Err(Error::invalid(format!(
                "skinning field of {} cells along the height is out of range ({} to {})",
                self.cells_along_height,
                FIELD_CELLS.start(),
                FIELD_CELLS.end()
            )));
        }
        if !(0.0..=2.0).contains(&self.margin)
            || !(0.0..=100.0).contains(&self.fixed_band)
            || self.smoothing_iterations > 10_000
        {
            return Err(Error::invalid(
                "skinning field options out of range (margin 0-2 m, band 0-100 cells, at most 10000 iterations)",
            ));
        }
        Ok(())
    }
}

impl Default for FieldOptions {
    fn default() -> Self {
        FieldOptions {
            cells_along_height: 128,
            margin: 0.35,
            fixed_band: 1.5,
            smoothing_iterations: 24,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct SkinningField {
    pub origin: Vec3,
    pub cell: f32,
    pub dims: [usize; 3],
    /// Dense weights, `NUM_JOINTS` per grid node, x fastest.
    pub weights: Vec<f32>,
}

impl SkinningField {
    /// Build around a body's rest surface (`rest` = shaped canonical vertices of `body`).
    pub fn build(body: &BodyModel, rest: &[Vec3], options: &FieldOptions) -> Result<SkinningField> {
        if rest.len() != body.weights.len() {
            return Err(Error::invalid(format!(
                "{} rest vertices for {} skinning weights",
                rest.len(),
                body.weights.len()
            )));
        }
        Self::build_around(&body.mesh(rest.to_vec()), &body.weights, options)
    }

    /// Build around any canonical surface with weights at its vertices (FITE builds it around
    /// the clothed template, so loose cloth moves with the template's weights).
    pub fn build_around(
        mesh: &TriMesh,
        vertex_weights: &[Weights],
        options: &FieldOptions,
    ) -> Result<SkinningField> {
        options.validate()?;
        let rest = &mesh.positions;
        if rest.len() != vertex_weights.len() || mesh.faces.is_empty() {
            return Err(Error::invalid(format!(
                "{} surface vertices ({} faces) for {} skinning weights",
                rest.len(),
                mesh.faces.len(),
                vertex_weights.len()
            )));
        }
        let (lo, hi) = crate::mesh::bounds(rest).ok_or_else(|| Error::invalid("empty body"))?;
        let extent = hi - lo;
        if !extent.is_finite() || extent.max_element() > 10.0 || extent.y <= 0.0 {
            return Err(Error::invalid(format!(
                "the shaped body spans {extent} m: not a plausible person (shape coefficients out of range?)"
            )));
        }
        let (lo, hi) = (lo - Vec3::splat(options.margin), hi + Vec3::splat(options.margin));
        let cell = (hi.y - lo.y) / options.cells_along_height.max(8) as f32;
        let dims = [0, 1, 2].map(|a| (((hi[a] - lo[a]) / cell).ceil() as usize + 1).max(2));
        let bvh = Bvh::build(mesh);
        let n = dims[0] * dims[1] * dims[2];
        // 1. Nearest surface point of every node: barycentric blend of its triangle's weights
        //    (exactly the body's weights on the surface, constant along the normal).
        let mut dist = vec![0f32; n];
        let mut weights = vec![0f32; n * NUM_JOINTS];
        weights.par_chunks_mut(NUM_JOINTS).zip(dist.par_iter_mut()).enumerate().for_each(
            |(i, (w, d))| {
                let p = node_position(lo, cell, dims, i);
                let hit = bvh.closest_point(p).expect("non-empty body");
                *d = hit.distance;
                let f = mesh.faces[hit.face as usize].map(|k| k as usize);
                let b = barycentric(hit.point, rest[f[0]], rest[f[1]], rest[f[2]]);
                w.copy_from_slice(&interpolate_weights(vertex_weights, f, b));
            },
        );
        // 2. Diffuse away from the surface (6-neighbour Jacobi), near-surface nodes fixed.
        let fixed: Vec<bool> = dist.iter().map(|&d| d <= options.fixed_band * cell).collect();
        let mut next = weights.clone();
        let stride = [1, dims[0], dims[0] * dims[1]];
        for _ in 0..options.smoothing_iterations {
            next.par_chunks_mut(NUM_JOINTS).enumerate().for_each(|(i, out)| {
                if fixed[i] {
                    out.copy_from_slice(&weights[i * NUM_JOINTS..(i + 1) * NUM_JOINTS]);
                    return;
                }
                let idx = [i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1])];
                let mut acc = [0f32; NUM_JOINTS];
                let mut count = 0.0;
                for a in 0..3 {
                    for s in [-1i64, 1] {
                        let c = idx[a] as i64 + s;
                        if c < 0 || c >= dims[a] as i64 {
                            continue;
                        }
                        let k = (i as i64 + s * stride[a] as i64) as usize;
                        for j in 0..NUM_JOINTS {
                            acc[j] += weights[k * NUM_JOINTS + j];
                        }
                        count += 1.0;
                    }
                }
                for j in 0..NUM_JOINTS {
                    out[j] = acc[j] / count;
                }
            });
            std::mem::swap(&mut weights, &mut next);
        }
        // 3. Clamp each joint's field to [0, 1] and renormalise.
        weights.par_chunks_mut(NUM_JOINTS).for_each(|w| {
            let mut sum = 0.0;
            for v in w.iter_mut() {
                *v = v.clamp(0.0, 1.0);
                sum += *v;
            }
            if sum > 0.0 {
                w.iter_mut().for_each(|v| *v /= sum);
            } else {
                w[0] = 1.0;
            }
        });
        Ok(SkinningField { origin: lo, cell, dims, weights })
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        let size = Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        ) * self.cell;
        (self.origin, self.origin + size)
    }

    pub fn contains(&self, p: Vec3) -> bool {
        let (lo, hi) = self.bounds();
        p.cmpge(lo).all() && p.cmple(hi).all()
    }

    /// Trilinear weights at `p` (clamped to the grid).
    pub fn weights_at(&self, p: Vec3) -> Weights {
        let g = ((p - self.origin) / self.cell).max(Vec3::ZERO);
        let mut out = [0f32; NUM_JOINTS];
        // `g` is not negative: truncation is the floor.
        let i0 = [0, 1, 2].map(|a| (g[a] as usize).min(self.dims[a] - 2));
        let t = Vec3::new(g.x - i0[0] as f32, g.y - i0[1] as f32, g.z - i0[2] as f32)
            .clamp(Vec3::ZERO, Vec3::ONE);
        let factors = [[1.0 - t.x, t.x], [1.0 - t.y, t.y], [1.0 - t.z, t.z]];
        let stride = [1, self.dims[0], self.dims[0] * self.dims[1]];
        let base = i0[0] + stride[1] * i0[1] + stride[2] * i0[2];
        for corner in 0..8 {
            let o = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let w = factors[0][o[0]] * factors[1][o[1]] * factors[2][o[2]];
            if w == 0.0 {
                continue;
            }
            let k = base + o[0] + stride[1] * o[1] + stride[2] * o[2];
            let node = &self.weights[k * NUM_JOINTS..(k + 1) * NUM_JOINTS];
            for (v, &x) in out.iter_mut().zip(node) {
                *v += w * x;
            }
        }
        out
    }

    pub fn num_nodes(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }
}

fn node_position(origin: Vec3, cell: f32, dims: [usize; 3], i: usize) -> Vec3 {
    let (x, y, z) = (i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1]));
    origin + Vec3::new(x as f32, y as f32, z as f32) * cell
}
