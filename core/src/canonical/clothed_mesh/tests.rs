use super::*;
use crate::body::{forward_kinematics, open_body_lowpoly};
use crate::canonical::garment_skinning::tests::skirt;
use crate::canonical::{
    Canonicalizer, FieldOptions, GarmentSkinner, SkinningField, forward_skin_with_weights,
};

/// Mid-stride: the left thigh forward, the right back, the left knee bent. (Much farther, a
/// thigh posed by its own bones passes through a skirt posed by the hips', which no scanned
/// cloth does: the cloth it pierces is unposed with the thigh.)
fn stride() -> BodyParams {
    let mut params = BodyParams::default();
    params.pose[1] = Vec3::new(-0.3, 0.0, 0.0);
    params.pose[2] = Vec3::new(0.25, 0.0, 0.0);
    params.pose[4] = Vec3::new(0.4, 0.0, 0.0);
    params
}

#[test]
fn the_posed_body_unposes_to_its_rest_vertices() {
    let body = open_body_lowpoly();
    let mut params = stride();
    params.pose[18] = Vec3::new(0.0, 0.0, -0.8);
    params.trans = Vec3::new(0.3, -0.1, 2.0);
    let posed = body.pose(&params);
    let unposed = unpose_clothed_mesh(
        &body,
        &params,
        &body.mesh(posed.vertices.clone()),
        &GarmentSkinning::default(),
    );
    // The crotch's fold may turn a face or two over.
    assert!(unposed.faces.len() * 100 >= body.faces.len() * 99, "faces turned over");
    let worst = unposed
        .positions
        .iter()
        .zip(&posed.rest_vertices)
        .map(|(a, b)| a.distance(*b))
        .fold(0f32, f32::max);
    assert!(worst < 1e-4, "a body vertex unposed {worst} m from its rest position");
}

/// A skirt posed mid-stride by the avatar's own skinning of loose cloth comes back to the
/// canonical pose as the skirt it was, where root finding in the body's field carries its
/// points between the legs with one thigh or the other.
#[test]
fn a_skirt_scanned_mid_stride_unposes_whole() {
    let body = open_body_lowpoly();
    let rest = body.shaped_vertices(&[]);
    let joints = body.regress_joints(&rest);
    let canonical = skirt(&rest, joints[0].y + 0.05, 0.6, 48);
    let field = SkinningField::build(
        &body,
        &rest,
        &FieldOptions { cells_along_height: 48, ..FieldOptions::default() },
    )
    .unwrap();
    let params = stride();
    let bones = forward_kinematics(&joints, &params.rotations(), params.trans);
    let weights = GarmentSkinner::new(&body, &[]).weights(&field, &canonical);
    let posed = forward_skin_with_weights(&bones, &canonical, &weights);

    let unposed = unpose_clothed_mesh(&body, &params, &posed, &GarmentSkinning::default());
    assert_eq!(unposed.positions.len(), canonical.positions.len(), "no vertex lost");
    let errors: Vec<f32> =
        unposed.positions.iter().zip(&canonical.positions).map(|(a, b)| a.distance(*b)).collect();
    let mean = errors.iter().sum::<f32>() / errors.len() as f32;
    let worst = errors.iter().copied().fold(0f32, f32::max);
    // Each edge keeps its length within 30 %: the sheet is not torn apart.
    let stretch = canonical
        .faces
        .iter()
        .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
        .map(|(a, b)| {
            let (a, b) = (a as usize, b as usize);
            let before = canonical.positions[a].distance(canonical.positions[b]);
            unposed.positions[a].distance(unposed.positions[b]) / before
        })
        .fold(1f32, |m, r| m.max(r).max(1.0 / r));
    assert!(
        mean < 0.01 && worst < 0.05 && stretch < 1.3,
        "unposed skirt: mean error {mean} m, worst {worst} m, edge stretch {stretch}"
    );
    assert!(unposed.faces.len() * 100 >= canonical.faces.len() * 98, "faces turned over");

    // Root finding point by point, for comparison: its hem lands far from the skirt's.
    let canonicalizer = Canonicalizer::new(
        &body,
        &[],
        &FieldOptions { cells_along_height: 48, ..FieldOptions::default() },
        None,
    )
    .unwrap();
    let normals = vec![Vec3::Z; posed.positions.len()];
    let rooted = canonicalizer.posed_points(&params, &posed.positions, &normals);
    let rooted_mean = rooted
        .points
        .iter()
        .zip(&rooted.source)
        .map(|(p, &i)| p.distance(canonical.positions[i]))
        .sum::<f32>()
        / rooted.points.len().max(1) as f32;
    assert!(
        rooted_mean > 3.0 * mean,
        "root finding's mean error {rooted_mean} m against the mesh's own weights' {mean} m"
    );
}
