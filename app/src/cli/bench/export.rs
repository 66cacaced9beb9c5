//! The export bench section: a 300-frame animated glTF of a synthetic full-body avatar.

use avatar_core::canonical::FieldOptions;
use avatar_core::export::{ExportOptions, SyntheticAvatar, export_glb};
use avatar_core::motion::{MotionClip, library};
use avatar_core::synth::Outfit;
use std::time::Instant;

pub fn bench_report() -> String {
    let mut out = String::from("## export\n\n| what | time | note |\n|---|---|---|\n");
    let avatar = match SyntheticAvatar::new(
        avatar_core::body::open_body(),
        2024,
        Outfit::LongsleeveTrousers,
        &FieldOptions::default(),
    ) {
        Ok(a) => a,
        Err(e) => return out + &format!("| avatar failed | | {e} |\n"),
    };
    // 300 frames: library clips back to back at 30 fps.
    let frames: Vec<_> = library().into_iter().flat_map(|c| c.frames).take(300).collect();
    let clip = MotionClip::new("bench", 30.0, frames);
    let t = Instant::now();
    match export_glb(&avatar, &clip, &ExportOptions::default()) {
        Ok(e) => {
            out += &format!(
                "| export 300 frames to GLB ({} vertices, {} morph targets) | {:.1} s | target < 30 s on 2 cores; {:.2} MB; largest compression error {:.2} mm |\n",
                e.rest.positions.len(),
                e.morphs.targets.len() + 1,
                t.elapsed().as_secs_f64(),
                e.glb.len() as f64 / 1e6,
                e.max_compression_error * 1000.0
            );
        }
        Err(e) => out += &format!("| export failed | | {e} |\n"),
    }
    out
}
