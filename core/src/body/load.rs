//! Loading a body model from an SMPL-style `.npz` (the user's SMPL, or the embedded open body).
//! Keys: v_template (V,3), shapedirs (V,3,K), posedirs (V,3,207, optional), J_regressor (24,V),
//! weights (V,24), kintree_table (2,24), f (F,3). Any float or integer dtype.

use super::model::{BodyModel, NUM_POSE_FEATURES};
use super::skeleton::{NUM_JOINTS, SMPL_PARENTS};
use crate::error::{Error, Result};
use crate::io::npz::{Array, Npz};
use glam::Vec3;
use std::io::{Read, Seek};
use std::path::Path;

impl BodyModel {
    /// Load a user's SMPL model file.
    pub fn load_npz(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let mut npz = Npz::open(path)?;
        let mut model = read_model(&mut npz)?;
        model.label = path.display().to_string();
        Ok(model)
    }

    /// Load a model from npz bytes in memory (`origin` names it in errors).
    pub fn from_npz_bytes(bytes: &[u8], origin: &str) -> Result<Self> {
        let mut npz = Npz::from_bytes(bytes, origin)?;
        let mut model = read_model(&mut npz)?;
        model.label = origin.to_string();
        Ok(model)
    }
}

fn read_model<R: Read + Seek>(npz: &mut Npz<R>) -> Result<BodyModel> {
    let origin = npz.origin().to_path_buf();
    let bad = |key: &str, msg: String| Error::file(&origin, format!("array '{key}': {msg}"));

    let v_template = npz.require("v_template")?;
    check_metres(&v_template, "v_template", &bad)?;
    let nv = match v_template.shape.as_slice() {
        [n, 3] if *n > 0 => *n,
        s => return Err(bad("v_template", format!("shape {s:?}, expected (V, 3)"))),
    };

    let kintree = npz.require("kintree_table")?;
    let nj = match kintree.shape.as_slice() {
        [2, n] => *n,
        s => return Err(bad("kintree_table", format!("shape {s:?}, expected (2, 24)"))),
    };
    if nj != NUM_JOINTS {
        return Err(bad(
            "kintree_table",
            format!(
                "{nj} joints; only SMPL's 24-joint skeleton is supported (SMPL-H/SMPL-X are not)"
            ),
        ));
    }
    for j in 1..NUM_JOINTS {
        let parent = kintree.data[j];
        if parent != SMPL_PARENTS[j] as f64 {
            return Err(bad(
                "kintree_table",
                format!("joint {j} has parent {parent}, SMPL's is {}", SMPL_PARENTS[j]),
            ));
        }
    }

    let shapedirs = npz.require("shapedirs")?;
    check_metres(&shapedirs, "shapedirs", &bad)?;
    let num_betas = match shapedirs.shape.as_slice() {
        [n, 3, k] if *n == nv => *k,
        s => return Err(bad("shapedirs", format!("shape {s:?}, expected ({nv}, 3, K)"))),
    };

    let posedirs = match npz.get("posedirs")? {
        None => None,
        Some(a) => {
            check_metres(&a, "posedirs", &bad)?;
            match a.shape.as_slice() {
                [n, 3, p] if *n == nv && *p == NUM_POSE_FEATURES => {
                    Some(vec3_blocks(&a, nv, NUM_POSE_FEATURES))
                }
                s => {
                    return Err(bad(
                        "posedirs",
                        format!("shape {s:?}, expected ({nv}, 3, {NUM_POSE_FEATURES})"),
                    ));
                }
            }
        }
    };

    let jreg = npz.require("J_regressor")?;
    check_finite(&jreg, "J_regressor", &bad)?;
    if jreg.shape != [NUM_JOINTS, nv] {
        return Err(bad(
            "J_regressor",
            format!("shape {:?}, expected (24, {nv}) dense", jreg.shape),
        ));
    }
    let j_regressor: Vec<Vec<(u32, f32)>> = (0..NUM_JOINTS)
        .map(|j| {
            (0..nv)
                .filter_map(|v| {
                    let w = jreg.data[j * nv + v];
                    (w != 0.0).then_some((v as u32, w as f32))
                })
                .collect()
        })
        .collect();
    if let Some(j) = j_regressor.iter().position(|r| r.is_empty()) {
        return Err(bad("J_regressor", format!("row {j} is all zeros")));
    }
    // Each joint is a weighted mean of vertices: rows sum to 1.
    if let Some((j, sum)) = j_regressor
        .iter()
        .map(|r| r.iter().map(|&(_, w)| w as f64).sum::<f64>())
        .enumerate()
        .find(|(_, s)| (s - 1.0).abs() > 0.1)
    {
        return Err(bad("J_regressor", format!("row {j} sums to {sum:.4}, expected 1")));
    }

    let weights = npz.require("weights")?;
    check_finite(&weights, "weights", &bad)?;
    if weights.shape != [nv, NUM_JOINTS] {
        return Err(bad("weights", format!("shape {:?}, expected ({nv}, 24)", weights.shape)));
    }
    let mut weight_rows = Vec::with_capacity(nv);
    for v in 0..nv {
        let row = &weights.data[v * NUM_JOINTS..(v + 1) * NUM_JOINTS];
        if row.iter().any(|&w| w < -1e-6) {
            return Err(bad("weights", format!("vertex {v} has a negative weight")));
        }
        let sum: f64 = row.iter().sum();
        if (sum - 1.0).abs() > 1e-3 {
            return Err(bad("weights", format!("vertex {v}: weights sum to {sum:.4}, expected 1")));
        }
        let mut w = [0f32; NUM_JOINTS];
        for (j, x) in row.iter().enumerate() {
            w[j] = (x.max(0.0) / sum) as f32;
        }
        weight_rows.push(w);
    }

    let f = npz.require("f")?;
    let faces = match f.shape.as_slice() {
        [_, 3] => f
            .data
            .chunks_exact(3)
            .enumerate()
            .map(|(i, c)| {
                let tri = [c[0], c[1], c[2]];
                if tri.iter().any(|&x| x < 0.0 || x >= nv as f64 || x.fract() != 0.0) {
                    return Err(bad("f", format!("face {i} has a vertex index outside 0..{nv}")));
                }
                Ok(tri.map(|x| x as u32))
            })
            .collect::<Result<Vec<_>>>()?,
        s => return Err(bad("f", format!("shape {s:?}, expected (F, 3)"))),
    };

    Ok(BodyModel {
        label: String::new(),
        v_template: vec3_blocks(&v_template, nv, 1),
        shapedirs: vec3_blocks(&shapedirs, nv, num_betas),
        num_betas,
        posedirs,
        j_regressor,
        frozen_joints: None,
        weights: weight_rows,
        faces,
        shape_names: Vec::new(),
        shape_limits: Vec::new(),
    })
}

/// Largest plausible coordinate or blend-shape offset in a body model file (metres): a body in
/// millimetres (values in the hundreds or thousands) or a corrupt array is refused.
const MAX_BODY_COORDINATE: f64 = 10.0;

/// Finite as float32 too (1e300 is a finite float64 but infinite once converted).
fn check_finite(a: &Array, key: &str, bad: &dyn Fn(&str, String) -> Error) -> Result<()> {
    match a.data.iter().position(|x| !(x.is_finite() && (*x as f32).is_finite())) {
        Some(i) => Err(bad(key, format!("contains NaN or infinity (flat index {i})"))),
        None => Ok(()),
    }
}

/// Finite and within [`MAX_BODY_COORDINATE`] metres.
fn check_metres(a: &Array, key: &str, bad: &dyn Fn(&str, String) -> Error) -> Result<()> {
    check_finite(a, key, bad)?;
    match a.data.iter().position(|x| x.abs() > MAX_BODY_COORDINATE) {
        Some(i) => Err(bad(
            key,
            format!(
                "value {} at flat index {i} is beyond {MAX_BODY_COORDINATE} m: the model must be in metres",
                a.data[i]
            ),
        )),
        None => Ok(()),
    }
}

/// (V, 3, K) row-major -> V*K Vec3 laid out [v][k].
fn vec3_blocks(a: &Array, nv: usize, k: usize) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(nv * k);
    for v in 0..nv {
        for i in 0..k {
            let at = |c: usize| a.data[(v * 3 + c) * k + i] as f32;
            out.push(Vec3::new(at(0), at(1), at(2)));
        }
    }
    out
}
