//! Depth noise smoothed away relative to the body. A network fitted to noisy depth points
//! carries the noise as bumps a few centimetres wide, and on a fine mesh a millimetre of bump
//! tilts the normals by several degrees: the fitted t-shirt's normals were further from the
//! truth's than the naked body's. Smoothing the surface itself (Taubin) either leaves such
//! bumps or flattens the limbs, whose curvature is of the same size. Where cloth lies close to
//! the body, the surface is the body's smooth surface plus an offset (the cloth's thickness and
//! drape): here that offset, a scalar on the mesh, is smoothed along the mesh and the surface
//! rebuilt from it, so the bumps go and the limbs keep the body's curvature. Loose cloth (a
//! skirt, tails) keeps its own shape; the smoothing fades out with the distance to the body.

use super::pose_displacement::{DisplacementLimit, bound_moves};
use crate::mesh::TriMesh;
use crate::mesh::signed_distance::SignedDistance;
use crate::mesh::smooth::{Neighbours, vertex_neighbours};
use glam::Vec3;
use rayon::prelude::*;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetSmoothing {
    /// Offsets from the body (metres, either side) up to which the smoothing is whole, and from
    /// which it is off.
    pub tight: (f32, f32),
    /// Averaging sweeps over the mesh's edges: the noise's wavelength it takes off grows with
    /// the square root (about 1 cm x sqrt(sweeps) at the 192-cell meshes).
    pub sweeps: usize,
}

impl Default for OffsetSmoothing {
    fn default() -> Self {
        // Quick preset, user captures, 192 cells (docs/decisions.md): 20, 40 and
        // 150 sweeps give the same NC (t-shirt 0.896-0.898 against 0.866 without); 150 costs
        // Chamfer. A band of 3-5 cm gains the blazer little (0.920 against 0.932 cm at 20
        // sweeps) and costs the polo spurious surface (0.5 -> 1.2 %).
        OffsetSmoothing { tight: (0.02, 0.035), sweeps: 40 }
    }
}

/// `mesh` (canonical, metres) with its offset from the rest body (`body`) smoothed where it
/// lies close to the body, in place; faces unchanged.
pub fn smooth_body_offsets(mesh: &mut TriMesh, body: &SignedDistance, options: &OffsetSmoothing) {
    if options.sweeps == 0 || mesh.faces.is_empty() {
        return;
    }
    let smoother = SurfaceSmoother::new(body, mesh, *options);
    smoother.smooth(&mut mesh.positions);
}

/// A mesh's smoothing relative to the body, measured once for its topology: each vertex's
/// nearest point of the body's smooth surface and the normal there. A reference mesh projected
/// onto each pose's surface (the studio's poser, the exporter) moves its vertices by millimetres
/// along the normal, so its offsets are read from these anchors at every pose without another
/// nearest-point search.
pub struct SurfaceSmoother {
    /// The mesh's own vertices: a pose's projection moves each at most `limit` away from them.
    reference: Vec<Vec3>,
    reference_normals: Vec<Vec3>,
    limit: DisplacementLimit,
    anchors: Vec<Option<(Vec3, Vec3)>>,
    neighbours: Neighbours,
    options: OffsetSmoothing,
    /// Vertices held where the reference has them (`pin`).
    pinned: Vec<(usize, Vec3)>,
    /// Where the reference pose's own projection moves each vertex (`relative_to`): empty, or
    /// one move a vertex.
    reference_moves: Vec<Vec3>,
    /// With `reference_moves`, the reference's own offsets from the body (measured once; a
    /// pose smooths only its change from them). Empty otherwise.
    reference_offsets: Vec<f32>,
}

impl SurfaceSmoother {
    pub fn new(body: &SignedDistance, mesh: &TriMesh, options: OffsetSmoothing) -> SurfaceSmoother {
        let anchors = mesh
            .positions
            .par_iter()
            .map(|&x| body.smooth_offset(x).map(|(d, n)| (x - d * n, n)))
            .collect();
        SurfaceSmoother {
            reference: mesh.positions.clone(),
            reference_normals: mesh.vertex_normals(),
            limit: DisplacementLimit::default(),
            anchors,
            neighbours: vertex_neighbours(mesh),
            options,
            pinned: Vec::new(),
            reference_moves: Vec::new(),
            reference_offsets: Vec::new(),
        }
    }

    /// Hold the reference's vertices for which `pin` is true where the reference has them,
    /// whatever a pose's projection did to them: a wrapped body's vertices that its surface
    /// swallowed (`body_wrap`) would otherwise be pushed onto the blob around them.
    pub fn pin(mut self, reference: &TriMesh, pin: &[bool]) -> SurfaceSmoother {
        self.pinned = reference
            .positions
            .iter()
            .zip(pin)
            .enumerate()
            .filter(|(_, (_, p))| **p)
            .map(|(v, (x, _))| (v, *x))
            .collect();
        self
    }

    /// Measure each pose's moves from where the projection puts the reference's vertices at
    /// the reference's own pose (`projected`), not from the reference itself: the reference is
    /// the surface finished at that pose (folds guarded, wrapped within a margin), and a
    /// projection moves it off that finish everywhere the zero level disagrees with it (the
    /// eyes, the nostrils, the ears), the same at every pose. So the reference pose gives the
    /// reference back exactly, and another pose moves it only by what the pose changes.
    pub fn relative_to(mut self, projected: &[Vec3]) -> SurfaceSmoother {
        if projected.len() == self.reference.len() {
            self.reference_moves = projected
                .iter()
                .zip(&self.reference)
                .map(|(p, r)| if p.is_finite() { *p - *r } else { Vec3::ZERO })
                .collect();
            self.reference_offsets = self
                .reference
                .par_iter()
                .zip(&self.anchors)
                .map(|(&x, anchor)| anchor.map_or(0.0, |(p, n)| (x - p).dot(n)))
                .collect();
        }
        self
    }

    /// Smooth `positions` (the mesh's vertices, here or moved by a pose's projection) in
    /// place: the moves taken relative to the reference pose's projection (`relative_to`),
    /// bounded and averaged (`pose_displacement`), then the offsets from the body smoothed.
    pub fn smooth(&self, positions: &mut [Vec3]) {
        if positions.len() != self.anchors.len() {
            return;
        }
        if self.reference_moves.len() == positions.len() {
            positions.par_iter_mut().zip(&self.reference_moves).for_each(|(x, m)| *x -= *m);
        }
        bound_moves(
            &self.reference,
            &self.reference_normals,
            positions,
            &self.neighbours,
            &self.limit,
        );
        self.smooth_offsets(positions);
        for &(v, x) in &self.pinned {
            positions[v] = x;
        }
    }

    fn smooth_offsets(&self, positions: &mut [Vec3]) {
        let (a, b) = self.options.tight;
        if self.options.sweeps == 0 {
            return;
        }
        let offsets: Vec<Option<f32>> = positions
            .par_iter()
            .zip(&self.anchors)
            .map(|(&x, anchor)| anchor.map(|(p, n)| (x - p).dot(n)))
            .collect();
        // Relative to a reference pose (`relative_to`), the reference is already a smoothed
        // surface: only each offset's change from the reference's is smoothed, so the reference
        // pose gives the reference back.
        let from = |v: usize| self.reference_offsets.get(v).copied().unwrap_or(0.0);
        // How much of the smoothing each vertex takes: 1 within `a` of the body, 0 from `b` on.
        let share: Vec<f32> = offsets
            .iter()
            .map(|d| match d {
                Some(d) if b > a => (1.0 - (d.abs() - a) / (b - a)).clamp(0.0, 1.0),
                Some(d) => (d.abs() <= a) as u8 as f32,
                None => 0.0,
            })
            .collect();
        if share.iter().all(|&s| s == 0.0) {
            return;
        }
        let n = &self.neighbours;
        // Each sweep: a vertex's offset becomes the mean of its own and its neighbours' among the
        // vertices that take part (loose cloth neither gives nor takes). Those neighbours are
        // listed once (compressed rows in the order of `neighbours`), not tested every sweep.
        let mut smoothed: Vec<f32> =
            offsets.iter().enumerate().map(|(v, d)| d.map_or(0.0, |d| d - from(v))).collect();
        let taking: Vec<u32> =
            (0..share.len() as u32).filter(|&v| share[v as usize] > 0.0).collect();
        let mut rows = Vec::with_capacity(taking.len() + 1);
        let mut around: Vec<u32> = Vec::with_capacity(n.indices.len());
        rows.push(0);
        for &v in &taking {
            let v = v as usize;
            around.extend(
                n.indices[n.offsets[v]..n.offsets[v + 1]]
                    .iter()
                    .filter(|&&u| share[u as usize] > 0.0),
            );
            rows.push(around.len());
        }
        let mut next = vec![0f32; taking.len()];
        for _ in 0..self.options.sweeps {
            next.par_iter_mut().with_min_len(1024).enumerate().for_each(|(i, out)| {
                let mut sum = smoothed[taking[i] as usize];
                let row = &around[rows[i]..rows[i + 1]];
                for &u in row {
                    sum += smoothed[u as usize];
                }
                *out = sum / (row.len() + 1) as f32;
            });
            for (&v, x) in taking.iter().zip(&next) {
                smoothed[v as usize] = *x;
            }
        }
        positions.par_iter_mut().enumerate().for_each(|(v, x)| {
            if let (Some(d), Some((_, normal))) = (offsets[v], self.anchors[v]) {
                *x += share[v] * (smoothed[v] - (d - from(v))) * normal;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::raster::tests::sphere;

    fn mesh_sphere(r: f32, rings: usize, segs: usize) -> TriMesh {
        let (p, f) = sphere(Vec3::ZERO, r, rings, segs);
        TriMesh::new(p, f)
    }

    #[test]
    fn the_offset_is_measured_from_the_smooth_surface_not_its_facets() {
        // A coarse 10 cm sphere: its faces sag up to 2 mm inside the sphere between corners.
        let body = SignedDistance::new(&mesh_sphere(0.1, 8, 16));
        let (mut flat_worst, mut smooth_worst) = (0f32, 0f32);
        for i in 0..400 {
            // Directions spread over the sphere (a Fibonacci lattice), 1 cm outside.
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / 400.0;
            let phi = i as f32 * 2.399_963;
            let dir =
                Vec3::new((1.0 - y * y).sqrt() * phi.cos(), y, (1.0 - y * y).sqrt() * phi.sin());
            let p = dir * 0.11;
            flat_worst = flat_worst.max((body.at(p).unwrap() - 0.01).abs());
            let (d, n) = body.smooth_offset(p).unwrap();
            smooth_worst = smooth_worst.max((d - 0.01).abs());
            assert!(n.dot(dir) > 0.98, "normal {n} at {dir}");
        }
        assert!(flat_worst > 1e-3, "the facets' error {flat_worst}");
        assert!(
            smooth_worst < 0.35 * flat_worst,
            "smooth offset off by up to {smooth_worst} m (facets: {flat_worst})"
        );
    }

    #[test]
    fn bumps_near_the_body_go_and_the_size_and_loose_cloth_stay() {
        let body = SignedDistance::new(&mesh_sphere(0.1, 48, 96));
        // Cloth 8 mm outside a 10 cm body with 1.5 mm bumps about 2 cm wide; the cap above
        // y = 0.09 m bulges 6 cm out (loose cloth).
        let mut cloth = mesh_sphere(0.108, 96, 192);
        let loose = |p: Vec3| p.y > 0.09;
        for p in cloth.positions.iter_mut() {
            let dir = p.normalize();
            let bump = 0.0015 * (dir.x * 31.0).sin() * (dir.z * 29.0).cos() * (dir.y * 23.0).cos();
            *p = if loose(*p) { dir * 0.16 } else { dir * (0.108 + bump) };
        }
        let offset_spread = |m: &TriMesh| {
            let r: Vec<f32> =
                m.positions.iter().filter(|p| p.y < 0.06).map(|p| p.length()).collect();
            let mean = r.iter().sum::<f32>() / r.len() as f32;
            (mean, (r.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / r.len() as f32).sqrt())
        };
        let normal_error = |m: &TriMesh| {
            let normals = m.vertex_normals();
            let e: Vec<f32> = m
                .positions
                .iter()
                .zip(&normals)
                .filter(|(p, _)| p.y < 0.06)
                .map(|(p, n)| (p.normalize() - *n).length())
                .collect();
            e.iter().sum::<f32>() / e.len() as f32
        };
        let (mean_before, spread_before) = offset_spread(&cloth);
        let error_before = normal_error(&cloth);
        let mut smoothed = cloth.clone();
        smooth_body_offsets(
            &mut smoothed,
            &body,
            &OffsetSmoothing { tight: (0.02, 0.035), sweeps: 40 },
        );
        let (mean_after, spread_after) = offset_spread(&smoothed);
        let error_after = normal_error(&smoothed);
        assert!(spread_after < 0.25 * spread_before, "bumps {spread_before} -> {spread_after} m");
        assert!(
            (mean_after - mean_before).abs() < 3e-4,
            "the cloth's offset moved: {mean_before} -> {mean_after} m"
        );
        assert!(error_after < 0.4 * error_before, "normals' error {error_before} -> {error_after}");
        // Loose cloth (6 cm out) is untouched.
        for (a, b) in cloth.positions.iter().zip(&smoothed.positions) {
            if a.length() > 0.15 {
                assert_eq!(a, b);
            }
        }
    }

    #[test]
    fn a_reference_moved_along_the_normals_is_smoothed_as_if_measured_anew() {
        // A pose's surface is the reference projected a few millimetres along the normals:
        // the anchors measured at the reference serve it.
        let body = SignedDistance::new(&mesh_sphere(0.1, 48, 96));
        let mut reference = mesh_sphere(0.108, 64, 128);
        for p in reference.positions.iter_mut() {
            *p *= 1.0 + 0.01 * (p.x * 40.0).sin();
        }
        let options = OffsetSmoothing { tight: (0.02, 0.035), sweeps: 40 };
        let smoother = SurfaceSmoother::new(&body, &reference, options);
        let mut pose = reference.clone();
        for (i, p) in pose.positions.iter_mut().enumerate() {
            *p += p.normalize() * 0.003 * ((i % 7) as f32 / 6.0);
        }
        // The smoother first bounds and averages the moves (`pose_displacement`); then its
        // offsets are those of the moved surface measured anew.
        let mut anew = pose.clone();
        bound_moves(
            &reference.positions,
            &reference.vertex_normals(),
            &mut anew.positions,
            &vertex_neighbours(&reference),
            &DisplacementLimit::default(),
        );
        smooth_body_offsets(&mut anew, &body, &options);
        smoother.smooth(&mut pose.positions);
        let worst = pose
            .positions
            .iter()
            .zip(&anew.positions)
            .map(|(a, b)| a.distance(*b))
            .fold(0f32, f32::max);
        assert!(worst < 1e-4, "{worst} m from the surface smoothed with fresh anchors");
        // A mesh of another topology is left as it is.
        let mut other = mesh_sphere(0.108, 8, 16);
        let before = other.positions.clone();
        smoother.smooth(&mut other.positions);
        assert_eq!(other.positions, before);
    }

    #[test]
    fn pinned_vertices_stay_where_the_reference_has_them() {
        let body = SignedDistance::new(&mesh_sphere(0.1, 48, 96));
        let reference = mesh_sphere(0.105, 32, 64);
        let pin: Vec<bool> = reference.positions.iter().map(|p| p.y > 0.09).collect();
        let smoother = SurfaceSmoother::new(&body, &reference, OffsetSmoothing::default())
            .pin(&reference, &pin);
        // A pose's projection pushed every vertex 1 cm out.
        let mut pose: Vec<Vec3> =
            reference.positions.iter().map(|p| *p + p.normalize() * 0.01).collect();
        smoother.smooth(&mut pose);
        for ((p, r), &pinned) in pose.iter().zip(&reference.positions).zip(&pin) {
            if pinned {
                assert_eq!(p, r);
            } else {
                assert!((p.length() - 0.115).abs() < 1e-3, "{} m", p.length());
            }
        }
    }

    #[test]
    fn relative_to_its_pose_the_reference_comes_back_and_a_pose_moves_it_by_the_change() {
        // A bumpy reference (the surface finished at its pose) whose projection at that same
        // pose lands 2-6 mm off it, differently at each vertex (the zero level disagreeing
        // with the finish: eyes, nostrils).
        let body = SignedDistance::new(&mesh_sphere(0.1, 48, 96));
        let mut reference = mesh_sphere(0.108, 64, 128);
        for p in reference.positions.iter_mut() {
            *p *= 1.0 + 0.01 * (p.x * 40.0).sin();
        }
        let off = |i: usize, p: Vec3| p.normalize() * (0.002 + 0.004 * ((i % 5) as f32 / 4.0));
        let projected: Vec<Vec3> =
            reference.positions.iter().enumerate().map(|(i, &p)| p + off(i, p)).collect();
        let options = OffsetSmoothing { tight: (0.02, 0.035), sweeps: 40 };
        let smoother = SurfaceSmoother::new(&body, &reference, options).relative_to(&projected);
        let mut same = projected.clone();
        smoother.smooth(&mut same);
        let worst =
            same.iter().zip(&reference.positions).map(|(a, b)| a.distance(*b)).fold(0f32, f32::max);
        assert!(worst < 1e-5, "the reference pose moved the reference by {worst} m");
        // Another pose's projection: the same disagreement plus 3 mm out everywhere.
        let mut pose: Vec<Vec3> = projected.iter().map(|&p| p + p.normalize() * 0.003).collect();
        smoother.smooth(&mut pose);
        for (p, r) in pose.iter().zip(&reference.positions) {
            let moved = p.length() - r.length();
            assert!((moved - 0.003).abs() < 3e-4, "moved {moved} m instead of 3 mm");
        }
    }
}
