//! Diagnostic: how far a synthetic capture's canonical points lie from the true canonical
//! clothing when they are canonicalized with the body's diffused field, and with a field
//! diffused from the true clothed rest surface carrying its garment weights (FITE's template
//! field, the weights inpainted along loose cloth). An upper bound for cloth-aware
//! canonicalization: the template is the truth here.
//! `cargo run --release --example garment_field_spread -- CAPTURE_DIR FRAMES SUBJECT OUTFIT`
use avatar_core::canonical::{
    FieldCache, FieldOptions, GarmentSkinning, RootOptions, RootPick, SkinningField,
    canonicalize_points_from, garment_weights,
};
use avatar_core::mesh::bvh::Bvh;
use avatar_neural::data::capture_points::CapturePoints;
use glam::Vec3;
use std::path::PathBuf;

fn main() -> avatar_core::error::Result<()> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: garment_field_spread CAPTURE_DIR FRAMES SUBJECT OUTFIT";
    let dir = PathBuf::from(args.next().expect(usage));
    let frames = args.next().and_then(|f| f.parse().ok()).expect(usage);
    let subject: u64 = args.next().and_then(|s| s.parse().ok()).expect(usage);
    let outfit = args.next().expect(usage);
    let cache = FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"));
    let capture = CapturePoints::open(&dir, frames, &cache)?;
    use avatar_core::synth::{ClothedTemplate, Outfit, PoseFeatures, canonical_surface};
    let template =
        ClothedTemplate::build(&capture.body, &capture.betas, Outfit::from_name(&outfit)?);
    let zero = avatar_core::body::BodyParams { betas: capture.betas.clone(), ..Default::default() };
    let truth = avatar_core::mesh::TriMesh::new(
        canonical_surface(&template, &PoseFeatures::of(&capture.body.pose(&zero).bones), subject),
        template.faces.clone(),
    );
    let options: GarmentSkinning = GarmentSkinning::default();
    let weights = garment_weights(&capture.field, &capture.rest_sdf, &truth, &options);
    let t = std::time::Instant::now();
    let garment_field = SkinningField::build_around(&truth, &weights, &FieldOptions::default())?;
    println!("template field built in {:.2} s", t.elapsed().as_secs_f32());
    let bvh = Bvh::build(&truth);
    let norm = capture.normalisation;
    println!("field     frame  points  p50(cm)  p90  >2cm  >5cm  >10cm");
    for (name, field) in [("body", &capture.field), ("template", &garment_field)] {
        let mut all = Vec::new();
        for (i, f) in capture.frames.iter().enumerate() {
            let posed = capture.body.pose(&f.params);
            // The frame's depth points: its canonical points skinned forward again (roots
            // converge to 1e-5 m, so this is the measured point).
            let posed_points: Vec<Vec3> = f
                .points
                .iter()
                .map(|&p| {
                    let x = norm.from_unit(p);
                    avatar_core::body::blend_transform(
                        &posed.bones.transforms,
                        &capture.field.weights_at(x),
                    )
                    .transform_point3(x)
                })
                .collect();
            let distance = |x: Vec3, cap: f32| {
                capture.rest_sdf.distance_within(x, cap).unwrap_or(f32::INFINITY)
            };
            let c = canonicalize_points_from(
                field,
                &posed.bones,
                &posed.vertices,
                &capture.body.weights,
                &posed_points,
                &f.normals,
                &[],
                &RootOptions::default(),
                RootPick::Nearest(&distance),
            );
            let d: Vec<f32> = c
                .points
                .iter()
                .map(|&x| bvh.closest_point(x).map_or(f32::NAN, |h| h.distance * 100.0))
                .collect();
            report(name, &format!("{i}"), &d, posed_points.len());
            all.extend(d);
        }
        report(name, "all", &all, all.len());
    }
    Ok(())
}

fn report(name: &str, frame: &str, d: &[f32], input: usize) {
    let mut d = d.to_vec();
    d.sort_by(f32::total_cmp);
    let q = |x: f32| d[((d.len() - 1) as f32 * x) as usize];
    let share = |t: f32| d.iter().filter(|&&v| v > t).count() as f32 / d.len() as f32 * 100.0;
    println!(
        "{name:9} {frame:5}  {:6}/{input}  {:7.2}  {:4.1}  {:4.1}%  {:4.1}%  {:4.1}%",
        d.len(),
        q(0.5),
        q(0.9),
        share(2.0),
        share(5.0),
        share(10.0)
    );
}
