//! SDF -> triangle mesh: marching cubes, coarse to fine.
//!
//! Convention (SIREN / MetaAvatar): the SDF is negative inside, positive outside, and its
//! gradient points along the outward normal. Faces come out counter-clockwise seen from
//! outside, so `TriMesh::vertex_normals` points outward.
//!
//! Coarse to fine: the box is cut into blocks of `B^3` fine cells (B = resolution /
//! coarse_resolution). The SDF is first evaluated at the block corners only. A block is
//! refined (its fine grid points evaluated and its cells polygonised) when its corners
//! change sign or when the smallest |sdf| at its corners is below `margin` times the block
//! diagonal: for a true distance function (1-Lipschitz), a block the surface passes through
//! always passes that test, so nothing is lost. Each fine point is evaluated once even where
//! blocks share faces. A learned SDF that is far from a distance (|grad| << 1) needs a larger
//! margin.
//!
//! The cells are polygonised with `marching_cubes`' case table.

use super::TriMesh;
use super::marching_cubes::{EDGES, case_table};
use super::topology::largest_component;
use crate::error::{Error, Result};
use glam::Vec3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Where and how finely to extract.
#[derive(Debug, Clone, PartialEq)]
pub struct ExtractOptions {
    /// Box to polygonise (the grid starts at `min` and covers at least up to `max`).
    pub min: Vec3,
    pub max: Vec3,
    /// Fine cells along the longest side of the box (128 or 256 "equivalent" resolution).
    pub resolution: usize,
    /// Cells along the longest side at the coarse level; the block size is
    /// `resolution / coarse_resolution` (rounded). `coarse_resolution >= resolution` means
    /// dense extraction.
    pub coarse_resolution: usize,
    /// Refine a block when min |sdf - level| over its corners < margin * block diagonal.
    pub margin: f32,
    /// Iso-level (0 for an SDF).
    pub level: f32,
    /// Most points handed to the SDF closure at once.
    pub batch_size: usize,
    /// Keep only the largest connected component (MetaAvatar's clean-up).
    pub largest_component_only: bool,
    /// Taubin smoothing iterations on the result (`super::smooth`): the terraces of the grid
    /// go, the shape stays.
    pub smoothing_iterations: usize,
}

impl ExtractOptions {
    /// Coarse-to-fine extraction over a box at `resolution` cells along its longest side,
    /// coarse level 32, margin 1, the largest component kept.
    pub fn new(min: Vec3, max: Vec3, resolution: usize) -> Self {
        ExtractOptions {
            min,
            max,
            resolution,
            coarse_resolution: 32.min(resolution),
            margin: 1.0,
            level: 0.0,
            batch_size: 1 << 16,
            largest_component_only: true,
            smoothing_iterations: 0,
        }
    }

    /// The same box and resolution, every grid point evaluated (the reference).
    pub fn dense(mut self) -> Self {
        self.coarse_resolution = self.resolution;
        self
    }
}

/// What an extraction cost.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ExtractStats {
    /// Fine cells along x, y, z.
    pub cells: [usize; 3],
    /// Fine cells per block side.
    pub block_size: usize,
    pub blocks: usize,
    pub refined_blocks: usize,
    /// SDF evaluations at the block corners.
    pub coarse_evaluations: usize,
    /// SDF evaluations of fine points inside refined blocks.
    pub fine_evaluations: usize,
    /// Grid points of the dense grid at the same resolution (what dense extraction costs).
    pub dense_evaluations: usize,
    /// Faces before the largest-component clean-up.
    pub raw_faces: usize,
}

impl ExtractStats {
    pub fn evaluations(&self) -> usize {
        self.coarse_evaluations + self.fine_evaluations
    }
    /// Dense evaluations divided by the evaluations actually made.
    pub fn savings(&self) -> f64 {
        self.dense_evaluations as f64 / self.evaluations().max(1) as f64
    }
}

#[derive(Debug, Clone)]
pub struct Extraction {
    pub mesh: TriMesh,
    pub stats: ExtractStats,
}

/// Extract the `level` set of a batch SDF (`sdf(points)[i]` = value at `points[i]`).
pub fn extract<F>(sdf: F, options: &ExtractOptions) -> Result<Extraction>
where
    F: Fn(&[Vec3]) -> Vec<f32>,
{
    try_extract(|points| Ok(sdf(points)), options)
}

/// `extract` for an SDF that can fail (a network on a device); its error is returned as is.
pub fn try_extract<F>(sdf: F, options: &ExtractOptions) -> Result<Extraction>
where
    F: Fn(&[Vec3]) -> Result<Vec<f32>>,
{
    let grid = Grid::new(options)?;
    let eval = |points: &[Vec3]| -> Result<Vec<f32>> {
        let mut values = Vec::with_capacity(points.len());
        for chunk in points.chunks(options.batch_size.max(1)) {
            let v = sdf(chunk)?;
            if v.len() != chunk.len() {
                return Err(Error::invalid(format!(
                    "SDF returned {} values for {} points",
                    v.len(),
                    chunk.len()
                )));
            }
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(Error::invalid(format!(
                    "SDF is not finite ({}) at {}",
                    v[i], chunk[i]
                )));
            }
            values.extend(v);
        }
        Ok(values)
    };

    // Coarse pass: the SDF at every block corner.
    let nb = grid.blocks;
    let corner_dims = [nb[0] + 1, nb[1] + 1, nb[2] + 1];
    let corner_points: Vec<Vec3> = (0..corner_dims[2])
        .flat_map(|z| {
            (0..corner_dims[1]).flat_map(move |y| (0..corner_dims[0]).map(move |x| [x, y, z]))
        })
        .map(|[x, y, z]| grid.point([x * grid.b, y * grid.b, z * grid.b]))
        .collect();
    let coarse = eval(&corner_points)?;
    let corner_value =
        |c: [usize; 3]| coarse[c[0] + corner_dims[0] * (c[1] + corner_dims[1] * c[2])];

    // Which blocks to refine.
    let threshold = options.margin * grid.h * grid.b as f32 * 3f32.sqrt();
    let block_count = nb[0] * nb[1] * nb[2];
    let mut slot = vec![u32::MAX; block_count];
    let mut active: Vec<[usize; 3]> = Vec::new();
    for z in 0..nb[2] {
        for y in 0..nb[1] {
            for x in 0..nb[0] {
                let mut inside = 0;
                let mut nearest = f32::INFINITY;
                for c in 0..8 {
                    let v = corner_value([x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1)])
                        - options.level;
                    inside += (v < 0.0) as usize;
                    nearest = nearest.min(v.abs());
                }
                if (inside > 0 && inside < 8) || nearest < threshold {
                    slot[x + nb[0] * (y + nb[1] * z)] = active.len() as u32;
                    active.push([x, y, z]);
                }
            }
        }
    }

    // Fine pass: each fine point of a refined block is evaluated by one owner block (the
    // refined block of smallest index among those sharing the point) and copied to the rest.
    let b = grid.b;
    let side = b + 1;
    let per_block = side * side * side;
    let mut values = vec![f32::NAN; active.len() * per_block];
    let mut to_eval: Vec<Vec3> = Vec::new();
    let mut eval_dst: Vec<u32> = Vec::new();
    let mut copies: Vec<(u32, u32)> = Vec::new(); // (destination, source) in `values`
    let block_index = |bc: [usize; 3]| bc[0] + nb[0] * (bc[1] + nb[1] * bc[2]);
    for (s, &bc) in active.iter().enumerate() {
        for lz in 0..side {
            for ly in 0..side {
                for lx in 0..side {
                    let local = [lx, ly, lz];
                    let dst = (s * per_block + lx + side * (ly + side * lz)) as u32;
                    if local.iter().all(|&l| l == 0 || l == b) {
                        let c = [bc[0] + lx / b, bc[1] + ly / b, bc[2] + lz / b];
                        values[dst as usize] = corner_value(c);
                        continue;
                    }
                    // Candidate blocks containing this point, per axis (block coord, local coord).
                    let cands = |axis: usize| -> ([(usize, usize); 2], usize) {
                        let (blk, l) = (bc[axis], local[axis]);
                        if l == 0 && blk > 0 {
                            ([(blk - 1, b), (blk, 0)], 2)
                        } else if l == b && blk + 1 < nb[axis] {
                            ([(blk, b), (blk + 1, 0)], 2)
                        } else {
                            ([(blk, l), (blk, l)], 1)
                        }
                    };
                    let (cx, nx) = cands(0);
                    let (cy, ny) = cands(1);
                    let (cz, nz) = cands(2);
                    let mut owner: Option<(usize, usize)> = None; // (block index, value offset)
                    for &(bz, llz) in &cz[..nz] {
                        for &(by, lly) in &cy[..ny] {
                            for &(bx, llx) in &cx[..nx] {
                                let bi = block_index([bx, by, bz]);
                                let sl = slot[bi];
                                if sl != u32::MAX && owner.is_none_or(|(o, _)| bi < o) {
                                    owner = Some((
                                        bi,
                                        sl as usize * per_block + llx + side * (lly + side * llz),
                                    ));
                                }
                            }
                        }
                    }
                    // The block itself is always a refined candidate, so an owner exists.
                    let (_, src) = owner.unwrap_or((block_index(bc), dst as usize));
                    if src == dst as usize {
                        to_eval.push(grid.point([bc[0] * b + lx, bc[1] * b + ly, bc[2] * b + lz]));
                        eval_dst.push(dst);
                    } else {
                        copies.push((dst, src as u32));
                    }
                }
            }
        }
    }
    let fine = eval(&to_eval)?;
    for (&d, v) in eval_dst.iter().zip(fine) {
        values[d as usize] = v;
    }
    for &(d, s) in &copies {
        values[d as usize] = values[s as usize];
    }

    // Marching cubes over the cells of refined blocks.
    let table = case_table();
    let mut positions: Vec<Vec3> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut vertex_of_edge: HashMap<u64, u32, BuildHasherDefault<EdgeHasher>> = HashMap::default();
    let stride = [1usize, grid.cells[0] + 1, (grid.cells[0] + 1) * (grid.cells[1] + 1)];
    for (s, &bc) in active.iter().enumerate() {
        let base = s * per_block;
        for lz in 0..b {
            for ly in 0..b {
                for lx in 0..b {
                    let mut v = [0f32; 8];
                    let mut case = 0usize;
                    for (c, value) in v.iter_mut().enumerate() {
                        let (dx, dy, dz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
                        *value = values[base + (lx + dx) + side * ((ly + dy) + side * (lz + dz))]
                            - options.level;
                        case |= ((*value < 0.0) as usize) << c;
                    }
                    let tris = &table[case];
                    if tris.is_empty() {
                        continue;
                    }
                    let g = [bc[0] * b + lx, bc[1] * b + ly, bc[2] * b + lz];
                    let mut edge_vertex = [u32::MAX; 12];
                    for tri in tris {
                        let face = tri.map(|e| {
                            let e = e as usize;
                            if edge_vertex[e] == u32::MAX {
                                let (c0, c1) = EDGES[e];
                                let lo = [
                                    g[0] + (c0 & 1),
                                    g[1] + ((c0 >> 1) & 1),
                                    g[2] + ((c0 >> 2) & 1),
                                ];
                                let key =
                                    ((lo[0] * stride[0] + lo[1] * stride[1] + lo[2] * stride[2])
                                        * 3
                                        + e / 4) as u64;
                                edge_vertex[e] = *vertex_of_edge.entry(key).or_insert_with(|| {
                                    let (v0, v1) = (v[c0], v[c1]);
                                    let t = v0 / (v0 - v1);
                                    let p0 = grid.point(lo);
                                    let mut p1 = lo;
                                    p1[e / 4] += 1;
                                    positions.push(p0 + (grid.point(p1) - p0) * t);
                                    (positions.len() - 1) as u32
                                });
                            }
                            edge_vertex[e]
                        });
                        faces.push(face);
                    }
                }
            }
        }
    }

    let stats = ExtractStats {
        cells: grid.cells,
        block_size: b,
        blocks: block_count,
        refined_blocks: active.len(),
        coarse_evaluations: corner_points.len(),
        fine_evaluations: to_eval.len(),
        dense_evaluations: (grid.cells[0] + 1) * (grid.cells[1] + 1) * (grid.cells[2] + 1),
        raw_faces: faces.len(),
    };
    let mut mesh = TriMesh::new(positions, faces);
    if options.largest_component_only {
        mesh = largest_component(&mesh);
    }
    super::smooth::taubin(&mut mesh, options.smoothing_iterations);
    Ok(Extraction { mesh, stats })
}

/// The fine grid: origin, cell size, cells per axis (a multiple of the block size).
struct Grid {
    min: Vec3,
    h: f32,
    b: usize,
    blocks: [usize; 3],
    cells: [usize; 3],
}

impl Grid {
    fn new(o: &ExtractOptions) -> Result<Grid> {
        let extent = o.max - o.min;
        if !o.min.is_finite() || !o.max.is_finite() || extent.min_element() <= 0.0 {
            return Err(Error::invalid(format!(
                "extraction box is empty or not finite: {} .. {}",
                o.min, o.max
            )));
        }
        if o.resolution < 2 || o.resolution > 4096 {
            return Err(Error::invalid(format!(
                "extraction resolution {} is outside 2..=4096",
                o.resolution
            )));
        }
        if !(o.margin >= 0.0) || !o.level.is_finite() {
            return Err(Error::invalid("extraction margin must be >= 0 and the level finite"));
        }
        let b = (o.resolution as f32 / o.coarse_resolution.max(1) as f32).round().max(1.0) as usize;
        let h = extent.max_element() / o.resolution as f32;
        let blocks =
            [0, 1, 2].map(|a| ((extent[a] / (h * b as f32)) - 1e-4).ceil().max(1.0) as usize);
        let cells = blocks.map(|n| n * b);
        Ok(Grid { min: o.min, h, b, blocks, cells })
    }

    fn point(&self, g: [usize; 3]) -> Vec3 {
        self.min + Vec3::new(g[0] as f32, g[1] as f32, g[2] as f32) * self.h
    }
}

/// Multiplicative hash for grid-edge keys (std's SipHash is several times slower here).
#[derive(Default)]
struct EdgeHasher(u64);

impl Hasher for EdgeHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            self.write_u64(byte as u64);
        }
    }
    fn write_u64(&mut self, x: u64) {
        let h = (self.0 ^ x).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 = h ^ (h >> 29);
    }
}

#[cfg(test)]
mod tests;
