//! A wrapped surface without folds. Each body vertex is moved along its normal on its own
//! (`BodyWrap::wrap_within`), so where the SDF is poor (eyes, ears, the nose bridge, where the
//! depth says little) neighbours can land on different crossings and their faces turn over:
//! crumpled sheets and spikes. Here the offsets of the vertices of a face that points against
//! the body's face beneath it move halfway to their neighbours' mean (never farther out) and
//! shrink toward the body, round after round, until no face is turned over; a vertex still in a
//! fold after that goes back onto the body, whose own detail is the better guess where the
//! evidence is thin. Offsets away from folds are not touched.
//!
//! The same relaxation untangles faces that pass through other faces of the surface (the cloth
//! that bridges the crotch from both thighs, an ear's rim through its neighbours), but for the
//! faces that cross already on the bare body (the open body's toes): offsets cannot undo those.

use crate::mesh::TriMesh;
use crate::mesh::crossings::{CrossingTracker, flags, self_intersecting_faces};
use glam::Vec3;
use std::sync::OnceLock;

/// Smoothing rounds before the vertices still in a fold go back onto the body.
const MAX_ROUNDS: usize = 60;
/// Each round, a folded vertex's offset also shrinks by this factor (toward the body).
const SHRINK: f32 = 0.85;
/// Rounds for crossing faces (each one tests the whole surface for crossings, so fewer; a
/// crossing shrinks to under a fifth of its offsets' first size in them).
const MAX_UNTANGLE_ROUNDS: usize = 10;

/// The rest body's neighbourhoods and face normals, built once per body.
#[derive(Debug, Clone)]
pub struct FoldGuard {
    /// Neighbours of vertex `v`: `neighbours[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    neighbours: Vec<u32>,
    rest_normals: Vec<Vec3>,
    /// Faces that cross another face on the bare body (its own mesh's flaws), found the first
    /// time a surface is untangled (off by default, so no avatar pays for it otherwise).
    crossing_at_rest: OnceLock<Vec<bool>>,
}

impl FoldGuard {
    pub fn new(rest: &TriMesh) -> FoldGuard {
        let n = rest.positions.len();
        let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &[a, b, c] in &rest.faces {
            for (u, v) in [(a, b), (b, c), (c, a), (b, a), (c, b), (a, c)] {
                adjacent[u as usize].push(v);
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut neighbours = Vec::new();
        for mut list in adjacent {
            list.sort_unstable();
            list.dedup();
            start.push(neighbours.len() as u32);
            neighbours.extend(list);
        }
        start.push(neighbours.len() as u32);
        FoldGuard {
            start,
            neighbours,
            rest_normals: rest.face_normals(),
            crossing_at_rest: OnceLock::new(),
        }
    }

    fn neighbours_of(&self, v: usize) -> &[u32] {
        &self.neighbours[self.start[v] as usize..self.start[v + 1] as usize]
    }

    /// Faces of `faces` at `positions` that point against the rest body's face (turned over).
    pub fn folded_faces(&self, faces: &[[u32; 3]], positions: &[Vec3]) -> Vec<bool> {
        faces
            .iter()
            .zip(&self.rest_normals)
            .map(|(f, &rest)| {
                let [a, b, c] = f.map(|v| positions[v as usize]);
                let n = (b - a).cross(c - a);
                n != Vec3::ZERO && n.dot(rest) <= 0.0
            })
            .collect()
    }

    /// Faces of the surface with `rest`'s faces at `positions` that pass through another
    /// face, but for those that cross on the bare body already.
    pub fn crossing_faces(&self, rest: &TriMesh, positions: &[Vec3]) -> Vec<bool> {
        self.not_at_rest(rest, self_intersecting_faces(positions, &rest.faces))
    }

    fn not_at_rest(&self, rest: &TriMesh, mut crossing: Vec<bool>) -> Vec<bool> {
        let at_rest = self
            .crossing_at_rest
            .get_or_init(|| self_intersecting_faces(&rest.positions, &rest.faces));
        for (c, &own) in crossing.iter_mut().zip(at_rest) {
            *c &= !own;
        }
        crossing
    }

    /// Removes the folds of the surface `rest + offset * normal` (offsets along the rest
    /// body's vertex `normals`; `None`: left on the body). Returns how many faces were turned
    /// over before.
    pub fn unfold(&self, rest: &TriMesh, normals: &[Vec3], offsets: &mut [Option<f32>]) -> usize {
        let place = |t: &[Option<f32>]| along_normals(rest, normals, t);
        self.relax(&rest.faces, offsets, MAX_ROUNDS, false, place, |p| {
            self.folded_faces(&rest.faces, p)
        })
    }

    /// Removes the crossings ([`Self::crossing_faces`]) of a surface with the rest body's
    /// faces, `positions` a vertex, as [`Self::unfold`] removes folds: each vertex's offset
    /// along the body's normal is what shrinks, the rest of its move from the body shrinking
    /// with it. Returns how many faces crossed before.
    pub fn untangle(&self, rest: &TriMesh, normals: &[Vec3], positions: &mut [Vec3]) -> usize {
        let start: Vec<f32> = positions
            .iter()
            .zip(&rest.positions)
            .zip(normals)
            .map(|((&p, &x), &n)| (p - x).dot(n))
            .collect();
        let aside: Vec<Vec3> = positions
            .iter()
            .zip(&rest.positions)
            .zip(normals)
            .zip(&start)
            .map(|(((&p, &x), &n), &t)| p - x - t * n)
            .collect();
        let place = |offsets: &[Option<f32>]| -> Vec<Vec3> {
            let along = along_normals(rest, normals, offsets);
            along
                .into_iter()
                .zip(offsets)
                .zip(&start)
                .zip(&aside)
                .map(|(((p, t), &t0), &r)| match t {
                    None => p,
                    Some(t) if t0.abs() > 1e-6 => p + r * (t / t0).clamp(0.0, 1.0),
                    Some(_) => p + r,
                })
                .collect()
        };
        let mut offsets: Vec<Option<f32>> = start.iter().map(|&t| Some(t)).collect();
        let mut tracker = CrossingTracker::new(&place(&offsets), &rest.faces);
        let before = self.relax(&rest.faces, &mut offsets, MAX_UNTANGLE_ROUNDS, true, place, |p| {
            self.not_at_rest(rest, flags(rest.faces.len(), tracker.update(p)))
        });
        if before > 0 {
            // Only the vertices that moved: the rest keep their positions to the bit.
            let placed = place(&offsets);
            for (v, p) in positions.iter_mut().enumerate() {
                if offsets[v] != Some(start[v]) {
                    *p = placed[v];
                }
            }
        }
        before
    }

    /// Moves the vertices of the faces `bad` finds toward their neighbours and the body, round
    /// after round, until none is bad; after `max_rounds` the vertices still in a bad face go
    /// back onto the body (once, or with `until_clean` as many rounds as that takes). Returns
    /// the bad faces before.
    fn relax(
        &self,
        faces: &[[u32; 3]],
        offsets: &mut [Option<f32>],
        max_rounds: usize,
        until_clean: bool,
        place: impl Fn(&[Option<f32>]) -> Vec<Vec3>,
        mut bad: impl FnMut(&[Vec3]) -> Vec<bool>,
    ) -> usize {
        let mut folded = bad(&place(offsets));
        let before = folded.iter().filter(|&&f| f).count();
        if before == 0 {
            return 0;
        }
        let n = offsets.len();
        let mut round = 0;
        while folded.iter().any(|&f| f) {
            // The bad faces' vertices move, toward their neighbours and toward the body:
            // never farther out, so a fold cannot spread what made it.
            let mut moving = vec![false; n];
            for (f, _) in faces.iter().zip(&folded).filter(|(_, f)| **f) {
                for &v in f {
                    moving[v as usize] = true;
                }
            }
            if round >= max_rounds {
                // Onto the body; with `until_clean`, round after round until no bad face is
                // left or none of theirs has an offset to give up (a flaw of the bare body).
                let mut changed = false;
                for (v, t) in offsets.iter_mut().enumerate() {
                    if moving[v] && t.is_some() {
                        *t = None;
                        changed = true;
                    }
                }
                if !until_clean || !changed {
                    break;
                }
                folded = bad(&place(offsets));
                round += 1;
                continue;
            }
            let current: Vec<Option<f32>> = offsets.to_vec();
            for (v, t) in offsets.iter_mut().enumerate().filter(|(v, _)| moving[*v]) {
                let around = self.neighbours_of(v);
                let mean = around.iter().map(|&u| current[u as usize].unwrap_or(0.0)).sum::<f32>()
                    / around.len().max(1) as f32;
                let own = current[v].unwrap_or(0.0);
                let toward = if own.abs() < mean.abs() { own } else { 0.5 * (own + mean) };
                *t = Some(SHRINK * toward);
            }
            folded = bad(&place(offsets));
            round += 1;
        }
        before
    }
}

/// `rest`'s vertices moved along `normals` by `offsets` (`None`: not moved).
fn along_normals(rest: &TriMesh, normals: &[Vec3], offsets: &[Option<f32>]) -> Vec<Vec3> {
    rest.positions
        .iter()
        .zip(normals)
        .zip(offsets)
        .map(|((&x, &n), t)| x + t.unwrap_or(0.0) * n)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The inside of a sphere of latitude-longitude quads (even triangles, unlike marching
    /// cubes' slivers, as a body mesh has), faces turned inwards.
    fn inside_of_sphere(r: f32, rings: usize, segments: usize) -> TriMesh {
        let mut positions = vec![Vec3::Y * r];
        for i in 1..rings {
            let theta = std::f32::consts::PI * i as f32 / rings as f32;
            for j in 0..segments {
                let phi = std::f32::consts::TAU * j as f32 / segments as f32;
                positions.push(
                    r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()),
                );
            }
        }
        positions.push(Vec3::NEG_Y * r);
        let ring = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
        let last = positions.len() as u32 - 1;
        let mut faces = Vec::new();
        for j in 0..segments {
            faces.push([0, ring(1, j + 1), ring(1, j)]);
            faces.push([last, ring(rings - 1, j), ring(rings - 1, j + 1)]);
            for i in 1..rings - 1 {
                faces.push([ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)]);
                faces.push([ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)]);
            }
        }
        let outward = TriMesh::new(positions, faces);
        let mut inside = outward.clone();
        // Decide the winding by the signed volume, then turn it inwards.
        if outward.signed_volume() > 0.0 {
            inside.faces.iter_mut().for_each(|f| f.swap(1, 2));
        }
        inside
    }

    #[test]
    fn a_crumpled_patch_is_unfolded_and_the_rest_is_untouched() {
        // A concave body (an eye socket, the web of a nose): the inside of a 10 cm sphere,
        // its normals pointing to the centre. Offsets beyond the centre of curvature turn
        // faces over.
        let r = 0.1;
        let socket = inside_of_sphere(r, 48, 96);
        let normals = socket.vertex_normals();
        assert!(normals[0].dot(socket.positions[0]) < 0.0, "normals point inwards");
        let guard = FoldGuard::new(&socket);
        // 1 cm of cloth everywhere, and a patch where every vertex picked its own crossing
        // within 16 cm: some beyond the centre.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let in_patch = |p: Vec3| p.y > 0.0 && p.x.abs() < 0.03 && p.z.abs() < 0.03;
        let mut offsets: Vec<Option<f32>> = socket
            .positions
            .iter()
            .map(|&p| Some(if in_patch(p) { rng.random_range(0.0..0.16) } else { 0.01 }))
            .collect();
        let original = offsets.clone();
        let before = guard.unfold(&socket, &normals, &mut offsets);
        assert!(before >= 3, "the patch should fold: {before} faces turned over");
        let placed: Vec<Vec3> = socket
            .positions
            .iter()
            .zip(&normals)
            .zip(&offsets)
            .map(|((&x, &n), t)| x + t.unwrap_or(0.0) * n)
            .collect();
        assert_eq!(guard.folded_faces(&socket.faces, &placed).iter().filter(|&&f| f).count(), 0);
        // Away from the patch nothing moved.
        let mut moved_far = 0;
        for (v, &p) in socket.positions.iter().enumerate() {
            if (p.y < 0.0 || p.x.abs() > 0.06 || p.z.abs() > 0.06) && offsets[v] != original[v] {
                moved_far += 1;
            }
        }
        assert_eq!(moved_far, 0);
        // A surface without folds is left exactly as it is.
        let mut smooth: Vec<Option<f32>> = vec![Some(0.01); socket.positions.len()];
        assert_eq!(guard.unfold(&socket, &normals, &mut smooth), 0);
        assert!(smooth.iter().all(|&t| t == Some(0.01)));
    }

    #[test]
    fn clothing_a_few_centimetres_out_is_left_alone_where_clothes_are() {
        // The body's own mesh, every vertex 0.5-3 cm out: shirts and trousers. The offset
        // surface folds only in the body's tight creases (eyelids, lips, ears, between fingers
        // and toes); the guard unfolds those and leaves the clothed region exactly as it was.
        let body = crate::body::open_body_ref();
        let rest = body.mesh(body.shaped_vertices(&[]));
        let normals = rest.vertex_normals();
        let guard = FoldGuard::new(&rest);
        let clothed: Vec<bool> = body
            .weights
            .iter()
            .map(|w| {
                crate::body::skeleton::CLOTHED_JOINTS.contains(&crate::synth::outfit::dominant(w))
            })
            .collect();
        for out in [0.005, 0.015, 0.03] {
            let mut offsets = vec![Some(out); rest.positions.len()];
            let before = guard.unfold(&rest, &normals, &mut offsets);
            assert!(before > 0, "the head's creases fold {out} m out");
            let placed: Vec<Vec3> = rest
                .positions
                .iter()
                .zip(&normals)
                .zip(&offsets)
                .map(|((&x, &n), t)| x + t.unwrap_or(0.0) * n)
                .collect();
            assert!(!guard.folded_faces(&rest.faces, &placed).contains(&true), "{out} m out");
            let moved: Vec<usize> =
                (0..offsets.len()).filter(|&v| clothed[v] && offsets[v] != Some(out)).collect();
            // The creases of the clothed region (armpits, the navel, behind the knees) fold
            // too once the offset is larger than their radius: a few percent of it at 3 cm.
            let share = moved.len() as f32 / clothed.iter().filter(|&&c| c).count() as f32;
            let bound = if out < 0.02 { 0.015 } else { 0.05 };
            assert!(share < bound, "{out} m out: {share} of the clothed vertices moved");
        }
    }

    /// Two spheres 2 cm apart, every vertex offset 3 cm out: the offset spheres pass through
    /// each other where they face; untangled, no face crosses and the far sides keep their
    /// offsets. Spheres that overlap on the bare body keep their crossing (no offset undoes it).
    #[test]
    fn offsets_that_pass_through_each_other_are_untangled_and_the_far_sides_kept() {
        let sphere = |centre: Vec3| {
            let mut s = inside_of_sphere(0.1, 24, 48);
            s.faces.iter_mut().for_each(|f| f.swap(1, 2));
            s.positions.iter_mut().for_each(|p| *p += centre);
            s
        };
        let pair = |gap: f32| {
            let (a, b) = (sphere(Vec3::ZERO), sphere(Vec3::X * (0.2 + gap)));
            let k = a.positions.len() as u32;
            let mut positions = a.positions;
            positions.extend(b.positions);
            let mut faces = a.faces;
            faces.extend(b.faces.iter().map(|f| f.map(|v| v + k)));
            TriMesh::new(positions, faces)
        };
        let body = pair(0.02);
        let normals = body.vertex_normals();
        let guard = FoldGuard::new(&body);
        // 3 cm out along the normals and 2 mm aside (what smoothing adds), which shrinks with it.
        let moved: Vec<Vec3> = body
            .positions
            .iter()
            .zip(&normals)
            .map(|(&x, &n)| x + 0.03 * n + 0.002 * n.cross(Vec3::Y).normalize_or_zero())
            .collect();
        let mut placed = moved.clone();
        let before = guard.untangle(&body, &normals, &mut placed);
        assert!(before >= 10, "the offset spheres should cross: {before} faces");
        assert_eq!(guard.crossing_faces(&body, &placed).iter().filter(|&&c| c).count(), 0);
        // The sides facing away (x < 0 on the first sphere, beyond the second's centre) kept
        // their place.
        let centre_b = 0.22;
        for (v, &p) in body.positions.iter().enumerate() {
            if p.x < -0.02 || p.x > centre_b + 0.02 {
                assert_eq!(placed[v], moved[v], "vertex {v} at {p} moved");
            }
        }
        // Overlapping on the bare body: nothing to untangle by offsets.
        let overlapping = pair(-0.02);
        let guard = FoldGuard::new(&overlapping);
        assert!(guard.crossing_faces(&overlapping, &overlapping.positions).iter().all(|&c| !c));
        assert!(guard.crossing_at_rest.get().is_some_and(|c| c.iter().any(|&c| c)));
        let normals = overlapping.vertex_normals();
        let mut bare = overlapping.positions.clone();
        assert_eq!(guard.untangle(&overlapping, &normals, &mut bare), 0);
        assert_eq!(bare, overlapping.positions);
    }
}
