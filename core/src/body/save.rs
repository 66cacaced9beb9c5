//! Writing a body model as an SMPL-layout `.npz` (float32, the keys `load.rs` reads): the open
//! body re-expressed as a user's SMPL file, for tests and for tools that want the studio's body
//! in SMPL form. A frozen body has no regressor or shape directions and cannot be written.

use super::model::{BodyModel, NUM_POSE_FEATURES};
use super::skeleton::{NUM_JOINTS, SMPL_PARENTS};
use crate::error::{Error, Result};
use crate::io::npz::write_f32_npz;
use glam::Vec3;
use std::path::Path;

impl BodyModel {
    /// Write the model as an SMPL-layout npz (atomic).
    pub fn save_npz(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        if self.is_frozen() {
            return Err(Error::file(
                path,
                "a frozen body (one shape, no joint regressor) cannot be written as a body model",
            ));
        }
        let nv = self.num_vertices();
        let flat = |v: &[Vec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
        // (V, 3, K) row-major from the [v][k] layout.
        let blocks = |dirs: &[Vec3], k: usize| {
            let mut out = vec![0f32; nv * 3 * k];
            for v in 0..nv {
                for i in 0..k {
                    let d = dirs[v * k + i];
                    for c in 0..3 {
                        out[(v * 3 + c) * k + i] = d[c];
                    }
                }
            }
            out
        };
        let mut jreg = vec![0f32; NUM_JOINTS * nv];
        for (j, row) in self.j_regressor.iter().enumerate() {
            for &(v, w) in row {
                jreg[j * nv + v as usize] = w;
            }
        }
        let mut kintree: Vec<f32> = SMPL_PARENTS.iter().map(|&p| p as f32).collect();
        kintree.extend((0..NUM_JOINTS).map(|j| j as f32));
        let mut arrays = vec![
            ("v_template", vec![nv, 3], flat(&self.v_template)),
            ("shapedirs", vec![nv, 3, self.num_betas], blocks(&self.shapedirs, self.num_betas)),
            ("J_regressor", vec![NUM_JOINTS, nv], jreg),
            ("weights", vec![nv, NUM_JOINTS], self.weights.iter().flatten().copied().collect()),
            ("kintree_table", vec![2, NUM_JOINTS], kintree),
            (
                "f",
                vec![self.faces.len(), 3],
                self.faces.iter().flatten().map(|&i| i as f32).collect(),
            ),
        ];
        if let Some(posedirs) = &self.posedirs {
            arrays.push((
                "posedirs",
                vec![nv, 3, NUM_POSE_FEATURES],
                blocks(posedirs, NUM_POSE_FEATURES),
            ));
        }
        write_f32_npz(path, &arrays)
    }
}

#[cfg(test)]
mod tests {
    use crate::body::{BodyModel, BodyParams, open_body_lowpoly_ref};
    use glam::Vec3;

    #[test]
    fn the_open_body_round_trips_through_smpl_layout() {
        let body = open_body_lowpoly_ref();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("open_body_smpl.npz");
        body.save_npz(&path).unwrap();
        let back = BodyModel::load_npz(&path).unwrap();
        assert_eq!(
            (back.num_vertices(), back.num_betas, back.faces.clone()),
            (body.num_vertices(), body.num_betas, body.faces.clone())
        );
        let mut p = BodyParams { betas: vec![0.5, -0.3, 0.2], ..Default::default() };
        p.pose[16] = Vec3::new(0.0, 0.0, -0.9);
        p.pose[2] = Vec3::new(-0.4, 0.1, 0.0);
        let (a, b) = (body.pose(&p), back.pose(&p));
        let worst =
            a.vertices.iter().zip(&b.vertices).map(|(x, y)| x.distance(*y)).fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{worst} m");
        assert!(body.frozen(&[]).save_npz(&path).unwrap_err().to_string().contains("frozen"));
    }
}
