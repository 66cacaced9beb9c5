//! `avatar-studio import depth|scan`: turn the material users have into a capture folder that
//! `fit` takes (docs/capture-format.md).

use avatar_core::capture::import::{DepthImport, Pinhole, import_depth};
use avatar_core::capture::scan::{ScanViews, import_scan};
use avatar_core::capture::{DEPTH_SCALE_MM, DEPTH_SCALE_TUM};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand)]
enum What {
    /// A folder of 16-bit depth PNGs plus per-frame SMPL fittings.
    Depth(DepthArgs),
    /// A 3D scan (OBJ) seen by a ring of virtual depth cameras.
    Scan(ScanArgs),
}

#[derive(clap::Args)]
struct DepthArgs {
    /// Folder of 16-bit depth PNGs (paired with the fittings in name order).
    dir: PathBuf,
    /// AMASS-style .npz, or a folder of JSON pose files (one per image).
    #[arg(long)]
    fittings: PathBuf,
    /// fx,fy,cx,cy in pixels, or a JSON file with those keys.
    #[arg(long)]
    intrinsics: String,
    /// Output capture folder (new or empty).
    #[arg(long)]
    out: PathBuf,
    /// Depth in TUM RGB-D units (5000 per metre) instead of millimetres.
    #[arg(long)]
    tum: bool,
    /// PNG units per metre (overrides --tum).
    #[arg(long)]
    depth_scale: Option<f32>,
    /// The fittings are Z-up (AMASS): turn them to the studio's Y-up world.
    #[arg(long)]
    z_up: bool,
    /// JSON camera-to-world (row-major 4x4, one for all frames or a list); without it the
    /// fittings must be in the depth camera's coordinates.
    #[arg(long)]
    cameras: Option<PathBuf>,
    /// Frame rate (default: the npz's, else 30).
    #[arg(long)]
    fps: Option<f32>,
    /// The SMPL-family model file (.npz) the fittings were made with (default: the open
    /// body). The capture names it by its absolute path; the file is not copied.
    #[arg(long)]
    body_model: Option<PathBuf>,
}

#[derive(clap::Args)]
struct ScanArgs {
    /// The scan (OBJ, metres, Y up, in the fitting's coordinates).
    scan: PathBuf,
    /// The scan's body fitting (JSON pose file).
    #[arg(long)]
    fitting: PathBuf,
    /// Output capture folder (new or empty).
    #[arg(long)]
    out: PathBuf,
    /// Virtual cameras on the ring.
    #[arg(long, default_value_t = 8)]
    views: usize,
    /// Side of the square depth images (pixels).
    #[arg(long, default_value_t = 256)]
    resolution: u32,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Depth(a) => depth(a),
        What::Scan(a) => scan(a),
    }
}

fn depth(a: DepthArgs) -> anyhow::Result<()> {
    let depth_scale = a.depth_scale.unwrap_or(if a.tum { DEPTH_SCALE_TUM } else { DEPTH_SCALE_MM });
    let job = DepthImport {
        depth_dir: a.dir,
        fittings: a.fittings,
        pinhole: Pinhole::parse(&a.intrinsics)?,
        depth_scale,
        z_up: a.z_up,
        cameras: a.cameras,
        fps: a.fps,
        body_model: a.body_model,
    };
    let report = import_depth(&job, &a.out)?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(d) = &report.diagnosis {
        eprintln!("warning: {d}");
    }
    println!(
        "wrote {}: {} frames, {} usable by `fit`",
        a.out.display(),
        report.frames,
        report.usable
    );
    Ok(())
}

fn scan(a: ScanArgs) -> anyhow::Result<()> {
    let views = ScanViews { views: a.views, resolution: a.resolution };
    let r = import_scan(&a.scan, &a.fitting, &a.out, avatar_core::body::open_body_ref(), &views)?;
    println!(
        "wrote {}: {} views of the scan ({} vertices, {} triangles) from {:.2} m, {} depth pixels",
        a.out.display(),
        r.frames,
        r.vertices,
        r.faces,
        r.distance,
        r.depth_pixels
    );
    Ok(())
}
