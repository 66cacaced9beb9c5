//! Skinning weights for a clothed mesh whose loose parts hang away from the body (a skirt, a
//! blazer's tails). The diffused field gives each point the weights of the body nearby, so a
//! skirt between the legs switches from one leg's weights to the other's within a few
//! centimetres and tears when the legs part. Here the weights of the loose vertices (from
//! `loose.0` metres outside the body on, wholly from `loose.1`) are inpainted along the mesh's
//! own edges (each the average of its neighbours, the vertices near the body held at the
//! field's weights), as robust skin-weight transfer does for garments (Abdrashitov et al.
//! 2023): along the cloth, not across the gap between the legs, so a hem follows both thighs
//! in proportion and stretches instead of tearing.

use super::SkinningField;
use crate::body::{BodyModel, Bones, NUM_JOINTS, Weights, blend_transform};
use crate::mesh::TriMesh;
use crate::mesh::signed_distance::SignedDistance;
use crate::mesh::smooth::vertex_neighbours;
use crate::mesh::topology::{compact, drop_non_manifold_faces};
use rayon::prelude::*;
use std::sync::Arc;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GarmentSkinning {
    /// Distance outside the body (metres) where the inpainting starts, and where it is whole.
    pub loose: (f32, f32),
    /// Most conjugate-gradient steps (the solve stops earlier when it has converged).
    pub iterations: usize,
    /// Loose cloth that spans both legs (a skirt, a coat's tails) does not follow the shins
    /// (`free_bridging_cloth_of_shins`).
    pub free_of_shins: bool,
}

impl Default for GarmentSkinning {
    fn default() -> Self {
        // Loose from 1 cm out, wholly from 3 cm: with the skirt one whole sheet
        // (`garment_sheet`), one fitted dress at 26 held-out poses (`examples/posed_errors`):
        // (0.02, 0.05) 0.744 cm Chamfer-L2, (0.01, 0.03) 0.724, (0.0, 0.02) 0.716, (0.03, 0.08)
        // 0.795; the lunge gains most (the skirt's front follows the raised thigh less).
        GarmentSkinning { loose: (0.01, 0.03), iterations: 300, free_of_shins: true }
    }
}

/// The weights of `mesh`'s vertices (canonical space): the field's, inpainted along the mesh
/// where it is loose clothing (`body`: the rest body's signed distance).
///
/// The inpainted weights are the fixed point of "each loose vertex takes (1 - l) of the field's
/// weights and l of its neighbours' average" (l its looseness), a sparse symmetric positive
/// definite system once each row is scaled by its degree / l; it is solved by conjugate
/// gradients with a diagonal preconditioner, the 24 joints side by side (Jacobi sweeps need
/// thousands of sweeps to carry the hips' weights down a skirt: 200 sweeps got the dress's
/// Chamfer-L2 from 1.507 to 1.286 cm, 800 to 1.098).
pub fn garment_weights(
    field: &SkinningField,
    body: &SignedDistance,
    mesh: &TriMesh,
    options: &GarmentSkinning,
) -> Vec<Weights> {
    inpaint_loose_weights(field_weights(field, mesh), body, mesh, options)
}

/// Each vertex's weights in the diffused field.
pub fn field_weights(field: &SkinningField, mesh: &TriMesh) -> Vec<Weights> {
    mesh.positions.par_iter().map(|&x| field.weights_at(x)).collect()
}

/// `own` (each vertex's weights where it stands) inpainted along the mesh where it is loose
/// clothing: [`garment_weights`] from any starting weights.
pub fn inpaint_loose_weights(
    own: Vec<Weights>,
    body: &SignedDistance,
    mesh: &TriMesh,
    options: &GarmentSkinning,
) -> Vec<Weights> {
    let (a, b) = options.loose;
    // How loose each vertex is, 0 (the field's weights) to nearly 1 (its neighbours' average;
    // never quite 1, so a loose piece that touches no tight vertex still has one solution).
    let looseness: Vec<f32> = mesh
        .positions
        .par_iter()
        .map(|&x| match body.at(x) {
            Some(d) if b > a => ((d - a) / (b - a)).clamp(0.0, MAX_LOOSENESS),
            _ => 0.0,
        })
        .collect();
    let loose: Vec<usize> = (0..mesh.positions.len()).filter(|&v| looseness[v] > 0.0).collect();
    if options.iterations == 0 || loose.is_empty() {
        return own;
    }
    let n = vertex_neighbours(mesh);
    let mut slot = vec![usize::MAX; mesh.positions.len()];
    for (i, &v) in loose.iter().enumerate() {
        slot[v] = i;
    }
    let degree = |v: usize| (n.offsets[v + 1] - n.offsets[v]) as f32;
    // Row v (scaled by degree / l): (degree / l) w_v - sum of the loose neighbours' w_u
    // = degree (1 - l) / l own_v + sum of the tight neighbours' own_u.
    let diagonal: Vec<f32> = loose.iter().map(|&v| degree(v).max(1.0) / looseness[v]).collect();
    let rhs: Vec<Weights> = loose
        .par_iter()
        .map(|&v| {
            let l = looseness[v];
            let mut r = own[v].map(|w| degree(v).max(1.0) * (1.0 - l) / l * w);
            for &u in &n.indices[n.offsets[v]..n.offsets[v + 1]] {
                if slot[u as usize] == usize::MAX {
                    add(&mut r, &own[u as usize], 1.0);
                }
            }
            r
        })
        .collect();
    let apply = |x: &[Weights]| -> Vec<Weights> {
        loose
            .par_iter()
            .enumerate()
            .map(|(i, &v)| {
                let mut y = x[i].map(|w| diagonal[i] * w);
                for &u in &n.indices[n.offsets[v]..n.offsets[v + 1]] {
                    let k = slot[u as usize];
                    if k != usize::MAX {
                        add(&mut y, &x[k], -1.0);
                    }
                }
                y
            })
            .collect()
    };
    let solved = conjugate_gradients(
        &apply,
        &rhs,
        &diagonal,
        loose.iter().map(|&v| own[v]).collect(),
        options.iterations,
    );
    let mut weights = own;
    for (&v, w) in loose.iter().zip(solved) {
        // The solution is a partition of unity up to the solver's tolerance.
        let w = w.map(|x| x.max(0.0));
        let sum: f32 = w.iter().sum();
        weights[v] = if sum > 0.0 { w.map(|x| x / sum) } else { weights[v] };
    }
    if options.free_of_shins {
        free_bridging_cloth_of_shins(&mut weights, &loose, &looseness);
    }
    weights
}

const MAX_LOOSENESS: f32 = 0.999;

/// The left and right leg's joints: hip (the thigh), knee (the shin), ankle and foot.
const LEFT_LEG: [usize; 4] = [1, 4, 7, 10];
const RIGHT_LEG: [usize; 4] = [2, 5, 8, 11];
const PELVIS: usize = 0;

/// Cloth hanging between the legs hangs from the pelvis and is pushed by the thighs, but no
/// shin drags it: the inpainted weights of a skirt's hem carry about half their weight on the
/// knees (the cloth near the knees holds the field's weights), so a lunge's back leg pulls the
/// hem back along the shin and a squat pulls the skirt down onto the shins. Each loose vertex's
/// knee, ankle and foot weights go to the pelvis in proportion to its looseness and to how
/// evenly it spans both legs (2 min(left, right) / (left + right) of its leg weights): a
/// skirt's front and back centre wholly, its sides little, a wide trouser leg (one leg's
/// weights) not at all. Quick preset's dress, one fitted avatar (docs/decisions.md): every
/// clip better, held-out Chamfer-L2 0.909 -> 0.847 cm.
fn free_bridging_cloth_of_shins(weights: &mut [Weights], loose: &[usize], looseness: &[f32]) {
    for &v in loose {
        let w = &mut weights[v];
        let left: f32 = LEFT_LEG.iter().map(|&j| w[j]).sum();
        let right: f32 = RIGHT_LEG.iter().map(|&j| w[j]).sum();
        if left + right <= 0.0 {
            continue;
        }
        let share = looseness[v] * 2.0 * left.min(right) / (left + right);
        for j in LEFT_LEG[1..].iter().chain(&RIGHT_LEG[1..]) {
            let moved = share * w[*j];
            w[*j] -= moved;
            w[PELVIS] += moved;
        }
    }
}

fn add(acc: &mut Weights, w: &Weights, scale: f32) {
    for (a, b) in acc.iter_mut().zip(w) {
        *a += scale * b;
    }
}

/// Per joint, the dot products of two block vectors (in f64).
fn dots(x: &[Weights], y: &[Weights]) -> [f64; NUM_JOINTS] {
    x.par_iter()
        .zip(y)
        .with_min_len(1024)
        .fold(
            || [0f64; NUM_JOINTS],
            |mut acc, (a, b)| {
                for j in 0..NUM_JOINTS {
                    acc[j] += a[j] as f64 * b[j] as f64;
                }
                acc
            },
        )
        .reduce(
            || [0f64; NUM_JOINTS],
            |mut p, q| {
                for j in 0..NUM_JOINTS {
                    p[j] += q[j];
                }
                p
            },
        )
}

/// Preconditioned conjugate gradients for `apply(x) = rhs`, every joint's column its own
/// system, from `x`, at most `iterations` steps or until each column's residual is 1e-5 of
/// its right-hand side.
fn conjugate_gradients(
    apply: &(dyn Fn(&[Weights]) -> Vec<Weights> + Sync),
    rhs: &[Weights],
    diagonal: &[f32],
    mut x: Vec<Weights>,
    iterations: usize,
) -> Vec<Weights> {
    let precondition = |r: &[Weights]| -> Vec<Weights> {
        r.par_iter().zip(diagonal).map(|(r, d)| r.map(|v| v / d)).collect()
    };
    let ax = apply(&x);
    let mut r: Vec<Weights> =
        rhs.par_iter().zip(&ax).map(|(b, a)| std::array::from_fn(|j| b[j] - a[j])).collect();
    let mut z = precondition(&r);
    let mut p = z.clone();
    let mut rz = dots(&r, &z);
    let target = dots(rhs, rhs).map(|b| b * 1e-10);
    for _ in 0..iterations {
        let ap = apply(&p);
        let pap = dots(&p, &ap);
        let alpha: [f32; NUM_JOINTS] =
            std::array::from_fn(|j| if pap[j] > 0.0 { (rz[j] / pap[j]) as f32 } else { 0.0 });
        x.par_iter_mut()
            .zip(&p)
            .for_each(|(x, p)| (0..NUM_JOINTS).for_each(|j| x[j] += alpha[j] * p[j]));
        r.par_iter_mut()
            .zip(&ap)
            .for_each(|(r, a)| (0..NUM_JOINTS).for_each(|j| r[j] -= alpha[j] * a[j]));
        let rr = dots(&r, &r);
        if (0..NUM_JOINTS).all(|j| rr[j] <= target[j]) {
            break;
        }
        z = precondition(&r);
        let rz_next = dots(&r, &z);
        let beta: [f32; NUM_JOINTS] =
            std::array::from_fn(|j| if rz[j] > 0.0 { (rz_next[j] / rz[j]) as f32 } else { 0.0 });
        rz = rz_next;
        p.par_iter_mut()
            .zip(&z)
            .for_each(|(p, z)| (0..NUM_JOINTS).for_each(|j| p[j] = z[j] + beta[j] * p[j]));
    }
    x
}

/// An avatar's skinning of its meshes: the diffused field, inpainted along loose clothing.
pub struct GarmentSkinner {
    body: Arc<SignedDistance>,
    pub options: GarmentSkinning,
}

impl GarmentSkinner {
    /// For the body `body` shaped by `betas` (its rest surface tells loose from tight).
    pub fn new(body: &BodyModel, betas: &[f32]) -> GarmentSkinner {
        Self::with_body(Arc::new(SignedDistance::new(&body.mesh(body.shaped_vertices(betas)))))
    }

    /// For a rest body whose signed distance is already built (a capture's).
    pub fn with_body(body: Arc<SignedDistance>) -> GarmentSkinner {
        GarmentSkinner { body, options: GarmentSkinning::default() }
    }

    /// The weights of a canonical mesh's vertices.
    pub fn weights(&self, field: &SkinningField, mesh: &TriMesh) -> Vec<Weights> {
        garment_weights(field, &self.body, mesh, &self.options)
    }

    /// [`GarmentSkinner::weights`] from given weights where each vertex stands (a wrapped
    /// body's own: `BodyWrap::own_weights`) instead of the field's.
    pub fn weights_from(&self, own: Vec<Weights>, mesh: &TriMesh) -> Vec<Weights> {
        inpaint_loose_weights(own, &self.body, mesh, &self.options)
    }

    /// How every avatar's extracted canonical surface comes out (posing, export, the
    /// evaluation, the studio): without the inner walls of its loose cloth (`canonical::sheets`),
    /// its offset from the body smoothed where it lies close to it
    /// (`canonical::offset_smoothing`).
    pub fn finish_surface(&self, mesh: TriMesh) -> TriMesh {
        let opened = super::open_inner_walls(mesh, &self.body, &super::SheetOptions::default());
        let (manifold, _) = drop_non_manifold_faces(&opened, 0);
        let mut mesh = compact(&manifold.positions, &manifold.faces);
        self.smooth_surface(&mut mesh);
        mesh
    }

    /// The depth noise smoothed off a canonical surface near the body, topology unchanged.
    pub fn smooth_surface(&self, mesh: &mut TriMesh) {
        super::smooth_body_offsets(mesh, &self.body, &super::OffsetSmoothing::default());
    }

    /// The same smoothing measured once for a reference mesh, to apply to its projections onto
    /// each pose's surface (`AvatarSource::surface_smoother`).
    pub fn surface_smoother(&self, reference: &TriMesh) -> super::SurfaceSmoother {
        super::SurfaceSmoother::new(&self.body, reference, super::OffsetSmoothing::default())
    }

    /// The canonical mesh posed by the bones.
    pub fn pose(&self, field: &SkinningField, bones: &Bones, mesh: &TriMesh) -> TriMesh {
        forward_skin_with_weights(bones, mesh, &self.weights(field, mesh))
    }
}

/// Forward skinning of `mesh` with per-vertex `weights`.
pub fn forward_skin_with_weights(bones: &Bones, mesh: &TriMesh, weights: &[Weights]) -> TriMesh {
    let positions = mesh
        .positions
        .par_iter()
        .zip(weights)
        .map(|(&x, w)| blend_transform(&bones.transforms, w).transform_point3(x))
        .collect();
    TriMesh::new(positions, mesh.faces.clone())
}

#[cfg(test)]
mod tests;
