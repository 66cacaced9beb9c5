//! Retargeting BVH motion capture to the 24-joint SMPL skeleton by joint names.
//!
//! Convention (docs/motion-import.md):
//! - Each SMPL joint takes the *world* rotation of the BVH joint mapped to it, measured from the
//!   BVH's rest pose (all channels zero), times a rest correction: the smallest rotation that
//!   turns the SMPL rest bone (joint to its child) onto the BVH rest bone. A BVH in the SMPL
//!   body's T-pose has no correction, so a joint's channel rotation comes out unchanged on the
//!   mapped SMPL joint; an A-pose rest is corrected so the posed bones point where the BVH's do.
//!   SMPL joints with no BVH joint keep their parent's world rotation (local identity); BVH
//!   joints with no SMPL joint (CMU's Neck1, fingers) still rotate their children.
//! - The file's world is turned to the studio's (Y up, facing +Z): `up: "z"` in a mapping
//!   file for Z-up exports, then a turn about Y that puts the BVH's left hip on the body's left.
//! - Units: metres per file unit from the mapping file's `scale`, otherwise guessed from the
//!   rest skeleton's height (m, cm, mm, inches or CMU's ASF units, whichever gives a height
//!   nearest 1.6 m). Root translation is kept in metres: `trans` = root position minus the
//!   rest skeleton's hips height above the floor (y = 0), so a standing frame stands on the
//!   floor and every displacement of the root is the file's.

use super::bvh::BvhFile;
use super::clip::MotionClip;
use crate::body::{BodyModel, BodyParams, JOINT_NAMES, NUM_JOINTS, SMPL_PARENTS};
use crate::error::{Error, Result};
use glam::{Mat3, Quat, Vec3};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Known skeletons: (profile, [(normalised BVH joint name, SMPL joint)]). Names are compared
/// after [`normalise_name`]; the profile matching the most joints of a file is used.
pub const PROFILES: [(&str, &[(&str, usize)]); 5] = [
    (
        "mixamo",
        &[
            ("hips", 0),
            ("leftupleg", 1),
            ("rightupleg", 2),
            ("spine", 3),
            ("leftleg", 4),
            ("rightleg", 5),
            ("spine1", 6),
            ("leftfoot", 7),
            ("rightfoot", 8),
            ("spine2", 9),
            ("lefttoebase", 10),
            ("righttoebase", 11),
            ("neck", 12),
            ("leftshoulder", 13),
            ("rightshoulder", 14),
            ("head", 15),
            ("leftarm", 16),
            ("rightarm", 17),
            ("leftforearm", 18),
            ("rightforearm", 19),
            ("lefthand", 20),
            ("righthand", 21),
            ("lefthandmiddle1", 22),
            ("righthandmiddle1", 23),
        ],
    ),
    (
        "cmu",
        &[
            ("hips", 0),
            ("leftupleg", 1),
            ("rightupleg", 2),
            ("lowerback", 3),
            ("leftleg", 4),
            ("rightleg", 5),
            ("spine", 6),
            ("leftfoot", 7),
            ("rightfoot", 8),
            ("spine1", 9),
            ("lefttoebase", 10),
            ("righttoebase", 11),
            ("neck", 12),
            ("leftshoulder", 13),
            ("rightshoulder", 14),
            ("head", 15),
            ("leftarm", 16),
            ("rightarm", 17),
            ("leftforearm", 18),
            ("rightforearm", 19),
            ("lefthand", 20),
            ("righthand", 21),
            ("leftfingerbase", 22),
            ("rightfingerbase", 23),
        ],
    ),
    // Blender's human metarig (and Rigify's DEF- bones, the prefix is dropped).
    (
        "blender",
        &[
            ("spine", 0),
            ("thighl", 1),
            ("thighr", 2),
            ("spine001", 3),
            ("shinl", 4),
            ("shinr", 5),
            ("spine002", 6),
            ("footl", 7),
            ("footr", 8),
            ("spine003", 9),
            ("toel", 10),
            ("toer", 11),
            ("spine004", 12),
            ("shoulderl", 13),
            ("shoulderr", 14),
            ("spine006", 15),
            ("upperarml", 16),
            ("upperarmr", 17),
            ("forearml", 18),
            ("forearmr", 19),
            ("handl", 20),
            ("handr", 21),
        ],
    ),
    // Unreal-style names, common in Blender exports of game rigs.
    (
        "unreal",
        &[
            ("pelvis", 0),
            ("thighl", 1),
            ("thighr", 2),
            ("spine01", 3),
            ("calfl", 4),
            ("calfr", 5),
            ("spine02", 6),
            ("footl", 7),
            ("footr", 8),
            ("spine03", 9),
            ("balll", 10),
            ("ballr", 11),
            ("neck01", 12),
            ("claviclel", 13),
            ("clavicler", 14),
            ("head", 15),
            ("upperarml", 16),
            ("upperarmr", 17),
            ("lowerarml", 18),
            ("lowerarmr", 19),
            ("handl", 20),
            ("handr", 21),
        ],
    ),
    // SMPL's own names (left_hip or L_Hip), as SMPL-to-BVH converters write them.
    (
        "smpl",
        &[
            ("pelvis", 0),
            ("lefthip", 1),
            ("lhip", 1),
            ("righthip", 2),
            ("rhip", 2),
            ("spine1", 3),
            ("leftknee", 4),
            ("lknee", 4),
            ("rightknee", 5),
            ("rknee", 5),
            ("spine2", 6),
            ("leftankle", 7),
            ("lankle", 7),
            ("rightankle", 8),
            ("rankle", 8),
            ("spine3", 9),
            ("leftfoot", 10),
            ("lfoot", 10),
            ("rightfoot", 11),
            ("rfoot", 11),
            ("neck", 12),
            ("leftcollar", 13),
            ("lcollar", 13),
            ("rightcollar", 14),
            ("rcollar", 14),
            ("head", 15),
            ("leftshoulder", 16),
            ("lshoulder", 16),
            ("rightshoulder", 17),
            ("rshoulder", 17),
            ("leftelbow", 18),
            ("lelbow", 18),
            ("rightelbow", 19),
            ("relbow", 19),
            ("leftwrist", 20),
            ("lwrist", 20),
            ("rightwrist", 21),
            ("rwrist", 21),
            ("lefthand", 22),
            ("lhand", 22),
            ("righthand", 23),
            ("rhand", 23),
        ],
    ),
];

/// The SMPL child whose direction defines each joint's bone for the rest correction.
const BONE_CHILD: [Option<usize>; NUM_JOINTS] = [
    None,
    Some(4),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(9),
    Some(10),
    Some(11),
    Some(12),
    None,
    None,
    Some(15),
    Some(16),
    Some(17),
    None,
    Some(18),
    Some(19),
    Some(20),
    Some(21),
    Some(22),
    Some(23),
    None,
    None,
];

/// Lower case, without a namespace (`mixamorig:`), Rigify's `DEF-` and separators.
pub fn normalise_name(name: &str) -> String {
    let base = name.rsplit(':').next().unwrap_or(name).to_ascii_lowercase();
    let base = base.strip_prefix("def-").unwrap_or(&base);
    base.chars().filter(|c| !matches!(c, ' ' | '_' | '-' | '.')).collect()
}

/// Which SMPL joint each BVH joint drives, and how to read the file's world.
#[derive(Debug, Clone, PartialEq)]
pub struct JointMap {
    /// The profile used, or the mapping file.
    pub source: String,
    /// BVH joint index of each SMPL joint.
    pub bvh_of: [Option<usize>; NUM_JOINTS],
    /// Metres per file unit; `None` = guess from the skeleton's height.
    pub scale: Option<f32>,
    pub z_up: bool,
}

/// A mapping file for skeletons no profile knows:
/// `{"joints": {"BVH name": "smpl_joint_name", ...}, "scale": 0.01, "up": "y"}`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MappingFile {
    pub joints: BTreeMap<String, String>,
    #[serde(default)]
    pub scale: Option<f32>,
    #[serde(default)]
    pub up: Option<String>,
}

impl JointMap {
    /// The known profile that matches the most joint names of `bvh`.
    pub fn by_names(bvh: &BvhFile) -> Result<JointMap> {
        let names: Vec<String> = bvh.joints.iter().map(|j| normalise_name(&j.name)).collect();
        let mut best: Option<(usize, JointMap)> = None;
        for (profile, table) in PROFILES {
            let mut bvh_of = [None; NUM_JOINTS];
            for (name, smpl) in table {
                if bvh_of[*smpl].is_none() {
                    bvh_of[*smpl] = names.iter().position(|n| n == name);
                }
            }
            let count = bvh_of.iter().flatten().count();
            if bvh_of[0].is_some() && best.as_ref().is_none_or(|(c, _)| count > *c) {
                best = Some((
                    count,
                    JointMap { source: profile.to_string(), bvh_of, scale: None, z_up: false },
                ));
            }
        }
        match best {
            Some((count, map)) if count >= 6 => Ok(map),
            _ => Err(Error::invalid(format!(
                "the skeleton's joint names ({}) match no known skeleton (CMU, Mixamo, Blender, Unreal, SMPL): \
                 write a mapping file (docs/motion-import.md)",
                bvh.joints.iter().take(6).map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ")
            ))),
        }
    }

    /// A mapping file's joints (exact BVH names) and settings.
    pub fn from_file(path: &Path, bvh: &BvhFile) -> Result<JointMap> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let file: MappingFile = serde_json::from_str(&text)
            .map_err(|e| Error::file(path, format!("not a valid BVH mapping file: {e}")))?;
        let mut bvh_of = [None; NUM_JOINTS];
        for (bvh_name, smpl_name) in &file.joints {
            let smpl = JOINT_NAMES.iter().position(|n| n == smpl_name).ok_or_else(|| {
                Error::file(
                    path,
                    format!(
                        "'{smpl_name}' is not an SMPL joint (use one of {})",
                        JOINT_NAMES.join(", ")
                    ),
                )
            })?;
            let b = bvh.joint_index(bvh_name).ok_or_else(|| {
                Error::file(path, format!("the BVH file has no joint '{bvh_name}'"))
            })?;
            if bvh_of[smpl].replace(b).is_some() {
                return Err(Error::file(path, format!("SMPL joint '{smpl_name}' is mapped twice")));
            }
        }
        if bvh_of[0].is_none() {
            return Err(Error::file(path, "no BVH joint is mapped to 'pelvis' (the root)"));
        }
        let z_up = match file.up.as_deref().map(str::to_ascii_lowercase).as_deref() {
            None | Some("y") => false,
            Some("z") => true,
            Some(other) => {
                return Err(Error::file(path, format!("\"up\" is '{other}': use \"y\" or \"z\"")));
            }
        };
        if let Some(s) = file.scale.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(Error::file(
                path,
                format!("\"scale\" {s} must be positive (metres per file unit)"),
            ));
        }
        Ok(JointMap { source: path.display().to_string(), bvh_of, scale: file.scale, z_up })
    }
}

/// The mapping file used for `clip.bvh`: `clip.map.json` beside it, else `bvh-map.json` in
/// its folder.
pub fn mapping_file_for(bvh_path: &Path) -> Option<PathBuf> {
    let own = bvh_path.with_extension("map.json");
    let folder = bvh_path.parent().unwrap_or(Path::new(".")).join("bvh-map.json");
    [own, folder].into_iter().find(|p| p.is_file())
}

/// Metres per file unit: the candidate that makes the rest skeleton's height nearest 1.6 m.
pub fn guess_scale(height: f32) -> (f32, &'static str) {
    const UNITS: [(f32, &str); 5] = [
        (1.0, "m"),
        (0.01, "cm"),
        (0.001, "mm"),
        (0.0254, "inches"),
        (0.0254 / 0.45, "CMU ASF units"),
    ];
    let off = |s: f32| (s * height / 1.6).ln().abs();
    UNITS.into_iter().min_by(|a, b| off(a.0).total_cmp(&off(b.0))).expect("non-empty")
}

/// Load a BVH file as a clip for the open body (name = file stem), with its mapping file if
/// there is one.
pub fn load_bvh_clip(path: &Path) -> Result<MotionClip> {
    let bvh = BvhFile::load(path)?;
    let map = match mapping_file_for(path) {
        Some(m) => JointMap::from_file(&m, &bvh)?,
        None => JointMap::by_names(&bvh).map_err(|e| e.in_file(path))?,
    };
    let name =
        path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "bvh".into());
    retarget(&bvh, &map, crate::body::open_body_ref(), &name).map_err(|e| e.in_file(path))
}

/// Retarget every frame of `bvh` onto `body`'s skeleton (its rest shape, no betas).
pub fn retarget(bvh: &BvhFile, map: &JointMap, body: &BodyModel, name: &str) -> Result<MotionClip> {
    // The file's world to the studio's: Z up to Y up, then the facing turn (below).
    let mut world =
        if map.z_up { Mat3::from_rotation_x(-std::f32::consts::FRAC_PI_2) } else { Mat3::IDENTITY };
    let rest: Vec<Vec3> = bvh.rest_positions().iter().map(|p| world * *p).collect();
    let ends: Vec<Vec3> = bvh.rest_end_sites().iter().map(|p| world * *p).collect();
    let (lo, hi) = rest
        .iter()
        .chain(&ends)
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)));
    let scale = match map.scale {
        Some(s) => s,
        None if hi - lo > 0.0 => guess_scale(hi - lo).0,
        None => {
            return Err(Error::invalid(
                "the rest skeleton has no height: cannot tell its units (give \"scale\" in a mapping file)",
            ));
        }
    };
    let smpl_rest = body.rest_joints(&[]);
    if let (Some(l), Some(r)) = (map.bvh_of[1], map.bvh_of[2]) {
        let flat = |v: Vec3| Vec3::new(v.x, 0.0, v.z).normalize_or_zero();
        let (from, to) = (flat(rest[l] - rest[r]), flat(smpl_rest[1] - smpl_rest[2]));
        if from != Vec3::ZERO && to != Vec3::ZERO {
            // About Y even when the two point opposite ways (a file facing -Z).
            world = Mat3::from_rotation_y(from.cross(to).y.atan2(from.dot(to))) * world;
        }
    }
    let rest: Vec<Vec3> = bvh.rest_positions().iter().map(|p| world * *p * scale).collect();
    // Rest correction of each mapped joint with a mapped bone child.
    let mut correction = [Mat3::IDENTITY; NUM_JOINTS];
    for j in 1..NUM_JOINTS {
        let (Some(b), Some(c)) = (map.bvh_of[j], BONE_CHILD[j]) else { continue };
        let Some(bc) = map.bvh_of[c] else { continue };
        let (ds, db) = (
            (smpl_rest[c] - smpl_rest[j]).normalize_or_zero(),
            (rest[bc] - rest[b]).normalize_or_zero(),
        );
        if ds != Vec3::ZERO && db != Vec3::ZERO {
            correction[j] = Mat3::from_quat(Quat::from_rotation_arc(ds, db));
        }
    }
    let root =
        map.bvh_of[0].ok_or_else(|| Error::invalid("no BVH joint drives the SMPL pelvis"))?;
    // The rest skeleton's hips height above its lowest point: a standing frame's root height.
    let standing = (rest[root].y - lo * scale).max(0.0);
    let world_t = world.transpose();
    let mut frames = Vec::with_capacity(bvh.frames.len());
    for f in 0..bvh.frames.len() {
        let (rot, pos) = bvh.pose(f).global(&bvh.joints);
        let mut global = [Mat3::IDENTITY; NUM_JOINTS];
        for j in 0..NUM_JOINTS {
            global[j] = match map.bvh_of[j] {
                Some(b) => world * rot[b] * world_t * correction[j],
                None => global[SMPL_PARENTS[j].max(0) as usize],
            };
        }
        let mut pose = [Vec3::ZERO; NUM_JOINTS];
        for j in 0..NUM_JOINTS {
            let local = match SMPL_PARENTS[j] {
                -1 => global[j],
                p => global[p as usize].transpose() * global[j],
            };
            let mut q = Quat::from_mat3(&local).normalize();
            if q.w < 0.0 {
                q = -q;
            }
            pose[j] = q.to_scaled_axis();
        }
        let p = world * pos[root] * scale;
        let trans = Vec3::new(p.x, p.y - standing, p.z);
        let params = BodyParams { pose, betas: Vec::new(), trans };
        params.validate().map_err(|e| Error::invalid(format!("frame {f}: {e}")))?;
        frames.push(params);
    }
    let clip = MotionClip::new(name, bvh.fps(), frames);
    clip.validate()?;
    Ok(clip)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_normalise_across_exporters() {
        assert_eq!(normalise_name("mixamorig:LeftUpLeg"), "leftupleg");
        assert_eq!(normalise_name("DEF-thigh.L"), "thighl");
        assert_eq!(normalise_name("spine.001"), "spine001");
        assert_eq!(normalise_name("L_Hip"), "lhip");
    }

    #[test]
    fn units_are_guessed_from_the_height() {
        assert_eq!(guess_scale(1.55).1, "m");
        assert_eq!(guess_scale(170.0).1, "cm");
        assert_eq!(guess_scale(66.0).1, "inches");
        assert_eq!(guess_scale(29.0).1, "CMU ASF units");
    }
}
