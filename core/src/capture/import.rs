//! `import depth`: a folder of 16-bit depth PNGs plus per-frame SMPL fittings (an AMASS-style
//! npz, or a folder of JSON pose files, one per frame) becomes a capture folder. The frames are
//! checked by reading them in place first (a chunk at a time: memory stays flat in the
//! video's length), so every problem is reported with `Capture::open`'s message naming the
//! input file; then the images are copied and
//! `capture.json` is written. See docs/capture-format.md.

use super::amass::{AmassSequence, read_amass, z_up_to_y_up};
use super::depth_png::read_depth_png;
use super::manifest::{CaptureManifest, FrameRecord, Intrinsics};
use super::open::{CaptureOptions, CaptureSource, FrameError};
use crate::body::{BodyModel, BodyParams};
use crate::error::{Error, Result};
use glam::{Mat4, Quat};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The pinhole part of the intrinsics (the image size comes from the images).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct Pinhole {
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
}

impl Pinhole {
    /// `fx,fy,cx,cy` in pixels, or the path of a JSON file with those keys (and optionally
    /// `width`, `height`, which must then match the images).
    pub fn parse(spec: &str) -> Result<Pinhole> {
        let parts: Vec<&str> = spec.split(',').map(str::trim).collect();
        if parts.len() == 4 && parts.iter().all(|p| p.parse::<f32>().is_ok()) {
            let v: Vec<f32> = parts.iter().map(|p| p.parse().expect("checked")).collect();
            return Ok(Pinhole {
                fx: v[0],
                fy: v[1],
                cx: v[2],
                cy: v[3],
                width: None,
                height: None,
            });
        }
        let path = Path::new(spec);
        if !path.is_file() {
            return Err(Error::invalid(format!(
                "intrinsics {spec:?}: give fx,fy,cx,cy in pixels or a JSON file with those keys"
            )));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        serde_json::from_str(&text).map_err(|e| {
            Error::file(
                path,
                format!(
                    "not an intrinsics file ({{\"fx\", \"fy\", \"cx\", \"cy\"}} in pixels): {e}"
                ),
            )
        })
    }
}

/// What `import depth` reads.
#[derive(Debug, Clone)]
pub struct DepthImport {
    /// Folder of 16-bit depth PNGs (sorted by name, numbers in names compared as numbers).
    pub depth_dir: PathBuf,
    /// An AMASS-style `.npz`, or a folder of JSON pose files (one per image, same order).
    pub fittings: PathBuf,
    pub pinhole: Pinhole,
    /// PNG units per metre: 1000 (millimetres) or 5000 (TUM).
    pub depth_scale: f32,
    /// The fittings are Z-up (AMASS's world): turn them to the studio's Y-up.
    pub z_up: bool,
    /// Camera-to-world of every frame (row-major 4x4 in the file); `None` = the fittings are
    /// in the depth camera's coordinates (OpenCV axes; the capture's world is then the camera's
    /// turned 180 degrees about X, Y up).
    pub cameras: Option<PathBuf>,
    pub fps: Option<f32>,
    /// The SMPL-family model file (.npz) the fittings were made with; the capture names it
    /// (`"body_model": {"smpl": ABSOLUTE PATH}`). `None`: the embedded open body.
    pub body_model: Option<PathBuf>,
}

/// What was imported.
#[derive(Debug)]
pub struct ImportReport {
    pub frames: usize,
    pub usable: usize,
    /// Frames `fit` will skip, each naming the input file and the reason.
    pub warnings: Vec<FrameError>,
    /// The one-line diagnosis when most frames miss the body (units, camera, axes).
    pub diagnosis: Option<String>,
}

/// Files in `dir` with extension `ext`, in natural order (`2.png` before `10.png`).
pub fn list_files(dir: &Path, ext: &str) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| e.eq_ignore_ascii_case(ext))
        })
        .collect();
    files.sort_by_key(|p| natural_key(p));
    Ok(files)
}

/// Name split into text and number runs, numbers compared by value.
fn natural_key(p: &Path) -> Vec<(String, u128)> {
    let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut key = Vec::new();
    let mut text = String::new();
    let mut digits = String::new();
    for c in name.chars() {
        if c.is_ascii_digit() {
            digits.push(c);
        } else {
            if !digits.is_empty() {
                key.push((std::mem::take(&mut text), digits.parse().unwrap_or(u128::MAX)));
                digits.clear();
            }
            text.push(c);
        }
    }
    key.push((text, digits.parse().unwrap_or(0)));
    key
}

/// Read the fittings: an AMASS-style npz, or a folder of JSON pose files.
pub fn read_fittings(path: &Path) -> Result<AmassSequence> {
    if path.is_dir() {
        let files = list_files(path, "json")?;
        if files.is_empty() {
            return Err(Error::file(path, "no .json pose files in this folder"));
        }
        let frames = files.iter().map(BodyParams::load_json).collect::<Result<Vec<_>>>()?;
        return Ok(AmassSequence { fps: 30.0, frames });
    }
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("npz") => read_amass(path),
        _ => Err(Error::file(
            path,
            "fittings must be an AMASS-style .npz or a folder of JSON pose files",
        )),
    }
}

/// Camera-to-world matrices: one 16-number row-major matrix for every frame, or a list of them.
fn read_cameras(path: &Path, frames: usize) -> Result<Vec<Mat4>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::file(path, format!("not JSON: {e}")))?;
    let one = |v: &serde_json::Value, i: usize| -> Result<Mat4> {
        let nums: Option<Vec<f32>> =
            v.as_array().map(|a| a.iter().filter_map(|x| x.as_f64().map(|x| x as f32)).collect());
        let nums = nums.filter(|n| n.len() == 16).ok_or_else(|| {
            Error::file(path, format!("matrix {i}: expected 16 numbers (row-major 4x4)"))
        })?;
        let mut rec = FrameRecord {
            depth: String::new(),
            mask: None,
            pose: None,
            shape: vec![],
            translation: None,
            camera_to_world: None,
        };
        rec.camera_to_world = Some(nums.try_into().expect("16 numbers"));
        rec.camera_to_world().map_err(|e| Error::file(path, format!("matrix {i}: {e}")))
    };
    match value.as_array() {
        Some(a) if a.first().is_some_and(|x| x.is_array()) => {
            if a.len() != frames {
                return Err(Error::file(path, format!("{} matrices for {frames} frames", a.len())));
            }
            a.iter().enumerate().map(|(i, m)| one(m, i)).collect()
        }
        _ => Ok(vec![one(&value, 0)?; frames]),
    }
}

/// Refuse an output folder that holds anything, or that is one of the inputs.
pub fn check_output_dir(out: &Path, inputs: &[&Path]) -> Result<()> {
    let canon = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    for input in inputs {
        let (a, b) = (canon(out), canon(input));
        if a == b || b.starts_with(&a) {
            return Err(Error::invalid(format!(
                "the output {} would overwrite the input {}",
                out.display(),
                input.display()
            )));
        }
    }
    if out.exists() {
        let empty =
            out.is_dir() && std::fs::read_dir(out).map_err(|e| Error::io(out, e))?.next().is_none();
        if !empty {
            return Err(Error::file(
                out,
                "the output folder exists and is not empty: choose a new folder",
            ));
        }
    }
    Ok(())
}

/// Frames read at once while an import checks them (a chunk's points are dropped before the
/// next is read).
const IMPORT_CHUNK: usize = 32;

/// Import a depth folder with its fittings into the capture folder `out`.
pub fn import_depth(job: &DepthImport, out: &Path) -> Result<ImportReport> {
    let mut inputs = vec![job.depth_dir.as_path(), job.fittings.as_path()];
    if let Some(c) = &job.cameras {
        inputs.push(c);
    }
    if let Some(m) = &job.body_model {
        inputs.push(m);
    }
    check_output_dir(out, &inputs)?;
    // The fittings' body: the user's model (read now, so that a bad file is named before
    // anything else is done) or the open body.
    let own_model = job.body_model.as_ref().map(BodyModel::load_npz).transpose()?;
    let body: &BodyModel = own_model.as_ref().unwrap_or(crate::body::open_body_ref());
    let images = list_files(&job.depth_dir, "png")?;
    if images.is_empty() {
        return Err(Error::file(&job.depth_dir, "no .png depth images in this folder"));
    }
    let mut seq = read_fittings(&job.fittings)?;
    if images.len() != seq.frames.len() {
        return Err(Error::invalid(format!(
            "{} depth images in {} but {} fitted frames in {}: they must pair one to one (in name order)",
            images.len(),
            job.depth_dir.display(),
            seq.frames.len(),
            job.fittings.display()
        )));
    }
    if job.z_up {
        z_up_to_y_up(&mut seq, body);
    }
    // The image size from the first readable image (the others are checked when opened).
    let first = read_depth_png(&images[0], job.depth_scale)?;
    let p = job.pinhole;
    for (what, given, actual) in
        [("width", p.width, first.width), ("height", p.height, first.height)]
    {
        if given.is_some_and(|g| g != actual) {
            return Err(Error::file(
                &images[0],
                format!("image {what} is {actual} but the intrinsics say {}", given.unwrap_or(0)),
            ));
        }
    }
    let intrinsics = Intrinsics {
        fx: p.fx,
        fy: p.fy,
        cx: p.cx,
        cy: p.cy,
        width: first.width,
        height: first.height,
    };
    let cameras = match &job.cameras {
        Some(path) => read_cameras(path, images.len())?,
        None => {
            // Fittings in OpenCV camera axes (y down): the capture's world is the camera's
            // turned 180 degrees about X, so that it is Y up like the body (floor removal needs
            // the up axis), and the fittings are turned with it.
            let flip = Quat::from_rotation_x(std::f32::consts::PI);
            for p in &mut seq.frames {
                let j0 = body.rest_joints(&p.betas)[0];
                p.pose[0] = (flip * Quat::from_scaled_axis(p.pose[0])).to_scaled_axis();
                p.trans = flip * (p.trans + j0) - j0;
            }
            vec![Mat4::from_quat(flip); images.len()]
        }
    };
    let mut manifest = CaptureManifest::new(intrinsics, job.depth_scale);
    manifest.fps = Some(job.fps.unwrap_or(seq.fps));
    if let Some(m) = &job.body_model {
        let absolute = std::fs::canonicalize(m).map_err(|e| Error::io(m, e))?;
        manifest.body_model = super::manifest::BodyModelRef::Smpl(absolute);
    }
    for (i, (image, params)) in images.iter().zip(&seq.frames).enumerate() {
        let mut rec = FrameRecord {
            depth: image.to_string_lossy().into_owned(),
            mask: None,
            pose: Some(params.flat_pose()),
            shape: params.betas.clone(),
            translation: Some(params.trans.to_array()),
            camera_to_world: None,
        };
        rec.set_camera_to_world(cameras[i]);
        manifest.frames.push(rec);
    }
    manifest.validate()?;

    // Read the frames where they are (absolute paths) so that problems name the input files;
    // a chunk at a time, so that a long depth video is never held whole.
    let staging = staging_dir(out);
    let checked = (|| {
        let abs: Vec<PathBuf> = images
            .iter()
            .map(|p| std::fs::canonicalize(p).map_err(|e| Error::io(p, e)))
            .collect::<Result<_>>()?;
        let mut probe = manifest.clone();
        for (rec, path) in probe.frames.iter_mut().zip(&abs) {
            rec.depth = path.to_string_lossy().into_owned();
        }
        std::fs::create_dir_all(&staging).map_err(|e| Error::io(&staging, e))?;
        probe.save(&staging)?;
        let source = CaptureSource::open(&staging, &CaptureOptions::default())?;
        let (usable, warnings) = source.scan(IMPORT_CHUNK)?;
        let diagnosis = super::units::diagnose(
            &source.dir,
            &source.manifest,
            &source.body,
            &warnings,
            source.len(),
        );
        Ok((usable, warnings, diagnosis))
    })();
    let _ = std::fs::remove_dir_all(&staging);
    let (usable, warnings, diagnosis) = checked.map_err(|e| match e {
        Error::InvalidFile { path, message } if path.starts_with(&staging) => {
            Error::file(&job.depth_dir, message)
        }
        other => other,
    })?;

    // Copy the images and write the manifest.
    for (i, (rec, image)) in manifest.frames.iter_mut().zip(&images).enumerate() {
        let bytes = std::fs::read(image).map_err(|e| Error::io(image, e))?;
        rec.depth = format!("depth/{i:06}.png");
        crate::io::write_bytes_atomic(out.join(&rec.depth), &bytes)?;
    }
    manifest.save(out)?;
    Ok(ImportReport { frames: manifest.frames.len(), usable, warnings, diagnosis })
}

/// A hidden sibling of `out` for checking the frames before anything is written there.
pub(crate) fn staging_dir(out: &Path) -> PathBuf {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "capture".into());
    out.with_file_name(format!(".{name}.import-{}", std::process::id()))
}
