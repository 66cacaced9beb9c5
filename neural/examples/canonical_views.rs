//! The true clothing at the zero pose beside avatar meshes posed at the zero pose (OBJ files,
//! e.g. `avatar-studio pose AVATAR --motion zero.json`), seen from the front, the side, the
//! back and from below: where a fitted surface grows what the truth does not have.
//!   cargo run --example canonical_views -- OUT.png SUBJECT OUTFIT BETAS_CAPTURE MESH.obj...
use avatar_core::capture::Capture;
use avatar_core::mesh::io::read_obj;
use avatar_core::synth::contact_sheet::write_view_sheet;
use avatar_core::synth::{ClothedTemplate, Outfit};
use glam::Vec3;

fn main() -> avatar_core::error::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let (out, subject, outfit, capture) =
        (&args[1], args[2].parse::<u64>().unwrap(), &args[3], Capture::open(&args[4])?);
    let betas = capture.frames[0].params.betas.clone();
    let template = ClothedTemplate::build(&capture.body, &betas, Outfit::from_name(outfit)?);
    // POSE=sheet: the truth at the contact sheets' pose (the kick at 45 %) instead.
    let pose = match std::env::var("POSE").as_deref() {
        Ok("sheet") => avatar_core::body::BodyParams {
            betas: betas.clone(),
            ..avatar_core::eval::dataset::sheet_pose()?
        },
        _ => avatar_core::body::BodyParams { betas: betas.clone(), ..Default::default() },
    };
    let truth =
        avatar_core::eval::runner::ground_truth_mesh(&capture.body, &template, &pose, subject);
    let truth_bvh = avatar_core::mesh::bvh::Bvh::build(&truth);
    let mut meshes = vec![truth];
    for p in &args[5..] {
        let mesh = read_obj(p)?;
        // The share of the mesh's area farther than 2 cm from the truth, and those faces alone.
        let (mut far_area, mut area, mut far, mut outward) = (0.0, 0.0, Vec::new(), 0.0);
        for f in &mesh.faces {
            let [a, b, c] = f.map(|i| mesh.positions[i as usize]);
            let s = (b - a).cross(c - a).length() / 2.0;
            area += s;
            if truth_bvh.closest_point((a + b + c) / 3.0).is_some_and(|h| h.distance > 0.02) {
                far_area += s;
                far.push(*f);
                // Facing away from the body's vertical axis (an outer surface) or toward it.
                let centre = (a + b + c) / 3.0;
                let radial = Vec3::new(centre.x, 0.0, centre.z - 0.0).normalize_or_zero();
                if (b - a).cross(c - a).dot(radial) > 0.0 {
                    outward += s;
                }
            }
        }
        println!(
            "{p}: {:.1} % of the area farther than 2 cm from the truth ({:.0} % of it facing outward)",
            far_area / area * 100.0,
            outward / far_area * 100.0
        );
        meshes.push(mesh.clone());
        meshes.push(avatar_core::mesh::TriMesh::new(mesh.positions.clone(), far));
    }
    write_view_sheet(
        out.as_ref(),
        &meshes,
        &[Vec3::Z, Vec3::X, Vec3::NEG_Z, Vec3::new(0.0, -1.0, 0.35)],
    )
}
