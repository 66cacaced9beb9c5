//! The neural speed targets, measured side by side on the embedded demo capture: fine-tuning 8
//! frames with the compact preset from the shipped meta-model (target: under 3 minutes on 2
//! CPU cores), a posed mesh at preview resolution (target: under 0.5 s), and fit's peak
//! memory (target: under 2 GB); a 300-frame animated glTF of the fitted avatar (target: under
//! 30 s); the SDF evaluation of a posed mesh with burn's forward against `siren_eval`'s.

use avatar_core::body::BodyParams;
use avatar_core::export::{ExportOptions, export_glb};
use avatar_core::mesh::extract::{ExtractOptions, extract};
use avatar_core::motion::{MotionClip, clip_by_name, library};
use avatar_neural::avatar::MeshResolution;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::{HyperFitOptions, Init, MetaAvatar, MetaModel};
use glam::Vec3;
use std::time::Instant;

/// Peak resident memory of this process so far (Linux), in bytes.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// `steps`: fine-tuning steps (the `fit` default is 300).
pub fn bench_report(steps: usize) -> String {
    let mut out = String::from("## neural\n\n| what | measured | target |\n|---|---|---|\n");
    let t = Instant::now();
    let capture = match super::demo_capture().and_then(|demo| {
        CapturePoints::open(&demo, 8, avatar_studio::cache::field_cache())
            .map_err(|e| e.to_string())
    }) {
        Ok(c) => c,
        Err(e) => return out + &format!("| open the demo capture | failed: {e} | |\n"),
    };
    let canonical_s = t.elapsed().as_secs_f64();
    let model = MetaModel::shipped();
    let options = HyperFitOptions { steps, ..HyperFitOptions::default() };
    let t = Instant::now();
    let (mut avatar, report) = MetaAvatar::fit_points(
        &capture,
        &Init::MetaLearned(&model),
        &options,
        None,
        &mut |_, _, _| {},
    );
    let fit_s = t.elapsed().as_secs_f64();
    out += &format!(
        "| canonicalize 8 demo frames ({} points) | {canonical_s:.1} s | |\n",
        report.points
    );
    out += &format!(
        "| fine-tune compact preset, 8 frames, {steps} steps | {fit_s:.1} s ({:.0} ms/step); with canonicalization {:.1} s | < 180 s |\n",
        fit_s * 1e3 / steps.max(1) as f64,
        fit_s + canonical_s
    );
    let clip = clip_by_name("walk").expect("library clip");
    for resolution in [128, 64] {
        avatar.set_mesh_resolution(MeshResolution::new(resolution).expect("within the bounds"));
        let mut times = Vec::new();
        let mut vertices = 0;
        for params in clip.frames.iter().step_by(12).take(5) {
            let t = Instant::now();
            match avatar.posed_mesh(params) {
                Ok(m) => vertices = m.positions.len(),
                Err(e) => return out + &format!("| posed mesh | failed: {e} | |\n"),
            }
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let target = if resolution == 128 { "< 0.5 s" } else { "" };
        out += &format!(
            "| new posed mesh at resolution {resolution} ({vertices} vertices), median of 5 poses | {:.2} s | {target} |\n",
            times[times.len() / 2]
        );
    }
    out += &burn_against_fast_path(&avatar, &clip.frames[36]);
    avatar.set_mesh_resolution(MeshResolution::new(128).expect("within the bounds"));
    out += &export_row(&avatar);
    if let Some(peak) = peak_memory_bytes() {
        out += &format!(
            "| peak memory of this process (fit included) | {:.0} MB | < 2048 MB |\n",
            peak as f64 / 1e6
        );
    }
    out
}

/// The posed mesh's SDF evaluations through burn's forward (the path before `siren_eval`) and
/// through `siren_eval`, side by side on one pose at resolution 128.
fn burn_against_fast_path(avatar: &MetaAvatar, params: &BodyParams) -> String {
    let n = avatar.header.normalisation;
    let mut options =
        ExtractOptions::new(n.from_unit(Vec3::splat(-1.0)), n.from_unit(Vec3::splat(1.0)), 128);
    options.margin = 0.25;
    let burn_sdf = avatar.burn_sdf_at(params);
    let t = Instant::now();
    let slow = extract(burn_sdf, &options);
    let burn_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let sdf = avatar.sdf_at(params);
    let fast = extract(|p: &[Vec3]| sdf.sdf(p), &options);
    let fast_s = t.elapsed().as_secs_f64();
    match (slow, fast) {
        (Ok(slow), Ok(fast)) => format!(
            "| canonical mesh at 128, one pose: burn forward vs siren_eval ({} evaluations; {} vs {} vertices) | {burn_s:.2} s vs {fast_s:.2} s = {:.1}x faster | |\n",
            fast.stats.evaluations(),
            slow.mesh.positions.len(),
            fast.mesh.positions.len(),
            burn_s / fast_s
        ),
        (Err(e), _) | (_, Err(e)) => format!("| burn vs siren_eval | failed: {e} | |\n"),
    }
}

/// A 300-frame animated glTF of the fitted avatar (library clips back to back at 30 fps).
fn export_row(avatar: &MetaAvatar) -> String {
    let frames: Vec<_> = library().into_iter().flat_map(|c| c.frames).take(300).collect();
    let clip = MotionClip::new("bench", 30.0, frames);
    let t = Instant::now();
    match export_glb(avatar, &clip, &ExportOptions::default()) {
        Ok(e) => format!(
            "| export {} frames to GLB ({} vertices, {} morph targets, {:.2} MB, largest compression error {:.2} mm) | {:.1} s | < 30 s |\n",
            clip.frames.len(),
            e.rest.positions.len(),
            e.morphs.targets.len() + 1,
            e.glb.len() as f64 / 1e6,
            e.max_compression_error * 1000.0,
            t.elapsed().as_secs_f64()
        ),
        Err(e) => format!("| export 300 frames | failed: {e} | < 30 s |\n"),
    }
}
