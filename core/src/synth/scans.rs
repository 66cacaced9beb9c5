//! The generator's clothed subjects saved as scans: per frame, the posed clothed surface as an
//! OBJ and its body fitting as a JSON pose file, side by side (`NAME.obj` + `NAME.json`): the
//! scans of a studio's own meta-training data (`own_data`: DIR/<subject>/<outfit>/).

use super::deform::{PoseFeatures, canonical_surface, pose_surface};
use super::generate::SynthJob;
use super::outfit::ClothedTemplate;
use crate::body::BodyModel;
use crate::error::{Error, Result};
use crate::io::write_bytes_atomic;
use crate::mesh::TriMesh;
use crate::mesh::io::write_obj;
use std::path::Path;

/// Write one scan per frame of `job` into `dir` as `PREFIX_FFFF.obj` + `PREFIX_FFFF.json` (the
/// frame's fitting, turned as `SynthJob::frame_params` turns it); returns the scans written.
/// Simulated garments are not written (their shape comes from a cloth simulation of the clip).
pub fn save_scans(dir: &Path, body: &BodyModel, job: &SynthJob, prefix: &str) -> Result<usize> {
    if job.outfit.is_simulated() {
        return Err(Error::invalid(format!(
            "scans of the simulated outfit {} are not written; use captures",
            job.outfit.name()
        )));
    }
    if job.clip.is_empty() {
        return Err(Error::invalid(format!("motion clip {:?} has no frames", job.clip.name)));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let params = job.frame_params(body);
    let template = ClothedTemplate::build(body, &params[0].betas, job.outfit);
    for (i, p) in params.iter().enumerate() {
        let bones = body.pose(p).bones;
        let canonical = canonical_surface(&template, &PoseFeatures::of(&bones), job.subject_seed);
        let posed = pose_surface(&template, &canonical, &bones);
        let name = format!("{prefix}_{i:04}");
        write_obj(dir.join(format!("{name}.obj")), &TriMesh::new(posed, template.faces.clone()))?;
        let fitting = serde_json::json!({
            "pose": p.flat_pose(),
            "betas": p.betas,
            "trans": p.trans.to_array(),
        });
        let text = serde_json::to_vec(&fitting).map_err(|e| Error::invalid(e.to_string()))?;
        write_bytes_atomic(dir.join(format!("{name}.json")), &text)?;
    }
    Ok(params.len())
}
