//! Experiment: fit a loose-cloth capture with one of the outside constraints taken away, to see
//! which one tears the garment. `loose_fit_variants CAPTURE OUT.avatar VARIANT [STEPS]`,
//! VARIANT one of base, refoff (no pose refinement), noshell (no shell samples, no
//! refinement), nofree (no free-space nor shell samples, no refinement).
use avatar_core::canonical::FieldCache;
use avatar_neural::avatar::{AvatarFit, FitKind, fit_avatar};
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::{HyperFitOptions, Init, MetaModel};

fn main() -> avatar_neural::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let (dir, out, variant) = (&args[1], &args[2], args[3].as_str());
    let mut options = HyperFitOptions::default();
    if let Some(steps) = args.get(4).and_then(|s| s.parse().ok()) {
        options.steps = steps;
    }
    let cache = FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"));
    let mut capture = CapturePoints::open(std::path::Path::new(dir), 32, &cache)?;
    match variant {
        "base" => {}
        "refoff" => options.refine_poses.enabled = false,
        "noshell" => {
            options.refine_poses.enabled = false;
            capture.frames.iter_mut().for_each(|f| f.shells.clear());
        }
        "nofree" => {
            options.refine_poses.enabled = false;
            capture.frames.iter_mut().for_each(|f| {
                f.shells.clear();
                f.free_space.clear()
            });
        }
        v if v.starts_with("cross") => {
            // crossR[_L]: drop free space within R cm of another frame's points lying L cm
            // (default 3) outside the body.
            let mut parts = v[5..].split('_');
            let r: f32 = parts.next().and_then(|s| s.parse().ok()).unwrap_or(3.0) / 100.0;
            let loose: f32 = parts.next().and_then(|s| s.parse().ok()).unwrap_or(3.0) / 100.0;
            let norm = capture.normalisation;
            let metric: Vec<Vec<glam::Vec3>> = capture
                .frames
                .iter()
                .map(|f| f.points.iter().map(|p| norm.from_unit(*p)).collect())
                .collect();
            let body = capture.rest_sdf.clone();
            let loose_pts: Vec<Vec<glam::Vec3>> = metric
                .iter()
                .map(|ps| {
                    ps.iter().copied().filter(|p| body.at(*p).unwrap_or(0.0) > loose).collect()
                })
                .collect();
            let (mut before, mut after) = (0, 0);
            for k in 0..capture.frames.len() {
                let others: Vec<glam::Vec3> = loose_pts
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != k)
                    .flat_map(|(_, p)| p.iter().copied())
                    .collect();
                let Ok(index) = avatar_core::mesh::point_index::PointIndex::new(&others) else {
                    continue;
                };
                let f = &mut capture.frames[k];
                before += f.free_space.len();
                f.free_space.retain(|p| index.nearest(norm.from_unit(*p)).1 > r);
                after += f.free_space.len();
            }
            println!("free space kept {after} of {before}");
            options.refine_poses.enabled = false;
        }
        other => panic!("unknown variant {other}"),
    }
    let prior = MetaModel::shipped();
    let fit = AvatarFit {
        kind: FitKind::Meta(Init::MetaLearned(&prior)),
        options,
        chunk: 0,
        cancel: None,
        trace: None,
    };
    let t = std::time::Instant::now();
    let (avatar, report) = fit_avatar(&capture, &fit, &mut |_| {})?;
    avatar.save(out)?;
    println!(
        "{variant}: {} frames, {} points, {:.0} s: {out}",
        report.frames,
        report.points,
        t.elapsed().as_secs_f32()
    );
    Ok(())
}
