//! Ground truth written beside a synthetic capture (`gt/`): the clothed mesh of every frame,
//! posed and canonical, per-vertex body-part labels and per-frame visibility.
//!
//! ```text
//! gt/ground_truth.json  format, version, outfit, subject, clip, num_frames, num_vertices
//! gt/mesh.npz           faces (F,3), vertex_joint (V), weights (V,24), rest (V,3)
//! gt/frames.npz         posed (N,V,3), canonical (N,V,3), visible (N,V)
//! ```
//! All arrays are float32 (integers stored exactly).

use crate::body::skeleton::BodyPart;
use crate::body::{NUM_JOINTS, Weights};
use crate::error::{Error, Result};
use crate::io::npz::{Npz, write_f32_npz};
use crate::mesh::TriMesh;
use crate::mesh::barycentric;
use crate::mesh::bvh::Bvh;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const GT_DIR: &str = "gt";
pub const GT_FORMAT: &str = "avatar-studio-gt";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GtHeader {
    pub format: String,
    pub version: u32,
    pub outfit: String,
    pub subject_seed: u64,
    pub betas: Vec<f32>,
    pub clip: String,
    pub num_frames: usize,
    pub num_vertices: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct GtFrame {
    pub posed: Vec<Vec3>,
    pub canonical: Vec<Vec3>,
    pub visible: Vec<bool>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct GroundTruth {
    pub header: GtHeader,
    pub faces: Vec<[u32; 3]>,
    pub vertex_joint: Vec<u8>,
    pub weights: Vec<Weights>,
    pub rest: Vec<Vec3>,
    pub frames: Vec<GtFrame>,
}

fn flat(v: &[Vec3]) -> Vec<f32> {
    v.iter().flat_map(|p| p.to_array()).collect()
}

impl GroundTruth {
    pub fn save(&self, capture_dir: impl AsRef<Path>) -> Result<()> {
        let dir = capture_dir.as_ref().join(GT_DIR);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let (n, v) = (self.frames.len(), self.rest.len());
        let json = serde_json::to_string_pretty(&self.header)
            .map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::write_bytes_atomic(dir.join("ground_truth.json"), json.as_bytes())?;
        write_f32_npz(
            dir.join("mesh.npz"),
            &[
                (
                    "faces",
                    vec![self.faces.len(), 3],
                    self.faces.iter().flat_map(|f| f.map(|i| i as f32)).collect(),
                ),
                ("vertex_joint", vec![v], self.vertex_joint.iter().map(|&j| j as f32).collect()),
                (
                    "weights",
                    vec![v, NUM_JOINTS],
                    self.weights.iter().flat_map(|w| w.iter().copied()).collect(),
                ),
                ("rest", vec![v, 3], flat(&self.rest)),
            ],
        )?;
        write_f32_npz(
            dir.join("frames.npz"),
            &[
                ("posed", vec![n, v, 3], self.frames.iter().flat_map(|f| flat(&f.posed)).collect()),
                (
                    "canonical",
                    vec![n, v, 3],
                    self.frames.iter().flat_map(|f| flat(&f.canonical)).collect(),
                ),
                (
                    "visible",
                    vec![n, v],
                    self.frames
                        .iter()
                        .flat_map(|f| f.visible.iter().map(|&b| b as u8 as f32))
                        .collect(),
                ),
            ],
        )
    }

    /// Load `gt/` from a capture folder.
    pub fn load(capture_dir: impl AsRef<Path>) -> Result<GroundTruth> {
        let dir = capture_dir.as_ref().join(GT_DIR);
        let hp = dir.join("ground_truth.json");
        let text = std::fs::read_to_string(&hp).map_err(|e| Error::io(&hp, e))?;
        let header: GtHeader = serde_json::from_str(&text)
            .map_err(|e| Error::file(&hp, format!("not a ground-truth header: {e}")))?;
        if header.format != GT_FORMAT {
            return Err(Error::file(
                &hp,
                format!("format is {:?}, expected {GT_FORMAT:?}", header.format),
            ));
        }
        let (n, v) = (header.num_frames, header.num_vertices);
        let mp = dir.join("mesh.npz");
        let mut mesh = Npz::open(&mp)?;
        let shape_err = |p: &Path, k: &str, got: &[usize]| {
            Error::file(
                p,
                format!(
                    "'{k}' has shape {got:?}, which does not match the header ({n} frames, {v} vertices)"
                ),
            )
        };
        let faces = mesh.require("faces")?;
        let vj = mesh.require("vertex_joint")?;
        let w = mesh.require("weights")?;
        let rest = mesh.require("rest")?;
        if vj.shape != [v] {
            return Err(shape_err(&mp, "vertex_joint", &vj.shape));
        }
        if w.shape != [v, NUM_JOINTS] {
            return Err(shape_err(&mp, "weights", &w.shape));
        }
        if rest.shape != [v, 3] {
            return Err(shape_err(&mp, "rest", &rest.shape));
        }
        let to_vec3 = |d: &[f64]| {
            d.chunks_exact(3)
                .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
                .collect::<Vec<_>>()
        };
        let faces: Vec<[u32; 3]> =
            faces.data.chunks_exact(3).map(|c| [c[0] as u32, c[1] as u32, c[2] as u32]).collect();
        if faces.iter().flatten().any(|&i| i as usize >= v) {
            return Err(Error::file(&mp, "'faces' refers to a vertex beyond 'rest'"));
        }
        let fp = dir.join("frames.npz");
        let mut fr = Npz::open(&fp)?;
        let posed = fr.require("posed")?;
        let canonical = fr.require("canonical")?;
        let visible = fr.require("visible")?;
        for (k, a) in [("posed", &posed), ("canonical", &canonical)] {
            if a.shape != [n, v, 3] {
                return Err(shape_err(&fp, k, &a.shape));
            }
        }
        if visible.shape != [n, v] {
            return Err(shape_err(&fp, "visible", &visible.shape));
        }
        let frames = (0..n)
            .map(|i| GtFrame {
                posed: to_vec3(&posed.data[i * v * 3..(i + 1) * v * 3]),
                canonical: to_vec3(&canonical.data[i * v * 3..(i + 1) * v * 3]),
                visible: visible.data[i * v..(i + 1) * v].iter().map(|&x| x > 0.5).collect(),
            })
            .collect();
        Ok(GroundTruth {
            header,
            faces,
            vertex_joint: vj.data.iter().map(|&x| x as u8).collect(),
            weights: w
                .data
                .chunks_exact(NUM_JOINTS)
                .map(|c| std::array::from_fn(|j| c[j] as f32))
                .collect(),
            rest: to_vec3(&rest.data),
            frames,
        })
    }

    pub fn posed_mesh(&self, i: usize) -> TriMesh {
        TriMesh::new(self.frames[i].posed.clone(), self.faces.clone())
    }

    pub fn canonical_mesh(&self, i: usize) -> TriMesh {
        TriMesh::new(self.frames[i].canonical.clone(), self.faces.clone())
    }

    /// The paper's metric region: clothed body parts (hands, wrists, feet, ankles, neck and head
    /// excluded).
    pub fn metric_mask(&self) -> Vec<bool> {
        self.vertex_joint.iter().map(|&j| BodyPart::is_clothed_joint(j as usize)).collect()
    }

    /// The true canonical position of a point on (or near) the posed surface of frame `i`:
    /// the same barycentric coordinates on the canonical mesh.
    pub fn canonical_of_posed_point(&self, i: usize, bvh: &Bvh, p: Vec3) -> Option<Vec3> {
        let hit = bvh.closest_point(p)?;
        let f = self.faces[hit.face as usize].map(|k| k as usize);
        let posed = &self.frames[i].posed;
        let bary = barycentric(hit.point, posed[f[0]], posed[f[1]], posed[f[2]]);
        let c = &self.frames[i].canonical;
        Some(c[f[0]] * bary.x + c[f[1]] * bary.y + c[f[2]] * bary.z)
    }
}
