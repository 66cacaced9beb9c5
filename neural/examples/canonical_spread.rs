//! How far a capture's canonical points lie from the canonical body: a diagnosis of fitting
//! errors (points canonicalized with a wrong pose land off the body, and a fit grows sheets
//! there). `cargo run --example canonical_spread -- CAPTURE_DIR [FRAMES]`
use avatar_core::mesh::bvh::Bvh;
use avatar_neural::capture_points::CapturePoints;
use std::path::PathBuf;

fn main() -> avatar_core::error::Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().expect("usage: canonical_spread CAPTURE_DIR [FRAMES]"));
    let frames = args.next().and_then(|f| f.parse().ok()).unwrap_or(8);
    let capture = CapturePoints::open(&dir, frames)?;
    let mesh = capture.body.mesh(capture.rest.clone());
    let bvh = Bvh::build(&mesh);
    println!("frame  points  free  p50(cm)  p90  p99  >5cm  >10cm");
    for (i, f) in capture.frames.iter().enumerate() {
        let mut d: Vec<f32> = f.points.iter().map(|p| bvh.closest_point(capture.normalisation.from_unit(*p)).map_or(f32::NAN, |h| h.distance * 100.0)).collect();
        d.sort_by(f32::total_cmp);
        let q = |x: f32| d[((d.len() - 1) as f32 * x) as usize];
        let share = |t: f32| d.iter().filter(|&&v| v > t).count() as f32 / d.len() as f32 * 100.0;
        println!("{i:5}  {:6}  {:4}  {:7.2}  {:4.1}  {:4.1}  {:4.1}%  {:4.1}%", d.len(), f.free_space.len(), q(0.5), q(0.9), q(0.99), share(5.0), share(10.0));
    }
    Ok(())
}
