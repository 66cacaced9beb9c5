//! The cloth solver keeps its edge lengths, hangs under gravity, stays outside the body, and
//! the simulated garments move as cloth through a motion.

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::integrity::integrity;
use avatar_core::motion::library_clip;
use avatar_core::synth::cloth::{
    BodyCollider, Cloth, ClothConfig, garment_mesh, pinned_vertices, simulate_garment,
};
use avatar_core::synth::{ClothedTemplate, Outfit, subject_betas};
use glam::Vec3;

/// A square sheet of `n` x `n` particles, `size` metres wide, in the XZ plane at height `y`.
fn sheet(n: usize, size: f32, y: f32) -> TriMesh {
    let mut positions = Vec::new();
    for r in 0..n {
        for c in 0..n {
            let (u, v) = (c as f32 / (n - 1) as f32, r as f32 / (n - 1) as f32);
            positions.push(Vec3::new((u - 0.5) * size, y, (v - 0.5) * size));
        }
    }
    let idx = |r: usize, c: usize| (r * n + c) as u32;
    let mut faces = Vec::new();
    for r in 0..n - 1 {
        for c in 0..n - 1 {
            faces.push([idx(r, c), idx(r + 1, c), idx(r + 1, c + 1)]);
            faces.push([idx(r, c), idx(r + 1, c + 1), idx(r, c + 1)]);
        }
    }
    TriMesh::new(positions, faces)
}

fn sphere(r: f32) -> TriMesh {
    use avatar_core::mesh::extract::{ExtractOptions, extract};
    let o = ExtractOptions::new(Vec3::splat(-1.3 * r), Vec3::splat(1.3 * r), 32);
    extract(|p: &[Vec3]| p.iter().map(|x| x.length() - r).collect(), &o).unwrap().mesh
}

#[test]
fn a_sheet_hung_by_two_corners_keeps_its_edge_lengths_and_falls() {
    let n = 15;
    let rest = sheet(n, 0.6, 1.0);
    let corners = [0u32, (n - 1) as u32];
    let pins: Vec<Vec3> = corners.iter().map(|&c| rest.positions[c as usize]).collect();
    let mut cloth = Cloth::new(&rest, &corners, ClothConfig::default());
    for _ in 0..60 {
        cloth.step_frame(1.0 / 30.0, &pins, None);
    }
    // Inextensible within a fraction of a percent on average, a few percent at worst (the
    // corners carry the whole sheet).
    assert!(cloth.mean_strain() < 0.01, "mean strain {}", cloth.mean_strain());
    assert!(cloth.max_strain() < 0.06, "max strain {}", cloth.max_strain());
    // The free edge has fallen most of the sheet's length below the pins, and the pins held.
    let lowest = cloth.positions.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    assert!(lowest < 1.0 - 0.45, "lowest point at {lowest} m");
    for (k, &c) in corners.iter().enumerate() {
        assert!(cloth.positions[c as usize].distance(pins[k]) < 1e-6);
    }
    // Every particle's finite and the sheet is still one whole piece.
    assert!(cloth.positions.iter().all(|p| p.is_finite()));
    let i = integrity(&TriMesh::new(cloth.positions.clone(), rest.faces.clone()));
    assert_eq!((i.pieces, i.non_manifold_edges), (1, 0));
}

#[test]
fn a_sheet_dropped_on_a_ball_drapes_over_it_and_stays_outside() {
    let r = 0.25;
    let ball = BodyCollider::new(&sphere(r));
    let rest = sheet(21, 0.9, r + 0.05);
    let config = ClothConfig { thickness: 0.01, ..ClothConfig::default() };
    let mut cloth = Cloth::new(&rest, &[], config);
    for _ in 0..45 {
        cloth.step_frame(1.0 / 30.0, &[], Some(&ball));
    }
    // Outside the (tessellated) ball, up to a millimetre.
    let inside = cloth.positions.iter().map(|p| p.length()).fold(f32::MAX, f32::min);
    assert!(inside > r + config.thickness - 0.004, "closest particle {inside} m from the centre");
    // Draped: the middle rests on top, the corners have fallen well below the top.
    let middle = cloth.positions[21 * 10 + 10];
    assert!((middle.y - (r + config.thickness)).abs() < 0.01, "middle at {middle}");
    let corner = cloth.positions[0];
    assert!(corner.y < 0.0, "corner still at {corner}");
    assert!(cloth.mean_strain() < 0.02, "mean strain {}", cloth.mean_strain());
}

/// The share of `points` inside the posed naked body, and the deepest one (metres).
fn inside_body(collider: &BodyCollider, points: &[Vec3]) -> (f32, f32) {
    let depths: Vec<f32> = points
        .iter()
        .filter_map(|&p| collider.signed_distance(p, 0.1).map(|(d, _)| d))
        .filter(|&d| d < 0.0)
        .collect();
    (depths.len() as f32 / points.len() as f32, depths.iter().fold(0.0f32, |a, &d| a.min(d)))
}

#[test]
fn a_simulated_skirt_and_cape_follow_a_kick_outside_the_body_and_swing_after_it() {
    let body = open_body_ref();
    let betas = subject_betas(body, 1001);
    let clip = library_clip("kick").unwrap();
    let poses: Vec<BodyParams> = clip
        .frames
        .iter()
        .map(|p| {
            let mut q = p.clone();
            q.betas = betas.clone();
            q.trans.x = 0.0;
            q.trans.z = 0.0;
            q
        })
        .collect();
    for outfit in [Outfit::SimSkirt, Outfit::SimCape] {
        let t = ClothedTemplate::build(body, &betas, outfit);
        let n = t.body_vertices;
        let rest = garment_mesh(&t, t.vertices[n..].to_vec());
        assert!(!pinned_vertices(&t).is_empty());
        let track = simulate_garment(body, &t, &poses, clip.fps, 1001, ClothConfig::default());
        assert_eq!(track.frames.len(), poses.len());
        let mut rigid_gap = 0.0f32;
        for (k, garment) in track.frames.iter().enumerate() {
            let mesh = garment_mesh(&t, garment.clone());
            // Whole and unstretched at every frame.
            let i = integrity(&mesh);
            assert_eq!((i.pieces, i.non_manifold_edges), (1, 0), "{outfit:?} frame {k}");
            let strain: f32 = rest
                .faces
                .iter()
                .flat_map(|f| [(f[0], f[1]), (f[1], f[2])])
                .map(|(a, b)| {
                    let l0 = rest.positions[a as usize].distance(rest.positions[b as usize]);
                    (mesh.positions[a as usize].distance(mesh.positions[b as usize]) - l0).abs()
                        / l0
                })
                .sum::<f32>()
                / (2 * rest.faces.len()) as f32;
            assert!(strain < 0.03, "{outfit:?} frame {k}: mean strain {strain}");
            // Outside the naked body (the clothing under it is thicker still).
            let posed = body.pose(&poses[k]);
            let collider = BodyCollider::new(&body.mesh(posed.vertices.clone()));
            let (share, deepest) = inside_body(&collider, garment);

            assert!(share < 0.01 && deepest > -0.02, "{outfit:?} frame {k}: {share} in, {deepest}");
            // How far the cloth is from where rigid skinning of its rest shape would put it.
            let rigid: Vec<Vec3> = (n..t.vertices.len())
                .map(|v| {
                    avatar_core::body::skin_point(
                        &posed.bones.transforms,
                        &t.weights[v],
                        t.vertices[v],
                    )
                })
                .collect();
            let gap = rigid.iter().zip(garment).map(|(a, b)| a.distance(*b)).sum::<f32>()
                / rigid.len() as f32;
            rigid_gap = rigid_gap.max(gap);
        }
        // Cloth, not a rigid panel: somewhere in the kick it is centimetres from where the
        // skinned rest shape would be.
        assert!(rigid_gap > 0.03, "{outfit:?}: at most {rigid_gap} m from rigid skinning");
    }
}
