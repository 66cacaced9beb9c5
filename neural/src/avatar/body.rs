//! The body an avatar file carries: part of the avatar file format (with `header`; both kinds,
//! static_avatar.rs and meta_avatar.rs, store it the same way).
//!
//! An avatar fitted on the embedded open body stores only the shape coefficients (version 1
//! files, unchanged): loading rebuilds the body from the embedded model. An avatar fitted on a
//! user's own SMPL model stores that model frozen at the subject's shape (version 2): the
//! header's `body` section says how many values follow the network's weights, and loading
//! needs no model file. The model itself (shape directions, pose correctives, regressor) is
//! never copied: only the user's derived data. Layout of the trailing float32 values:
//!
//! ```text
//! rest vertices V x 3 | rest joints 24 x 3 | faces F x 3 (indices) |
//! weights per vertex: count V, then E pairs (joint index, weight), vertex by vertex
//! ```
//!
//! Indices are exact in float32 (below 2^24). Sparse weights keep the file small: an SMPL body
//! (6,890 vertices, 13,776 faces) adds about 0.3 MB plus 8 bytes per non-zero weight.

use crate::data::capture_points::CapturePoints;
use crate::error::{Error, Result};
use avatar_core::body::{BodyModel, NUM_JOINTS, Weights, open_body_ref};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The avatar format version of files without a body section (open-body avatars).
pub const VERSION_OPEN_BODY: u32 = 1;
/// The avatar format version of files that carry their frozen body.
pub const VERSION_WITH_BODY: u32 = 2;
/// `body_model` of an avatar on the embedded open body.
pub const OPEN_BODY: &str = "open_body";
/// `body_model` of an avatar on a user's SMPL model (its frozen body follows the weights).
pub const SMPL: &str = "smpl";

/// The header's description of the frozen body stored after the network's weights.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BodySection {
    /// The model file's name, for display (not its contents, not needed to load).
    pub label: String,
    pub vertices: usize,
    pub faces: usize,
    /// Non-zero skinning weights over all vertices.
    pub weight_entries: usize,
}

impl BodySection {
    /// Float32 values the section occupies in the file.
    pub fn len(&self) -> usize {
        self.vertices * 3
            + NUM_JOINTS * 3
            + self.faces * 3
            + self.vertices
            + 2 * self.weight_entries
    }

    pub fn is_empty(&self) -> bool {
        self.vertices == 0
    }
}

/// What an avatar fitted on `capture` poses with, its `body_model` name, its format version and
/// the body section to write (None for the open body).
pub fn of_capture(capture: &CapturePoints) -> (BodyModel, &'static str, u32, Option<BodySection>) {
    let Some(file) = &capture.body_file else {
        return (capture.body.clone(), OPEN_BODY, VERSION_OPEN_BODY, None);
    };
    let body = capture.body.frozen(&capture.betas);
    let label = file
        .file_name()
        .map_or_else(|| file.display().to_string(), |n| n.to_string_lossy().into_owned());
    let section = BodySection {
        label,
        vertices: body.num_vertices(),
        faces: body.faces.len(),
        weight_entries: body.weights.iter().map(|w| w.iter().filter(|&&x| x != 0.0).count()).sum(),
    };
    (body, SMPL, VERSION_WITH_BODY, Some(section))
}

/// A version-2 file carries a body section and a version-1 file none.
pub fn check_version(version: u32, section: Option<&BodySection>) -> Result<()> {
    if (version == VERSION_WITH_BODY) != section.is_some() {
        let has = if section.is_some() { "a stored body" } else { "no stored body" };
        return Err(Error::invalid(format!(
            "version {version} with {has} (version {VERSION_OPEN_BODY}: none, version {VERSION_WITH_BODY}: one)"
        )));
    }
    Ok(())
}

/// The values of a frozen body's section (appended to the network's weights).
pub fn encode(body: &BodyModel, section: &BodySection) -> Vec<f32> {
    let mut out = Vec::with_capacity(section.len());
    out.extend(body.v_template.iter().flat_map(|v| v.to_array()));
    out.extend(body.rest_joints(&[]).iter().flat_map(|v| v.to_array()));
    out.extend(body.faces.iter().flatten().map(|&i| i as f32));
    out.extend(body.weights.iter().map(|w| w.iter().filter(|&&x| x != 0.0).count() as f32));
    for w in &body.weights {
        for (j, &x) in w.iter().enumerate().filter(|(_, x)| **x != 0.0) {
            out.extend([j as f32, x]);
        }
    }
    out
}

/// Split a file's values into the network's `num_params` weights and the body it poses with:
/// the frozen body of its section, or the embedded open body. Errors name the file.
pub fn split(
    path: &Path,
    body_model: &str,
    section: Option<&BodySection>,
    mut values: Vec<f32>,
    num_params: usize,
) -> Result<(Vec<f32>, BodyModel)> {
    let extra = section.map_or(0, BodySection::len);
    if values.len() != num_params + extra {
        return Err(Error::file(
            path,
            format!(
                "truncated avatar file: {} values, expected {} ({num_params} weights and {extra} of its body)",
                values.len(),
                num_params + extra
            ),
        ));
    }
    let body = match (body_model, section) {
        (OPEN_BODY, None) => open_body_ref().clone(),
        (SMPL, Some(s)) => decode(s, &values[num_params..]).map_err(|e| e.in_file(path))?,
        (name, None) => {
            return Err(Error::file(
                path,
                format!(
                    "the avatar's body model {name:?} is not the open body and the file carries no body"
                ),
            ));
        }
        (name, Some(_)) => {
            return Err(Error::file(
                path,
                format!(
                    "body model {name:?} with a stored body (this build reads {OPEN_BODY:?} without one, {SMPL:?} with one)"
                ),
            ));
        }
    };
    values.truncate(num_params);
    Ok((values, body))
}

fn decode(s: &BodySection, data: &[f32]) -> Result<BodyModel> {
    let (nv, nf) = (s.vertices, s.faces);
    let bad = |what: &str| Error::invalid(format!("avatar body: {what}"));
    if nv == 0 || nv >= 1 << 24 {
        return Err(bad(&format!("{nv} vertices")));
    }
    let index = |x: f32, below: usize| {
        (x >= 0.0 && x.fract() == 0.0 && (x as usize) < below).then_some(x as u32)
    };
    let vec3s =
        |d: &[f32]| d.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
    let (rest, data) = data.split_at(nv * 3);
    let (joints, data) = data.split_at(NUM_JOINTS * 3);
    let (faces, data) = data.split_at(nf * 3);
    let (counts, pairs) = data.split_at(nv);
    let faces = faces
        .chunks_exact(3)
        .map(|c| Some([index(c[0], nv)?, index(c[1], nv)?, index(c[2], nv)?]))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| bad("a face has a vertex index out of range"))?;
    let mut weights: Vec<Weights> = Vec::with_capacity(nv);
    let mut pairs = pairs.chunks_exact(2);
    for (v, &n) in counts.iter().enumerate() {
        let n = index(n, NUM_JOINTS + 1)
            .ok_or_else(|| bad(&format!("vertex {v} has a bad skinning-weight count")))?;
        let mut w = [0f32; NUM_JOINTS];
        for _ in 0..n {
            let p = pairs.next().ok_or_else(|| bad("fewer skinning weights than counted"))?;
            let j = index(p[0], NUM_JOINTS)
                .ok_or_else(|| bad(&format!("vertex {v} has a joint index out of range")))?;
            w[j as usize] = p[1];
        }
        weights.push(w);
    }
    if pairs.next().is_some() {
        return Err(bad("more skinning weights than counted"));
    }
    let joints: [Vec3; NUM_JOINTS] = vec3s(joints).try_into().expect("24 joints");
    Ok(BodyModel::from_frozen_parts(
        &format!("{} (frozen in the avatar)", s.label),
        vec3s(rest),
        faces,
        weights,
        joints,
    )?)
}
