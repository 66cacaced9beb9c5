//! `avatar-studio canonicalize`: map a capture's depth points to the canonical (unposed) space
//! and write them as a point cloud with normals.

use avatar_core::canonical::{Canonicalizer, FieldOptions};
use avatar_core::capture::{Capture, CaptureOptions};
use avatar_core::io::Inputs;
use avatar_core::mesh::{PointCloud, io::write_point_cloud};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder (with capture.json).
    capture: PathBuf,
    /// Output point cloud (.ply with normals).
    #[arg(long)]
    out: PathBuf,
    /// Use only the first N usable frames.
    #[arg(long)]
    frames: Option<usize>,
    /// Cells of the skinning field along the body's height (16 to 256).
    #[arg(long, default_value_t = 128)]
    field_cells: usize,
    /// The SMPL-family model file (.npz) of the fittings, replacing the one capture.json names.
    #[arg(long)]
    body_model: Option<PathBuf>,
    /// Do not read or write the skinning-field cache.
    #[arg(long)]
    no_cache: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    Inputs::new().capture(&args.capture).check_file(&args.out, &["ply"])?;
    let options = FieldOptions { cells_along_height: args.field_cells, ..FieldOptions::default() };
    options.validate().map_err(|e| anyhow::anyhow!("--field-cells: {e}"))?;
    if args.frames == Some(0) {
        anyhow::bail!("--frames must be at least 1");
    }
    let capture = Capture::open_with(
        &args.capture,
        &CaptureOptions { body_model: args.body_model.clone(), ..CaptureOptions::default() },
    )?;
    for w in &capture.warnings {
        eprintln!("warning: {w}");
    }
    let frames: Vec<_> = capture.frames.iter().take(args.frames.unwrap_or(usize::MAX)).collect();
    let betas = frames[0].params.betas.clone();
    let cache = if args.no_cache { None } else { avatar_studio::cache::field_cache().dir() };
    let canon = Canonicalizer::new(&capture.body, &betas, &options, cache)?;
    if let Some(w) = &canon.cache_warning {
        eprintln!("warning: {w}");
    }
    let mut cloud = PointCloud { points: Vec::new(), normals: Vec::new() };
    for f in frames {
        let c = canon.frame(f);
        eprintln!(
            "frame {}: {} points canonicalized, {} dropped by the 2 cm filter, {} without a root",
            f.index,
            c.points.len(),
            c.dropped,
            c.unsolved
        );
        cloud.points.extend(c.points);
        cloud.normals.extend(c.normals);
    }
    write_point_cloud(&args.out, &cloud)?;
    println!("wrote {} canonical points to {}", cloud.points.len(), args.out.display());
    Ok(())
}
