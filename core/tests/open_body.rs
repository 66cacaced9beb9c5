//! The embedded open body: T-pose layout, proportions, symmetry, weights, shape directions.

use avatar_core::body::skeleton::LEFT_RIGHT_PAIRS;
use avatar_core::body::{BodyModel, BodyParams, NUM_JOINTS, open_body_lowpoly_ref, open_body_ref};
use glam::Vec3;

fn height(v: &[Vec3]) -> f32 {
    let (lo, hi) = avatar_core::mesh::bounds(v).unwrap();
    hi.y - lo.y
}

fn check_layout(model: &BodyModel) {
    let rest = model.rest_joints(&[]);
    let verts = model.shaped_vertices(&[]);
    let h = height(&verts);
    assert!((1.6..=1.8).contains(&h), "height {h} m");
    // Left/right symmetry of the joints (x mirrored) within 1 mm.
    for (l, r) in LEFT_RIGHT_PAIRS {
        let mirrored = rest[r] * Vec3::new(-1.0, 1.0, 1.0);
        assert!(
            (rest[l] - mirrored).length() < 1e-3,
            "joints {l}/{r} asymmetric by {}",
            (rest[l] - mirrored).length()
        );
        assert!(rest[l].x > 0.0, "left joint {l} must be on +x");
    }
    // Spine joints on the mid-plane.
    for j in [0, 3, 6, 9, 12, 15] {
        assert!(rest[j].x.abs() < 1e-3, "joint {j} off the mid-plane");
    }
    // T-pose: shoulder -> elbow -> wrist horizontal (within 5 degrees), arm span 1.3-1.8 m.
    for (s, w) in [(16, 20), (17, 21)] {
        let d = (rest[w] - rest[s]).normalize();
        assert!(d.y.abs() < 5f32.to_radians().sin(), "arm not horizontal: {d}");
    }
    let span = (rest[22] - rest[23]).length();
    assert!((1.3..1.8).contains(&span), "hand-to-hand span {span}");
    // Head above neck above pelvis above knees above ankles.
    assert!(
        rest[15].y > rest[12].y
            && rest[12].y > rest[0].y
            && rest[0].y > rest[4].y
            && rest[4].y > rest[7].y
    );
    // Weights: rows sum to 1, every joint drives some vertex.
    let mut used = [false; NUM_JOINTS];
    for w in &model.weights {
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        for j in 0..NUM_JOINTS {
            used[j] |= w[j] > 0.1;
        }
    }
    assert!(used.iter().all(|&u| u), "a joint drives no vertex: {used:?}");
    // Outward-facing closed-ish surface.
    assert!(model.mesh(verts).signed_volume() > 0.03);
}

#[test]
fn open_body_t_pose_layout() {
    let model = open_body_ref();
    assert!(model.num_vertices() > 10_000);
    assert!(model.posedirs.is_none());
    check_layout(model);
}

#[test]
fn lowpoly_body_matches_full_body() {
    let low = open_body_lowpoly_ref();
    let full = open_body_ref();
    assert!((1000..=2000).contains(&low.num_vertices()), "{}", low.num_vertices());
    check_layout(low);
    let (a, b) = (low.rest_joints(&[]), full.rest_joints(&[]));
    for j in 0..NUM_JOINTS {
        assert!((a[j] - b[j]).length() < 0.01, "joint {j} differs by {}", (a[j] - b[j]).length());
    }
}

#[test]
fn shape_directions_change_height_as_named() {
    let model = open_body_ref();
    assert_eq!(model.shape_names.len(), model.num_betas);
    assert_eq!(model.shape_limits.len(), model.num_betas);
    let base = height(&model.shaped_vertices(&[]));
    let at = |name: &str, value: f32| {
        let k = model.shape_names.iter().position(|n| n == name).unwrap();
        let mut betas = vec![0.0; model.num_betas];
        betas[k] = value;
        height(&model.shaped_vertices(&model.clamp_betas(&betas)))
    };
    assert!(at("taller", 1.0) > base + 0.05);
    assert!(at("shorter", 1.0) < base - 0.05);
    let (tall, short) = (at("taller", 10.0), at("shorter", 10.0));
    assert!(tall < 2.0 && short > 1.45, "limits keep height sane: {short}..{tall}");
    // Joints follow the shape.
    let k = model.shape_names.iter().position(|n| n == "taller").unwrap();
    let mut betas = vec![0.0; model.num_betas];
    betas[k] = model.shape_limits[k].1;
    assert!(model.rest_joints(&betas)[15].y > model.rest_joints(&[])[15].y + 0.03);
}

#[test]
fn posed_open_body_round_trips_through_inverse_lbs() {
    let model = open_body_ref();
    let mut params = BodyParams::default();
    params.pose[16] = Vec3::new(0.0, 0.0, -1.2);
    params.pose[18] = Vec3::new(0.0, -1.4, 0.0);
    params.pose[1] = Vec3::new(-0.8, 0.0, 0.1);
    params.pose[4] = Vec3::new(1.2, 0.0, 0.0);
    params.trans = Vec3::new(0.1, 0.0, 2.0);
    let posed = model.pose(&params);
    let mut worst = 0f32;
    for ((rest, p), w) in posed.rest_vertices.iter().zip(&posed.vertices).zip(&model.weights) {
        let back = avatar_core::body::unskin_point(&posed.bones.transforms, w, *p);
        worst = worst.max((back - *rest).length());
    }
    assert!(worst < 1e-5, "round trip {worst}");
}
