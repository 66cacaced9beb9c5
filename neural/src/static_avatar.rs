//! A static (pose-independent) SDF avatar fitted from scratch to a capture's canonicalized
//! depth points: the "static SDF" and "from scratch" baselines of the paper, and the first
//! avatar the studio can fit, pose and export. The meta-learned hypernetwork avatar replaces
//! the static SDF with a pose-conditioned one (issue 6).

use crate::fit::{fit_sdf, sdf_values, FitOptions, Progress};
use crate::siren::{Siren, SirenConfig};
use avatar_core::body::{open_body_ref, BodyModel, BodyParams, Weights};
use avatar_core::canonical::{default_cache_dir, Canonicalizer, FieldOptions, Normalisation, SkinningField};
use avatar_core::capture::Capture;
use avatar_core::error::{Error, Result};
use avatar_core::export::AvatarSource;
use avatar_core::mesh::extract::{extract, ExtractOptions};
use avatar_core::mesh::TriMesh;
use burn::module::{Module, Param};
use burn::tensor::{Device, Tensor, TensorData};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::atomic::AtomicBool;

pub const AVATAR_FORMAT: &str = "avatar-studio-avatar";
pub const AVATAR_VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"AVATAR\0\x01";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvatarHeader {
    pub format: String,
    pub version: u32,
    pub kind: String,
    pub siren: SirenConfig,
    pub normalisation: Normalisation,
    pub betas: Vec<f32>,
    pub body_model: String,
    pub field_cells: usize,
}

pub struct StaticAvatar {
    pub header: AvatarHeader,
    pub model: Siren,
    body: BodyModel,
    field: SkinningField,
    device: Device,
    /// Marching-cubes resolution of the canonical mesh (cells along the longest side).
    pub resolution: usize,
}

/// What fitting reports.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    pub frames: usize,
    pub points: usize,
    pub dropped: usize,
    pub warnings: Vec<String>,
}

impl StaticAvatar {
    /// Fit to the first `frames` usable frames of a capture.
    pub fn fit_capture(dir: &Path, frames: usize, siren: SirenConfig, options: &FitOptions, cancel: Option<&AtomicBool>, progress: Progress) -> Result<(StaticAvatar, FitReport)> {
        let capture = Capture::open(dir)?;
        if capture.manifest.body_model != "open_body" {
            return Err(Error::invalid(format!("{}: fitting supports the embedded open body only in this build", dir.display())));
        }
        let mut warnings: Vec<String> = capture.warnings.iter().map(|w| w.to_string()).collect();
        let betas = capture.frames[0].params.betas.clone();
        let field_options = FieldOptions::default();
        let cache = default_cache_dir();
        let canon = Canonicalizer::new(&capture.body, &betas, &field_options, cache.as_deref())?;
        warnings.extend(canon.cache_warning.clone());
        let norm = canon.normalisation;
        let (mut points, mut normals, mut dropped) = (Vec::new(), Vec::new(), 0);
        let used: Vec<_> = capture.frames.iter().take(frames.max(1)).collect();
        for f in &used {
            let c = canon.frame(f);
            dropped += c.dropped + c.unsolved;
            points.extend(c.points.iter().map(|p| norm.to_unit(*p)));
            normals.extend(c.normals);
        }
        if points.len() < 100 {
            return Err(Error::invalid(format!("{}: only {} canonical points survived; cannot fit an avatar", dir.display(), points.len())));
        }
        let device = crate::cpu_training_device();
        let model = siren.init(options.seed, &device);
        // PINA's off-surface prior: far outside the canonical body (beyond any clothing) the
        // SDF must be positive, well inside the body negative. This removes the spurious
        // surfaces a from-scratch SIREN grows where no depth point constrains it.
        let body_mesh = capture.body.mesh(canon.rest.clone());
        let bvh = avatar_core::mesh::bvh::Bvh::build(&body_mesh);
        let face_normals = body_mesh.face_normals();
        let prior = |unit: &[Vec3]| -> Vec<f32> {
            unit.iter()
                .map(|q| {
                    let p = norm.from_unit(*q);
                    match bvh.closest_point(p) {
                        Some(h) if (p - h.point).dot(face_normals[h.face as usize]) >= 0.0 => if h.distance > 0.35 { 1.0 } else { 0.0 },
                        Some(h) => if h.distance > 0.03 { -1.0 } else { 0.0 },
                        None => 0.0,
                    }
                })
                .collect()
        };
        let model = fit_sdf(model, &points, &normals, options, &device, Some(&prior), cancel, progress);
        let header = AvatarHeader {
            format: AVATAR_FORMAT.into(),
            version: AVATAR_VERSION,
            kind: "static-sdf".into(),
            siren,
            normalisation: norm,
            betas: betas.clone(),
            body_model: "open_body".into(),
            field_cells: field_options.cells_along_height,
        };
        let report = FitReport { frames: used.len(), points: points.len(), dropped, warnings };
        let infer = crate::cpu_device();
        Ok((StaticAvatar { header, model: model.valid(), body: capture.body.as_ref().clone(), field: canon.field, device: infer, resolution: 128 }, report))
    }

    /// SDF in metres at canonical points (metres).
    pub fn sdf_metres(&self, points: &[Vec3]) -> Vec<f32> {
        let n = self.header.normalisation;
        let unit: Vec<Vec3> = points.iter().map(|p| n.to_unit(*p)).collect();
        sdf_values(&self.model, &unit, &self.device).into_iter().map(|f| f * n.metres_per_unit()).collect()
    }

    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let header = serde_json::to_vec(&self.header).map_err(|e| Error::invalid(e.to_string()))?;
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(header.len() as u64).to_le_bytes());
        out.extend_from_slice(&header);
        let (w, b) = self.model.params();
        for t in w.iter().map(|t| t.to_data()).chain(b.iter().map(|t| t.to_data())) {
            for v in t.as_slice::<f32>().map_err(|e| Error::invalid(format!("{e:?}")))? {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        avatar_core::io::write_bytes_atomic(path, &out)
    }

    pub fn load(path: impl AsRef<Path>) -> Result<StaticAvatar> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            return Err(Error::file(path, "not an Avatar Studio avatar file"));
        }
        let len = u64::from_le_bytes(bytes[8..16].try_into().unwrap()) as usize;
        let body_start = 16usize.checked_add(len).filter(|&e| e <= bytes.len()).ok_or_else(|| Error::file(path, "truncated avatar file (header)"))?;
        let header: AvatarHeader = serde_json::from_slice(&bytes[16..body_start]).map_err(|e| Error::file(path, format!("bad avatar header: {e}")))?;
        if header.format != AVATAR_FORMAT || header.version != AVATAR_VERSION {
            return Err(Error::file(
                path,
                format!("avatar format {:?} version {} is not supported by this build (it reads {AVATAR_FORMAT:?} version {AVATAR_VERSION})", header.format, header.version),
            ));
        }
        if header.kind != "static-sdf" {
            return Err(Error::file(path, format!("avatar kind {:?} is not supported by this build", header.kind)));
        }
        let widths = header.siren.widths();
        let expected: usize = header.siren.num_params();
        if bytes.len() != body_start + 4 * expected {
            return Err(Error::file(path, format!("truncated avatar file: {} weight bytes, expected {}", bytes.len() - body_start, 4 * expected)));
        }
        let floats: Vec<f32> = bytes[body_start..].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        if floats.iter().any(|v| !v.is_finite()) {
            return Err(Error::file(path, "avatar weights contain NaN or infinity"));
        }
        let device = crate::cpu_device();
        let mut offset = 0;
        let mut weights = Vec::new();
        for p in widths.windows(2) {
            let n = p[0] * p[1];
            weights.push(Param::from_tensor(Tensor::from_data(TensorData::new(floats[offset..offset + n].to_vec(), [p[0], p[1]]), &device)));
            offset += n;
        }
        let mut biases = Vec::new();
        for p in widths.windows(2) {
            biases.push(Param::from_tensor(Tensor::from_data(TensorData::new(floats[offset..offset + p[1]].to_vec(), [p[1]]), &device)));
            offset += p[1];
        }
        let body = open_body_ref().clone();
        let field_options = FieldOptions { cells_along_height: header.field_cells, ..FieldOptions::default() };
        let cache = default_cache_dir();
        let field = Canonicalizer::new(&body, &header.betas, &field_options, cache.as_deref())?.field;
        Ok(StaticAvatar { header, model: Siren { weights, biases }, body, field, device, resolution: 128 })
    }
}

impl AvatarSource for StaticAvatar {
    fn body(&self) -> &BodyModel {
        &self.body
    }
    fn betas(&self) -> &[f32] {
        &self.header.betas
    }
    /// Pose-independent: the same canonical surface for every pose (coarse-to-fine marching
    /// cubes over the normalised cube, largest component).
    fn canonical_mesh(&self, _params: &BodyParams) -> Result<TriMesh> {
        let n = self.header.normalisation;
        let (lo, hi) = (n.from_unit(Vec3::splat(-1.0)), n.from_unit(Vec3::splat(1.0)));
        Ok(extract(|p: &[Vec3]| self.sdf_metres(p), &ExtractOptions::new(lo, hi, self.resolution))?.mesh)
    }
    fn sdf(&self, _params: &BodyParams, points: &[Vec3]) -> Result<Vec<f32>> {
        Ok(self.sdf_metres(points))
    }
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights> {
        points.iter().map(|&p| self.field.weights_at(p)).collect()
    }
    /// The surface does not change with the pose: reference vertices already lie on it.
    fn project(&self, _params: &BodyParams, points: &[Vec3], _steps: usize) -> Result<Vec<Vec3>> {
        Ok(points.to_vec())
    }
}
