//! SMPL-style body parameters: 24 x 3 axis-angle pose, shape coefficients, translation.
//! Read from JSON (`{"pose": [72 numbers] or [[x,y,z] x 24], "betas": [...], "trans": [x,y,z]}`).

use super::skeleton::NUM_JOINTS;
use crate::error::{Error, Result};
use glam::{Mat3, Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Largest accepted joint rotation (radians). Axis-angle beyond 2 pi is a unit error
/// (degrees passed as radians) rather than a real pose.
pub const MAX_JOINT_ANGLE: f32 = 2.0 * std::f32::consts::PI + 1e-3;
/// Largest accepted shape coefficient in magnitude: SMPL's betas are in standard deviations
/// (|b| <= 5 covers real people), the open body's in slider units (-1..1); beyond 10 the body
/// is no longer a person (1e4 made a 4 km body).
pub const MAX_ABS_BETA: f32 = 10.0;
/// At most this many shape coefficients (SMPL-X has 400).
pub const MAX_BETAS: usize = 512;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodyParams {
    /// Axis-angle rotation of each joint relative to its parent (joint 0 = global orientation).
    pub pose: [Vec3; NUM_JOINTS],
    /// Shape coefficients (may be shorter or longer than the model's; extras are ignored).
    #[serde(default)]
    pub betas: Vec<f32>,
    /// Global translation in metres.
    #[serde(default)]
    pub trans: Vec3,
}

impl Default for BodyParams {
    fn default() -> Self {
        BodyParams { pose: [Vec3::ZERO; NUM_JOINTS], betas: Vec::new(), trans: Vec3::ZERO }
    }
}

#[derive(Deserialize)]
struct ParamsFile {
    #[serde(alias = "poses", alias = "body_pose_72")]
    pose: Option<serde_json::Value>,
    #[serde(alias = "shape", alias = "betas_")]
    betas: Option<Vec<f64>>,
    #[serde(alias = "transl", alias = "translation")]
    trans: Option<Vec<f64>>,
}

impl BodyParams {
    /// Rotation matrix of each joint.
    pub fn rotations(&self) -> [Mat3; NUM_JOINTS] {
        self.pose.map(|aa| Mat3::from_quat(Quat::from_scaled_axis(aa)))
    }

    /// Build from a flat 72-vector of axis-angles.
    pub fn from_flat(pose: &[f32], betas: Vec<f32>, trans: Vec3) -> Result<Self> {
        if pose.len() != 3 * NUM_JOINTS {
            return Err(Error::invalid(format!(
                "pose has {} values, expected 72 (24 x 3 axis-angle)",
                pose.len()
            )));
        }
        let mut p = [Vec3::ZERO; NUM_JOINTS];
        for (j, c) in p.iter_mut().enumerate() {
            *c = Vec3::new(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
        }
        let params = BodyParams { pose: p, betas, trans };
        params.validate()?;
        Ok(params)
    }

    /// Flat 72-vector of axis-angles.
    pub fn flat_pose(&self) -> Vec<f32> {
        self.pose.iter().flat_map(|v| v.to_array()).collect()
    }

    /// Reject NaN, infinities and angles that cannot be radians.
    pub fn validate(&self) -> Result<()> {
        for (j, aa) in self.pose.iter().enumerate() {
            if !aa.is_finite() {
                return Err(Error::invalid(format!(
                    "pose of joint {j} ({}) is not finite",
                    super::JOINT_NAMES[j]
                )));
            }
            if aa.length() > MAX_JOINT_ANGLE {
                return Err(Error::invalid(format!(
                    "pose of joint {j} ({}) rotates {:.1} rad: axis-angle must be in radians",
                    super::JOINT_NAMES[j],
                    aa.length()
                )));
            }
        }
        if let Some(i) = self.betas.iter().position(|b| !b.is_finite()) {
            return Err(Error::invalid(format!("shape coefficient {i} is not finite")));
        }
        check_betas(&self.betas)?;
        if !self.trans.is_finite() {
            return Err(Error::invalid("translation is not finite"));
        }
        if self.trans.length() > 1000.0 {
            return Err(Error::invalid(format!(
                "translation {} is over 1 km: wrong units?",
                self.trans
            )));
        }
        Ok(())
    }

    /// Parse the JSON pose format.
    pub fn from_json_str(text: &str) -> Result<Self> {
        let file: ParamsFile = serde_json::from_str(text)
            .map_err(|e| Error::invalid(format!("not a valid pose JSON ({e})")))?;
        let pose: Vec<f32> = match file.pose {
            None => vec![0.0; 72],
            Some(value) => flatten_numbers(&value)?,
        };
        let betas = file.betas.unwrap_or_default().into_iter().map(|b| b as f32).collect();
        let trans = match file.trans {
            None => Vec3::ZERO,
            Some(t) if t.len() == 3 => Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32),
            Some(t) => {
                return Err(Error::invalid(format!("trans has {} values, expected 3", t.len())));
            }
        };
        Self::from_flat(&pose, betas, trans)
    }

    pub fn load_json(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::from_json_str(&text).map_err(|e| e.in_file(path))
    }
}

/// Shape coefficients within [`MAX_ABS_BETA`] and at most [`MAX_BETAS`] of them (NaN refused).
pub fn check_betas(betas: &[f32]) -> Result<()> {
    if betas.len() > MAX_BETAS {
        return Err(Error::invalid(format!(
            "{} shape coefficients, at most {MAX_BETAS} are read",
            betas.len()
        )));
    }
    if let Some((i, b)) = betas.iter().enumerate().find(|(_, b)| !(b.abs() <= MAX_ABS_BETA)) {
        return Err(Error::invalid(format!(
            "shape coefficient {i} is {b}: not a plausible body shape (|beta| <= {MAX_ABS_BETA})"
        )));
    }
    Ok(())
}

fn flatten_numbers(value: &serde_json::Value) -> Result<Vec<f32>> {
    let mut out = Vec::new();
    fn walk(v: &serde_json::Value, out: &mut Vec<f32>) -> Result<()> {
        match v {
            serde_json::Value::Number(n) => {
                out.push(
                    n.as_f64().ok_or_else(|| Error::invalid("pose holds a non-numeric value"))?
                        as f32,
                );
                Ok(())
            }
            serde_json::Value::Array(a) => a.iter().try_for_each(|x| walk(x, out)),
            serde_json::Value::Null => {
                Err(Error::invalid("pose holds null (NaN is not valid JSON; fix the fitting)"))
            }
            _ => Err(Error::invalid("pose must be an array of numbers")),
        }
    }
    walk(value, &mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_nested_and_flat_agree() {
        let mut nested = vec![vec![0.0f32; 3]; 24];
        nested[18] = vec![0.0, 1.2, 0.0];
        let a = BodyParams::from_json_str(
            &serde_json::json!({"pose": nested, "trans": [0, 1, 0]}).to_string(),
        )
        .unwrap();
        let mut flat = vec![0.0f32; 72];
        flat[55] = 1.2;
        let b = BodyParams::from_json_str(
            &serde_json::json!({"poses": flat, "transl": [0, 1, 0]}).to_string(),
        )
        .unwrap();
        assert_eq!(a, b);
        assert_eq!(a.pose[18], Vec3::new(0.0, 1.2, 0.0));
    }

    #[test]
    fn bad_poses_are_rejected_with_reason() {
        let e = BodyParams::from_json_str(r#"{"pose": [1, 2, 3]}"#).unwrap_err().to_string();
        assert!(e.contains("72"), "{e}");
        let mut degrees = vec![0.0f32; 72];
        degrees[55] = 90.0;
        let e = BodyParams::from_json_str(&serde_json::json!({ "pose": degrees }).to_string())
            .unwrap_err()
            .to_string();
        assert!(e.contains("radians") && e.contains("left_elbow"), "{e}");
        let e = BodyParams::from_json_str(r#"{"pose": [null]}"#).unwrap_err().to_string();
        assert!(e.contains("null"), "{e}");
    }
}
