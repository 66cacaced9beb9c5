//! Opening a capture folder: every frame read, checked, back-projected, oriented and cropped.
//! Bad frames become per-frame warnings that name the frame, the file and the problem; the
//! good frames stay usable. Only a capture with no usable frame is an error.

use super::depth_png::{read_depth_png_sized, read_mask_png_sized};
pub use super::frame_error::{FrameError, NO_DEPTH_NEAR_BODY};
use super::manifest::{BodyModelRef, CaptureManifest, FrameRecord, MANIFEST_FILE};
use super::points::{CropOptions, CropReport, backproject, crop_to_body, estimate_normals};
use crate::body::{BodyModel, BodyParams, open_body_ref};
use crate::error::{Error, Result};
use crate::mesh::bvh::Bvh;
use glam::{Mat4, Vec3};
use rayon::prelude::*;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Depth beyond this (metres, median over the valid pixels) is a unit error, not a person.
pub const MAX_PLAUSIBLE_DEPTH: f32 = 10.0;
/// Depth below this (metres, median) is a unit error too (metres stored at millimetre scale).
pub const MIN_PLAUSIBLE_DEPTH: f32 = 0.2;
/// Fewer valid pixels than this fraction: the image is "mostly zero".
pub const MIN_VALID_FRACTION: f32 = 0.005;

#[derive(Debug, Clone, PartialEq)]
pub struct CaptureOptions {
    pub crop: CropOptions,
    /// Neighbours for the PCA normals.
    pub normal_neighbours: usize,
    /// Keep only these frame indices (in manifest order); `None` = all.
    pub frames: Option<Vec<usize>>,
    /// An SMPL `.npz` that replaces the body model the manifest names (`fit --body-model`).
    pub body_model: Option<PathBuf>,
}

impl Default for CaptureOptions {
    fn default() -> Self {
        CaptureOptions {
            crop: CropOptions::default(),
            normal_neighbours: 16,
            frames: None,
            body_model: None,
        }
    }
}

/// A usable frame: the person's oriented points in world (body) space and the fitting.
#[derive(Debug, Clone)]
pub struct CaptureFrame {
    /// Index in the manifest.
    pub index: usize,
    pub depth_file: PathBuf,
    pub params: BodyParams,
    pub camera_to_world: Mat4,
    pub points: Vec<Vec3>,
    /// Unit normals facing the camera.
    pub normals: Vec<Vec3>,
    /// Pixel index (v * width + u) of each point.
    pub pixels: Vec<u32>,
    pub crop: CropReport,
}

impl CaptureFrame {
    pub fn camera_center(&self) -> Vec3 {
        self.camera_to_world.w_axis.truncate()
    }
}

pub struct Capture {
    pub dir: PathBuf,
    pub manifest: CaptureManifest,
    /// The body model of the fittings: the embedded open body or the user's SMPL file.
    pub body: Arc<BodyModel>,
    /// The SMPL file `body` was read from (`None`: the open body).
    pub body_file: Option<PathBuf>,
    pub frames: Vec<CaptureFrame>,
    pub warnings: Vec<FrameError>,
}

impl fmt::Debug for Capture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Capture")
            .field("dir", &self.dir)
            .field("frames", &self.frames.len())
            .field("warnings", &self.warnings)
            .finish()
    }
}

/// Opening every frame of a capture at once may hold at most this much: each frame's points,
/// normals and pixel indices, counted as if every pixel were a point (28 bytes a pixel). A
/// longer capture is refused before any depth is read, naming the limit; `fit` chooses its
/// frames from it ([`super::frame_choice`]) and reads only those.
pub const MAX_OPEN_BYTES: u64 = 4 << 30;
/// Bytes a frame's points may take per pixel of its depth image: a point, a normal (12 bytes
/// each) and a pixel index (4).
const BYTES_PER_PIXEL: u64 = 28;

/// A capture folder whose manifest and body model are read and checked; its frames are read
/// on demand (a long depth video is never held whole).
pub struct CaptureSource {
    pub dir: PathBuf,
    pub manifest: CaptureManifest,
    pub body: Arc<BodyModel>,
    pub body_file: Option<PathBuf>,
    options: CaptureOptions,
}

impl CaptureSource {
    /// Read and check `capture.json` and the body model; no depth image is read.
    pub fn open(dir: impl AsRef<Path>, options: &CaptureOptions) -> Result<CaptureSource> {
        let dir = dir.as_ref();
        let dir = if dir.is_file() { dir.parent().unwrap_or(Path::new(".")) } else { dir };
        let manifest = CaptureManifest::load(dir)?;
        let (body_ref, named_by) = match &options.body_model {
            Some(path) => (BodyModelRef::Smpl(path.clone()), "given with --body-model".to_string()),
            None => (
                manifest.body_model.clone(),
                format!("named in {}", dir.join(MANIFEST_FILE).display()),
            ),
        };
        let body_file = body_ref.resolve(dir);
        let body = load_body_model(body_file.as_deref(), &named_by)?;
        check_shape_coefficients(dir, &manifest, &body, body_file.is_some())?;
        Ok(CaptureSource {
            dir: dir.to_path_buf(),
            manifest,
            body,
            body_file,
            options: options.clone(),
        })
    }

    /// Frames in the manifest.
    pub fn len(&self) -> usize {
        self.manifest.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.manifest.frames.is_empty()
    }

    /// Refuse holding `frames` frames at once when they could take more than
    /// [`MAX_OPEN_BYTES`]; checked before any depth is read.
    pub fn check_memory(&self, frames: usize) -> Result<()> {
        let intr = &self.manifest.intrinsics;
        let per_frame = intr.width as u64 * intr.height as u64 * BYTES_PER_PIXEL;
        let bytes = per_frame.saturating_mul(frames as u64);
        if bytes <= MAX_OPEN_BYTES {
            return Ok(());
        }
        let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
        Err(Error::file(
            self.dir.join(MANIFEST_FILE),
            format!(
                "too large to open whole: {frames} frames of {}x{} could hold {:.1} GiB of points, over the limit of {:.0} GiB ({} frames at this size); `fit` chooses its frames from the whole capture and reads only those (fit --frames N)",
                intr.width,
                intr.height,
                gib(bytes),
                gib(MAX_OPEN_BYTES),
                MAX_OPEN_BYTES / per_frame.max(1)
            ),
        ))
    }

    /// Read the frames `indices` (manifest indices, in that order; in parallel): each one
    /// checked, back-projected, oriented and cropped, or the reason it cannot be used.
    pub fn load(
        &self,
        indices: &[usize],
    ) -> Result<Vec<std::result::Result<CaptureFrame, FrameError>>> {
        load_frames(&self.dir, &self.manifest, &self.body, indices, &self.options)
    }

    /// Read every frame, a chunk at a time, keeping only what could not be used: how many
    /// frames are usable, and the others' reasons. Memory stays that of one chunk whatever the
    /// capture's length (`import depth`). No usable frame at all is an error.
    pub fn scan(&self, chunk: usize) -> Result<(usize, Vec<FrameError>)> {
        let all: Vec<usize> = (0..self.len()).collect();
        let (mut usable, mut warnings) = (0, Vec::new());
        for part in all.chunks(chunk.max(1)) {
            for r in self.load(part)? {
                match r {
                    Ok(_) => usable += 1,
                    Err(e) => warnings.push(e),
                }
            }
        }
        if usable == 0 {
            return Err(self.no_usable_frame(&warnings));
        }
        Ok((usable, warnings))
    }

    /// The error of a capture none of whose frames can be used, with the likely reason.
    pub fn no_usable_frame(&self, warnings: &[FrameError]) -> Error {
        no_usable_frame(&self.dir, &self.manifest, &self.body, warnings)
    }

    /// The capture of the frames read, with the reasons of those that could not be.
    pub fn into_capture(self, frames: Vec<CaptureFrame>, warnings: Vec<FrameError>) -> Capture {
        Capture {
            dir: self.dir,
            manifest: self.manifest,
            body: self.body,
            body_file: self.body_file,
            frames,
            warnings,
        }
    }
}

impl Capture {
    pub fn open(dir: impl AsRef<Path>) -> Result<Capture> {
        Self::open_with(dir, &CaptureOptions::default())
    }

    /// Every frame (or `options.frames`) read at once; refused before any depth is read when
    /// they could hold more than [`MAX_OPEN_BYTES`].
    pub fn open_with(dir: impl AsRef<Path>, options: &CaptureOptions) -> Result<Capture> {
        let source = CaptureSource::open(dir, options)?;
        let selected: Vec<usize> = match &options.frames {
            Some(list) => list.clone(),
            None => (0..source.len()).collect(),
        };
        source.check_memory(selected.len())?;
        let mut frames = Vec::new();
        let mut warnings = Vec::new();
        for r in source.load(&selected)? {
            match r {
                Ok(f) => frames.push(f),
                Err(e) => warnings.push(e),
            }
        }
        if frames.is_empty() {
            return Err(source.no_usable_frame(&warnings));
        }
        Ok(source.into_capture(frames, warnings))
    }

    /// Read the frames `indices` too (manifest indices, in parallel), each one added to the
    /// frames or, with its reason, to the warnings.
    pub fn read_frames(&mut self, indices: &[usize], options: &CaptureOptions) -> Result<()> {
        for r in load_frames(&self.dir, &self.manifest, &self.body, indices, options)? {
            match r {
                Ok(f) => self.frames.push(f),
                Err(e) => self.warnings.push(e),
            }
        }
        Ok(())
    }

    /// The error of a capture none of whose frames read so far can be used.
    pub fn no_usable_frame(&self) -> Error {
        no_usable_frame(&self.dir, &self.manifest, &self.body, &self.warnings)
    }

    /// All frames' points (world space), concatenated.
    pub fn total_points(&self) -> usize {
        self.frames.iter().map(|f| f.points.len()).sum()
    }
}

fn load_frames(
    dir: &Path,
    manifest: &CaptureManifest,
    body: &BodyModel,
    indices: &[usize],
    options: &CaptureOptions,
) -> Result<Vec<std::result::Result<CaptureFrame, FrameError>>> {
    if let Some(&bad) = indices.iter().find(|&&i| i >= manifest.frames.len()) {
        return Err(Error::invalid(format!(
            "{}: frame {bad} requested but the capture has {} frames",
            dir.display(),
            manifest.frames.len()
        )));
    }
    // One tree of the body at rest, refitted to each frame's pose (a fraction of a build;
    // the same answers).
    let rest_tree = Bvh::build(&body.mesh(body.v_template.clone()));
    Ok(indices
        .par_iter()
        .map(|&i| load_frame(dir, manifest, &manifest.frames[i], i, body, &rest_tree, options))
        .collect())
}

fn no_usable_frame(
    dir: &Path,
    manifest: &CaptureManifest,
    body: &BodyModel,
    warnings: &[FrameError],
) -> Error {
    let reasons: Vec<String> = warnings.iter().take(5).map(|w| w.to_string()).collect();
    let why = super::units::diagnose(dir, manifest, body, warnings, warnings.len())
        .map(|d| format!(": {d}"))
        .unwrap_or_default();
    Error::file(
        dir.join(MANIFEST_FILE),
        format!(
            "no usable frame in the capture ({} skipped){why}. Frames: {}",
            warnings.len(),
            reasons.join("; ")
        ),
    )
}

/// No file: the embedded open body; else the user's SMPL npz (`named_by` says where the path
/// came from, for the message when it cannot be read).
pub fn load_body_model(file: Option<&Path>, named_by: &str) -> Result<Arc<BodyModel>> {
    let Some(path) = file else {
        return Ok(Arc::new(open_body_ref().clone()));
    };
    match BodyModel::load_npz(path) {
        Err(Error::Io { path, cause }) => {
            Err(Error::file(&path, format!("cannot read the SMPL body model {named_by}: {cause}")))
        }
        Err(Error::InvalidFile { path, message }) => {
            Err(Error::file(&path, format!("{message} (the SMPL body model {named_by})")))
        }
        other => Ok(Arc::new(other?)),
    }
}

/// Shape coefficients the body model does not have mean the fittings are another model's (SMPL
/// betas read as the open body's seven MakeHuman directions): refused, naming the first frame.
/// Trailing zeros are padding and fine; fewer coefficients than the model has are zeros.
fn check_shape_coefficients(
    dir: &Path,
    manifest: &CaptureManifest,
    body: &BodyModel,
    smpl: bool,
) -> Result<()> {
    let k = body.num_betas;
    let Some((i, n)) = manifest.frames.iter().enumerate().find_map(|(i, f)| {
        let used = f.shape.iter().rposition(|&b| b != 0.0).map_or(0, |last| last + 1);
        (used > k).then_some((i, f.shape.len()))
    }) else {
        return Ok(());
    };
    let hint = if smpl {
        "is the capture fitted with another model? name it with \"body_model\": {\"smpl\": PATH} or fit --body-model PATH"
    } else {
        "SMPL fittings need the SMPL model they were made with: add \"body_model\": {\"smpl\": PATH} to capture.json or pass fit --body-model PATH"
    };
    Err(Error::file(
        dir.join(MANIFEST_FILE),
        format!(
            "frame {i} has {n} shape coefficients but the body model {} has {k}: {hint}",
            body.label
        ),
    ))
}

fn load_frame(
    dir: &Path,
    manifest: &CaptureManifest,
    record: &FrameRecord,
    index: usize,
    body: &BodyModel,
    rest_tree: &Bvh,
    options: &CaptureOptions,
) -> std::result::Result<CaptureFrame, FrameError> {
    let depth_file = dir.join(&record.depth);
    let fail = |reason: String| FrameError { index, file: depth_file.clone(), reason };
    // The fitting first: a frame without one is useless whatever its image holds.
    let params = record.params().map_err(|e| fail(format!("body fitting: {e}")))?;
    let camera_to_world = record.camera_to_world().map_err(|e| fail(e.to_string()))?;
    let intr = &manifest.intrinsics;
    let depth =
        read_depth_png_sized(&depth_file, manifest.depth_scale, Some((intr.width, intr.height)))
            .map_err(|e| fail(strip_path(&e, &depth_file)))?;
    if (depth.width, depth.height) != (intr.width, intr.height) {
        return Err(fail(format!(
            "image is {}x{} but the intrinsics say {}x{}",
            depth.width, depth.height, intr.width, intr.height
        )));
    }
    check_units(&depth.metres, manifest.depth_scale).map_err(fail)?;
    let mask = match &record.mask {
        None => None,
        Some(m) => {
            let path = dir.join(m);
            let (w, h, mask) = read_mask_png_sized(&path, Some((depth.width, depth.height)))
                .map_err(|e| fail(format!("mask: {e}")))?;
            if (w, h) != (depth.width, depth.height) {
                return Err(fail(format!(
                    "mask {} is {w}x{h}, the depth image {}x{}",
                    path.display(),
                    depth.width,
                    depth.height
                )));
            }
            Some(mask)
        }
    };
    let (points, pixels) = backproject(&depth, intr, camera_to_world, mask.as_deref());
    let posed = body.pose(&params);
    let bvh = rest_tree.refit(&body.mesh(posed.vertices));
    // World up: the body's rest up axis (Y) carried by the root orientation is not the floor's
    // up; captures are in a Y-up world, like the body model.
    let (kept, crop) =
        crop_to_body(&points, &bvh, Vec3::Y, &options.crop).map_err(|e| fail(e.to_string()))?;
    if kept.is_empty() {
        return Err(fail(format!(
            "{NO_DEPTH_NEAR_BODY} {:.0} cm of the fitted body ({} points, all background): is this frame's fitting right?",
            options.crop.max_distance * 100.0,
            points.len()
        )));
    }
    let points: Vec<Vec3> = kept.iter().map(|&i| points[i]).collect();
    let pixels: Vec<u32> = kept.iter().map(|&i| pixels[i]).collect();
    let normals =
        estimate_normals(&points, camera_to_world.w_axis.truncate(), options.normal_neighbours);
    Ok(CaptureFrame { index, depth_file, params, camera_to_world, points, normals, pixels, crop })
}

/// The frame error already names the file; keep only the problem.
fn strip_path(e: &Error, path: &Path) -> String {
    let s = e.to_string();
    let prefix = format!("{}: ", path.display());
    s.strip_prefix(&prefix).map(str::to_string).unwrap_or(s)
}

/// Depth mostly zero, or a median beyond 10 m / below 20 cm, is a unit problem.
fn check_units(metres: &[f32], depth_scale: f32) -> std::result::Result<(), String> {
    let mut valid: Vec<f32> = metres.iter().copied().filter(|&z| z > 0.0).collect();
    let fraction = valid.len() as f32 / metres.len().max(1) as f32;
    if fraction < MIN_VALID_FRACTION {
        return Err(format!(
            "depth is zero almost everywhere ({:.2}% of pixels have a value): empty or not a depth image",
            fraction * 100.0
        ));
    }
    let mid = valid.len() / 2;
    let median = *valid.select_nth_unstable_by(mid, f32::total_cmp).1;
    if median > MAX_PLAUSIBLE_DEPTH {
        return Err(format!(
            "median depth is {median:.1} m (beyond {MAX_PLAUSIBLE_DEPTH} m) at depth_scale {depth_scale}: wrong units? \
             depth_scale is PNG units per metre (1000 for millimetres, 5000 for TUM)"
        ));
    }
    if median < MIN_PLAUSIBLE_DEPTH {
        return Err(format!(
            "median depth is {median:.3} m (closer than {MIN_PLAUSIBLE_DEPTH} m) at depth_scale {depth_scale}: wrong units? \
             depth_scale is PNG units per metre (1000 for millimetres, 5000 for TUM)"
        ));
    }
    Ok(())
}
