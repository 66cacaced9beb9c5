//! How far a capture's canonical points lie from the canonical body: a diagnosis of fitting
//! errors (points canonicalized with a wrong pose land off the body, and a fit grows sheets
//! there). `cargo run --example canonical_spread -- CAPTURE_DIR [FRAMES [SUBJECT OUTFIT]]`: with
//! a synthetic capture's subject and outfit, the distances are also measured to the true
//! clothed surface at the zero pose (the canonical clothing, panels hanging).
use avatar_core::canonical::FieldCache;
use avatar_core::mesh::bvh::Bvh;
use avatar_neural::data::capture_points::CapturePoints;
use std::path::PathBuf;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() -> avatar_core::error::Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().expect("usage: canonical_spread CAPTURE_DIR [FRAMES]"));
    let frames = args.next().and_then(|f| f.parse().ok()).unwrap_or(8);
    let capture = CapturePoints::open(&dir, frames, &field_cache())?;
    let mut surfaces = vec![("the canonical body", capture.body.mesh(capture.rest.clone()))];
    if let (Some(subject), Some(outfit)) =
        (args.next().and_then(|s| s.parse::<u64>().ok()), args.next())
    {
        use avatar_core::synth::{ClothedTemplate, Outfit, PoseFeatures, canonical_surface};
        let template =
            ClothedTemplate::build(&capture.body, &capture.betas, Outfit::from_name(&outfit)?);
        let zero =
            avatar_core::body::BodyParams { betas: capture.betas.clone(), ..Default::default() };
        let canonical = canonical_surface(
            &template,
            &PoseFeatures::of(&capture.body.pose(&zero).bones),
            subject,
        );
        surfaces.push((
            "the true clothing at the zero pose",
            avatar_core::mesh::TriMesh::new(canonical, template.faces.clone()),
        ));
    }
    // MESH=FILE.obj: also the distance to a fitted mesh at the zero pose (how closely the fit
    // follows the points; `avatar-studio pose AVATAR --motion ZERO.json` writes one).
    if let Ok(mesh) = std::env::var("MESH") {
        surfaces.push(("the mesh in MESH", avatar_core::mesh::io::read_obj(&mesh)?));
    }
    for (name, mesh) in surfaces {
        let bvh = Bvh::build(&mesh);
        println!("distance to {name}\nframe  points  free  p50(cm)  p90  p99  >2cm  >5cm  >10cm");
        for (i, f) in capture.frames.iter().enumerate() {
            let mut d: Vec<f32> = f
                .points
                .iter()
                .map(|p| {
                    bvh.closest_point(capture.normalisation.from_unit(*p))
                        .map_or(f32::NAN, |h| h.distance * 100.0)
                })
                .collect();
            d.sort_by(f32::total_cmp);
            let q = |x: f32| d[((d.len() - 1) as f32 * x) as usize];
            let share =
                |t: f32| d.iter().filter(|&&v| v > t).count() as f32 / d.len() as f32 * 100.0;
            println!(
                "{i:5}  {:6}  {:4}  {:7.2}  {:4.1}  {:4.1}  {:4.1}%  {:4.1}%  {:4.1}%",
                d.len(),
                f.free_space.len(),
                q(0.5),
                q(0.9),
                q(0.99),
                share(2.0),
                share(5.0),
                share(10.0)
            );
        }
    }
    Ok(())
}
