//! `capture.json`: intrinsics, depth scale and one record per frame (depth image, optional mask,
//! the frame's SMPL fitting, optional camera-to-world). See docs/capture-format.md.

use crate::body::{BodyParams, NUM_JOINTS};
use crate::error::{Error, Result};
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub const MANIFEST_FILE: &str = "capture.json";
pub const FORMAT_NAME: &str = "avatar-studio-capture";
pub const FORMAT_VERSION: u32 = 1;
/// Depth PNG units per metre: millimetres (Kinect, most datasets).
pub const DEPTH_SCALE_MM: f32 = 1000.0;
/// Depth PNG units per metre in the TUM RGB-D datasets.
pub const DEPTH_SCALE_TUM: f32 = 5000.0;
/// A manifest larger than this is not a capture (tens of thousands of frames fit in a few MB).
pub const MAX_MANIFEST_BYTES: u64 = 64 << 20;
/// Largest image side, and largest image, a capture may declare (4096 x 4096 depth pixels
/// decode to 100 MB; depth sensors give at most about 1 megapixel).
pub const MAX_IMAGE_SIDE: u32 = 8192;
pub const MAX_IMAGE_PIXELS: u64 = 4096 * 4096;

/// Pinhole intrinsics in pixels (OpenCV convention: x right, y down, z forward), as capture.json
/// records them; `synth::camera::PinholeCamera` is the renderer's camera: these plus a depth range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    pub width: u32,
    pub height: u32,
}

impl Intrinsics {
    /// Camera-space point of pixel (u, v) at depth z (metres).
    pub fn unproject(&self, u: f32, v: f32, z: f32) -> Vec3 {
        Vec3::new((u - self.cx) * z / self.fx, (v - self.cy) * z / self.fy, z)
    }

    fn validate(&self) -> Result<()> {
        let ok = |v: f32| v.is_finite() && v > 0.0;
        if !(ok(self.fx) && ok(self.fy)) {
            return Err(Error::invalid(format!(
                "intrinsics: focal lengths must be positive, got fx {} fy {}",
                self.fx, self.fy
            )));
        }
        if !(self.cx.is_finite() && self.cy.is_finite()) {
            return Err(Error::invalid("intrinsics: principal point is not finite"));
        }
        if self.width == 0
            || self.height == 0
            || self.width > MAX_IMAGE_SIDE
            || self.height > MAX_IMAGE_SIDE
            || self.width as u64 * self.height as u64 > MAX_IMAGE_PIXELS
        {
            return Err(Error::invalid(format!(
                "intrinsics: image size {}x{} is out of range",
                self.width, self.height
            )));
        }
        Ok(())
    }
}

/// One frame: files relative to the capture folder plus the body fitting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    pub depth: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask: Option<String>,
    /// 72 axis-angle values (SMPL joint order); `None` = the frame has no fitting.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "nullable_numbers"
    )]
    pub pose: Option<Vec<f32>>,
    #[serde(default, deserialize_with = "nullable_numbers_vec")]
    pub shape: Vec<f32>,
    #[serde(default)]
    pub translation: Option<[f32; 3]>,
    /// Row-major 4x4; identity when absent (the fitting is then in camera coordinates).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_to_world: Option<[f32; 16]>,
}

impl FrameRecord {
    /// The frame's fitting as body parameters (validated: finite, angles within 2 pi).
    pub fn params(&self) -> Result<BodyParams> {
        let pose = self
            .pose
            .as_ref()
            .ok_or_else(|| Error::invalid("the frame has no body fitting (no \"pose\")"))?;
        if pose.len() != 3 * NUM_JOINTS {
            return Err(Error::invalid(format!(
                "\"pose\" has {} values, expected 72 (24 joints x 3 axis-angle)",
                pose.len()
            )));
        }
        if let Some(i) = self.shape.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid(format!("\"shape\"[{i}] is not a finite number")));
        }
        let t = self.translation.unwrap_or([0.0; 3]);
        BodyParams::from_flat(pose, self.shape.clone(), Vec3::from_array(t))
    }

    pub fn camera_to_world(&self) -> Result<Mat4> {
        match self.camera_to_world {
            None => Ok(Mat4::IDENTITY),
            Some(m) => {
                if m.iter().any(|v| !v.is_finite()) {
                    return Err(Error::invalid("\"camera_to_world\" has a non-finite value"));
                }
                // Row-major in the file, column-major in glam.
                let mat = Mat4::from_cols_array(&m).transpose();
                let r = glam::Mat3::from_mat4(mat);
                if (r.determinant() - 1.0).abs() > 1e-3 || mat.row(3) != glam::Vec4::W {
                    return Err(Error::invalid(
                        "\"camera_to_world\" is not a rigid transform (rotation + translation, last row 0 0 0 1)",
                    ));
                }
                Ok(mat)
            }
        }
    }

    pub fn set_camera_to_world(&mut self, m: Mat4) {
        self.camera_to_world = Some(m.transpose().to_cols_array());
    }
}

/// JSON has no NaN: tools write `null` for it. Read `null` as NaN so that the frame, not the
/// whole manifest, is refused, with a message naming the value.
fn nullable_numbers<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<Vec<f32>>, D::Error> {
    let v: Option<Vec<Option<f32>>> = Deserialize::deserialize(d)?;
    Ok(v.map(|v| v.into_iter().map(|x| x.unwrap_or(f32::NAN)).collect()))
}

fn nullable_numbers_vec<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Vec<f32>, D::Error> {
    Ok(nullable_numbers(d)?.unwrap_or_default())
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaptureManifest {
    pub format: String,
    pub version: u32,
    pub intrinsics: Intrinsics,
    /// Depth PNG units per metre (1000 = millimetres, 5000 = TUM).
    pub depth_scale: f32,
    /// The body model of the fittings: `"open_body"` or `{"smpl": PATH}`.
    #[serde(default)]
    pub body_model: BodyModelRef,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fps: Option<f32>,
    pub frames: Vec<FrameRecord>,
}

/// Which body model the fittings' pose and shape coefficients belong to.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum BodyModelRef {
    /// The embedded open body (`"open_body"`, the default).
    #[default]
    OpenBody,
    /// The user's own SMPL-family `.npz` (`{"smpl": PATH}`), relative to the capture folder or
    /// absolute. A plain path string is read the same way (captures written before the object).
    Smpl(PathBuf),
}

impl BodyModelRef {
    /// The model file, resolved against the capture folder.
    pub fn resolve(&self, capture_dir: &Path) -> Option<PathBuf> {
        match self {
            BodyModelRef::OpenBody => None,
            BodyModelRef::Smpl(p) => {
                Some(if p.is_absolute() { p.clone() } else { capture_dir.join(p) })
            }
        }
    }
}

impl Serialize for BodyModelRef {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            BodyModelRef::OpenBody => s.serialize_str("open_body"),
            BodyModelRef::Smpl(p) => {
                use serde::ser::SerializeMap;
                let mut m = s.serialize_map(Some(1))?;
                m.serialize_entry("smpl", p)?;
                m.end()
            }
        }
    }
}

impl<'de> Deserialize<'de> for BodyModelRef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Name(String),
            Model { smpl: PathBuf },
        }
        let raw = Raw::deserialize(d).map_err(|_| {
            serde::de::Error::custom(
                "\"body_model\" must be \"open_body\" or {\"smpl\": \"path/to/model.npz\"}",
            )
        })?;
        Ok(match raw {
            Raw::Name(n) if n.is_empty() || n == "open_body" => BodyModelRef::OpenBody,
            Raw::Name(path) => BodyModelRef::Smpl(path.into()),
            Raw::Model { smpl } => BodyModelRef::Smpl(smpl),
        })
    }
}

impl CaptureManifest {
    pub fn new(intrinsics: Intrinsics, depth_scale: f32) -> Self {
        CaptureManifest {
            format: FORMAT_NAME.into(),
            version: FORMAT_VERSION,
            intrinsics,
            depth_scale,
            body_model: BodyModelRef::OpenBody,
            fps: None,
            frames: Vec::new(),
        }
    }

    /// Path of the manifest inside a capture folder (accepts the folder or the file).
    pub fn path_in(dir_or_file: &Path) -> PathBuf {
        if dir_or_file.is_dir() {
            dir_or_file.join(MANIFEST_FILE)
        } else {
            dir_or_file.to_path_buf()
        }
    }

    /// Load and validate the header (frames are checked one by one when opened).
    pub fn load(dir_or_file: impl AsRef<Path>) -> Result<Self> {
        let path = Self::path_in(dir_or_file.as_ref());
        let size = std::fs::metadata(&path).map_err(|e| Error::io(&path, e))?.len();
        if size > MAX_MANIFEST_BYTES {
            return Err(Error::file(
                &path,
                format!(
                    "{size} bytes: too large for a capture manifest (at most {MAX_MANIFEST_BYTES})"
                ),
            ));
        }
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        let manifest: CaptureManifest = serde_json::from_str(&text)
            .map_err(|e| Error::file(&path, format!("not a valid capture manifest: {e}")))?;
        manifest.validate().map_err(|e| e.in_file(&path))?;
        Ok(manifest)
    }

    pub fn validate(&self) -> Result<()> {
        if self.format != FORMAT_NAME {
            return Err(Error::invalid(format!(
                "\"format\" is {:?}, expected {FORMAT_NAME:?}",
                self.format
            )));
        }
        if self.version != FORMAT_VERSION {
            return Err(Error::invalid(format!(
                "capture format version {} is not supported (this build reads {FORMAT_VERSION})",
                self.version
            )));
        }
        self.intrinsics.validate()?;
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0) {
            return Err(Error::invalid(format!(
                "\"depth_scale\" must be positive (PNG units per metre), got {}",
                self.depth_scale
            )));
        }
        if let Some(fps) = self.fps
            && !(crate::motion::MIN_FPS..=crate::motion::MAX_FPS).contains(&fps)
        {
            return Err(Error::invalid(format!(
                "\"fps\" {fps} is not a plausible frame rate ({} to {})",
                crate::motion::MIN_FPS,
                crate::motion::MAX_FPS
            )));
        }
        if self.frames.is_empty() {
            return Err(Error::invalid("the capture has no frames"));
        }
        Ok(())
    }

    /// Write `capture.json` atomically into `dir`.
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<()> {
        self.validate()?;
        let path = dir.as_ref().join(MANIFEST_FILE);
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::write_bytes_atomic(&path, text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn intr() -> Intrinsics {
        Intrinsics { fx: 250.0, fy: 250.0, cx: 125.0, cy: 125.0, width: 250, height: 250 }
    }

    #[test]
    fn camera_to_world_round_trips_row_major() {
        let m = Mat4::from_rotation_y(0.7) * Mat4::from_translation(Vec3::new(0.1, 0.2, 2.0));
        let mut f = FrameRecord {
            depth: "d.png".into(),
            mask: None,
            pose: None,
            shape: vec![],
            translation: None,
            camera_to_world: None,
        };
        f.set_camera_to_world(m);
        assert!(f.camera_to_world().unwrap().abs_diff_eq(m, 1e-6));
        // Row-major: the translation sits in elements 3, 7, 11.
        let raw = f.camera_to_world.unwrap();
        assert!((raw[3] - m.w_axis.x).abs() < 1e-6 && (raw[11] - m.w_axis.z).abs() < 1e-6);
    }

    #[test]
    fn bad_header_values_are_named() {
        let mut m = CaptureManifest::new(intr(), 0.0);
        m.frames.push(FrameRecord {
            depth: "d.png".into(),
            mask: None,
            pose: None,
            shape: vec![],
            translation: None,
            camera_to_world: None,
        });
        assert!(m.validate().unwrap_err().to_string().contains("depth_scale"));
        m.depth_scale = 1000.0;
        m.intrinsics.fx = -1.0;
        assert!(m.validate().unwrap_err().to_string().contains("focal"));
    }

    #[test]
    fn body_model_reads_the_name_the_object_and_a_plain_path() {
        let read = |v: &str| serde_json::from_str::<BodyModelRef>(v);
        assert_eq!(read(r#""open_body""#).unwrap(), BodyModelRef::OpenBody);
        assert_eq!(
            read(r#"{"smpl": "models/SMPL_NEUTRAL.npz"}"#).unwrap(),
            BodyModelRef::Smpl("models/SMPL_NEUTRAL.npz".into())
        );
        assert_eq!(read(r#""my.npz""#).unwrap(), BodyModelRef::Smpl("my.npz".into()));
        assert!(read(r#"{"smplx": "a.npz"}"#).unwrap_err().to_string().contains("open_body"));
        let m = BodyModelRef::Smpl("/abs/m.npz".into());
        assert_eq!(serde_json::to_string(&m).unwrap(), r#"{"smpl":"/abs/m.npz"}"#);
        assert_eq!(m.resolve(Path::new("/cap")), Some(PathBuf::from("/abs/m.npz")));
        assert_eq!(
            BodyModelRef::Smpl("m.npz".into()).resolve(Path::new("/cap")),
            Some(PathBuf::from("/cap/m.npz"))
        );
    }

    #[test]
    fn frame_without_fitting_or_with_nan_is_refused() {
        let mut f = FrameRecord {
            depth: "d.png".into(),
            mask: None,
            pose: None,
            shape: vec![],
            translation: None,
            camera_to_world: None,
        };
        assert!(f.params().unwrap_err().to_string().contains("no body fitting"));
        let mut pose = vec![0.0; 72];
        pose[5] = f32::NAN;
        f.pose = Some(pose);
        assert!(f.params().is_err());
        f.pose = Some(vec![0.0; 69]);
        assert!(f.params().unwrap_err().to_string().contains("72"));
    }
}
