//! `avatar-studio body`: pose the embedded open body or a user's SMPL model and write a mesh.

use anyhow::Context;
use avatar_core::body::{BodyModel, BodyParams};
use avatar_core::io::Inputs;
use avatar_core::mesh::io::write_mesh;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Pose file (JSON: "pose" 24x3 or 72 axis-angle radians, optional "betas", "trans").
    /// Without it, the rest (T) pose.
    #[arg(long)]
    pose: Option<PathBuf>,
    /// Output mesh (.obj or .ply).
    #[arg(long)]
    out: PathBuf,
    /// Your own SMPL model (.npz with v_template, shapedirs, posedirs, J_regressor, weights,
    /// kintree_table, f). Default: the embedded open body.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Use the low-poly open body (about 1.2k vertices) for fast previews.
    #[arg(long, conflicts_with = "model")]
    lowpoly: bool,
}

pub fn load_model(model: Option<&PathBuf>, lowpoly: bool) -> anyhow::Result<BodyModel> {
    Ok(match model {
        Some(path) => BodyModel::load_npz(path)?,
        None if lowpoly => avatar_core::body::open_body_lowpoly(),
        None => avatar_core::body::open_body(),
    })
}

pub fn run(args: Args) -> anyhow::Result<()> {
    Inputs::new()
        .maybe_file(args.pose.as_ref())
        .maybe_file(args.model.as_ref())
        .check_file(&args.out, &["obj", "ply"])?;
    let model = load_model(args.model.as_ref(), args.lowpoly)?;
    let params = match &args.pose {
        Some(p) => BodyParams::load_json(p)?,
        None => BodyParams::default(),
    };
    if params.betas.len() > model.num_betas {
        eprintln!(
            "warning: the pose has {} shape coefficients, the model {}; the extra ones are ignored",
            params.betas.len(),
            model.num_betas
        );
    }
    let posed = model.pose(&params);
    let mesh = model.mesh(posed.vertices);
    write_mesh(&args.out, &mesh).with_context(|| format!("writing {}", args.out.display()))?;
    let (lo, hi) = mesh.bounds().unwrap_or_default();
    println!(
        "wrote {} ({} vertices, {} faces, model: {}, height {:.3} m)",
        args.out.display(),
        mesh.positions.len(),
        mesh.faces.len(),
        model.label,
        hi.y - lo.y
    );
    Ok(())
}
