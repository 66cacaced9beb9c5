//! Write a long motion-capture take as BVH: the library's clips back to back
//! (`avatar_core::motion::bvh_write::long_take`), for measuring `export` and `pose` on takes
//! of real length (docs/export.md).
//!
//! `cargo run --release -p avatar-core --example long_take -- OUT.bvh [FRAMES] [FPS]`
//! (default 2752 frames at 120 fps: the length of CMU subject 1's first take).

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out) = args.first() else {
        eprintln!("usage: long_take OUT.bvh [FRAMES] [FPS]");
        std::process::exit(2);
    };
    let frames: usize = args.get(1).map_or(Ok(2752), |s| s.parse()).expect("FRAMES: a count");
    let fps: f32 = args.get(2).map_or(Ok(120.0), |s| s.parse()).expect("FPS: a number");
    let name = std::path::Path::new(out).file_stem().map_or("take".into(), |s| s.to_string_lossy());
    let clip = avatar_core::motion::bvh_write::long_take(&name, frames, fps)
        .unwrap_or_else(|e| panic!("{e}"));
    avatar_core::motion::bvh_write::save_bvh(&clip, out).unwrap_or_else(|e| panic!("{e}"));
    println!("wrote {out}: {} frames at {fps} fps ({:.1} s)", clip.len(), clip.len() as f32 / fps);
}
