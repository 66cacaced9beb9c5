//! Open a capture and take its depth points to the canonical pose: the first stage of every
//! avatar. A capture is a folder (docs/capture-format.md): `capture.json` (the camera, and per
//! frame a depth image and the body's fitting) beside the depth images.
//!
//! cargo run --release -p avatar-core --example open_capture [-- CAPTURE_DIR]
//!
//! Without an argument it opens the demo capture shipped in `assets/demo`. Next:
//! `neural/examples/fit_avatar.rs` fits an avatar to a capture.

use avatar_core::canonical::{Canonicalizer, FieldCache, FieldOptions};
use avatar_core::capture::Capture;
use std::path::PathBuf;

fn main() -> avatar_core::Result<()> {
    let dir = std::env::args().nth(1).map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/demo"),
        PathBuf::from,
    );

    // Every frame's depth image back-projected to world points (metres, Y up) with normals, the
    // body cropped out of the background, and the body's fitting (SMPL pose and shape).
    let capture = Capture::open(&dir)?;
    println!("{}: {} frames", dir.display(), capture.frames.len());
    for w in &capture.warnings {
        println!("  skipped: {w}");
    }
    for f in capture.frames.iter().take(3) {
        println!(
            "  frame {}: {} depth points, translation {:?}",
            f.index,
            f.points.len(),
            f.params.trans
        );
    }

    // Canonicalization: each posed point moved back to the body's rest pose by inverse skinning
    // through a skinning field built for this body shape. Building a field takes seconds; the
    // program says where fields are kept between runs (avatar-studio:
    // ~/.cache/avatar-studio/fields), and `FieldCache::none()` builds it every time.
    let cache = FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"));
    let betas = &capture.frames[0].params.betas;
    let canon = Canonicalizer::new(&capture.body, betas, &FieldOptions::default(), cache.dir())?;
    let frame = &capture.frames[0];
    let canonical = canon.frame(frame);
    println!(
        "frame {}: {} of {} points canonicalized ({} dropped by the 2 cm filter, {} without a root)",
        frame.index,
        canonical.points.len(),
        canonical.input_len(),
        canonical.dropped,
        canonical.unsolved
    );
    Ok(())
}
