//! Meshes prepared for the metrics' repeated queries, and the check every scored mesh passes.

use super::sampling::sample_surface;
use super::surface_error::SampleDistances;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::mesh::bvh::Bvh;
use crate::mesh::point_index::PointIndex;
use glam::Vec3;
use rand_chacha::ChaCha8Rng;

/// A mesh prepared for repeated queries (normals, vertex index, BVH).
pub struct Prepared<'a> {
    pub mesh: &'a TriMesh,
    pub normals: Vec<Vec3>,
    pub vertices: PointIndex,
    pub bvh: Bvh,
}

impl<'a> Prepared<'a> {
    /// `what` names the mesh in errors ("predicted", "ground-truth").
    pub fn new(mesh: &'a TriMesh, what: &str) -> Result<Prepared<'a>> {
        check_mesh(mesh, what)?;
        Ok(Prepared {
            mesh,
            normals: mesh.vertex_normals(),
            vertices: PointIndex::new(&mesh.positions)?,
            bvh: Bvh::build(mesh),
        })
    }
}

impl Prepared<'_> {
    /// Distance from `p` to the surface, given an upper bound (e.g. the nearest-vertex
    /// distance) that prunes the BVH search.
    pub fn surface_distance_below(&self, p: Vec3, bound: f32) -> f32 {
        self.bvh
            .closest_point_within(p, bound * (1.0 + 1e-5) + 1e-9)
            .map_or(bound, |h| h.distance.min(bound))
    }

    /// Distance from `p` to the surface.
    pub fn surface_distance(&self, p: Vec3) -> f32 {
        self.surface_distance_below(p, self.vertices.nearest(p).1)
    }

    /// `n` area-uniform samples of this surface measured to `other`; `clothed(p)` says
    /// whether a sample lies in the clothed region.
    pub fn sample_distances(
        &self,
        other: &Prepared,
        n: usize,
        rng: &mut ChaCha8Rng,
        clothed: impl Fn(Vec3) -> bool,
    ) -> Result<SampleDistances> {
        let points = sample_surface(self.mesh, n.max(1), rng)?;
        Ok(SampleDistances {
            distance: points.iter().map(|&p| other.surface_distance(p)).collect(),
            clothed: points.iter().map(|&p| clothed(p)).collect(),
        })
    }
}

/// A mesh must have faces, finite positions and valid indices to be scored.
pub fn check_mesh(mesh: &TriMesh, what: &str) -> Result<()> {
    if mesh.faces.is_empty() {
        return Err(Error::invalid(format!("{what} mesh is empty")));
    }
    if let Some(p) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(Error::invalid(format!(
            "{what} mesh vertex {p} is not finite ({})",
            mesh.positions[p]
        )));
    }
    let n = mesh.positions.len() as u32;
    if let Some(f) = mesh.faces.iter().position(|f| f.iter().any(|&i| i >= n)) {
        return Err(Error::invalid(format!("{what} mesh face {f} refers to a vertex beyond {n}")));
    }
    Ok(())
}
