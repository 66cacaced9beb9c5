//! The canonical bench section: the skinning field's build time, and canonicalizing 8 frames x
//! 5,000 points.

use avatar_core::canonical::{Canonicalizer, FieldOptions};
use avatar_core::capture::Capture;
use avatar_core::motion::clip_by_name;
use avatar_core::synth::{Outfit, SynthJob, generate_capture};
use std::time::Instant;

pub fn bench_report() -> String {
    let body = avatar_core::body::open_body_ref();
    let mut out = String::from("## canonical\n\n| what | time | note |\n|---|---|---|\n");
    let t = Instant::now();
    let canon = match Canonicalizer::new(body, &[], &FieldOptions::default(), None) {
        Ok(c) => c,
        Err(e) => return out + &format!("| build failed | | {e} |\n"),
    };
    out += &format!(
        "| build the diffused skinning field ({}x{}x{} nodes, {:.1} cm cells) | {:.2} s | once per body shape, then cached |\n",
        canon.field.dims[0],
        canon.field.dims[1],
        canon.field.dims[2],
        canon.field.cell * 100.0,
        t.elapsed().as_secs_f64()
    );
    let dir =
        std::env::temp_dir().join(format!("avatar-studio-canon-bench-{}", std::process::id()));
    let mut job =
        SynthJob::new(3, Outfit::LongsleeveTrousers, clip_by_name("walk").expect("library clip"));
    job.frames = Some(8);
    job.write_ground_truth = false;
    let frames = generate_capture(&dir, body, &job).and_then(|_| Capture::open(&dir));
    let _ = std::fs::remove_dir_all(&dir);
    let Ok(mut capture) = frames else { return out + "| synthetic capture failed | | |\n" };
    for f in &mut capture.frames {
        // Exactly 5,000 points a frame, evenly spread.
        let n = f.points.len();
        let keep: Vec<usize> = (0..5000).map(|i| i * n / 5000).collect();
        f.points = keep.iter().map(|&i| f.points[i]).collect();
        f.normals = keep.iter().map(|&i| f.normals[i]).collect();
    }
    let t = Instant::now();
    let results: Vec<_> = capture.frames.iter().map(|f| canon.frame(f)).collect();
    let secs = t.elapsed().as_secs_f64();
    let dropped: usize = results.iter().map(|r| r.dropped + r.unsolved).sum();
    out += &format!(
        "| canonicalize 8 frames x 5,000 points (9 Broyden starts each) | {secs:.2} s | target < 2 s on 2 cores; {dropped} of 40,000 dropped |\n"
    );
    out
}
