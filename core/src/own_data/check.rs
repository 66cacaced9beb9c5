//! The checks of one item of own data, run by discovery (and so by the dry run) before anything
//! is trained: a capture folder's manifest and body model, a scan's OBJ and fitting, the fitting
//! of the right body model, the scan on its fitted body.

use super::{Item, ItemKind};
use crate::body::{BodyModel, BodyParams};
use crate::capture::open::{CaptureOptions, CaptureSource};
use crate::capture::scan::{check_scan_on_body, load_scan};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use std::path::Path;

/// A capture folder: its `capture.json` and the body model it names read and checked (the
/// shape coefficients of every frame the model's), no depth image read.
pub fn capture(dir: &Path) -> Result<Item> {
    let source = CaptureSource::open(dir, &CaptureOptions::default())?;
    if source.is_empty() {
        return Err(Error::file(
            dir.join(crate::capture::MANIFEST_FILE),
            "the capture has no frames",
        ));
    }
    Ok(Item {
        path: dir.to_path_buf(),
        kind: ItemKind::Capture { frames: source.len() },
        body_file: source.body_file.clone(),
    })
}

/// A scan and its fitting: both read, the fitting's shape coefficients the body model's, and
/// most of the scan within 30 cm of the fitted body.
pub fn scan(
    obj: &Path,
    fitting: &Path,
    body: &BodyModel,
    body_file: Option<&Path>,
) -> Result<Item> {
    let (mesh, _) = load_scan_item(obj, fitting, body, body_file.is_some())?;
    Ok(Item {
        path: obj.to_path_buf(),
        kind: ItemKind::Scan {
            fitting: fitting.to_path_buf(),
            vertices: mesh.positions.len(),
            faces: mesh.faces.len(),
        },
        body_file: body_file.map(Path::to_path_buf),
    })
}

/// Read and check a scan and its fitting (what [`scan`] checks), for training.
pub fn load_scan_item(
    obj: &Path,
    fitting: &Path,
    body: &BodyModel,
    smpl: bool,
) -> Result<(TriMesh, BodyParams)> {
    let params = BodyParams::load_json(fitting)?;
    check_fitting_body(fitting, &params, body, smpl)?;
    let mesh = load_scan(obj)?;
    check_scan_on_body(obj, &mesh, body, &params)?;
    Ok((mesh, params))
}

/// Shape coefficients the body model does not have mean a fitting of another model (SMPL's ten
/// betas read as the open body's seven directions): refused with the way to name the model.
/// Trailing zeros are padding and fine.
pub fn check_fitting_body(
    path: &Path,
    params: &BodyParams,
    body: &BodyModel,
    smpl: bool,
) -> Result<()> {
    let used = params.betas.iter().rposition(|&b| b != 0.0).map_or(0, |last| last + 1);
    if used <= body.num_betas {
        return Ok(());
    }
    let hint = if smpl {
        "is it fitted with another model than the one the subject's subject.json names?"
    } else {
        "a fitting of another body model (SMPL?): name the model in the subject folder's subject.json as {\"body_model\": {\"smpl\": PATH}}"
    };
    Err(Error::file(
        path,
        format!(
            "the fitting has {} shape coefficients but the body model {} has {}: {hint}",
            params.betas.len(),
            body.label,
            body.num_betas
        ),
    ))
}
