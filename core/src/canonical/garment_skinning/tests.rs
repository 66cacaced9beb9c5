use super::*;
use crate::body::open_body_lowpoly;
use crate::canonical::FieldOptions;
use glam::Vec3;

/// A skirt as a flared tube from the waist to below the knees, in rings of `segments`
/// vertices, around the rest body's legs.
fn skirt(rest: &[Vec3], waist_y: f32, length: f32, segments: usize) -> TriMesh {
    let waist: Vec<Vec3> = rest.iter().copied().filter(|p| (p.y - waist_y).abs() < 0.02).collect();
    let centre = waist.iter().sum::<Vec3>() / waist.len() as f32;
    let (rx, rz) = waist.iter().fold((0f32, 0f32), |(x, z), p| {
        (x.max((p.x - centre.x).abs()), z.max((p.z - centre.z).abs()))
    });
    let rings = 12;
    let mut positions = Vec::new();
    for r in 0..=rings {
        let t = r as f32 / rings as f32;
        // Tight at the waist (5 mm out), 20 cm of flare at the hem.
        let (ex, ez) = (rx + 0.005 + 0.2 * t, rz + 0.005 + 0.2 * t);
        for s in 0..segments {
            let a = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push(Vec3::new(
                centre.x + ex * a.sin(),
                waist_y - t * length,
                centre.z + ez * a.cos(),
            ));
        }
    }
    let idx = |r: usize, s: usize| (r * segments + s % segments) as u32;
    // Diagonals alternating like a checkerboard: the same one everywhere would make the
    // neighbour average drift around the tube.
    let quad = move |r: usize, s: usize| {
        let (a, b, c, d) = (idx(r, s), idx(r + 1, s), idx(r + 1, s + 1), idx(r, s + 1));
        if (r + s).is_multiple_of(2) { [[a, b, c], [a, c, d]] } else { [[a, b, d], [b, c, d]] }
    };
    let faces = (0..rings).flat_map(|r| (0..segments).flat_map(move |s| quad(r, s))).collect();
    TriMesh::new(positions, faces)
}

#[test]
fn a_skirts_weights_are_inpainted_along_it_and_tight_cloth_keeps_the_fields() {
    let body = open_body_lowpoly();
    let rest = body.shaped_vertices(&[]);
    let field = SkinningField::build(
        &body,
        &rest,
        &FieldOptions { cells_along_height: 48, ..FieldOptions::default() },
    )
    .unwrap();
    let joints = body.regress_joints(&rest);
    // The inpainting alone (the shins' release has its own test below).
    let mut skinner = GarmentSkinner::new(&body, &[]);
    skinner.options.free_of_shins = false;
    let mesh = skirt(&rest, joints[0].y + 0.05, 0.6, 48);
    let field_weights: Vec<Weights> = mesh.positions.iter().map(|&x| field.weights_at(x)).collect();
    let weights = skinner.weights(&field, &mesh);
    // Weights stay a partition of unity.
    for w in &weights {
        assert!(
            (w.iter().sum::<f32>() - 1.0).abs() < 1e-4 && w.iter().all(|&v| v >= -1e-6),
            "{w:?}"
        );
    }
    // Where the waist ring lies on the body (nearer than the inpainting starts): the field's
    // weights, untouched.
    let distance = SignedDistance::new(&body.mesh(rest.clone()));
    let on_body: Vec<usize> = (0..48)
        .filter(|&v| distance.at(mesh.positions[v]).unwrap() <= skinner.options.loose.0)
        .collect();
    assert!(on_body.len() >= 24, "{} waist vertices on the body", on_body.len());
    for v in on_body {
        assert_eq!(weights[v], field_weights[v], "waist vertex {v}");
    }
    // Along the hem (the last ring) the field's share of the left leg changes by up to a
    // ninth between neighbours; the inpainted weights change by at most 60 % of that.
    let legs = |w: &Weights| (w[1] + w[4] + w[7] + w[10], w[2] + w[5] + w[8] + w[11]);
    let hem = mesh.positions.len() - 48..mesh.positions.len();
    let largest_jump = |ws: &[Weights]| {
        hem.clone()
            .map(|v| {
                let n = if v + 1 == mesh.positions.len() { hem.start } else { v + 1 };
                (legs(&ws[v]).0 - legs(&ws[n]).0).abs()
            })
            .fold(0f32, f32::max)
    };
    let (before, after) = (largest_jump(&field_weights), largest_jump(&weights));
    assert!(before > 0.08, "the field switches legs along the hem: largest step {before}");
    assert!(after < 0.6 * before, "largest step along the hem {before} -> {after}");
    // Far from the body (the hem, 20 cm and more out) each vertex's weights are its
    // neighbours' average: the solve reached the fixed point.
    let n = vertex_neighbours(&mesh);
    for v in hem.clone() {
        let nb = &n.indices[n.offsets[v]..n.offsets[v + 1]];
        for j in 0..NUM_JOINTS {
            let mean = nb.iter().map(|&u| weights[u as usize][j]).sum::<f32>() / nb.len() as f32;
            assert!(
                (weights[v][j] - mean).abs() < 2e-3,
                "hem vertex {v}, joint {j}: {} against its neighbours' {mean}",
                weights[v][j]
            );
        }
    }
    // At the front and the back of the hem, between the legs, both legs pull alike.
    for v in [hem.start, hem.start + 24] {
        let (l, r) = legs(&weights[v]);
        assert!((l - r).abs() < 0.15, "vertex {v}: left {l}, right {r}");
    }
    // Tight clothing (the body 5 mm out) keeps the field's weights exactly.
    let normals = body.mesh(rest.clone()).vertex_normals();
    let tight = TriMesh::new(
        rest.iter().zip(&normals).map(|(p, n)| *p + *n * 0.005).collect(),
        body.faces.clone(),
    );
    let own: Vec<Weights> = tight.positions.iter().map(|&x| field.weights_at(x)).collect();
    assert_eq!(skinner.weights(&field, &tight), own);
}

/// A tube of `rings` x `segments` around the vertical axis through `centre`, of radius
/// `radius`, from `top` down to `bottom` (metres).
fn tube(
    centre: Vec3,
    radius: f32,
    top: f32,
    bottom: f32,
    rings: usize,
    segments: usize,
) -> TriMesh {
    let positions = (0..=rings)
        .flat_map(|r| {
            let y = top + (bottom - top) * r as f32 / rings as f32;
            (0..segments).map(move |s| {
                let a = std::f32::consts::TAU * s as f32 / segments as f32;
                Vec3::new(centre.x + radius * a.sin(), y, centre.z + radius * a.cos())
            })
        })
        .collect();
    let idx = |r: usize, s: usize| (r * segments + s % segments) as u32;
    let faces = (0..rings)
        .flat_map(|r| {
            (0..segments).flat_map(move |s| {
                [
                    [idx(r, s), idx(r + 1, s), idx(r + 1, s + 1)],
                    [idx(r, s), idx(r + 1, s + 1), idx(r, s + 1)],
                ]
            })
        })
        .collect();
    TriMesh::new(positions, faces)
}

#[test]
fn a_skirt_between_the_legs_follows_no_shin_but_a_wide_trouser_leg_does() {
    assert_eq!(
        (
            crate::body::JOINT_NAMES[PELVIS],
            crate::body::JOINT_NAMES[LEFT_LEG[1]],
            crate::body::JOINT_NAMES[RIGHT_LEG[3]]
        ),
        ("pelvis", "left_knee", "right_foot")
    );
    let body = open_body_lowpoly();
    let rest = body.shaped_vertices(&[]);
    let field = SkinningField::build(
        &body,
        &rest,
        &FieldOptions { cells_along_height: 48, ..FieldOptions::default() },
    )
    .unwrap();
    let joints = body.regress_joints(&rest);
    let released = GarmentSkinner::new(&body, &[]);
    let mut inpainted = GarmentSkinner::new(&body, &[]);
    inpainted.options.free_of_shins = false;
    let shins =
        |w: &Weights| LEFT_LEG[1..].iter().chain(&RIGHT_LEG[1..]).map(|&j| w[j]).sum::<f32>();
    let thighs = |w: &Weights| w[LEFT_LEG[0]] + w[RIGHT_LEG[0]];

    // A skirt down past the knees: at the front and the back of its hem the inpainting
    // gives the shins a good part of the weight; released, they keep almost none, the
    // thighs keep theirs and the pelvis takes the rest.
    let mesh = skirt(&rest, joints[0].y + 0.05, 0.6, 48);
    let (before, after) = (inpainted.weights(&field, &mesh), released.weights(&field, &mesh));
    let hem = mesh.positions.len() - 48;
    for v in [hem, hem + 24] {
        assert!(
            shins(&before[v]) > 0.05,
            "hem vertex {v}: shins {} before the release",
            shins(&before[v])
        );
        assert!(
            shins(&after[v]) < 0.15 * shins(&before[v]),
            "hem vertex {v}: shins {} -> {}",
            shins(&before[v]),
            shins(&after[v])
        );
        assert!((thighs(&after[v]) - thighs(&before[v])).abs() < 1e-6);
        assert!(
            (after[v][PELVIS] - before[v][PELVIS] - (shins(&before[v]) - shins(&after[v]))).abs()
                < 1e-5
        );
    }
    for w in &after {
        assert!(
            (w.iter().sum::<f32>() - 1.0).abs() < 1e-4 && w.iter().all(|&x| x >= -1e-6),
            "{w:?}"
        );
    }
    // Where the skirt lies on the body (nearer than the inpainting starts) nothing changes.
    let distance = SignedDistance::new(&body.mesh(rest.clone()));
    let on_body: Vec<usize> = (0..mesh.positions.len())
        .filter(|&v| distance.at(mesh.positions[v]).unwrap() <= GarmentSkinning::default().loose.0)
        .collect();
    assert!(on_body.len() >= 24);
    for v in on_body {
        assert_eq!(after[v], before[v], "vertex {v} on the body");
    }

    // A wide trouser leg round the left shin, 4 cm and more off it: one leg's weights, so
    // it keeps following its knee.
    let knee = joints[LEFT_LEG[1]];
    let leg = tube(knee, 0.09, knee.y + 0.1, joints[LEFT_LEG[2]].y + 0.05, 10, 24);
    let (before, after) = (inpainted.weights(&field, &leg), released.weights(&field, &leg));
    let loose: Vec<usize> = (0..leg.positions.len()).filter(|&v| shins(&before[v]) > 0.3).collect();
    assert!(
        loose.len() > leg.positions.len() / 2,
        "{} of {} trouser vertices on the shin",
        loose.len(),
        leg.positions.len()
    );
    for v in loose {
        assert!(
            shins(&after[v]) > 0.9 * shins(&before[v]),
            "trouser vertex {v}: shins {} -> {}",
            shins(&before[v]),
            shins(&after[v])
        );
    }
}
