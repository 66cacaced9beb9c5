//! A wrapped surface without folds. Each body vertex is moved along its normal on its own
//! (`BodyWrap::wrap_within`), so where the SDF is poor (eyes, ears, the nose bridge, where the
//! depth says little) neighbours can land on different crossings and their faces turn over:
//! crumpled sheets and spikes. Here the offsets of the vertices of a face that points against
//! the body's face beneath it move halfway to their neighbours' mean (never farther out) and
//! shrink toward the body, round after round, until no face is turned over; a vertex still in a
//! fold after that goes back onto the body, whose own detail is the better guess where the
//! evidence is thin. Offsets away from folds are not touched.
//!
//! Faces that pass through other faces of the surface (an eyelid folded through its
//! neighbours) are spanned as a membrane instead (`span_crossings`): their vertices move toward
//! their neighbours' mean position, so the surface bridges the crease rather than dropping
//! onto the body; faces that cross already on the bare body (the open body's toes) are left.

use crate::mesh::TriMesh;
use crate::mesh::crossings::{CrossingTracker, flags, self_intersecting_faces};
use glam::Vec3;
use std::sync::OnceLock;

/// Smoothing rounds before the vertices still in a fold go back onto the body.
const MAX_ROUNDS: usize = 60;
/// Each round, a folded vertex's offset also shrinks by this factor (toward the body).
const SHRINK: f32 = 0.85;
/// Rounds of spanning crossings: 10 clear the demo's default fit; a head wrapped 4 mm past
/// its creases' limit (hundreds of crossing faces) takes 80.
const MAX_SPAN_ROUNDS: usize = 100;

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
        self.relax(&rest.faces, offsets, MAX_ROUNDS, place, |p| self.folded_faces(&rest.faces, p))
    }

    /// Removes the crossings of a surface with the rest body's faces (`positions` a vertex) as
    /// a membrane would: the `movable` vertices of each crossing face (but for the bare body's
    /// own crossings) move halfway to their neighbours' mean position, round after round, until
    /// no such face is left or [`MAX_SPAN_ROUNDS`] have run. A fold spans the crease it folded
    /// into instead of being pulled onto the body. Returns how many faces crossed before in
    /// pairs with a face that has a movable vertex (pairs of two others are not tested).
    pub fn span_crossings(
        &self,
        rest: &TriMesh,
        positions: &mut [Vec3],
        movable: &[bool],
    ) -> usize {
        let n_faces = rest.faces.len();
        let can_move: Vec<bool> =
            rest.faces.iter().map(|f| f.iter().any(|&v| movable[v as usize])).collect();
        if !can_move.contains(&true) {
            return 0;
        }
        let mut tracker = CrossingTracker::among(positions, &rest.faces, Some(&can_move));
        let mut crossing = self.not_at_rest(rest, flags(n_faces, tracker.update(positions)));
        let before = crossing.iter().filter(|&&c| c).count();
        for _ in 0..MAX_SPAN_ROUNDS {
            let mut moving = vec![false; positions.len()];
            for (f, _) in rest.faces.iter().zip(&crossing).filter(|(_, c)| **c) {
                for &v in f {
                    moving[v as usize] |= movable[v as usize];
                }
            }
            if !moving.contains(&true) {
                break;
            }
            let current = positions.to_vec();
            for (v, p) in positions.iter_mut().enumerate().filter(|(v, _)| moving[*v]) {
                let around = self.neighbours_of(v);
                if around.is_empty() {
                    continue;
                }
                let mean =
                    around.iter().map(|&u| current[u as usize]).sum::<Vec3>() / around.len() as f32;
                *p = 0.5 * (current[v] + mean);
            }
            crossing = self.not_at_rest(rest, flags(n_faces, tracker.update(positions)));
        }
        before
    }

    /// Moves the vertices of the faces `bad` finds toward their neighbours and the body, round
    /// after round, until none is bad; after `max_rounds` the vertices still in a bad face go
    /// back onto the body. Returns the bad faces before.
    fn relax(
        &self,
        faces: &[[u32; 3]],
        offsets: &mut [Option<f32>],
        max_rounds: usize,
        place: impl Fn(&[Option<f32>]) -> Vec<Vec3>,
        bad: impl Fn(&[Vec3]) -> Vec<bool>,
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
                for (v, t) in offsets.iter_mut().enumerate() {
                    if moving[v] {
                        *t = None;
                    }
                }
                break;
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

    /// Two spheres 2 cm apart, every vertex offset 1.2 cm out: the offset spheres pass through
    /// each other where they face; spanned, no face crosses and the far sides keep their
    /// places to the bit; vertices not movable stay. Spheres that overlap on the bare body keep
    /// their crossing (no move of the surface undoes it).
    #[test]
    fn crossings_are_spanned_and_the_far_sides_kept() {
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
        let moved: Vec<Vec3> =
            body.positions.iter().zip(&normals).map(|(&x, &n)| x + 0.012 * n).collect();
        let all = vec![true; moved.len()];
        let mut placed = moved.clone();
        let before = guard.span_crossings(&body, &mut placed, &all);
        assert!(before >= 10, "the offset spheres should cross: {before} faces");
        assert_eq!(guard.crossing_faces(&body, &placed).iter().filter(|&&c| c).count(), 0);
        let centre_b = 0.22;
        for (v, &p) in body.positions.iter().enumerate() {
            if p.x < -0.02 || p.x > centre_b + 0.02 {
                assert_eq!(placed[v], moved[v], "vertex {v} at {p} moved");
            }
        }
        // Only the movable vertices move: the first sphere held, the second gives way alone.
        let second: Vec<bool> = (0..moved.len()).map(|v| v >= moved.len() / 2).collect();
        let mut placed = moved.clone();
        guard.span_crossings(&body, &mut placed, &second);
        assert_eq!(placed[..moved.len() / 2], moved[..moved.len() / 2]);
        // Overlapping on the bare body: nothing to span.
        let overlapping = pair(-0.02);
        let guard = FoldGuard::new(&overlapping);
        assert!(guard.crossing_faces(&overlapping, &overlapping.positions).iter().all(|&c| !c));
        assert!(guard.crossing_at_rest.get().is_some_and(|c| c.iter().any(|&c| c)));
        let mut bare = overlapping.positions.clone();
        assert_eq!(guard.span_crossings(&overlapping, &mut bare, &all), 0);
        assert_eq!(bare, overlapping.positions);
    }
}
