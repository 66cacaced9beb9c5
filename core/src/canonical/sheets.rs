//! Loose cloth as a sheet. A signed distance field can only draw closed surfaces, so an
//! avatar's skirt or blazer tails come out as a thin slab: the cloth's outer side, and an inner
//! wall a few centimetres behind it (as thin as the shell samples make it,
//! `canonical::shell`) that faces the legs. Real cloth, and the truth the evaluation scores
//! against, is one sheet: the inner wall is surface that is not there (on the dress, about half
//! of what the evaluation called spurious), and in a viewer it shows as a second skirt inside
//! the first. Here the inner wall is taken off: faces well outside the body whose normals face
//! the body and behind which (through the slab) the outer side follows within `max_wall`.
//! Skin, tight clothing and solid blobs keep every face.

use crate::mesh::bvh::Bvh;
use crate::mesh::signed_distance::SignedDistance;
use crate::mesh::topology::compact;
use crate::mesh::TriMesh;
use rayon::prelude::*;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SheetOptions {
    /// Only vertices this far outside the body (metres) can be an inner wall: the shells'
    /// "loose" distance (behind tighter cloth the body is the inside).
    pub loose: f32,
    /// The slab is thin when its outer side is at most this far behind (metres). A solid
    /// thing thinner than this, farther out than `loose` and facing the body (a ponytail, a
    /// bag held at the hip) is opened too.
    pub max_wall: f32,
    /// The vertex normal faces the body: cosine with the direction to the body's nearest point.
    pub facing: f32,
}

impl Default for SheetOptions {
    fn default() -> Self {
        // Measured on the quick preset (dress / blazer Chamfer-L2): max_wall 0.10 and facing 0.5
        // gave 1.029 / 0.484 cm, 0.20 and 0.1 give 1.000 / 0.479 (the skirt's slab is thicker
        // where its shells found no room); 0.30 and 0.0 gain no more (docs/evaluation.md).
        SheetOptions { loose: 0.03, max_wall: 0.20, facing: 0.1 }
    }
}

/// `mesh` (canonical, metres, outward faces) without the inner walls of its loose cloth;
/// `body` is the rest body's signed distance. Faces with all three vertices on an inner wall
/// go; unused vertices are dropped.
pub fn open_inner_walls(mesh: TriMesh, body: &SignedDistance, options: &SheetOptions) -> TriMesh {
    if mesh.faces.is_empty() {
        return mesh;
    }
    let normals = mesh.vertex_normals();
    let candidates: Vec<bool> = mesh
        .positions
        .par_iter()
        .zip(&normals)
        .map(|(&x, &n)| match body.with_closest(x) {
            Some((d, nearest)) if d > options.loose => n.dot((nearest - x).normalize_or_zero()) > options.facing,
            _ => false,
        })
        .collect();
    if !candidates.iter().any(|&c| c) {
        return mesh;
    }
    let bvh = Bvh::build(&mesh);
    // Through the slab, away from the body: the outer side within `max_wall`.
    let inner: Vec<bool> = mesh
        .positions
        .par_iter()
        .zip(&normals)
        .zip(&candidates)
        .map(|((&x, &n), &c)| c && bvh.ray_cast(x, -n, 1e-3, options.max_wall).is_some())
        .collect();
    let kept: Vec<[u32; 3]> = mesh.faces.iter().copied().filter(|f| !f.iter().all(|&v| inner[v as usize])).collect();
    if kept.len() == mesh.faces.len() {
        return mesh;
    }
    compact(&mesh.positions, &kept)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::extract::{extract, ExtractOptions};
    use glam::Vec3;

    /// The "body": a closed cylinder of radius 28 cm around the y axis, 60 cm high.
    fn cylinder() -> TriMesh {
        let sdf = |p: &[Vec3]| -> Vec<f32> { p.iter().map(|q| (Vec3::new(q.x, 0.0, q.z).length() - 0.28).max(q.y.abs() - 0.3)).collect() };
        extract(sdf, &ExtractOptions::new(Vec3::splat(-0.4), Vec3::splat(0.4), 96)).unwrap().mesh
    }

    /// A ring-shaped slab around the y axis (radii `inner` to `outer`, 20 cm high), as marching
    /// cubes draws it from its signed distance.
    fn ring_slab(inner: f32, outer: f32) -> TriMesh {
        let (mid, half) = ((inner + outer) / 2.0, (outer - inner) / 2.0);
        let sdf = |p: &[Vec3]| -> Vec<f32> { p.iter().map(|q| (Vec3::new(q.x, 0.0, q.z).length() - mid).abs().max(q.y.abs() - 0.1 + half) - half).collect() };
        extract(sdf, &ExtractOptions::new(Vec3::splat(-outer - 0.05), Vec3::splat(outer + 0.05), 96)).unwrap().mesh
    }

    fn area_where(mesh: &TriMesh, keep: impl Fn(Vec3, Vec3) -> bool) -> f32 {
        (0..mesh.faces.len())
            .map(|f| {
                let [a, b, c] = mesh.triangle(f);
                let n = (b - a).cross(c - a);
                if keep((a + b + c) / 3.0, n.normalize_or_zero()) { n.length() / 2.0 } else { 0.0 }
            })
            .sum()
    }

    #[test]
    fn a_thin_skirt_loses_its_inner_wall_and_skin_and_solid_cloth_keep_theirs() {
        let body = SignedDistance::new(&cylinder());
        let options = SheetOptions::default();
        let radial = |x: Vec3| Vec3::new(x.x, 0.0, x.z).length();
        // Facing the axis (the body), on the slab's side walls.
        let inner_wall = |c: Vec3, n: Vec3| c.y.abs() < 0.07 && n.dot(-Vec3::new(c.x, 0.0, c.z).normalize()) > 0.9;
        let outer_wall = |c: Vec3, n: Vec3| c.y.abs() < 0.07 && n.dot(Vec3::new(c.x, 0.0, c.z).normalize()) > 0.9;
        // A 3 cm wall 4 cm outside the body (the skirt).
        let skirt = ring_slab(0.32, 0.35);
        let opened = open_inner_walls(skirt.clone(), &body, &options);
        let (inner_before, inner_after) = (area_where(&skirt, inner_wall), area_where(&opened, inner_wall));
        assert!(inner_before > 0.2, "the slab has an inner wall: {inner_before} m^2");
        assert!(inner_after < 0.02 * inner_before, "inner wall {inner_before} -> {inner_after} m^2");
        let (outer_before, outer_after) = (area_where(&skirt, outer_wall), area_where(&opened, outer_wall));
        assert!((outer_after - outer_before).abs() < 1e-6 * outer_before.max(1.0), "outer wall {outer_before} -> {outer_after} m^2");
        assert!(opened.positions.iter().all(|&x| radial(x) > 0.31), "no vertex inside the slab's inner radius");
        // A slab 30 cm thick (a solid bell, not a sheet): its inner wall stays.
        let solid = ring_slab(0.32, 0.62);
        assert_eq!(open_inner_walls(solid.clone(), &body, &options), solid);
        // Cloth 1 cm off the body: its inside is the body, not a second wall.
        let tight = ring_slab(0.29, 0.32);
        assert_eq!(open_inner_walls(tight.clone(), &body, &options), tight);
    }
}
